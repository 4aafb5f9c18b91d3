// The image-formation models besides the paper's eq. 2 (docs/model.md, "Models"):
//
//   paper    I = [J * h] t + (1 - t) E_L [+ (1 - t) B_inf],  t = exp(-beta r)        (eq. 2)
//   revised  I = [J * h] exp(-beta^D r) + (1 - exp(-beta^B r)) (B_inf + E_L)
//            D. Akkaynak, T. Treibitz, "A Revised Underwater Image Formation Model", CVPR 2018
//            (eq. 3 there), with separate direct and backscatter coefficients per channel, and
//            optionally beta^D(r) = a exp(b r) + c exp(d r) as Sea-thru fits it (D. Akkaynak,
//            T. Treibitz, "Sea-thru", CVPR 2019, eq. 10 there).
//   uwcnn    I = A rho t + A (1 - t),  t_c = N_c^d,  A_c = scale N_c^exponent
//            C. Li, S. Anwar, F. Porikli, Pattern Recognition 98 (2020) 107038, as the authors'
//            NYU-v2 synthesis scripts compute it: N_c per Jerlov type (water.h,
//            UwcnnResidualEnergy), A on the direct signal too, d the distance (optionally rescaled
//            so the farthest pixel is at max_distance_m). domain "encoded" (default, the scripts):
//            rho and I are 8-bit sRGB codes / 255; "linear": rho and I are linear light.
//            Gray images: the equal-weight mean of the three channels' recipes.
//
// r is the range along the viewing ray everywhere. The renderer (render.cc) composes these;
// this header holds their options and the per-row transmission of the Sea-thru form.
#pragma once

#include <array>
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
  // With water.iop set: beta^D(r) (the direct signal) and beta^B(r) are derived from the spectra
  // (simulator/iop.h) instead of beta_* and beta_b_*; false keeps the typed-in values.
  bool from_iop = true;
  Rgb a_rgb{0.7, 0.7, 0.7}, b_rgb{0, 0, 0}, c_rgb{0, 0, 0}, d_rgb{0, 0, 0};
  double a_gray = 0.7, b_gray = 0.0, c_gray = 0.0, d_gray = 0.0;
  bool Check(std::string* why) const;
};

// Where the uwcnn recipe is applied: on 8-bit sRGB codes scaled to [0, 1] as the published
// scripts do ("encoded"), or on linear light ("linear", turbid's variant).
enum class UwcnnDomain { kEncoded, kLinear };

// model "uwcnn".
struct UwcnnOptions {
  // Jerlov type (I, IA, IB, II, III, 1C, 3C, 5C, 7C, 9C) whose N_lambda is used, or "custom".
  std::string type = "IB";
  // N per metre (R, G, B), in (0, 1]; set from the type unless it is "custom". Gray images take
  // the mean of the three channels' recipes (transmissions N_c^d weighted by A_c), so n_gray_per_m
  // is informative only (the mean of R, G, B) and not read by the renderer.
  Rgb n_rgb_per_m{0.830, 0.950, 0.968};
  double n_gray_per_m = (0.830 + 0.950 + 0.968) / 3.0;
  // Global light A_c = backlight_scale * N_c^backlight_exponent (image units), on the direct signal
  // and as the background: the NYU-v2 script draws the exponent from U(3, 5) per image with scale
  // 1.5 (default: the middle, 4; a sweep draws it with a uniform distribution on 3..5); scale 0.8
  // with exponent 0 is the other script's constant 0.8. Scale in [0, 10], exponent in [0, 50].
  double backlight_scale = 1.5;
  double backlight_exponent = 4.0;
  // > 0: distances are rescaled so the farthest valid pixel lies at this many metres (the
  // recipe's normalised depth x U(0.5, 15) m); 0: the scene's own ranges. [0, 1000] m.
  double max_distance_m = 0.0;
  UwcnnDomain domain = UwcnnDomain::kEncoded;
  bool Check(std::string* why) const;
};

// The per-channel constants of the uwcnn recipe for an image of `channels` (1 or 3, image order
// B, G, R) with distances multiplied by distance_scale: beta_c = -ln(N_c) scale (t = N^d),
// A_c. For gray images (1 channel) the three channels' values are kept in rgb_* and the image
// uses t = sum_c w_c exp(-beta_c r), w_c = A_c / sum A, and A = mean A_c, so that I = mean_c of the
// three recipes.
struct UwcnnConstants {
  std::vector<double> beta, light;                      // per image channel, 1/m and image units
  std::array<float, 3> gray_neg_beta{}, gray_weight{};  // B, G, R order; gray images only
};
UwcnnConstants UwcnnChannelConstants(const UwcnnOptions& resolved, int channels,
                                     double distance_scale);
// One row of the gray transmission above: out[x] = sum_c weight[c] exp(neg_beta[c] r[x]); NaN
// range (open water) gives 0.
void UwcnnGrayTransmissionRow(const float* range_row, int width, const float* neg_beta,
                              const float* weight, float* out);
// n values: linear light to its 8-bit sRGB code / 255 (values clipped to [0, 1]), what
// the recipe reads from an 8-bit image file.
void UwcnnEncodeRow(const float* linear, int n, float* coded);
// In place on n values: sRGB-coded values (any real value; the curve extended past 1 and mirrored
// below 0) back to linear light.
void UwcnnDecodeRow(float* values, int n);

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
