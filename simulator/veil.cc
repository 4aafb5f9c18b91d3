#include "simulator/veil.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <mutex>
#include <string>

#include "core/error.h"
#include "simulator/water.h"

namespace turbid {
namespace {

constexpr double kPi = 3.14159265358979323846;

// One lamp in the inner loop: position, unit axis, Lambertian order and pi U0 colour_c b_c.
struct Lamp {
  cv::Vec3d position, axis;
  double order = 1.0;
  double cos_cutoff = 0.0;  // spot cut-off (0: none)
  double weight[3] = {0, 0, 0};
};

// What every ray's table needs.
struct Context {
  std::vector<Lamp> lamps;
  int channels = 1;
  double c[3] = {0, 0, 0};
  double min_distance = 0.01;
  double a = 0.25;  // the substitution's length scale, metres
  int segments = 48;
  std::vector<float> phase;  // p by cos theta: index (1 - cos) (n - 1) / 2
  double phase_scale = 0;

  double Phase(double cos_theta) const {
    const double x = std::clamp((1.0 - cos_theta) * phase_scale, 0.0, phase_scale * 2.0);
    const int i = std::min(static_cast<int>(x), static_cast<int>(phase.size()) - 2);
    const double f = x - i;
    return phase[i] + f * (phase[i + 1] - phase[i]);
  }

  // The integrand in s (1/m per channel, image units per metre) at P = s d, added to g.
  void Integrand(const cv::Vec3d& d, double s, double* g) const {
    for (int ch = 0; ch < channels; ++ch) g[ch] = 0.0;
    for (const Lamp& lamp : lamps) {
      const cv::Vec3d v = s * d - lamp.position;
      const double l_true = std::sqrt(v.dot(v));
      if (l_true <= 0.0) continue;
      const double cos_phi = lamp.axis.dot(v) / l_true;
      if (cos_phi <= 0.0 || cos_phi < lamp.cos_cutoff) continue;
      const double l = std::max(l_true, min_distance);
      const double profile = lamp.order == 1.0   ? cos_phi
                             : lamp.order == 2.0 ? cos_phi * cos_phi
                                                 : std::pow(cos_phi, lamp.order);
      const double cos_theta = -v.dot(d) / l_true;
      const double geometry = profile * Phase(cos_theta) / (l * l);
      for (int ch = 0; ch < channels; ++ch)
        g[ch] += lamp.weight[ch] * geometry * std::exp(-c[ch] * (s + l));
    }
  }

  // The table of one ray: F (cumulative) and G = dF/du at u_j = j / M, channel fastest;
  // Simpson's rule on each segment (its ends are the breakpoints, shared with G).
  void Table(const cv::Vec3d& d, float* f_out, float* g_out) const {
    const double du = 1.0 / segments;
    double f[3] = {0, 0, 0}, g0[3], gm[3], g1[3];
    auto integrand_u = [&](double u, double* g) {
      if (u >= 1.0) {  // s = infinity: no light left (c > 0; b = 0 when c = 0)
        for (int ch = 0; ch < channels; ++ch) g[ch] = 0.0;
        return;
      }
      Integrand(d, a * u / (1.0 - u), g);
      const double ds = a / ((1.0 - u) * (1.0 - u));
      for (int ch = 0; ch < channels; ++ch) g[ch] *= ds;
    };
    integrand_u(0.0, g0);
    for (int j = 0; j <= segments; ++j) {
      for (int ch = 0; ch < channels; ++ch) {
        f_out[j * channels + ch] = static_cast<float>(f[ch]);
        g_out[j * channels + ch] = static_cast<float>(g0[ch]);
      }
      if (j == segments) break;
      integrand_u((j + 0.5) * du, gm);
      integrand_u(j + 1 == segments ? 1.0 : (j + 1) * du, g1);
      for (int ch = 0; ch < channels; ++ch) {
        f[ch] += du / 6.0 * (g0[ch] + 4.0 * gm[ch] + g1[ch]);
        g0[ch] = g1[ch];
      }
    }
  }

  double U(double range_m) const { return std::isfinite(range_m) ? range_m / (range_m + a) : 1.0; }
};

// The tabulated phase function, cached for the last few options (building a Fournier-Forand
// phase function costs about as much as a small render).
std::vector<float> PhaseTable(const PhaseFunctionOptions& o, int n) {
  struct Entry {
    std::string key;
    std::vector<float> table;
  };
  static std::mutex mutex;
  static std::deque<Entry> cache;
  const std::string key = PhaseFunctionFields().ToJson(o).dump(
                              -1, ' ', true, nlohmann::json::error_handler_t::replace) +
                          "/" + std::to_string(n);
  {
    std::lock_guard<std::mutex> lock(mutex);
    for (const Entry& e : cache)
      if (e.key == key) return e.table;
  }
  std::vector<float> table = PhaseFunction(o).TabulateByCosine(n);
  std::lock_guard<std::mutex> lock(mutex);
  cache.push_front({key, table});
  if (cache.size() > 8) cache.pop_back();
  return table;
}

Context MakeContext(const IrradianceOptions& light, const VeilWater& water,
                    const VeilQuadrature& q) {
  ThrowIfInvalid(light, "light");
  const int channels = static_cast<int>(water.c_per_m.size());
  if ((channels != 1 && channels != 3) || water.b_per_m.size() != water.c_per_m.size())
    throw Error("veil", "water coefficients must have 1 or 3 channels");
  if (q.grid_step_px < 0 || q.segments < 2 || q.phase_table < 2)
    throw Error("veil", "quadrature: grid_step_px >= 0, segments >= 2, phase_table >= 2");
  Context k;
  k.channels = channels;
  for (int ch = 0; ch < channels; ++ch) k.c[ch] = water.c_per_m[ch];
  k.min_distance = light.min_distance_m;
  k.segments = q.segments;
  double nearest = 1e300;
  for (const LightOptions& o : light.lights) {
    if (o.power <= 0.0) continue;
    Lamp lamp;
    lamp.position = o.position_in_camera_m;
    lamp.axis = o.axis_in_camera / cv::norm(o.axis_in_camera);
    lamp.order = LambertianOrder(o.half_power_angle_deg);
    lamp.cos_cutoff = CosCutoff(o.cutoff_angle_deg);
    // m = 1 (60 degrees) comes out as 1 + 2e-16: take whole orders as such (no pow).
    if (std::abs(lamp.order - std::round(lamp.order)) < 1e-9) lamp.order = std::round(lamp.order);
    const std::vector<double> colour = ChannelValues(
        o.color_rgb, (o.color_rgb[0] + o.color_rgb[1] + o.color_rgb[2]) / 3.0, channels);
    for (int ch = 0; ch < channels; ++ch)
      lamp.weight[ch] = kPi * o.power * colour[ch] * water.b_per_m[ch];
    nearest = std::min(nearest, cv::norm(lamp.position));
    k.lamps.push_back(lamp);
  }
  k.a = std::clamp(nearest, 0.05, 10.0);
  k.phase = PhaseTable(water.phase, q.phase_table);
  k.phase_scale = 0.5 * (q.phase_table - 1);
  return k;
}

// F at u from one ray's table (cubic Hermite in u).
double Hermite(const float* f, const float* g, int channels, int ch, int segments, double u) {
  const double x = u * segments;
  const int j = std::min(static_cast<int>(x), segments - 1);
  const double t = x - j, t2 = t * t, t3 = t2 * t;
  const int i0 = j * channels + ch, i1 = i0 + channels;
  const double value = (2 * t3 - 3 * t2 + 1) * f[i0] + (-2 * t3 + 3 * t2) * f[i1] +
                       ((t3 - 2 * t2 + t) * g[i0] + (t3 - t2) * g[i1]) / segments;
  return std::max(value, 0.0);
}

// Coarse-grid nodes along one axis (every `step` pixels and the last pixel), and for each pixel
// the node before it and the weight of the node after it.
struct Axis {
  std::vector<int> nodes;
  std::vector<int> before;
  std::vector<float> weight;
  explicit Axis(int n, int step) {
    for (int i = 0; i < n - 1; i += step) nodes.push_back(i);
    nodes.push_back(n - 1);
    before.resize(n), weight.resize(n);
    size_t k = 0;
    for (int i = 0; i < n; ++i) {
      while (k + 2 < nodes.size() && nodes[k + 1] <= i) ++k;
      before[i] = static_cast<int>(k);
      const int span = nodes.size() > 1 ? nodes[k + 1] - nodes[k] : 1;
      weight[i] = nodes.size() > 1 ? static_cast<float>(i - nodes[k]) / span : 0.0f;
    }
    if (nodes.size() == 1) nodes.push_back(nodes[0]);  // one pixel: both neighbours the same
  }
};

// The coarse grid's step: quadrature.grid_step_px, or (0) the pixels spanning 5 degrees at the
// shorter focal length (the veil's angular detail is set by the lamps' geometry, not the image's
// resolution), at least 1 and at most 64.
int GridStep(const VeilQuadrature& q, const CameraIntrinsics& camera) {
  if (q.grid_step_px > 0) return q.grid_step_px;
  const double focal = std::min(std::abs(camera.fx), std::abs(camera.fy));
  return static_cast<int>(std::clamp(std::lround(0.0874886635 * focal), 1L, 64L));
}

cv::Vec3d UnitRay(const CameraIntrinsics& camera, double x, double y) {
  const cv::Vec3d r = camera.Ray(x, y);
  return r / cv::norm(r);
}

}  // namespace

std::string VeilModelName(VeilModel model) {
  return model == VeilModel::kSingleScatter ? "single_scatter" : "paper";
}

std::vector<double> SingleScatterVeilAlongRay(const IrradianceOptions& light,
                                              const VeilWater& water, const cv::Vec3d& ray,
                                              double range_m, const VeilQuadrature& quadrature) {
  const Context k = MakeContext(light, water, quadrature);
  const int n = (k.segments + 1) * k.channels;
  std::vector<float> f(n), g(n);
  k.Table(ray / cv::norm(ray), f.data(), g.data());
  std::vector<double> out(k.channels);
  for (int ch = 0; ch < k.channels; ++ch)
    out[ch] = Hermite(f.data(), g.data(), k.channels, ch, k.segments, k.U(range_m));
  return out;
}

cv::Mat SingleScatterVeilMap(const IrradianceOptions& light, const VeilWater& water,
                             const CameraIntrinsics& camera, const cv::Mat& range_m,
                             const VeilQuadrature& quadrature) {
  const Context k = MakeContext(light, water, quadrature);
  const int channels = k.channels, width = range_m.cols, height = range_m.rows;
  cv::Mat out(range_m.size(), CV_32FC(channels), cv::Scalar::all(0));
  if (k.lamps.empty() || range_m.empty()) return out;
  const int step = GridStep(quadrature, camera);
  const Axis ax(width, step), ay(height, step);
  const int nx = static_cast<int>(ax.nodes.size()), ny = static_cast<int>(ay.nodes.size());
  const int per_node = (k.segments + 1) * channels;
  std::vector<float> f(static_cast<size_t>(nx) * ny * per_node), g(f.size());
  cv::parallel_for_(cv::Range(0, nx * ny), [&](const cv::Range& nodes) {
    for (int i = nodes.start; i < nodes.end; ++i) {
      const cv::Vec3d d = UnitRay(camera, ax.nodes[i % nx], ay.nodes[i / nx]);
      k.Table(d, f.data() + static_cast<size_t>(i) * per_node,
              g.data() + static_cast<size_t>(i) * per_node);
    }
  });
  cv::parallel_for_(cv::Range(0, height), [&](const cv::Range& rows) {
    // Per row: the tables interpolated vertically between the two node rows around it (one
    // table per node column), then per pixel horizontally between two columns and Hermite in u.
    std::vector<float> row_f(static_cast<size_t>(nx) * per_node), row_g(row_f.size());
    const float m = static_cast<float>(k.segments), inv_m = 1.0f / m;
    const float a = static_cast<float>(k.a);
    for (int y = rows.start; y < rows.end; ++y) {
      const int j0 = ay.before[y];
      const float wy = ay.weight[y];
      const size_t top = static_cast<size_t>(j0) * nx * per_node, below = top + nx * per_node;
      for (size_t i = 0; i < row_f.size(); ++i) {
        row_f[i] = (1 - wy) * f[top + i] + wy * f[below + i];
        row_g[i] = (1 - wy) * g[top + i] + wy * g[below + i];
      }
      const float* r = range_m.ptr<float>(y);
      float* o = out.ptr<float>(y);
      for (int x = 0; x < width; ++x) {
        const float wx = ax.weight[x];
        const float range = r[x];
        const float u = range == range && range < 3e38f ? range / (range + a) : 1.0f;
        const float xs = u * m;
        const int seg = std::min(static_cast<int>(xs), k.segments - 1);
        const float t = xs - seg, t2 = t * t, t3 = t2 * t;
        const float h00 = 2 * t3 - 3 * t2 + 1, h01 = -2 * t3 + 3 * t2;
        const float h10 = (t3 - 2 * t2 + t) * inv_m, h11 = (t3 - t2) * inv_m;
        const size_t left = static_cast<size_t>(ax.before[x]) * per_node + seg * channels;
        const size_t right = left + per_node;
        for (int ch = 0; ch < channels; ++ch) {
          const size_t i0 = ch, i1 = ch + channels;
          auto lerp = [&](const std::vector<float>& v, size_t i) {
            return (1 - wx) * v[left + i] + wx * v[right + i];
          };
          const float value = h00 * lerp(row_f, i0) + h01 * lerp(row_f, i1) +
                              h10 * lerp(row_g, i0) + h11 * lerp(row_g, i1);
          o[x * channels + ch] = std::max(value, 0.0f);
        }
      }
    }
  });
  return out;
}

}  // namespace turbid
