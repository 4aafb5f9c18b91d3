// Water from its inherent optical properties (docs/model.md, "Water from its IOPs"): absorption
// a(lambda), scattering b(lambda) and beam attenuation c = a + b, per Jerlov type or from a CSV,
// integrated with an illuminant and a camera sensitivity (simulator/spectra.h) into the effective
// per-channel coefficients the renderer uses.
//
// Jerlov IOPs: M. G. Solonenko, C. D. Mobley, "Inherent optical properties of Jerlov water types",
// Appl. Opt. 54(17), 5392-5401 (2015), Tables 4-8 (400-700 nm, 25 nm steps), the one complete
// source for all ten types (Williamson & Hollins 2022 measured six and disagree strongly on b; we
// do not mix them). The published table has two defects (rows duplicated from short wavelengths):
// 3C at 675/700 nm and 5C at 600-700 nm. There b is S&M's own eq. 8 with their Table 3 parameters,
// and a is the type-I (pure-water) absorption plus the type's excess absorption at its last good
// wavelength shaped like 7C's excess (docs/model.md gives the rule and the values).
#pragma once

#include <string>
#include <vector>

#include "simulator/spectra.h"

namespace turbid {

struct WaterSpectra {
  Spectrum a, b;  // on SpectralGrid(), 1/m
  std::string name;
};

// Solonenko & Mobley (2015) as published at a tabulated wavelength (400, 425, ..., 700 nm): a or b
// in 1/m; NaN for the defective cells named above. Throws Error for an unknown type or wavelength.
double SolonenkoMobleyPublished(const std::string& type, int wavelength_nm, char quantity);
// A type's spectra on the grid (defects filled as above, linear interpolation between the 25 nm
// samples), or a CSV (wavelength_nm, a, b; 1/m) when iop ends in ".csv". Throws Error.
WaterSpectra WaterSpectraFor(const std::string& iop);

// The camera's view of a water: per channel (R, G, B) and for gray (the sum of the channels'
// sensitivities), the weights w(lambda) = S_k(lambda) E(lambda) of the light that reaches it.
struct EffectiveWater {
  WaterSpectra water;
  std::array<Spectrum, 4> weight;  // R, G, B, gray
  // Weighted means over the spectrum, the r -> 0 limits: c_k = sum w c / sum w, b_k likewise.
  std::array<double, 4> c{}, b{};
  // t_D,k(r) = sum w rho e^{-c r} / sum w rho with rho = 1 (a grey surface): the direct signal's
  // transmission at range r, and beta^D_k(r) = -ln(t_D,k(r)) / r (its r -> 0 limit is c_k).
  double DirectTransmission(int k, double range_m) const;
  double DirectBeta(int k, double range_m) const;
  // beta^B_k: the backscatter's effective coefficient, from 1 - exp(-beta^B r) = sum w (b/c)(1 -
  // e^{-c r}) / sum w (b/c) at r = range_m (Akkaynak & Treibitz 2018, eq. 13 and 14 there).
  double BackscatterBeta(int k, double range_m) const;
};
EffectiveWater Effective(const WaterSpectra& water, const CameraSensitivity& camera,
                         const Spectrum& illuminant);

// A function of range tabulated at r = i * step_m, i = 0 .. values.size() - 1, read by linear
// interpolation (clamped at the last value).
struct RangeTable {
  double step_m = 1.0;
  std::vector<float> values;
  float At(float range_m) const;
};
// The direct transmission t_D (which = 'd') or the backscatter transmission exp(-beta^B(r) r)
// (which = 'b') of channel k over [0, max_range_m] in `samples` steps.
RangeTable TabulateTransmission(const EffectiveWater& e, int k, char which, double max_range_m,
                                int samples = 256);
// out[x * channels + ch] = tables[ch].At(r[x]); NaN range (open water) gives 0.
void TabulatedTransmissionRow(const float* range_row, int width, int channels,
                              const RangeTable* tables, float* out);

}  // namespace turbid
