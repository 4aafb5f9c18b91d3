// Noise N of paper eq. 2: marine snow (large particles that reflect the lights straight into the
// camera, paper §II-A "D") and Poisson-Gaussian sensor noise (Foi et al., "Practical
// Poissonian-Gaussian noise modeling and fitting for single-image raw-data", IEEE TIP 2008).
// All randomness comes from a counter-based generator: every sample is a hash of (seed, stream,
// index), so the bytes do not depend on the thread count or the order of evaluation.
#pragma once

#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "scenes/scene.h"
#include "simulator/light.h"

namespace turbid {

// Counter-based random numbers (SplitMix64 finalizer as the mixing function; Steele et al.,
// "Fast splittable pseudorandom number generators", OOPSLA 2014).
uint64_t RandomKey(uint64_t seed, uint64_t stream);  // key of one independent stream
uint64_t RandomBits(uint64_t key, uint64_t index);   // 64 random bits for (key, index)
double RandomUniform(uint64_t key, uint64_t index);  // in (0, 1), 53-bit resolution
// Standard normal samples for indices first .. first + count - 1: Box-Muller on pairs of 24-bit
// uniforms from 32-bit integer hashes of (key, pair), with float log and sin/cos polynomials
// (error < 1e-6); tails reach 5.77 sigma. Sample i depends only on (key, i).
void RandomNormals(uint64_t key, uint64_t first, int count, float* out);

struct SnowOptions {
  bool enabled = true;  // false: no marine snow
  // Particles per cubic metre of the viewing frustum between near_m and far_m, in [0, 1e5].
  double density_per_m3 = 20.0;
  double near_m = 0.2;  // nearest particle distance (z), metres, in (0, far_m)
  double far_m = 4.0;   // farthest particle distance (z), metres, in (near_m, 1000]
  // Particle diameter, metres, log-uniform in [size_min_m, size_max_m], 1e-5 .. 0.1. Marine snow is
  // by definition > 0.5 mm (Alldredge & Silver 1988); 0.5-5 mm by default.
  double size_min_m = 0.0005;
  double size_max_m = 0.005;
  // Particle reflectance, uniform in [albedo_min, albedo_max], within [0, 1].
  double albedo_min = 0.3;
  double albedo_max = 0.9;
  // Particles are drawn as flux-preserving Gaussian blobs with sigma^2 = R^2/2 + blur_px^2 (R: the
  // projected radius in pixels; blur_px: defocus and forward-scatter blur), pixels, in [0.3, 50].
  double blur_px = 0.7;
  // "per_frame" (the default): particles are drawn anew in each render's frustum from `seed`.
  // "world": particles live in the world, in 1 m cells (each cell's particles drawn from
  // (world_seed, cell)), drifting with current_m_per_s; a render sees those in its frustum from
  // the camera pose camera_to_world at time_s, so along a sequence they move with parallax and
  // stay the same particles (docs/model.md "Marine snow").
  std::string mode = "per_frame";
  // world: camera-to-world [R | p] row-major (R orthonormal, metres); identity by default.
  std::array<double, 12> camera_to_world{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  double time_s = 0.0;                             // world: seconds, [-1e6, 1e6]
  std::array<double, 3> current_m_per_s{0, 0, 0};  // world: drift velocity in the world, [-10, 10]
  uint64_t world_seed = 0;  // world: seeds the particles (0: the render's seed)

  bool Check(std::string* why) const;
};

struct MarineSnow {
  cv::Mat layer;      // CV_32FC(channels): additive radiance of the particles, >= 0
  int particles = 0;  // particles drawn in the frustum
  int visible = 0;    // particles in front of the scene surface and inside the image
};

// Draws round(density * frustum volume) particles from (seed, snow stream): image position uniform,
// z with uniform volume density, size log-uniform, albedo uniform. Each is lit by E_A and the
// lights (facing them), attenuated by exp(-beta r) towards the camera, hidden behind the scene
// surface (range_m; NaN range: never hidden), and added (not occluding). beta and ambient in image
// channel order. Throws Error when more than 1e6 particles would be drawn.
MarineSnow RenderMarineSnow(const SnowOptions& options, const IrradianceOptions& lights,
                            const CameraIntrinsics& camera, const cv::Mat& range_m,
                            const std::vector<double>& beta_per_m,
                            const std::vector<double>& ambient, uint64_t seed);

struct SensorNoiseOptions {
  bool enabled = true;  // false: noise-free sensor
  // Photo-electrons collected at image value 1 (full-scale signal), in [0, 1e7]; 0 disables the
  // signal-dependent (Poisson) part. Shot-noise variance is value / photons_at_white.
  double photons_at_white = 4000.0;
  // Signal-independent (read) noise standard deviation, image units, in [0, 0.5].
  double read_noise = 0.002;

  bool Check(std::string* why) const;
};

// Adds noise with mean 0 and variance value / photons_at_white + read_noise^2 at each sample (the
// Poisson part as its Gaussian approximation, exact in mean and variance; Foi et al. 2008 eq. 2-3).
// Negative signal counts as 0 for the shot variance. Works row-parallel; bytes independent of the
// thread count. Returns the noisy image (same type as `image`).
cv::Mat AddSensorNoise(const SensorNoiseOptions& options, const cv::Mat& image, uint64_t seed);
// The same, in place (the renderer's path: no extra image).
void AddSensorNoiseInPlace(const SensorNoiseOptions& options, cv::Mat& image, uint64_t seed);

}  // namespace turbid
