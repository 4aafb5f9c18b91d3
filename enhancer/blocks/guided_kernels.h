// Internals of the guided filter (guided_filter.cc, guided_kernels.cc): row kernels of window
// sums and coefficients, shared by the streamed one-channel filter. Not part of the API.
#pragma once

#include <cstddef>

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define TURBID_HAVE_ROLLING_QUADS 1
#endif

namespace turbid::guided_internal {

// The per-pixel formulas (He 2013 Alg. 1), from window sums and 1/N = inv_cx[x] * inv_cy; every
// kernel below uses these, so all paths round alike. Self-guided: a = var / (var + eps),
// b = m (1 - a). Guided: a = cov(I, p) / (var(I) + eps), b = mean p - a mean I. Output:
// q = (sum a * I + sum b) / N.
inline void SelfCoefficient(float s_i, float s_ii, float inv, float eps, float* a, float* b) {
  const float m = s_i * inv;
  const float var = s_ii * inv - m * m;
  const float av = var / (var + eps);
  *a = av;
  *b = m - av * m;
}

inline void GuidedCoefficient(float s_i, float s_p, float s_ii, float s_ip, float inv, float eps,
                              float* a, float* b) {
  const float mi = s_i * inv, mp = s_p * inv;
  const float var = s_ii * inv - mi * mi;
  const float cov = s_ip * inv - mi * mp;
  const float av = cov / (var + eps);
  *a = av;
  *b = mp - av * mi;
}

inline float ApplyCoefficient(float s_a, float s_b, float guide, float inv) {
  return (s_a * guide + s_b) * inv;
}

// Window sums of `window` (odd) consecutive values of ext (w + window - 1 values: the row with
// zeros on both sides, the clipped window): out[x] = ext[x] + ... + ext[x + window - 1], x < w.
// t0, t1: scratch of the row's length.
void WindowSums(const float* ext, int w, int window, float* out, float* t0, float* t1);

// The per-pixel formulas above on rows of window sums (unfused path).
void SelfCoefficients(const float* __restrict s_i, const float* __restrict s_ii,
                      const float* __restrict inv_cx, float inv_cy, float eps, float* __restrict a,
                      float* __restrict b, int w);
void GuidedCoefficients(const float* __restrict s_i, const float* __restrict s_p,
                        const float* __restrict s_ii, const float* __restrict s_ip,
                        const float* __restrict inv_cx, float inv_cy, float eps,
                        float* __restrict a, float* __restrict b, int w);
void ApplyCoefficients(const float* __restrict s_a, const float* __restrict s_b,
                       const float* __restrict guide, const float* __restrict inv_cx, float inv_cy,
                       float* __restrict q, int w);

// Column-sum updates of the streamed filter (guided_kernels.cc says which planes): c += add - sub
// per plane, a null row being absent.
void ColumnStepSelf(float* __restrict c_i, float* __restrict c_ii, const float* __restrict add,
                    const float* __restrict sub, int w);
void ColumnStepPair(float* __restrict c0, float* __restrict c1, const float* __restrict add0,
                    const float* __restrict sub0, const float* __restrict add1,
                    const float* __restrict sub1, int w);
void ColumnStepGuided(float* __restrict c_i, float* __restrict c_ii, float* __restrict c_p,
                      float* __restrict c_ip, const float* __restrict add_i,
                      const float* __restrict sub_i, const float* __restrict add_p,
                      const float* __restrict sub_p, int w);

// Window sums of W > 25 values as running sums on a stride of 8 (GuidedFilterGrayRunning); g:
// w + window - 8 floats of scratch.
void RunningWindowSumsPortable(const float* e, int w, int window, float* out, float* g);

#ifdef TURBID_HAVE_ROLLING_QUADS
// AVX2 versions (same additions in the same order): RunningWindowSumsPortable, and WindowSums's
// doubling tree for W > 25 (scratch: DoublingScratchFloats(w, window) floats).
void RunningWindowSumsAvx2(const float* e, int w, int window, float* out, float* g);
void DoublingWindowSumsAvx2(const float* ext, int w, int window, float* out, float* scratch);
size_t DoublingScratchFloats(int w, int window);
#endif

// The fused kernels of one radius; quads is null where W < 9 (direct sums) and where the AVX2
// kernels form the 4-sums themselves.
struct FusedKernels {
  void (*quads)(const float*, const float*, float*, float*, int) = nullptr;
  void (*self_coefficients)(const float*, const float*, const float*, const float*, const float*,
                            float, float, float*, float*, int) = nullptr;
  void (*guided_coefficients)(const float* const*, const float* const*, const float*, float, float,
                              float*, float*, int) = nullptr;
  void (*apply)(const float*, const float*, const float*, const float*, const float*, const float*,
                float, float*, int) = nullptr;
};

constexpr int kMaxFusedRadius = 12;

// Kernels for radius r (1..kMaxFusedRadius), one-channel rows.
FusedKernels FusedKernelsFor(int r);

}  // namespace turbid::guided_internal
