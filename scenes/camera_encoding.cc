#include "scenes/camera_encoding.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "core/error.h"

namespace turbid {
namespace {

// IEC 61966-2-1 decoding (code value in [0, 1] -> linear), in double.
double SrgbDecode(double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); }

// Tables for one bit depth: decision thresholds, decoded codes and a bin index that gives a lower
// bound of the code from floor(v * bins). The bins are finer than the closest two thresholds
// (8 bits: bin 1/65536 against a spacing of at least 1 / (255 * 12.92)), so one branch-free step
// after the lookup almost always finds the code; the loop after it keeps the result exact anyway.
struct SrgbTables {
  int levels = 0;                  // L = 2^bits - 1
  int bins = 0;
  std::vector<double> threshold;  // threshold[k] = decode((k + 1/2) / L), k = 0 .. L - 1; [L] = inf
  std::vector<float> decoded;      // decoded[k] = decode(k / L), k = 0 .. L
  std::vector<uint16_t> first;     // first[i]: codes certainly reached by every v in bin i

  explicit SrgbTables(int bits) : levels((1 << bits) - 1), bins(65536) {
    threshold.resize(levels + 1);
    decoded.resize(levels + 1);
    for (int k = 0; k < levels; ++k) threshold[k] = SrgbDecode((k + 0.5) / levels);
    threshold[levels] = std::numeric_limits<double>::infinity();  // the step never passes L
    for (int k = 0; k <= levels; ++k) decoded[k] = static_cast<float>(SrgbDecode(double(k) / levels));
    first.resize(bins + 1);
    int count = 0;
    for (int i = 0; i <= bins; ++i) {
      // A value in bin i is at least i / bins up to float rounding of v * bins.
      const double low = static_cast<double>(i) / bins * (1.0 - 1e-6);
      while (count < levels && threshold[count] <= low) ++count;
      first[i] = static_cast<uint16_t>(count);
    }
  }

  // Compared in double: a float v on either side of a threshold gets the code of the exact curve.
  int Code(float v) const {
    int q = first[static_cast<int>(v * static_cast<float>(bins))];
    const double value = v;
    q += value >= threshold[q];         // branch-free: at most one threshold in a bin, as a rule
    while (value >= threshold[q]) ++q;  // threshold[levels] is infinite: stops at L
    return q;
  }
};

const SrgbTables& TablesFor(int bits) {
  static const SrgbTables eight(8), sixteen(16);
  return bits == 16 ? sixteen : eight;
}

}  // namespace

std::string CameraEncodingName(CameraEncoding encoding) {
  return encoding == CameraEncoding::kSrgb ? "srgb" : "linear";
}

CameraEncoding CameraEncodingFromName(const std::string& name, const std::string& what) {
  if (name == "srgb") return CameraEncoding::kSrgb;
  if (name == "linear") return CameraEncoding::kLinear;
  throw Error(what + ": unknown encoding '" + name + "' (srgb, linear)");
}

Transfer TransferFor(CameraEncoding encoding) {
  return encoding == CameraEncoding::kSrgb ? Transfer::kSrgb : Transfer::kLinear;
}

void QuantiseEncodedRow(float* values, int n, CameraEncoding encoding, int bits) {
  CV_Assert(bits == 8 || bits == 16);
  if (encoding == CameraEncoding::kLinear) {
    const float levels = bits == 8 ? 255.0f : 65535.0f;
    for (int i = 0; i < n; ++i) {
      const float v = std::min(values[i] > 0.0f ? values[i] : 0.0f, 1.0f);  // NaN -> 0
      values[i] = static_cast<float>(static_cast<int>(v * levels + 0.5f)) / levels;
    }
    return;
  }
  const SrgbTables& tables = TablesFor(bits);
  for (int i = 0; i < n; ++i) {
    const float v = std::min(values[i] > 0.0f ? values[i] : 0.0f, 1.0f);
    values[i] = tables.decoded[tables.Code(v)];
  }
}

void QuantiseEncodedRowSwapRB(float* values, int n, CameraEncoding encoding, int bits) {
  CV_Assert(n % 3 == 0);
  if (encoding == CameraEncoding::kLinear) {
    QuantiseEncodedRow(values, n, encoding, bits);  // vectorised; the reorder after it
    for (int i = 0; i < n; i += 3) std::swap(values[i], values[i + 2]);
    return;
  }
  const SrgbTables& tables = TablesFor(bits);
  const auto code = [&tables](float value) {
    const float v = std::min(value > 0.0f ? value : 0.0f, 1.0f);  // NaN -> 0
    return tables.decoded[tables.Code(v)];
  };
  for (int i = 0; i < n; i += 3) {
    const float b = code(values[i]), g = code(values[i + 1]), r = code(values[i + 2]);
    values[i] = r;
    values[i + 1] = g;
    values[i + 2] = b;
  }
}

cv::Mat QuantiseEncoded(const cv::Mat& linear, CameraEncoding encoding, int bits) {
  CV_Assert(linear.depth() == CV_32F);
  cv::Mat out = linear.clone();
  const int per_row = out.cols * out.channels();
  cv::parallel_for_(cv::Range(0, out.rows), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y)
      QuantiseEncodedRow(out.ptr<float>(y), per_row, encoding, bits);
  });
  return out;
}

cv::Mat EncodeCodes(const cv::Mat& linear, CameraEncoding encoding, int bits) {
  CV_Assert(linear.depth() == CV_32F && (bits == 8 || bits == 16));
  cv::Mat out(linear.size(), linear.type());
  const int per_row = linear.cols * linear.channels();
  const float levels = bits == 8 ? 255.0f : 65535.0f;
  const SrgbTables* tables = encoding == CameraEncoding::kSrgb ? &TablesFor(bits) : nullptr;
  cv::parallel_for_(cv::Range(0, linear.rows), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      const float* in = linear.ptr<float>(y);
      float* codes = out.ptr<float>(y);
      for (int i = 0; i < per_row; ++i) {
        const float v = std::min(in[i] > 0.0f ? in[i] : 0.0f, 1.0f);  // NaN -> 0
        codes[i] = tables != nullptr ? static_cast<float>(tables->Code(v))
                                     : static_cast<float>(static_cast<int>(v * levels + 0.5f));
      }
    }
  });
  return out;
}

}  // namespace turbid
