// EnhanceInput::rgb (the Python boundary's R, G, B order): every registered method, given the
// R, G, B twin of a B, G, R image, returns exactly the R, G, B twin of its B, G, R result, whether
// it reads the order natively (MethodEntry::rgb_native) or Enhance reorders for it. And Enhance's
// one-pass clamp gives the values of cv::patchNaNs, cv::min and cv::max (and +0 for -0).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <string>

#include "enhancer/registry.h"
#include "simulator/render.h"
#include "tests/simulator/test_scenes.h"

namespace turbid {
namespace {

cv::Mat Swapped(const cv::Mat& image) {
  cv::Mat out;
  cv::cvtColor(image, out, cv::COLOR_BGR2RGB);
  return out;
}

int CountDifferentBits(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return -1;
  const cv::Mat ai = a.reshape(1).clone(), bi = b.reshape(1).clone();
  cv::Mat ne;
  cv::compare(cv::Mat(ai.size(), CV_32S, ai.data), cv::Mat(bi.size(), CV_32S, bi.data), ne,
              cv::CMP_NE);
  return cv::countNonZero(ne);
}

TEST(ChannelOrder, EveryMethodGivesTheSameValuesInRgbOrder) {
  for (const cv::Size size : {cv::Size(97, 61), cv::Size(160, 120)}) {
    const Scene scene = testing::MakePlaneScene(size.width, size.height, 2.5, 3, 120.0);
    RenderOptions o;
    o.water.type = "5C";
    o.seed = 3;
    const RenderResult render = Render(o, scene);
    const cv::Mat rgb = Swapped(render.image);
    for (const MethodInfo& method : ListMethods()) {
      const std::string what = method.name + " at " + std::to_string(size.width) + "x" +
                               std::to_string(size.height);
      EnhanceInput bgr_in{render.image, &scene, &render.sidecar, false};
      EnhanceInput rgb_in{rgb, &scene, &render.sidecar, true};
      const cv::Mat expected = Swapped(Enhance(method.name, nlohmann::json::object(), bgr_in));
      const cv::Mat got = Enhance(method.name, nlohmann::json::object(), rgb_in);
      EXPECT_EQ(CountDifferentBits(got, expected), 0) << what;
      // The input is not modified in place.
      EXPECT_EQ(CountDifferentBits(rgb_in.image, Swapped(render.image)), 0) << what;
    }
  }
}

TEST(ChannelOrder, GrayImagesIgnoreTheFlag) {
  const Scene scene = testing::MakePlaneScene(64, 48, 2.0, 1, 80.0);
  RenderOptions o;
  o.water.type = "3C";
  o.seed = 5;
  const RenderResult render = Render(o, scene);
  for (const char* name : {"clahe", "simplified", "dcp"}) {
    const cv::Mat a = Enhance(name, {}, EnhanceInput{render.image, &scene, &render.sidecar, false});
    const cv::Mat b = Enhance(name, {}, EnhanceInput{render.image, &scene, &render.sidecar, true});
    EXPECT_EQ(CountDifferentBits(a, b), 0) << name;
  }
}

TEST(ClampEnhanceOutput, MatchesPatchNansMinMax) {
  const float special[] = {std::numeric_limits<float>::quiet_NaN(),
                           -std::numeric_limits<float>::quiet_NaN(),
                           std::numeric_limits<float>::infinity(),
                           -std::numeric_limits<float>::infinity(),
                           -0.0f, 0.0f, 1.0f, -1e-30f, 1.0000001f, 0.5f, -2.0f, 3.0f};
  for (int channels : {1, 3})
    for (int width : {1, 7, 8, 9, 33, 257}) {
      cv::Mat image(13, width, CV_32FC(channels));
      cv::RNG rng(width * 7 + channels);
      rng.fill(image, cv::RNG::UNIFORM, -0.5, 1.5);
      for (int i = 0; i < static_cast<int>(image.total() * channels); i += 5)
        reinterpret_cast<float*>(image.data)[i] = special[(i / 5) % std::size(special)];
      cv::Mat expected = image.clone();
      cv::patchNaNs(expected, 0.0);
      cv::min(expected, 1.0, expected);
      cv::max(expected, 0.0, expected);
      cv::Mat got = image.clone();
      ClampEnhanceOutput(got);
      // Equal values; and -0 is always +0 here (OpenCV's scalar tail keeps -0, its SIMD body not).
      EXPECT_EQ(cv::norm(got, expected, cv::NORM_INF), 0.0) << width << " x " << channels;
      const float* g = got.ptr<float>();
      for (size_t i = 0; i < got.total() * channels; ++i) ASSERT_FALSE(std::signbit(g[i])) << i;
    }
}

}  // namespace
}  // namespace turbid
