// Spectra and their integration into a camera's R, G, B (docs/model.md, "Water from its IOPs").
//
// The default camera is the sRGB standard observer: the CIE 1931 2-degree colour matching functions
// in the analytic multi-lobe fit of C. Wyman, P.-P. Sloan, P. Shirley, "Simple Analytic
// Approximations to the CIE XYZ Color Matching Functions", JCGT 2(2) 2013, eq. 2 and Table 1 there
// (a closed form, no table), taken to linear sRGB (IEC 61966-2-1 XYZ -> RGB matrix) with the
// negative lobes dropped (a camera's sensitivity is not negative). Illuminants: equal energy
// (default), CIE D65 (CIE 15:2004 Table T.1, 400-700 nm in 10 nm steps) or a CSV. Cameras: the
// default above, or a CSV of wavelength_nm, r, g, b (e.g. a measured camera).
#pragma once

#include <array>
#include <string>
#include <vector>

namespace turbid {

// A sampled spectrum on the common grid (SpectralGrid()).
using Spectrum = std::vector<double>;

// The wavelengths every spectrum is resampled to: 400, 405, ..., 700 nm.
const std::vector<double>& SpectralGrid();

// The CIE 1931 colour matching functions x, y, z at a wavelength (nm), Wyman et al. 2013
// multi-lobe.
std::array<double, 3> Cie1931Xyz(double wavelength_nm);

// Camera sensitivities R, G, B on the grid.
struct CameraSensitivity {
  std::array<Spectrum, 3> rgb;
  std::string name;
};
// "srgb" (the default above); else a CSV path with header and columns wavelength_nm, r, g, b
// (linear interpolation; zero outside the file's range). Throws Error("<file>: ...").
CameraSensitivity CameraSensitivityFor(const std::string& name_or_csv);
// "equal_energy", "d65", or a CSV path with wavelength_nm, value. Throws Error.
Spectrum IlluminantFor(const std::string& name_or_csv);

// Reads a CSV of numeric columns with one header line: returns columns (the first is the
// wavelength, strictly increasing). `columns` is the count expected. Throws Error("<file>: ...").
std::vector<std::vector<double>> ReadSpectraCsv(const std::string& path, int columns);
// Linear interpolation of (x, y) samples onto the grid; `outside` beyond the samples' range.
Spectrum Resample(const std::vector<double>& x, const std::vector<double>& y, double outside);

}  // namespace turbid
