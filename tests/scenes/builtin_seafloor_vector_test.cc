// The seafloor's sand texture has an AVX2 version of its value noise (issue 34 item 6: ray-casting
// the built-in frames of a sequence): the same doubles as the scalar Noise2 / Fbm2 calls of the
// texture, so the scene's bytes do not depend on the CPU.
#include <gtest/gtest.h>

#include <cstring>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "scenes/builtin.h"
#include "scenes/builtin_internal.h"
#include "scenes/builtin_model.h"

namespace turbid {
namespace {

using builtin_model::Cell;
using builtin_model::Cellular2;
using builtin_model::Fbm2;
using builtin_model::Fbm3;
using builtin_model::Noise2;

struct VectorTextures {  // switches the vectorised path for one scope
  explicit VectorTextures(bool on) { builtin_internal::SetBuiltinVectorTextures(on); }
  ~VectorTextures() { builtin_internal::SetBuiltinVectorTextures(true); }
};

// Random points on and far off the seabed (beyond 2^31 lattice cells the vector path falls back
// to the scalar code), edges, an odd count; both paths against the texture's scalar calls.
TEST(BuiltinSeafloorVector, SandNoiseIsBitIdentical) {
  cv::RNG rng(34);
  std::vector<double> u, v;
  for (int k = 0; k < 20000; ++k) {
    const double range = k < 15000 ? 6.0 : k < 19000 ? 1e4 : 3e8;
    u.push_back(rng.uniform(-range, range));
    v.push_back(rng.uniform(-range, range));
  }
  for (double w : {0.0, -0.0, 1e-300, -1e-300, 0.5, -0.5, 1.0 / 3.0}) {
    u.push_back(w);
    v.push_back(-w);
  }
  const int n = static_cast<int>(u.size());
  for (bool vector : {true, false}) {
    SCOPED_TRACE(vector ? "vector" : "scalar");
    const VectorTextures mode(vector);
    std::vector<double> got(7 * static_cast<size_t>(n));
    builtin_internal::BuiltinSandNoiseForTest(u.data(), v.data(), n, got.data());
    int differing = 0;
    for (int k = 0; k < n; ++k) {
      const Cell shell = Cellular2(u[k] / 0.06, v[k] / 0.06, 36u);
      const double want[7] = {Fbm2(u[k] * 2.5, v[k] * 2.5, 4, 31u),
                              Fbm2(u[k] * 1.5, v[k] * 1.5, 3, 32u),
                              Noise2(u[k] * 140, v[k] * 140, 33u),
                              Fbm2(u[k] * 0.9 + 5, v[k] * 0.9, 4, 34u),
                              Noise2(u[k] * 60, v[k] * 60, 35u),
                              shell.distance,
                              shell.id};
      if (std::memcmp(want, &got[7 * static_cast<size_t>(k)], sizeof(want)) != 0) ++differing;
    }
    EXPECT_EQ(differing, 0) << "of " << n;
  }
}

// The rocks' three fractal sums (Fbm3, 11 Noise3 layers) on AVX2 against the texture's scalar
// calls, bit for bit: points on the rocks (offsets within a metre of their centres), far off them
// (beyond 2^31 lattice cells the vector path falls back to the scalar code), edges, an odd count,
// each rock's seed.
TEST(BuiltinSeafloorVector, RockNoiseIsBitIdentical) {
  cv::RNG rng(61);
  std::vector<double> xyz;
  for (int k = 0; k < 6000; ++k) {
    const double range = k < 4500 ? 0.5 : k < 5800 ? 1e4 : 3e7;
    for (int c = 0; c < 3; ++c) xyz.push_back(rng.uniform(-range, range));
  }
  for (double w : {0.0, -0.0, 1e-300, -1e-300, 0.5, -0.5, 1.0 / 3.0}) {
    xyz.insert(xyz.end(), {w, -w, 2 * w});
  }
  const int n = static_cast<int>(xyz.size() / 3);
  for (uint32_t seed : {40u, 44u, 61u, 62u}) {
    for (bool vector : {true, false}) {
      SCOPED_TRACE(std::string(vector ? "vector" : "scalar") + ", seed " + std::to_string(seed));
      const VectorTextures mode(vector);
      std::vector<double> got(3 * static_cast<size_t>(n));
      builtin_internal::BuiltinRockNoiseForTest(xyz.data(), n, seed, got.data());
      int differing = 0;
      for (int k = 0; k < n; ++k) {
        const cv::Vec3d p(xyz[3 * k], xyz[3 * k + 1], xyz[3 * k + 2]);
        const double want[3] = {Fbm3(p * 7.0, 5, seed), Fbm3(p * 3.0, 3, seed + 7),
                                Fbm3(p * 12.0 + cv::Vec3d(3, 1, 2), 3, seed + 9)};
        if (std::memcmp(want, &got[3 * static_cast<size_t>(k)], sizeof(want)) != 0) ++differing;
      }
      EXPECT_EQ(differing, 0) << "of " << n;
    }
  }
}

// The whole scene, from its own pose and from a pose along a survey: the same bytes either way.
TEST(BuiltinSeafloorVector, SceneBytesDoNotDependOnThePath) {
  BuiltinSceneOptions options;
  options.scale = 0.25;
  Pose moved = BuiltinScenePose("seafloor");
  moved.position_m += cv::Vec3d(0.4, -0.1, 0.2);
  for (const Pose& pose : {BuiltinScenePose("seafloor"), moved}) {
    options.pose = pose;
    Scene vector_scene, scalar_scene;
    {
      const VectorTextures mode(true);
      vector_scene = MakeBuiltinScene("seafloor", options);
    }
    {
      const VectorTextures mode(false);
      scalar_scene = MakeBuiltinScene("seafloor", options);
    }
    ASSERT_EQ(vector_scene.image.size(), scalar_scene.image.size());
    const size_t bytes = vector_scene.image.total() * vector_scene.image.elemSize();
    EXPECT_EQ(std::memcmp(vector_scene.image.data, scalar_scene.image.data, bytes), 0);
  }
}

}  // namespace
}  // namespace turbid
