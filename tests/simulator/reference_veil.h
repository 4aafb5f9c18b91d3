// The slow, obviously-correct single-scatter veil the fast path (simulator/veil.h) is checked
// against: dense ray marching of
//   V_c = pi integral_0^R b_c p(theta(s)) E_c(s) exp(-c_c s) ds
// by composite Simpson on a uniform grid in s (no substitution, no tables): 20000 intervals on
// [0, min(R, 5 m)] and 20000 more on the rest of the ray; open water (R = infinity) is marched to
// 40 / c_min (the light left there is below exp(-80)). The phase function is evaluated exactly
// (PhaseFunction::operator()), the lamp's profile with std::pow.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "simulator/light.h"
#include "simulator/phase_function.h"
#include "simulator/veil.h"
#include "simulator/water.h"

namespace turbid::testing {

// The integrand at distance s along the unit ray d, per channel (image order).
inline std::vector<double> ReferenceIntegrand(const IrradianceOptions& light, const VeilWater& w,
                                              const PhaseFunction& phase, const cv::Vec3d& d,
                                              double s) {
  const int channels = static_cast<int>(w.c_per_m.size());
  std::vector<double> out(channels, 0.0);
  for (const LightOptions& lamp : light.lights) {
    const cv::Vec3d axis = lamp.axis_in_camera / cv::norm(lamp.axis_in_camera);
    const cv::Vec3d point = s * d;
    const cv::Vec3d to_point = point - lamp.position_in_camera_m;
    const double distance = cv::norm(to_point);
    if (distance == 0.0) continue;
    const double cos_emission = axis.dot(to_point) / distance;
    if (cos_emission <= 0.0) continue;
    if (lamp.cutoff_angle_deg < 90.0 &&
        cos_emission < std::cos(lamp.cutoff_angle_deg * 3.14159265358979323846 / 180.0))
      continue;  // beyond the spot cut-off
    const double l = std::max(distance, light.min_distance_m);
    const double m = LambertianOrder(lamp.half_power_angle_deg);
    // Scattering angle: between the lamp's ray (to_point / distance) and the way back to the
    // camera (-d).
    const double cos_scatter = std::clamp(-to_point.dot(d) / distance, -1.0, 1.0);
    const double p = phase(std::acos(cos_scatter));
    const Rgb& rgb = lamp.color_rgb;
    const std::vector<double> colour =
        ChannelValues(rgb, (rgb[0] + rgb[1] + rgb[2]) / 3.0, channels);
    for (int c = 0; c < channels; ++c) {
      const double irradiance = colour[c] * lamp.power * std::pow(cos_emission, m) *
                                std::exp(-w.c_per_m[c] * l) / (l * l);
      out[c] +=
          3.14159265358979323846 * w.b_per_m[c] * p * irradiance * std::exp(-w.c_per_m[c] * s);
    }
  }
  return out;
}

inline void SimpsonAdd(const IrradianceOptions& light, const VeilWater& w,
                       const PhaseFunction& phase, const cv::Vec3d& d, double lo, double hi, int n,
                       std::vector<double>& sum) {
  if (hi <= lo) return;
  const double h = (hi - lo) / n;
  for (int i = 0; i <= n; ++i) {
    const double weight = (i == 0 || i == n) ? 1.0 : (i % 2 ? 4.0 : 2.0);
    const std::vector<double> g = ReferenceIntegrand(light, w, phase, d, lo + i * h);
    for (size_t c = 0; c < sum.size(); ++c) sum[c] += weight * g[c] * h / 3.0;
  }
}

// V along the ray (any non-zero direction) to range_m (NaN or infinity: open water).
inline std::vector<double> ReferenceVeil(const IrradianceOptions& light, const VeilWater& w,
                                         const cv::Vec3d& ray, double range_m, int n = 20000) {
  const PhaseFunction phase(w.phase);
  const cv::Vec3d d = ray / cv::norm(ray);
  double end = range_m;
  if (!std::isfinite(range_m)) {
    const double c_min = *std::min_element(w.c_per_m.begin(), w.c_per_m.end());
    end = 40.0 / c_min;
  }
  std::vector<double> sum(w.c_per_m.size(), 0.0);
  const double split = std::min(end, 5.0);
  SimpsonAdd(light, w, phase, d, 0.0, split, n, sum);
  SimpsonAdd(light, w, phase, d, split, end, n, sum);
  return sum;
}

// The reference veil of every pixel of a small image (CV_64FC(channels)).
inline cv::Mat ReferenceVeilMap(const IrradianceOptions& light, const VeilWater& w,
                                const CameraIntrinsics& camera, const cv::Mat& range_m,
                                int n = 20000) {
  const int channels = static_cast<int>(w.c_per_m.size());
  cv::Mat out(range_m.size(), CV_64FC(channels));
  for (int y = 0; y < range_m.rows; ++y)
    for (int x = 0; x < range_m.cols; ++x) {
      const float r = range_m.at<float>(y, x);
      const std::vector<double> v = ReferenceVeil(
          light, w, camera.Ray(x, y), r == r ? r : std::numeric_limits<double>::infinity(), n);
      for (int c = 0; c < channels; ++c) out.ptr<double>(y)[x * channels + c] = v[c];
    }
  return out;
}

}  // namespace turbid::testing
