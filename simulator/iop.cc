#include "simulator/iop.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "simulator/water.h"

namespace turbid {
namespace {

constexpr int kWavelengths = 13;  // 400 ... 700 nm in 25 nm steps
constexpr int kTypes = 10;        // I, IA, IB, II, III, 1C, 3C, 5C, 7C, 9C (JerlovTypeNames order)
constexpr double kDefect = std::numeric_limits<double>::quiet_NaN();

// Solonenko & Mobley (2015), Appl. Opt. 54(17) 5392, Tables 4-8: a(lambda) and b(lambda), 1/m; rows
// 400 ... 700 nm, columns I, IA, IB, II, III, 1C, 3C, 5C, 7C, 9C. kDefect: the printed row repeats
// a short-wavelength row (see iop.h). Transcribed from shared/data/jerlov_iop/
// solonenko_mobley_2015_a_b_c_400_700_wide.csv (provenance in its SOURCE.md, section 1).
const double kA[kWavelengths][kTypes] = {
    {0.022, 0.0295, 0.0331, 0.0355, 0.0615, 0.227, 0.388, 0.66, 1.03, 1.613},
    {0.017, 0.0225, 0.0246, 0.0257, 0.0449, 0.147, 0.236, 0.437, 0.753, 1.242},
    {0.018, 0.0221, 0.0235, 0.0241, 0.0388, 0.105, 0.154, 0.297, 0.542, 0.943},
    {0.019, 0.0216, 0.0225, 0.0228, 0.0335, 0.077, 0.105, 0.204, 0.388, 0.709},
    {0.026, 0.0282, 0.0287, 0.0288, 0.0358, 0.064, 0.081, 0.151, 0.29, 0.543},
    {0.046, 0.0468, 0.0469, 0.0469, 0.0507, 0.068, 0.078, 0.127, 0.233, 0.43},
    {0.062, 0.0622, 0.0623, 0.0622, 0.0646, 0.076, 0.082, 0.117, 0.195, 0.348},
    {0.082, 0.0821, 0.0822, 0.0821, 0.0838, 0.092, 0.095, 0.119, 0.175, 0.291},
    {0.228, 0.228, 0.2278, 0.228, 0.229, 0.236, 0.239, kDefect, 0.301, 0.39},
    {0.295, 0.295, 0.296, 0.296, 0.297, 0.304, 0.307, kDefect, 0.367, 0.436},
    {0.334, 0.334, 0.334, 0.334, 0.336, 0.344, 0.346, kDefect, 0.403, 0.456},
    {0.434, 0.435, 0.435, 0.436, 0.439, 0.455, kDefect, kDefect, 0.559, 0.604},
    {0.582, 0.582, 0.582, 0.582, 0.583, 0.586, kDefect, kDefect, 0.621, 0.651},
};
const double kB[kWavelengths][kTypes] = {
    {0.0062, 0.0092, 0.0795, 0.616, 1.69, 0.63, 1.83, 2.28, 4.02, 5.36},
    {0.00482, 0.00755, 0.0732, 0.555, 1.52, 0.567, 1.65, 2.06, 3.63, 4.84},
    {0.00381, 0.00631, 0.068, 0.504, 1.38, 0.514, 1.5, 1.87, 3.3, 4.39},
    {0.00306, 0.00536, 0.0635, 0.459, 1.26, 0.469, 1.36, 1.71, 3.01, 4.01},
    {0.00249, 0.00461, 0.0597, 0.421, 1.152, 0.429, 1.25, 1.56, 2.76, 3.67},
    {0.00205, 0.00402, 0.0565, 0.387, 1.06, 0.395, 1.15, 1.44, 2.54, 3.38},
    {0.0017, 0.00354, 0.0536, 0.358, 0.98, 0.365, 1.06, 1.33, 2.35, 3.12},
    {0.00143, 0.00315, 0.0511, 0.332, 0.908, 0.338, 0.985, 1.23, 2.18, 2.89},
    {0.00122, 0.00283, 0.0488, 0.309, 0.845, 0.314, 0.916, kDefect, 2.03, 2.69},
    {0.00104, 0.00256, 0.0468, 0.288, 0.788, 0.293, 0.855, kDefect, 1.89, 2.51},
    {0.000899, 0.00234, 0.045, 0.27, 0.737, 0.274, 0.8, kDefect, 1.77, 2.35},
    {0.000782, 0.00214, 0.0434, 0.253, 0.692, 0.257, kDefect, kDefect, 1.66, 2.2},
    {0.000685, 0.00198, 0.042, 0.238, 0.65, 0.242, kDefect, kDefect, 1.56, 2.07},
};
// b in the defective cells from S&M's eq. 8 with their Table 3 parameters (3C: 675, 700 nm; 5C:
// 600 ... 700 nm), as reconstructed in the same data file's b_eq8_reconstructed column.
const double kB3C[2] = {0.7542, 0.709};
const double kB5C[5] = {1.1468, 1.0702, 1.0014, 0.9395, 0.8834};

int Column(const std::string& type) {
  const std::string canonical = CanonicalJerlovType(type);
  const std::vector<std::string> names = JerlovTypeNames();
  return static_cast<int>(std::find(names.begin(), names.end(), canonical) - names.begin());
}

// a and b of a column at row i with the defects filled (see iop.h).
double FilledA(int i, int column) {
  if (!std::isnan(kA[i][column])) return kA[i][column];
  const int last_good = column == 6 ? 10 : 7;  // 3C: 650 nm, 5C: 575 nm
  const double excess = kA[last_good][column] - kA[last_good][0];
  const double shape_ref = kA[last_good][8] - kA[last_good][0];  // 7C's excess there
  return kA[i][0] + excess * (kA[i][8] - kA[i][0]) / shape_ref;
}
double FilledB(int i, int column) {
  if (!std::isnan(kB[i][column])) return kB[i][column];
  return column == 6 ? kB3C[i - 11] : kB5C[i - 8];
}

double Sum(const Spectrum& w, const Spectrum& v) {
  double s = 0.0;
  for (size_t i = 0; i < w.size(); ++i) s += w[i] * v[i];
  return s;
}

}  // namespace

double SolonenkoMobleyPublished(const std::string& type, int nm, char quantity) {
  const int column = Column(type);
  if (nm < 400 || nm > 700 || (nm - 400) % 25 != 0)
    throw Error("Solonenko & Mobley table: no row for " + std::to_string(nm) + " nm");
  if (quantity != 'a' && quantity != 'b') throw Error("Solonenko & Mobley table: a or b");
  const int row = (nm - 400) / 25;
  return quantity == 'a' ? kA[row][column] : kB[row][column];
}

WaterSpectra WaterSpectraFor(const std::string& iop) {
  WaterSpectra w;
  w.name = iop;
  if (iop.size() > 4 && iop.compare(iop.size() - 4, 4, ".csv") == 0) {
    const auto columns = ReadSpectraCsv(iop, 3);
    if (columns[0].front() > 400.0 || columns[0].back() < 700.0)
      throw Error(iop, "the spectra must cover 400-700 nm");
    w.a = Resample(columns[0], columns[1], 0.0);
    w.b = Resample(columns[0], columns[2], 0.0);
    return w;
  }
  const int column = Column(iop);  // throws for an unknown type
  w.name = CanonicalJerlovType(iop);
  std::vector<double> x, a, b;
  for (int i = 0; i < kWavelengths; ++i) {
    x.push_back(400 + 25 * i);
    a.push_back(FilledA(i, column));
    b.push_back(FilledB(i, column));
  }
  w.a = Resample(x, a, 0.0);
  w.b = Resample(x, b, 0.0);
  return w;
}

EffectiveWater Effective(const WaterSpectra& water, const CameraSensitivity& camera,
                         const Spectrum& illuminant) {
  EffectiveWater e;
  e.water = water;
  const size_t n = SpectralGrid().size();
  Spectrum c(n);
  for (size_t i = 0; i < n; ++i) c[i] = water.a[i] + water.b[i];
  for (int k = 0; k < 4; ++k) {
    e.weight[k].resize(n);
    for (size_t i = 0; i < n; ++i)
      e.weight[k][i] =
          illuminant[i] *
          (k < 3 ? camera.rgb[k][i] : camera.rgb[0][i] + camera.rgb[1][i] + camera.rgb[2][i]);
    const double total = Sum(e.weight[k], Spectrum(n, 1.0));
    if (!(total > 0.0)) throw Error("water.iop: the camera sees none of the illuminant");
    e.c[k] = Sum(e.weight[k], c) / total;
    e.b[k] = Sum(e.weight[k], water.b) / total;
  }
  return e;
}

double EffectiveWater::DirectTransmission(int k, double r) const {
  double num = 0.0, den = 0.0;
  for (size_t i = 0; i < weight[k].size(); ++i) {
    num += weight[k][i] * std::exp(-(water.a[i] + water.b[i]) * r);
    den += weight[k][i];
  }
  return num / den;
}

double EffectiveWater::DirectBeta(int k, double r) const {
  if (r <= 0.0) return c[k];
  return -std::log(DirectTransmission(k, r)) / r;
}

double EffectiveWater::BackscatterBeta(int k, double r) const {
  if (r <= 0.0) {
    // r -> 0: sum w b / sum w (b / c).
    double num = 0.0, den = 0.0;
    for (size_t i = 0; i < weight[k].size(); ++i) {
      const double cc = water.a[i] + water.b[i];
      if (cc <= 0.0) continue;
      num += weight[k][i] * water.b[i];
      den += weight[k][i] * water.b[i] / cc;
    }
    return den > 0.0 ? num / den : c[k];
  }
  double num = 0.0, den = 0.0;
  for (size_t i = 0; i < weight[k].size(); ++i) {
    const double cc = water.a[i] + water.b[i];
    if (cc <= 0.0) continue;
    num += weight[k][i] * water.b[i] / cc * (1.0 - std::exp(-cc * r));
    den += weight[k][i] * water.b[i] / cc;
  }
  if (!(den > 0.0)) return c[k];
  return -std::log(std::max(1.0 - num / den, 1e-300)) / r;
}

float RangeTable::At(float r) const {
  const float u = std::max(r, 0.0f) / static_cast<float>(step_m);
  const int last = static_cast<int>(values.size()) - 1;
  if (u >= last) return values[last];
  const int i = static_cast<int>(u);
  const float w = u - i;
  return values[i] + w * (values[i + 1] - values[i]);
}

RangeTable TabulateTransmission(const EffectiveWater& e, int k, char which, double max_range_m,
                                int samples) {
  RangeTable table;
  const double top = std::isfinite(max_range_m) && max_range_m > 0.0 ? max_range_m : 1.0;
  table.step_m = top / samples;
  for (int i = 0; i <= samples; ++i) {
    const double r = i * table.step_m;
    const double t =
        which == 'd' ? e.DirectTransmission(k, r) : std::exp(-e.BackscatterBeta(k, r) * r);
    table.values.push_back(static_cast<float>(t));
  }
  return table;
}

void TabulatedTransmissionRow(const float* range_row, int width, int channels,
                              const RangeTable* tables, float* out) {
  for (int x = 0; x < width; ++x) {
    const float r = range_row[x];
    for (int ch = 0; ch < channels; ++ch) out[x * channels + ch] = r == r ? tables[ch].At(r) : 0.0f;
  }
}

}  // namespace turbid
