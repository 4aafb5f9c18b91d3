#include "scenes/camera_encoding.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

#include "core/cpu.h"
#include "core/error.h"

namespace turbid {
namespace {

// IEC 61966-2-1 decoding (code value in [0, 1] -> linear), in double.
double SrgbDecode(double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); }

// Tables for one bit depth: decision thresholds, decoded codes and a bin index that gives a lower
// bound of the code from floor(v * bins). The bins are finer than the closest two thresholds
// (8 bits: bin 1/65536 against a spacing of at least 1 / (255 * 12.92)), so one branch-free step
// after the lookup almost always finds the code; the loop after it keeps the result exact anyway.
// The thresholds are computed in double and held as the smallest float at or above each: for a
// float v, v >= threshold (double) exactly when v >= that float, so float compares give the codes
// of the double thresholds, bit for bit, and vectorise (8 lanes with AVX2 gathers).
struct SrgbTables {
  int levels = 0;                  // L = 2^bits - 1
  int bins = 0;
  std::vector<float> threshold;    // smallest float >= decode((k + 1/2) / L), k < L; [L] = inf
  std::vector<float> decoded;      // decoded[k] = decode(k / L), k = 0 .. L
  std::vector<int32_t> first;      // first[i]: codes certainly reached by every v in bin i

  explicit SrgbTables(int bits) : levels((1 << bits) - 1), bins(65536) {
    std::vector<double> exact(levels + 1);
    threshold.resize(levels + 1);
    decoded.resize(levels + 1);
    for (int k = 0; k < levels; ++k) {
      exact[k] = SrgbDecode((k + 0.5) / levels);
      float f = static_cast<float>(exact[k]);
      if (static_cast<double>(f) < exact[k]) f = std::nextafter(f, 2.0f);
      threshold[k] = f;
    }
    exact[levels] = std::numeric_limits<double>::infinity();
    threshold[levels] = std::numeric_limits<float>::infinity();  // the step never passes L
    for (int k = 0; k <= levels; ++k) decoded[k] = static_cast<float>(SrgbDecode(double(k) / levels));
    if (bits == 8) BuildStepTable();
    first.resize(bins + 1);
    int count = 0;
    for (int i = 0; i <= bins; ++i) {
      // A value in bin i is at least i / bins up to float rounding of v * bins.
      const double low = static_cast<double>(i) / bins * (1.0 - 1e-6);
      while (count < levels && exact[count] <= low) ++count;
      first[i] = count;
    }
  }

  // The one-step table (8 bits): for each of kStepBins + 1 bins of width 2^-13 (v * 2^13 is exact
  // in float, so bin i holds exactly the v in [i, i + 1) / 2^13), {the first threshold above the
  // codes every v of the bin reaches, the decoded code below it, the decoded code above it, the
  // code below it}: the decoded code of v is step[4 i + 1 + (v >= step[4 i])], its code
  // step[4 i + 3] + (v >= step[4 i]). Built only when every bin holds at
  // most one threshold (checked below; true for 8 bits: thresholds are >= 3e-4 apart, bins 1.2e-4).
  static constexpr int kStepBins = 8192;
  std::vector<float> step;

  void BuildStepTable() {
    std::vector<float> table(4 * (kStepBins + 1));
    for (int i = 0; i <= kStepBins; ++i) {
      const float low = static_cast<float>(i) / kStepBins, high = (i + 1.0f) / kStepBins;
      int q = 0;
      while (q < levels && threshold[q] <= low) ++q;
      if (q < levels && threshold[q + 1] < high) return;  // two thresholds in one bin: no table
      table[4 * i] = threshold[q];
      table[4 * i + 1] = decoded[q];
      table[4 * i + 2] = decoded[std::min(q + 1, levels)];
      table[4 * i + 3] = static_cast<float>(q);  // the code below (EncodeCodesRow8)
    }
    step = std::move(table);
  }

  // v in [0, 1] (clipped, not NaN): the code of the exact curve.
  int Code(float v) const {
    int q = first[static_cast<int>(v * static_cast<float>(bins))];
    q += v >= threshold[q];         // branch-free: at most one threshold in a bin, as a rule
    while (v >= threshold[q]) ++q;  // threshold[levels] is infinite: stops at L
    return q;
  }
};

#if defined(__x86_64__) && defined(__GNUC__)
// The scalar loop's codes eight values at a time (clip, bin lookup, threshold steps until no lane
// moves, decoded lookup: the same compares, so the same bits). Returns how many values it did
// (a multiple of 8); the caller finishes the tail.
__attribute__((target("avx2"))) int DecodedCodesAvx2(const SrgbTables& t, const float* in, int n,
                                                     float* out) {
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
  const __m256 bins = _mm256_set1_ps(static_cast<float>(t.bins));
  const float* thresholds = t.threshold.data();
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    // max(x, 0) returns its second operand, 0, for NaN: NaN -> 0 as the scalar clip.
    const __m256 v = _mm256_min_ps(_mm256_max_ps(_mm256_loadu_ps(in + i), zero), one);
    __m256i q =
        _mm256_i32gather_epi32(t.first.data(), _mm256_cvttps_epi32(_mm256_mul_ps(v, bins)), 4);
    for (;;) {
      const __m256 reached = _mm256_cmp_ps(v, _mm256_i32gather_ps(thresholds, q, 4), _CMP_GE_OQ);
      if (_mm256_testz_ps(reached, reached)) break;
      q = _mm256_sub_epi32(q, _mm256_castps_si256(reached));  // + 1 where reached (mask = -1)
    }
    _mm256_storeu_ps(out + i, _mm256_i32gather_ps(t.decoded.data(), q, 4));
  }
  return i;
}

// The one-step table's lookups (SrgbTables::step), eight or sixteen values at a time: two
// independent-of-the-code gathers instead of the search's chain of three or four. The same
// compares as the scalar loop, so the same bits.
__attribute__((target("avx2"))) int StepCodesAvx2(const SrgbTables& t, const float* in, int n,
                                                  float* out) {
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
  const __m256 bins = _mm256_set1_ps(static_cast<float>(SrgbTables::kStepBins));
  const float* step = t.step.data();
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m256 v = _mm256_min_ps(_mm256_max_ps(_mm256_loadu_ps(in + i), zero), one);
    const __m256i at = _mm256_slli_epi32(_mm256_cvttps_epi32(_mm256_mul_ps(v, bins)), 2);
    const __m256 above = _mm256_cmp_ps(v, _mm256_i32gather_ps(step, at, 4), _CMP_GE_OQ);
    // + 1 for the code below, + 2 (mask -1 subtracted) where the threshold is reached.
    const __m256i pick =
        _mm256_sub_epi32(_mm256_add_epi32(at, _mm256_set1_epi32(1)), _mm256_castps_si256(above));
    _mm256_storeu_ps(out + i, _mm256_i32gather_ps(step, pick, 4));
  }
  return i;
}

// GCC 12 warns of -Wmaybe-uninitialized inside avx512fintrin.h's own _mm512_undefined_* operands
// (GCC bug 105593, fixed in its headers in GCC 13); silenced for the AVX-512 kernels below only.
#if !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
// Sixteen values' step-table entries: `at` the entry's first float (its threshold) and `above`
// the lanes whose clipped value reached it.
__attribute__((target("avx512f"))) inline void StepLookup16(const float* step, const float* in,
                                                            __m512i* at, __mmask16* above) {
  const __m512 bins = _mm512_set1_ps(static_cast<float>(SrgbTables::kStepBins));
  const __m512 v =
      _mm512_min_ps(_mm512_max_ps(_mm512_loadu_ps(in), _mm512_setzero_ps()), _mm512_set1_ps(1.0f));
  *at = _mm512_slli_epi32(_mm512_cvttps_epi32(_mm512_mul_ps(v, bins)), 2);
  *above = _mm512_cmp_ps_mask(v, _mm512_i32gather_ps(*at, step, 4), _CMP_GE_OQ);
}

__attribute__((target("avx512f"))) int StepCodesAvx512(const SrgbTables& t, const float* in, int n,
                                                       float* out) {
  const float* step = t.step.data();
  int i = 0;
  for (; i + 16 <= n; i += 16) {
    __m512i at;
    __mmask16 above;
    StepLookup16(step, in + i, &at, &above);
    const __m512i pick = _mm512_mask_add_epi32(_mm512_add_epi32(at, _mm512_set1_epi32(1)), above,
                                               at, _mm512_set1_epi32(2));
    _mm512_storeu_ps(out + i, _mm512_i32gather_ps(pick, step, 4));
  }
  return i;
}

// The codes (bytes) by the one-step table, sixteen at a time.
__attribute__((target("avx512f"))) int StepCodeBytesAvx512(const SrgbTables& t, const float* in,
                                                           int n, uint8_t* out) {
  const __m512 one = _mm512_set1_ps(1.0f);
  const float* step = t.step.data();
  int i = 0;
  for (; i + 16 <= n; i += 16) {
    __m512i at;
    __mmask16 above;
    StepLookup16(step, in + i, &at, &above);
    const __m512 below = _mm512_i32gather_ps(_mm512_add_epi32(at, _mm512_set1_epi32(3)), step, 4);
    const __m512i code = _mm512_cvttps_epi32(_mm512_mask_add_ps(below, above, below, one));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out + i), _mm512_cvtepi32_epi8(code));
  }
  return i;
}
#if !defined(__clang__)
#pragma GCC diagnostic pop
#endif
#endif

// The decoded sRGB codes of n values, from `in` to `out` (may be the same).
void DecodedCodes(const SrgbTables& tables, const float* in, int n, float* out) {
  int i = 0;
#if defined(__x86_64__) && defined(__GNUC__)
  const CpuLevel level = KernelCpuLevel();
  if (!tables.step.empty() && level >= CpuLevel::kAvx512)
    i = StepCodesAvx512(tables, in, n, out);
  else if (!tables.step.empty() && level >= CpuLevel::kAvx2)
    i = StepCodesAvx2(tables, in, n, out);
  else if (level >= CpuLevel::kAvx2)
    i = DecodedCodesAvx2(tables, in, n, out);
#endif
  for (; i < n; ++i) {
    const float v = std::min(in[i] > 0.0f ? in[i] : 0.0f, 1.0f);  // NaN -> 0
    out[i] = tables.decoded[tables.Code(v)];
  }
}

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
  DecodedCodes(TablesFor(bits), values, n, values);
}

void QuantiseEncodedRowSwapRB(float* values, int n, CameraEncoding encoding, int bits) {
  CV_Assert(n % 3 == 0);
  if (encoding == CameraEncoding::kLinear) {
    QuantiseEncodedRow(values, n, encoding, bits);  // vectorised; the reorder after it
    for (int i = 0; i < n; i += 3) std::swap(values[i], values[i + 2]);
    return;
  }
  DecodedCodes(TablesFor(bits), values, n, values);
  for (int i = 0; i < n; i += 3) std::swap(values[i], values[i + 2]);
}

void EncodeCodesRow8(const float* in, int n, CameraEncoding encoding, uint8_t* out) {
  int i = 0;
  if (encoding == CameraEncoding::kLinear) {
    for (; i < n; ++i) {
      const float v = std::min(in[i] > 0.0f ? in[i] : 0.0f, 1.0f);  // NaN -> 0
      out[i] = static_cast<uint8_t>(static_cast<int>(v * 255.0f + 0.5f));
    }
    return;
  }
  const SrgbTables& tables = TablesFor(8);
#if defined(__x86_64__) && defined(__GNUC__)
  if (!tables.step.empty() && KernelCpuLevel() >= CpuLevel::kAvx512)
    i = StepCodeBytesAvx512(tables, in, n, out);
#endif
  for (; i < n; ++i) {
    const float v = std::min(in[i] > 0.0f ? in[i] : 0.0f, 1.0f);  // NaN -> 0
    out[i] = static_cast<uint8_t>(tables.Code(v));
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
