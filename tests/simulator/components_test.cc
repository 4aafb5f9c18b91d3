// Closed-form checks of the forward model's pieces: water, light, PSF, noise (issue 3 item 5).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "core/error.h"
#include "simulator/light.h"
#include "simulator/noise.h"
#include "simulator/psf.h"
#include "simulator/water.h"
#include "test_scenes.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {

TEST(Water, DefaultsPassCheck) {
  std::string why;
  EXPECT_TRUE(WaterOptions{}.Check(&why)) << why;
}

TEST(Water, JerlovTableSpotValuesAndBandMeans) {
  // SOURCE.md spot checks: type I at 475 nm = 0.018 1/m, type C9 at 400 nm = 2.4 1/m.
  EXPECT_DOUBLE_EQ(JerlovKd("I", 475), 0.018);
  EXPECT_DOUBLE_EQ(JerlovKd("9C", 400), 2.4);
  EXPECT_DOUBLE_EQ(JerlovKd("C9", 400), 2.4);
  const JerlovBetas ib = JerlovBeta("IB");
  EXPECT_NEAR(ib.rgb_per_m[0], (0.245 + 0.315 + 0.375 + 0.435 + 0.58) / 5, 1e-12);
  EXPECT_NEAR(ib.rgb_per_m[1], (0.042 + 0.054 + 0.072 + 0.099) / 4, 1e-12);
  EXPECT_NEAR(ib.rgb_per_m[2], (0.051 + 0.042 + 0.036 + 0.033) / 4, 1e-12);
  // Within a factor 2 of DeepSeaRenderer's hand-picked IB and II triples (R, G, B).
  const double dsr[2][3] = {{0.37, 0.044, 0.035}, {0.4, 0.071, 0.06}};
  const JerlovBetas ii = JerlovBeta("II");
  for (int c = 0; c < 3; ++c) {
    EXPECT_LT(std::abs(std::log(ib.rgb_per_m[c] / dsr[0][c])), std::log(2.0)) << c;
    EXPECT_LT(std::abs(std::log(ii.rgb_per_m[c] / dsr[1][c])), std::log(2.0)) << c;
  }
  // Coastal waters attenuate more than open ocean in every channel.
  const JerlovBetas c9 = JerlovBeta("9C");
  for (int c = 0; c < 3; ++c) EXPECT_GT(c9.rgb_per_m[c], ib.rgb_per_m[c]);
  EXPECT_THROW(JerlovBeta("IV"), Error);
  EXPECT_EQ(JerlovTypeNames().size(), 10u);
}

TEST(Water, JerlovTableMatchesDataFile) {
  TURBID_REQUIRE_DATA(data);
  std::ifstream file(data + "/jerlov/jerlov_Kd.csv");
  ASSERT_TRUE(file) << "missing jerlov_Kd.csv";
  std::string line;
  std::getline(file, line);  // header: wavelength_nm,I,IA,IB,II,III,C1,C3,C5,C7,C9
  const std::vector<std::string> types = {"I",  "IA", "IB", "II", "III",
                                          "1C", "3C", "5C", "7C", "9C"};
  int rows = 0;
  while (std::getline(file, line)) {
    std::stringstream s(line);
    std::string cell;
    std::getline(s, cell, ',');
    const int nm = std::stoi(cell);
    for (const std::string& type : types) {
      std::getline(s, cell, ',');
      EXPECT_DOUBLE_EQ(JerlovKd(type, nm), std::stod(cell)) << type << " " << nm;
    }
    ++rows;
  }
  EXPECT_EQ(rows, 15);
}

TEST(Water, TransmissionEqualsExpOfRange) {
  const Scene scene = testing::MakePlaneScene(40, 30, 3.0);
  const cv::Mat range = RangeFromDepth(scene.camera, scene.depth_m);
  const std::vector<double> beta = {0.05, 0.4, 1.7};
  const cv::Mat t = TransmissionMap(range, beta);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x) {
      const double dx = (x - scene.camera.cx) / scene.camera.fx,
                   dy = (y - scene.camera.cy) / scene.camera.fy;
      const double r = 3.0 * std::sqrt(dx * dx + dy * dy + 1.0);
      for (int c = 0; c < 3; ++c)
        ASSERT_NEAR(t.at<cv::Vec3f>(y, x)[c], std::exp(-beta[c] * r), 1e-6) << x << "," << y;
    }
  // Invalid depth is open water: t = 0; beta = 10 at 50 m stays finite.
  cv::Mat far(2, 2, CV_32FC1, cv::Scalar(50.0f));
  far.at<float>(0, 0) = std::nanf("");
  const cv::Mat t2 = TransmissionMap(far, {10.0});
  EXPECT_EQ(t2.at<float>(0, 0), 0.0f);
  EXPECT_GE(t2.at<float>(1, 1), 0.0f);
  EXPECT_TRUE(std::isfinite(t2.at<float>(1, 1)));
}

// Independent closed form of SPEC's E_L for one light on a fronto-parallel plane (normal -z).
double PlaneIrradiance(const Scene& scene, int x, int y, const LightOptions& light, double beta,
                       bool eq5, double min_cos) {
  const double z = scene.depth_m.at<float>(y, x);
  const double X[3] = {(x - scene.camera.cx) / scene.camera.fx * z,
                       (y - scene.camera.cy) / scene.camera.fy * z, z};
  double v[3], l2 = 0.0;
  for (int i = 0; i < 3; ++i) v[i] = X[i] - light.position_in_camera_m[i], l2 += v[i] * v[i];
  const double l = std::sqrt(l2);
  const double axis_norm = cv::norm(light.axis_in_camera);
  double cos_phi = 0.0;
  for (int i = 0; i < 3; ++i) cos_phi += light.axis_in_camera[i] / axis_norm * v[i] / l;
  const double cos_psi = v[2] / l;  // -n.v/l with n = (0, 0, -1)
  const double m = -std::log(2.0) / std::log(std::cos(light.half_power_angle_deg * M_PI / 180.0));
  const double f =
      eq5 ? (cos_psi > 0 ? 1.0 / std::max(cos_psi, min_cos) : 0.0) : std::max(cos_psi, 0.0);
  return light.power * std::pow(std::max(cos_phi, 0.0), m) * f * std::exp(-beta * l) / l2;
}

TEST(Light, DefaultsPassCheckAndOrder) {
  std::string why;
  EXPECT_TRUE(LightOptions{}.Check(&why)) << why;
  EXPECT_TRUE(IrradianceOptions{}.Check(&why)) << why;
  EXPECT_NEAR(LambertianOrder(60.0), 1.0, 1e-12);
  EXPECT_NEAR(LambertianOrder(30.0), std::log(2.0) / -std::log(std::cos(M_PI / 6)), 1e-12);
}

TEST(Light, FrontoParallelPlaneMatchesClosedForm) {
  const Scene scene = testing::MakePlaneScene(48, 36, 1.5, 3, 40.0);
  for (bool eq5 : {false, true}) {
    IrradianceOptions options;
    options.incidence = eq5 ? IncidenceModel::kPaperEq5 : IncidenceModel::kLambertian;
    LightOptions a;
    a.position_in_camera_m = {0.1, 0.2, 0.0};
    a.axis_in_camera = {0.1, -0.1, 1.0};
    a.power = 3.0;
    a.half_power_angle_deg = 30.0;  // non-integer order
    a.color_rgb = {1.0, 0.5, 0.25};
    LightOptions b;
    b.position_in_camera_m = {-0.3, 0.0, 0.05};
    b.power = 2.0;  // 60 deg: m = 1
    options.lights = {a, b};
    const std::vector<double> beta = {0.9, 0.3, 0.1};  // B, G, R
    const cv::Mat e = IrradianceMap(options, scene.camera, scene.depth_m, scene.normals, beta);
    ASSERT_EQ(e.type(), CV_32FC3);
    for (int y = 0; y < 36; y += 5)
      for (int x = 0; x < 48; x += 5) {
        const double color_a[3] = {0.25, 0.5, 1.0};  // BGR
        for (int c = 0; c < 3; ++c) {
          const double expected = color_a[c] * PlaneIrradiance(scene, x, y, a, beta[c], eq5, 0.05) +
                                  PlaneIrradiance(scene, x, y, b, beta[c], eq5, 0.05);
          ASSERT_NEAR(e.at<cv::Vec3f>(y, x)[c], expected, 2e-5 * expected + 1e-7)
              << "eq5=" << eq5 << " " << x << "," << y << " c" << c;
        }
      }
    // Normals estimated from depth give the same answer on a plane.
    const cv::Mat e2 = IrradianceMap(options, scene.camera, scene.depth_m, cv::Mat(), beta);
    EXPECT_LT(cv::norm(e, e2, cv::NORM_INF), 1e-4);
  }
}

TEST(Light, GrazingTouchingAndBehindStayFinite) {
  const Scene scene = testing::MakePlaneScene(32, 24, 0.5, 1, 20.0);
  IrradianceOptions options;
  options.incidence = IncidenceModel::kPaperEq5;
  LightOptions touching;  // on the surface, pointing along it: l -> 0 and psi -> 90 deg
  touching.position_in_camera_m = {0.0, 0.0, 0.5};
  touching.axis_in_camera = {1.0, 0.0, 0.0};
  touching.power = 1e6;
  touching.half_power_angle_deg = 0.5;
  LightOptions behind;  // behind the surface: no light
  behind.position_in_camera_m = {0.0, 0.0, 5.0};
  behind.axis_in_camera = {0.0, 0.0, -1.0};
  options.lights = {touching, behind};
  for (IncidenceModel model : {IncidenceModel::kPaperEq5, IncidenceModel::kLambertian}) {
    options.incidence = model;
    const cv::Mat e = IrradianceMap(options, scene.camera, scene.depth_m, scene.normals, {10.0});
    EXPECT_TRUE(cv::checkRange(e, true, nullptr, 0.0, 1e30));
  }
  // The guard caps 1/cos(psi) at 1/min_cos_incidence.
  IrradianceOptions grazing;
  LightOptions side;
  side.position_in_camera_m = {-100.0, 0.0, 0.5 - 1e-6};
  side.axis_in_camera = {1.0, 0.0, 0.0};
  grazing.lights = {side};
  grazing.incidence = IncidenceModel::kPaperEq5;
  const auto at = IrradianceAtPoint(grazing, {0, 0, 0.5}, cv::Vec3d(0, 0, -1), {0.0});
  EXPECT_NEAR(at[0], side.power / (100.0 * 100.0) / grazing.min_cos_incidence, 1e-6);
}

TEST(Light, RejectsBadOptions) {
  LightOptions light;
  std::string why;
  light.half_power_angle_deg = 90.0;
  EXPECT_FALSE(light.Check(&why));
  light = {};
  light.axis_in_camera = {0, 0, 0};
  EXPECT_FALSE(light.Check(&why));
  light = {};
  light.power = std::nan("");
  EXPECT_FALSE(light.Check(&why));
  EXPECT_THROW(IncidenceModelFromName("phong"), Error);
}

TEST(Psf, DefaultsPassCheck) {
  std::string why;
  EXPECT_TRUE(PsfOptions{}.Check(&why)) << why;
}

TEST(Psf, IncompleteGammaClosedForms) {
  for (double x : {0.01, 0.5, 1.0, 3.0, 10.0, 40.0}) {
    EXPECT_NEAR(RegularizedGammaP(1.0, x), 1.0 - std::exp(-x), 1e-13) << x;
    EXPECT_NEAR(RegularizedGammaP(0.5, x), std::erf(std::sqrt(x)), 1e-13) << x;
    EXPECT_NEAR(RegularizedGammaP(2.0, x), 1.0 - (1.0 + x) * std::exp(-x), 1e-13) << x;
  }
}

TEST(Psf, SumsToOneSymmetricAndGaussianAtP2) {
  PsfOptions options;  // paper: T = 4 (p = 2), q = 0.9
  options.pixels_per_unit = 3.0;
  const Psf psf = PsfKernel(options);
  ASSERT_TRUE(psf.separable);
  ASSERT_FALSE(psf.is_delta);
  EXPECT_NEAR(cv::sum(psf.kernel)[0], 1.0, 1e-6);
  const double sigma = 0.5 / std::sqrt(0.9) * 3.0;
  EXPECT_NEAR(psf.sigma_px, sigma, 1e-12);
  const int r = psf.radius_px;
  // Gaussian of standard deviation sigma, truncated to the same square and normalised.
  double total = 0.0;
  for (int j = -r; j <= r; ++j)
    for (int i = -r; i <= r; ++i) total += std::exp(-(i * i + j * j) / (2 * sigma * sigma));
  for (int j = -r; j <= r; ++j)
    for (int i = -r; i <= r; ++i) {
      const double g = std::exp(-(i * i + j * j) / (2 * sigma * sigma)) / total;
      ASSERT_NEAR(psf.kernel.at<float>(j + r, i + r), g, 1e-6);
      // Radial symmetry: the 8 symmetric positions agree.
      const float k = psf.kernel.at<float>(j + r, i + r);
      ASSERT_EQ(k, psf.kernel.at<float>(-j + r, i + r));
      ASSERT_EQ(k, psf.kernel.at<float>(i + r, j + r));
    }
  // The tail beyond the truncation radius is below tail_mass: 2-D Gaussian tail exp(-R^2/2s^2).
  EXPECT_LE(std::exp(-r * r / (2 * sigma * sigma)), options.tail_mass * 1.0001);
  EXPECT_GT(std::exp(-(r - 1) * (r - 1) / (2 * sigma * sigma)), options.tail_mass);
}

TEST(Psf, NonGaussianIsRadialAndNormalised) {
  PsfOptions options;
  options.optical_thickness = 1.0;  // p = 1: Laplacian-like, heavy tail
  options.forward_scatter = 0.3;
  options.pixels_per_unit = 2.0;
  const Psf psf = PsfKernel(options);
  EXPECT_FALSE(psf.separable);
  EXPECT_NEAR(cv::sum(psf.kernel)[0], 1.0, 1e-6);
  const int r = psf.radius_px;
  ASSERT_GE(r, 5);
  // Points at equal radius 5: (3, 4) and (5, 0).
  EXPECT_NEAR(psf.kernel.at<float>(r + 4, r + 3), psf.kernel.at<float>(r, r + 5), 1e-9);
  EXPECT_NEAR(psf.kernel.at<float>(r + 4, r + 3) / psf.kernel.at<float>(r, r),
              PsfProfile(psf.p, psf.scale_a_px, 5.0), 1e-6);
}

TEST(Psf, SeparableEqualsFilter2DAndDeltaIsIdentity) {
  cv::Mat image(37, 53, CV_32FC3);
  cv::randu(image, 0.0, 1.0);
  PsfOptions options;
  options.pixels_per_unit = 2.5;
  const Psf psf = PsfKernel(options);
  cv::Mat reference;
  cv::filter2D(image, reference, CV_32F, psf.kernel, cv::Point(-1, -1), 0, cv::BORDER_REFLECT_101);
  EXPECT_LT(cv::norm(ApplyPsf(psf, image), reference, cv::NORM_INF), 1e-5);
  options.pixels_per_unit = 0.1;  // sigma 0.05 px: a delta
  const Psf delta = PsfKernel(options);
  EXPECT_TRUE(delta.is_delta);
  EXPECT_EQ(cv::norm(ApplyPsf(delta, image), image, cv::NORM_INF), 0.0);
}

TEST(Psf, ExtremesStayFinite) {
  for (double t : {1e-4, 0.01, 1.0, 4.0, 100.0})
    for (double q : {1e-6, 0.01, 0.5, 1.0}) {
      PsfOptions options;
      options.optical_thickness = t;
      options.forward_scatter = q;
      options.max_radius_px = 40;
      const Psf psf = PsfKernel(options);
      ASSERT_TRUE(cv::checkRange(psf.kernel)) << t << " " << q;
      ASSERT_NEAR(cv::sum(psf.kernel)[0], 1.0, 1e-5) << t << " " << q;
      ASSERT_LE(psf.radius_px, 40);
      ASSERT_TRUE(std::isfinite(psf.tail_mass_outside));
    }
  PsfOptions bad;
  bad.forward_scatter = 0.0;
  EXPECT_THROW(PsfKernel(bad), Error);
  bad = {};
  bad.optical_thickness = -1.0;
  EXPECT_THROW(PsfKernel(bad), Error);
}

TEST(Psf, DepthDependentEqualsFixedAtReferenceRange) {
  cv::Mat image(20, 24, CV_32FC1);
  cv::randu(image, 0.0, 1.0);
  PsfOptions options;
  options.pixels_per_unit = 2.0;
  options.depth_dependent = true;
  const cv::Mat range(20, 24, CV_32FC1, cv::Scalar(options.reference_range_m));
  EXPECT_LT(cv::norm(ApplyDepthDependentPsf(options, image, range),
                     ApplyPsf(PsfKernel(options), image), cv::NORM_INF),
            1e-6);
  // Wider with range: far half blurs more (lower variance of the result).
  cv::Mat ramp(20, 24, CV_32FC1);
  for (int y = 0; y < 20; ++y) ramp.row(y).setTo(y < 10 ? 0.5 : 8.0);
  const cv::Mat out = ApplyDepthDependentPsf(options, image, ramp);
  cv::Scalar m1, s1, m2, s2;
  cv::meanStdDev(out(cv::Rect(0, 2, 24, 6)), m1, s1);
  cv::meanStdDev(out(cv::Rect(0, 12, 24, 6)), m2, s2);
  EXPECT_GT(s1[0], s2[0]);
}

TEST(Noise, DefaultsPassCheck) {
  std::string why;
  EXPECT_TRUE(SnowOptions{}.Check(&why)) << why;
  EXPECT_TRUE(SensorNoiseOptions{}.Check(&why)) << why;
}

TEST(Noise, NormalsAreStandardAndCounterBased) {
  const uint64_t key = RandomKey(42, 7);
  std::vector<float> all(200000);
  RandomNormals(key, 0, static_cast<int>(all.size()), all.data());
  double sum = 0, sum2 = 0;
  for (float v : all) sum += v, sum2 += static_cast<double>(v) * v;
  const double n = static_cast<double>(all.size());
  EXPECT_NEAR(sum / n, 0.0, 4.0 / std::sqrt(n));
  EXPECT_NEAR(sum2 / n, 1.0, 0.015);
  std::vector<float> slice(7);
  RandomNormals(key, 1001, 7, slice.data());  // odd start: sample i depends only on (key, i)
  for (int i = 0; i < 7; ++i) EXPECT_EQ(slice[i], all[1001 + i]);
  EXPECT_NE(RandomBits(RandomKey(1, 0), 0), RandomBits(RandomKey(2, 0), 0));
}

TEST(Noise, SensorMeanAndVarianceMatchParameters) {
  SensorNoiseOptions options;
  options.photons_at_white = 1000.0;
  options.read_noise = 0.01;
  for (float level : {0.0f, 0.3f, 0.8f}) {
    const cv::Mat image(300, 300, CV_32FC1, cv::Scalar(level));
    const cv::Mat noisy = AddSensorNoise(options, image, 5);
    cv::Scalar mean, stddev;
    cv::meanStdDev(noisy, mean, stddev);
    const double variance = level / 1000.0 + 1e-4;
    EXPECT_NEAR(mean[0], level, 4.0 * std::sqrt(variance / 90000.0)) << level;
    EXPECT_NEAR(stddev[0] * stddev[0], variance, 0.03 * variance) << level;
  }
}

TEST(Noise, SensorNoiseIsThreadCountIndependent) {
  cv::Mat image(123, 77, CV_32FC3);
  cv::randu(image, 0.0, 1.0);
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);
  const cv::Mat one = AddSensorNoise({}, image, 9);
  cv::setNumThreads(2);
  const cv::Mat many = AddSensorNoise({}, image, 9);
  cv::setNumThreads(threads);
  EXPECT_EQ(cv::norm(one, many, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(AddSensorNoise({}, image, 10), one, cv::NORM_INF), 0.0);
}

TEST(Noise, SnowIsSeededLitAndHiddenBehindSurface) {
  const Scene scene = testing::MakePlaneScene(64, 48, 1.0, 3, 50.0);
  const cv::Mat range = RangeFromDepth(scene.camera, scene.depth_m);
  SnowOptions options;
  options.density_per_m3 = 2000.0;
  IrradianceOptions lights;
  const MarineSnow a =
      RenderMarineSnow(options, lights, scene.camera, range, {0.1, 0.1, 0.1}, {0.1, 0.1, 0.1}, 3);
  const MarineSnow b =
      RenderMarineSnow(options, lights, scene.camera, range, {0.1, 0.1, 0.1}, {0.1, 0.1, 0.1}, 3);
  EXPECT_EQ(cv::norm(a.layer, b.layer, cv::NORM_INF), 0.0);
  EXPECT_GT(a.particles, 0);
  EXPECT_GT(a.visible, 0);
  EXPECT_LT(a.visible, a.particles);  // the plane at 1 m hides particles between 1 m and far_m
  // Expected count: density x frustum volume (z from near to far).
  const double volume = (64 / 50.0) * (48 / 50.0) * (std::pow(4.0, 3) - std::pow(0.2, 3)) / 3.0;
  EXPECT_EQ(a.particles, static_cast<int>(std::llround(2000.0 * volume)));
  EXPECT_TRUE(cv::checkRange(a.layer, true, nullptr, 0.0, 1e6));
  EXPECT_GT(cv::norm(a.layer, cv::NORM_INF), 0.0);
  options.density_per_m3 = 1e5;
  options.far_m = 1000.0;
  EXPECT_THROW(
      RenderMarineSnow(options, lights, scene.camera, range, {0.1, 0.1, 0.1}, {0.1, 0.1, 0.1}, 3),
      Error);
}

}  // namespace
}  // namespace turbid

namespace turbid {
namespace {

// E_L on a tilted plane (normal not along the optical axis, so cos psi varies across the image
// and differs from the fronto-parallel case) against the closed form of SPEC's eq.: U0 cos^m(phi)
// f(psi) exp(-beta l) / l^2 with cos psi = -n . v / l.
TEST(Light, TiltedPlaneMatchesClosedForm) {
  const int w = 48, h = 36;
  Scene scene = testing::MakePlaneScene(w, h, 2.0, 3, 40.0);
  const cv::Vec3d n = cv::normalize(cv::Vec3d(0.4, -0.3, -1.0));  // faces the camera
  const cv::Vec3d p0(0.0, 0.0, 2.0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const cv::Vec3d ray((x - scene.camera.cx) / scene.camera.fx,
                          (y - scene.camera.cy) / scene.camera.fy, 1.0);
      scene.depth_m.at<float>(y, x) = static_cast<float>(n.dot(p0) / n.dot(ray));
      scene.normals.at<cv::Vec3f>(y, x) = cv::Vec3f(n);
    }
  LightOptions light;
  light.position_in_camera_m = {0.15, 0.25, 0.0};
  light.axis_in_camera = {0.0, -0.1, 1.0};
  light.power = 4.0;
  light.half_power_angle_deg = 40.0;
  IrradianceOptions options;
  options.lights = {light};
  const double m = LambertianOrder(light.half_power_angle_deg);
  const std::vector<double> beta = {0.2, 0.5, 0.8};
  const cv::Mat e = IrradianceMap(options, scene.camera, scene.depth_m, scene.normals, beta);
  const cv::Mat e_est = IrradianceMap(options, scene.camera, scene.depth_m, cv::Mat(), beta);
  const cv::Vec3d axis = cv::normalize(light.axis_in_camera);
  double lo_cos = 1, hi_cos = 0;
  for (int y = 0; y < h; y += 3)
    for (int x = 0; x < w; x += 3) {
      const double z = scene.depth_m.at<float>(y, x);
      const cv::Vec3d point((x - scene.camera.cx) / scene.camera.fx * z,
                            (y - scene.camera.cy) / scene.camera.fy * z, z);
      const cv::Vec3d v = point - light.position_in_camera_m;
      const double l = cv::norm(v);
      const double cos_phi = std::max(axis.dot(v) / l, 0.0);
      const double cos_psi = std::max(-n.dot(v) / l, 0.0);
      lo_cos = std::min(lo_cos, cos_psi), hi_cos = std::max(hi_cos, cos_psi);
      for (int c = 0; c < 3; ++c) {
        const double expected =
            light.power * std::pow(cos_phi, m) * cos_psi * std::exp(-beta[c] * l) / (l * l);
        ASSERT_NEAR(e.at<cv::Vec3f>(y, x)[c], expected, 2e-5 * expected + 1e-7) << x << "," << y;
        if (x > 0 && y > 0 && x < w - 1 && y < h - 1)  // normals from depth: central differences
          ASSERT_NEAR(e_est.at<cv::Vec3f>(y, x)[c], expected, 1e-3 * expected + 1e-6);
      }
    }
  EXPECT_GT(hi_cos - lo_cos, 0.05) << "the tilt must make cos psi vary";
}

}  // namespace
}  // namespace turbid
