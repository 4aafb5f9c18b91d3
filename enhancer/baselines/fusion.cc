// Underwater enhancement by fusion (Ancuti, Ancuti, Haber, Bekaert, CVPR 2012). See
// enhancer/baselines/fusion.h and docs/methods-baselines.md.
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "enhancer/baselines/clahe.h"
#include "enhancer/baselines/fusion.h"
#include "enhancer/baselines/common.h"
#include "core/error.h"

namespace turbid {
namespace {

// Separable 5-tap binomial low-pass [1 4 6 4 1] / 16: Ancuti 2012 §3.2 use it (cut-off near
// π/2.75) for the local-contrast and saliency weights, after Achanta et al. CVPR 2009.
cv::Mat Binomial5(const cv::Mat& image) {
  const cv::Mat kernel =
      (cv::Mat_<float>(1, 5) << 1.f / 16, 4.f / 16, 6.f / 16, 4.f / 16, 1.f / 16);
  cv::Mat out;
  cv::sepFilter2D(image, out, CV_32F, kernel, kernel, cv::Point(-1, -1), 0, cv::BORDER_REFLECT_101);
  return out;
}

// Gray-world balance: each channel scaled so its mean equals the mean of the channel means, gains
// capped at max_gain; clamped to [0,1].
cv::Mat GrayWorld(const cv::Mat& image, double max_gain) {
  const cv::Scalar means = cv::mean(image);
  const double gray = (means[0] + means[1] + means[2]) / 3.0;
  cv::Scalar gains(1, 1, 1);
  for (int c = 0; c < 3; ++c) {
    gains[c] = means[c] > 0.0 ? std::min(gray / means[c], max_gain) : 1.0;
  }
  cv::Mat out;
  cv::multiply(image, gains, out);
  baselines_internal::ClampUnit(out);
  return out;
}

// Achanta et al. 2009 frequency-tuned saliency: distance between the image's mean colour and each
// blurred pixel, in CIELAB for colour (scaled by 1/100 so it is on the [0,1] scale of the other
// weights) and in luminance for gray.
cv::Mat Saliency(const cv::Mat& input, const cv::Mat& luminance) {
  if (input.channels() == 1) {
    const double mean = cv::mean(luminance)[0];
    return cv::abs(Binomial5(luminance) - mean);
  }
  cv::Mat lab;
  cv::cvtColor(input, lab, cv::COLOR_LBGR2Lab);
  const cv::Scalar mean = cv::mean(lab);
  const cv::Mat blurred = Binomial5(lab);
  cv::Mat out(input.size(), CV_32FC1);
  for (int y = 0; y < input.rows; ++y) {
    const cv::Vec3f* b = blurred.ptr<cv::Vec3f>(y);
    float* o = out.ptr<float>(y);
    for (int x = 0; x < input.cols; ++x) {
      const double dl = b[x][0] - mean[0];
      const double da = b[x][1] - mean[1];
      const double db = b[x][2] - mean[2];
      o[x] = static_cast<float>(std::sqrt(dl * dl + da * da + db * db) / 100.0);
    }
  }
  return out;
}

}  // namespace

bool FusionOptions::Check(std::string* why) const {
  auto fail = [why](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (levels < 1) return fail("levels must be >= 1");
  if (!(max_white_balance_gain >= 1.0) || !std::isfinite(max_white_balance_gain)) {
    return fail("max_white_balance_gain must be >= 1");
  }
  if (!(exposedness_sigma > 0.0) || !std::isfinite(exposedness_sigma)) {
    return fail("exposedness_sigma must be > 0");
  }
  std::string clahe_why;
  if (!clahe.Check(&clahe_why)) return fail("clahe: " + clahe_why);
  return true;
}

cv::Mat FusionWeight(const cv::Mat& input, double exposedness_sigma) {
  // The filters are OpenCV's as before, run on strips of rows (a strip of a larger image reads
  // its neighbours above and below from that image, so every value is as for the whole image);
  // the per-pixel sums run on each strip while it is in cache, with the same float operations
  // in the same order as before, so the weights are unchanged bit for bit.
  // A standalone luminance: a strip must find the image's own border where the image ends.
  const bool gray = input.channels() == 1;
  const cv::Mat luminance = !gray                 ? baselines_internal::Luminance(input)
                            : input.isSubmatrix() ? input.clone()
                                                  : input;
  const cv::Mat saliency = gray ? cv::Mat() : Saliency(input, luminance);
  const float mean = gray ? static_cast<float>(cv::mean(luminance)[0]) : 0.0f;
  // scale * a * b in double, as OpenCV's scaled product (a.mul(b) * scale) computes it.
  const double coefficient = -1.0 / (2.0 * exposedness_sigma * exposedness_sigma);
  cv::Mat weight(input.size(), CV_32FC1);
  cv::Mat argument(1, input.cols, CV_32FC1), exposedness(1, input.cols, CV_32FC1);
  cv::Mat laplacian, blurred;
  constexpr int kStrip = 32;
  for (int y0 = 0; y0 < input.rows; y0 += kStrip) {
    const cv::Mat strip = luminance.rowRange(y0, std::min(y0 + kStrip, input.rows));
    cv::Laplacian(strip, laplacian, CV_32F, 1, 1.0, 0.0, cv::BORDER_REFLECT_101);
    blurred = Binomial5(strip);
    for (int s = 0; s < strip.rows; ++s) {
      const int y = y0 + s;
      const float* l = luminance.ptr<float>(y);
      float* arg = argument.ptr<float>();
      for (int x = 0; x < input.cols; ++x) {
        const float centred = l[x] - 0.5f;
        arg[x] = static_cast<float>(coefficient * centred * centred);
      }
      cv::exp(argument, exposedness);
      const float* e = exposedness.ptr<float>();
      const float* lap = laplacian.ptr<float>(s);
      const float* b = blurred.ptr<float>(s);
      const float* sal = gray ? nullptr : saliency.ptr<float>(y);
      float* w = weight.ptr<float>(y);
      for (int x = 0; x < input.cols; ++x) {
        const float sl = gray ? std::fabs(b[x] - mean) : sal[x];
        w[x] = std::fabs(lap[x]) + std::fabs(l[x] - b[x]) + sl + e[x];
      }
    }
  }
  return weight;
}

namespace {

// blended = (gaussian - up) * weight, plus blended unless `first` (up empty: the band is the
// Gaussian level itself). The same float operations, in the same order, as forming the band and
// the product as images and adding them up.
void AccumulateBand(const cv::Mat& gaussian, const cv::Mat& up, const cv::Mat& weight,
                    cv::Mat& blended, bool first) {
  const int channels = gaussian.channels();
  const int cols = gaussian.cols;
  if (first) blended.create(gaussian.size(), gaussian.type());
  std::vector<float> band(static_cast<size_t>(cols) * channels);
  for (int y = 0; y < gaussian.rows; ++y) {
    const float* g = gaussian.ptr<float>(y);
    const float* w = weight.ptr<float>(y);
    float* b = blended.ptr<float>(y);
    float* d = band.data();
    if (up.empty()) {
      std::copy_n(g, cols * channels, d);
    } else {
      const float* u = up.ptr<float>(y);
      for (int i = 0; i < cols * channels; ++i) d[i] = g[i] - u[i];
    }
    if (channels == 1) {
      if (first) {
        for (int x = 0; x < cols; ++x) b[x] = d[x] * w[x];
      } else {
        for (int x = 0; x < cols; ++x) b[x] = b[x] + d[x] * w[x];
      }
    } else {
      for (int x = 0; x < cols; ++x) {
        for (int c = 0; c < channels; ++c) {
          const int i = x * channels + c;
          b[i] = first ? d[i] * w[x] : b[i] + d[i] * w[x];
        }
      }
    }
  }
}

// out = up + blended, optionally clamped to [0,1] (as ClampUnit: max with 0, then min with 1).
void AddLevel(const cv::Mat& up, const cv::Mat& blended, cv::Mat& out, bool clamp) {
  out.create(up.size(), up.type());
  const int n = up.cols * up.channels();
  for (int y = 0; y < up.rows; ++y) {
    const float* u = up.ptr<float>(y);
    const float* b = blended.ptr<float>(y);
    float* o = out.ptr<float>(y);
    for (int x = 0; x < n; ++x) {
      const float v = u[x] + b[x];
      o[x] = clamp ? std::min(std::max(v, 0.0f), 1.0f) : v;
    }
  }
}

// Rows [y0, y1) of cv::pyrUp(src, size), as a view into `work`: pyrUp of only the source rows
// they depend on (output rows 2i and 2i+1 read source rows i-1 .. i+1), with two rows of margin
// whose outputs (the only ones that see the cut as a border) are dropped. So the rows are those of
// the whole-image pyrUp, bit for bit, without a full-size buffer.
cv::Mat PyrUpRows(const cv::Mat& src, cv::Size size, int y0, int y1, cv::Mat& work) {
  const int sy0 = std::max(0, y0 / 2 - 2);
  const int sy1 = std::min(src.rows, (y1 + 1) / 2 + 2);
  cv::pyrUp(src.rowRange(sy0, sy1), work, cv::Size(size.width, 2 * (sy1 - sy0)));
  return work.rowRange(y0 - 2 * sy0, y1 - 2 * sy0);
}

// Rows per strip of the band and collapse steps (a strip's pyrUp stays in cache).
constexpr int kBlendStrip = 64;

cv::Mat Blend(const std::vector<cv::Mat>& inputs, const std::vector<cv::Mat>& weights, int levels,
              bool clamp) {
  CV_Assert(!inputs.empty() && inputs.size() == weights.size() && levels >= 1);
  const cv::Size size = inputs[0].size();
  const int max_levels =
      1 + static_cast<int>(
              std::floor(std::log2(static_cast<double>(std::min(size.width, size.height)))));
  const int used = std::min(levels, max_levels);
  std::vector<cv::Mat> blended(used);
  cv::Mat work;
  for (size_t k = 0; k < inputs.size(); ++k) {
    CV_Assert(inputs[k].size() == size && inputs[k].type() == inputs[0].type());
    CV_Assert(weights[k].size() == size && weights[k].type() == CV_32FC1);
    cv::Mat gaussian = inputs[k];
    cv::Mat weight = weights[k];
    for (int level = 0; level < used; ++level) {
      if (k == 0) blended[level].create(gaussian.size(), gaussian.type());
      cv::Mat next_gaussian;
      cv::Mat next_weight;
      if (level + 1 < used) {
        cv::pyrDown(gaussian, next_gaussian);
        for (int y0 = 0; y0 < gaussian.rows; y0 += kBlendStrip) {
          const int y1 = std::min(y0 + kBlendStrip, gaussian.rows);
          const cv::Mat up = PyrUpRows(next_gaussian, gaussian.size(), y0, y1, work);
          cv::Mat rows = blended[level].rowRange(y0, y1);
          AccumulateBand(gaussian.rowRange(y0, y1), up, weight.rowRange(y0, y1), rows, k == 0);
        }
        cv::pyrDown(weight, next_weight);
      } else {
        AccumulateBand(gaussian, cv::Mat(), weight, blended[level], k == 0);
      }
      gaussian = next_gaussian;
      weight = next_weight;
    }
  }
  cv::Mat result = blended[used - 1];
  if (used == 1 && clamp)
    AddLevel(cv::Mat::zeros(result.size(), result.type()), result, result, true);
  for (int level = used - 2; level >= 0; --level) {
    // Each level is written over its own blended image (read and written element by element).
    for (int y0 = 0; y0 < blended[level].rows; y0 += kBlendStrip) {
      const int y1 = std::min(y0 + kBlendStrip, blended[level].rows);
      const cv::Mat up = PyrUpRows(result, blended[level].size(), y0, y1, work);
      cv::Mat rows = blended[level].rowRange(y0, y1);
      AddLevel(up, rows, rows, clamp && level == 0);
    }
    result = blended[level];
  }
  return result;
}

}  // namespace

cv::Mat PyramidBlend(const std::vector<cv::Mat>& inputs, const std::vector<cv::Mat>& weights,
                     int levels) {
  return Blend(inputs, weights, levels, false);
}

FusionResult FusionDetailed(const FusionOptions& options, const cv::Mat& image) {
  baselines_internal::ValidateImage(image, "fusion");
  ThrowIfInvalid(options, "fusion");
  FusionResult result;
  // Ancuti 2012 §3.1: input 1 is the white-balanced image, input 2 its contrast-enhanced version
  // (the paper also denoises it with a bilateral filter; we leave that out, see the docs).
  // Without a balance, input 1 is the image itself (shared, not copied, unless it is a view into
  // a larger image).
  cv::Mat balanced = (image.channels() == 3 && options.white_balance)
                         ? GrayWorld(image, options.max_white_balance_gain)
                     : image.isSubmatrix() ? image.clone()
                                           : image;
  cv::Mat enhanced = ClaheBaseline(options.clahe, balanced);
  result.inputs = {balanced, enhanced};

  // Ancuti 2012 §3.2: per-input weight = sum of the four measures, normalised over the inputs.
  // δ keeps the normalisation defined where every weight underflows (a tiny exposedness σ).
  constexpr float kDelta = 1e-12f;
  cv::Mat w0 = FusionWeight(balanced, options.exposedness_sigma);
  cv::Mat w1 = FusionWeight(enhanced, options.exposedness_sigma);
  for (int y = 0; y < image.rows; ++y) {
    float* a = w0.ptr<float>(y);
    float* b = w1.ptr<float>(y);
    for (int x = 0; x < image.cols; ++x) {
      const float ra = a[x] + kDelta;
      const float rb = b[x] + kDelta;
      const float total = ra + rb;
      a[x] = ra / total;
      b[x] = rb / total;
    }
  }
  result.weights = {w0, w1};
  result.image = Blend(result.inputs, result.weights, options.levels, true);
  return result;
}

cv::Mat Fusion(const FusionOptions& options, const cv::Mat& image) {
  return FusionDetailed(options, image).image;
}

}  // namespace turbid
