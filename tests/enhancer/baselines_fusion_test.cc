#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <random>
#include <sstream>

#include "enhancer/baselines/clahe.h"
#include "enhancer/baselines/fusion.h"
#include "enhancer/baselines/common.h"
#include "scenes/builtin.h"
#include "core/error.h"
#include "scenes/image_io.h"
#include "simulator/render.h"
#include "tests/enhancer/baselines_test_images.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {

// ---------------------------------------------------------------------------------------------
// The pre-optimisation implementation of fusion (enhancer/baselines_fusion.cc at commit 6722196:
// one OpenCV call per step, a temporary per call), kept as the reference for today's.
namespace reference {

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

cv::Mat ReferenceFusionWeight(const cv::Mat& input, double exposedness_sigma) {
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

cv::Mat ReferencePyramidBlend(const std::vector<cv::Mat>& inputs,
                              const std::vector<cv::Mat>& weights, int levels) {
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

FusionResult ReferenceFusion(const FusionOptions& options, const cv::Mat& image) {
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
    raw.push_back(ReferenceFusionWeight(input, options.exposedness_sigma) + kDelta);
  }
  cv::Mat total = raw[0] + raw[1];
  for (const cv::Mat& w : raw) {
    cv::Mat normalised;
    cv::divide(w, total, normalised);
    result.weights.push_back(normalised);
  }
  result.image = ReferencePyramidBlend(result.inputs, result.weights, options.levels);
  baselines_internal::ClampUnit(result.image);
  return result;
}

}  // namespace reference

using reference::ReferenceFusion;
using reference::ReferenceFusionWeight;
using reference::ReferencePyramidBlend;

cv::Mat RandomImage(int rows, int cols, int channels, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  cv::Mat image(rows, cols, CV_32FC(channels));
  float* p = image.ptr<float>();
  for (size_t i = 0; i < image.total() * channels; ++i) p[i] = u(rng);
  return image;
}

TEST(BaselinesFusion, DefaultsPassCheck) {
  std::string why;
  EXPECT_TRUE(FusionOptions{}.Check(&why)) << why;
  FusionOptions bad;
  bad.levels = 0;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("levels"), std::string::npos);
  bad = FusionOptions{};
  bad.clahe.tiles_x = 1;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("clahe"), std::string::npos);
  EXPECT_THROW(Fusion(bad, cv::Mat(3, 3, CV_32FC3, cv::Scalar::all(0.5))), Error);
}

// Known answer: when every input is the same image, any weights summing to 1 give it back (the
// Laplacian pyramid collapses exactly), whatever the number of levels.
TEST(BaselinesFusion, BlendOfAgreeingInputsIsTheInput) {
  for (int channels : {1, 3}) {
    const cv::Mat image = RandomImage(37, 50, channels, 11);
    const cv::Mat w0 = RandomImage(37, 50, 1, 12);
    const cv::Mat w1 = 1.0 - w0;
    for (int levels : {1, 3, 5, 12}) {
      const cv::Mat out = PyramidBlend({image, image}, {w0, w1}, levels);
      EXPECT_LT(cv::norm(out, image, cv::NORM_INF), 1e-5) << channels << " " << levels;
    }
  }
}

// One level is a plain per-pixel weighted sum (closed form).
TEST(BaselinesFusion, SingleLevelIsWeightedSum) {
  const cv::Mat a = RandomImage(9, 7, 3, 1);
  const cv::Mat b = RandomImage(9, 7, 3, 2);
  const cv::Mat w = RandomImage(9, 7, 1, 3);
  const cv::Mat out = PyramidBlend({a, b}, {w, 1.0 - w}, 1);
  for (int y = 0; y < 9; ++y) {
    for (int x = 0; x < 7; ++x) {
      const float wv = w.at<float>(y, x);
      const cv::Vec3f expected = a.at<cv::Vec3f>(y, x) * wv + b.at<cv::Vec3f>(y, x) * (1 - wv);
      const cv::Vec3f d = out.at<cv::Vec3f>(y, x) - expected;
      ASSERT_LT(std::sqrt(d.dot(d)), 1e-6);
    }
  }
}

TEST(BaselinesFusion, WeightsSumToOneAndInputsAreDerived) {
  BuiltinSceneOptions scene_options;
  scene_options.scale = 0.25;
  const cv::Mat clean = MakeBuiltinScene("seafloor", scene_options).image;
  const cv::Mat hazy = clean * 0.5 + cv::Scalar(0.35, 0.3, 0.05);  // blue-green cast
  const FusionResult result = FusionDetailed(FusionOptions{}, hazy);
  ASSERT_EQ(result.inputs.size(), 2u);
  ASSERT_EQ(result.weights.size(), 2u);
  const cv::Mat sum = result.weights[0] + result.weights[1];
  EXPECT_LT(cv::norm(sum, cv::Mat(sum.size(), CV_32FC1, cv::Scalar(1.0)), cv::NORM_INF), 1e-5);
  double lo, hi;
  cv::minMaxLoc(result.weights[0], &lo, &hi);
  EXPECT_GE(lo, 0.0);
  EXPECT_LE(hi, 1.0);
  // Gray-world balance equalises the channel means of input 1 (no gain hit the cap here).
  const cv::Scalar means = cv::mean(result.inputs[0]);
  EXPECT_NEAR(means[0], means[2], 0.02);
  EXPECT_NEAR(means[1], means[2], 0.02);
  // Input 2 has more contrast than input 1.
  cv::Scalar m0, s0, m1, s1;
  cv::meanStdDev(baselines_internal::Luminance(result.inputs[0]), m0, s0);
  cv::meanStdDev(baselines_internal::Luminance(result.inputs[1]), m1, s1);
  EXPECT_GT(s1[0], s0[0]);
}

// The weight terms on a flat image: no contrast, no saliency, exposedness only.
TEST(BaselinesFusion, WeightOfFlatImageIsExposedness) {
  const cv::Mat flat(6, 6, CV_32FC1, cv::Scalar(0.75));
  const cv::Mat w = FusionWeight(flat, 0.25);
  const double expected = std::exp(-(0.25 * 0.25) / (2 * 0.25 * 0.25));
  EXPECT_LT(cv::norm(w, cv::Mat(6, 6, CV_32FC1, cv::Scalar(expected)), cv::NORM_INF), 1e-6);
}

// ---------------------------------------------------------------------------------------------
// Today's implementation against the pre-optimisation one.

cv::Mat Hazy(int rows, int cols, int channels, uint32_t seed) {
  cv::Mat image = RandomImage(rows, cols, channels, seed);
  cv::GaussianBlur(image, image, cv::Size(5, 5), 1.5);  // some structure, not only noise
  return image * 0.5 + cv::Scalar::all(0.3);
}

TEST(BaselinesFusion, WeightMatchesPreOptimisationImplementation) {
  for (int channels : {1, 3}) {
    for (cv::Size size : {cv::Size(1, 1), cv::Size(3, 2), cv::Size(37, 29), cv::Size(64, 48)}) {
      const cv::Mat image = Hazy(size.height, size.width, channels, 5);
      for (double sigma : {0.25, 0.05}) {
        EXPECT_EQ(
            cv::norm(FusionWeight(image, sigma), ReferenceFusionWeight(image, sigma), cv::NORM_INF),
            0.0)
            << channels << " " << size << " " << sigma;
      }
    }
  }
}

// A view into a larger image gives what the same pixels give as an image of their own (the
// filters must not read the neighbours outside the view).
TEST(BaselinesFusion, ViewIntoLargerImageMatchesPreOptimisationImplementation) {
  for (int channels : {1, 3}) {
    const cv::Mat large = Hazy(90, 80, channels, 8);
    const cv::Mat view = large(cv::Rect(7, 11, 53, 61));
    EXPECT_EQ(cv::norm(Fusion(FusionOptions{}, view),
                       ReferenceFusion(FusionOptions{}, view.clone()).image, cv::NORM_INF),
              0.0);
    EXPECT_EQ(
        cv::norm(FusionWeight(view, 0.25), ReferenceFusionWeight(view.clone(), 0.25), cv::NORM_INF),
        0.0);
  }
}

TEST(BaselinesFusion, MatchesPreOptimisationImplementation) {
  for (int channels : {1, 3}) {
    for (cv::Size size : {cv::Size(1, 1), cv::Size(2, 3), cv::Size(17, 9), cv::Size(37, 29),
                          cv::Size(64, 48), cv::Size(101, 77), cv::Size(257, 301)}) {
      const cv::Mat image = Hazy(size.height, size.width, channels, 6);
      for (int levels : {1, 2, 5, 12}) {
        for (bool white_balance : {true, false}) {
          FusionOptions options;
          options.levels = levels;
          options.white_balance = white_balance;
          const FusionResult ours = FusionDetailed(options, image);
          const FusionResult reference = ReferenceFusion(options, image);
          std::ostringstream what;
          what << channels << " channels " << size << " levels " << levels << " wb "
               << white_balance;
          EXPECT_EQ(cv::norm(ours.image, reference.image, cv::NORM_INF), 0.0) << what.str();
          for (int k = 0; k < 2; ++k) {
            EXPECT_EQ(cv::norm(ours.inputs[k], reference.inputs[k], cv::NORM_INF), 0.0)
                << what.str();
            EXPECT_EQ(cv::norm(ours.weights[k], reference.weights[k], cv::NORM_INF), 0.0)
                << what.str();
          }
        }
      }
    }
  }
}

void ExpectFusionMatchesReference(const cv::Mat& image, const std::string& what) {
  const FusionResult ours = FusionDetailed(FusionOptions{}, image);
  const FusionResult reference = ReferenceFusion(FusionOptions{}, image);
  EXPECT_EQ(cv::norm(ours.image, reference.image, cv::NORM_INF), 0.0) << what;
  for (int k = 0; k < 2; ++k) {
    EXPECT_EQ(cv::norm(ours.weights[k], reference.weights[k], cv::NORM_INF), 0.0) << what;
  }
}

// The 1360x1024 gray render `turbid bench` times, and the real frames in $TURBID_DATA.
TEST(BaselinesFusion, MatchesPreOptimisationImplementationOnRender) {
  const Scene hull = MakeBuiltinScene("hull", BuiltinSceneOptions{});
  RenderOptions render;
  render.water.type = "3C";
  render.seed = 1;
  render.camera.encoding = CameraEncoding::kLinear;
  ExpectFusionMatchesReference(Render(render, hull).image, "hull render");
}

TEST(BaselinesFusion, MatchesPreOptimisationImplementationOnRealFrames) {
  TURBID_REQUIRE_DATA(data);
  for (const char* file : {"/uieb_waternet/616.png", "/euvp_funiegan/A/1.jpg",
                           "/subvo/images/frame_00_00_21.000.jpg"}) {
    const cv::Mat image = ReadImage(data + file);
    cv::Mat gray;
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
    ExpectFusionMatchesReference(image, std::string(file) + " colour");
    ExpectFusionMatchesReference(gray, std::string(file) + " gray");
  }
}

}  // namespace
}  // namespace turbid
