#include "simulator/phase_function.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "core/input_file.h"

namespace turbid {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kFfIndex = 1.10;     // Mobley et al. (2002): n = 1.10 for the FF family
constexpr double kGridMinRad = 1e-6;  // smallest angle of the integration grid
constexpr int kGridPoints = 2048;     // log-spaced from kGridMinRad to pi

bool IsModel(const std::string& m) {
  return m == "fournier_forand" || m == "henyey_greenstein" || m == "isotropic" || m == "tabulated";
}

// Mobley et al. (2002) eq. 5, theta in radians.
double FournierForand(double theta, double n, double mu) {
  const double nu = 0.5 * (3.0 - mu);
  const double k = 4.0 / (3.0 * (n - 1.0) * (n - 1.0));
  const double s2 = std::pow(std::sin(0.5 * theta), 2);
  const double delta = k * s2;
  const double delta_nu = std::pow(delta, nu);
  const double bracket =
      nu * (1.0 - delta) - (1.0 - delta_nu) + (delta * (1.0 - delta_nu) - nu * (1.0 - delta)) / s2;
  const double main = bracket / (4.0 * kPi * (1.0 - delta) * (1.0 - delta) * delta_nu);
  const double d180 = k;
  const double d180_nu = std::pow(d180, nu);
  const double c = std::cos(theta);
  const double back = (1.0 - d180_nu) / (16.0 * kPi * (d180 - 1.0) * d180_nu) * (3 * c * c - 1);
  return main + back;
}

// mu in (3, 5) with FournierForandBackscatterRatio(n, mu) = target, by bisection (the ratio
// rises with mu).
double FournierForandMuFor(double target) {
  double lo = 3.0 + 1e-9, hi = 5.0 - 1e-9;
  const double b_lo = FournierForandBackscatterRatio(kFfIndex, lo);
  const double b_hi = FournierForandBackscatterRatio(kFfIndex, hi);
  if (!(target >= b_lo && target <= b_hi)) {
    std::ostringstream why;
    why << "phase function: fournier_forand backscatter_ratio " << target
        << " is outside what n = 1.10 reaches (" << b_lo << " ... " << b_hi << ")";
    throw Error(why.str());
  }
  for (int i = 0; i < 200 && hi - lo > 1e-13; ++i) {
    const double mid = 0.5 * (lo + hi);
    (FournierForandBackscatterRatio(kFfIndex, mid) < target ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

void ReadTable(const std::string& path, std::vector<double>* theta, std::vector<double>* p) {
  CheckInputFile(path);  // never open a FIFO or a device
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot read the phase-function table");
  std::string line;
  std::getline(in, line);  // header
  int row = 1;
  while (std::getline(in, line)) {
    ++row;
    if (line.empty() || line == "\r") continue;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream fields(line);
    double angle_deg = 0, value = 0;
    if (!(fields >> angle_deg >> value) || !std::isfinite(angle_deg) || !std::isfinite(value) ||
        value <= 0 || angle_deg <= 0 || angle_deg > 180 ||
        (!theta->empty() && angle_deg * kPi / 180 <= theta->back()))
      throw Error(path + ": line " + std::to_string(row) +
                  ": expected 'angle_deg,p' with angles increasing in (0, 180] and p > 0");
    theta->push_back(angle_deg * kPi / 180.0);
    p->push_back(value);
  }
  if (theta->size() < 2) throw Error(path + ": a phase-function table needs at least two rows");
}

}  // namespace

double FournierForandBackscatterRatio(double n, double mu) {
  const double nu = 0.5 * (3.0 - mu);
  const double d90 = 4.0 / (3.0 * (n - 1.0) * (n - 1.0)) * 0.5;  // sin^2(45 deg) = 1/2
  const double d90_nu = std::pow(d90, nu);
  return 1.0 - (1.0 - d90 * d90_nu - 0.5 * (1.0 - d90_nu)) / ((1.0 - d90) * d90_nu);
}

bool PhaseFunctionOptions::Check(std::string* why) const {
  if (!IsModel(model)) {
    *why = "model: expected one of fournier_forand, henyey_greenstein, isotropic, tabulated";
    return false;
  }
  if (!(backscatter_ratio >= 0.002 && backscatter_ratio <= 0.3)) {
    *why = "backscatter_ratio: expected a value in [0.002, 0.3]";
    return false;
  }
  if (!(g >= -0.99 && g <= 0.99)) {
    *why = "g: expected a value in [-0.99, 0.99]";
    return false;
  }
  if (model == "tabulated" && file.empty()) {
    *why = "file: a tabulated phase function needs a table file";
    return false;
  }
  return true;
}

const Fields<PhaseFunctionOptions>& PhaseFunctionFields() {
  using O = PhaseFunctionOptions;
  static const Fields<O> fields =
      Fields<O>()
          .String("model", &O::model,
                  "fournier_forand (default; Petzold-like at b_b/b 0.0183), henyey_greenstein, "
                  "isotropic or tabulated")
          .Number("backscatter_ratio", &O::backscatter_ratio,
                  "fournier_forand: backscatter ratio b_b/b", NumberRange::Between(0.002, 0.3))
          .Number("g", &O::g, "henyey_greenstein: mean cosine", NumberRange::Between(-0.99, 0.99))
          .String("file", &O::file, "tabulated: CSV file of angle (deg), p (1/sr)");
  return fields;
}

PhaseFunction::PhaseFunction(const PhaseFunctionOptions& options) : options_(options) {
  std::string why;
  if (!options.Check(&why)) throw Error("phase function: " + why);
  if (options.model == "fournier_forand") ff_mu_ = FournierForandMuFor(options.backscatter_ratio);
  if (options.model == "tabulated") ReadTable(options.file, &table_theta_, &table_p_);
  BuildCumulative();
}

double PhaseFunction::Analytic(double theta) const {
  theta = std::clamp(theta, kGridMinRad, kPi);
  const std::string& m = options_.model;
  if (m == "fournier_forand") return FournierForand(theta, kFfIndex, ff_mu_);
  if (m == "henyey_greenstein") {
    const double g = options_.g;
    return (1 - g * g) / (4 * kPi * std::pow(1 + g * g - 2 * g * std::cos(theta), 1.5));
  }
  if (m == "isotropic") return 1.0 / (4.0 * kPi);
  // Tabulated: log-log interpolation, a power law below the first angle, constant past the last.
  const std::vector<double>& t = table_theta_;
  const std::vector<double>& p = table_p_;
  if (theta >= t.back()) return p.back() * normalisation_;
  size_t i = std::upper_bound(t.begin(), t.end(), theta) - t.begin();
  i = std::clamp<size_t>(i, 1, t.size() - 1);
  const double slope = std::log(p[i] / p[i - 1]) / std::log(t[i] / t[i - 1]);
  return p[i - 1] * std::pow(theta / t[i - 1], slope) * normalisation_;
}

double PhaseFunction::operator()(double theta_rad) const { return Analytic(theta_rad); }

// Cumulative fraction F and second moment M on a log grid u = ln(theta): dF/du = 2 pi p sin(t) t
// and dM/du = t^2 dF/du, integrated per interval with 2-point Gauss-Legendre (error O(h^4)); below
// the first grid angle p is extended as a power law and integrated in closed form. Between grid
// points F and M are cubic Hermite in u (values and slopes known). A table is renormalised so that
// F(pi) = 1; analytic models are normalised by construction (the tests check an independent
// quadrature).
void PhaseFunction::BuildCumulative() {
  const double log_lo = std::log(kGridMinRad), log_hi = std::log(kPi);
  const double du = (log_hi - log_lo) / (kGridPoints - 1);
  auto slope = [this](double t) { return 2 * kPi * Analytic(t) * std::sin(t) * t; };
  grid_theta_.resize(kGridPoints);
  grid_slope_.resize(kGridPoints);
  for (int i = 0; i < kGridPoints; ++i) {
    grid_theta_[i] = i == kGridPoints - 1 ? kPi : std::exp(log_lo + i * du);
    grid_slope_[i] = slope(grid_theta_[i]);
  }
  const double t0 = grid_theta_[0], p0 = Analytic(t0);
  const double s = std::log(Analytic(grid_theta_[1]) / p0) / std::log(grid_theta_[1] / t0);
  // integral_0^t0 2 pi p0 (t/t0)^s t dt (sin t = t there), the same with t^2 and with cos t = 1.
  grid_fraction_.assign(kGridPoints, 0);
  grid_moment2_.assign(kGridPoints, 0);
  grid_fraction_[0] = s > -2 ? 2 * kPi * p0 * t0 * t0 / (s + 2) : 0;
  grid_moment2_[0] = s > -4 ? 2 * kPi * p0 * std::pow(t0, 4) / (s + 4) : 0;
  double mean_cos = grid_fraction_[0];
  const double gauss = 0.5 / std::sqrt(3.0);
  for (int i = 1; i < kGridPoints; ++i) {
    const double ua = std::log(grid_theta_[i - 1]), ub = std::log(grid_theta_[i]);
    const double h = ub - ua, mid = 0.5 * (ua + ub);
    double df = 0, dm = 0, dc = 0;
    for (double x : {mid - gauss * h, mid + gauss * h}) {
      const double t = std::exp(x), f = 0.5 * h * slope(t);
      df += f;
      dm += t * t * f;
      dc += std::cos(t) * f;
    }
    grid_fraction_[i] = grid_fraction_[i - 1] + df;
    grid_moment2_[i] = grid_moment2_[i - 1] + dm;
    mean_cos += dc;
  }
  const double total = grid_fraction_.back();
  if (options_.model == "tabulated") normalisation_ = 1.0 / total;
  for (int i = 0; i < kGridPoints; ++i) {
    grid_fraction_[i] /= total;
    grid_moment2_[i] /= total;
    grid_slope_[i] /= total;
  }
  mean_cosine_ = mean_cos / total;
}

// Cubic Hermite interpolation in u = ln(theta) of a grid quantity with values v and slopes d
// (dv/du), at theta in [grid_theta_[i-1], grid_theta_[i]].
double PhaseFunction::Hermite(const std::vector<double>& v, bool moment, size_t i,
                              double theta) const {
  const double ta = grid_theta_[i - 1], tb = grid_theta_[i];
  const double h = std::log(tb / ta), x = std::log(theta / ta) / h;
  const double da = grid_slope_[i - 1] * (moment ? ta * ta : 1) * h;
  const double db = grid_slope_[i] * (moment ? tb * tb : 1) * h;
  const double x2 = x * x, x3 = x2 * x;
  return (2 * x3 - 3 * x2 + 1) * v[i - 1] + (x3 - 2 * x2 + x) * da + (-2 * x3 + 3 * x2) * v[i] +
         (x3 - x2) * db;
}

double PhaseFunction::FractionWithin(double theta_rad) const {
  if (theta_rad <= 0) return 0;
  if (theta_rad >= kPi) return 1;
  if (theta_rad <= grid_theta_[0]) {
    const double e =
        std::log(grid_fraction_[1] / grid_fraction_[0]) / std::log(grid_theta_[1] / grid_theta_[0]);
    return grid_fraction_[0] * std::pow(theta_rad / grid_theta_[0], e);
  }
  const size_t i =
      std::upper_bound(grid_theta_.begin(), grid_theta_.end(), theta_rad) - grid_theta_.begin();
  return Hermite(grid_fraction_, false, i, theta_rad);
}

double PhaseFunction::MeanSquareAngle(double theta_max_rad) const {
  theta_max_rad = std::clamp(theta_max_rad, grid_theta_[1], kPi);
  const size_t i = std::min<size_t>(
      std::upper_bound(grid_theta_.begin(), grid_theta_.end(), theta_max_rad) - grid_theta_.begin(),
      grid_theta_.size() - 1);
  return Hermite(grid_moment2_, true, i, theta_max_rad) / FractionWithin(theta_max_rad);
}

std::vector<float> PhaseFunction::TabulateByCosine(int n) const {
  if (n < 2) throw Error("phase function: a table by cosine needs at least 2 entries");
  std::vector<float> out(n);
  for (int i = 0; i < n; ++i) {
    const double c = std::clamp(1.0 - 2.0 * i / (n - 1), -1.0, 1.0);
    out[i] = static_cast<float>(Analytic(std::acos(c)));
  }
  return out;
}

}  // namespace turbid
