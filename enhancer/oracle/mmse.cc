// The MMSE oracle's estimate: the data term (noise variance, weights, censoring), the
// hierarchical local-Gaussian prior and its streamed box sums (docs/methods.md, "oracle").
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "core/error.h"
#include "core/row_kernel.h"
#include "enhancer/blocks/box_stream.h"
#include "enhancer/oracle/oracle_internal.h"
#include "simulator/image_pool.h"
#include "simulator/kernels.h"
#include "simulator/light.h"
#include "simulator/noise.h"
#include "simulator/psf.h"
#include "simulator/render.h"
#include "simulator/water.h"

namespace turbid {
namespace oracle_internal {
namespace {

using box_stream::BoxCount;
using box_stream::BoxStream;
using box_stream::BoxStreamImage;
using box_stream::BoxStreamTwoRadii;

TURBID_ROW_KERNEL void ProductRow(const float* __restrict a, const float* __restrict b,
                                  float* __restrict out, int n) {
  for (int i = 0; i < n; ++i) out[i] = a[i] * b[i];
}

// out = m / max(w, 1e-30).
TURBID_ROW_KERNEL void QuotientRow(const float* __restrict w, const float* __restrict m,
                                   float* __restrict out, int n) {
  for (int i = 0; i < n; ++i) out[i] = m[i] / std::max(w[i], 1e-30f);
}

// The estimate and the posterior variance (into s) of HierarchicalMmse.
TURBID_ROW_KERNEL void EstimateRow(const float* __restrict a, const float* __restrict u,
                                   const float* __restrict p, float* __restrict s,
                                   float* __restrict e, int n) {
  for (int i = 0; i < n; ++i) {
    const float sa_px = s[i] * a[i];
    const float den = sa_px + 1.0f;
    const float gain = sa_px / den;
    s[i] = s[i] / den;
    e[i] = p[i] + gain * (u[i] - p[i]);
  }
}

TURBID_ROW_KERNEL void NoiseVarianceRow(const float* __restrict mean, float* __restrict v,
                                        float gain, float floor_var, int n) {
  for (int i = 0; i < n; ++i) v[i] = std::max(mean[i], 0.0f) * gain + floor_var;
}

// The coded-domain quantisation variance added at the local mean (CodedQuantisation).
void AddQuantisationRow(const float* mean, const CodedQuantisation& q, float* v, int n) {
  if (q.step_var == 0.0f) return;
  for (int i = 0; i < n; ++i) v[i] += q.Variance(mean[i]);
}

// LocalSignalVariance's last step: max(sum - count, 0) / max(sum a, 1e-30), with the maxima as
// the vector loop of cv::max(image, scalar) takes them, x > floor ? x : floor (NaN gives the
// floor; std::max keeps it). The numerator's box sums are NaN once a (z - p)^2 overflowed (inf -
// inf in the running sums: z = m, the level mean, reaches ~1e21 where t E is at the 1e-12 floor
// and a window's sum of a is a negative rounding residue). Returns how many values had a NaN
// sum - count or sum a: cv::max's scalar loop (ScalarLoopValues) keeps those (FixScalarLoopNans).
TURBID_ROW_KERNEL int SignalVarianceRow(const float* __restrict sum, const float* __restrict w,
                                        const float* __restrict count, float* __restrict o, int n) {
  int nans = 0;
  for (int i = 0; i < n; ++i) {
    const float v = sum[i] - count[i];
    nans += (v != v) | (w[i] != w[i]);
    o[i] = (v > 0.0f ? v : 0.0f) / (w[i] > 1e-30f ? w[i] : 1e-30f);
  }
  return nans;
}

TURBID_ROW_KERNEL int SignalVarianceRowFull(const float* __restrict sum, const float* __restrict w,
                                            float full, float* __restrict o, int n) {
  int nans = 0;
  for (int i = 0; i < n; ++i) {
    const float v = sum[i] - full;
    nans += (v != v) | (w[i] != w[i]);
    o[i] = (v > 0.0f ? v : 0.0f) / (w[i] > 1e-30f ? w[i] : 1e-30f);
  }
  return nans;
}

// The values (flat indices, ascending) of a continuous rows x cols float image of ch channels
// that cv::max(image, cv::Scalar) leaves to its scalar loop, where a NaN stays NaN (std::max)
// instead of becoming the scalar (its vector loop): the last values of each block it splits the
// image into, which depend on OpenCV's block size and vector width, so found by asking cv::max
// (on NaNs) once per shape, only when a NaN is met. Per thread, the last shape's.
const std::vector<int>& ScalarLoopValues(int rows, int cols, int ch) {
  thread_local int shape[3] = {-1, -1, -1};
  thread_local std::vector<int> values;
  if (shape[0] != rows || shape[1] != cols || shape[2] != ch) {
    cv::Mat probe(rows, cols, CV_32FC(ch),
                  cv::Scalar::all(std::numeric_limits<double>::quiet_NaN()));
    cv::max(probe, cv::Scalar::all(0.0), probe);
    values.clear();
    const float* p = probe.ptr<float>(0);
    for (size_t k = 0; k < probe.total() * ch; ++k)
      if (std::isnan(p[k])) values.push_back(static_cast<int>(k));
    shape[0] = rows, shape[1] = cols, shape[2] = ch;
  }
  return values;
}

// Row y (n values) of SignalVarianceRow's output where it met NaNs: the values in cv::max's scalar
// loop get std::max's maxima (a NaN sum - count or sum a stays NaN). count null: full.
void FixScalarLoopNans(int rows, int cols, int ch, int y, const float* sum, const float* w,
                       const float* count, float full, float* o) {
  const int n = cols * ch;
  const std::vector<int>& values = ScalarLoopValues(rows, cols, ch);
  const auto first = std::lower_bound(values.begin(), values.end(), y * n);
  for (auto it = first; it != values.end() && *it < (y + 1) * n; ++it) {
    const int i = *it - y * n;
    const float v = sum[i] - (count != nullptr ? count[i] : full);
    o[i] = std::max(v, 0.0f) / std::max(w[i], 1e-30f);
  }
}

// Values of a row with no data (a > 0 false: 0, negative or NaN).
TURBID_ROW_KERNEL int NoDataRow(const float* __restrict a, int n) {
  int none = 0;
  for (int i = 0; i < n; ++i) none += a[i] > 0.0f ? 0 : 1;
  return none;
}

// Element-wise passes over images of the same size and type (any channel count, rows possibly
// strided): fn(i, pointers...) for every value i of a row. Every formula below is written as the
// OpenCV expressions it replaced evaluate it (one float rounding per operation, no FMA), so the
// values are the same; the passes fuse what were separate full-size temporaries.
template <typename Fn, typename... Mats>
void ForRows(const cv::Mat& shape, Fn fn, Mats&... mats) {
  const int n = shape.cols * shape.channels();
  for (int y = 0; y < shape.rows; ++y) fn(n, mats.template ptr<float>(y)...);
}

// One row of the data term: u = ((I - S) - veil) / sc and a = sc^2 / variance with
// sc = max(t E, 1e-12), both 0 where masked; a also 0 where I > clip_level (censored).
template <int kChannels>
TURBID_ROW_KERNEL void DataTermRowN(const float* __restrict in, const float* __restrict t,
                                    const float* __restrict e, const float* __restrict sn,
                                    const float* __restrict ve, const float* __restrict var,
                                    const uchar* __restrict mk, float clip_level, int cols,
                                    float* __restrict uu, float* __restrict aa) {
  // The selects as bit masks (max(p, 1e-12) as p < 1e-12 ? 1e-12 : p, the masked values' +0), so
  // that both quotients are formed for every value and the loop has no branch: GCC split sc * sc /
  // var into the two cases of the max, and under trapping math does not form a division that only
  // one branch uses, so it left this loop scalar (two scalar divisions per value).
  constexpr uint32_t kFloor = std::bit_cast<uint32_t>(1e-12f);
  for (int x = 0; x < cols; ++x) {
    const uint32_t keep = mk[x] != 0 ? 0u : ~0u;
    for (int c = 0; c < kChannels; ++c) {
      const int i = x * kChannels + c;
      const float te = t[i] * e[i];
      const uint32_t low = te < 1e-12f ? ~0u : 0u;  // std::max(te, 1e-12f)
      const float sc = std::bit_cast<float>((kFloor & low) | (std::bit_cast<uint32_t>(te) & ~low));
      const float ui = ((in[i] - sn[i]) - ve[i]) / sc;
      const float ai = (sc * sc) / var[i];
      const float high = in[i] > clip_level ? 1.0f : 0.0f;
      uu[i] = std::bit_cast<float>(std::bit_cast<uint32_t>(ui) & keep);
      aa[i] = std::bit_cast<float>(std::bit_cast<uint32_t>(ai) & keep) * (1.0f - high);
    }
  }
}

void DataTermRow(const float* in, const float* t, const float* e, const float* sn, const float* ve,
                 const float* var, const uchar* mk, float clip_level, int ch, int cols, float* uu,
                 float* aa) {
  if (ch == 1) {
    DataTermRowN<1>(in, t, e, sn, ve, var, mk, clip_level, cols, uu, aa);
  } else {
    DataTermRowN<3>(in, t, e, sn, ve, var, mk, clip_level, cols, uu, aa);
  }
}

// Pixels of a row with some channel above clip_level.
TURBID_ROW_KERNEL int CountClippedRow1(const float* __restrict in, float clip_level, int cols) {
  int count = 0;
  for (int x = 0; x < cols; ++x) count += in[x] > clip_level ? 1 : 0;
  return count;
}

int CountClipped(const float* in, float clip_level, int ch, int cols) {
  if (ch == 1) return CountClippedRow1(in, clip_level, cols);
  int count = 0;
  for (int x = 0; x < cols; ++x) {
    bool clipped = false;
    for (int c = 0; c < ch; ++c) clipped = clipped || in[x * ch + c] > clip_level;
    count += clipped ? 1 : 0;
  }
  return count;
}

// One row of LocalSignalVariance's numerator a (z - p)^2 (its box count of [a > 0] is made in
// integers: BoxCount).
TURBID_ROW_KERNEL void NumeratorOnlyRow(const float* __restrict zz, const float* __restrict aa,
                                        const float* __restrict pp, float* __restrict nn, int n) {
  for (int i = 0; i < n; ++i) {
    const float d = zz[i] - pp[i];
    nn[i] = aa[i] * (d * d);
  }
}

// out = p + S w / (S w + 1) (m - p): the shrink of the prior p towards the level mean m.
TURBID_ROW_KERNEL void ShrinkRowTo(const float* __restrict s, const float* __restrict w,
                                   const float* __restrict m, const float* __restrict p,
                                   float* __restrict out, int n) {
  for (int i = 0; i < n; ++i) {
    const float sw = s[i] * w[i];
    const float gain = sw / (sw + 1.0f);
    out[i] = p[i] + gain * (m[i] - p[i]);
  }
}

// Per channel, the values of a row with no data (a > 0 false).
void NoDataPerChannel(const float* a, int cols, int ch, long long* none) {
  if (ch == 1) {
    none[0] += NoDataRow(a, cols);
    return;
  }
  for (int x = 0; x < cols; ++x)
    for (int c = 0; c < ch; ++c) none[c] += a[x * ch + c] > 0.0f ? 0 : 1;
}

// The censored values (I > clip_level) of the data term, per row, with their lower bounds on
// rho, (I - 2 sigma - S - veil) / max(t E, 1e-12): row y's are entries row_start[y] ..
// row_start[y + 1] - 1 (value index within the row, bound).
struct Censored {
  std::vector<int> row_start, index;
  std::vector<float> bound;
};

// x + 0 where x is finite, NaN elsewhere: the unclipped branch of the censoring step (its
// factor 0 times a finite difference).
TURBID_ROW_KERNEL void KeepFiniteRow(const float* __restrict x, float* __restrict out, int n) {
  // As bit masks, so that the sum is formed for every value and the loop has no branch.
  constexpr uint32_t kQuietNan = std::bit_cast<uint32_t>(std::numeric_limits<float>::quiet_NaN());
  for (int i = 0; i < n; ++i) {
    const uint32_t kept = std::bit_cast<uint32_t>(x[i] + 0.0f);
    const uint32_t finite = (std::bit_cast<uint32_t>(x[i]) & 0x7f800000u) != 0x7f800000u ? ~0u : 0u;
    out[i] = std::bit_cast<float>((kept & finite) | (kQuietNan & ~finite));
  }
}

// The censoring step on one row: listed values raised onto their bound, x + (max(x, bound) -
// x); the others x + 0 (KeepFiniteRow).
void CensorRow(const Censored& c, int y, const float* x, float* out, int n) {
  KeepFiniteRow(x, out, n);
  for (int j = c.row_start[y]; j < c.row_start[y + 1]; ++j) {
    const int i = c.index[j];
    out[i] = x[i] + (std::max(x[i], c.bound[j]) - x[i]);
  }
}

using DeblurStats = DetailSums;

// One gray row of DetailAndStats: d = e - p, and over the values not masked the sums of v, d and
// d^2 in four partial sums, value x into sum x mod 4 (the partial sums side by side: one vector
// of four doubles each; a masked value adds +0, which leaves a sum started at +0 unchanged).
// Returns how many values are not masked.
TURBID_ROW_KERNEL int DetailStatsRow1(const float* __restrict e, const float* __restrict p,
                                      const float* __restrict v, const uchar* __restrict m,
                                      float* __restrict d, double* __restrict sp,
                                      double* __restrict sd, double* __restrict sq, int n) {
  for (int i = 0; i < n; ++i) d[i] = e[i] - p[i];
  // The four partial sums as one vector each (GCC vector extensions; masked values as +0 by
  // a bit mask).
  using V4d = double __attribute__((vector_size(32)));
  using V4f = float __attribute__((vector_size(16)));
  using V4l = int64_t __attribute__((vector_size(32)));
  V4d vp = {sp[0], sp[1], sp[2], sp[3]}, vd = {sd[0], sd[1], sd[2], sd[3]};
  V4d vq = {sq[0], sq[1], sq[2], sq[3]};
  V4l kept = {0, 0, 0, 0};
  int x = 0;
  for (; x + 4 <= n; x += 4) {
    V4f vf, df;
    std::memcpy(&vf, v + x, sizeof(vf));
    std::memcpy(&df, d + x, sizeof(df));
    const V4l keep = V4l{m[x], m[x + 1], m[x + 2], m[x + 3]} == 0;  // all ones where kept
    const V4d vv = __builtin_convertvector(vf, V4d), dd = __builtin_convertvector(df, V4d);
    const V4d dd2 = dd * dd;
    vp += reinterpret_cast<V4d>(reinterpret_cast<V4l>(vv) & keep);
    vd += reinterpret_cast<V4d>(reinterpret_cast<V4l>(dd) & keep);
    vq += reinterpret_cast<V4d>(reinterpret_cast<V4l>(dd2) & keep);
    kept -= keep;
  }
  int count = 0;
  for (int k = 0; k < 4; ++k) {
    sp[k] = vp[k];
    sd[k] = vd[k];
    sq[k] = vq[k];
    count += static_cast<int>(kept[k]);
  }
  for (; x < n; ++x) {
    if (m[x] != 0) continue;
    const int k = x & 3;
    const double dd = d[x];
    sp[k] += v[x];
    sd[k] += dd;
    sq[k] += dd * dd;
    ++count;
  }
  return count;
}

// One row of the detail d = e - p (float) and of DeblurStats (cols pixels, ch channels). Four
// partial sums per quantity for one channel (independent chains).
void DetailStatsRow(const float* e, const float* p, const float* v, const uchar* m, float* d,
                    int cols, int ch, DeblurStats& st) {
  const int n = cols * ch;
  if (ch == 1) {
    double sp[4] = {0, 0, 0, 0}, sd[4] = {0, 0, 0, 0}, sq[4] = {0, 0, 0, 0};
    st.count += DetailStatsRow1(e, p, v, m, d, sp, sd, sq, n);
    st.posterior[0] += (sp[0] + sp[1]) + (sp[2] + sp[3]);
    st.detail[0] += (sd[0] + sd[1]) + (sd[2] + sd[3]);
    st.detail_sq[0] += (sq[0] + sq[1]) + (sq[2] + sq[3]);
    return;
  }
  for (int i = 0; i < n; ++i) d[i] = e[i] - p[i];
  for (int x = 0; x < cols; ++x) {
    if (m[x] != 0) continue;
    for (int c = 0; c < ch; ++c) {
      const double dd = d[x * ch + c];
      st.posterior[c] += v[x * ch + c];
      st.detail[c] += dd;
      st.detail_sq[c] += dd * dd;
    }
    ++st.count;
  }
}

// HierarchicalMmse's optional output: detail = est - prior and its sums over the pixels not
// masked (OracleEnhance's Wiener ratio), made as the estimate's rows are.
struct DetailOut {
  cv::Mat masked;  // CV_8UC1, 255 = masked
  cv::Mat detail;  // the estimate's size and type
  DeblurStats sums;
};

// Row buffers of HierarchicalMmse's streams (per thread, kept between calls).
struct MmseRows {
  std::vector<float> has, s, e, post, est;
};

MmseRows& ThreadMmseRows(int n) {
  thread_local MmseRows rows;
  for (std::vector<float>* v : {&rows.has, &rows.s, &rows.e, &rows.post, &rows.est})
    v->resize(std::max<size_t>(v->size(), static_cast<size_t>(n)));
  return rows;
}

// Local signal variance around the prior mean p of values z whose noise variances are 1 / a (a =
// 0: no data): max(box(a (z - p)^2) - box([a > 0]), 0) / box(a) over windows of `radius`.
// Unbiased for independent samples (E a (z - p)^2 = a S + 1). no_data: how many values of a
// have a > 0 false. Streamed: the box sums of a, of the numerator and (where some value has no
// data) of [a > 0] exist only as rows; consume(y) is called once row y of the variance is in
// s_row(y), in order of y. p_row(y): row y of p (asked for once or more per row, before the
// variance's row y). With data everywhere the box count of [a > 0] is the full (2r + 1)^2 window
// (reflected borders), a small integer, exact whatever the summation.
template <typename PRow, typename SRow, typename Consume>
void LocalSignalVariance(const cv::Mat& z, const cv::Mat& a, PRow&& p_row, int radius,
                         long long no_data, SRow&& s_row, Consume&& consume) {
  const int n = z.cols * z.channels();
  const size_t bytes = sizeof(float) * n;
  MmseRows& rows = ThreadMmseRows(n);
  const float full = static_cast<float>((2 * radius + 1) * (2 * radius + 1));
  if (no_data == 0) {
    BoxStream<2>(
        z.rows, z.cols, z.channels(), radius, 1.0,
        [&](int y, float* const* in) {
          std::memcpy(in[0], a.ptr<float>(y), bytes);
          NumeratorOnlyRow(z.ptr<float>(y), a.ptr<float>(y), p_row(y), in[1], n);
        },
        [&](int y, const float* const* o) {
          float* s = s_row(y);
          if (SignalVarianceRowFull(o[1], o[0], full, s, n) > 0)
            FixScalarLoopNans(z.rows, z.cols, z.channels(), y, o[1], o[0], nullptr, full, s);
          consume(y);
        });
  } else {
    // The box count of [a > 0] in integers beside the two double planes (BoxStream asks for its
    // bordered rows once each, in order).
    BoxCount count(z.cols, z.channels(), radius);
    BoxStream<2>(
        z.rows, z.cols, z.channels(), radius, 1.0,
        [&](int y, float* const* in) {
          std::memcpy(in[0], a.ptr<float>(y), bytes);
          NumeratorOnlyRow(z.ptr<float>(y), a.ptr<float>(y), p_row(y), in[1], n);
          count.Add(a.ptr<float>(y));
        },
        [&](int y, const float* const* o) {
          count.Output(y, rows.has.data());
          float* s = s_row(y);
          if (SignalVarianceRow(o[1], o[0], rows.has.data(), s, n) > 0)
            FixScalarLoopNans(z.rows, z.cols, z.channels(), y, o[1], o[0], rows.has.data(), 0, s);
          consume(y);
        });
  }
}

// The coarse and middle levels of HierarchicalMmse: w (box sums of a) and m (the BLUE of the
// local mean) per level, the level-0 constant p0 and the coarse level's per-channel signal
// variance s0 (as rows of n values), and the middle level's count of values without data.
struct MmseLevels {
  cv::Mat wc, mc, wm, mm;
  std::vector<float> p0, s0;
  long long wm_none = 0;
};

// Level 0: the inverse-variance-weighted global mean (0.5 where a channel has no data), in float
// as setTo stores it, as one row.
std::vector<float> LevelZero(const cv::Mat& a, const cv::Mat& au, int n, int ch) {
  const cv::Scalar sa = cv::sum(a), sau = cv::sum(au);
  std::vector<float> p0(n);
  for (int i = 0; i < n; ++i) {
    const int c = i % ch;
    p0[i] = static_cast<float>(sa[c] > 0 ? sau[c] / sa[c] : 0.5);
  }
  return p0;
}

// w = box sum of a; m = box sum of a u / max(w, 1e-30), the BLUE of the local mean (noise 1 / w).
// The coarse and middle levels from one pass over a and a u (BoxStreamTwoRadii), with the
// numerator of the coarse level's whole-image signal variance (z = m, weights w, p = the level-0
// constant): s0 = max(sum w (m - p)^2 - sum [w > 0], 0) / sum w per channel; the count of
// [w > 0] is an integer, exact in double whatever the order of its sum.
MmseLevels CoarseAndMiddleLevels(const OracleOptions& o, const cv::Mat& u, const cv::Mat& a,
                                 const cv::Mat& au) {
  const int ch = u.channels();
  const int n = u.cols * ch;
  const size_t bytes = sizeof(float) * n;
  MmseLevels lv;
  lv.p0 = LevelZero(a, au, n, ch);
  lv.s0.resize(n);
  auto level = [&](int y, const float* const* out, const cv::Mat& m) {
    QuotientRow(out[0], out[1], const_cast<cv::Mat&>(m).ptr<float>(y), n);
  };
  auto level_input = [&](int y, float* const* in) {
    std::memcpy(in[0], a.ptr<float>(y), bytes);
    std::memcpy(in[1], au.ptr<float>(y), bytes);
  };
  lv.wc = NewLike(u);
  lv.mc = NewLike(u);
  lv.wm = NewLike(u);
  lv.mm = NewLike(u);
  const cv::Mat num = NewLike(u);
  long long wc_none[4] = {0, 0, 0, 0};
  BoxStreamTwoRadii<2>(
      u.rows, u.cols, ch, o.coarse_radius, o.middle_radius, level_input,
      [&](int y, const float* const* out) {
        level(y, out, lv.mc);
        NumeratorOnlyRow(lv.mc.ptr<float>(y), out[0], lv.p0.data(),
                         const_cast<cv::Mat&>(num).ptr<float>(y), n);
        NoDataPerChannel(out[0], u.cols, ch, wc_none);
      },
      [&](int y, const float* const* out) {
        level(y, out, lv.mm);
        lv.wm_none += NoDataRow(out[0], n);
      },
      [&](int y) { return lv.wc.ptr<float>(y); },  // w written in place
      [&](int y) { return lv.wm.ptr<float>(y); });
  const cv::Scalar sw = cv::sum(lv.wc), sn = cv::sum(num);
  const double values = static_cast<double>(u.rows) * u.cols;
  for (int i = 0; i < n; ++i) {
    const int c = i % ch;
    const double sh = values - static_cast<double>(wc_none[c]);
    lv.s0[i] = static_cast<float>(sw[c] > 0 ? std::max(sn[c] - sh, 0.0) / sw[c] : 0.0);
  }
  return lv;
}

// The middle level's signal variance over coarse windows around p1, the coarse shrink p1 = p0 +
// S w / (S w + 1) (m - p0) (w = 0 keeps p), made as the stream first asks for its rows (again for
// the reflected border: the same values); then the middle shrink into p2 (returned).
// p1 only as a ring of rows (slot y mod ring_rows): the stream asks for source rows at most
// coarse_radius + its batch (8) rows ahead of the output row it emits, and again near the borders
// (the same values, made again), so a ring of 2 coarse_radius + 17 rows keeps every row until its
// output row has read it.
cv::Mat MiddlePrior(const OracleOptions& o, const cv::Mat& u, const MmseLevels& lv,
                    MmseRows& rows) {
  const int n = u.cols * u.channels();
  const cv::Mat p2 = NewLike(u);
  const int ring_rows = 2 * o.coarse_radius + 17;
  thread_local std::vector<float> p1_ring;
  p1_ring.resize(std::max(p1_ring.size(), static_cast<size_t>(ring_rows) * n));
  auto p1_slot = [&](int y) { return p1_ring.data() + static_cast<size_t>(y % ring_rows) * n; };
  auto p1_row = [&](int y) {
    float* row = p1_slot(y);
    ShrinkRowTo(lv.s0.data(), lv.wc.ptr<float>(y), lv.mc.ptr<float>(y), lv.p0.data(), row, n);
    return row;
  };
  LocalSignalVariance(
      lv.mm, lv.wm, p1_row, o.coarse_radius, lv.wm_none, [&](int) { return rows.s.data(); },
      [&](int y) {
        ShrinkRowTo(rows.s.data(), lv.wm.ptr<float>(y), lv.mm.ptr<float>(y), p1_slot(y),
                    const_cast<cv::Mat&>(p2).ptr<float>(y), n);
      });
  return p2;
}

// The linear MMSE estimate of rho from u = rho + noise of variance v (a = 1 / v, 0 where
// masked), under a hierarchical local Gaussian prior (docs/methods.md, "oracle"). Writes the
// prior mean of the finest level to *prior and the posterior variance to *posterior.
// au = a u; a_no_data: how many values of a have a > 0 false; censored (may be null): the
// censoring step applied to the estimate and the prior (OracleMmse). images false: the estimate
// and the posterior variance only as rows (for the detail and its sums; both returned empty).
//
// Level 0 is a per-channel constant (the weighted global mean), level 1 (coarse) shrinks it
// towards the coarse local means with one per-channel signal variance (whole-image sums), level
// 2 (middle) towards the middle local means with the signal variance over coarse windows, and
// the estimate uses the signal variance over pixel windows. Each step is an epilogue of the box
// stream that makes its inputs; only the level means, weights and priors are images (a prior is
// written to a new image, since the stream that reads it re-reads rows for the bottom border).
cv::Mat HierarchicalMmse(const OracleOptions& o, const cv::Mat& u, const cv::Mat& a,
                         const cv::Mat& au, long long a_no_data, const Censored* censored,
                         cv::Mat* prior, cv::Mat* posterior, DetailOut* detail, bool images) {
  const int ch = u.channels();
  const int n = u.cols * ch;
  MmseRows& rows = ThreadMmseRows(n);
  const cv::Mat p2 = MiddlePrior(o, u, CoarseAndMiddleLevels(o, u, a, au), rows);
  // Gain S / (S + v) = S a / (S a + 1), 0 where masked (a = 0); posterior variance
  // S v / (S + v) = S / (S a + 1), S where masked.
  cv::Mat post, est;
  if (images) {
    post = NewLike(u);
    est = NewLike(u);
  }
  auto post_row = [&](int y) { return images ? post.ptr<float>(y) : rows.post.data(); };
  auto est_row = [&](int y) { return images ? est.ptr<float>(y) : rows.est.data(); };
  cv::Mat prior_out = censored != nullptr ? NewLike(u) : p2;
  LocalSignalVariance(
      u, a, [&](int y) { return p2.ptr<float>(y); }, o.pixel_radius, a_no_data, post_row,
      [&](int y) {
        float* s = post_row(y);
        if (censored == nullptr) {
          EstimateRow(a.ptr<float>(y), u.ptr<float>(y), p2.ptr<float>(y), s, est_row(y), n);
        } else {
          EstimateRow(a.ptr<float>(y), u.ptr<float>(y), p2.ptr<float>(y), s, rows.e.data(), n);
          CensorRow(*censored, y, rows.e.data(), est_row(y), n);
          CensorRow(*censored, y, p2.ptr<float>(y), prior_out.ptr<float>(y), n);
        }
        if (detail != nullptr) {
          DetailStatsRow(est_row(y), prior_out.ptr<float>(y), s, detail->masked.ptr<uchar>(y),
                         detail->detail.ptr<float>(y), u.cols, ch, detail->sums);
        }
      });
  *prior = prior_out;
  *posterior = post;
  return est;
}

// MaskBelow's row for the oracle's stream: 255 where some channel of t is below floor (the
// threshold in float, as cv::compare converts it), else 0; returns how many.
TURBID_ROW_KERNEL int MaskRow1(const float* __restrict t, float floor, uchar* __restrict m,
                               int cols) {
  int count = 0;
  for (int x = 0; x < cols; ++x) {
    const bool below = t[x] < floor;
    m[x] = below ? 255 : 0;
    count += below ? 1 : 0;
  }
  return count;
}

int MaskRow(const float* t, float floor, int ch, int cols, uchar* m) {
  if (ch == 1) return MaskRow1(t, floor, m, cols);
  int count = 0;
  for (int x = 0; x < cols; ++x) {
    bool below = false;
    for (int c = 0; c < ch; ++c) below = below || t[x * ch + c] < floor;
    m[x] = below ? 255 : 0;
    count += below ? 1 : 0;
  }
  return count;
}

}  // namespace

cv::Mat NewLike(const cv::Mat& m) { return internal::PooledMat(m.size(), m.type()); }

// Pixels where any channel of t is below `floor` (NaN depth has t = 0): CV_8UC1, 255 = masked.
cv::Mat MaskBelow(const cv::Mat& t, double floor) {
  if (t.channels() == 1) return t < floor;  // no copy of the one plane (cv::split would)
  std::vector<cv::Mat> planes;
  cv::split(t, planes);
  cv::Mat mask = planes[0] < floor;
  for (size_t c = 1; c < planes.size(); ++c) mask |= planes[c] < floor;
  return mask;
}

OracleMmseResult OracleMmse(const OracleOptions& o, const cv::Mat& image,
                            const cv::Mat& transmission, const cv::Mat& irradiance,
                            const cv::Mat& snow, const cv::Mat& veil, double shot_gain,
                            double floor_var, double clip_level, bool with_detail,
                            const CodedQuantisation& quantisation) {
  return OracleMmse(
      o, image,
      [&](int y, const float*& t, const float*& e, const float*& sn, const float*& ve) {
        t = transmission.ptr<float>(y);
        e = irradiance.ptr<float>(y);
        sn = snow.ptr<float>(y);
        ve = veil.ptr<float>(y);
      },
      shot_gain, floor_var, clip_level, with_detail, true, quantisation);
}

OracleMmseResult OracleMmse(const OracleOptions& o, const cv::Mat& image,
                            const TruthRowFn& truth_row, double shot_gain, double floor_var,
                            double clip_level_d, bool with_detail, bool keep_estimate,
                            const CodedQuantisation& quantisation) {
  const float gain_f = static_cast<float>(shot_gain), floor_f = static_cast<float>(floor_var);

  // u = (I - S - veil) / (t (E_A + E_L)) ~ h * rho, with variance v = var / (t E)^2; a = 1 / v,
  // 0 where masked. Clipped samples (I at 1 in a channel) are not Gaussian data: they get no
  // weight. A sample clipped at 1 still bounds rho from below, (1 - 2 sigma - S - veil) / (t E):
  // the estimate is raised onto that bound where it falls short (docs/methods.md).
  OracleMmseResult r;
  r.masked = internal::PooledMat(image.size(), CV_8UC1);  // made row by row in the stream below
  const cv::Mat& masked = r.masked;
  const float mask_floor = static_cast<float>(o.mask_transmission);  // as cv::compare takes it
  const float clip_level = static_cast<float>(clip_level_d);
  const int ch = image.channels();
  // One streamed pass: the 7 x 7 mean of I (cv::boxFilter's, bit for bit), the variance from it
  // (a row only), the data term, a u, the counts, and the censored values with their bounds
  // (est += (max(est, bound) - est) where clipped, applied as the estimate is made).
  cv::Mat u = NewLike(image), a = NewLike(image), au = NewLike(image);
  int censored = 0;
  long long a_no_data = 0;
  const int n = image.cols * ch;
  thread_local std::vector<float> variance_row;
  variance_row.resize(std::max<size_t>(variance_row.size(), n));
  thread_local Censored clipped;
  clipped.row_start.assign(1, 0);
  clipped.index.clear();
  clipped.bound.clear();
  BoxStreamImage(image, 3, 1.0 / 49.0, [&](int y, const float* const* mean) {
    float* var = variance_row.data();
    NoiseVarianceRow(mean[0], var, gain_f, floor_f, n);
    AddQuantisationRow(mean[0], quantisation, var, n);
    const float* in = image.ptr<float>(y);
    const float *t = nullptr, *e = nullptr, *sn = nullptr, *ve = nullptr;
    truth_row(y, t, e, sn, ve);
    float* uu = u.ptr<float>(y);
    float* aa = a.ptr<float>(y);
    uchar* mk = const_cast<cv::Mat&>(masked).ptr<uchar>(y);
    r.masked_pixels += MaskRow(t, mask_floor, ch, image.cols, mk);
    DataTermRow(in, t, e, sn, ve, var, mk, clip_level, ch, image.cols, uu, aa);
    const int clipped_here = CountClipped(in, clip_level, ch, image.cols);
    censored += clipped_here;
    for (int i = 0; clipped_here > 0 && i < n; ++i) {
      if (!(in[i] > clip_level)) continue;
      const float sc = std::max(t[i] * e[i], 1e-12f);
      clipped.index.push_back(i);
      clipped.bound.push_back((((in[i] - 2.0f * std::sqrt(var[i])) - sn[i]) - ve[i]) / sc);
    }
    clipped.row_start.push_back(static_cast<int>(clipped.index.size()));
    ProductRow(aa, uu, au.ptr<float>(y), n);
    a_no_data += NoDataRow(aa, n);
  });
  r.censored_pixels = censored;
  DetailOut detail_out;
  if (with_detail) {
    detail_out.masked = masked;
    detail_out.detail = NewLike(image);
  }
  r.estimate = HierarchicalMmse(o, u, a, au, a_no_data, censored > 0 ? &clipped : nullptr, &r.prior,
                                &r.posterior, with_detail ? &detail_out : nullptr,
                                !with_detail || keep_estimate);
  if (with_detail) {
    r.detail = detail_out.detail;
    r.detail_sums = detail_out.sums;
  }
  return r;
}

}  // namespace oracle_internal
}  // namespace turbid
