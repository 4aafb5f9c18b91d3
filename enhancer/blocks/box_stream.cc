#include "enhancer/blocks/box_stream.h"

#include <cstddef>

namespace turbid::box_stream {

// The direct sums of a window of 3 or 5 (values cn apart), left to right.
TURBID_ROW_KERNEL void BoxDirect3Row(const float* __restrict s, double* __restrict d, int cn,
                                     int n) {
  for (int i = 0; i < n; ++i) {
    d[i] = (static_cast<double>(s[i]) + static_cast<double>(s[i + cn])) +
           static_cast<double>(s[i + 2 * cn]);
  }
}

TURBID_ROW_KERNEL void BoxDirect5Row(const float* __restrict s, double* __restrict d, int cn,
                                     int n) {
  for (int i = 0; i < n; ++i) {
    d[i] = (((static_cast<double>(s[i]) + static_cast<double>(s[i + cn])) +
             static_cast<double>(s[i + 2 * cn])) +
            static_cast<double>(s[i + 3 * cn])) +
           static_cast<double>(s[i + 4 * cn]);
  }
}

// One output row of the column running sum: s = SUM + h_new, out = float(s), SUM = s - h_old.
TURBID_ROW_KERNEL void BoxColumnRow(double* __restrict sum, const double* __restrict add,
                                    const double* __restrict sub, float* __restrict out, int n) {
  for (int i = 0; i < n; ++i) {
    const double s = sum[i] + add[i];
    out[i] = static_cast<float>(s);
    sum[i] = s - sub[i];
  }
}

TURBID_ROW_KERNEL void BoxColumnRowScaled(double* __restrict sum, const double* __restrict add,
                                          const double* __restrict sub, float* __restrict out,
                                          double scale, int n) {
  for (int i = 0; i < n; ++i) {
    const double s = sum[i] + add[i];
    out[i] = static_cast<float>(s * scale);
    sum[i] = s - sub[i];
  }
}

TURBID_ROW_KERNEL void BoxAccumulateRow(double* __restrict sum, const double* __restrict add,
                                        int n) {
  for (int i = 0; i < n; ++i) sum[i] += add[i];
}

// The running sums of four rows at once (independent chains side by side, the sums in
// registers): for each channel c, from the first sum h_r[c], h_r[(i + 1) cn + c] = h_r[i cn + c]
// + (double(e_r[(i + k) cn + c]) - double(e_r[i cn + c])) in order of i.
// The rows come as doubles (converted beforehand by vector conversions, exact): a scalar float
// to double conversion per value was the chains' bottleneck (one per cycle).
TURBID_ROW_KERNEL void BoxRunning4(const double* __restrict e0, const double* __restrict e1,
                                   const double* __restrict e2, const double* __restrict e3,
                                   double* __restrict h0, double* __restrict h1,
                                   double* __restrict h2, double* __restrict h3, int cn, int k,
                                   int steps) {
  const int ahead = k * cn;
  for (int c = 0; c < cn; ++c) {
    double s0 = h0[c], s1 = h1[c], s2 = h2[c], s3 = h3[c];
    for (int i = 0; i < steps; ++i) {
      const int j = i * cn + c;
      s0 = s0 + (e0[j + ahead] - e0[j]);
      s1 = s1 + (e1[j + ahead] - e1[j]);
      s2 = s2 + (e2[j + ahead] - e2[j]);
      s3 = s3 + (e3[j + ahead] - e3[j]);
      h0[j + cn] = s0;
      h1[j + cn] = s1;
      h2[j + cn] = s2;
      h3[j + cn] = s3;
    }
  }
}

// BoxRunning4 for eight rows of one channel (cn = 1) whose bordered rows are `stride` values
// apart (e + r stride): the same per-row operations in the same order, h_r[i + 1] = h_r[i] +
// (e_r[i + k] - e_r[i]), but each chain step is one vector add over four rows (two vectors: rows
// 0-3 and 4-7), so eight chains run side by side instead of four (the four scalar chains of
// BoxRunning4 are latency-bound at ~1 value per cycle). The differences of four columns are
// formed row-wise and transposed (4 x 4) into column vectors; the sums are transposed back into
// the rows, stored 32-byte aligned where the rows allow it (unaligned stores split cache lines).
TURBID_ROW_KERNEL void BoxRunning8Gray(const double* __restrict e, size_t stride,
                                       double* const* __restrict h, int k, int steps) {
  using V4d = double __attribute__((vector_size(32)));
  // The difference of four columns of one row: e_r[i + k ..] - e_r[i ..].
  auto diff = [k](V4d& d, const double* p) {
    V4d a, b;
    std::memcpy(&a, p + k, sizeof(a));
    std::memcpy(&b, p, sizeof(b));
    d = a - b;
  };
  auto transpose = [](V4d& r0, V4d& r1, V4d& r2, V4d& r3) {
    const V4d t0 = __builtin_shufflevector(r0, r1, 0, 4, 2, 6);
    const V4d t1 = __builtin_shufflevector(r0, r1, 1, 5, 3, 7);
    const V4d t2 = __builtin_shufflevector(r2, r3, 0, 4, 2, 6);
    const V4d t3 = __builtin_shufflevector(r2, r3, 1, 5, 3, 7);
    r0 = __builtin_shufflevector(t0, t2, 0, 1, 4, 5);
    r1 = __builtin_shufflevector(t1, t3, 0, 1, 4, 5);
    r2 = __builtin_shufflevector(t0, t2, 2, 3, 6, 7);
    r3 = __builtin_shufflevector(t1, t3, 2, 3, 6, 7);
  };
  double* hr[8];
  for (int r = 0; r < 8; ++r) hr[r] = h[r];
  // First the columns up to where the stores h_r + i + 1 are 32-byte aligned (when the eight
  // rows share their alignment), one row at a time.
  int i = 0;
  const auto misalign = [](const double* p) { return reinterpret_cast<uintptr_t>(p) % 32; };
  bool same = misalign(hr[0]) % sizeof(double) == 0;
  for (int r = 1; r < 8; ++r) same = same && misalign(hr[r]) == misalign(hr[0]);
  if (same) {
    while (i < steps && misalign(hr[0] + i + 1) != 0) ++i;
    for (int r = 0; r < 8; ++r) {
      const double* er = e + static_cast<size_t>(r) * stride;
      double sum = hr[r][0];
      for (int j = 0; j < i; ++j) {
        sum = sum + (er[j + k] - er[j]);
        hr[r][j + 1] = sum;
      }
    }
  }
  V4d s[2];
  for (int g = 0; g < 2; ++g)
    s[g] = V4d{hr[4 * g][i], hr[4 * g + 1][i], hr[4 * g + 2][i], hr[4 * g + 3][i]};
  for (; i + 4 <= steps; i += 4) {
    for (int g = 0; g < 2; ++g) {
      const double* eg = e + static_cast<size_t>(4 * g) * stride + i;
      V4d d0, d1, d2, d3;
      diff(d0, eg);
      diff(d1, eg + stride);
      diff(d2, eg + 2 * stride);
      diff(d3, eg + 3 * stride);
      transpose(d0, d1, d2, d3);  // now d_c: column i + c of the four rows
      V4d s0 = s[g] + d0;
      V4d s1 = s0 + d1;
      V4d s2 = s1 + d2;
      V4d s3 = s2 + d3;
      s[g] = s3;
      transpose(s0, s1, s2, s3);  // now s_r: columns i + 1 .. i + 4 of row 4 g + r
      std::memcpy(hr[4 * g] + i + 1, &s0, sizeof(s0));
      std::memcpy(hr[4 * g + 1] + i + 1, &s1, sizeof(s1));
      std::memcpy(hr[4 * g + 2] + i + 1, &s2, sizeof(s2));
      std::memcpy(hr[4 * g + 3] + i + 1, &s3, sizeof(s3));
    }
  }
  for (int r = 0; r < 8; ++r) {
    const double* er = e + static_cast<size_t>(r) * stride;
    double sum = s[r / 4][r % 4];
    for (int j = i; j < steps; ++j) {
      sum = sum + (er[j + k] - er[j]);
      hr[r][j + 1] = sum;
    }
  }
}

TURBID_ROW_KERNEL void WidenRow(const float* __restrict in, double* __restrict out, int n) {
  for (int i = 0; i < n; ++i) out[i] = static_cast<double>(in[i]);
}

void BoxRunning1(const double* e, double* h, int cn, int k, int steps) {
  for (int c = 0; c < cn; ++c) {
    double s = h[c];
    for (int i = 0; i < steps; ++i) {
      const int j = i * cn + c;
      s = s + (e[j + k * cn] - e[j]);
      h[j + cn] = s;
    }
  }
}

BoxScratch& ThreadBoxScratch() {
  thread_local BoxScratch scratch;
  return scratch;
}

}  // namespace turbid::box_stream
