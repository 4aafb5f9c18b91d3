// ambient: "derived" (simulator/water.h DerivedBackscatter): B_inf = (b/c) E_A H from the ambient
// light, the water's b, c and its phase function; H against closed forms and a direct numerical
// integral over the sphere of incoming directions.
#include <gtest/gtest.h>

#include <cmath>

#include "simulator/phase_function.h"
#include "simulator/render.h"
#include "simulator/water.h"
#include "tests/simulator/test_scenes.h"

namespace turbid {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Direct: integral over downward-travelling directions w (a (theta_w, phi_w) grid, theta_w from
// straight down) of p(angle(w, -d)), -d the unit vector towards the camera at elevation -elev.
double DirectShare(const PhaseFunction& p, double elevation_deg, int n_theta, int n_phi) {
  const double e = -elevation_deg * kPi / 180.0;
  const cv::Vec3d out(std::cos(e), 0.0, std::sin(e));  // x horizontal, z up
  double sum = 0.0;
  const double dt = (kPi / 2) / n_theta, dp = 2 * kPi / n_phi;
  for (int i = 0; i < n_theta; ++i) {
    const double t = (i + 0.5) * dt;  // from straight down
    for (int j = 0; j < n_phi; ++j) {
      const double f = (j + 0.5) * dp;
      const cv::Vec3d w(std::sin(t) * std::cos(f), std::sin(t) * std::sin(f), -std::cos(t));
      sum += p(std::acos(std::clamp(w.dot(out), -1.0, 1.0))) * std::sin(t) * dt * dp;
    }
  }
  return sum;
}

TEST(AmbientBackscatter, ShareClosedForms) {
  PhaseFunctionOptions ff, hg, iso;
  hg.model = "henyey_greenstein";
  hg.g = 0.8;
  iso.model = "isotropic";
  for (const PhaseFunctionOptions& o : {ff, hg, iso}) {
    const PhaseFunction p(o);
    EXPECT_NEAR(AmbientBackscatterShare(p, 0.0), 0.5, 1e-6) << o.model;  // horizontal
    EXPECT_NEAR(AmbientBackscatterShare(p, -90.0), p.BackscatterRatio(), 1e-9) << o.model;
    EXPECT_NEAR(AmbientBackscatterShare(p, 90.0), 1.0 - p.BackscatterRatio(), 1e-9) << o.model;
  }
  const PhaseFunction p(iso);
  for (double e : {-60.0, -20.0, 45.0}) EXPECT_NEAR(AmbientBackscatterShare(p, e), 0.5, 1e-6);
  // Looking down sees less of the forward-peaked ambient scattering than looking up.
  const PhaseFunction f(ff);
  EXPECT_LT(AmbientBackscatterShare(f, -45.0), 0.5);
  EXPECT_GT(AmbientBackscatterShare(f, 45.0), 0.5);
}

TEST(AmbientBackscatter, ShareMatchesADirectIntegralOverTheSphere) {
  PhaseFunctionOptions hg;
  hg.model = "henyey_greenstein";
  hg.g = 0.8;
  const PhaseFunction h(hg);
  for (double e : {-70.0, -30.0, -5.0, 20.0, 60.0}) {
    const double direct = DirectShare(h, e, 1500, 3000);
    EXPECT_NEAR(AmbientBackscatterShare(h, e) / direct, 1.0, 2e-3) << "HG, elevation " << e;
  }
  // Fournier-Forand: looking down keeps its forward peak outside the downward hemisphere, where
  // the direct grid integral is accurate.
  const PhaseFunction f{PhaseFunctionOptions{}};
  for (double e : {-80.0, -45.0, -20.0}) {
    const double direct = DirectShare(f, e, 1500, 3000);
    EXPECT_NEAR(AmbientBackscatterShare(f, e) / direct, 1.0, 5e-3) << "FF, elevation " << e;
  }
}

TEST(AmbientBackscatter, DerivedRenderFollowsTheAmbientLight) {
  const Scene scene = testing::MakePlaneScene(16, 12, 3.0);
  RenderOptions o;
  o.light.lights.clear();
  o.snow.enabled = false;
  o.sensor.enabled = false;
  o.psf.enabled = false;
  o.camera.bit_depth = 32;
  o.ambient = AmbientModel::kDerived;
  o.water.ambient_view_elevation_deg = -60.0;
  o.water.scattering_albedo_rgb = {0.5, 0.7, 0.9};
  o.water.ambient_rgb = {0.1, 0.2, 0.3};
  o.maps.veil = true;
  o.maps.transmission = true;
  const RenderResult r = Render(o, scene);
  const double h = AmbientBackscatterShare(PhaseFunction(o.water.phase), -60.0);
  const double expected_bgr[3] = {0.9 * 0.3 * h, 0.7 * 0.2 * h, 0.5 * 0.1 * h};
  for (int c = 0; c < 3; ++c) {
    const double t = r.transmission.at<cv::Vec3f>(5, 5)[c];
    EXPECT_NEAR(r.veil.at<cv::Vec3f>(5, 5)[c], (1 - t) * expected_bgr[c], 1e-6) << c;
  }
  EXPECT_NE(r.plan.ToText().find("ambient: derived"), std::string::npos);
  // Twice the ambient light, twice the backscatter (typed B_inf ignores E_A).
  o.water.ambient_rgb = {0.2, 0.4, 0.6};
  const RenderResult r2 = Render(o, scene);
  EXPECT_NEAR(r2.veil.at<cv::Vec3f>(5, 5)[0], 2 * r.veil.at<cv::Vec3f>(5, 5)[0], 1e-6);
  EXPECT_EQ(RenderOptionsToJson(o)["ambient"], "derived");
  EXPECT_EQ(RenderOptions{}.ambient, AmbientModel::kTyped);
  EXPECT_EQ(RenderOptionsFromJson(nlohmann::json::parse(R"({"ambient": "derived"})")).ambient,
            AmbientModel::kDerived);
}

}  // namespace
}  // namespace turbid
