#include "enhancer/blocks/deconvolution.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <opencv2/imgproc.hpp>
#include <vector>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define TURBID_HAVE_TAPS_FMA 1
#endif

#include "core/cpu.h"
#include "core/error.h"
#include "core/row_kernel.h"
#include "enhancer/simd_vec.h"

namespace turbid {
namespace {

void CheckPsf(const cv::Mat& psf) {
  if (psf.empty() || psf.type() != CV_32FC1 || psf.rows % 2 == 0 || psf.cols % 2 == 0) {
    throw Error("deconvolution: PSF must be a non-empty odd-sized float32 one-channel kernel");
  }
  if (!cv::checkRange(psf)) throw Error("deconvolution: PSF has non-finite values");
  const double s = cv::sum(psf)[0];
  if (!(s > 1e-6)) throw Error("deconvolution: PSF must have a positive sum");
}

// Optical transfer function of `psf` on a rows x cols grid (kernel centre at the origin).
cv::Mat Otf(const cv::Mat& psf, int rows, int cols) {
  cv::Mat grid(rows, cols, CV_32F, cv::Scalar(0));
  const int ry = psf.rows / 2, rx = psf.cols / 2;
  const double norm = 1.0 / cv::sum(psf)[0];
  for (int y = 0; y < psf.rows; ++y) {
    for (int x = 0; x < psf.cols; ++x) {
      const int gy = ((y - ry) % rows + rows) % rows;
      const int gx = ((x - rx) % cols + cols) % cols;
      grid.at<float>(gy, gx) += static_cast<float>(psf.at<float>(y, x) * norm);
    }
  }
  cv::Mat otf;
  cv::dft(grid, otf, cv::DFT_COMPLEX_OUTPUT);
  return otf;
}

// Raised-cosine weights: 0 at the frame, 1 beyond `ramp` pixels from it.
std::vector<float> Ramp(int n, int ramp) {
  std::vector<float> w(n, 1.0f);
  for (int i = 0; i < n; ++i) {
    const int d = std::min(i, n - 1 - i);
    if (d < ramp) w[i] = static_cast<float>(0.5 - 0.5 * std::cos(CV_PI * d / ramp));
  }
  return w;
}

cv::Mat CircularConvolve(const cv::Mat& image, const cv::Mat& otf) {
  cv::Mat f, out;
  cv::dft(image, f, cv::DFT_COMPLEX_OUTPUT);
  cv::mulSpectrums(f, otf, f, 0);
  cv::dft(f, out, cv::DFT_INVERSE | cv::DFT_SCALE | cv::DFT_REAL_OUTPUT);
  return out;
}

struct Frame {
  cv::Mat padded;  // mirrored and tapered, optimal DFT size
  cv::Rect roi;    // the image inside it
  cv::Mat otf;
};

Frame MakeFrame(const cv::Mat& plane, const cv::Mat& psf, bool taper) {
  Frame f;
  const int margin = taper ? std::max(psf.rows, psf.cols) + 2 : 0;
  const int rows = cv::getOptimalDFTSize(plane.rows + 2 * margin);
  const int cols = cv::getOptimalDFTSize(plane.cols + 2 * margin);
  const int top = (rows - plane.rows) / 2, left = (cols - plane.cols) / 2;
  cv::copyMakeBorder(plane, f.padded, top, rows - plane.rows - top, left, cols - plane.cols - left,
                     cv::BORDER_REFLECT_101);
  f.roi = cv::Rect(left, top, plane.cols, plane.rows);
  f.otf = Otf(psf, rows, cols);
  if (taper && margin > 0) {
    const cv::Mat blurred = CircularConvolve(f.padded, f.otf);
    const int ramp_y = std::max(1, std::min(top, psf.rows + 1));
    const int ramp_x = std::max(1, std::min(left, psf.cols + 1));
    const std::vector<float> wy = Ramp(rows, ramp_y), wx = Ramp(cols, ramp_x);
    for (int y = 0; y < rows; ++y) {
      float* p = f.padded.ptr<float>(y);
      const float* b = blurred.ptr<float>(y);
      for (int x = 0; x < cols; ++x) {
        const float w = wy[y] * wx[x];
        p[x] = w * p[x] + (1.0f - w) * b[x];
      }
    }
  }
  return f;
}

cv::Mat WienerFft(const cv::Mat& plane, const cv::Mat& psf, double nsr, bool taper) {
  Frame f = MakeFrame(plane, psf, taper);
  cv::Mat g;
  cv::dft(f.padded, g, cv::DFT_COMPLEX_OUTPUT);
  cv::Mat filt(f.otf.size(), CV_32FC2);
  for (int y = 0; y < filt.rows; ++y) {
    const cv::Vec2f* h = f.otf.ptr<cv::Vec2f>(y);
    cv::Vec2f* w = filt.ptr<cv::Vec2f>(y);
    for (int x = 0; x < filt.cols; ++x) {
      const float p = h[x][0] * h[x][0] + h[x][1] * h[x][1];
      const float d = 1.0f / (p + static_cast<float>(nsr));
      w[x] = cv::Vec2f(h[x][0] * d, -h[x][1] * d);
    }
  }
  cv::mulSpectrums(g, filt, g, 0);
  cv::Mat out;
  cv::dft(g, out, cv::DFT_INVERSE | cv::DFT_SCALE | cv::DFT_REAL_OUTPUT);
  return out(f.roi).clone();
}

cv::Mat RichardsonLucy(const cv::Mat& plane, const cv::Mat& psf, int iterations, bool taper) {
  Frame f = MakeFrame(plane, psf, taper);
  cv::Mat g = cv::max(f.padded, 0.0);
  cv::Mat u = g.clone();
  cv::Mat otf_conj = f.otf.clone();  // the PSF is flipped for the correction step
  for (int y = 0; y < otf_conj.rows; ++y) {
    cv::Vec2f* h = otf_conj.ptr<cv::Vec2f>(y);
    for (int x = 0; x < otf_conj.cols; ++x) h[x][1] = -h[x][1];
  }
  constexpr float kFloor = 1e-6f;
  for (int it = 0; it < iterations; ++it) {
    cv::Mat est = CircularConvolve(u, f.otf);
    cv::Mat ratio(est.size(), CV_32F);
    for (int y = 0; y < est.rows; ++y) {
      const float* e = est.ptr<float>(y);
      const float* gg = g.ptr<float>(y);
      float* r = ratio.ptr<float>(y);
      for (int x = 0; x < est.cols; ++x) r[x] = gg[x] / std::max(e[x], kFloor);
    }
    cv::Mat corr = CircularConvolve(ratio, otf_conj);
    u = u.mul(cv::max(corr, 0.0));
  }
  return u(f.roi).clone();
}

// Row kernels (TURBID_ROW_KERNEL: an AVX2 clone besides the baseline one).

// Vertical pass of one separable term: out[x] = sum_j c[j] rows[j][x], K taps.
template <int K>
TURBID_ROW_KERNEL void VerticalTaps(const float* const* rows, const float* c, float* __restrict out,
                                    int w) {
  for (int x = 0; x < w; ++x) {
    float s = c[0] * rows[0][x];
    for (int j = 1; j < K; ++j) s += c[j] * rows[j][x];
    out[x] = s;
  }
}

// Horizontal pass of one term, accumulated: acc[x] += sum_i r[i] ext[x + S i], K taps, over w
// values; S is the distance between neighbouring pixels' values of one channel (the channel count
// of an interleaved row).
template <int K, int S = 1>
TURBID_ROW_KERNEL void HorizontalTaps(const float* __restrict ext, const float* r,
                                      float* __restrict acc, int w) {
  for (int x = 0; x < w; ++x) {
    float s = r[0] * ext[x];
    for (int i = 1; i < K; ++i) s += r[i] * ext[x + S * i];
    acc[x] += s;
  }
}

// Any K (kernels larger than the unrolled sizes).
void VerticalTapsAny(const float* const* rows, const float* c, float* out, int w, int k) {
  for (int x = 0; x < w; ++x) out[x] = c[0] * rows[0][x];
  for (int j = 1; j < k; ++j) {
    for (int x = 0; x < w; ++x) out[x] += c[j] * rows[j][x];
  }
}
void HorizontalTapsAny(const float* ext, const float* r, float* acc, int w, int k, int stride) {
  for (int i = 0; i < k; ++i) {
    for (int x = 0; x < w; ++x) acc[x] += r[i] * ext[x + stride * i];
  }
}

#ifdef TURBID_HAVE_TAPS_FMA
// The fused tap kernels at 8 and 16 lanes (deconvolution_taps.inc, written once over the width;
// the same bits at both).
#define TURBID_VEC_BODY "enhancer/blocks/deconvolution_taps.inc"
#include "enhancer/simd_widths.inc"  // NOLINT(build/include): the body at 8 and 16 lanes

// Whether every term's vertical and horizontal taps are even within 1e-5 of the term's largest
// tap (the SVD of a symmetric kernel gives them so up to its rounding); if so they are all made
// exactly even (the mean of each mirrored pair). K odd, 5 to 15.
bool MakeTapsEven(std::vector<std::vector<float>>& cols, std::vector<std::vector<float>>& rows) {
  std::vector<std::vector<float>*> terms;
  for (auto& v : cols) terms.push_back(&v);
  for (auto& v : rows) terms.push_back(&v);
  for (const std::vector<float>* t : terms) {
    const std::vector<float>& v = *t;
    const int k = static_cast<int>(v.size());
    if (k % 2 == 0 || k < 5 || k > 15) return false;
    float big = 0.0f;
    for (float a : v) big = std::max(big, std::abs(a));
    for (int j = 0; j < k / 2; ++j) {
      if (!(std::abs(v[j] - v[k - 1 - j]) <= 1e-5f * big)) return false;
    }
  }
  for (std::vector<float>* t : terms) {
    std::vector<float>& v = *t;
    const int k = static_cast<int>(v.size());
    for (int j = 0; j < k / 2; ++j) v[j] = v[k - 1 - j] = 0.5f * (v[j] + v[k - 1 - j]);
  }
  return true;
}
#endif

// Whether the tap kernels use FMA (KernelCpuLevel at least avx2+fma; tests lower the cap).
bool TapsUseFma() {
#ifdef TURBID_HAVE_TAPS_FMA
  return KernelCpuLevel() >= CpuLevel::kAvx2Fma;
#else
  return false;
#endif
}

template <int K>
bool TapsUpTo(int k, const float* const* rows, const float* c, float* tmp, int w) {
  if (k == K) {
    VerticalTaps<K>(rows, c, tmp, w);
    return true;
  }
  if constexpr (K > 3) return TapsUpTo<K - 2>(k, rows, c, tmp, w);
  return false;
}
template <int K>
bool HTapsUpTo(int k, int stride, const float* ext, const float* r, float* acc, int w) {
  if (k == K) {
    if (stride == 3) {
      HorizontalTaps<K, 3>(ext, r, acc, w);
    } else {
      HorizontalTaps<K>(ext, r, acc, w);
    }
    return true;
  }
  if constexpr (K > 3) return HTapsUpTo<K - 2>(k, stride, ext, r, acc, w);
  return false;
}

// The tap passes of one kernel at the CPU's level: the fused kernels (16 lanes where
// KernelCpuLevel() reaches avx512, else 8), their even-tap forms when every term is even, else
// the portable loops.
struct TapPasses {
  bool fma = TapsUseFma();
  bool wide = KernelCpuLevel() >= CpuLevel::kAvx512;
  bool even = false;

  // The vertical pass of terms t (and t + 1 when the even kernels take two); returns how many.
  int Vertical(int k, const float* const* rows, const std::vector<std::vector<float>>& cols, int t,
               float* out, size_t out_step, int w) const {
#ifdef TURBID_HAVE_TAPS_FMA
    if (even) {
      const int pair = std::min(2, static_cast<int>(cols.size()) - t);
      const float* taps[2] = {cols[t].data(), cols[t + pair - 1].data()};
      float* outs[2] = {out, out + (pair - 1) * out_step};
      wide ? vec16::EvenTaps(k, rows, taps, outs, w, pair)
           : vec8::EvenTaps(k, rows, taps, outs, w, pair);
      return pair;
    }
    if (fma && (wide ? vec16::TapsFma(k, rows, cols[t].data(), out, w)
                     : vec8::TapsFma(k, rows, cols[t].data(), out, w))) {
      return 1;
    }
#endif
    if (!TapsUpTo<25>(k, rows, cols[t].data(), out, w)) {
      VerticalTapsAny(rows, cols[t].data(), out, w, k);
    }
    return 1;
  }
  // The horizontal pass of one term into acc (add: acc += the pass; else acc = it, which only
  // the even kernels do: see Stores()).
  void Horizontal(int k, int stride, bool add, const float* ext, const float* r, float* acc,
                  int w) const {
#ifdef TURBID_HAVE_TAPS_FMA
    if (even && (wide ? vec16::EvenHTaps(k, stride, add, ext, r, acc, w)
                      : vec8::EvenHTaps(k, stride, add, ext, r, acc, w))) {
      return;
    }
    if (fma && (wide ? vec16::HTapsFma(k, stride, ext, r, acc, w)
                     : vec8::HTapsFma(k, stride, ext, r, acc, w))) {
      return;
    }
#endif
    if (!HTapsUpTo<25>(k, stride, ext, r, acc, w)) HorizontalTapsAny(ext, r, acc, w, k, stride);
  }
  // Whether the first term's horizontal pass stores its sums (no zero-filled acc).
  bool Stores(int stride) const { return even && (stride == 1 || stride == 3); }
};

// The first address at or after p that is a multiple of `floats` floats (a power of two).
float* AlignFloats(float* p, size_t floats) {
  const uintptr_t a = reinterpret_cast<uintptr_t>(p), bytes = floats * sizeof(float);
  return reinterpret_cast<float*>((a + bytes - 1) & ~(bytes - 1));
}

// BORDER_REFLECT_101 index for i in (-n, 2n) (folded repeatedly for tiny images).
int Reflect101(int i, int n) {
  if (n == 1) return 0;
  const int period = 2 * n - 2;
  i %= period;
  if (i < 0) i += period;
  return i < n ? i : period - i;
}

// The separable terms of a 2-D kernel from its SVD, until the captured energy reaches 1 - 1e-7:
// per term the vertical taps (kernel.rows) and the horizontal ones (kernel.cols).
void SeparableTerms(const cv::Mat& kernel, std::vector<std::vector<float>>* cols,
                    std::vector<std::vector<float>>* rows) {
  cv::Mat k64;
  kernel.convertTo(k64, CV_64F);
  cv::SVD svd(k64, cv::SVD::FULL_UV);
  const double total = cv::sum(svd.w.mul(svd.w))[0];
  const int kr = kernel.rows, kc = kernel.cols;
  double captured = 0.0;
  for (int i = 0; i < svd.w.rows; ++i) {
    const double s = svd.w.at<double>(i);
    captured += s * s;
    std::vector<float> c(kr), r(kc);
    // Correlation, as cv::sepFilter2D: out(y, x) = sum c[j] r[i] in(y + j - ry, x + i - rx).
    for (int j = 0; j < kr; ++j) c[j] = static_cast<float>(svd.u.at<double>(j, i) * std::sqrt(s));
    for (int j = 0; j < kc; ++j) r[j] = static_cast<float>(svd.vt.at<double>(i, j) * std::sqrt(s));
    cols->push_back(std::move(c));
    rows->push_back(std::move(r));
    if (captured >= (1.0 - 1e-7) * total) break;
  }
}

// Applies a 2-D kernel as a sum of separable terms from its SVD (terms until the captured energy
// reaches 1 - 1e-7), mirrored borders (BORDER_REFLECT_101), streamed by rows: per output row and
// term, a vertical pass over the kernel's rows into a mirrored row buffer, then a horizontal pass
// accumulated into the row. emit(y, row) receives each output row in order; no full-size
// temporaries. The input (h rows of w pixels, `channels` interleaved, each channel alone) comes
// from source(y), asked for rows within [y - ry, y + ry] for output row y (ry = kernel.rows / 2).
void ApplySeparableRowsFrom(int h, int w, int channels,
                            const std::function<const float*(int)>& source, const cv::Mat& kernel,
                            const std::function<void(int, const float*)>& emit) {
  const int kr = kernel.rows, kc = kernel.cols;
  const int ry = kr / 2, rx = kc / 2;
  std::vector<std::vector<float>> cols, rows;  // per term: vertical taps (kr), horizontal (kc)
  SeparableTerms(kernel, &cols, &rows);
  const int c = channels, n = w * c;  // values per row
  const int terms = static_cast<int>(cols.size());
  // One bordered row per term, each row's values (after its left border, `lead` floats from the
  // row's start in the buffer) 64-byte aligned, as acc: the passes' 16-lane stores then never
  // split a cache line.
  constexpr size_t kAlign = 16;  // floats
  const size_t border = static_cast<size_t>(rx) * c;
  const size_t lead = (border + kAlign - 1) / kAlign * kAlign;
  const size_t ext_n = (lead + n + border + kAlign - 1) / kAlign * kAlign;
  std::vector<float> ext_buffer(ext_n * terms + kAlign), acc_buffer(n + kAlign);
  float* const ext = AlignFloats(ext_buffer.data(), kAlign);
  float* const acc = AlignFloats(acc_buffer.data(), kAlign);
  std::vector<int> col_src(w + 2 * rx);
  for (int x = 0; x < w + 2 * rx; ++x) col_src[x] = Reflect101(x - rx, w);
  std::vector<const float*> in_rows(kr), strip_rows(kr);
  // The vertical passes of all terms strip by strip of kStrip values: the kr input rows' strip
  // stays in L1 for every term (whole rows, term after term, were read again from L2). Each
  // value's sum is VerticalTaps's, wherever the strips start.
  constexpr int kStrip = 512;
  TapPasses passes;
#ifdef TURBID_HAVE_TAPS_FMA
  // Even taps (a symmetric kernel, 5 to 15 wide): the folded FMA kernels, two terms per vertical
  // pass.
  passes.even = passes.fma && MakeTapsEven(cols, rows);
#endif
  for (int y = 0; y < h; ++y) {
    for (int j = 0; j < kr; ++j) in_rows[j] = source(Reflect101(y + j - ry, h));
    for (int x0 = 0; x0 < n; x0 += kStrip) {
      const int len = std::min(kStrip, n - x0);
      for (int j = 0; j < kr; ++j) strip_rows[j] = in_rows[j] + x0;
      for (int t = 0; t < terms;) {
        float* mid = ext + t * ext_n + lead + x0;
        t += passes.Vertical(kr, strip_rows.data(), cols, t, mid, ext_n, len);
      }
    }
    // Then per term its border and its horizontal pass, added into acc in order of the terms.
    // (The even kernels store the first term's sums: no zero fill.)
    const bool stores = passes.Stores(c);
    if (!stores) std::fill(acc, acc + n, 0.0f);
    for (int t = 0; t < terms; ++t) {
      float* e = ext + t * ext_n + (lead - border);
      const float* mid = e + static_cast<size_t>(rx) * c;
      for (int x = 0; x < rx; ++x) std::copy_n(mid + col_src[x] * c, c, e + x * c);
      for (int x = w + rx; x < w + 2 * rx; ++x) {
        std::copy_n(mid + col_src[x] * c, c, e + static_cast<size_t>(x) * c);
      }
      passes.Horizontal(kc, c, !stores || t > 0, e, rows[t].data(), acc, n);
    }
    emit(y, acc);
  }
}

void ApplySeparableRows(const cv::Mat& image, const cv::Mat& kernel,
                        const std::function<void(int, const float*)>& emit) {
  ApplySeparableRowsFrom(
      image.rows, image.cols, image.channels(), [&image](int y) { return image.ptr<float>(y); },
      kernel, emit);
}

cv::Mat ApplySeparable(const cv::Mat& image, const cv::Mat& kernel) {
  cv::Mat out(image.size(), image.type());
  const size_t n = static_cast<size_t>(image.cols) * image.channels();
  ApplySeparableRows(image, kernel,
                     [&](int y, const float* row) { std::copy_n(row, n, out.ptr<float>(y)); });
  return out;
}

// The spatial Wiener inverse filter when the options select the spatial path for this PSF, else
// an empty Mat.
cv::Mat SpatialInverse(const DeconvolutionOptions& options, const cv::Mat& psf) {
  if (options.method != DeconvolutionMethod::kWiener || options.spatial_max_radius <= 0) return {};
  cv::Mat inverse = WienerInverseKernel(psf, options.nsr);
  if (inverse.rows / 2 > options.spatial_max_radius) return {};
  return inverse;
}

void CheckDeconvolveInputs(const DeconvolutionOptions& options, const cv::Mat& image,
                           const cv::Mat& psf) {
  ThrowIfInvalid(options, "deconvolution");
  if (image.empty() || image.depth() != CV_32F) {
    throw Error("deconvolution: expected a non-empty float32 image");
  }
  CheckPsf(psf);
}

}  // namespace

DeconvolutionMethod DeconvolutionMethodFromName(const std::string& name) {
  if (name == "wiener") return DeconvolutionMethod::kWiener;
  if (name == "richardson_lucy") return DeconvolutionMethod::kRichardsonLucy;
  throw Error("deconvolution: unknown method '" + name + "' (expected wiener or richardson_lucy)");
}

std::string DeconvolutionMethodName(DeconvolutionMethod method) {
  return method == DeconvolutionMethod::kWiener ? "wiener" : "richardson_lucy";
}

bool DeconvolutionOptions::Check(std::string* why) const {
  if (!std::isfinite(nsr) || nsr < 1e-8 || nsr > 10.0) {
    *why = "nsr must be in [1e-8, 10], got " + std::to_string(nsr);
    return false;
  }
  if (iterations < 1 || iterations > 1000) {
    *why = "iterations must be in [1, 1000], got " + std::to_string(iterations);
    return false;
  }
  if (spatial_max_radius < 0 || spatial_max_radius > 64) {
    *why = "spatial_max_radius must be in [0, 64], got " + std::to_string(spatial_max_radius);
    return false;
  }
  return true;
}

cv::Mat WienerInverseKernel(const cv::Mat& psf, double nsr) {
  CheckPsf(psf);
  int n = 64;
  while (n < 8 * std::max(psf.rows, psf.cols)) n *= 2;
  const cv::Mat otf = Otf(psf, n, n);
  cv::Mat filt(n, n, CV_32FC2);
  for (int y = 0; y < n; ++y) {
    const cv::Vec2f* h = otf.ptr<cv::Vec2f>(y);
    cv::Vec2f* w = filt.ptr<cv::Vec2f>(y);
    for (int x = 0; x < n; ++x) {
      const double p = h[x][0] * h[x][0] + h[x][1] * h[x][1];
      w[x] = cv::Vec2f(static_cast<float>(h[x][0] / (p + nsr)),
                       static_cast<float>(-h[x][1] / (p + nsr)));
    }
  }
  cv::Mat spatial;
  cv::dft(filt, spatial, cv::DFT_INVERSE | cv::DFT_SCALE | cv::DFT_REAL_OUTPUT);
  // Radius where the filter has decayed below 1e-4 of its peak (square support).
  double peak = 0;
  cv::minMaxLoc(cv::abs(spatial), nullptr, &peak);
  int radius = 0;
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      if (std::fabs(spatial.at<float>(y, x)) < 1e-4 * peak) continue;
      const int dy = std::min(y, n - y), dx = std::min(x, n - x);
      radius = std::max(radius, std::max(dy, dx));
    }
  }
  radius = std::min(radius, n / 2 - 1);
  cv::Mat k(2 * radius + 1, 2 * radius + 1, CV_32F);
  for (int y = -radius; y <= radius; ++y) {
    for (int x = -radius; x <= radius; ++x) {
      k.at<float>(y + radius, x + radius) = spatial.at<float>((y + n) % n, (x + n) % n);
    }
  }
  return k;
}

cv::Mat ApplySeparableKernel(const cv::Mat& image, const cv::Mat& kernel) {
  CV_Assert(image.depth() == CV_32F && (image.channels() == 1 || image.channels() == 3) &&
            kernel.type() == CV_32FC1 && kernel.rows == kernel.cols && kernel.rows % 2 == 1);
  return ApplySeparable(image, kernel);
}

cv::Mat ConvolveMirrored(const cv::Mat& image, const cv::Mat& psf) {
  CheckPsf(psf);
  cv::Mat out;
  cv::filter2D(image, out, CV_32F, psf / cv::sum(psf)[0], cv::Point(-1, -1), 0,
               cv::BORDER_REFLECT_101);
  return out;
}

cv::Mat Deconvolve(const DeconvolutionOptions& options, const cv::Mat& image, const cv::Mat& psf) {
  CheckDeconvolveInputs(options, image, psf);
  if (psf.rows == 1 && psf.cols == 1) return image.clone();
  const cv::Mat inverse = SpatialInverse(options, psf);
  // Spatial Wiener: every channel at once, interleaved (each channel's arithmetic as alone).
  if (!inverse.empty() && image.channels() <= 3) return ApplySeparable(image, inverse);
  std::vector<cv::Mat> planes;
  if (image.channels() == 1) {
    planes = {image};  // cv::split would copy a one-channel image
  } else {
    cv::split(image, planes);
  }
  for (cv::Mat& p : planes) {
    if (!inverse.empty()) {
      p = ApplySeparable(p, inverse);
    } else if (options.method == DeconvolutionMethod::kWiener) {
      p = WienerFft(p, psf, options.nsr, options.taper);
    } else {
      p = RichardsonLucy(p, psf, options.iterations, options.taper);
    }
  }
  if (planes.size() == 1) return planes[0];
  cv::Mat out;
  cv::merge(planes, out);
  return out;
}

bool DeconvolveRows(const DeconvolutionOptions& options, const cv::Mat& image, const cv::Mat& psf,
                    const std::function<void(int, const float*)>& emit) {
  CheckDeconvolveInputs(options, image, psf);
  return DeconvolveRowsFrom(
      options, image.size(), image.channels(), [&image](int y) { return image.ptr<float>(y); }, psf,
      emit);
}

bool DeconvolveRowsFrom(const DeconvolutionOptions& options, cv::Size size, int channels,
                        const std::function<const float*(int)>& source, const cv::Mat& psf,
                        const std::function<void(int, const float*)>& emit) {
  ThrowIfInvalid(options, "deconvolution");
  CheckPsf(psf);
  if (size.width <= 0 || size.height <= 0) throw Error("deconvolution: empty image");
  if (channels != 1 && channels != 3) {
    throw Error("deconvolution rows: expected a one- or three-channel image");
  }
  if (psf.rows == 1 && psf.cols == 1) return false;
  const cv::Mat inverse = SpatialInverse(options, psf);
  if (inverse.empty()) return false;
  ApplySeparableRowsFrom(size.height, size.width, channels, source, inverse, emit);
  return true;
}

}  // namespace turbid
