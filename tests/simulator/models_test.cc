// The image-formation models besides eq. 2 (issue 16, item 1): closed forms on a plane at known
// range, each written out here independently of the renderer (range from the pinhole geometry,
// transmissions and the published N values typed in from the papers' recipe).
#include "simulator/models.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "simulator/render.h"
#include "test_scenes.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {

RenderOptions Bare() {
  RenderOptions o;
  o.water.ambient_rgb = {1, 1, 1};
  o.water.ambient_gray = 1;
  o.light.lights.clear();
  o.psf.enabled = false;
  o.snow.enabled = false;
  o.sensor.enabled = false;
  o.camera.bit_depth = 32;
  return o;
}

// Range along the ray of pixel (x, y) of MakePlaneScene (fronto-parallel plane at depth z).
double PlaneRange(const Scene& s, int x, int y) {
  const double u = (x - s.camera.cx) / s.camera.fx, v = (y - s.camera.cy) / s.camera.fy;
  return s.depth_m.at<float>(y, x) * std::sqrt(u * u + v * v + 1.0);
}

double Clip(double v) { return std::min(std::max(v, 0.0), 1.0); }

TEST(Models, RevisedSeparatesDirectAndBackscatterCoefficients) {
  const Scene scene = testing::MakePlaneScene(40, 30, 2.5, 3, 30.0);
  RenderOptions o = Bare();
  o.model = ImageModel::kRevised;
  o.water.beta_rgb_per_m = {0.6, 0.25, 0.15};  // beta^D, R G B
  o.water.ambient_rgb = {0.9, 0.8, 0.7};
  o.water.backscatter_rgb = {0.05, 0.2, 0.3};  // B_inf
  o.revised.beta_b_rgb_per_m = {0.3, 0.45, 0.5};
  o.maps = MapSelection::FromList("transmission,veil");
  const RenderResult r = Render(o, scene);
  const double bd[3] = {0.15, 0.25, 0.6}, bb[3] = {0.5, 0.45, 0.3}, binf[3] = {0.3, 0.2, 0.05},
               ea[3] = {0.7, 0.8, 0.9};  // BGR
  for (int y = 0; y < 30; y += 2)
    for (int x = 0; x < 40; x += 3) {
      const double z = PlaneRange(scene, x, y);
      for (int c = 0; c < 3; ++c) {
        const double rho = scene.image.at<cv::Vec3f>(y, x)[c];
        const double expected =
            ea[c] * rho * std::exp(-bd[c] * z) + binf[c] * (1.0 - std::exp(-bb[c] * z));
        ASSERT_NEAR(r.image.at<cv::Vec3f>(y, x)[c], Clip(expected), 2e-6) << x << "," << y;
        ASSERT_NEAR(r.transmission.at<cv::Vec3f>(y, x)[c], std::exp(-bd[c] * z), 1e-6);
        ASSERT_NEAR(r.veil.at<cv::Vec3f>(y, x)[c], binf[c] * (1.0 - std::exp(-bb[c] * z)), 1e-6);
      }
    }
  EXPECT_NE(r.plan.ToText().find("model: revised"), std::string::npos);
  EXPECT_EQ(r.sidecar.ToJson()["derived"]["model"], "revised");
}

TEST(Models, RevisedWithEqualCoefficientsIsEquationTwoWithBackscatter) {
  const Scene scene = testing::MakePlaneScene(33, 21, 1.7, 3, 25.0);
  RenderOptions paper;  // defaults: light, PSF, snow and noise on
  paper.water.backscatter = true;
  paper.camera.bit_depth = 32;
  RenderOptions revised = paper;
  revised.model = ImageModel::kRevised;
  revised.revised.beta_b_rgb_per_m = paper.water.beta_rgb_per_m;
  const RenderResult a = Render(paper, scene), b = Render(revised, scene);
  EXPECT_LT(cv::norm(a.image, b.image, cv::NORM_INF), 1e-6);
}

TEST(Models, RevisedSeaThruRangeDependentDirectCoefficient) {
  const Scene scene = testing::MakePlaneScene(36, 24, 3.0, 3, 20.0);
  RenderOptions o = Bare();
  o.model = ImageModel::kRevised;
  o.water.backscatter_rgb = {0.1, 0.1, 0.1};
  o.revised.beta_b_rgb_per_m = {0.2, 0.2, 0.2};
  o.revised.range_dependent = true;
  o.revised.a_rgb = {0.9, 0.5, 0.4};
  o.revised.b_rgb = {-0.3, -0.2, -0.1};
  o.revised.c_rgb = {0.2, 0.1, 0.05};
  o.revised.d_rgb = {-0.02, 0.0, -0.5};
  const RenderResult r = Render(o, scene);
  const double a[3] = {0.4, 0.5, 0.9}, b[3] = {-0.1, -0.2, -0.3}, c2[3] = {0.05, 0.1, 0.2},
               d[3] = {-0.5, 0.0, -0.02};
  double spread = 0.0;
  for (int y = 0; y < 24; y += 2)
    for (int x = 0; x < 36; x += 2) {
      const double z = PlaneRange(scene, x, y);
      spread = std::max(spread, z - 3.0);
      for (int c = 0; c < 3; ++c) {
        const double beta_d = a[c] * std::exp(b[c] * z) + c2[c] * std::exp(d[c] * z);
        const double rho = scene.image.at<cv::Vec3f>(y, x)[c];
        const double expected = rho * std::exp(-beta_d * z) + 0.1 * (1.0 - std::exp(-0.2 * z));
        ASSERT_NEAR(r.image.at<cv::Vec3f>(y, x)[c], Clip(expected), 2e-6) << x << "," << y;
      }
    }
  EXPECT_GT(spread, 1.0);  // the plane's ranges really vary (3 m on axis, > 4 m at the corners)
  RenderOptions bad = o;
  bad.revised.b_rgb = {0.1, 0, 0};  // Sea-thru's fit bounds: b <= 0
  EXPECT_THROW(Render(bad, scene), Error);
}

TEST(Models, UwcnnPowerLawTransmissionAndBackgroundLight) {
  const Scene scene = testing::MakePlaneScene(30, 20, 2.0, 3, 20.0);
  RenderOptions o = Bare();
  o.model = ImageModel::kUwcnn;
  o.uwcnn.type = "3C";  // Li, Anwar & Porikli 2020: N = 0.710, 0.820, 0.800 (R, G, B)
  o.uwcnn.domain = UwcnnDomain::kLinear;
  o.water.ambient_rgb = {0.1, 0.1, 0.1};  // ignored by this model: J = A rho
  o.light.lights = {LightOptions{}};      // ignored too
  const RenderResult r = Render(o, scene);
  const double n[3] = {0.800, 0.820, 0.710};  // BGR
  for (int y = 0; y < 20; y += 2)
    for (int x = 0; x < 30; x += 2) {
      const double d = PlaneRange(scene, x, y);
      for (int c = 0; c < 3; ++c) {
        // The scripts' I = A rho t + A (1 - t): A lights the direct signal too.
        const double t = std::pow(n[c], d), a = 1.5 * std::pow(n[c], 4.0);
        const double rho = scene.image.at<cv::Vec3f>(y, x)[c];
        ASSERT_NEAR(r.image.at<cv::Vec3f>(y, x)[c], Clip(a * rho * t + a * (1.0 - t)), 2e-6);
      }
    }
  EXPECT_EQ(r.sidecar.ToJson()["options"]["uwcnn"]["type"], "3C");
  EXPECT_EQ(r.sidecar.ToJson()["options"]["uwcnn"]["domain"], "linear");
  EXPECT_NE(r.plan.ToText().find("on linear light"), std::string::npos);

  // Rescaled distances: the farthest pixel at 12 m, constant A = 0.8 (the other script's recipe),
  // and a gray image is the mean of the three channels' recipes (mean of the powers N_c^d, not
  // (mean N)^d).
  o.uwcnn.max_distance_m = 12.0;
  o.uwcnn.backlight_scale = 0.8;
  o.uwcnn.backlight_exponent = 0.0;
  const Scene gray = testing::MakePlaneScene(30, 20, 2.0, 1, 20.0);
  const RenderResult g = Render(o, gray);
  const double far = PlaneRange(gray, 0, 0);
  for (int y = 0; y < 20; y += 3)
    for (int x = 0; x < 30; x += 3) {
      const double d = PlaneRange(gray, x, y) * 12.0 / far;
      const double t = (std::pow(0.710, d) + std::pow(0.820, d) + std::pow(0.800, d)) / 3.0;
      const double rho = gray.image.at<float>(y, x);
      ASSERT_NEAR(g.image.at<float>(y, x), Clip(0.8 * rho * t + 0.8 * (1.0 - t)), 2e-6);
    }
  // With A_c unequal the gray image is still the mean of the three recipes.
  o.uwcnn.backlight_scale = 1.5;
  o.uwcnn.backlight_exponent = 3.0;
  const RenderResult g3 = Render(o, gray);
  for (int y = 0; y < 20; y += 3)
    for (int x = 0; x < 30; x += 3) {
      const double d = PlaneRange(gray, x, y) * 12.0 / far;
      const double rho = gray.image.at<float>(y, x);
      double mean = 0.0;
      for (double nc : {0.710, 0.820, 0.800}) {
        const double a = 1.5 * std::pow(nc, 3.0), t = std::pow(nc, d);
        mean += (a * rho * t + a * (1.0 - t)) / 3.0;
      }
      ASSERT_NEAR(g3.image.at<float>(y, x), Clip(mean), 2e-6);
    }
}

// domain "encoded" (default): the recipe on the 8-bit sRGB code of rho scaled to [0, 1], the
// result decoded to linear light for the rest of the pipeline; an 8-bit sRGB camera writes the
// recipe's own codes (to one level: the code of the rounded value).
TEST(Models, UwcnnEncodedDomainWorksOnSrgbCodes) {
  const Scene scene = testing::MakePlaneScene(30, 20, 2.0, 3, 20.0);
  RenderOptions o = Bare();
  o.model = ImageModel::kUwcnn;
  o.uwcnn.type = "II";  // N = 0.800, 0.925, 0.940
  ASSERT_EQ(o.uwcnn.domain, UwcnnDomain::kEncoded);
  const RenderResult r = Render(o, scene);
  const double n[3] = {0.940, 0.925, 0.800};  // BGR
  auto encode = [](double v) {
    v = std::clamp(v, 0.0, 1.0);
    return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
  };
  for (int y = 0; y < 20; y += 2)
    for (int x = 0; x < 30; x += 2) {
      const double d = PlaneRange(scene, x, y);
      for (int c = 0; c < 3; ++c) {
        const double t = std::pow(n[c], d), a = 1.5 * std::pow(n[c], 4.0);
        const double code = std::round(255.0 * encode(scene.image.at<cv::Vec3f>(y, x)[c])) / 255;
        const double coded_i = std::min(a * code * t + a * (1.0 - t), 1.0);
        // Decoded: the output is linear, its sRGB value is the recipe's coded I.
        ASSERT_NEAR(encode(r.image.at<cv::Vec3f>(y, x)[c]), coded_i, 2e-6);
      }
    }
  EXPECT_NE(r.plan.ToText().find("8-bit sRGB codes"), std::string::npos);
  // The two domains differ (the recipe is not linear in the coding).
  o.uwcnn.domain = UwcnnDomain::kLinear;
  EXPECT_GT(cv::norm(Render(o, scene).image, r.image, cv::NORM_INF), 0.01);
}

// The built-in N table against the data file it was typed from (shared/data/jerlov/
// uwcnn_nlambda.csv, provenance in its SOURCE.md): every type, every channel, exactly.
TEST(Models, UwcnnTableMatchesDataFile) {
  TURBID_REQUIRE_DATA(data);
  std::ifstream file(data + "/jerlov/uwcnn_nlambda.csv");
  ASSERT_TRUE(file) << "missing uwcnn_nlambda.csv";
  std::string line;
  std::getline(file, line);
  ASSERT_EQ(line.rfind("type,N_R,N_G,N_B", 0), 0u) << line;
  int rows = 0;
  while (std::getline(file, line)) {
    if (line.empty() || line == "\r") continue;
    std::stringstream cells(line);
    std::string type, r, g, b;
    std::getline(cells, type, ',');
    std::getline(cells, r, ',');
    std::getline(cells, g, ',');
    std::getline(cells, b, ',');
    const Rgb n = UwcnnResidualEnergy(type);
    EXPECT_DOUBLE_EQ(n[0], std::stod(r)) << type;
    EXPECT_DOUBLE_EQ(n[1], std::stod(g)) << type;
    EXPECT_DOUBLE_EQ(n[2], std::stod(b)) << type;
    ++rows;
  }
  EXPECT_EQ(rows, 10);
}

TEST(Models, JsonBindingRoundTripsAndRejectsBadValues) {
  RenderOptions o;
  o.model = ImageModel::kUwcnn;
  o.uwcnn.type = "C9";
  const nlohmann::json j = RenderOptionsToJson(o);
  EXPECT_EQ(j["model"], "uwcnn");
  EXPECT_EQ(j["uwcnn"]["type"], "9C");
  EXPECT_NEAR(j["uwcnn"]["n_rgb_per_m"][2].get<double>(), 0.290, 1e-12);
  EXPECT_EQ(RenderOptionsToJson(RenderOptionsFromJson(j)), j);
  auto error_of = [](const char* text) {
    try {
      RenderOptionsFromJson(nlohmann::json::parse(text));
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(
      error_of(R"({"model": "jaffe"})").find("'model': expected one of paper, revised, uwcnn"),
      std::string::npos);
  EXPECT_NE(error_of(R"({"uwcnn": {"type": "IB", "n_rgb_per_m": [0.5, 0.5, 0.5]}})")
                .find("uwcnn.n_rgb_per_m: conflicts"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"revised": {"beta_b_rgb_per_m": [1, 1, 11]}})")
                .find("revised.beta_b_rgb_per_m"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"uwcnn": {"n_gray_per_m": 0}})").find("uwcnn.n_gray_per_m"),
            std::string::npos);
  RenderOptions r;
  r.model = ImageModel::kRevised;
  r.revised.range_dependent = true;
  r.revised.d_rgb = {-0.5, -0.25, 0};
  const nlohmann::json rj = RenderOptionsToJson(r);
  EXPECT_EQ(RenderOptionsToJson(RenderOptionsFromJson(rj)), rj);
  EXPECT_FALSE(rj.contains("uwcnn"));
}

}  // namespace
}  // namespace turbid
