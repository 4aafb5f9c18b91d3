#include "simulator/light.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "core/error.h"
#include "core/row_kernel.h"
#include "simulator/fast_math.h"
#include "simulator/kernels.h"
#include "simulator/wide_kernel.h"

namespace turbid {
namespace {

bool Finite3(const cv::Vec3d& v) {
  return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

// Per-light constants used in the inner loops.
}  // namespace

double CosCutoff(double cutoff_angle_deg) {
  return cutoff_angle_deg >= 90.0 ? 0.0 : std::cos(cutoff_angle_deg * M_PI / 180.0);
}

namespace {
struct LightConstants {
  cv::Vec3d position;
  cv::Vec3d axis;  // unit
  double power = 0.0;
  double order = 1.0;      // m
  int integer_order = -1;  // m when it is a small integer (cheap power), else -1
  double cos_cutoff = 0.0;  // no light where cos phi < this (0: the profile's own edge)
};

LightConstants Constants(const LightOptions& light) {
  LightConstants k;
  k.position = light.position_in_camera_m;
  k.axis = light.axis_in_camera / cv::norm(light.axis_in_camera);
  k.power = light.power;
  k.order = LambertianOrder(light.half_power_angle_deg);
  const double rounded = std::round(k.order);
  if (std::abs(k.order - rounded) < 1e-9 && rounded >= 0 && rounded <= 8)
    k.integer_order = static_cast<int>(rounded);
  k.cos_cutoff = CosCutoff(light.cutoff_angle_deg);
  return k;
}

// A gray camera sees the light's mean colour.
double GrayColor(const LightOptions& light) {
  return (light.color_rgb[0] + light.color_rgb[1] + light.color_rgb[2]) / 3.0;
}

}  // namespace

bool LightOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& message) {
    if (why) *why = message;
    return false;
  };
  if (!Finite3(position_in_camera_m) || cv::norm(position_in_camera_m, cv::NORM_INF) > 100.0)
    return fail("position_in_camera_m: each coordinate must be finite, |x| <= 100 m");
  if (!Finite3(axis_in_camera) || cv::norm(axis_in_camera) < 1e-9)
    return fail("axis_in_camera: must be a finite non-zero vector");
  if (!std::isfinite(power) || power < 0.0 || power > 1e6)
    return fail("power: must be in [0, 1e6]");
  if (!std::isfinite(half_power_angle_deg) || half_power_angle_deg <= 0.0 ||
      half_power_angle_deg >= 90.0)
    return fail("half_power_angle_deg: must be in (0, 90) degrees");
  // Below ~0.5 deg the order m exceeds 1e5: cos^m underflows everywhere but on the axis.
  if (!std::isfinite(cutoff_angle_deg) || cutoff_angle_deg <= 0.0 || cutoff_angle_deg > 90.0)
    return fail("cutoff_angle_deg: must be in (0, 90] degrees");
  if (half_power_angle_deg < 0.5) return fail("half_power_angle_deg: must be at least 0.5 degrees");
  for (double c : color_rgb)
    if (!std::isfinite(c) || c < 0.0 || c > 10.0)
      return fail("color_rgb: each value must be in [0, 10]");
  return true;
}

IncidenceModel IncidenceModelFromName(const std::string& name) {
  if (name == "lambertian") return IncidenceModel::kLambertian;
  if (name == "paper_eq5") return IncidenceModel::kPaperEq5;
  throw Error("light.incidence: unknown model '" + name + "' (lambertian, paper_eq5)");
}

std::string IncidenceModelName(IncidenceModel model) {
  return model == IncidenceModel::kPaperEq5 ? "paper_eq5" : "lambertian";
}

bool IrradianceOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& message) {
    if (why) *why = message;
    return false;
  };
  if (lights.size() > 16) return fail("lights: at most 16 lights");
  for (size_t i = 0; i < lights.size(); ++i) {
    std::string inner;
    if (!lights[i].Check(&inner)) return fail("lights[" + std::to_string(i) + "]." + inner);
  }
  if (!std::isfinite(min_cos_incidence) || min_cos_incidence < 0.01 || min_cos_incidence > 1.0)
    return fail("min_cos_incidence: must be in [0.01, 1]");
  if (!std::isfinite(min_distance_m) || min_distance_m < 1e-4 || min_distance_m > 1.0)
    return fail("min_distance_m: must be in [1e-4, 1] m");
  return true;
}

double LambertianOrder(double half_power_angle_deg) {
  const double c = std::cos(half_power_angle_deg * M_PI / 180.0);
  return -std::log(2.0) / std::log(c);
}

namespace internal {

std::vector<LightRowConstants> LightConstantsFor(const IrradianceOptions& options, int channels) {
  std::vector<LightRowConstants> out;
  for (const LightOptions& light : options.lights) {
    const LightConstants k = Constants(light);
    LightRowConstants r;
    for (int i = 0; i < 3; ++i) {
      r.position[i] = static_cast<float>(k.position[i]);
      r.axis[i] = static_cast<float>(k.axis[i]);
    }
    r.power = static_cast<float>(k.power);
    r.order = k.order;
    r.integer_order = k.integer_order;
    r.cos_cutoff = static_cast<float>(k.cos_cutoff);
    const std::vector<double> color = ChannelValues(light.color_rgb, GrayColor(light), channels);
    for (int c = 0; c < channels; ++c) r.color[c] = static_cast<float>(color[c]);
    out.push_back(r);
  }
  return out;
}

LightRowContext LightContextFor(const IrradianceOptions& options, const CameraIntrinsics& camera,
                                int width) {
  LightRowContext context;
  context.eq5 = options.incidence == IncidenceModel::kPaperEq5;
  context.min_cos = static_cast<float>(options.min_cos_incidence);
  context.min_distance = static_cast<float>(options.min_distance_m);
  context.ray_x.resize(width);
  for (int x = 0; x < width; ++x)
    context.ray_x[x] = static_cast<float>((x - camera.cx) / camera.fx);
  return context;
}

namespace {

// Distance and U0 f(psi) / l^2 for one row; cos_phi receives cos(phi) clamped to [0, 1]. Written
// without branches (selects) so that it vectorises; the AVX2 clone computes the same values (no
// FMA contraction).
template <bool kEq5>
TURBID_WIDE_KERNEL void GeometryRowKernel(const float* __restrict ray_x, float ry,
                                          const float* __restrict z,
                                          const float* __restrict normals, int width,
                                          const float* position, const float* axis, float power,
                                          float min_cos, float min_l, float* __restrict l_out,
                                          float* __restrict g_out, float* __restrict cos_phi) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float lx = position[0], ly = position[1], lz = position[2];
  const float ax = axis[0], ay = axis[1], az = axis[2];
  for (int x = 0; x < width; ++x) {
    const float rx = ray_x[x];
    const float zx = z[x];
    const float px = rx * zx, py = ry * zx, pz = zx;
    const float vx = px - lx;
    const float vy = py - ly;
    const float vz = pz - lz;
    const float l_true = std::sqrt(vx * vx + vy * vy + vz * vz);
    const float l = std::max(l_true, min_l);
    // Coincident light and point: treat as head-on (cos phi = cos psi = 1).
    const bool apart = l_true > 1e-12f;
    const float inv_true = 1.0f / l_true;  // computed for every lane, selected below
    const float inv = apart ? inv_true : 0.0f;
    const float cphi_raw = (ax * vx + ay * vy + az * vz) * inv;
    float cphi = apart ? cphi_raw : 1.0f;
    const float nx = normals[3 * x], ny = normals[3 * x + 1], nz = normals[3 * x + 2];
    // inv = 0 when coincident: cos psi = 1 by adding 1 rather than by a select (a select lets GCC
    // sink the normal loads into a branch, which stops vectorisation). x + 0 = x except that -0
    // becomes +0, which changes no output (E_L sums start from +0).
    const float cpsi = -(nx * vx + ny * vy + nz * vz) * inv + (apart ? 0.0f : 1.0f);
    float incidence;
    if constexpr (kEq5) {
      const float inverse_cos = 1.0f / std::max(cpsi, min_cos);
      incidence = cpsi > 0.0f ? inverse_cos : 0.0f;
    } else {
      incidence = std::max(cpsi, 0.0f);
    }
    cphi = std::clamp(cphi, 0.0f, 1.0f);
    cos_phi[x] = cphi;
    const bool valid = zx == zx;
    const float g = power * incidence / (l * l);
    l_out[x] = valid ? l : nan;
    g_out[x] = valid ? g : 0.0f;
  }
}

// Whether any of n floats is NaN, on the bits (integer compares vectorise without fast-math).
TURBID_ROW_KERNEL bool AnyNaN(const float* v, int n) {
  const uint32_t* bits = reinterpret_cast<const uint32_t*>(v);  // NOLINT: float bits
  uint32_t any = 0;
  for (int i = 0; i < n; ++i) any |= static_cast<uint32_t>((bits[i] & 0x7fffffffu) > 0x7f800000u);
  return any != 0;
}

// g *= c^k by repeated multiplication (left to right: p = 1 c c ... c), then non-finite -> 0.
TURBID_ROW_KERNEL void PowerStep(const float* c, int width, float* p) {
  for (int x = 0; x < width; ++x) p[x] *= c[x];
}

TURBID_ROW_KERNEL void MultiplyFiniteRow(const float* p, int width, float* g) {
  for (int x = 0; x < width; ++x) {
    const float v = g[x] * p[x];
    g[x] = std::abs(v) <= std::numeric_limits<float>::max() ? v : 0.0f;
  }
}

}  // namespace

void LightGeometryRow(const LightRowContext& context, const LightRowConstants& light, float ray_y,
                      const float* z, const cv::Vec3f* normals, int width, float* l_out,
                      float* g_out, float* cos_scratch) {
  const float* n = reinterpret_cast<const float*>(normals);
  // A NaN normal faces the camera along the viewing ray: rows that have one get a copy of their
  // normals with those replaced (the kernel then has no selects on normals).
  if (AnyNaN(n, 3 * width)) {
    float* clean = cos_scratch + 2 * width;
    for (int x = 0; x < width; ++x) {
      float nx = n[3 * x], ny = n[3 * x + 1], nz = n[3 * x + 2];
      if (std::isnan(nx) || std::isnan(ny) || std::isnan(nz)) {
        const float rx = context.ray_x[x];
        const float rl = 1.0f / std::sqrt(rx * rx + ray_y * ray_y + 1.0f);
        nx = -rx * rl, ny = -ray_y * rl, nz = -rl;
      }
      clean[3 * x] = nx, clean[3 * x + 1] = ny, clean[3 * x + 2] = nz;
    }
    n = clean;
  }
  if (context.eq5)
    GeometryRowKernel<true>(context.ray_x.data(), ray_y, z, n, width, light.position, light.axis,
                            light.power, context.min_cos, context.min_distance, l_out, g_out,
                            cos_scratch);
  else
    GeometryRowKernel<false>(context.ray_x.data(), ray_y, z, n, width, light.position, light.axis,
                             light.power, context.min_cos, context.min_distance, l_out, g_out,
                             cos_scratch);
  // Spot cut-off: cos phi below it counts as 0 (beyond the beam). Only with a cut-off below 90
  // degrees (cos phi is already clamped to [0, 1]).
  if (light.cos_cutoff > 0.0f)
    for (int x = 0; x < width; ++x)
      cos_scratch[x] = cos_scratch[x] >= light.cos_cutoff ? cos_scratch[x] : 0.0f;
  // cos^m(phi): small integer orders by multiplication, otherwise exp(m log cos phi).
  if (light.integer_order == 0) {
    std::fill(cos_scratch, cos_scratch + width, 1.0f);  // 1 * (no factor)
    MultiplyFiniteRow(cos_scratch, width, g_out);
  } else if (light.integer_order == 1) {
    MultiplyFiniteRow(cos_scratch, width, g_out);
  } else if (light.integer_order > 0) {
    // p = 1 c c ... c: the first step is exact (1 c = c), so p starts as a copy of c.
    float* power = cos_scratch + width;
    std::copy(cos_scratch, cos_scratch + width, power);
    for (int i = 1; i < light.integer_order; ++i) PowerStep(cos_scratch, width, power);
    MultiplyFiniteRow(power, width, g_out);
  } else {
    for (int x = 0; x < width; ++x) cos_scratch[x] = std::max(cos_scratch[x], 1e-30f);
    cv::Mat row(1, width, CV_32F, cos_scratch);
    cv::log(row, row);
    row *= light.order;
    cv::exp(row, row);
    MultiplyFiniteRow(cos_scratch, width, g_out);
  }
}

}  // namespace internal

LightGeometry ComputeLightGeometry(const IrradianceOptions& options, const CameraIntrinsics& camera,
                                   const cv::Mat& depth_m, const cv::Mat& normals_in) {
  ThrowIfInvalid(options, "light");
  CV_Assert(depth_m.type() == CV_32FC1);
  const cv::Mat normals = normals_in.empty() ? NormalsFromDepth(camera, depth_m) : normals_in;
  CV_Assert(normals.type() == CV_32FC3 && normals.size() == depth_m.size());
  const int w = depth_m.cols, h = depth_m.rows;
  const internal::LightRowContext context =
      internal::LightContextFor(options, camera, depth_m.cols);
  const std::vector<internal::LightRowConstants> lights = internal::LightConstantsFor(options, 1);
  LightGeometry geometry;
  std::vector<float> cos_phi(5 * w);
  for (const internal::LightRowConstants& light : lights) {
    cv::Mat distance(depth_m.size(), CV_32FC1), factor(depth_m.size(), CV_32FC1);
    for (int y = 0; y < h; ++y)
      internal::LightGeometryRow(context, light, context.RayY(camera, y), depth_m.ptr<float>(y),
                                 normals.ptr<cv::Vec3f>(y), w, distance.ptr<float>(y),
                                 factor.ptr<float>(y), cos_phi.data());
    geometry.distance_m.push_back(distance);
    geometry.geometry.push_back(factor);
  }
  return geometry;
}

namespace {

// out[x, c] += colour[c] g[x] exp(-beta[c] l[x]) for one row; NaN l (invalid depth) has g = 0.
// kStore: out = ... instead (the first light; 0 + v = v, up to the sign of a zero).
template <int kChannels, bool kStore>
TURBID_WIDE_KERNEL void AccumulateLightKernel(const float* __restrict l, const float* __restrict g,
                                              int width, const float* neg_beta, const float* color,
                                              float* __restrict out) {
  for (int x = 0; x < width; ++x) {
    const float range = std::max(0.0f, l[x]);  // NaN -> 0 without a branch
    for (int c = 0; c < kChannels; ++c) {
      const float value = color[c] * g[x] * internal::ExpNonPositive(neg_beta[c] * range);
      if constexpr (kStore)
        out[x * kChannels + c] = value;
      else
        out[x * kChannels + c] += value;
    }
  }
}

}  // namespace

void internal::AccumulateLightRow(const float* l, const float* g, int width, int channels,
                                  const float* neg_beta, const float* color, bool first, float* e) {
  if (channels == 3)
    (first ? AccumulateLightKernel<3, true> : AccumulateLightKernel<3, false>)(l, g, width,
                                                                               neg_beta, color, e);
  else
    (first ? AccumulateLightKernel<1, true> : AccumulateLightKernel<1, false>)(l, g, width,
                                                                               neg_beta, color, e);
}

cv::Mat IrradianceFromGeometry(const IrradianceOptions& options, const LightGeometry& geometry,
                               const std::vector<double>& beta_per_m) {
  const int channels = static_cast<int>(beta_per_m.size());
  CV_Assert(channels == 1 || channels == 3);
  CV_Assert(geometry.geometry.size() == options.lights.size());
  if (geometry.geometry.empty()) return {};
  const cv::Size size = geometry.geometry[0].size();
  cv::Mat irradiance(size, CV_32FC(channels), cv::Scalar::all(0));
  float neg_beta[3] = {0, 0, 0};
  for (int c = 0; c < channels; ++c) neg_beta[c] = -static_cast<float>(beta_per_m[c]);
  for (size_t k = 0; k < options.lights.size(); ++k) {
    const std::vector<double> color_d =
        ChannelValues(options.lights[k].color_rgb, GrayColor(options.lights[k]), channels);
    float color[3] = {0, 0, 0};
    for (int c = 0; c < channels; ++c) color[c] = static_cast<float>(color_d[c]);
    cv::parallel_for_(cv::Range(0, size.height), [&](const cv::Range& rows) {
      for (int y = rows.start; y < rows.end; ++y) {
        const float* l = geometry.distance_m[k].ptr<float>(y);
        const float* g = geometry.geometry[k].ptr<float>(y);
        float* out = irradiance.ptr<float>(y);
        internal::AccumulateLightRow(l, g, size.width, channels, neg_beta, color, false, out);
      }
    });
  }
  return irradiance;
}

cv::Mat IrradianceMap(const IrradianceOptions& options, const CameraIntrinsics& camera,
                      const cv::Mat& depth_m, const cv::Mat& normals,
                      const std::vector<double>& beta_per_m) {
  const int channels = static_cast<int>(beta_per_m.size());
  if (options.lights.empty()) {
    ThrowIfInvalid(options, "light");
    return cv::Mat(depth_m.size(), CV_32FC(channels), cv::Scalar::all(0));
  }
  return IrradianceFromGeometry(options, ComputeLightGeometry(options, camera, depth_m, normals),
                                beta_per_m);
}

std::vector<double> IrradianceAtPoint(const IrradianceOptions& options, const cv::Vec3d& point_m,
                                      const std::optional<cv::Vec3d>& normal,
                                      const std::vector<double>& beta_per_m) {
  const int channels = static_cast<int>(beta_per_m.size());
  std::vector<double> e(channels, 0.0);
  for (const LightOptions& light : options.lights) {
    const LightConstants k = Constants(light);
    const cv::Vec3d v = point_m - k.position;
    const double l_true = cv::norm(v);
    const double l = std::max(l_true, options.min_distance_m);
    double cphi = l_true > 1e-12 ? std::clamp(k.axis.dot(v) / l_true, 0.0, 1.0) : 1.0;
    if (cphi < k.cos_cutoff) cphi = 0.0;  // beyond the spot cut-off
    double cpsi = 1.0;
    if (normal && l_true > 1e-12) cpsi = -normal->dot(v) / l_true;
    double incidence;
    if (options.incidence == IncidenceModel::kPaperEq5)
      incidence = cpsi > 0.0 ? 1.0 / std::max(cpsi, options.min_cos_incidence) : 0.0;
    else
      incidence = std::max(cpsi, 0.0);
    const double g = k.power * std::pow(cphi, k.order) * incidence / (l * l);
    const std::vector<double> color = ChannelValues(light.color_rgb, GrayColor(light), channels);
    for (int c = 0; c < channels; ++c) e[c] += color[c] * g * std::exp(-beta_per_m[c] * l);
  }
  return e;
}

}  // namespace turbid
