// Size-like method parameters are bounded by the image (enhancer/registry.h, SizeBound): a window
// larger than 2 x the image's larger side + 1, or a radius or tile count above the larger side,
// is refused by Enhance with one line naming the method, the parameter, its value and the bound,
// before any work; defaults always run (tiny images keep working).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <string>

#include "enhancer/registry.h"
#include "core/error.h"

namespace turbid {
namespace {

cv::Mat Image(int width, int height) {
  cv::Mat m(height, width, CV_32FC3);
  cv::RNG rng(3);
  rng.fill(m, cv::RNG::UNIFORM, 0.1, 0.9);
  return m;
}

std::string EnhanceError(const std::string& method, const nlohmann::json& params,
                         const cv::Mat& image) {
  EnhanceInput input;
  input.image = image;
  try {
    Enhance(method, params, input);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

bool LooksSizeLike(const std::string& name) {
  for (const char* part : {"patch_size", "radius", "tiles_", "window"})
    if (name.find(part) != std::string::npos) return true;
  return name == "sv";
}

TEST(SizeBounds, EverySizeLikeParameterDeclaresItsBound) {
  int declared = 0;
  for (const MethodInfo& m : ListMethods())
    for (const MethodParam& p : m.params) {
      if (LooksSizeLike(p.name)) {
        EXPECT_NE(p.bound, SizeBound::kNone) << m.name << "." << p.name;
      }
      declared += p.bound != SizeBound::kNone;
    }
  EXPECT_GE(declared, 15);
}

TEST(SizeBounds, ValuesPastTheBoundAreOneLineBeforeAnyWork) {
  const cv::Mat image = Image(24, 16);
  int refused = 0;
  for (const MethodInfo& m : ListMethods())
    for (const MethodParam& p : m.params) {
      if (p.bound == SizeBound::kNone) continue;
      const int64_t limit =
          std::max(SizeBoundLimit(p.bound, image.size()), p.default_value.get<int64_t>());
      for (const int64_t value : {limit + 2, int64_t{10000001}}) {
        const auto start = std::chrono::steady_clock::now();
        const std::string message = EnhanceError(m.name, {{p.name, value}}, image);
        const double seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        EXPECT_EQ(message,
                  m.name + ": parameter '" + p.name + "' = " + std::to_string(value) + " exceeds " +
                      std::to_string(limit) + ", the bound for a 24x16 image (" +
                      (p.bound == SizeBound::kWindow   ? "2 x its larger side + 1"
                       : p.bound == SizeBound::kRadius ? "its larger side"
                                                       : "its larger side (regions per axis)") +
                      ")");
        EXPECT_LT(seconds, 1.0) << m.name << "." << p.name;
        ++refused;
      }
    }
  EXPECT_GE(refused, 30);
}

TEST(SizeBounds, TheIssuesPatchSizeIsRefusedAtOnce) {
  // `turbid enhance --method dcp -p patch_size=10000001` on 128x96 took 74 s and 10 GB.
  const std::string message = EnhanceError("dcp", {{"patch_size", 10000001}}, Image(128, 96));
  EXPECT_EQ(message,
            "dcp: parameter 'patch_size' = 10000001 exceeds 257, the bound for a 128x96 image (2 x "
            "its larger side + 1)");
}

TEST(SizeBounds, BoundsAndDefaultsStillRun) {
  // At the bound the window covers the image from every pixel; dcp's default 15 on a 2x2 image
  // (above the image's bound of 5) is still accepted.
  EXPECT_EQ(EnhanceError("dcp", {{"patch_size", 49}, {"guided_radius", 24}}, Image(24, 16)), "");
  EXPECT_EQ(EnhanceError("tarel", {{"sv", 49}}, Image(24, 16)), "");
  EXPECT_EQ(EnhanceError("clahe", {{"tiles_x", 24}, {"tiles_y", 16}}, Image(24, 16)), "");
  EXPECT_EQ(EnhanceError("dcp", nlohmann::json::object(), Image(2, 2)), "");
  EXPECT_EQ(EnhanceError("cap", nlohmann::json::object(), Image(1, 1)), "");
}

TEST(SizeBounds, LimitsFollowTheLargerSide) {
  EXPECT_EQ(SizeBoundLimit(SizeBound::kWindow, {128, 96}), 257);
  EXPECT_EQ(SizeBoundLimit(SizeBound::kRadius, {96, 128}), 128);
  EXPECT_EQ(SizeBoundLimit(SizeBound::kPerAxis, {1, 1}), 1);
  EXPECT_EQ(SizeBoundLimit(SizeBound::kNone, {1, 1}), INT64_MAX);
}

}  // namespace
}  // namespace turbid
