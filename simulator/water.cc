#include "simulator/water.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/row_kernel.h"
#include "simulator/fast_math.h"
#include "simulator/iop.h"
#include "simulator/wide_kernel.h"

namespace turbid {
namespace {

constexpr int kWavelengths = 15;  // 350 ... 700 nm in 25 nm steps
constexpr int kTypes = 10;
const char* const kTypeNames[kTypes] = {"I", "IA", "IB", "II", "III", "1C", "3C", "5C", "7C", "9C"};

// Jerlov (1976), Marine Optics, Table XXVII p. 135: Kd(lambda) in 1/m; rows 350..700 nm,
// columns in kTypeNames order. Transcribed from shared/data/jerlov/jerlov_Kd.csv.
const double kKd[kWavelengths][kTypes] = {
    {0.062, 0.078, 0.1, 0.175, 0.32, 1.2, 1.7, 2.3, 3, 3.9},
    {0.038, 0.052, 0.066, 0.122, 0.22, 0.8, 1.1, 1.6, 2.1, 3},
    {0.028, 0.038, 0.051, 0.096, 0.185, 0.51, 0.78, 1.1, 1.6, 2.4},
    {0.022, 0.031, 0.042, 0.081, 0.16, 0.36, 0.54, 0.78, 1.2, 1.9},
    {0.019, 0.026, 0.036, 0.068, 0.135, 0.25, 0.39, 0.56, 0.89, 1.6},
    {0.018, 0.025, 0.033, 0.062, 0.116, 0.17, 0.29, 0.43, 0.71, 1.23},
    {0.027, 0.032, 0.042, 0.07, 0.115, 0.14, 0.22, 0.36, 0.58, 0.99},
    {0.043, 0.048, 0.054, 0.076, 0.116, 0.13, 0.2, 0.31, 0.49, 0.78},
    {0.063, 0.067, 0.072, 0.089, 0.12, 0.12, 0.19, 0.3, 0.46, 0.63},
    {0.089, 0.094, 0.099, 0.115, 0.148, 0.15, 0.21, 0.33, 0.46, 0.58},
    {0.235, 0.24, 0.245, 0.26, 0.295, 0.3, 0.33, 0.4, 0.48, 0.6},
    {0.305, 0.31, 0.315, 0.335, 0.375, 0.37, 0.4, 0.48, 0.54, 0.65},
    {0.36, 0.37, 0.375, 0.4, 0.445, 0.45, 0.46, 0.54, 0.63, 0.76},
    {0.42, 0.43, 0.435, 0.465, 0.52, 0.51, 0.56, 0.65, 0.78, 0.92},
    {0.56, 0.57, 0.58, 0.61, 0.66, 0.65, 0.71, 0.8, 0.92, 1.1},
};

// Canonical column index of a type name; "C3" is accepted for "3C". -1 when unknown.
int TypeIndex(const std::string& type) {
  std::string name = type;
  std::transform(name.begin(), name.end(), name.begin(), ::toupper);
  if (name.size() == 2 && name[0] == 'C' && std::isdigit(static_cast<unsigned char>(name[1])))
    name = std::string(1, name[1]) + "C";
  for (int i = 0; i < kTypes; ++i)
    if (name == kTypeNames[i]) return i;
  return -1;
}

// UWCNN's N_lambda (R, G, B) per Jerlov type, kTypeNames order: Li, Anwar & Porikli, Pattern
// Recognition 98 (2020) 107038, as the authors' synthesis scripts list them ([B, G, R] there).
// Types I and IA red are 0.85 / 0.84 as in those scripts (an earlier port's 0.805 / 0.804 made red
// non-monotone across I, IA, IB); provenance and the data file tests check against:
// shared/data/jerlov/uwcnn_nlambda.csv and its SOURCE.md.
const double kUwcnnN[kTypes][3] = {
    {0.850, 0.961, 0.982}, {0.840, 0.955, 0.975}, {0.830, 0.950, 0.968}, {0.800, 0.925, 0.940},
    {0.750, 0.885, 0.890}, {0.750, 0.885, 0.875}, {0.710, 0.820, 0.800}, {0.670, 0.730, 0.670},
    {0.620, 0.610, 0.500}, {0.550, 0.460, 0.290},
};

double BandMean(int column, int first_nm, int last_nm) {
  double sum = 0.0;
  int count = 0;
  for (int row = 0; row < kWavelengths; ++row) {
    const int nm = 350 + 25 * row;
    if (nm < first_nm || nm > last_nm) continue;
    sum += kKd[row][column];
    ++count;
  }
  return sum / count;
}

bool InRange(double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; }

}  // namespace

std::string AmbientModelName(AmbientModel model) {
  return model == AmbientModel::kDerived ? "derived" : "typed";
}

double AmbientBackscatterShare(const PhaseFunction& phase, double view_elevation_deg) {
  constexpr double kPi = 3.14159265358979323846;
  const double e = -view_elevation_deg * kPi / 180.0;  // elevation of -d, towards the camera
  const double tan_e = std::tan(e);
  // A(theta) / (2 pi): the share of the cone at theta around -d whose directions travel down.
  auto share = [&](double theta) {
    if (std::abs(e) >= kPi / 2 - 1e-12) return (e > 0) == (theta > kPi / 2) ? 1.0 : 0.0;
    const double k = -std::cos(theta) / std::sin(theta) * tan_e;
    return 1.0 - std::acos(std::clamp(k, -1.0, 1.0)) / kPi;
  };
  // H = integral share(theta) dF(theta), F = PhaseFunction::FractionWithin: midpoint share on a
  // uniform grid in theta (the share is constant near 0 and pi, where p peaks).
  constexpr int kSteps = 8192;
  double h = 0.0, f0 = 0.0;
  for (int i = 1; i <= kSteps; ++i) {
    const double theta1 = kPi * i / kSteps;
    const double f1 = i == kSteps ? 1.0 : phase.FractionWithin(theta1);
    h += share(kPi * (i - 0.5) / kSteps) * (f1 - f0);
    f0 = f1;
  }
  return h;
}

std::vector<double> DerivedBackscatter(const WaterOptions& water, int channels) {
  const double h =
      AmbientBackscatterShare(PhaseFunction(water.phase), water.ambient_view_elevation_deg);
  const std::vector<double> omega =
      ChannelValues(water.scattering_albedo_rgb, water.scattering_albedo_gray, channels);
  const std::vector<double> ambient =
      ChannelValues(water.ambient_rgb, water.ambient_gray, channels);
  const std::vector<double> beta =
      ChannelValues(water.beta_rgb_per_m, water.beta_gray_per_m, channels);
  std::vector<double> out(static_cast<size_t>(channels));
  for (int c = 0; c < channels; ++c) out[c] = beta[c] > 0.0 ? omega[c] * ambient[c] * h : 0.0;
  return out;
}

bool WaterOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& message) {
    if (why) *why = message;
    return false;
  };
  if (!std::isfinite(ambient_view_elevation_deg) || std::abs(ambient_view_elevation_deg) > 90.0)
    return fail("ambient_view_elevation_deg: must be in [-90, 90] degrees");
  if (type != "custom" && TypeIndex(type) < 0)
    return fail("type: unknown water type '" + type +
                "' (custom, I, IA, IB, II, III, 1C, 3C, 5C, 7C, 9C)");
  for (double b : beta_rgb_per_m)
    if (!InRange(b, 0.0, 10.0)) return fail("beta_rgb_per_m: each value must be in [0, 10] 1/m");
  if (!InRange(beta_gray_per_m, 0.0, 10.0)) return fail("beta_gray_per_m: must be in [0, 10] 1/m");
  for (double a : ambient_rgb)
    if (!InRange(a, 0.0, 10.0)) return fail("ambient_rgb: each value must be in [0, 10]");
  if (!InRange(ambient_gray, 0.0, 10.0)) return fail("ambient_gray: must be in [0, 10]");
  for (double b : backscatter_rgb)
    if (!InRange(b, 0.0, 1.0)) return fail("backscatter_rgb: each value must be in [0, 1]");
  if (!InRange(backscatter_gray, 0.0, 1.0)) return fail("backscatter_gray: must be in [0, 1]");
  for (double w : scattering_albedo_rgb)
    if (!InRange(w, 0.0, 1.0)) return fail("scattering_albedo_rgb: each value must be in [0, 1]");
  if (!InRange(scattering_albedo_gray, 0.0, 1.0))
    return fail("scattering_albedo_gray: must be in [0, 1]");
  std::string phase_why;
  if (!phase.Check(&phase_why)) return fail("phase." + phase_why);
  if (!iop.empty() && type != "custom")
    return fail("iop: water.type '" + type + "' names the water already (use type \"custom\")");
  if (!iop.empty() && iop.size() < 5 && TypeIndex(iop) < 0)
    return fail("iop: unknown Jerlov type '" + iop +
                "' (I, IA, IB, II, III, 1C, 3C, 5C, 7C, 9C, or a .csv file)");
  return true;
}

std::vector<std::string> JerlovTypeNames() {
  return {std::begin(kTypeNames), std::end(kTypeNames)};
}

JerlovBetas JerlovBeta(const std::string& type) {
  const int column = TypeIndex(type);
  if (column < 0) throw Error("water.type: unknown Jerlov water type '" + type + "'");
  JerlovBetas betas;
  betas.rgb_per_m = {BandMean(column, 600, 700), BandMean(column, 500, 575),
                     BandMean(column, 400, 475)};
  betas.gray_per_m = BandMean(column, 400, 700);
  return betas;
}

double JerlovKd(const std::string& type, int wavelength_nm) {
  const int column = TypeIndex(type);
  if (column < 0) throw Error("water.type: unknown Jerlov water type '" + type + "'");
  if (wavelength_nm < 350 || wavelength_nm > 700 || (wavelength_nm - 350) % 25 != 0)
    throw Error("Jerlov table: no row for " + std::to_string(wavelength_nm) + " nm");
  return kKd[(wavelength_nm - 350) / 25][column];
}

Rgb UwcnnResidualEnergy(const std::string& type) {
  const int column = TypeIndex(type);
  if (column < 0) throw Error("uwcnn.type: unknown Jerlov water type '" + type + "'");
  return {kUwcnnN[column][0], kUwcnnN[column][1], kUwcnnN[column][2]};
}

std::string CanonicalJerlovType(const std::string& type) {
  const int column = TypeIndex(type);
  if (column < 0) throw Error("unknown Jerlov water type '" + type + "'");
  return kTypeNames[column];
}

WaterOptions ResolveWater(const WaterOptions& options) {
  WaterOptions resolved = options;
  if (!options.iop.empty() && options.type == "custom") {
    const EffectiveWater e =
        Effective(WaterSpectraFor(options.iop), CameraSensitivityFor(options.camera_sensitivity),
                  IlluminantFor(options.illuminant));
    if (e.water.name.size() < 5) resolved.iop = e.water.name;  // canonical type spelling
    for (int k = 0; k < 3; ++k) {
      resolved.beta_rgb_per_m[k] = std::min(e.c[k], 10.0);
      resolved.scattering_albedo_rgb[k] = e.c[k] > 0.0 ? e.b[k] / e.c[k] : 0.0;
    }
    resolved.beta_gray_per_m = std::min(e.c[3], 10.0);
    resolved.scattering_albedo_gray = e.c[3] > 0.0 ? e.b[3] / e.c[3] : 0.0;
    return resolved;
  }
  if (options.type == "custom") return resolved;
  const int column = TypeIndex(options.type);
  if (column < 0) throw Error("water.type: unknown water type '" + options.type + "'");
  const JerlovBetas betas = JerlovBeta(options.type);
  resolved.type = kTypeNames[column];
  resolved.beta_rgb_per_m = betas.rgb_per_m;
  resolved.beta_gray_per_m = betas.gray_per_m;
  return resolved;
}

std::vector<double> ChannelValues(const Rgb& rgb, double gray, int channels) {
  if (channels == 1) return {gray};
  CV_Assert(channels == 3);
  return {rgb[2], rgb[1], rgb[0]};
}

namespace {

// t[x, c] = exp(-beta[c] r[x]); NaN range (open water) gives 0.
template <int kChannels>
TURBID_WIDE_KERNEL void TransmissionRow(const float* r, int width, const float* neg_beta,
                                        float* out) {
  for (int x = 0; x < width; ++x) {
    // max(0, NaN) is 0 and keep is 0 for NaN: arithmetic selects keep the loop vectorisable.
    const float range = std::max(0.0f, r[x]);
    const float keep = static_cast<float>(r[x] == r[x]);
    for (int c = 0; c < kChannels; ++c)
      out[x * kChannels + c] = keep * internal::ExpNonPositive(neg_beta[c] * range);
  }
}

}  // namespace

void TransmissionRows(const float* range_row, int width, const std::vector<double>& beta_per_m,
                      float* out) {
  float neg_beta[3] = {0, 0, 0};
  for (size_t c = 0; c < beta_per_m.size(); ++c) neg_beta[c] = -static_cast<float>(beta_per_m[c]);
  if (beta_per_m.size() == 3)
    TransmissionRow<3>(range_row, width, neg_beta, out);
  else
    TransmissionRow<1>(range_row, width, neg_beta, out);
}

cv::Mat TransmissionMap(const cv::Mat& range_m, const std::vector<double>& beta_per_m) {
  CV_Assert(range_m.type() == CV_32FC1);
  const int channels = static_cast<int>(beta_per_m.size());
  CV_Assert(channels == 1 || channels == 3);
  cv::Mat t(range_m.size(), CV_32FC(channels));
  cv::parallel_for_(cv::Range(0, range_m.rows), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y)
      TransmissionRows(range_m.ptr<float>(y), range_m.cols, beta_per_m, t.ptr<float>(y));
  });
  return t;
}

}  // namespace turbid
