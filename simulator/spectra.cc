#include "simulator/spectra.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "core/input_file.h"

namespace turbid {
namespace {

// A piecewise Gaussian of Wyman et al. 2013 (eq. 2): different widths left and right of the mean.
double Lobe(double x, double mean, double left, double right) {
  const double t = (x - mean) / (x < mean ? left : right);
  return std::exp(-0.5 * t * t);
}

// CIE 15:2004 Table T.1, D65 relative spectral power, 400-700 nm in 10 nm steps.
const double kD65[31] = {82.7549, 91.486,  93.4318, 86.6823, 104.865, 117.008, 117.812, 114.861,
                         115.923, 108.811, 109.354, 107.802, 104.79,  107.689, 104.405, 104.046,
                         100.0,   96.3342, 95.788,  88.6856, 90.0062, 89.5991, 87.6987, 83.2886,
                         83.6992, 80.0268, 80.2146, 82.2778, 78.2842, 69.7213, 71.6091};

bool IsCsvPath(const std::string& s) {
  return s.size() > 4 && s.compare(s.size() - 4, 4, ".csv") == 0;
}

}  // namespace

const std::vector<double>& SpectralGrid() {
  static const std::vector<double> grid = [] {
    std::vector<double> g;
    for (int nm = 400; nm <= 700; nm += 5) g.push_back(nm);
    return g;
  }();
  return grid;
}

std::array<double, 3> Cie1931Xyz(double l) {
  // Wyman, Sloan & Shirley 2013, the 1931 multi-lobe fit (Table 1 there).
  const double x = 1.056 * Lobe(l, 599.8, 37.9, 31.0) + 0.362 * Lobe(l, 442.0, 16.0, 26.7) -
                   0.065 * Lobe(l, 501.1, 20.4, 26.2);
  const double y = 0.821 * Lobe(l, 568.8, 46.9, 40.5) + 0.286 * Lobe(l, 530.9, 16.3, 31.1);
  const double z = 1.217 * Lobe(l, 437.0, 11.8, 36.0) + 0.681 * Lobe(l, 459.0, 26.0, 13.8);
  return {x, y, z};
}

Spectrum Resample(const std::vector<double>& x, const std::vector<double>& y, double outside) {
  Spectrum out;
  for (double l : SpectralGrid()) {
    if (x.empty() || l < x.front() || l > x.back()) {
      out.push_back(outside);
      continue;
    }
    const size_t i = std::upper_bound(x.begin(), x.end(), l) - x.begin();
    if (i >= x.size()) {
      out.push_back(y.back());
      continue;
    }
    const double w = (l - x[i - 1]) / (x[i] - x[i - 1]);
    out.push_back(y[i - 1] + w * (y[i] - y[i - 1]));
  }
  return out;
}

std::vector<std::vector<double>> ReadSpectraCsv(const std::string& path, int columns) {
  CheckInputFile(path);  // never open a FIFO or a device
  std::ifstream file(path);
  if (!file) throw Error(path, "cannot open the spectra file");
  std::string line;
  if (!std::getline(file, line)) throw Error(path, "empty file (a header line is expected)");
  std::vector<std::vector<double>> out(columns);
  int row = 1;
  while (std::getline(file, line)) {
    ++row;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::stringstream s(line);
    std::string cell;
    int k = 0;
    while (std::getline(s, cell, ',')) {
      if (k >= columns) throw Error(path, "row " + std::to_string(row) + ": too many columns");
      char* end = nullptr;
      const double v = std::strtod(cell.c_str(), &end);
      if (end == cell.c_str() || !std::isfinite(v) || v < 0.0)
        throw Error(path, "row " + std::to_string(row) + ": column " + std::to_string(k + 1) +
                              " is not a finite number >= 0");
      out[k++].push_back(v);
    }
    if (k != columns)
      throw Error(path, "row " + std::to_string(row) + ": expected " + std::to_string(columns) +
                            " columns");
    const auto& l = out[0];
    if (l.size() > 1 && !(l.back() > l[l.size() - 2]))
      throw Error(path, "row " + std::to_string(row) + ": wavelengths must increase");
  }
  if (out[0].size() < 2) throw Error(path, "fewer than 2 rows of spectra");
  return out;
}

CameraSensitivity CameraSensitivityFor(const std::string& name) {
  CameraSensitivity camera;
  camera.name = name;
  if (name == "srgb") {
    // IEC 61966-2-1 XYZ -> linear sRGB, negative lobes dropped.
    const double m[3][3] = {
        {3.2406, -1.5372, -0.4986}, {-0.9689, 1.8758, 0.0415}, {0.0557, -0.2040, 1.0570}};
    for (double l : SpectralGrid()) {
      const auto xyz = Cie1931Xyz(l);
      for (int k = 0; k < 3; ++k)
        camera.rgb[k].push_back(
            std::max(0.0, m[k][0] * xyz[0] + m[k][1] * xyz[1] + m[k][2] * xyz[2]));
    }
    return camera;
  }
  if (!IsCsvPath(name))
    throw Error("water.camera: '" + name + "' is neither \"srgb\" nor a .csv file");
  const auto columns = ReadSpectraCsv(name, 4);
  for (int k = 0; k < 3; ++k) camera.rgb[k] = Resample(columns[0], columns[k + 1], 0.0);
  for (int k = 0; k < 3; ++k) {
    double sum = 0.0;
    for (double v : camera.rgb[k]) sum += v;
    if (!(sum > 0.0)) throw Error(name, "a channel has no sensitivity within 400-700 nm");
  }
  return camera;
}

Spectrum IlluminantFor(const std::string& name) {
  if (name == "equal_energy") return Spectrum(SpectralGrid().size(), 1.0);
  if (name == "d65") {
    std::vector<double> x, y;
    for (int i = 0; i < 31; ++i) x.push_back(400 + 10 * i), y.push_back(kD65[i] / 100.0);
    return Resample(x, y, 0.0);
  }
  if (!IsCsvPath(name))
    throw Error("water.illuminant: '" + name + "' is not equal_energy, d65 or a .csv file");
  const auto columns = ReadSpectraCsv(name, 2);
  Spectrum e = Resample(columns[0], columns[1], 0.0);
  double sum = 0.0;
  for (double v : e) sum += v;
  if (!(sum > 0.0)) throw Error(name, "the illuminant has no power within 400-700 nm");
  return e;
}

}  // namespace turbid
