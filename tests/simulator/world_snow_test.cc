// World-space marine snow (issue 34 item 2): particles live in the world in 1 m cells, seen from
// each camera pose; per-frame snow (the default) is drawn anew per render.
#include <gtest/gtest.h>

#include <cmath>

#include "simulator/noise.h"
#include "simulator/render.h"
#include "tests/simulator/test_scenes.h"

namespace turbid {
namespace {

struct Frame {
  Scene scene = testing::MakePlaneScene(96, 72, 1.0, 3, 60.0);
  cv::Mat range;  // NaN: nothing hides a particle
  Frame() { range = cv::Mat(scene.depth_m.size(), CV_32F, cv::Scalar(std::nan(""))); }
  MarineSnow Snow(const SnowOptions& options, uint64_t seed) const {
    return RenderMarineSnow(options, IrradianceOptions{}, scene.camera, range, {0.1, 0.1, 0.1},
                            {0.1, 0.1, 0.1}, seed);
  }
};

SnowOptions World(double x_m, double time_s, double current_x) {
  SnowOptions options;
  options.mode = "world";
  options.density_per_m3 = 500.0;
  options.far_m = 3.0;
  options.world_seed = 77;
  options.camera_to_world[3] = x_m;
  options.time_s = time_s;
  options.current_m_per_s[0] = current_x;
  return options;
}

TEST(WorldSnow, ParticlesBelongToTheWorldNotToTheRenderSeed) {
  const Frame f;
  const MarineSnow a = f.Snow(World(0.0, 0.0, 0.0), 3);
  const MarineSnow b = f.Snow(World(0.0, 0.0, 0.0), 4);  // another frame's sensor seed
  EXPECT_GT(a.visible, 100);
  EXPECT_EQ(cv::norm(a.layer, b.layer, cv::NORM_INF), 0.0);
  // Per-frame snow re-randomises with the seed.
  SnowOptions per_frame = World(0.0, 0.0, 0.0);
  per_frame.mode = "per_frame";
  EXPECT_GT(cv::norm(f.Snow(per_frame, 3).layer, f.Snow(per_frame, 4).layer, cv::NORM_INF), 0.0);
  // Another world seed: other particles.
  SnowOptions other = World(0.0, 0.0, 0.0);
  other.world_seed = 78;
  EXPECT_GT(cv::norm(f.Snow(other, 3).layer, a.layer, cv::NORM_INF), 0.0);
}

TEST(WorldSnow, CountMatchesDensityTimesFrustumVolume) {
  const Frame f;
  const MarineSnow a = f.Snow(World(0.3, 0.0, 0.0), 1);
  const CameraIntrinsics& c = f.scene.camera;
  const double volume =
      (96 / std::abs(c.fx)) * (72 / std::abs(c.fy)) * (std::pow(3.0, 3) - std::pow(0.2, 3)) / 3.0;
  const double expected = 500.0 * volume;
  // Uniform in each cell: the count in the frustum is a sum of binomials, sd <= sqrt(expected).
  EXPECT_NEAR(a.particles, expected, 4.0 * std::sqrt(expected)) << expected;
  EXPECT_EQ(a.visible, a.particles);  // nothing hides them here
}

TEST(WorldSnow, DriftWithTheCurrentEqualsMovingTheCameraBack) {
  // Particles drifting +0.2 m along x for 1 s are seen like a camera moved -0.2 m: parallax
  // (near particles shift more than far ones) included, to float rounding.
  const Frame f;
  const MarineSnow drift = f.Snow(World(0.0, 1.0, 0.2), 1);
  const MarineSnow moved = f.Snow(World(-0.2, 0.0, 0.0), 1);
  const MarineSnow still = f.Snow(World(0.0, 0.0, 0.0), 1);
  EXPECT_EQ(drift.particles, moved.particles);
  EXPECT_LT(cv::norm(drift.layer, moved.layer, cv::NORM_INF),
            1e-4 * cv::norm(moved.layer, cv::NORM_INF));
  EXPECT_GT(cv::norm(drift.layer, still.layer, cv::NORM_INF),
            0.1 * cv::norm(still.layer, cv::NORM_INF));
}

TEST(WorldSnow, OptionsAreChecked) {
  std::string why;
  SnowOptions options = World(0.0, 0.0, 0.0);
  EXPECT_TRUE(options.Check(&why)) << why;
  options.mode = "sometimes";
  EXPECT_FALSE(options.Check(&why));
  options = World(0.0, 0.0, 0.0);
  options.camera_to_world[0] = 2.0;  // not a rotation
  EXPECT_FALSE(options.Check(&why));
  EXPECT_NE(why.find("orthonormal"), std::string::npos);
}

}  // namespace
}  // namespace turbid
