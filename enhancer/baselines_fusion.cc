// Underwater enhancement by fusion (Ancuti, Ancuti, Haber, Bekaert, CVPR 2012). See
// enhancer/baselines.h and docs/methods-baselines.md.
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "enhancer/baselines.h"
#include "enhancer/baselines_common.h"
#include "scenes/error.h"

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

cv::Mat ExpandChannels(const cv::Mat& weight, int channels) {
  if (channels == 1) return weight;
  cv::Mat out;
  cv::merge(std::vector<cv::Mat>(channels, weight), out);
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
  const cv::Mat luminance = baselines_internal::Luminance(input);
  cv::Mat laplacian;
  cv::Laplacian(luminance, laplacian, CV_32F, 1, 1.0, 0.0, cv::BORDER_REFLECT_101);
  const cv::Mat laplacian_contrast = cv::abs(laplacian);
  const cv::Mat local_contrast = cv::abs(luminance - Binomial5(luminance));
  const cv::Mat saliency = Saliency(input, luminance);
  cv::Mat exposedness;
  const cv::Mat centred = luminance - 0.5;
  cv::exp(centred.mul(centred) * (-1.0 / (2.0 * exposedness_sigma * exposedness_sigma)),
          exposedness);
  return laplacian_contrast + local_contrast + saliency + exposedness;
}

cv::Mat PyramidBlend(const std::vector<cv::Mat>& inputs, const std::vector<cv::Mat>& weights,
                     int levels) {
  CV_Assert(!inputs.empty() && inputs.size() == weights.size() && levels >= 1);
  const cv::Size size = inputs[0].size();
  const int channels = inputs[0].channels();
  const int max_levels =
      1 + static_cast<int>(
              std::floor(std::log2(static_cast<double>(std::min(size.width, size.height)))));
  const int used = std::min(levels, max_levels);
  std::vector<cv::Mat> blended(used);
  for (size_t k = 0; k < inputs.size(); ++k) {
    CV_Assert(inputs[k].size() == size && inputs[k].type() == inputs[0].type());
    CV_Assert(weights[k].size() == size && weights[k].type() == CV_32FC1);
    cv::Mat gaussian = inputs[k];
    cv::Mat weight = weights[k];
    for (int level = 0; level < used; ++level) {
      cv::Mat band;
      cv::Mat next_gaussian;
      cv::Mat next_weight;
      if (level + 1 < used) {
        cv::pyrDown(gaussian, next_gaussian);
        cv::Mat up;
        cv::pyrUp(next_gaussian, up, gaussian.size());
        band = gaussian - up;
        cv::pyrDown(weight, next_weight);
      } else {
        band = gaussian;
      }
      cv::Mat term = band.mul(ExpandChannels(weight, channels));
      if (blended[level].empty()) {
        blended[level] = term;
      } else {
        blended[level] += term;
      }
      gaussian = next_gaussian;
      weight = next_weight;
    }
  }
  cv::Mat result = blended[used - 1];
  for (int level = used - 2; level >= 0; --level) {
    cv::Mat up;
    cv::pyrUp(result, up, blended[level].size());
    result = up + blended[level];
  }
  return result;
}

FusionResult FusionDetailed(const FusionOptions& options, const cv::Mat& image) {
  baselines_internal::ValidateImage(image, "fusion");
  ThrowIfInvalid(options, "fusion");
  FusionResult result;
  // Ancuti 2012 §3.1: input 1 is the white-balanced image, input 2 its contrast-enhanced version
  // (the paper also denoises it with a bilateral filter; we leave that out, see the docs).
  cv::Mat balanced = (image.channels() == 3 && options.white_balance)
                         ? GrayWorld(image, options.max_white_balance_gain)
                         : image.clone();
  cv::Mat enhanced = ClaheBaseline(options.clahe, balanced);
  result.inputs = {balanced, enhanced};

  // Ancuti 2012 §3.2: per-input weight = sum of the four measures, normalised over the inputs.
  // δ keeps the normalisation defined where every weight underflows (a tiny exposedness σ).
  constexpr float kDelta = 1e-12f;
  std::vector<cv::Mat> raw;
  for (const cv::Mat& input : result.inputs) {
    raw.push_back(FusionWeight(input, options.exposedness_sigma) + kDelta);
  }
  cv::Mat total = raw[0] + raw[1];
  for (const cv::Mat& w : raw) {
    cv::Mat normalised;
    cv::divide(w, total, normalised);
    result.weights.push_back(normalised);
  }
  result.image = PyramidBlend(result.inputs, result.weights, options.levels);
  baselines_internal::ClampUnit(result.image);
  return result;
}

cv::Mat Fusion(const FusionOptions& options, const cv::Mat& image) {
  return FusionDetailed(options, image).image;
}

}  // namespace turbid
