// `full`'s clahe_domain (issue 32 item 2; docs/methods.md "The CLAHE domain"): the default
// equalises the camera-coded image with the paper's Rayleigh alpha 0.4 and decodes back to linear;
// "linear" keeps the earlier behaviour (alpha 0.3 on linear light) by name.
//
// The reference is an independent composition of existing pieces: scenes/image_io.h's sRGB curve
// (LinearToSrgb / SrgbToLinear, float std::pow per value) around the CLAHE block (Clahe, alpha
// 0.4) on the image `full` had before its last step (FullResult::deblurred, clamped to [0, 1]).
// `full` codes through tables with linear interpolation (enhancer/paper/full_coding.cc: error
// below 1e-7 against the double-precision curve). Where such a difference moves a value across a
// bin edge (round(v * 255)) the pixel's mapping moves by one bin, so the bound is on the bulk
// (99.9 % of values within 1e-4 of the composition) and on the worst value (one bin step of a
// Rayleigh mapping clipped at 0.01: below 0.02), and the mean difference (below 1e-5).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/error.h"
#include "enhancer/blocks/clahe.h"
#include "enhancer/paper/full.h"
#include "enhancer/registry.h"
#include "scenes/builtin.h"
#include "scenes/image_io.h"
#include "simulator/render.h"

namespace turbid {
namespace {

cv::Mat Clamped(const cv::Mat& m) {
  cv::Mat c = m.clone();
  cv::patchNaNs(c, 0.0);
  return cv::min(cv::max(c, 0.0), 1.0);
}

// encode -> CLAHE (alpha 0.4, adapthisteq's defaults) -> decode, from existing blocks.
cv::Mat Composition(const cv::Mat& linear) {
  const cv::Mat coded = LinearToSrgb(Clamped(linear));
  return SrgbToLinear(Clahe(ClaheOptions{}, coded));
}

struct Difference {
  double max = 0.0, mean = 0.0, share_above_1e4 = 0.0;
};

Difference Compare(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat d;
  cv::absdiff(a, b, d);
  d = d.reshape(1);
  Difference r;
  cv::minMaxLoc(d, nullptr, &r.max);
  r.mean = cv::mean(d)[0];
  r.share_above_1e4 =
      static_cast<double>(cv::countNonZero(d > 1e-4)) / static_cast<double>(d.total());
  return r;
}

void ExpectNearComposition(const cv::Mat& got, const cv::Mat& want, const std::string& where) {
  const Difference d = Compare(got, want);
  std::printf("%s: max %.3g, mean %.3g, share > 1e-4 %.3g\n", where.c_str(), d.max, d.mean,
              d.share_above_1e4);
  EXPECT_LT(d.max, 0.02) << where;
  EXPECT_LT(d.mean, 1e-5) << where;
  EXPECT_LE(d.share_above_1e4, 1e-3) << where;
}

RenderResult RenderOf(const Scene& scene) {
  RenderOptions o;
  o.seed = 3;
  return Render(o, scene);
}

// hull is gray, seafloor and room colour.
Scene Builtin(const char* name) {
  BuiltinSceneOptions so;
  so.scale = 0.25;
  return MakeBuiltinScene(name, so);
}

// Every path of step 5 (the colour rows streamed into CLAHE, the gray rows streamed, the
// whole-image steps), default options, against the composition on the image before CLAHE.
TEST(FullClaheDomain, EncodedEqualsEncodeClaheDecode) {
  {
    for (const char* name : {"hull", "seafloor", "room"}) {
      const Scene scene = Builtin(name);
      const RenderResult r = RenderOf(scene);
      const FullOptions o;
      ASSERT_EQ(o.clahe_domain, ClaheDomain::kEncoded);
      ASSERT_EQ(o.clahe.alpha, 0.4);
      const FullResult f = FullEnhanceDetailed(o, r.image, &scene, &r.sidecar);
      EXPECT_EQ(f.clahe_encoding, CameraEncoding::kSrgb);
      EXPECT_EQ(f.clahe_encoding_source, "the sidecar's camera");
      EXPECT_NE(f.steps.back().find("srgb-coded values"), std::string::npos) << f.steps.back();
      const std::string where = name;
      ExpectNearComposition(f.image, Composition(f.deblurred), where + " detailed");
      // The streamed paths (no inspection) give the detailed path's output.
      const cv::Mat fast = FullEnhance(o, r.image, &scene, &r.sidecar);
      EXPECT_LE(cv::norm(fast, f.image, cv::NORM_INF), 1e-5) << where;
      EXPECT_TRUE(cv::checkRange(fast, true, nullptr, 0.0, 1.0 + 1e-6)) << where;
    }
  }
}

// Only step 5: the output is the composition on the input itself.
TEST(FullClaheDomain, OnlyClaheIsTheCompositionOnTheInput) {
  for (const char* name : {"hull", "room"}) {
    const Scene scene = Builtin(name);
    const RenderResult r = RenderOf(scene);
    FullOptions only;
    only.denoise = only.light = only.dehaze = only.deblur = false;
    ExpectNearComposition(FullEnhance(only, r.image, &scene, &r.sidecar), Composition(r.image),
                          std::string(name) + ", CLAHE only");
  }
}

// "linear" by name is the earlier `full` bit for bit: alpha 0.3 on linear light over the same
// image before CLAHE (the composition the earlier test pinned at 1e-6), unless clahe_alpha is
// named; the variants keep their 0.4.
TEST(FullClaheDomain, LinearByNameKeepsTheEarlierBehaviour) {
  const FullOptions linear = FullOptionsFromJson({{"clahe_domain", "linear"}}, "full");
  EXPECT_EQ(linear.clahe_domain, ClaheDomain::kLinear);
  EXPECT_EQ(linear.clahe.alpha, 0.3);
  EXPECT_EQ(FullOptionsFromJson({{"clahe_domain", "linear"}, {"clahe_alpha", 0.25}}).clahe.alpha,
            0.25);
  EXPECT_EQ(FullOptionsFromJson(nlohmann::json::object()).clahe.alpha, 0.4);
  for (const char* variant : {"full_literal", "full_matched", "full_physical"}) {
    EXPECT_EQ(FullOptionsFromJson({{"clahe_domain", "linear"}}, variant).clahe.alpha, 0.4);
    EXPECT_EQ(FullVariantDefaults(variant).clahe_domain, ClaheDomain::kEncoded);
  }
  for (const char* name : {"hull", "seafloor"}) {
    const Scene scene = Builtin(name);
    const RenderResult r = RenderOf(scene);
    const FullResult f = FullEnhanceDetailed(linear, r.image, &scene, &r.sidecar);
    EXPECT_EQ(f.clahe_encoding, CameraEncoding::kLinear);
    EXPECT_NE(f.steps.back().find("alpha 0.3, on linear light"), std::string::npos)
        << f.steps.back();
    EXPECT_LE(cv::norm(f.image, Clahe(LinearDomainFullClahe(), Clamped(f.deblurred)), cv::NORM_INF),
              1e-6);
    const cv::Mat fast = FullEnhance(linear, r.image, &scene, &r.sidecar);
    EXPECT_LE(cv::norm(fast, f.image, cv::NORM_INF), 1e-5);
    // The registry reads the key too.
    const cv::Mat reg =
        Enhance("full", {{"clahe_domain", "linear"}}, EnhanceInput{r.image, &scene, &r.sidecar});
    EXPECT_EQ(cv::norm(reg, fast, cv::NORM_INF), 0.0);
  }
  try {
    FullOptionsFromJson({{"clahe_domain", "srgb"}});
    ADD_FAILURE() << "accepted clahe_domain srgb";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("clahe_domain"), std::string::npos) << e.what();
  }
}

// The curve is the camera's: a linear camera's codes are linear, so "encoded" equalises linear
// values (alpha 0.4); without a sidecar sRGB is assumed and the step log says so.
TEST(FullClaheDomain, TheCurveIsTheCamerasOrSrgbWithoutOne) {
  const Scene scene = Builtin("seafloor");
  RenderOptions ro;
  ro.seed = 3;
  ro.camera.encoding = CameraEncoding::kLinear;
  const RenderResult lin = Render(ro, scene);
  const FullResult f = FullEnhanceDetailed(FullOptions{}, lin.image, &scene, &lin.sidecar);
  EXPECT_EQ(f.clahe_encoding, CameraEncoding::kLinear);
  EXPECT_LE(cv::norm(f.image, Clahe(ClaheOptions{}, Clamped(f.deblurred)), cv::NORM_INF), 1e-6);

  const FullResult none = FullEnhanceDetailed(FullOptions{}, lin.image, &scene, nullptr);
  EXPECT_EQ(none.clahe_encoding, CameraEncoding::kSrgb);
  EXPECT_EQ(none.clahe_encoding_source, "no sidecar camera: sRGB assumed");
  EXPECT_NE(none.steps.back().find("sRGB assumed"), std::string::npos) << none.steps.back();
  ExpectNearComposition(none.image, Composition(none.deblurred), "seafloor, no sidecar");
}

// The brightness-keeping target in the coded domain keeps the mean of the codes, with the linear
// floor coded (0.18 -> 0.46): the output's coded mean luminance is at least the floor's code.
TEST(FullClaheDomain, KeptMeanFloorIsCoded) {
  const Scene scene = Builtin("room");
  const RenderResult r = RenderOf(scene);
  FullOptions o;
  o.clahe_target_mean = true;
  const FullResult f = FullEnhanceDetailed(o, r.image, &scene, &r.sidecar);
  const double coded_mean = cv::mean(LinearToSrgb(f.image))[0];
  const double floor_code = 1.055 * std::pow(0.18, 1 / 2.4) - 0.055;  // 0.4614
  std::printf("coded mean %.4f, floor %.4f, input coded mean %.4f\n", coded_mean, floor_code,
              cv::mean(LinearToSrgb(Clamped(f.deblurred)))[0]);
  EXPECT_GE(coded_mean, floor_code - 0.03);
}

}  // namespace
}  // namespace turbid
