// The veil of the artificial lights: what the water between the camera and the scene scatters
// towards the camera. Two models (render option "veil", docs/model.md "The veil"):
//
//   paper           (1 - t(x)) E_L(x): eq. 2 of the paper, the lamp's irradiance at the surface
//                   point seen at x, times the opacity of the path (render.cc composes it).
//   single_scatter  the single-scattered radiance of every lamp integrated along the view ray
//                   (the "volume scattering" term of McGlamery 1980 and Jaffe 1990, IEEE J. Ocean.
//                   Eng. 15(2) 101, eq. for E_b):
//     V_c(x) = pi * integral_0^R b_c p(theta(s)) E_c(s) exp(-c_c s) ds,
//     E_c(s) = colour_c U0 cos^m(phi(s)) exp(-c_c l(s)) / l(s)^2   (l clamped to min_distance_m),
//   with P(s) = s d the point at distance s on the unit view ray d, l = |P - L| and phi the
//   emission angle of the lamp at L (cos phi = axis . (P - L) / l; 0 behind the lamp), theta the
//   scattering angle between the lamp's ray (P - L) / l and the reversed view ray -d, c = beta
//   (the beam attenuation) and b = omega c (water.scattering_albedo_*), p the water's phase
//   function (water.phase, 1/sr). R is the range of the surface; rays that hit no surface (NaN
//   depth: open water) are integrated to infinity (the substitution below maps s = infinity to
//   u = 1, where the integrand vanishes for c > 0).
//   Units: E_L is in image units (a white Lambertian surface under irradiance E images at E, i.e.
//   image = pi x radiance); the factor pi converts the path radiance b p E to the same units.
//
// Fast path (SingleScatterVeilMap): the substitution s = a u / (1 - u), u in [0, 1), with a the
// distance of the nearest lamp from the camera (>= 5 cm), puts half the samples within a of the
// camera, where most of the veil builds. On a coarse grid of view rays (every 5 degrees: see
// VeilQuadrature, and the last row and column) the cumulative integral F(u_j) and its integrand
// dF/du(u_j) are tabulated at M + 1 breakpoints u_j = j / M (Simpson's rule per segment, the
// phase function tabulated by cos theta). Each pixel interpolates the four tables
// around it bilinearly (the tables are smooth in the ray direction) and evaluates F at its own
// u(R) by cubic Hermite interpolation: the upper limit is the pixel's exact range. Every value is
// computed from its inputs alone: the same bytes on any thread count.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "scenes/scene.h"
#include "simulator/light.h"
#include "simulator/phase_function.h"

namespace turbid {

enum class VeilModel { kPaper, kSingleScatter };
std::string VeilModelName(VeilModel model);  // "paper" | "single_scatter"

// The water as the single-scatter veil sees it, per channel in image order ({gray} or {B, G, R}).
struct VeilWater {
  std::vector<double> c_per_m;  // beam attenuation c (water.beta_*), 1/m, >= 0
  std::vector<double> b_per_m;  // scattering coefficient b = omega c, 1/m, >= 0
  PhaseFunctionOptions phase;
};

struct VeilQuadrature {
  // Coarse grid of view rays, pixels: 0 (default) = the pixels spanning 5 degrees of field at the
  // shorter focal length (1..64); >= 1 that step (1: every pixel exact).
  int grid_step_px = 0;
  int segments = 48;       // M: breakpoints in u
  int phase_table = 8192;  // phase function samples uniform in cos theta
};

// V for every pixel, CV_32FC(channels): range_m is CV_32FC1 (NaN: open water, integrated to
// infinity). The lights' colours in image order (gray: their mean), as the light model. Throws
// Error when the light options fail Check.
cv::Mat SingleScatterVeilMap(const IrradianceOptions& light, const VeilWater& water,
                             const CameraIntrinsics& camera, const cv::Mat& range_m,
                             const VeilQuadrature& quadrature = {});

// V along one view ray (unit direction `ray`, camera frame) to range_m (infinity: open water),
// with the fast path's quadrature (no pixel interpolation). Per channel, image order.
std::vector<double> SingleScatterVeilAlongRay(const IrradianceOptions& light,
                                              const VeilWater& water, const cv::Vec3d& ray,
                                              double range_m,
                                              const VeilQuadrature& quadrature = {});

}  // namespace turbid
