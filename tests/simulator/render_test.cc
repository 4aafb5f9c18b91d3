// The composed forward model: identities, JSON binding, determinism, caches and a seeded stress
// sweep over the accepted parameter space (issue 3 items 5 and 6).
#include "simulator/render.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <thread>

#include "scenes/builtin.h"
#include "core/error.h"
#include "test_scenes.h"

namespace turbid {
namespace {

RenderOptions Bare() {
  RenderOptions o;
  o.water.beta_rgb_per_m = {0, 0, 0};
  o.water.beta_gray_per_m = 0;
  o.water.ambient_rgb = {1, 1, 1};
  o.water.ambient_gray = 1;
  o.light.lights.clear();
  o.psf.enabled = false;
  o.snow.enabled = false;
  o.sensor.enabled = false;
  o.camera.bit_depth = 32;
  return o;
}

TEST(Render, DefaultsPassCheck) {
  std::string why;
  EXPECT_TRUE(RenderOptions{}.Check(&why)) << why;
  EXPECT_TRUE(CameraOutputOptions{}.Check(&why)) << why;
}

TEST(Render, ZeroBetaNoLightNoPsfNoNoiseIsIdentity) {
  for (int channels : {1, 3}) {
    const Scene scene = testing::MakePlaneScene(31, 17, 2.0, channels);
    const RenderResult r = Render(Bare(), scene);
    EXPECT_EQ(cv::norm(r.image, scene.image, cv::NORM_INF), 0.0) << channels;
    EXPECT_EQ(cv::norm(r.lit, scene.image, cv::NORM_INF), 0.0);
    EXPECT_FALSE(r.plan.skipped.empty());
  }
}

TEST(Render, ComposesEquationTwoOnAPlane) {
  const Scene scene = testing::MakePlaneScene(40, 30, 1.5, 3, 40.0);
  RenderOptions o = Bare();
  o.water.beta_rgb_per_m = {0.9, 0.5, 0.2};
  o.water.ambient_rgb = {0.1, 0.2, 0.3};
  o.light.lights = {LightOptions{}};
  o.maps = MapSelection::FromList("transmission,light,veil");
  const RenderResult r = Render(o, scene);
  const std::vector<double> beta = {0.2, 0.5, 0.9}, ambient = {0.3, 0.2, 0.1};  // BGR
  const cv::Mat e_l = IrradianceMap(o.light, scene.camera, scene.depth_m, scene.normals, beta);
  const cv::Mat t = TransmissionMap(RangeFromDepth(scene.camera, scene.depth_m), beta);
  for (int y = 0; y < 30; y += 3)
    for (int x = 0; x < 40; x += 3)
      for (int c = 0; c < 3; ++c) {
        const double rho = scene.image.at<cv::Vec3f>(y, x)[c], e = e_l.at<cv::Vec3f>(y, x)[c];
        const double tt = t.at<cv::Vec3f>(y, x)[c];
        const double expected = std::clamp((ambient[c] + e) * rho * tt + (1 - tt) * e, 0.0, 1.0);
        ASSERT_NEAR(r.image.at<cv::Vec3f>(y, x)[c], expected, 1e-5);
        ASSERT_NEAR(r.veil.at<cv::Vec3f>(y, x)[c], (1 - tt) * e, 1e-6);
      }
  EXPECT_LT(cv::norm(r.transmission, t, cv::NORM_INF), 1e-7);
  EXPECT_LT(cv::norm(r.light, e_l, cv::NORM_INF), 1e-7);
}

TEST(Render, InvalidDepthIsOpenWater) {
  Scene scene = testing::MakePlaneScene(20, 10, 2.0, 3);
  scene.depth_m.at<float>(3, 4) = std::nanf("");
  scene.normals.at<cv::Vec3f>(3, 4) = cv::Vec3f(NAN, NAN, NAN);
  RenderOptions o = Bare();
  o.water.beta_rgb_per_m = {0.3, 0.3, 0.3};
  o.water.backscatter = true;
  o.light.lights = {LightOptions{}};
  o.maps.transmission = true;
  const RenderResult r = Render(o, scene);
  const cv::Vec3f b = r.image.at<cv::Vec3f>(3, 4);
  EXPECT_EQ(r.transmission.at<cv::Vec3f>(3, 4)[0], 0.0f);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(b[c], o.water.backscatter_rgb[2 - c], 1e-6);
}

TEST(Render, UniformRangeAndSkipPathsAgreeWithGeneralPath) {
  // Constant range (a sphere around the camera) takes the constant-t path; compare with the map.
  Scene scene = testing::MakePlaneScene(24, 18, 2.0, 3);
  for (int y = 0; y < 18; ++y)
    for (int x = 0; x < 24; ++x) {
      const cv::Vec3d ray = scene.camera.Ray(x, y);
      scene.depth_m.at<float>(y, x) = static_cast<float>(3.0 / cv::norm(ray));
    }
  RenderOptions o = Bare();
  o.water.beta_rgb_per_m = {0.4, 0.2, 0.1};
  o.light.lights = {LightOptions{}};
  Renderer renderer(scene);
  const RenderResult r = renderer.Render(o);
  bool uniform = false;
  for (const auto& s : r.plan.steps)
    uniform = uniform || s.find("uniform range") != std::string::npos;
  EXPECT_TRUE(uniform) << r.plan.ToText();
  o.maps.transmission = true;
  const RenderResult r2 = renderer.Render(o);
  const std::vector<double> beta = {0.1, 0.2, 0.4};
  const cv::Mat t = TransmissionMap(renderer.range_m(), beta);
  EXPECT_LT(cv::norm(r2.transmission, t, cv::NORM_INF), 1e-6);
}

TEST(Render, JsonRoundTripAndStrictErrors) {
  RenderOptions o;
  o.water.type = "C3";
  o.seed = 12345678901234ULL;
  o.psf.optical_thickness = 2.0;
  o.light.incidence = IncidenceModel::kPaperEq5;
  o.light.lights.push_back(LightOptions{});
  o.light.lights[1].position_in_camera_m = {0.3, -0.1, 0.0};
  const nlohmann::json j = RenderOptionsToJson(o);
  const RenderOptions back = RenderOptionsFromJson(j);
  EXPECT_EQ(back.water.type, "3C");  // canonical, betas filled from the preset
  EXPECT_DOUBLE_EQ(back.water.beta_rgb_per_m[0], JerlovBeta("3C").rgb_per_m[0]);
  EXPECT_EQ(RenderOptionsToJson(back),
            RenderOptionsToJson(RenderOptionsFromJson(RenderOptionsToJson(back))));
  EXPECT_EQ(back.seed, o.seed);
  EXPECT_EQ(back.light.lights.size(), 2u);
  EXPECT_EQ(back.light.incidence, IncidenceModel::kPaperEq5);
  // Missing keys keep the in-class defaults.
  EXPECT_EQ(RenderOptionsToJson(RenderOptionsFromJson(nlohmann::json::object())),
            RenderOptionsToJson(RenderOptions{}));

  auto error_of = [](const std::string& text) {
    try {
      RenderOptionsFromJson(nlohmann::json::parse(text));
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(
      error_of(R"({"psf": {"forward_scater": 0.9}})").find("unknown key 'psf.forward_scater'"),
      std::string::npos);
  EXPECT_NE(error_of(R"({"psf": {"forward_scatter": 0}})").find("psf.forward_scatter"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"psf": {"forward_scatter": "a"}})")
                .find("'psf.forward_scatter': expected a number"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"water": {"beta_rgb_per_m": [1, 2]}})").find("water.beta_rgb_per_m"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"water": {"beta_rgb_per_m": [1, 2, 11]}})").find("water.beta_rgb_per_m"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"water": {"type": "IB", "beta_rgb_per_m": [1, 2, 3]}})").find("conflicts"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"light": {"lights": [{"power": -1}]}})").find("light.lights[0].power"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"light": {"incidence": "phong"}})").find("light.incidence"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"seed": -1})").find("seed"), std::string::npos);
  EXPECT_NE(error_of(R"({"camera": {"bit_depth": 12}})").find("camera.bit_depth"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"colour": 1})").find("unknown key 'colour'"), std::string::npos);
  EXPECT_THROW(MapSelection::FromList("light,fog"), Error);
}

TEST(Render, SameSeedSameBytesOnOneAndManyThreads) {
  const Scene scene = MakeBuiltinScene("seafloor", {0.15});
  RenderOptions o;
  o.seed = 77;
  o.snow.density_per_m3 = 200.0;
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);
  const RenderResult one = Render(o, scene);
  cv::setNumThreads(2);
  const RenderResult many = Render(o, scene);
  cv::setNumThreads(threads);
  EXPECT_EQ(cv::norm(one.image, many.image, cv::NORM_INF), 0.0);
  EXPECT_EQ(one.sidecar.ToJson().dump(), many.sidecar.ToJson().dump());
  o.seed = 78;
  EXPECT_GT(cv::norm(Render(o, scene).image, one.image, cv::NORM_INF), 0.0);
}

// RenderOptions::rgb_image (the Python package's zero-copy image): the same bytes, R and B swapped,
// the maps untouched, the sidecar unchanged; gray renders ignore it. Snow, sensor noise, light and
// the PSF on, in the streamed and the plain path (the PSF switches between them).
TEST(Render, RgbImageIsTheSameBytesReordered) {
  for (bool psf : {true, false})
    for (int channels : {3, 1})
      for (int camera : {0, 1, 2}) {  // sRGB 8-bit (the default), linear 16-bit, float
        Scene scene = MakeBuiltinScene("seafloor", {0.2});
        if (channels == 1) cv::cvtColor(scene.image, scene.image, cv::COLOR_BGR2GRAY);
        RenderOptions o;
        o.seed = 9;
        o.water.type = "5C";
        o.snow.density_per_m3 = 150.0;
        o.psf.enabled = psf;
        o.maps = MapSelection::FromList("transmission,veil");
        if (camera == 1) {
          o.camera.encoding = CameraEncoding::kLinear;
          o.camera.bit_depth = 16;
        } else if (camera == 2) {
          o.camera.bit_depth = 32;
        }
        const RenderResult bgr = Render(o, scene);
        o.rgb_image = true;
        const RenderResult rgb = Render(o, scene);
        cv::Mat expected;  // a new buffer (a header copy of bgr.image would be swapped in place)
        if (channels == 3)
          cv::cvtColor(bgr.image, expected, cv::COLOR_BGR2RGB);
        else
          expected = bgr.image;
        const cv::Mat a = rgb.image.reshape(1), b = expected.reshape(1);
        EXPECT_EQ(std::memcmp(a.data, b.data, a.total() * a.elemSize()), 0)
            << psf << channels << camera;
        EXPECT_EQ(cv::norm(rgb.transmission, bgr.transmission, cv::NORM_INF), 0.0);
        EXPECT_EQ(cv::norm(rgb.veil, bgr.veil, cv::NORM_INF), 0.0);
        EXPECT_EQ(rgb.sidecar.ToJson().dump(), bgr.sidecar.ToJson().dump());
        if (channels == 3) EXPECT_GT(cv::norm(rgb.image, bgr.image, cv::NORM_INF), 0.0);
      }
}

TEST(Render, RendererCachesGiveTheSameBytesAndAreThreadSafe) {
  const Scene scene = MakeBuiltinScene("room", {0.1});
  Renderer renderer(scene);
  std::vector<RenderOptions> sweep;
  for (double beta : {0.1, 0.7, 2.0})
    for (uint64_t seed : {1u, 2u}) {
      RenderOptions o;
      o.water.beta_rgb_per_m = {beta, beta / 2, beta / 3};
      o.seed = seed;
      sweep.push_back(o);
    }
  std::vector<cv::Mat> fresh;
  for (const auto& o : sweep) fresh.push_back(Render(o, scene).image);
  std::vector<cv::Mat> cached(sweep.size());
  std::vector<std::thread> workers;
  for (size_t i = 0; i < sweep.size(); ++i)
    workers.emplace_back([&, i] { cached[i] = renderer.Render(sweep[i]).image; });
  for (auto& w : workers) w.join();
  for (size_t i = 0; i < sweep.size(); ++i)
    EXPECT_EQ(cv::norm(fresh[i], cached[i], cv::NORM_INF), 0.0) << i;
}

TEST(Render, SidecarHasEverythingUsed) {
  const Scene scene = testing::MakePlaneScene(16, 12, 1.0, 1);
  RenderOptions o;
  o.water.type = "IB";
  o.seed = 4;
  const RenderResult r = Render(o, scene);
  EXPECT_EQ(r.sidecar.ToJson()["seed"], 4);
  EXPECT_EQ(r.sidecar.ToJson()["options"]["water"]["type"], "IB");
  EXPECT_NEAR(r.sidecar.ToJson()["options"]["water"]["beta_gray_per_m"].get<double>(),
              JerlovBeta("IB").gray_per_m, 1e-12);
  EXPECT_TRUE(r.sidecar.ToJson().contains("version"));
  EXPECT_TRUE(r.sidecar.ToJson()["scene"].contains("input_hashes"));
  EXPECT_EQ(r.sidecar.ToJson()["derived"]["channel_order"], "gray");
  // The sidecar's options reproduce the render.
  const RenderResult again = Render(RenderOptionsFromJson(r.sidecar.ToJson()["options"]), scene);
  EXPECT_EQ(cv::norm(r.image, again.image, cv::NORM_INF), 0.0);
}

// Seeded sweep over the accepted parameter space, extremes included: every output finite, in range.
TEST(RenderStress, SeededSweepStaysFiniteAndInRange) {
  std::mt19937_64 rng(2024);
  auto uniform = [&](double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(rng);
  };
  auto pick = [&](std::vector<double> v) { return v[rng() % v.size()]; };
  for (int trial = 0; trial < 40; ++trial) {
    const int channels = trial % 2 ? 1 : 3;
    const double depth = pick({0.01, 0.5, 2.0, 50.0});
    Scene scene = testing::MakePlaneScene(24, 18, depth, channels, pick({5.0, 20.0, 200.0}));
    if (trial % 5 == 0) scene.depth_m.at<float>(2, 2) = std::nanf("");
    if (trial % 7 == 0) scene.normals.setTo(cv::Scalar::all(NAN));
    RenderOptions o;
    const double b = pick({0.0, 1e-6, 0.7, 10.0});
    o.water.beta_rgb_per_m = {b, uniform(0, 10), uniform(0, 10)};
    o.water.beta_gray_per_m = b;
    o.water.ambient_rgb = {pick({0.0, 10.0}), uniform(0, 10), uniform(0, 10)};
    o.water.backscatter = trial % 3 == 0;
    o.light.incidence = trial % 2 ? IncidenceModel::kPaperEq5 : IncidenceModel::kLambertian;
    o.light.min_cos_incidence = pick({0.01, 0.05, 1.0});
    o.light.min_distance_m = pick({1e-4, 0.01, 1.0});
    o.light.lights.clear();
    const int lights = static_cast<int>(rng() % 4);
    for (int k = 0; k < lights; ++k) {
      LightOptions l;
      // Touching the surface, grazing, behind the camera, far away.
      l.position_in_camera_m = {pick({0.0, 0.3, -100.0}), uniform(-1, 1),
                                pick({0.0, depth, -5.0, 100.0})};
      l.axis_in_camera = {uniform(-1, 1), uniform(-1, 1), pick({1.0, 0.0, -1.0})};
      if (cv::norm(l.axis_in_camera) < 1e-3) l.axis_in_camera = {0, 0, 1};
      l.power = pick({0.0, 1.0, 1e6});
      l.half_power_angle_deg = pick({0.5, 30.0, 60.0, 89.99});
      o.light.lights.push_back(l);
    }
    o.psf.enabled = trial % 4 != 0;
    o.psf.optical_thickness = pick({1e-4, 0.5, 4.0, 100.0});
    o.psf.forward_scatter = pick({1e-6, 0.01, 0.9, 1.0});
    o.psf.pixels_per_unit = pick({0.01, 1.0, 50.0});
    o.psf.max_radius_px = static_cast<int>(pick({1, 8, 30}));
    o.psf.depth_dependent = trial % 6 == 0;
    o.snow.enabled = trial % 2 == 0;
    o.snow.density_per_m3 = pick({0.0, 10.0, 1000.0});
    o.snow.far_m = pick({0.5, 5.0});
    o.snow.near_m = 0.1;
    o.sensor.photons_at_white = pick({0.0, 10.0, 1e7});
    o.sensor.read_noise = pick({0.0, 0.5});
    o.camera.bit_depth = static_cast<int>(pick({8, 16, 32}));
    o.seed = rng();
    std::string why;
    ASSERT_TRUE(o.Check(&why)) << why;
    const RenderResult r = Render(o, scene);
    ASSERT_TRUE(cv::checkRange(r.image, true, nullptr, 0.0, 1.0 + 1e-6))
        << "trial " << trial << "\n"
        << RenderOptionsToJson(o).dump();
    ASSERT_TRUE(cv::checkRange(r.lit)) << "trial " << trial;
  }
}

TEST(RenderStress, OutOfRangeOptionsAreRejected) {
  const Scene scene = testing::MakePlaneScene(8, 6, 1.0);
  auto rejects = [&](auto mutate) {
    RenderOptions o;
    mutate(o);
    EXPECT_THROW(Render(o, scene), Error);
  };
  rejects([](RenderOptions& o) { o.water.beta_rgb_per_m[0] = 10.5; });
  rejects([](RenderOptions& o) { o.water.beta_gray_per_m = -0.1; });
  rejects([](RenderOptions& o) { o.water.type = "XX"; });
  rejects([](RenderOptions& o) { o.psf.forward_scatter = 1.5; });
  rejects([](RenderOptions& o) { o.psf.optical_thickness = 0.0; });
  rejects([](RenderOptions& o) { o.psf.max_radius_px = 10000; });
  rejects([](RenderOptions& o) { o.light.lights[0].half_power_angle_deg = 0.0; });
  rejects([](RenderOptions& o) { o.light.min_distance_m = 0.0; });
  rejects([](RenderOptions& o) { o.snow.near_m = 5.0; });
  rejects([](RenderOptions& o) { o.sensor.read_noise = std::nan(""); });
  rejects([](RenderOptions& o) { o.camera.bit_depth = 10; });
  Scene bad = scene;
  bad.depth_m.at<float>(0, 0) = -1.0f;
  EXPECT_THROW(Render(RenderOptions{}, bad), Error);
}

TEST(Render, BadDepthIsRejectedWithItsPixel) {
  const Scene scene = testing::MakePlaneScene(12, 8, 1.0);
  for (float value : {-1.0f, 0.0f, -0.0f, std::numeric_limits<float>::infinity(),
                      -std::numeric_limits<float>::infinity()}) {
    Scene bad = scene;
    bad.depth_m = scene.depth_m.clone();
    bad.depth_m.at<float>(3, 5) = value;
    try {
      Render(Bare(), bad);
      ADD_FAILURE() << "accepted depth " << value;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("(5, 3)"), std::string::npos) << e.what();
    }
  }
  // NaN of either sign is invalid depth (open water), not an error; all NaN is an error.
  Scene holes = scene;
  holes.depth_m = scene.depth_m.clone();
  holes.depth_m.at<float>(1, 1) = -std::numeric_limits<float>::quiet_NaN();
  holes.depth_m.at<float>(2, 2) = std::numeric_limits<float>::quiet_NaN();
  const RenderResult r = Render(Bare(), holes);
  EXPECT_NEAR(r.sidecar.ToJson()["derived"]["valid_depth_fraction"].get<double>(), 94.0 / 96.0, 1e-12);
  holes.depth_m.setTo(std::numeric_limits<float>::quiet_NaN());
  try {
    Render(Bare(), holes);
    ADD_FAILURE() << "accepted a depth map without a valid pixel";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no valid pixel"), std::string::npos) << e.what();
  }
  // The renderer checks depth in its range pass and asks Scene::Validate only about suspect
  // values: a finite depth whose range overflows float is valid depth, as Validate says.
  Scene far = scene;
  far.depth_m = scene.depth_m.clone();
  far.depth_m.at<float>(3, 5) = 3e38f;
  EXPECT_NO_THROW(far.Validate());
  EXPECT_NO_THROW(Render(Bare(), far));
}

TEST(Render, RangeStatisticsMatchTheRangeMap) {
  Scene scene = MakeBuiltinScene("hull", {0.1});
  scene.depth_m = scene.depth_m.clone();
  for (int x = 0; x < 20; ++x) scene.depth_m.at<float>(4, x) = std::nanf("");
  const Renderer renderer(scene);
  const cv::Mat range = RangeFromDepth(scene.camera, scene.depth_m);
  // The renderer's range map is RangeFromDepth, value for value (NaN where depth is NaN).
  double lo = std::numeric_limits<double>::infinity(), hi = 0.0;
  int valid = 0;
  for (int y = 0; y < range.rows; ++y)
    for (int x = 0; x < range.cols; ++x) {
      const float expected = range.at<float>(y, x), got = renderer.range_m().at<float>(y, x);
      if (std::isnan(expected)) {
        ASSERT_TRUE(std::isnan(got)) << x << ", " << y;
        continue;
      }
      ASSERT_EQ(got, expected) << x << ", " << y;
      lo = std::min<double>(lo, expected), hi = std::max<double>(hi, expected), ++valid;
    }
  EXPECT_EQ(valid, range.rows * range.cols - 20);
  const RenderResult r = renderer.Render(Bare());
  EXPECT_EQ(r.sidecar.ToJson()["derived"]["range_m"]["min"].get<double>(), lo);
  EXPECT_EQ(r.sidecar.ToJson()["derived"]["range_m"]["max"].get<double>(), hi);
  EXPECT_NEAR(r.sidecar.ToJson()["derived"]["valid_depth_fraction"].get<double>(),
              static_cast<double>(valid) / range.total(), 1e-12);
}

// The renderer blurs J row by row with its own separable kernel; it must equal ApplyPsf (OpenCV's
// sepFilter2D, mirrored borders) to float rounding, also when the kernel is wider than the image.
TEST(Render, RowBlurEqualsApplyPsf) {
  for (int channels : {1, 3})
    for (double pixels_per_unit : {1.0, 3.0, 12.0}) {
      const Scene scene = testing::MakePlaneScene(23, 9, 2.0, channels);
      RenderOptions o = Bare();
      o.psf.enabled = true;
      o.psf.pixels_per_unit = pixels_per_unit;
      const RenderResult r = Render(o, scene);
      const Psf psf = PsfKernel(o.psf);
      ASSERT_TRUE(psf.separable);
      ASSERT_FALSE(psf.is_delta);
      const cv::Mat reference = ApplyPsf(psf, r.lit);
      EXPECT_LT(cv::norm(r.image, reference, cv::NORM_INF), 1e-6)
          << channels << " channels, radius " << psf.radius_px;
    }
}

// Output buffers are recycled between renders only after every Mat sharing them is gone.
TEST(Render, RecycledBuffersAreNotSharedWhileInUse) {
  const Scene scene = MakeBuiltinScene("seafloor", {0.1});
  RenderOptions o;
  o.seed = 3;
  cv::Mat kept = Render(o, scene).image;
  const cv::Mat copy = kept.clone();
  for (uint64_t seed : {4u, 5u, 6u}) {
    o.seed = seed;
    const RenderResult other = Render(o, scene);
    EXPECT_NE(other.image.data, kept.data);
  }
  EXPECT_EQ(cv::norm(kept, copy, cv::NORM_INF), 0.0);
  o.seed = 3;
  kept.release();
  EXPECT_EQ(cv::norm(Render(o, scene).image, copy, cv::NORM_INF), 0.0);
}

}  // namespace
}  // namespace turbid

namespace turbid {
namespace {

// beta = 0 with invalid (NaN) depth is the limit beta -> 0+: t = 0 there (open water), so those
// pixels show B_inf (and snow), while the valid ones are the same as at a vanishing beta.
TEST(Render, ZeroBetaWithInvalidDepthIsTheLimitOfSmallBeta) {
  Scene scene = testing::MakePlaneScene(30, 20, 2.0, 3);
  for (int y = 4; y < 9; ++y)
    for (int x = 10; x < 16; ++x) {
      scene.depth_m.at<float>(y, x) = std::nanf("");
      scene.normals.at<cv::Vec3f>(y, x) = cv::Vec3f(NAN, NAN, NAN);
    }
  RenderOptions zero = Bare();
  zero.water.ambient_rgb = {0.2, 0.2, 0.2};
  zero.water.backscatter = true;
  zero.light.lights = {LightOptions{}};
  zero.psf.enabled = true;
  zero.snow.enabled = true;
  zero.snow.density_per_m3 = 2000;
  zero.maps = MapSelection::FromList("transmission,veil");
  RenderOptions tiny = zero;
  tiny.water.beta_rgb_per_m = {1e-7, 1e-7, 1e-7};
  const RenderResult a = Render(zero, scene), b = Render(tiny, scene);
  EXPECT_LT(cv::norm(a.image, b.image, cv::NORM_INF), 1e-5);
  EXPECT_LT(cv::norm(a.transmission, b.transmission, cv::NORM_INF), 1e-5);
  EXPECT_LT(cv::norm(a.veil, b.veil, cv::NORM_INF), 1e-5);
  EXPECT_EQ(a.transmission.at<cv::Vec3f>(5, 12), cv::Vec3f(0, 0, 0));
  EXPECT_EQ(a.transmission.at<cv::Vec3f>(0, 0), cv::Vec3f(1, 1, 1));
}

// beta > 0 and a wide PSF (sigma = 2 px) together, against [J * h] t + (1 - t)(E_L + B_inf)
// computed here: J from the scene and E_L, the blur by a direct 2-D sum over the kernel with
// mirrored (reflect-101) indices, t from the range.
TEST(Render, WidePsfWithAttenuationMatchesAnIndependentComposition) {
  const BuiltinSceneOptions so{0.125, 1};
  const Scene scene = MakeBuiltinScene("seafloor", so);
  RenderOptions o = Bare();
  o.water.beta_rgb_per_m = {0.9, 0.5, 0.3};
  o.water.ambient_rgb = {0.1, 0.15, 0.2};
  o.water.backscatter = true;
  o.light.lights = {LightOptions{}};
  o.light.lights[0].power = 2.0;
  o.psf.enabled = true;
  o.psf.forward_scatter = 0.0625;  // sigma = 0.5 / sqrt(q) = 2 px
  o.psf.optical_thickness = 4.0;
  const RenderResult r = Render(o, scene);
  const Psf psf = PsfKernel(o.psf);
  ASSERT_NEAR(psf.sigma_px, 2.0, 1e-12);
  ASSERT_GE(psf.radius_px, 6);
  const std::vector<double> beta = {0.3, 0.5, 0.9}, ambient = {0.2, 0.15, 0.1};
  const std::vector<double> bs = {0.25, 0.2, 0.05};
  const cv::Mat e_l = IrradianceMap(o.light, scene.camera, scene.depth_m, scene.normals, beta);
  const cv::Mat range = RangeFromDepth(scene.camera, scene.depth_m);
  const int w = scene.width(), h = scene.height(), rad = psf.radius_px;
  auto mirror = [](int i, int n) { return i < 0 ? -i : (i >= n ? 2 * n - 2 - i : i); };
  double worst = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        double jb = 0;
        for (int dy = -rad; dy <= rad; ++dy)
          for (int dx = -rad; dx <= rad; ++dx) {
            const int sy = mirror(y + dy, h), sx = mirror(x + dx, w);
            const double j = (ambient[c] + e_l.at<cv::Vec3f>(sy, sx)[c]) *
                             scene.image.at<cv::Vec3f>(sy, sx)[c];
            jb += psf.kernel.at<float>(dy + rad, dx + rad) * j;
          }
        const double t = std::exp(-beta[c] * range.at<float>(y, x));
        const double expected =
            std::clamp(jb * t + (1 - t) * (e_l.at<cv::Vec3f>(y, x)[c] + bs[c]), 0.0, 1.0);
        worst = std::max(worst, std::abs(r.image.at<cv::Vec3f>(y, x)[c] - expected));
      }
  EXPECT_LT(worst, 2e-5);
}

}  // namespace
}  // namespace turbid
