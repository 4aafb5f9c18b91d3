#include "simulator/veil.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "simulator/water.h"

namespace turbid {
namespace {

constexpr double kPi = 3.14159265358979323846;

// One lamp in the inner loop: position, unit axis, Lambertian order and pi U0 colour_c b_c.
struct Lamp {
  cv::Vec3d position, axis;
  double order = 1.0;
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
      if (cos_phi <= 0.0) continue;
      const double l = std::max(l_true, min_distance);
      const double profile = lamp.order == 1.0 ? cos_phi : std::pow(cos_phi, lamp.order);
      const double cos_theta = -v.dot(d) / l_true;
      const double geometry = profile * Phase(cos_theta) / (l * l);
      for (int ch = 0; ch < channels; ++ch)
        g[ch] += lamp.weight[ch] * geometry * std::exp(-c[ch] * (s + l));
    }
  }

  // The table of one ray: F (cumulative) and G = dF/du at u_j = j / M, channel fastest.
  void Table(const cv::Vec3d& d, float* f_out, float* g_out) const {
    static constexpr double kNode[3] = {-0.7745966692414834, 0.0, 0.7745966692414834};
    static constexpr double kWeight[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
    const double du = 1.0 / segments;
    double f[3] = {0, 0, 0}, g[3];
    for (int j = 0; j <= segments; ++j) {
      const double u0 = j * du;
      for (int ch = 0; ch < channels; ++ch) f_out[j * channels + ch] = static_cast<float>(f[ch]);
      if (j == segments) {  // u = 1: s = infinity, no light left (c > 0; b = 0 when c = 0)
        for (int ch = 0; ch < channels; ++ch) g_out[j * channels + ch] = 0.0f;
        break;
      }
      const double ds0 = a / ((1.0 - u0) * (1.0 - u0));
      Integrand(d, a * u0 / (1.0 - u0), g);
      for (int ch = 0; ch < channels; ++ch)
        g_out[j * channels + ch] = static_cast<float>(g[ch] * ds0);
      for (int k = 0; k < 3; ++k) {
        const double u = u0 + 0.5 * (1.0 + kNode[k]) * du;
        const double ds = a / ((1.0 - u) * (1.0 - u));
        Integrand(d, a * u / (1.0 - u), g);
        for (int ch = 0; ch < channels; ++ch) f[ch] += 0.5 * du * kWeight[k] * g[ch] * ds;
      }
    }
  }

  double U(double range_m) const { return std::isfinite(range_m) ? range_m / (range_m + a) : 1.0; }
};

Context MakeContext(const IrradianceOptions& light, const VeilWater& water,
                    const VeilQuadrature& q) {
  ThrowIfInvalid(light, "light");
  const int channels = static_cast<int>(water.c_per_m.size());
  if ((channels != 1 && channels != 3) || water.b_per_m.size() != water.c_per_m.size())
    throw Error("veil", "water coefficients must have 1 or 3 channels");
  if (q.grid_step_px < 1 || q.segments < 2 || q.phase_table < 2)
    throw Error("veil", "quadrature: grid_step_px >= 1, segments >= 2, phase_table >= 2");
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
    const std::vector<double> colour = ChannelValues(
        o.color_rgb, (o.color_rgb[0] + o.color_rgb[1] + o.color_rgb[2]) / 3.0, channels);
    for (int ch = 0; ch < channels; ++ch)
      lamp.weight[ch] = kPi * o.power * colour[ch] * water.b_per_m[ch];
    nearest = std::min(nearest, cv::norm(lamp.position));
    k.lamps.push_back(lamp);
  }
  k.a = std::clamp(nearest, 0.05, 10.0);
  k.phase = PhaseFunction(water.phase).TabulateByCosine(q.phase_table);
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
  const Axis ax(width, quadrature.grid_step_px), ay(height, quadrature.grid_step_px);
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
    std::vector<float> fi(per_node), gi(per_node);
    for (int y = rows.start; y < rows.end; ++y) {
      const int j0 = ay.before[y];
      const float wy = ay.weight[y];
      const float* r = range_m.ptr<float>(y);
      float* o = out.ptr<float>(y);
      for (int x = 0; x < width; ++x) {
        const int i0 = ax.before[x];
        const float wx = ax.weight[x];
        const double u = k.U(r[x]);
        const int seg = std::min(static_cast<int>(u * k.segments), k.segments - 1);
        // Only the two breakpoints around u are interpolated across the four rays.
        const float w[4] = {(1 - wx) * (1 - wy), wx * (1 - wy), (1 - wx) * wy, wx * wy};
        const size_t base[4] = {(static_cast<size_t>(j0) * nx + i0) * per_node,
                                (static_cast<size_t>(j0) * nx + i0 + 1) * per_node,
                                (static_cast<size_t>(j0 + 1) * nx + i0) * per_node,
                                (static_cast<size_t>(j0 + 1) * nx + i0 + 1) * per_node};
        for (int e = seg * channels; e < (seg + 2) * channels; ++e) {
          float fv = 0, gv = 0;
          for (int q = 0; q < 4; ++q) fv += w[q] * f[base[q] + e], gv += w[q] * g[base[q] + e];
          fi[e] = fv, gi[e] = gv;
        }
        for (int ch = 0; ch < channels; ++ch)
          o[x * channels + ch] =
              static_cast<float>(Hermite(fi.data(), gi.data(), channels, ch, k.segments, u));
      }
    }
  });
  return out;
}

}  // namespace turbid
