// The image-formation models besides the paper's eq. 2 (docs/model.md, "Models"):
//
//   paper    I = [J * h] t + (1 - t) E_L [+ (1 - t) B_inf],  t = exp(-beta r)        (eq. 2)
//   revised  I = [J * h] exp(-beta^D r) + (1 - exp(-beta^B r)) (B_inf + E_L)
//            D. Akkaynak, T. Treibitz, "A Revised Underwater Image Formation Model", CVPR 2018
//            (eq. 3 there), with separate direct and backscatter coefficients per channel, and
//            optionally beta^D(r) = a exp(b r) + c exp(d r) as Sea-thru fits it (D. Akkaynak,
//            T. Treibitz, "Sea-thru", CVPR 2019, eq. 10 there).
//   uwcnn    I = rho t + B (1 - t),  t_c = N_c^d
//            C. Li, S. Anwar, F. Porikli, Pattern Recognition 98 (2020) 107038: N_c per Jerlov
//            type (water.h, UwcnnResidualEnergy), B_c = scale N_c^exponent, d the distance
//            (optionally rescaled so the farthest pixel is at max_distance_m).
//
// r is the range along the viewing ray everywhere. The renderer (render.cc) composes these;
// this header holds their options and the per-row transmission of the Sea-thru form.
#pragma once

#include <string>
#include <vector>

#include "simulator/water.h"

namespace turbid {

enum class ImageModel { kPaper, kRevised, kUwcnn };
std::string ImageModelName(ImageModel model);
// "paper", "revised", "uwcnn"; throws Error otherwise.
ImageModel ImageModelFromName(const std::string& name);

// model "revised": beta^D is water.beta_* (and the Jerlov presets); B_inf is
// water.backscatter_* (always applied in this model); these are the rest.
struct RevisedOptions {
  // beta^B per channel (R, G, B) and for gray images, 1/m, each in [0, 10].
  Rgb beta_b_rgb_per_m{0.7, 0.7, 0.7};
  double beta_b_gray_per_m = 0.7;
  // Sea-thru's range-dependent beta^D(r) = a exp(b r) + c exp(d r) for the direct signal (the LED's
  // path to the scene keeps water.beta_*). a, c in [0, 10] 1/m; b, d in [-10, 0] 1/m (Sea-thru's
  // fit bounds: a, c >= 0, b, d <= 0).
  bool range_dependent = false;
  Rgb a_rgb{0.7, 0.7, 0.7}, b_rgb{0, 0, 0}, c_rgb{0, 0, 0}, d_rgb{0, 0, 0};
  double a_gray = 0.7, b_gray = 0.0, c_gray = 0.0, d_gray = 0.0;
  bool Check(std::string* why) const;
};

// model "uwcnn".
struct UwcnnOptions {
  // Jerlov type (I, IA, IB, II, III, 1C, 3C, 5C, 7C, 9C) whose N_lambda is used, or "custom".
  std::string type = "IB";
  // N per metre (R, G, B), in (0, 1]; set from the type unless it is "custom". Gray images use
  // n_gray (a type gives the mean of its R, G, B values).
  Rgb n_rgb_per_m{0.830, 0.950, 0.968};
  double n_gray_per_m = (0.830 + 0.950 + 0.968) / 3.0;
  // Background light B_c = backlight_scale * N_c^backlight_exponent (image units): the NYU-v2
  // script draws the exponent from U(3, 5) with scale 1.5 (default: the middle, 4); scale 0.8 with
  // exponent 0 is the other script's constant B = 0.8. Scale in [0, 10], exponent in [0, 50].
  double backlight_scale = 1.5;
  double backlight_exponent = 4.0;
  // > 0: distances are rescaled so the farthest valid pixel lies at this many metres (the
  // recipe's normalised depth x U(0.5, 15) m); 0: the scene's own ranges. [0, 1000] m.
  double max_distance_m = 0.0;
  bool Check(std::string* why) const;
};

// Returns options with n_* filled in from the type (unless "custom") and the type spelled
// canonically. Throws Error for an unknown type.
UwcnnOptions ResolveUwcnn(const UwcnnOptions& options);

// t[x, c] = exp(-(a_c exp(b_c r) + c_c exp(d_c r)) r) for one row; NaN range gives 0.
// coefficients: 4 vectors (a, b, c, d) of `channels` values each.
void SeaThruTransmissionRow(const float* range_row, int width, int channels, const float* a,
                            const float* b, const float* c, const float* d, float* out);
// The optical thickness of the same direct path, beta^D_c(r) r (-ln of the above); NaN range stays
// NaN. For the turbidity-dependent PSF (simulator/psf.h).
void SeaThruThicknessRow(const float* range_row, int width, int channels, const float* a,
                         const float* b, const float* c, const float* d, float* out);

}  // namespace turbid
