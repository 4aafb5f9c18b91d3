// psf.model "small_angle" (simulator/psf_small_angle.h): closed forms of the energy and width,
// the channel order of the blur, the focal-length scaling, any kernel at any image size, and the
// slow per-pixel reference (reference_small_angle.h) per water type and scene.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <map>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "core/error.h"
#include "scenes/builtin.h"
#include "simulator/psf_small_angle.h"
#include "simulator/render.h"
#include "tests/simulator/reference_small_angle.h"
#include "tests/simulator/test_scenes.h"
#include "tests/support/asan.h"

namespace turbid {
namespace {

constexpr double kPi = 3.14159265358979323846;

// b and c (1/m) of Jerlov types at 650, 550, 450 nm (R, G, B): Solonenko & Mobley, Appl. Opt.
// 54(17) 5392 (2015), as in veil_test.cc (checked against the data there).
struct Iop {
  const char* type;
  Rgb b, c;
};
const Iop kWaters[] = {
    {"I", {0.000899, 0.0017, 0.00381}, {0.334899, 0.0637, 0.02181}},
    {"II", {0.27, 0.358, 0.504}, {0.604, 0.4202, 0.5281}},
    {"3C", {0.8, 1.06, 1.5}, {1.146, 1.142, 1.654}},
    {"9C", {2.35, 3.12, 4.39}, {2.806, 3.468, 5.333}},
};

VeilWater Water(const Iop& iop) {
  VeilWater w;
  w.b_per_m = ChannelValues(iop.b, 0.0, 3);
  w.c_per_m = ChannelValues(iop.c, 0.0, 3);
  return w;  // Fournier-Forand, b_b/b = 0.0183
}

// A plane at uniform *range* R (depth R / |K^-1 [u v 1]|), fx = fy = focal_px.
cv::Mat UniformRange(int width, int height, double range_m) {
  return cv::Mat(height, width, CV_32FC1, cv::Scalar(range_m));
}

CameraIntrinsics Camera(int width, int height, double focal_px) {
  return {focal_px, focal_px, (width - 1) / 2.0, (height - 1) / 2.0, width, height};
}

TEST(SmallAnglePsf, WidthClosedFormsForIsotropicScattering) {
  // Isotropic: b_b/b = 1/2, <theta^2> within 90 degrees = int_0^{pi/2} t^2 sin t dt = pi - 2.
  VeilWater w;
  w.c_per_m = {1.0};
  w.b_per_m = {0.6};
  w.phase.model = "isotropic";
  const SmallAngleChannel ch = SmallAngleChannels(w)[0];
  EXPECT_NEAR(ch.forward_per_m, 0.3, 1e-6);
  EXPECT_NEAR(ch.mean_square_angle_rad2, kPi - 2.0, 1e-5);
  // <psi^2> = b_f r <theta^2> / (3 (1 - e^{-b_f r})): <theta^2> / 3 as r -> 0 (one scattering,
  // uniform along the path: the mean of (1 - s/r)^2 is 1/3).
  EXPECT_NEAR(GlowMeanSquareAngle(ch, 0.0), (kPi - 2.0) / 3.0, 1e-9);
  EXPECT_NEAR(GlowMeanSquareAngle(ch, 5.0), 1.5 * (kPi - 2.0) / (3.0 * (1 - std::exp(-1.5))), 1e-9);
  EXPECT_NEAR(GlowFactor(ch, 5.0), std::exp(1.5) - 1.0, 1e-8);
  EXPECT_EQ(GlowFactor(ch, std::nan("")), 0.0);
}

// A point source of 1 at the centre of an n x n image at uniform range: (out - J) is the glow
// (relative to the ballistic e^{-c r}).
cv::Mat PointGlow(const VeilWater& w, int n, double focal_px, double range_m) {
  cv::Mat j(n, n, CV_32FC(static_cast<int>(w.c_per_m.size())), cv::Scalar::all(0));
  for (int c = 0; c < j.channels(); ++c) j.ptr<float>(n / 2)[(n / 2) * j.channels() + c] = 1.0f;
  PsfOptions o;
  o.model = PsfModel::kSmallAngle;
  cv::Mat out = ApplySmallAnglePsf(o, w, Camera(n, n, focal_px), UniformRange(n, n, range_m), j);
  return out - j;
}

TEST(SmallAnglePsf, EnergyBookkeepingBallisticPlusGlow) {
  VeilWater w;
  w.c_per_m = {0.9, 0.7, 0.5};
  w.b_per_m = {0.7, 0.4, 0.1};
  const double r = 2.5;
  const cv::Mat glow = PointGlow(w, 161, 20.0, r);
  const std::vector<SmallAngleChannel> chans = SmallAngleChannels(w);
  std::vector<cv::Mat> planes;
  cv::split(glow, planes);
  for (int c = 0; c < 3; ++c) {
    const double t = std::exp(-w.c_per_m[c] * r);
    const double bf = chans[c].forward_per_m;
    // Received: ballistic t J (the delta) + t (e^{b_f r} - 1) G J summing to the closed form.
    const double glow_energy = t * cv::sum(planes[c])[0];
    const double expected = std::exp(-(w.c_per_m[c] - bf) * r) - std::exp(-w.c_per_m[c] * r);
    EXPECT_NEAR(glow_energy / expected, 1.0, 1e-5) << "channel " << c;
    EXPECT_NEAR(bf, w.b_per_m[c] * (1 - 0.0183), 2e-5 * w.b_per_m[c]);
    // The glow's second moment in pixels^2 is fx^2 <psi^2> (2-D).
    double m2 = 0.0, m0 = 0.0;
    for (int y = 0; y < 161; ++y)
      for (int x = 0; x < 161; ++x) {
        const double v = planes[c].at<float>(y, x), dx = x - 80, dy = y - 80;
        m0 += v, m2 += v * (dx * dx + dy * dy);
      }
    EXPECT_NEAR(m2 / m0 / (400.0 * GlowMeanSquareAngle(chans[c], r)), 1.0, 1e-3) << c;
  }
}

TEST(SmallAnglePsf, FiguresAtTheDefaults) {
  // docs/model.md quotes these: beta = 0.7, omega = 0.8, Fournier-Forand b_b/b = 0.0183.
  VeilWater w;
  w.c_per_m = {0.7};
  w.b_per_m = {0.56};
  const SmallAngleChannel ch = SmallAngleChannels(w)[0];
  std::cout << "b_f = " << ch.forward_per_m
            << " 1/m, <theta^2> within 90 deg = " << ch.mean_square_angle_rad2 << " rad^2\n";
  for (double r : {0.5, 1.0, 2.0, 5.0, 10.0}) {
    const double rms = std::sqrt(GlowMeanSquareAngle(ch, r));
    std::cout << "r = " << r << " m: glow / ballistic = " << GlowFactor(ch, r)
              << ", glow share of the received = " << GlowFactor(ch, r) / (1 + GlowFactor(ch, r))
              << ", rms angle = " << rms << " rad (" << rms * 180 / kPi
              << " deg), sigma per axis at fx = 500 px: " << 500 * rms / std::sqrt(2.0) << " px\n";
  }
  EXPECT_NEAR(ch.forward_per_m, 0.56 * (1 - 0.0183), 1e-5);
  EXPECT_GT(ch.mean_square_angle_rad2, 0.0);
  EXPECT_LT(ch.mean_square_angle_rad2, kPi - 2.0);  // more forward-peaked than isotropic
}

TEST(SmallAnglePsf, PixelWidthScalesWithTheFocalLength) {
  VeilWater w;
  w.c_per_m = {0.8};
  w.b_per_m = {0.6};
  auto rms_px = [&](double focal) {
    const cv::Mat g = PointGlow(w, 201, focal, 3.0);
    double m2 = 0.0, m0 = 0.0;
    for (int y = 0; y < 201; ++y)
      for (int x = 0; x < 201; ++x) {
        const double v = g.at<float>(y, x);
        m0 += v, m2 += v * ((x - 100.0) * (x - 100.0) + (y - 100.0) * (y - 100.0));
      }
    return std::sqrt(m2 / m0);
  };
  // Half the image scale: half the pixel width (not a fixed width in pixels).
  const double full = rms_px(24.0), half = rms_px(12.0);
  EXPECT_NEAR(full / half, 2.0, 2e-3) << full << " px vs " << half << " px";
}

TEST(SmallAnglePsf, BlurFollowsScatteringNotAttenuation) {
  // Red attenuates most (absorption) but scatters least: its blur must be the weakest. The
  // fraction of a point's received light that leaves its pixel grows with b.
  VeilWater w;
  w.c_per_m = {1.2, 0.5, 0.4};  // image order B, G, R -> here channel 0 is B
  w.b_per_m = {0.35, 0.3, 0.05};
  const cv::Mat glow = PointGlow(w, 121, 20.0, 2.0);
  double spread[3];
  for (int c = 0; c < 3; ++c) {
    const double total_glow = cv::sum(glow)[c];
    const double direct = 1.0;  // relative to the ballistic
    spread[c] = (total_glow - glow.at<cv::Vec3f>(60, 60)[c]) / (direct + total_glow);
  }
  EXPECT_GT(spread[0], spread[1]);
  EXPECT_GT(spread[1], spread[2]);
  EXPECT_GT(spread[2], 0.0);
  // Through the renderer: the channel with the largest b loses most of its Laplacian energy.
  const Scene scene = testing::MakePlaneScene(64, 48, 2.0, 3, 60.0);
  RenderOptions o;
  o.light.lights.clear();
  o.snow.enabled = false;
  o.sensor.enabled = false;
  o.camera.bit_depth = 32;
  o.water.beta_rgb_per_m = {0.4, 0.5, 1.2};               // R, G, B: blue attenuates most here
  o.water.scattering_albedo_rgb = {0.125, 0.6, 0.29167};  // b = 0.05, 0.3, 0.35 (R, G, B)
  o.psf.model = PsfModel::kSmallAngle;
  o.maps.transmission = true;
  const RenderResult res = Render(o, scene);
  // A wide glow is a haze more than a local blur: the loss is in contrast, |Laplacian| / mean,
  // against the unscattered J t.
  double loss[3];
  for (int c = 0; c < 3; ++c) {
    cv::Mat img, ref, t, li, lr;
    cv::extractChannel(res.image, img, c);
    cv::extractChannel(res.lit, ref, c);
    cv::extractChannel(res.transmission, t, c);
    ref = ref.mul(t);
    cv::Laplacian(img, li, CV_32F);
    cv::Laplacian(ref, lr, CV_32F);
    loss[c] = 1.0 - (cv::norm(li) / cv::sum(img)[0]) / (cv::norm(lr) / cv::sum(ref)[0]);
  }
  // Image order B, G, R: b = 0.35, 0.3, 0.05.
  EXPECT_GT(loss[0], loss[1]);
  EXPECT_GT(loss[1], loss[2]);
}

TEST(SmallAnglePsf, AnyKernelSizeAtAnyImageSize) {
  cv::RNG rng(7);
  for (const cv::Size size : {cv::Size(1, 1), cv::Size(1, 6), cv::Size(5, 1), cv::Size(2, 3),
                              cv::Size(7, 4), cv::Size(13, 9)}) {
    cv::Mat plane(size, CV_32FC1);
    rng.fill(plane, cv::RNG::UNIFORM, 0.0, 1.0);
    for (double sigma : {0.0, 0.3, 0.9, 2.5, 40.0, 300.0}) {
      const cv::Mat fast = MirroredGaussianBlur(plane, sigma, 0.7 * sigma);
      for (int y = 0; y < size.height; ++y)
        for (int x = 0; x < size.width; ++x)
          ASSERT_NEAR(fast.at<float>(y, x),
                      testing::ReferenceGaussianAt(plane, 0, x, y, sigma, 0.7 * sigma), 2e-6)
              << size << " sigma " << sigma << " at " << x << "," << y;
    }
    // The whole model at uniform range (one width: exact) and at a focal length that makes the
    // kernel far wider than the image.
    VeilWater w;
    w.c_per_m = {1.0};
    w.b_per_m = {0.8};
    const CameraIntrinsics cam = Camera(size.width, size.height, 500.0);
    const cv::Mat range = UniformRange(size.width, size.height, 3.0);
    PsfOptions o;
    o.model = PsfModel::kSmallAngle;
    const cv::Mat fast = ApplySmallAnglePsf(o, w, cam, range, plane);
    const cv::Mat slow = testing::ReferenceSmallAnglePsf(w, cam, range, plane);
    for (int y = 0; y < size.height; ++y)
      for (int x = 0; x < size.width; ++x)
        ASSERT_NEAR(fast.at<float>(y, x), slow.at<double>(y, x), 1e-5) << size;
  }
}

// Mean relative error of the glow, (fast - J) against (reference - J), where the reference glow
// is above 1e-6 of its maximum.
double MeanGlowError(const cv::Mat& fast, const cv::Mat& slow, const cv::Mat& j) {
  const int n = j.cols * j.channels();
  double max_ref = 0.0, sum = 0.0;
  int count = 0;
  for (int y = 0; y < j.rows; ++y)
    for (int i = 0; i < n; ++i)
      max_ref = std::max(max_ref, slow.ptr<double>(y)[i] - j.ptr<float>(y)[i]);
  for (int y = 0; y < j.rows; ++y)
    for (int i = 0; i < n; ++i) {
      const double ref = slow.ptr<double>(y)[i] - j.ptr<float>(y)[i];
      if (ref <= 1e-6 * max_ref) continue;
      const double got = static_cast<double>(fast.ptr<float>(y)[i]) - j.ptr<float>(y)[i];
      sum += std::abs(got - ref) / ref, ++count;
    }
  return count ? sum / count : 0.0;
}

// The scenes of the table: a frontal plane at 2 m, the built-in hull and seafloor reduced to
// 40 px wide with their own intrinsics (the glow spans a few pixels to the whole image).
std::map<std::string, Scene> ErrorScenes() {
  std::map<std::string, Scene> out;
  out["plane 2 m"] = testing::MakePlaneScene(40, 30, 2.0, 3, 48.0);
  for (const char* name : {"hull", "seafloor"}) {
    BuiltinSceneOptions options;
    options.scale = 40.0 / BuiltinSceneCamera(name).width;
    Scene s = MakeBuiltinScene(name, options);
    if (s.image.channels() == 1) cv::cvtColor(s.image, s.image, cv::COLOR_GRAY2BGR);
    out[name] = s;
  }
  return out;
}

#ifdef TURBID_TEST_ASAN
constexpr int kScenesChecked = 1;
#else
constexpr int kScenesChecked = 1000;
#endif

TEST(SmallAnglePsf, GlowMatchesTheReferencePerWaterTypeAndScene) {
  // The error table of docs/model.md "Small-angle forward scatter" (printed here).
  std::ostringstream table;
  table << "| scene | I | II | 3C | 9C |\n|---|---|---|---|---|\n";
  int scenes_left = kScenesChecked;
  PsfOptions o;
  o.model = PsfModel::kSmallAngle;
  for (const auto& [name, scene] : ErrorScenes()) {
    if (scenes_left-- == 0) break;
    const cv::Mat range = RangeFromDepth(scene.camera, scene.depth_m);
    table << "| " << name;
    for (const Iop& iop : kWaters) {
      const VeilWater w = Water(iop);
      const cv::Mat fast = ApplySmallAnglePsf(o, w, scene.camera, range, scene.image);
      const cv::Mat slow = testing::ReferenceSmallAnglePsf(w, scene.camera, range, scene.image);
      const double error = MeanGlowError(fast, slow, scene.image);
      table << " | " << 100 * error << " %";
      EXPECT_LT(error, 0.01) << name << ", water " << iop.type;
    }
    table << " |\n";
  }
  std::cout << table.str();
}

TEST(SmallAnglePsf, RendersThroughTheOptionsAndComposesWithTransmission) {
  const Scene scene = testing::MakePlaneScene(32, 24, 1.5, 3, 40.0);
  RenderOptions o = RenderOptionsFromJson(nlohmann::json::parse(
      R"({"psf": {"model": "small_angle"}, "snow": {"enabled": false},
          "sensor": {"enabled": false}, "camera": {"bit_depth": 32}, "light": {"lights": []}})"));
  EXPECT_EQ(o.psf.model, PsfModel::kSmallAngle);
  EXPECT_EQ(RenderOptionsToJson(o)["psf"]["model"], "small_angle");
  const RenderResult r = Render(o, scene);
  VeilWater w;
  w.c_per_m = {0.7, 0.7, 0.7};
  w.b_per_m = {0.56, 0.56, 0.56};
  const cv::Mat range = RangeFromDepth(scene.camera, scene.depth_m);
  const cv::Mat blurred = ApplySmallAnglePsf(o.psf, w, scene.camera, range, r.lit);
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 32; ++x)
      for (int c = 0; c < 3; ++c) {
        const double t = std::exp(-0.7 * range.at<float>(y, x));
        ASSERT_NEAR(r.image.at<cv::Vec3f>(y, x)[c],
                    std::min(1.0, blurred.at<cv::Vec3f>(y, x)[c] * t), 2e-6);
      }
  const std::string plan = r.plan.ToText();
  EXPECT_NE(plan.find("psf: small_angle"), std::string::npos) << plan;
  // Eq. 7's range models do not combine with it.
  o.psf.turbidity_dependent = true;
  EXPECT_THROW(Render(o, scene), Error);
  EXPECT_THROW(RenderOptionsFromJson(nlohmann::json::parse(R"({"psf": {"model": "wide"}})")),
               Error);
  EXPECT_EQ(PsfOptions{}.model, PsfModel::kPaper);
}

}  // namespace
}  // namespace turbid
