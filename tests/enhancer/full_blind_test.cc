// `full` run blind (issue "The paper's full method must work blind"): the light scale estimated
// from the image against renders whose true scale is known, the never-collapse property on the
// built-in scenes, and the registry's privileged marks for the variants.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "enhancer/paper/full.h"
#include "enhancer/registry.h"
#include "metrics/registry.h"
#include "scenes/builtin.h"
#include "scenes/camera_encoding.h"
#include "scenes/image_io.h"
#include "core/error.h"
#include "scenes/scene_loader.h"
#include "simulator/render.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {

double Metric(const std::string& name, const cv::Mat& image, const cv::Mat& reference,
              const cv::Mat& original) {
  MetricInputs in;
  in.image = image;
  in.reference = reference;
  in.original = original;
  return ComputeMetrics({name}, in).at(name);
}

// SSIM as the field scores it (issue 32, docs/experiments.md "Scoring domain"): both images as
// the default camera writes them, sRGB 8-bit codes (here divided by 255: SSIM with data range 1
// on codes / 255 is SSIM with range 255 on the codes).
double CodedSsim(const cv::Mat& image, const cv::Mat& reference, const cv::Mat& original) {
  const auto coded = [](const cv::Mat& m) {
    return LinearToSrgb(QuantiseEncoded(m, CameraEncoding::kSrgb, 8));
  };
  return Metric("ssim", coded(image), coded(reference), coded(original));
}

// Share of the tiles (8x8 grid) textured in the degraded input (standard deviation >= 0.02, twice
// the default sensor's noise, so that a tile of noise alone does not count as texture) that
// the output makes flat (standard deviation below half the input's: contrast lost where an
// enhancement should add it) or saturated (half the pixels at 0 or 1 within 1/255). The check
// docs/methods.md states for "never collapses".
double CollapsedTileShare(const cv::Mat& output, const cv::Mat& input) {
  int textured = 0, collapsed = 0;
  for (int ty = 0; ty < 8; ++ty) {
    for (int tx = 0; tx < 8; ++tx) {
      const cv::Rect tile(tx * input.cols / 8, ty * input.rows / 8, input.cols / 8,
                          input.rows / 8);
      cv::Scalar m_i, s_i, m_o, s_o;
      cv::meanStdDev(input(tile).reshape(1), m_i, s_i);
      if (s_i[0] < 0.02) continue;
      ++textured;
      const cv::Mat o = output(tile).reshape(1);
      cv::meanStdDev(o, m_o, s_o);
      const double extreme = static_cast<double>(cv::countNonZero(o <= 1.0 / 255) +
                                                 cv::countNonZero(o >= 254.0 / 255)) /
                             static_cast<double>(o.total());
      if (s_o[0] < 0.5 * s_i[0] || extreme >= 0.5) ++collapsed;
    }
  }
  return textured == 0 ? 0.0 : static_cast<double>(collapsed) / textured;
}

RenderOptions Clean(double beta, double power) {
  RenderOptions o;
  o.snow.enabled = false;
  o.sensor.enabled = false;
  o.psf.enabled = false;
  o.camera.bit_depth = 16;
  o.water.beta_gray_per_m = beta;
  o.water.beta_rgb_per_m = {beta, beta, beta};
  o.light.lights[0].power = power;
  return o;
}

// The render's sidecar with the LED power replaced by 1: the blind estimate then has to find
// the true power (in image units) from the image alone.
RenderRecord WithUnitPower(RenderRecord sidecar) {
  for (LightOptions& light : sidecar.options->light.lights) light.power = 1.0;
  return sidecar;
}

// The estimate against the true scale, with beta matched (the only beta at which "the true scale"
// of the light model is defined). Measured (a / U0, 2026-11-25): hull 0.77-1.10, seafloor
// 0.69-1.10, room 0.60-1.36 for U0 = 4-16 and beta 0.4-1.0 (docs/methods.md). Tolerances: 25% on
// the hull (the paper's plane), 45% on the seafloor and room, whose geometry is not a plane. At
// U0 = 32 the lit plate saturates the sensor (values clip at 1), so the veil's true size is not
// observable: the estimate stays below the truth, the side that cannot over-subtract.
TEST(FullBlind, LightScaleRecoversTheTrueLedPower) {
  BuiltinSceneOptions so;
  so.scale = 0.25;
  for (const char* name : {"hull", "seafloor", "room"}) {
    const Scene scene = MakeBuiltinScene(name, so);
    const double tolerance = std::string(name) == "hull" ? 0.25 : 0.45;
    for (double beta : {0.4, 0.7, 1.0}) {
      for (double power : {4.0, 8.0, 16.0, 32.0}) {
        const RenderResult r = Render(Clean(beta, power), scene);
        const RenderRecord unit = WithUnitPower(r.sidecar);
        const FullResult f =
            FullEnhanceDetailed(FullVariantDefaults("full_matched"), r.image, &scene, &unit);
        ASSERT_EQ(f.light_scale.size(), static_cast<size_t>(r.image.channels()));
        for (double a : f.light_scale) {
          const std::string where = std::string(name) + " beta " + std::to_string(beta) +
                                    " power " + std::to_string(power) + " estimate " +
                                    std::to_string(a);
          if (power < 32) {
            EXPECT_NEAR(a / power, 1.0, tolerance) << where;
            std::printf("light scale %s beta %.1f U0 %.0f: a/U0 = %.3f\n", name, beta, power,
                        a / power);
          } else {
            EXPECT_LT(a / power, 1.0) << where;
            EXPECT_GT(a / power, 0.3) << where;
          }
        }
      }
    }
  }
}

// The bound alone is an upper bound on the veil: I_de - (1 - t) a L stays >= 0 on all but the
// percentile's share of the supported pixels (noise-free: the bound is exact at the dark end).
TEST(FullBlind, ScaleKeepsTheVeilBelowTheImage) {
  BuiltinSceneOptions so;
  so.scale = 0.25;
  const Scene scene = MakeBuiltinScene("hull", so);
  const RenderResult r = Render(Clean(0.7, 8.0), scene);
  const FullResult f = FullEnhanceDetailed(FullOptions{}, r.image, &scene, &r.sidecar);
  ASSERT_FALSE(f.light.empty());
  const cv::Mat rest = f.denoised - (1.0 - f.transmission).mul(f.light);
  const double negative_share =
      static_cast<double>(cv::countNonZero(rest < -1e-3)) / static_cast<double>(rest.total());
  EXPECT_LE(negative_share, 0.01);
}

// Mean scores of one configuration of `full` over the images of one turbidity level.
struct LevelScores {
  double coded_in = 0, coded_out = 0;    // SSIM on sRGB 8-bit codes (the field's domain)
  double linear_in = 0, linear_out = 0;  // SSIM on linear light (before issue 32)
  double e = 0;                          // Hautiere e, mean
  void Add(const cv::Mat& out, const cv::Mat& clean, const cv::Mat& degraded, double n) {
    coded_out += CodedSsim(out, clean, degraded) / n;
    coded_in += CodedSsim(degraded, clean, degraded) / n;
    linear_out += Metric("ssim", out, clean, degraded) / n;
    linear_in += Metric("ssim", degraded, clean, degraded) / n;
    e += Metric("hautiere_e", out, clean, degraded) / n;
  }
  void Print(const std::string& what) const {
    std::printf("%s: SSIM coded input %.3f, full %.3f; linear input %.3f, full %.3f; e %.3f\n",
                what.c_str(), coded_in, coded_out, linear_in, linear_out, e);
  }
};

// The configurations the never-collapse tests run: the default (CLAHE on the camera-coded image,
// alpha 0.4) and clahe_domain linear by name (alpha 0.3 on linear light, the default before
// issue 32).
struct Config {
  const char* name;
  nlohmann::json params;
};
std::vector<Config> Configs() {
  return {{"default", nlohmann::json::object()}, {"linear", {{"clahe_domain", "linear"}}}};
}

// The bars per level. Both configurations: no collapsed tile, mean e >= 0. clahe_domain linear:
// mean SSIM >= the input's in linear light (the bar of the issue that made `full` blind, set and
// met in that domain). The default, scored as the field scores (coded): below the input at every
// level measured, a finding of issue 32 reported in docs/methods.md ("The CLAHE domain"), not a
// bar; guarded here against a further fall of 0.1 (measured 2026-11-29: -0.04 to -0.09 on the
// built-in scenes, -0.03 to -0.04 on the ICL frames).
void ExpectBars(const Config& c, const LevelScores& s, const std::string& where) {
  s.Print(std::string(c.name) + " " + where);
  EXPECT_GE(s.e, 0.0) << c.name << " " << where;
  if (std::string(c.name) == "linear") {
    EXPECT_GE(s.linear_out, s.linear_in) << c.name << " " << where;
  } else {
    EXPECT_GE(s.coded_out, s.coded_in - 0.1) << c.name << " " << where;
  }
}

// Never collapses: on the built-in scenes with the default render (noise, snow, PSF) at the
// paper's beta and either side, blind `full` keeps the mean Hautiere e over the scenes >= the
// degraded input's (the bars are on means per turbidity level), loses at most 2% of any
// one image's visible edges (e >= -0.02; the quarter-size hull at beta 1.0, where the
// transmission floor limits the dehazing, is at -0.008 in linear), and leaves no textured tile
// flat or saturated; SSIM as ExpectBars says. The literal [min I, max I] reading does collapse on
// the hull (what the issue reported), so the check can fail.
TEST(FullBlind, NeverCollapsesWhereTheLiteralReadingDoes) {
  BuiltinSceneOptions so;
  so.scale = 0.25;
  for (const Config& config : Configs()) {
    for (double beta : {0.4, 0.7, 1.0}) {
      LevelScores scores;
      for (const char* name : {"hull", "seafloor", "room"}) {
        const Scene scene = MakeBuiltinScene(name, so);
        RenderOptions ro;
        ro.seed = 7;
        ro.water.beta_gray_per_m = beta;
        ro.water.beta_rgb_per_m = {beta * 1.3, beta, beta * 0.8};
        const RenderResult r = Render(ro, scene);
        const EnhanceInput in{r.image, &scene, &r.sidecar};
        const cv::Mat out = Enhance("full", config.params, in);
        const std::string where =
            std::string(config.name) + " " + name + " beta " + std::to_string(beta);
        scores.Add(out, scene.image, r.image, 3);
        EXPECT_GE(Metric("hautiere_e", out, scene.image, r.image), -0.02) << where;
        EXPECT_EQ(CollapsedTileShare(out, r.image), 0.0) << where;
      }
      ExpectBars(config, scores, "built-in beta " + std::to_string(beta));
    }
  }
  BuiltinSceneOptions half;
  half.scale = 0.25;
  const Scene hull = MakeBuiltinScene("hull", half);
  RenderOptions ro;
  ro.seed = 7;
  const RenderResult r = Render(ro, hull);
  const cv::Mat literal = Enhance("full_literal", {}, EnhanceInput{r.image, &hull, &r.sidecar});
  EXPECT_GT(CollapsedTileShare(literal, r.image), 0.5);
}

// The same bars on the real ICL-NUIM frames 0-3 of $TURBID_DATA under table1.json's render (PSF
// T = 4, q = 0.9; one LED of power 2; gray water at beta 0.4, 0.7, 1.0; the default noise and
// snow): per level, the bars of ExpectBars; no collapsed tile in any image. Measured 2026-11-29
// (seeds 1-4 here, the sweep's differ), SSIM coded input / default / linear by name: 0.691 /
// 0.649 / 0.680, 0.626 / 0.595 / 0.639, 0.544 / 0.510 / 0.562 (docs/methods.md).
TEST(FullBlind, NeverCollapsesOnTheRealIclFrames) {
  const auto data = testing::DataDir();
  if (!data) GTEST_SKIP() << "TURBID_DATA not set: skipping the ICL-NUIM frames";
  const testing::TempDir dir;
  std::vector<Scene> scenes;
  for (int k = 0; k < 4; ++k) {
    const nlohmann::json spec = {
        {"type", "rgbd"},
        {"name", "icl" + std::to_string(k)},
        {"image", *data + "/icl_nuim_lr_kt1/rgb/" + std::to_string(k) + ".png"},
        {"depth", *data + "/icl_nuim_lr_kt1/depth/" + std::to_string(k) + ".png"},
        {"camera", "icl_nuim"}};
    scenes.push_back(LoadScene(dir.Write("icl" + std::to_string(k) + ".json", spec.dump())));
  }
  for (double beta : {0.4, 0.7, 1.0}) {
    std::vector<LevelScores> scores(Configs().size());
    for (size_t k = 0; k < scenes.size(); ++k) {
      const nlohmann::json options = {
          {"seed", 1 + k},
          {"psf", {{"optical_thickness", 4.0}, {"forward_scatter", 0.9}}},
          {"light", {{"lights", {{{"power", 2.0}}}}}},
          {"water", {{"beta_gray_per_m", beta}, {"beta_rgb_per_m", {beta, beta, beta}}}}};
      const RenderResult r = Render(RenderOptionsFromJson(options), scenes[k]);
      for (size_t c = 0; c < Configs().size(); ++c) {
        const Config config = Configs()[c];
        const cv::Mat out =
            Enhance("full", config.params, EnhanceInput{r.image, &scenes[k], &r.sidecar});
        scores[c].Add(out, scenes[k].image, r.image, static_cast<double>(scenes.size()));
        EXPECT_EQ(CollapsedTileShare(out, r.image), 0.0)
            << config.name << " " << scenes[k].name << " beta " << beta;
      }
    }
    for (size_t c = 0; c < Configs().size(); ++c) {
      ExpectBars(Configs()[c], scores[c], "ICL beta " + std::to_string(beta));
    }
  }
}

// Mean Rec. 709 luminance (BGR order) of an image clamped to [0, 1].
double LumaMean(const cv::Mat& image) {
  cv::Mat c;
  cv::min(cv::max(image, 0.0), 1.0, c);
  const cv::Scalar m = cv::mean(c);
  return c.channels() == 1 ? m[0] : 0.0722 * m[0] + 0.7152 * m[1] + 0.2126 * m[2];
}

// Brightness kept (clahe_target_mean): the CLAHE target's alpha is chosen so that the mapped mean
// equals the mean of the image entering CLAHE, or middle grey (clahe_min_mean 0.18) when that is
// darker, so the output's mean luminance stays within a few hundredths of that aim; the paper's
// fixed Rayleigh(0.4) target lifts the restored scenes above it, so the check can fail. Measured
// 2026-11-25 (scale 0.25, default render): kept within 0.005 (hull 0.000, seafloor 0.002, room
// 0.005); fixed +0.10 (hull), +0.12 (seafloor), +0.12 (room) (blind full's fixed 0.3: +0.05).
TEST(FullBlind, ClaheTargetKeepsTheRestoredBrightness) {
  BuiltinSceneOptions so;
  so.scale = 0.25;
  double worst_fixed = 0.0;
  for (const char* name : {"hull", "seafloor", "room"}) {
    const Scene scene = MakeBuiltinScene(name, so);
    RenderOptions ro;
    ro.seed = 7;
    const RenderResult r = Render(ro, scene);
    for (bool target : {true, false}) {
      // In linear light, where these means are measured (the coded domain keeps coded means:
      // paper_clahe_domain_test.cc).
      FullOptions o = FullVariantDefaults("full");
      o.clahe_domain = ClaheDomain::kLinear;
      o.clahe_target_mean = target;
      o.clahe.alpha = ClaheOptions().alpha;  // the paper's 0.4 (used when !target)
      const FullResult f = FullEnhanceDetailed(o, r.image, &scene, &r.sidecar);
      ASSERT_FALSE(f.deblurred.empty());
      const double before = LumaMean(f.deblurred), after = LumaMean(f.image);
      std::printf("%s target_mean %d: mean before CLAHE %.3f, after %.3f, alpha %.3f\n", name,
                  target ? 1 : 0, before, after, f.clahe_alpha);
      const double aim = std::max(before, o.clahe_min_mean);
      if (target) {
        EXPECT_NEAR(after, aim, 0.03) << name;
      } else {
        EXPECT_DOUBLE_EQ(f.clahe_alpha, o.clahe.alpha) << name;
        worst_fixed = std::max(worst_fixed, after - aim);
      }
    }
  }
  EXPECT_GT(worst_fixed, 0.1);
  // Blind full equalises the coded image with the paper's 0.4 (issue 32); 0.3 in linear light by
  // name only (paper_clahe_domain_test.cc).
  EXPECT_EQ(FullVariantDefaults("full").clahe.alpha, 0.4);
  EXPECT_EQ(FullOptions().clahe.alpha, 0.4);
  EXPECT_EQ(FullOptionsFromJson({{"clahe_domain", "linear"}}, "full").clahe.alpha, 0.3);
  for (const char* variant : {"full_literal", "full_matched", "full_physical"}) {
    EXPECT_EQ(FullVariantDefaults(variant).clahe.alpha, 0.4) << variant;
  }
  // Naming clahe_alpha selects the fixed target.
  EXPECT_TRUE(FullOptionsFromJson({{"clahe_alpha", 0.3}, {"clahe_target_mean", true}}, "full")
                  .clahe_target_mean);
  EXPECT_FALSE(FullOptionsFromJson({{"clahe_alpha", 0.3}}, "full").clahe_target_mean);
  EXPECT_TRUE(FullOptionsFromJson({{"clahe_target_mean", true}}, "full").clahe_target_mean);
  EXPECT_FALSE(FullOptionsFromJson(nlohmann::json::object(), "full").clahe_target_mean);
  EXPECT_FALSE(FullVariantDefaults("full_literal").clahe_target_mean);
}

TEST(FullBlind, PrivilegedVariantsAreMarked) {
  EXPECT_FALSE(IsPrivileged("full", {}));
  EXPECT_FALSE(IsPrivileged("full_literal", {}));
  EXPECT_TRUE(IsPrivileged("full_matched", {}));
  EXPECT_TRUE(IsPrivileged("full_physical", {}));
  EXPECT_TRUE(IsPrivileged("full", {{"beta_source", "auto"}}));
  EXPECT_TRUE(IsPrivileged("full", {{"light_scaling", "physical"}}));
  EXPECT_FALSE(IsPrivileged("full_matched", {{"beta_source", "fixed"}}));
  EXPECT_FALSE(IsPrivileged("simplified", {}));
  EXPECT_FALSE(IsPrivileged("clahe", {}));
  EXPECT_THROW(IsPrivileged("nope", {}), Error);
  EXPECT_THROW(IsPrivileged("full", {{"light_scaling", "guess"}}), Error);
  for (const MethodInfo& m : ListMethods()) {
    if (m.name.rfind("full", 0) == 0) {
      EXPECT_NE(m.inputs.find("plane"), std::string::npos) << m.name;
    }
  }
}

// Defaults: `full` is the paper's method with what the paper has (beta 0.7 fixed).
TEST(FullBlind, DefaultReadsNoWater) {
  BuiltinSceneOptions so;
  so.scale = 0.2;
  const Scene scene = MakeBuiltinScene("seafloor", so);
  RenderOptions ro = Clean(1.5, 8.0);
  const RenderResult r = Render(ro, scene);
  const FullResult f = FullEnhanceDetailed(FullOptions{}, r.image, &scene, &r.sidecar);
  EXPECT_EQ(f.beta_source, "beta_per_m");
  EXPECT_EQ(f.beta_per_m, std::vector<double>(3, 0.7));
  std::string why;
  for (const char* v : {"full", "full_literal", "full_matched", "full_physical"}) {
    EXPECT_TRUE(FullVariantDefaults(v).Check(&why)) << v << ": " << why;
  }
}

}  // namespace
}  // namespace turbid
