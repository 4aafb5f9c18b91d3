#include "simulator/noise.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <opencv2/core.hpp>

#include "core/error.h"
#include "core/row_kernel.h"
#include "simulator/kernels.h"
#include "simulator/wide_kernel.h"

namespace turbid {
namespace {

constexpr uint64_t kGolden = 0x9e3779b97f4a7c15ULL;

inline uint64_t Mix64(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

bool InRange(double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; }

constexpr uint64_t kSnowStream = 1;
constexpr uint64_t kSensorStream = 2;

}  // namespace

uint64_t RandomKey(uint64_t seed, uint64_t stream) {
  return Mix64(Mix64(seed) ^ (stream * kGolden + 1));
}

uint64_t RandomBits(uint64_t key, uint64_t index) { return Mix64(key + (index + 1) * kGolden); }

double RandomUniform(uint64_t key, uint64_t index) {
  return (static_cast<double>(RandomBits(key, index) >> 11) + 0.5) * (1.0 / 9007199254740992.0);
}

namespace {

// 32-bit integer hash ("lowbias32", C. Wellons 2018): cheap, well mixed and vectorisable.
inline uint32_t Hash32(uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}

// ln(x) for x in (0, 1], float, vectorisable: x = 2^e m with m in [sqrt(1/2), sqrt(2)),
// ln m = 2 atanh(s), s = (m - 1)/(m + 1), odd series to s^9 (|s| < 0.172: error < 1e-7 relative).
inline float FastLog(float x) {
  uint32_t bits;
  std::memcpy(&bits, &x, 4);
  int e = static_cast<int>(bits >> 23) - 127;
  bits = (bits & 0x007fffffU) | 0x3f800000U;  // m in [1, 2)
  float m;
  std::memcpy(&m, &bits, 4);
  const int big = m > 1.41421356f;  // arithmetic instead of branches keeps the loop vectorisable
  m *= 1.0f - 0.5f * static_cast<float>(big);
  e += big;
  const float s = (m - 1.0f) / (m + 1.0f), s2 = s * s;
  const float series =
      s * (2.0f + s2 * (0.6666666667f + s2 * (0.4f + s2 * (0.2857142857f + s2 * 0.2222222222f))));
  return series + static_cast<float>(e) * 0.69314718056f;
}

// sin and cos of 2 pi u for u in [0, 1): reduce to theta in [-pi/4, pi/4] around the nearest
// quarter turn, Taylor to theta^9 / theta^8 (error < 4e-7), then rotate by the quadrant.
inline void FastSinCos2Pi(float u, float* sin_out, float* cos_out) {
  const float quarters = u * 4.0f;
  const int q = static_cast<int>(quarters + 0.5f);  // nearest quarter turn, 0..4
  const float theta = (quarters - static_cast<float>(q)) * 1.5707963268f;
  const float t2 = theta * theta;
  const float s =
      theta *
      (1.0f + t2 * (-1.0f / 6 + t2 * (1.0f / 120 + t2 * (-1.0f / 5040 + t2 * (1.0f / 362880)))));
  const float c = 1.0f + t2 * (-0.5f + t2 * (1.0f / 24 + t2 * (-1.0f / 720 + t2 * (1.0f / 40320))));
  // Rotation by q * 90 degrees, branch-free: odd quadrants swap sin and cos; the signs follow.
  const float swap = static_cast<float>(q & 1);
  const float sin_sign = 1.0f - 2.0f * static_cast<float>((q >> 1) & 1);
  const float cos_sign = 1.0f - 2.0f * static_cast<float>(((q + 1) >> 1) & 1);
  *sin_out = sin_sign * (s + swap * (c - s));
  *cos_out = cos_sign * (c + swap * (s - c));
}

}  // namespace

namespace {

// Box-Muller for pairs low0 .. low0 + n - 1 (32-bit counter, fixed high word): a straight loop
// the compiler vectorises; an AVX-512 or AVX2 clone is picked at run time where the CPU has it
// (same results: integer hashing and the same float operations, no FMA contraction in any clone).
TURBID_WIDE_KERNEL void NormalPairs(uint32_t low0, uint32_t high, uint32_t k1, uint32_t k2, int n,
                                    float* cos_part, float* sin_part) {
  for (int j = 0; j < n; ++j) {
    const uint32_t a = Hash32((low0 + static_cast<uint32_t>(j)) ^ k1) ^ high;
    const uint32_t b1 = Hash32(a ^ k2), b2 = Hash32((a + 0x9e3779b9U) ^ k2);
    const float u1 =
        (static_cast<float>(static_cast<int>(b1 >> 8)) + 1.0f) * (1.0f / 16777216.0f);  // (0, 1]
    const float u2 =
        static_cast<float>(static_cast<int>(b2 >> 8)) * (1.0f / 16777216.0f);  // [0, 1)
    const float radius = std::sqrt(-2.0f * FastLog(u1));
    float s, c;
    FastSinCos2Pi(u2, &s, &c);
    cos_part[j] = radius * c;
    sin_part[j] = radius * s;
  }
}

// p += n sqrt(max(p, 0) shot + read2): the Gaussian approximation of Poisson plus read noise.
TURBID_ROW_KERNEL void ScaleNoise(const float* normals, float shot, float read2, int n, float* p) {
  for (int i = 0; i < n; ++i) p[i] += normals[i] * std::sqrt(std::max(p[i], 0.0f) * shot + read2);
}

// ScaleNoise for normals given as pair halves: sample 2j is cos_part[j], 2j + 1 is sin_part[j].
TURBID_WIDE_KERNEL void ScaleNoisePairs(const float* __restrict cos_part,
                                        const float* __restrict sin_part, float shot, float read2,
                                        int pairs, float* __restrict p) {
  for (int j = 0; j < pairs; ++j) {
    p[2 * j] += cos_part[j] * std::sqrt(std::max(p[2 * j], 0.0f) * shot + read2);
    p[2 * j + 1] += sin_part[j] * std::sqrt(std::max(p[2 * j + 1], 0.0f) * shot + read2);
  }
}

}  // namespace

void RandomNormals(uint64_t key, uint64_t first, int count, float* out) {
  if (count <= 0) return;
  // Box-Muller on pairs: pair j gives samples 2j (cos) and 2j + 1 (sin); its two uniforms are
  // 32-bit hashes of (key, j), so a sample depends only on (key, index).
  const uint64_t first_pair = first / 2, last_pair = (first + count - 1) / 2;
  const int pairs = static_cast<int>(last_pair - first_pair + 1);
  thread_local std::vector<float> cos_part, sin_part;
  cos_part.resize(pairs);
  sin_part.resize(pairs);
  const uint32_t k1 = static_cast<uint32_t>(key), k2 = static_cast<uint32_t>(key >> 32);
  // Split where the pair counter's high word changes (only past 2^32 pairs).
  for (int done = 0; done < pairs;) {
    const uint64_t pair = first_pair + done;
    const uint64_t block_end = std::min<uint64_t>(last_pair + 1, ((pair >> 32) + 1) << 32);
    const int n = static_cast<int>(block_end - pair);
    NormalPairs(static_cast<uint32_t>(pair), static_cast<uint32_t>(pair >> 32), k1, k2, n,
                cos_part.data() + done, sin_part.data() + done);
    done += n;
  }
  // Interleave: out[i] is sample first + i; pair j holds samples 2(first_pair + j) and +1.
  const int offset = static_cast<int>(first - 2 * first_pair);  // 0 or 1
  int i = 0;
  if (offset == 1) out[i++] = sin_part[0];
  const float* c = cos_part.data() + offset;
  const float* s = sin_part.data() + offset;
  const int whole = (count - i) / 2;
  float* o = out + i;
  for (int j = 0; j < whole; ++j) {
    o[2 * j] = c[j];
    o[2 * j + 1] = s[j];
  }
  i += 2 * whole;
  if (i < count) out[i] = c[whole];
}

bool SnowOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& message) {
    if (why) *why = message;
    return false;
  };
  if (!InRange(density_per_m3, 0.0, 1e5)) return fail("density_per_m3: must be in [0, 1e5]");
  if (!InRange(far_m, 0.0, 1000.0) || far_m <= 0.0) return fail("far_m: must be in (0, 1000] m");
  if (!InRange(near_m, 0.0, far_m) || near_m <= 0.0 || near_m >= far_m)
    return fail("near_m: must be in (0, far_m) m");
  if (!InRange(size_min_m, 1e-5, 0.1)) return fail("size_min_m: must be in [1e-5, 0.1] m");
  if (!InRange(size_max_m, size_min_m, 0.1))
    return fail("size_max_m: must be in [size_min_m, 0.1] m");
  if (!InRange(albedo_min, 0.0, 1.0)) return fail("albedo_min: must be in [0, 1]");
  if (!InRange(albedo_max, albedo_min, 1.0)) return fail("albedo_max: must be in [albedo_min, 1]");
  if (!InRange(blur_px, 0.3, 50.0)) return fail("blur_px: must be in [0.3, 50] pixels");
  if (mode != "per_frame" && mode != "world") return fail("mode: must be per_frame or world");
  if (!InRange(time_s, -1e6, 1e6)) return fail("time_s: must be in [-1e6, 1e6] s");
  for (double c : current_m_per_s)
    if (!InRange(c, -10.0, 10.0)) return fail("current_m_per_s: each must be in [-10, 10] m/s");
  for (double c : camera_to_world)
    if (!std::isfinite(c) || std::abs(c) > 1e6) return fail("camera_to_world: must be finite");
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      double dot = 0.0;  // rows of R orthonormal within 1e-6
      for (int k = 0; k < 3; ++k) dot += camera_to_world[i * 4 + k] * camera_to_world[j * 4 + k];
      if (std::abs(dot - (i == j ? 1.0 : 0.0)) > 1e-6)
        return fail("camera_to_world: its rotation must be orthonormal");
    }
  }
  return true;
}

namespace {

constexpr uint64_t kSnowWorldStream = 3;
constexpr double kSnowCellM = 1.0;  // world snow: particles are drawn per cube of this side

// World-space snow: the particles of the 1 m cells the frustum (near_m..far_m) overlaps, in the
// particles' rest frame (world minus current x time). A cell (i, j, k) holds floor(d) particles
// plus one with probability frac(d), d = density x 1 m^3, each from (world_seed, cell, index):
// position uniform in the cell, size log-uniform, albedo uniform. Those inside the frustum and the
// image are handed to add(u, v, z, camera point, diameter, albedo) in cell order.
template <typename Add>
void DrawWorldSnow(const SnowOptions& options, const CameraIntrinsics& camera, int w, int h,
                   uint64_t seed, double log_size_min, double log_size_max, int* particles,
                   const Add& add) {
  const auto& m = options.camera_to_world;
  const cv::Matx33d r(m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]);
  const cv::Vec3d drift = cv::Vec3d(options.current_m_per_s[0], options.current_m_per_s[1],
                                    options.current_m_per_s[2]) *
                          options.time_s;
  const cv::Vec3d origin = cv::Vec3d(m[3], m[7], m[11]) - drift;  // camera in the rest frame
  cv::Vec3d lo(1e300, 1e300, 1e300), hi(-1e300, -1e300, -1e300);
  for (double z : {options.near_m, options.far_m}) {
    for (double u : {-0.5, w - 0.5}) {
      for (double v : {-0.5, h - 0.5}) {
        const cv::Vec3d corner = r * camera.BackProject(u, v, z) + origin;
        for (int a = 0; a < 3; ++a) {
          lo[a] = std::min(lo[a], corner[a]);
          hi[a] = std::max(hi[a], corner[a]);
        }
      }
    }
  }
  int64_t cell_lo[3], cell_hi[3];
  double cells = 1.0;
  for (int a = 0; a < 3; ++a) {
    cell_lo[a] = static_cast<int64_t>(std::floor(lo[a] / kSnowCellM));
    cell_hi[a] = static_cast<int64_t>(std::floor(hi[a] / kSnowCellM));
    cells *= static_cast<double>(cell_hi[a] - cell_lo[a] + 1);
  }
  const double per_cell = options.density_per_m3 * kSnowCellM * kSnowCellM * kSnowCellM;
  if (!(cells * (per_cell + 1.0) <= 1e6))
    throw Error("snow: world mode would draw " + std::to_string(cells * per_cell) +
                " particles in the cells around the frustum (at most 1e6)");
  const uint64_t key =
      RandomKey(options.world_seed != 0 ? options.world_seed : seed, kSnowWorldStream);
  const cv::Matx33d rt = r.t();
  const int whole = static_cast<int>(std::floor(per_cell));
  const double fraction = per_cell - whole;
  *particles = 0;
  for (int64_t i = cell_lo[0]; i <= cell_hi[0]; ++i) {
    for (int64_t j = cell_lo[1]; j <= cell_hi[1]; ++j) {
      for (int64_t k = cell_lo[2]; k <= cell_hi[2]; ++k) {
        // The cell's own stream, keyed by its integer coordinates.
        uint64_t cell = RandomBits(key, static_cast<uint64_t>(i) * 0x9E3779B97F4A7C15ULL);
        cell = RandomBits(cell, static_cast<uint64_t>(j) * 0xC2B2AE3D27D4EB4FULL);
        cell = RandomBits(cell, static_cast<uint64_t>(k) * 0x165667B19E3779F9ULL);
        const int count = whole + (RandomUniform(cell, 0) < fraction ? 1 : 0);
        for (int n = 0; n < count; ++n) {
          const uint64_t base = 8 + static_cast<uint64_t>(n) * 8;
          const cv::Vec3d rest((i + RandomUniform(cell, base + 0)) * kSnowCellM,
                               (j + RandomUniform(cell, base + 1)) * kSnowCellM,
                               (k + RandomUniform(cell, base + 2)) * kSnowCellM);
          const cv::Vec3d point = rt * (rest - origin);
          const double z = point[2];
          if (!(z >= options.near_m && z <= options.far_m)) continue;
          const double u = camera.fx * point[0] / z + camera.cx;
          const double v = camera.fy * point[1] / z + camera.cy;
          if (!(u >= -0.5 && u < w - 0.5 && v >= -0.5 && v < h - 0.5)) continue;
          ++*particles;
          const double diameter = std::exp(log_size_min + RandomUniform(cell, base + 3) *
                                                              (log_size_max - log_size_min));
          const double albedo = options.albedo_min + RandomUniform(cell, base + 4) *
                                                         (options.albedo_max - options.albedo_min);
          add(u, v, z, point, diameter, albedo);
        }
      }
    }
  }
}

// The camera-relative mode: `particles` drawn uniformly in the frustum volume between near_m and
// far_m (z from the cube-root law), each handed to `add` in drawing order.
template <typename Add>
void DrawFrustumSnow(const SnowOptions& options, const CameraIntrinsics& camera, int w, int h,
                     uint64_t seed, int particles, double log_size_min, double log_size_max,
                     const Add& add) {
  const uint64_t key = RandomKey(seed, kSnowStream);
  const double near3 = std::pow(options.near_m, 3), far3 = std::pow(options.far_m, 3);
  for (int i = 0; i < particles; ++i) {
    const uint64_t base = static_cast<uint64_t>(i) * 8;
    const double u = RandomUniform(key, base + 0) * w - 0.5;
    const double v = RandomUniform(key, base + 1) * h - 0.5;
    const double z = std::cbrt(near3 + RandomUniform(key, base + 2) * (far3 - near3));
    const double diameter =
        std::exp(log_size_min + RandomUniform(key, base + 3) * (log_size_max - log_size_min));
    const double albedo = options.albedo_min +
                          RandomUniform(key, base + 4) * (options.albedo_max - options.albedo_min);
    add(u, v, z, camera.BackProject(u, v, z), diameter, albedo);
  }
}

// Rows -> splats (counting sort; each row lists its splats in drawing order).
void IndexSplatRows(int h, internal::SnowSplats* snow) {
  for (const internal::SnowSplats::Splat& s : snow->splats)
    for (int y = s.y0; y <= s.y1; ++y) ++snow->row_start[y + 1];
  for (int y = 0; y < h; ++y) snow->row_start[y + 1] += snow->row_start[y];
  snow->row_index.resize(snow->row_start[h]);
  std::vector<int> fill(snow->row_start.begin(), snow->row_start.end() - 1);
  for (int i = 0; i < static_cast<int>(snow->splats.size()); ++i)
    for (int y = snow->splats[i].y0; y <= snow->splats[i].y1; ++y) snow->row_index[fill[y]++] = i;
}

}  // namespace

namespace internal {

SnowSplats DrawMarineSnow(const SnowOptions& options, const IrradianceOptions& lights,
                          const CameraIntrinsics& camera, const cv::Mat& range_m,
                          const std::vector<double>& beta_per_m, const std::vector<double>& ambient,
                          uint64_t seed) {
  ThrowIfInvalid(options, "snow");
  const int channels = static_cast<int>(beta_per_m.size());
  CV_Assert((channels == 1 || channels == 3) && ambient.size() == beta_per_m.size());
  CV_Assert(range_m.type() == CV_32FC1);
  const int w = range_m.cols, h = range_m.rows;
  SnowSplats snow;
  snow.channels = channels;
  snow.row_start.assign(h + 1, 0);
  if (!options.enabled) return snow;
  const double volume = (w / std::abs(camera.fx)) * (h / std::abs(camera.fy)) *
                        (std::pow(options.far_m, 3) - std::pow(options.near_m, 3)) / 3.0;
  const double expected = options.density_per_m3 * volume;
  if (!(expected <= 1e6))
    throw Error("snow: density_per_m3 x frustum volume gives " + std::to_string(expected) +
                " particles (at most 1e6)");
  const double focal = std::sqrt(std::abs(camera.fx * camera.fy));
  // One particle at image position (u, v), depth z, camera-frame point `point`: hidden behind the
  // scene, or lit, attenuated and splatted.
  const auto add = [&](double u, double v, double z, const cv::Vec3d& point, double diameter,
                       double albedo) {
    const double range = cv::norm(point);
    const int px = std::clamp(static_cast<int>(std::lround(u)), 0, w - 1);
    const int py = std::clamp(static_cast<int>(std::lround(v)), 0, h - 1);
    const float surface = range_m.at<float>(py, px);
    if (!std::isnan(surface) && surface <= range) return;  // behind the scene
    ++snow.visible;
    const std::vector<double> lit = IrradianceAtPoint(lights, point, std::nullopt, beta_per_m);
    const double radius_px = 0.5 * diameter * focal / z;
    const double sigma2 = 0.5 * radius_px * radius_px + options.blur_px * options.blur_px;
    // Flux-preserving peak: the disc's pi R^2 radiance spread over a Gaussian of variance sigma2.
    const double peak_scale = radius_px * radius_px / (2.0 * sigma2);
    SnowSplats::Splat splat;
    for (int c = 0; c < channels; ++c)
      splat.peak[c] = static_cast<float>(albedo * (ambient[c] + lit[c]) *
                                         std::exp(-beta_per_m[c] * range) * peak_scale);
    const int reach = std::min(static_cast<int>(std::ceil(3.0 * std::sqrt(sigma2))), 200);
    splat.x0 = std::max(static_cast<int>(std::floor(u)) - reach, 0);
    splat.x1 = std::min(static_cast<int>(std::ceil(u)) + reach, w - 1);
    splat.y0 = std::max(static_cast<int>(std::floor(v)) - reach, 0);
    splat.y1 = std::min(static_cast<int>(std::ceil(v)) + reach, h - 1);
    splat.v = v;
    // The Gaussian is separable: one exp per column and per row of the footprint.
    splat.inv = -0.5 / sigma2;
    splat.gx_offset = static_cast<int>(snow.gx.size());
    for (int x = splat.x0; x <= splat.x1; ++x)
      snow.gx.push_back(static_cast<float>(std::exp((x - u) * (x - u) * splat.inv)));
    snow.splats.push_back(splat);
  };
  const double log_size_min = std::log(options.size_min_m),
               log_size_max = std::log(options.size_max_m);
  if (options.mode == "world") {
    DrawWorldSnow(options, camera, w, h, seed, log_size_min, log_size_max, &snow.particles, add);
  } else {
    snow.particles = static_cast<int>(std::llround(expected));
    DrawFrustumSnow(options, camera, w, h, seed, snow.particles, log_size_min, log_size_max, add);
  }
  IndexSplatRows(h, &snow);
  return snow;
}

void AddSnowRow(const SnowSplats& snow, int y, int width, float* scratch, float* out) {
  const int first = snow.row_start[y], last = snow.row_start[y + 1];
  if (first == last) return;
  const int channels = snow.channels;
  // The row of the layer (a sum over particles in drawing order), then added to out: the same
  // float operations as drawing the whole layer and adding it.
  int lo = width, hi = -1;
  for (int i = first; i < last; ++i) {
    const SnowSplats::Splat& s = snow.splats[snow.row_index[i]];
    lo = std::min(lo, s.x0);
    hi = std::max(hi, s.x1);
  }
  std::fill(scratch + lo * channels, scratch + (hi + 1) * channels, 0.0f);
  for (int i = first; i < last; ++i) {
    const SnowSplats::Splat& s = snow.splats[snow.row_index[i]];
    const float gy = static_cast<float>(std::exp((y - s.v) * (y - s.v) * s.inv));
    const float* gx = snow.gx.data() + s.gx_offset;
    for (int x = s.x0; x <= s.x1; ++x)
      for (int c = 0; c < channels; ++c) scratch[x * channels + c] += s.peak[c] * gy * gx[x - s.x0];
  }
  for (int i = lo * channels; i < (hi + 1) * channels; ++i) out[i] += scratch[i];
}

}  // namespace internal

MarineSnow RenderMarineSnow(const SnowOptions& options, const IrradianceOptions& lights,
                            const CameraIntrinsics& camera, const cv::Mat& range_m,
                            const std::vector<double>& beta_per_m,
                            const std::vector<double>& ambient, uint64_t seed) {
  const internal::SnowSplats splats =
      internal::DrawMarineSnow(options, lights, camera, range_m, beta_per_m, ambient, seed);
  MarineSnow snow;
  const int channels = splats.channels;
  snow.layer = cv::Mat(range_m.size(), CV_32FC(channels), cv::Scalar::all(0));
  snow.particles = splats.particles;
  snow.visible = splats.visible;
  std::vector<float> scratch(static_cast<size_t>(range_m.cols) * channels);
  for (int y = 0; y < range_m.rows; ++y)
    internal::AddSnowRow(splats, y, range_m.cols, scratch.data(), snow.layer.ptr<float>(y));
  return snow;
}

bool SensorNoiseOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& message) {
    if (why) *why = message;
    return false;
  };
  if (!InRange(photons_at_white, 0.0, 1e7)) return fail("photons_at_white: must be in [0, 1e7]");
  if (!InRange(read_noise, 0.0, 0.5)) return fail("read_noise: must be in [0, 0.5]");
  return true;
}

void internal::AddSensorNoiseRow(const SensorNoiseOptions& options, uint64_t seed, int y,
                                 int per_row, float* p, float* normals_scratch) {
  const uint64_t key = RandomKey(seed, kSensorStream);
  const float shot =
      options.photons_at_white > 0.0 ? static_cast<float>(1.0 / options.photons_at_white) : 0.0f;
  const float read2 = static_cast<float>(options.read_noise * options.read_noise);
  const uint64_t first = static_cast<uint64_t>(y) * per_row;
  const uint64_t first_pair = first / 2, pairs = static_cast<uint64_t>(per_row) / 2;
  if (first % 2 == 0 && per_row % 2 == 0 && (first_pair >> 32) == ((first_pair + pairs) >> 32)) {
    // The usual case, fused: the pairs' cos and sin halves go straight onto the even and odd
    // samples (the same normals and the same arithmetic as RandomNormals + ScaleNoise).
    float* cos_part = normals_scratch;
    float* sin_part = normals_scratch + pairs;
    NormalPairs(static_cast<uint32_t>(first_pair), static_cast<uint32_t>(first_pair >> 32),
                static_cast<uint32_t>(key), static_cast<uint32_t>(key >> 32),
                static_cast<int>(pairs), cos_part, sin_part);
    ScaleNoisePairs(cos_part, sin_part, shot, read2, static_cast<int>(pairs), p);
    return;
  }
  RandomNormals(key, first, per_row, normals_scratch);
  ScaleNoise(normals_scratch, shot, read2, per_row, p);
}

void AddSensorNoiseInPlace(const SensorNoiseOptions& options, cv::Mat& image, uint64_t seed) {
  ThrowIfInvalid(options, "sensor");
  CV_Assert(image.depth() == CV_32F);
  const int per_row = image.cols * image.channels();
  cv::parallel_for_(cv::Range(0, image.rows), [&](const cv::Range& rows) {
    std::vector<float> normals(per_row);
    for (int y = rows.start; y < rows.end; ++y)
      internal::AddSensorNoiseRow(options, seed, y, per_row, image.ptr<float>(y), normals.data());
  });
}

cv::Mat AddSensorNoise(const SensorNoiseOptions& options, const cv::Mat& image, uint64_t seed) {
  cv::Mat out = image.clone();
  AddSensorNoiseInPlace(options, out, seed);
  return out;
}

}  // namespace turbid
