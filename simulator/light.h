// Artificial light: Lambertian LEDs (paper §III-A.2, eq. 5, after the LED model of its ref. [7]).
// For the surface point X seen at pixel x with unit normal n, and a light at L with unit axis a:
//   v = X - L, l = |v|, cos(phi) = a.v / l (emission angle), cos(psi) = -n.v / l (incidence angle),
//   m = -ln 2 / ln(cos(Phi_half))   (Lambertian order from the half-power angle Phi_half),
//   E_L,c(x) = sum over lights k of  colour_k,c * U0_k * cos^m(phi) * f(psi) * exp(-beta_c l) / l^2
// with f(psi) = max(cos psi, 0) (kLambertian: irradiance on a surface, the default) or
// f(psi) = 1 / max(cos psi, min_cos_incidence) for front-facing points (kPaperEq5: the paper's
// eq. 5, which divides by cos psi; the guard keeps it finite as psi -> 90 degrees).
// Units: U0 is in image units times m^2: a white surface facing a light 1 m away on its axis, in
// clear water, images at U0 (E_L is added to E_A and multiplies rho, paper eq. 2).
// Points behind the emitter (cos phi <= 0) and surfaces facing away (cos psi <= 0) get no light;
// l is clamped to min_distance_m so a light touching the surface stays finite.
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "scenes/normals.h"  // NormalsFromDepth: normals of scenes that have none
#include "scenes/scene.h"
#include "simulator/water.h"

namespace turbid {

struct LightOptions {
  // Emitter position in the camera frame (x right, y down, z forward), metres, each |.| <= 100.
  // Default: 0.25 m below the camera, as on a typical inspection AUV.
  cv::Vec3d position_in_camera_m{0.0, 0.25, 0.0};
  // Emission axis in the camera frame; normalised on use (must be non-zero). Default: forward.
  cv::Vec3d axis_in_camera{0.0, 0.0, 1.0};
  // U0, image units * m^2 (see the header), in [0, 1e6]. Default 8: a white surface 2 m ahead on
  // axis images at 8/4 = 2 in clear water and at 2 exp(-1.4) = 0.49 at the paper's beta = 0.7.
  double power = 8.0;
  // Half-power angle Phi_half, degrees, in [0.5, 90): m = -ln2/ln(cos Phi_half). 60 deg gives m = 1
  // (an ideal Lambertian emitter); narrower beams give larger m.
  double half_power_angle_deg = 60.0;
  // Spot cut-off, degrees, in (0, 90]: no light beyond this angle from the axis (a reflector's or
  // housing's hard edge). 90 (default): none beyond the cos^m profile's own edge.
  double cutoff_angle_deg = 90.0;
  // Relative spectral power per channel R, G, B, each in [0, 10]; gray images use their mean.
  Rgb color_rgb{1.0, 1.0, 1.0};

  bool Check(std::string* why) const;
};

enum class IncidenceModel {
  kLambertian,  // max(cos psi, 0): irradiance on the surface (SPEC default)
  kPaperEq5,    // 1 / cos psi, guarded (paper eq. 5 as printed)
};
// "lambertian" | "paper_eq5" <-> enum; the name form throws Error for an unknown name.
IncidenceModel IncidenceModelFromName(const std::string& name);
std::string IncidenceModelName(IncidenceModel model);

struct IrradianceOptions {
  std::vector<LightOptions> lights{LightOptions{}};  // zero or more LEDs (0..16); empty: no E_L
  IncidenceModel incidence = IncidenceModel::kLambertian;
  // kPaperEq5 guard: cos psi is clamped to at least this, in [0.01, 1]. 0.05 caps the 1/cos psi
  // gain at 20 (psi ~ 87 deg).
  double min_cos_incidence = 0.05;
  // Light-to-surface distances are clamped to at least this, metres, in [1e-4, 1]: the emitter is
  // not a point closer than its own size. Keeps E_L finite when a light touches the surface.
  double min_distance_m = 0.01;

  bool Check(std::string* why) const;
};

// m = -ln 2 / ln(cos Phi_half), Phi_half in degrees in (0, 90).
// cos of a spot cut-off angle (degrees); 0 at 90 (no cut-off beyond the profile's edge).
double CosCutoff(double cutoff_angle_deg);

double LambertianOrder(double half_power_angle_deg);

// The beta-independent part of E_L for every light: distance l (metres, clamped as above) and the
// geometric factor U0 cos^m(phi) f(psi) / l^2. Computed once per scene and reused across beta.
struct LightGeometry {
  std::vector<cv::Mat> distance_m;  // per light, CV_32FC1; NaN where depth is invalid
  std::vector<cv::Mat> geometry;  // per light, CV_32FC1, >= 0 and finite; 0 where depth is invalid
};
// normals: CV_32FC3 unit normals or empty (then NormalsFromDepth). A NaN normal falls back to the
// normal facing the camera along the viewing ray. Throws Error when options fail Check.
LightGeometry ComputeLightGeometry(const IrradianceOptions& options, const CameraIntrinsics& camera,
                                   const cv::Mat& depth_m, const cv::Mat& normals);
// E_L from cached geometry: CV_32FC(beta.size()), channel order of the image ({gray} or {B,G,R}).
cv::Mat IrradianceFromGeometry(const IrradianceOptions& options, const LightGeometry& geometry,
                               const std::vector<double>& beta_per_m);

// The stable entry point (the enhancer's light estimate and oracle use it): per-pixel E_L in image
// units, CV_32FC(beta.size()) with beta in image channel order ({gray} or {B, G, R}); 0 where depth
// is NaN. Equivalent to IrradianceFromGeometry(options, ComputeLightGeometry(...), beta).
cv::Mat IrradianceMap(const IrradianceOptions& options, const CameraIntrinsics& camera,
                      const cv::Mat& depth_m, const cv::Mat& normals,
                      const std::vector<double>& beta_per_m);

// E_L at one point, per channel in the order of beta: the closed form the maps are tested against.
// normal: unit surface normal, or nullopt for a point that faces every light (cos psi = 1: how
// marine-snow particles are lit).
std::vector<double> IrradianceAtPoint(const IrradianceOptions& options, const cv::Vec3d& point_m,
                                      const std::optional<cv::Vec3d>& normal,
                                      const std::vector<double>& beta_per_m);

}  // namespace turbid
