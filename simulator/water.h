// The water: per-channel attenuation coefficients beta_c (1/m), Jerlov water-type presets, ambient
// light E_A and the optional classic ambient backscatter B_inf. Transmission along a ray of range r
// is t_c = exp(-beta_c r) (paper eq. 2; SPEC "The forward model"). docs/model.md has the details.
//
// Jerlov presets: N. G. Jerlov, Marine Optics, 2nd ed., Elsevier 1976, Table XXVII p. 135 (diffuse
// downward attenuation Kd(lambda), 1/m, as transcribed in jkibele/OpticalRS opticalrs/Const.py; our
// copy: shared/data/jerlov/jerlov_Kd.csv). RGB values are band means of the table's samples:
// B = mean Kd at 400, 425, 450, 475 nm; G = 500, 525, 550, 575 nm; R = 600 ... 700 nm (5 samples);
// gray = mean of all samples 400 ... 700 nm. Kd is not the beam attenuation c = a + b (Kd < c), so
// the presets understate beam attenuation; they order water types correctly and are what simulators
// such as DeepSeaRenderer use.
#pragma once

#include <array>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "simulator/phase_function.h"

namespace turbid {

// Colour triples are written in R, G, B order everywhere in options and JSON (what people write);
// images are BGR in memory, ChannelValues() does the conversion.
using Rgb = std::array<double, 3>;

struct WaterOptions {
  // "custom" (use beta_* below) or a Jerlov type: I, IA, IB, II, III, 1C, 3C, 5C, 7C, 9C ("C1" ...
  // "C9" accepted). With a Jerlov type, beta_* are set from the preset (ResolveWater).
  std::string type = "custom";
  // Attenuation coefficient beta per colour channel (R, G, B), 1/m, each in [0, 10]. Default 0.7 on
  // every channel: the paper's value (§III-A.3, "we use beta = 0.7").
  Rgb beta_rgb_per_m{0.7, 0.7, 0.7};
  // beta for single-channel (gray) images, 1/m, in [0, 10]. Default: the paper's 0.7.
  double beta_gray_per_m = 0.7;
  // Ambient light E_A (paper eq. 2, "global veiling light bias from the water surface"), image
  // units (a white surface lit by E_A alone images at E_A), per channel R, G, B, each in [0, 10].
  Rgb ambient_rgb{0.15, 0.15, 0.15};
  double ambient_gray = 0.15;  // E_A for gray images, image units, [0, 10]
  // Adds the classic single-scattering ambient backscatter (1 - t) B_inf (Schechner & Karpel 2005;
  // the paper's eq. 1 airlight A) on top of eq. 2. Off by default: eq. 2 has no such term.
  bool backscatter = false;
  Rgb backscatter_rgb{0.05, 0.2, 0.25};  // B_inf per channel R, G, B, image units, [0, 1]
  double backscatter_gray = 0.15;        // B_inf for gray images, image units, [0, 1]
  // Scattering, for the terms that follow the water's optics rather than eq. 2 (the single-scatter
  // veil, the small-angle PSF; docs/model.md "The water's scattering"): the single-scattering
  // albedo omega = b / c per channel R, G, B, each in [0, 1], so that the scattering coefficient is
  // b = omega beta (beta taken as the beam attenuation c). Default 0.8, the value the physics
  // issue's measurements use (coastal waters, Solonenko & Mobley 2015: b/c at 550 nm 0.85 for II,
  // 0.86 for 3C). The paper model does not read these.
  Rgb scattering_albedo_rgb{0.8, 0.8, 0.8};
  double scattering_albedo_gray = 0.8;  // omega for gray images, [0, 1]
  // Elevation of the camera's optical axis above the horizontal, degrees, in [-90, 90] (-90:
  // looking straight down), for ambient "derived" (AmbientBackscatterShare).
  double ambient_view_elevation_deg = 0.0;
  // The phase function of that scattering (simulator/phase_function.h), JSON "phase": {...}.
  PhaseFunctionOptions phase;
  // Water from its inherent optical properties (simulator/iop.h): "" (off), a Jerlov type
  // (a(lambda), b(lambda) of Solonenko & Mobley 2015) or a CSV of wavelength_nm, a, b (1/m). When
  // set (type must be "custom"), ResolveWater fills beta_* with the effective beam attenuation c
  // (the weighted mean of c(lambda) over the light the camera sees, the r -> 0 limit) and
  // scattering_albedo_* with b / c of the same weights; "revised" derives beta^D(r) and beta^B from
  // the spectra.
  std::string iop;
  // The light's spectrum: "equal_energy", "d65" or a CSV of wavelength_nm, value.
  std::string illuminant = "equal_energy";
  // The camera's R, G, B sensitivities: "srgb" (CIE 1931 via Wyman et al. 2013 to linear sRGB) or a
  // CSV of wavelength_nm, r, g, b.
  std::string camera_sensitivity = "srgb";

  bool Check(std::string* why) const;
};

// Jerlov water types known to JerlovBeta, in table order: I, IA, IB, II, III, 1C, 3C, 5C, 7C, 9C.
std::vector<std::string> JerlovTypeNames();

struct JerlovBetas {
  Rgb rgb_per_m{};        // band means (see the header comment), 1/m, R, G, B
  double gray_per_m = 0;  // mean over 400-700 nm, 1/m
};
// Band-averaged coefficients of one Jerlov type. Throws Error for an unknown name.
JerlovBetas JerlovBeta(const std::string& type);
// The Jerlov (1976) Table XXVII value Kd(lambda) in 1/m for a type and a tabulated wavelength
// (350 ... 700 nm in 25 nm steps). Throws Error otherwise. Exposed so tests can check the table.
double JerlovKd(const std::string& type, int wavelength_nm);

// UWCNN's normalized residual energy ratio N_lambda per metre (t = N^d) for a Jerlov type, as
// used to synthesise the UWCNN training sets: C. Li, S. Anwar, F. Porikli, "Underwater scene prior
// inspired deep underwater image and video enhancement", Pattern Recognition 98 (2020) 107038
// (values as in the public synthesis scripts; provenance: shared/data/jerlov/SOURCE.md). R, G, B.
// Throws Error for an unknown type.
Rgb UwcnnResidualEnergy(const std::string& type);
// The canonical spelling of a Jerlov type ("C3" -> "3C"); Error when unknown.
std::string CanonicalJerlovType(const std::string& type);

// Returns options with beta_* filled in from the Jerlov preset when type is not "custom", and the
// type spelled canonically ("C3" -> "3C"); with iop set, beta_* = c and scattering_albedo_* = b / c
// from the spectra (simulator/iop.h). Throws Error for an unknown type or an unreadable file.
WaterOptions ResolveWater(const WaterOptions& options);

// The ambient backscatter B_inf: "typed" (water.backscatter_*, default) or "derived" from the
// ambient light, b, c and the phase function (DerivedBackscatter; docs/model.md "Ambient
// backscatter"). Render option "ambient".
enum class AmbientModel { kTyped, kDerived };
std::string AmbientModelName(AmbientModel model);  // "typed" | "derived"

// H(elevation): the share of single scattering that turns ambient light travelling downwards
// (uniform radiance over the downward hemisphere) into the direction back along a view ray of that
// elevation (degrees, -90 = looking straight down):
//   H = integral over downward directions w of p(angle(w, -d)) dw
//     = integral_0^pi p(theta) sin(theta) A(theta) dtheta,  A = 2 pi - 2 acos(clamp(-cot(theta)
//       tan(e), -1, 1)), e = -elevation the elevation of -d.
// 1/2 at the horizontal for every phase function, b_b/b looking straight down, 1 - b_b/b up.
double AmbientBackscatterShare(const PhaseFunction& phase, double view_elevation_deg);

// B_inf per channel (image order) of an infinite homogeneous water under a diffuse downwelling
// ambient light of irradiance E_A (image units) in single scattering:
//   B_inf,c = pi integral_0^inf b_c (E_A,c / pi) H e^{-c_c s} ds = (b_c / c_c) E_A,c H
// = omega_c E_A,c H (0 where c = 0). `water` resolved (ResolveWater).
std::vector<double> DerivedBackscatter(const WaterOptions& water, int channels);

// Per-channel values in image channel order: {gray} for 1 channel, {B, G, R} for 3.
std::vector<double> ChannelValues(const Rgb& rgb, double gray, int channels);

// t_c = exp(-beta_c r): CV_32FC(beta.size()) from range_m (CV_32FC1, metres). NaN range (invalid
// depth) is open water seen to infinity: t = 0. beta.size() must be 1 or 3 (image channel order).
// exp is a float polynomial (relative error < 2e-7); values below ~1.6e-38 round to that.
cv::Mat TransmissionMap(const cv::Mat& range_m, const std::vector<double>& beta_per_m);
// One row of TransmissionMap: range_row has `width` values, out has width * beta.size().
void TransmissionRows(const float* range_row, int width, const std::vector<double>& beta_per_m,
                      float* out);

}  // namespace turbid
