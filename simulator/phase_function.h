// The water's scattering phase function p(theta): the angular distribution of singly scattered
// light, per steradian, normalised so that its integral over the sphere is 1 (the volume
// scattering function is beta(theta) = b p(theta)). docs/model.md "Phase functions".
//
// Models:
//   - "fournier_forand" (default): Fournier & Forand (1994) in the form of Mobley, Sundman & Boss
//     (2002, Appl. Opt. 41(6) 1035, eq. 5), refractive index n = 1.10 and the slope mu chosen so
//     that the backscatter ratio b_b/b is `backscatter_ratio` (Mobley et al. 2002, eq. 6). With
//     b_b/b = 0.0183 it is the usual analytic stand-in for Petzold's "average particle" phase
//     function (mu = 3.5835), which Solonenko & Mobley (2015) used for the Jerlov water types.
//   - "henyey_greenstein": p = (1 - g^2) / (4 pi (1 + g^2 - 2 g cos theta)^1.5), mean cosine g.
//   - "isotropic": 1 / (4 pi).
//   - "tabulated": p (1/sr) read from a CSV file (`file`): a header line, then rows whose first
//     column is the angle in degrees and second p(theta) (any further columns ignored), angles
//     increasing in (0, 180]; e.g. Petzold's average-particle table (Mobley et al. 1993, Table 2;
//     shared/data/jerlov_iop). Interpolated log-log in angle, extended as a power law below the
//     first angle, and renormalised to integrate to 1 (the ratio applied is NormalisationFactor()).
#pragma once

#include <string>
#include <vector>

#include "core/fields.h"

namespace turbid {

struct PhaseFunctionOptions {
  std::string model = "fournier_forand";  // fournier_forand | henyey_greenstein | isotropic |
                                          // tabulated
  double backscatter_ratio = 0.0183;      // fournier_forand: b_b/b, in [0.002, 0.3]
  double g = 0.924;                       // henyey_greenstein: mean cosine, in [-0.99, 0.99]
  std::string file;                       // tabulated: CSV of angle (deg), p (1/sr)

  bool Check(std::string* why) const;
};

// The field table of PhaseFunctionOptions (keys model, backscatter_ratio, g, file).
const Fields<PhaseFunctionOptions>& PhaseFunctionFields();

class PhaseFunction {
 public:
  // Throws Error for options failing Check or an unreadable / malformed table file.
  explicit PhaseFunction(const PhaseFunctionOptions& options);

  // p(theta) in 1/sr for theta in radians, [0, pi]. Finite everywhere except theta = 0 for
  // fournier_forand and tables with a diverging forward peak (there, the value at 1e-6 rad).
  double operator()(double theta_rad) const;

  // Fraction of the scattered light within theta of the forward direction:
  // 2 pi integral_0^theta p(t) sin t dt. 1 at pi.
  double FractionWithin(double theta_rad) const;
  // b_b/b = 1 - FractionWithin(pi/2).
  double BackscatterRatio() const { return 1.0 - FractionWithin(kHalfPi); }
  // Mean cosine g = 2 pi integral p cos t sin t dt.
  double MeanCosine() const { return mean_cosine_; }
  // Mean square scattering angle (rad^2) of the light scattered within theta_max:
  // integral_0^theta_max t^2 p sin t dt / integral_0^theta_max p sin t dt.
  double MeanSquareAngle(double theta_max_rad) const;

  const PhaseFunctionOptions& options() const { return options_; }
  // fournier_forand: the slope mu found for the backscatter ratio; 0 otherwise.
  double FournierForandMu() const { return ff_mu_; }
  // tabulated: the factor the table was multiplied by to integrate to 1; 1 otherwise.
  double NormalisationFactor() const { return normalisation_; }

  // p(theta) sampled at n angles uniform in cos theta from 1 (theta = 0) to -1 (theta = pi),
  // for fast lookups (index i <-> cos theta = 1 - 2 i / (n - 1)); the first entry is the value at
  // the smallest grid angle. n >= 2.
  std::vector<float> TabulateByCosine(int n) const;

 private:
  static constexpr double kHalfPi = 1.5707963267948966;
  double Analytic(double theta_rad) const;  // fournier_forand / hg / isotropic, or table lookup
  void BuildCumulative();
  double Hermite(const std::vector<double>& v, bool moment, size_t i, double theta) const;

  PhaseFunctionOptions options_;
  double ff_mu_ = 0;
  double normalisation_ = 1;
  double mean_cosine_ = 0;
  // Tabulated input (radians, 1/sr), when model is "tabulated".
  std::vector<double> table_theta_, table_p_;
  // Integration grid: log-spaced angles, the cumulative fraction and 2nd moment at each, and the
  // fraction's slope d/d(ln theta).
  std::vector<double> grid_theta_, grid_fraction_, grid_moment2_, grid_slope_;
};

// Fournier-Forand backscatter ratio for refractive index n and slope mu (Mobley et al. 2002,
// eq. 6). Exposed for tests.
double FournierForandBackscatterRatio(double n, double mu);

}  // namespace turbid
