// Closed loop for Sea-thru's water estimate on real RGB-D frames of $TURBID_DATA (issue 31 item 4):
// the ICL-NUIM living-room frames 0-3 (1.45-2.68 m) and the TUM RGB-D frame (Kinect, 1.1-9.2 m,
// holes) rendered in three known `revised` waters, noise on and off, fitted, and compared with
// the truth. What holds and what cannot, with the figures reached: docs/cli/water.md "What it
// reaches". The printed lines are those figures (ctest -R SeathruRealFrames -V).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "enhancer/seathru/water_fit.h"
#include "scenes/scene_loader.h"
#include "simulator/render.h"
#include "tests/enhancer/seathru_waters.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {

using seathru_test::kWaters;
using seathru_test::RevisedWater;
using seathru_test::Water;
using seathru_test::WithShadows;

struct LoopResult {
  // Worst relative error over the channels; the curves over 21 ranges spanning the frame.
  double b_inf = 0, beta_b = 0, backscatter_curve = 0, beta_d = 0;
};

LoopResult CloseLoop(const Scene& scene, const Water& w, bool noise) {
  Renderer renderer(scene);
  const RenderResult result = renderer.Render(RevisedWater(w, noise));
  const WaterFit fit = FitWater({{result.image, renderer.range_m().clone(), scene.name}});
  LoopResult out;
  for (int c = 0; c < 3; ++c) {
    out.b_inf = std::max(out.b_inf, std::abs(fit.backscatter.b_inf[c] - w.b_inf[c]) / w.b_inf[c]);
    out.beta_b =
        std::max(out.beta_b, std::abs(fit.backscatter.beta_b[c] - w.beta_b[c]) / w.beta_b[c]);
    for (int i = 0; i <= 20; ++i) {
      const double r = fit.min_range_m + (fit.max_range_m - fit.min_range_m) * i / 20;
      const double truth = w.b_inf[c] * (1.0 - std::exp(-w.beta_b[c] * r));
      out.backscatter_curve =
          std::max(out.backscatter_curve, std::abs(fit.backscatter.Evaluate(c, r) - truth) / truth);
      out.beta_d =
          std::max(out.beta_d, std::abs(fit.attenuation.Beta(c, r) - w.beta_d[c]) / w.beta_d[c]);
    }
  }
  std::printf("%s %s %s: B_inf %.1f %%, beta^B %.1f %%, B(r) %.1f %%, beta^D(r) %.0f %%\n",
              scene.name.c_str(), w.name, noise ? "noise" : "noise-free", 100 * out.b_inf,
              100 * out.beta_b, 100 * out.backscatter_curve, 100 * out.beta_d);
  return out;
}

Scene LoadFrame(const testing::TempDir& dir, const nlohmann::json& spec) {
  return WithShadows(LoadScene(dir.Write(spec["name"].get<std::string>() + ".json", spec.dump())));
}

// ICL-NUIM living room, frames 0-3: the backscatter is recovered noise-free as on the built-in
// scenes (B∞ within 5 %, β^B within 10 %; reached: <= 0.6 % and <= 0.9 %). With 8-bit noise the
// ranges span only 1.2 m, over which B(r) is close to a straight line: the curve at the ranges
// present stays within 10 % (reached: <= 6.1 %), but its split into B∞ and β^B does not (up to
// 33 % / 58 %, harbour and coastal water), so only the curve is tested with noise.
TEST(SeathruRealFrames, IclNuimBackscatter) {
  const auto data = testing::DataDir();
  if (!data) GTEST_SKIP() << "TURBID_DATA not set: skipping the ICL-NUIM frames";
  const testing::TempDir dir;
  for (int k = 0; k < 4; ++k) {
    const std::string n = std::to_string(k);
    const Scene scene = LoadFrame(dir, {{"type", "rgbd"},
                                        {"name", "icl" + n},
                                        {"image", *data + "/icl_nuim_lr_kt1/rgb/" + n + ".png"},
                                        {"depth", *data + "/icl_nuim_lr_kt1/depth/" + n + ".png"},
                                        {"camera", "icl_nuim"}});
    for (const Water& w : kWaters) {
      for (bool noise : {false, true}) {
        SCOPED_TRACE(scene.name + " " + w.name + (noise ? " noise" : ""));
        const LoopResult r = CloseLoop(scene, w, noise);
        if (!noise) {
          EXPECT_LT(r.b_inf, 0.05);
          EXPECT_LT(r.beta_b, 0.10);
          EXPECT_LT(r.backscatter_curve, 0.01);
        } else {
          EXPECT_LT(r.backscatter_curve, 0.10);
        }
      }
    }
  }
}

// The TUM RGB-D frame (a real Kinect frame with holes, 1.1-9.2 m): B∞ within 5 % and β^B within
// 10 % noise-free (reached: 2.4 %, 6.5 %); with noise the built-in seafloor's bounds, B∞ within 8 %
// and β^B within 25 % (reached: 5.1 %, 17.5 %).
TEST(SeathruRealFrames, TumBackscatter) {
  const auto data = testing::DataDir();
  if (!data) GTEST_SKIP() << "TURBID_DATA not set: skipping the TUM RGB-D frame";
  const testing::TempDir dir;
  const Scene scene =
      LoadFrame(dir, {{"type", "rgbd"},
                      {"name", "tum"},
                      {"image", *data + "/tum_rgbd/1.png"},
                      {"depth", *data + "/tum_rgbd/1_depth.png"},
                      {"camera", {{"fx", 520.9}, {"fy", 521.0}, {"cx", 325.1}, {"cy", 249.7}}}});
  for (const Water& w : kWaters) {
    for (bool noise : {false, true}) {
      SCOPED_TRACE(std::string(w.name) + (noise ? " noise" : ""));
      const LoopResult r = CloseLoop(scene, w, noise);
      EXPECT_LT(r.b_inf, noise ? 0.08 : 0.05);
      EXPECT_LT(r.beta_b, noise ? 0.25 : 0.10);
    }
  }
}

}  // namespace
}  // namespace turbid
