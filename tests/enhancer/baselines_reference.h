// The pre-optimisation implementations (commit 6722196) of the steps that dcp, udcp and cap
// share, kept as references for the tests that check today's code gives the same values
// (tests/enhancer/baselines_dcp_test.cc, baselines_cap_test.cc), and the inputs they run on.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <numeric>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "tests/enhancer/baselines_test_images.h"

namespace turbid::baselines_reference {

inline cv::Mat MinFilter(const cv::Mat& gray, int size) {
  cv::Mat out;
  if (size <= 1) return gray.clone();
  const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(size, size));
  cv::erode(gray, out, kernel, cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  return out;
}

inline cv::Mat DarkChannel(const cv::Mat& image, int patch_size, bool skip_red) {
  cv::Mat channel_min;
  if (image.channels() == 1) {
    channel_min = image.clone();
  } else {
    std::vector<cv::Mat> planes;
    cv::split(image, planes);
    channel_min = cv::min(planes[0], planes[1]);
    if (!skip_red) channel_min = cv::min(channel_min, planes[2]);
  }
  return MinFilter(channel_min, patch_size);
}

inline cv::Point EstimateAirlight(const cv::Mat& image, const cv::Mat& prior, double fraction,
                                  cv::Vec3f* airlight) {
  const int total = static_cast<int>(prior.total());
  const int count = std::clamp(static_cast<int>(std::ceil(fraction * total)), 1, total);
  std::vector<int> order(total);
  std::iota(order.begin(), order.end(), 0);
  const float* p = prior.ptr<float>();
  auto brighter = [p](int a, int b) { return p[a] > p[b] || (p[a] == p[b] && a < b); };
  std::nth_element(order.begin(), order.begin() + (count - 1), order.end(), brighter);
  const int channels = image.channels();
  int best = -1;
  float best_sum = -1.0f;
  for (int i = 0; i < count; ++i) {
    const int index = order[i];
    const float* px = image.ptr<float>(index / image.cols) + (index % image.cols) * channels;
    float sum = 0.0f;
    for (int c = 0; c < channels; ++c) sum += px[c];
    if (sum > best_sum || (sum == best_sum && index < best)) {
      best_sum = sum;
      best = index;
    }
  }
  const cv::Point at(best % image.cols, best / image.cols);
  const float* px = image.ptr<float>(at.y) + at.x * channels;
  for (int c = 0; c < 3; ++c) (*airlight)[c] = px[channels == 3 ? c : 0];
  return at;
}

inline cv::Mat RecoverRadiance(const cv::Mat& image, const cv::Mat& transmission,
                               const cv::Vec3f& airlight, double t_min) {
  const int channels = image.channels();
  cv::Mat out(image.size(), image.type());
  for (int y = 0; y < image.rows; ++y) {
    const float* in = image.ptr<float>(y);
    const float* t = transmission.ptr<float>(y);
    float* o = out.ptr<float>(y);
    for (int x = 0; x < image.cols; ++x) {
      const float tt = std::max(t[x], static_cast<float>(t_min));
      for (int c = 0; c < channels; ++c) {
        const float a = airlight[c];
        const float j = (in[x * channels + c] - a) / tt + a;
        o[x * channels + c] = std::clamp(j, 0.0f, 1.0f);
      }
    }
  }
  return out;
}

inline void ClampUnit(cv::Mat& image) {
  cv::max(image, 0.0, image);
  cv::min(image, 1.0, image);
}

// max |a - b| (0 when both are empty); -0 and +0 count as equal.
inline double MaxDiff(const cv::Mat& a, const cv::Mat& b) {
  if (a.empty() && b.empty()) return 0.0;
  if (a.size() != b.size() || a.type() != b.type()) return INFINITY;
  return cv::norm(a, b, cv::NORM_INF);
}

// The inputs the equivalence tests run on: gray and colour, odd and tiny sizes, constant images,
// textures with and without haze, values at 0 and 1.
struct NamedImage {
  std::string name;
  cv::Mat image;
};

inline std::vector<NamedImage> EquivalenceInputs() {
  std::vector<NamedImage> out;
  const int sizes[][2] = {{1, 1}, {2, 3}, {5, 7}, {16, 16}, {17, 31}, {40, 97}, {101, 203}};
  uint64_t seed = 11;
  for (const auto& s : sizes) {
    const int rows = s[0], cols = s[1];
    cv::Mat noise(rows, cols, CV_32FC3);
    cv::RNG(seed++).fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
    cv::Mat smooth;
    cv::GaussianBlur(noise, smooth, cv::Size(0, 0), 3.0);
    const cv::Mat colour = 0.3 * noise + 0.7 * smooth;
    cv::Mat gray;
    cv::cvtColor(colour, gray, cv::COLOR_BGR2GRAY);
    const std::string tag = std::to_string(rows) + "x" + std::to_string(cols);
    out.push_back({"texture colour " + tag, colour});
    out.push_back({"texture gray " + tag, gray});
    out.push_back(
        {"constant colour " + tag, cv::Mat(rows, cols, CV_32FC3, cv::Scalar(0.2, 0.5, 0.7))});
    out.push_back({"constant gray " + tag, cv::Mat(rows, cols, CV_32FC1, cv::Scalar(0.4))});
  }
  // Haze over a dark-prior texture, with saturated and black pixels.
  const cv::Mat clean = baselines_test::DarkPriorTexture(61, 127, false);
  const cv::Mat t = baselines_test::ColumnTransmission(61, 127, 12, 0.1f, 1.0f);
  cv::Mat hazy = baselines_test::AddHaze(clean, t, cv::Vec3f(0.85f, 0.8f, 0.7f));
  hazy(cv::Rect(100, 10, 9, 7)).setTo(cv::Scalar::all(1.0));
  hazy(cv::Rect(50, 40, 5, 5)).setTo(cv::Scalar::all(0.0));
  out.push_back({"haze colour 61x127", hazy});
  cv::Mat hazy_gray;
  cv::extractChannel(hazy, hazy_gray, 1);
  out.push_back({"haze gray 61x127", hazy_gray});
  return out;
}

// Real underwater photographs from $TURBID_DATA (colour and their gray), when present.
inline std::vector<NamedImage> RealInputs() {
  std::vector<NamedImage> out;
  const char* data = std::getenv("TURBID_DATA");
  if (data == nullptr || *data == '\0') return out;
  for (const char* file : {"uieb_waternet/616.png"}) {
    const cv::Mat bgr8 = cv::imread(std::string(data) + "/" + file, cv::IMREAD_COLOR);
    if (bgr8.empty()) continue;
    cv::Mat colour, gray;
    bgr8.convertTo(colour, CV_32F, 1.0 / 255.0);
    cv::cvtColor(colour, gray, cv::COLOR_BGR2GRAY);
    out.push_back({std::string(file) + " colour", colour});
    out.push_back({std::string(file) + " gray", gray});
  }
  return out;
}

// dcp, udcp and cap refine gray images with GuidedFilterGrayRunning (radius > 12: running
// horizontal sums, not the doubling tree of the pre-optimisation filter), so their refined maps
// equal the reference's to float rounding only: within this (absolute, maps of magnitude <= ~1),
// the bound both float filters keep from the exact double-precision filter
// (tests/enhancer/guided_filter_test.cc, RunningSumVariantEqualsFilterToFloatRounding). Colour
// guides and radii <= 12 still give the reference's values bit for bit.
constexpr double kRunningGuidedTolerance = 1e-5;
inline bool UsesRunningGuidedFilter(const cv::Mat& image, int radius) {
  return image.channels() == 1 && std::min(radius, std::max(image.rows, image.cols)) > 12;
}

}  // namespace turbid::baselines_reference
