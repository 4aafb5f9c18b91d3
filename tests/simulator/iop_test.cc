// Water from its inherent optical properties (simulator/iop.h, spectra.h): the Solonenko & Mobley
// table against its data file, the spectral integration against closed forms, the derived water
// and the revised model's range-dependent beta^D(r).
#include "simulator/iop.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "simulator/render.h"
#include "simulator/render_options.h"
#include "simulator/water.h"
#include "test_scenes.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {

const Spectrum& Flat() {
  static const Spectrum flat(SpectralGrid().size(), 1.0);
  return flat;
}

// Flat spectra give the flat value whatever the camera and illuminant: c = a + b, b / c, and
// beta^D(r) = c at every range.
TEST(Iop, FlatSpectraGiveTheFlatValue) {
  testing::TempDir dir;
  const std::string csv = dir.Write("flat.csv", "wavelength_nm,a,b\n380,0.1,0.2\n720,0.1,0.2\n");
  for (const char* illuminant : {"equal_energy", "d65"}) {
    const EffectiveWater e =
        Effective(WaterSpectraFor(csv), CameraSensitivityFor("srgb"), IlluminantFor(illuminant));
    for (int k = 0; k < 4; ++k) {
      EXPECT_NEAR(e.c[k], 0.3, 1e-12);
      EXPECT_NEAR(e.b[k], 0.2, 1e-12);
      for (double r : {0.5, 5.0, 30.0}) {
        EXPECT_NEAR(e.DirectBeta(k, r), 0.3, 1e-12);
        EXPECT_NEAR(e.BackscatterBeta(k, r), 0.3, 1e-12);
      }
    }
  }
}

// A camera that sees one wavelength picks that wavelength's c (Solonenko & Mobley's published
// value, no interpolation at a tabulated wavelength).
TEST(Iop, SingleWavelengthCameraPicksThatWavelength) {
  testing::TempDir dir;
  const std::string camera = dir.Write("camera.csv",
                                       "wavelength_nm,r,g,b\n400,0,0,0\n545,0,0,0\n550,1,0,0\n"
                                       "555,0,0,0\n645,0,0,0\n650,0,1,0\n655,0,0,0\n695,0,0,0\n"
                                       "700,0,0,1\n");
  for (const char* type : {"IB", "3C", "9C"}) {
    const EffectiveWater e =
        Effective(WaterSpectraFor(type), CameraSensitivityFor(camera), IlluminantFor("d65"));
    const double c550 =
        SolonenkoMobleyPublished(type, 550, 'a') + SolonenkoMobleyPublished(type, 550, 'b');
    const double c650 =
        SolonenkoMobleyPublished(type, 650, 'a') + SolonenkoMobleyPublished(type, 650, 'b');
    const double c700 =
        SolonenkoMobleyPublished(type, 700, 'a') + SolonenkoMobleyPublished(type, 700, 'b');
    EXPECT_NEAR(e.c[0], c550, 1e-12) << type;
    EXPECT_NEAR(e.c[1], c650, 1e-12) << type;
    if (std::string(type) != "3C") EXPECT_NEAR(e.c[2], c700, 1e-12) << type;  // 3C 700: a defect
    // One wavelength: the direct signal is a pure exponential.
    EXPECT_NEAR(e.DirectBeta(0, 7.0), c550, 1e-9);
  }
}

// The CIE fit integrates to the known white point: equal-energy light seen by the x, y, z functions
// gives X = Y = Z (to the fit's accuracy, Wyman et al. report < 1 % error), and the sRGB camera
// sees it as nearly neutral.
TEST(Iop, CieFitIsBalanced) {
  double sum[3] = {0, 0, 0};
  for (double l = 360; l <= 830; l += 1.0) {
    const auto xyz = Cie1931Xyz(l);
    for (int k = 0; k < 3; ++k) sum[k] += xyz[k];
  }
  EXPECT_NEAR(sum[0] / sum[1], 1.0, 0.01);
  EXPECT_NEAR(sum[2] / sum[1], 1.0, 0.02);
  EXPECT_NEAR(sum[1], 106.86, 1.0);  // the tabulated CIE y integrates to 106.86 at 1 nm
  EXPECT_NEAR(Cie1931Xyz(555)[1], 1.0, 0.02);
}

// Akkaynak & Treibitz (2018): beta^D depends on range through the spectrum reaching the camera.
// IB red with the sRGB camera and equal-energy light falls with range; measured values below
// (docs/model.md quotes them).
TEST(Iop, RevisedBetaDFallsWithRange) {
  const EffectiveWater e =
      Effective(WaterSpectraFor("IB"), CameraSensitivityFor("srgb"), IlluminantFor("equal_energy"));
  const double b1 = e.DirectBeta(0, 1.0), b10 = e.DirectBeta(0, 10.0), b20 = e.DirectBeta(0, 20.0);
  EXPECT_GT(e.c[0], b1);
  EXPECT_GT(b1, b10);
  EXPECT_GT(b10, b20);
  EXPECT_GT(b1 - b20, 0.02);  // a real fall, not rounding
  // Independent check of t_D at 10 m: the weighted sum written out.
  double num = 0.0, den = 0.0;
  const CameraSensitivity cam = CameraSensitivityFor("srgb");
  const WaterSpectra w = WaterSpectraFor("IB");
  for (size_t i = 0; i < SpectralGrid().size(); ++i) {
    num += cam.rgb[0][i] * std::exp(-(w.a[i] + w.b[i]) * 10.0);
    den += cam.rgb[0][i];
  }
  EXPECT_NEAR(b10, -std::log(num / den) / 10.0, 1e-12);
  std::printf("IB red beta^D: r->0 %.3f, 1 m %.3f, 10 m %.3f, 20 m %.3f /m\n", e.c[0], b1, b10,
              b20);
}

// The built-in table against the data file it was typed from, every published cell.
TEST(Iop, SolonenkoMobleyTableMatchesDataFile) {
  const auto data = testing::DataDir();
  if (!data) GTEST_SKIP() << "TURBID_DATA not set: table check skipped";
  std::ifstream file(*data + "/jerlov_iop/solonenko_mobley_2015_a_b_c_400_700_wide.csv");
  ASSERT_TRUE(file) << "missing solonenko_mobley_2015_a_b_c_400_700_wide.csv";
  std::string line;
  std::getline(file, line);
  std::vector<std::string> header;
  std::stringstream h(line);
  for (std::string cell; std::getline(h, cell, ',');) header.push_back(cell);
  int checked = 0, defects = 0;
  while (std::getline(file, line)) {
    std::stringstream s(line);
    std::vector<std::string> cells;
    for (std::string cell; std::getline(s, cell, ',');) cells.push_back(cell);
    cells.resize(header.size());
    const int nm = std::stoi(cells[0]);
    for (size_t i = 1; i < header.size(); ++i) {
      const char q = header[i][0];
      if (q == 'c') continue;
      const std::string type = header[i].substr(2);
      const double mine = SolonenkoMobleyPublished(type, nm, q);
      if (cells[i].empty()) {
        EXPECT_TRUE(std::isnan(mine)) << type << " " << nm;
        ++defects;
      } else {
        EXPECT_DOUBLE_EQ(mine, std::stod(cells[i])) << header[i] << " " << nm;
        ++checked;
      }
    }
  }
  EXPECT_EQ(checked + defects, 260);
  EXPECT_EQ(defects, 14);  // 3C 675/700 and 5C 600-700, a and b
}

// water.iop fills beta (= c) and the albedo (= b / c); conflicts and bad files are errors.
TEST(Iop, WaterFromIopFillsBetaAndAlbedo) {
  const RenderOptions o =
      RenderOptionsFromJson(nlohmann::json::parse(R"({"water": {"iop": "ib"}})"));
  const EffectiveWater e =
      Effective(WaterSpectraFor("IB"), CameraSensitivityFor("srgb"), IlluminantFor("equal_energy"));
  EXPECT_EQ(o.water.iop, "IB");
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(o.water.beta_rgb_per_m[k], e.c[k], 1e-12);
    EXPECT_NEAR(o.water.scattering_albedo_rgb[k], e.b[k] / e.c[k], 1e-12);
  }
  // Red attenuates most, and IB's albedo is small in red (absorption by water dominates).
  EXPECT_GT(o.water.beta_rgb_per_m[0], o.water.beta_rgb_per_m[2]);
  EXPECT_LT(o.water.scattering_albedo_rgb[0], 0.3);
  // The written options read back (the derived values repeat).
  EXPECT_NO_THROW(RenderOptionsFromJson(RenderOptionsToJson(o)));
  auto error_of = [](const std::string& text) {
    try {
      RenderOptionsFromJson(nlohmann::json::parse(text));
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error_of(R"({"water": {"iop": "IB", "beta_rgb_per_m": [1, 1, 1]}})")
                .find("water.beta_rgb_per_m: conflicts with water.iop"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"water": {"iop": "IB", "type": "II"}})").find("water.iop"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"water": {"iop": "XX"}})").find("unknown Jerlov type"), std::string::npos);
  EXPECT_NE(error_of(R"({"water": {"iop": "/nonexistent/w.csv"}})").find("/nonexistent/w.csv"),
            std::string::npos);
  testing::TempDir dir;
  const std::string bad = dir.Write("bad.csv", "wavelength_nm,a,b\n400,0.1\n");
  EXPECT_NE(error_of(R"({"water": {"iop": ")" + bad + R"("}})").find("expected 3 columns"),
            std::string::npos);
}

// The revised model with water.iop: each pixel is J t_D(r) + (1 - exp(-beta^B(r) r)) B_inf with the
// transmissions of the spectra (to the range table's interpolation, 1e-4).
TEST(Iop, RevisedUsesDerivedRangeDependentBetas) {
  const Scene scene = testing::MakePlaneScene(40, 30, 3.0, 3, 25.0);
  RenderOptions o;
  o.model = ImageModel::kRevised;
  o.water.iop = "3C";
  o.water.ambient_rgb = {1, 1, 1};
  o.light.lights.clear();
  o.psf.enabled = false;
  o.snow.enabled = false;
  o.sensor.enabled = false;
  o.camera.bit_depth = 32;
  const RenderResult r = Render(o, scene);
  const EffectiveWater e =
      Effective(WaterSpectraFor("3C"), CameraSensitivityFor("srgb"), IlluminantFor("equal_energy"));
  const Renderer renderer(scene);
  const cv::Mat& range = renderer.range_m();
  const double bs[3] = {o.water.backscatter_rgb[2], o.water.backscatter_rgb[1],
                        o.water.backscatter_rgb[0]};
  for (int y = 0; y < 30; y += 3)
    for (int x = 0; x < 40; x += 3) {
      const double rr = range.at<float>(y, x);
      for (int c = 0; c < 3; ++c) {
        const int k = 2 - c;
        const double td = e.DirectTransmission(k, rr);
        const double tb = std::exp(-e.BackscatterBeta(k, rr) * rr);
        const double want = scene.image.at<cv::Vec3f>(y, x)[c] * td + (1.0 - tb) * bs[c];
        ASSERT_NEAR(r.image.at<cv::Vec3f>(y, x)[c], want, 1e-4) << x << "," << y << "," << c;
      }
    }
  EXPECT_NE(r.plan.ToText().find("from the spectra of water.iop 3C"), std::string::npos);
  // Typed-in values keep working.
  o.revised.from_iop = false;
  const RenderResult typed = Render(o, scene);
  EXPECT_GT(cv::norm(typed.image, r.image, cv::NORM_INF), 1e-3);
}

}  // namespace
}  // namespace turbid
