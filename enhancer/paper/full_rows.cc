// `full` on colour images, streamed (FullEnhance only; FullEnhanceDetailed keeps every
// intermediate). The whole-image steps become row producers with the same arithmetic: J_plane
// (eq. 6), its exposure scale and the detail layer are computed per row as the deblur asks for
// them, the deblurred rows are clamped and binned for CLAHE as they come, and the output reuses
// the denoised image's buffer. Full-size buffers: the denoised image (then the output), the
// upsampled t and E_L maps (one channel each when one beta), CLAHE's bins.
#include <algorithm>
#include <functional>
#include <string>
#include <vector>

#include "core/row_kernel.h"
#include "enhancer/blocks/clahe.h"
#include "enhancer/counted_sample.h"
#include "enhancer/blocks/deconvolution.h"
#include "enhancer/paper/full.h"
#include "enhancer/paper/full_internal.h"
#include "enhancer/paper/kernels.h"
#include "enhancer/simd_switch.h"
#include "simulator/psf.h"

namespace turbid::paper_internal {
namespace {

// Row y of the image entering the deblur (J_plane, exposure-scaled, plus the detail layer), from
// the input, the denoised image, E_L (map or rows, x scale) and t (`transmission`, or `t_rows`
// when that is not empty).
class ColorRowSource {
 public:
  ColorRowSource(const FullOptions& o, const cv::Mat& image, const cv::Mat& denoised,
                 LightEstimate light, const cv::Mat& transmission,
                 const enhancer_internal::LinearUpsampler& t_rows, bool dehaze)
      : image_(image),
        denoised_(denoised),
        light_(std::move(light)),
        t_(transmission),
        t_rows_(t_rows),
        dehaze_(dehaze),
        detail_(o.keep_detail > 0 && o.denoise),
        keep_(static_cast<float>(o.keep_detail)),
        n_(image.cols * 3),
        e_row_(light_.empty() ? 0 : n_),
        t_row_(n_),
        e_upsampled_(light_.rows.empty() ? 0 : image.cols),
        t_upsampled_(t_rows_.empty() ? 0 : image.cols) {
    // E_L's per-channel scale (1 without one), for DehazeSpreadAvx2.
    const bool scaled = !light_.empty() && !light_.scale.empty();
    for (int c = 0; c < 3; ++c) scale_[c] = scaled ? light_.scale[c] : 1.0;
  }

  // J_plane of row y (eq. 6), or the denoised row without dehazing; `dst` holds n floats.
  void Dehazed(int y, float* dst) {
    const float* in = denoised_.ptr<float>(y);
    if (!dehaze_) {
      std::copy_n(in, n_, dst);
      return;
    }
#ifdef TURBID_HAVE_DEHAZE_AVX2
    if (Spread()) {
      DehazeSpreadAvx2<AfterDehaze::kNone>(in, LightRow(y), scale_, TRow(y), nullptr, 1.0f, 0.0f,
                                           dst, image_.cols);
      return;
    }
#endif
    const float* t = Expand(TRow(y), TChannels(), nullptr, t_row_.data());
    if (light_.empty()) {
      DehazeRowNoLight(in, t, dst, n_);
    } else {
      const float* e = Expand(LightRow(y), LightChannels(), &light_.scale, e_row_.data());
      DehazeRowLight(in, e, t, dst, n_);
    }
  }

  // The deblur's input row: J_plane / exposure, plus keep_detail (I - I_de).
  void Row(int y, float* dst) {
#ifdef TURBID_HAVE_DEHAZE_AVX2
    // Eq. 6, the exposure scale and the detail layer in one pass over the row.
    if (dehaze_ && Spread() && (detail_ || exposure_ != 1.0f)) {
      const float* in = denoised_.ptr<float>(y);
      if (detail_) {
        DehazeSpreadAvx2<AfterDehaze::kScaleDetail>(in, LightRow(y), scale_, TRow(y),
                                                    image_.ptr<float>(y), exposure_, keep_, dst,
                                                    image_.cols);
      } else {
        DehazeSpreadAvx2<AfterDehaze::kScale>(in, LightRow(y), scale_, TRow(y), nullptr, exposure_,
                                              0.0f, dst, image_.cols);
      }
      return;
    }
#endif
    Dehazed(y, dst);
    if (detail_) {
      ExposureDetailRow(image_.ptr<float>(y), denoised_.ptr<float>(y), exposure_, keep_, dst, n_);
    } else if (exposure_ != 1.0f) {
      ScaleRow(dst, exposure_, n_);
    }
  }

  int values() const { return n_; }
  // J_plane is divided by `level` (cv::Mat::convertTo's float product by 1 / level).
  void SetExposure(double level) { exposure_ = static_cast<float>(1.0 / level); }

 private:
#ifdef TURBID_HAVE_DEHAZE_AVX2
  // Whether DehazeSpreadAvx2 serves: one t and one E_L map for every channel (one beta), spread
  // and scaled in registers, on a CPU with AVX2 and FMA.
  bool Spread() const {
    static const bool fma = CpuHasFma();
    return fma && TChannels() == 1 && (light_.empty() || LightChannels() == 1) &&
           enhancer_internal::UseHandWrittenAvx2();
  }
#endif
  // Row y of t and of E_L (null without light), from the maps or computed from their rows.
  const float* TRow(int y) {
    return t_rows_.empty() ? t_.ptr<float>(y) : t_rows_.Row(y, t_upsampled_.data());
  }
  const float* LightRow(int y) {
    if (!light_.rows.empty()) return light_.rows.Row(y, e_upsampled_.data());
    return light_.map.empty() ? nullptr : light_.map.ptr<float>(y);
  }
  int TChannels() const { return t_rows_.empty() ? t_.channels() : 1; }
  int LightChannels() const { return light_.rows.empty() ? light_.map.channels() : 1; }

  // A row `p` of a one- or three-channel map as three values per pixel, times scale[c] in double
  // (cv::multiply by a Scalar) when a scale is given.
  const float* Expand(const float* p, int channels, const std::vector<double>* scale, float* buf) {
    const int w = image_.cols;
    if (scale == nullptr || scale->empty()) {
      if (channels == 3) return p;
      SpreadRow(p, buf, w);
    } else if (channels == 1) {
      SpreadScaledRow(p, (*scale)[0], (*scale)[1], (*scale)[2], buf, w);
    } else {
      ScaledRow3(p, (*scale)[0], (*scale)[1], (*scale)[2], buf, w);
    }
    return buf;
  }

  static TURBID_ROW_KERNEL void SpreadRow(const float* __restrict p, float* __restrict b, int w) {
    for (int x = 0; x < w; ++x) b[3 * x] = b[3 * x + 1] = b[3 * x + 2] = p[x];
  }
  static TURBID_ROW_KERNEL void SpreadScaledRow(const float* __restrict p, double s0, double s1,
                                                double s2, float* __restrict b, int w) {
    for (int x = 0; x < w; ++x) {
      const double v = p[x];
      b[3 * x] = static_cast<float>(v * s0);
      b[3 * x + 1] = static_cast<float>(v * s1);
      b[3 * x + 2] = static_cast<float>(v * s2);
    }
  }
  static TURBID_ROW_KERNEL void ScaledRow3(const float* __restrict p, double s0, double s1,
                                           double s2, float* __restrict b, int w) {
    for (int x = 0; x < w; ++x) {
      b[3 * x] = static_cast<float>(static_cast<double>(p[3 * x]) * s0);
      b[3 * x + 1] = static_cast<float>(static_cast<double>(p[3 * x + 1]) * s1);
      b[3 * x + 2] = static_cast<float>(static_cast<double>(p[3 * x + 2]) * s2);
    }
  }

  static TURBID_ROW_KERNEL void DehazeRowLight(const float* __restrict in,
                                               const float* __restrict e, const float* __restrict t,
                                               float* __restrict d, int n) {
    for (int i = 0; i < n; ++i) d[i] = (in[i] - e[i]) / t[i] + e[i];
  }
  static TURBID_ROW_KERNEL void DehazeRowNoLight(const float* __restrict in,
                                                 const float* __restrict t, float* __restrict d,
                                                 int n) {
    for (int i = 0; i < n; ++i) d[i] = in[i] / t[i];
  }
  static TURBID_ROW_KERNEL void ScaleRow(float* __restrict v, float k, int n) {
    for (int i = 0; i < n; ++i) v[i] *= k;
  }

  const cv::Mat& image_;
  const cv::Mat& denoised_;
  const LightEstimate light_;
  const cv::Mat& t_;
  const enhancer_internal::LinearUpsampler& t_rows_;
  const bool dehaze_, detail_;
  const float keep_;
  const int n_;
  float exposure_ = 1.0f;
  double scale_[3];
  std::vector<float> e_row_, t_row_;
  std::vector<float> e_upsampled_, t_upsampled_;  // one-channel rows computed from *_rows
};

// ExposureStep on the rows of J_plane (the same sample: every second value of every second row).
void ExposureStepRows(const FullOptions& o, ColorRowSource& src, int rows, FullResult* r) {
  if (o.exposure_percentile <= 0) return;
  const int n = src.values();
  std::vector<float> row(n);
  enhancer_internal::CountedSample sample(static_cast<size_t>((rows + 1) / 2) *
                                          static_cast<size_t>((n + 1) / 2));
  for (int y = 0; y < rows; y += 2) {
    src.Dehazed(y, row.data());
    sample.AddEverySecondFinite(row.data(), n);
  }
  if (sample.empty()) return;
  const double level = sample.Percentile(o.exposure_percentile);
  if (level > 1.0) {
    r->exposure_scale = level;
    src.SetExposure(level);
    r->steps.push_back("exposure: J_plane divided by its " + FormatNumber(o.exposure_percentile) +
                       "th percentile " + FormatNumber(level));
  }
}

// Steps 4 and 5 over the row source when the deblur is the spatial Wiener filter: rows produced
// into a ring of 2k + 1 (k the inverse filter's radius), deblurred, clamped (ClampUnit) and
// binned into `out`. Returns false (nothing done) when another deblur path applies.
bool DeblurAndContrastRows(const FullOptions& o, ColorRowSource& src, cv::Mat& out, FullResult* r) {
  if (!o.deblur) return false;
  PsfOptions p;
  p.optical_thickness = o.psf_optical_thickness;
  p.forward_scatter = o.psf_forward_scatter;
  const Psf psf = PsfKernel(p);
  if (psf.is_delta || o.deconvolution.method != DeconvolutionMethod::kWiener ||
      o.deconvolution.spatial_max_radius <= 0) {
    return false;
  }
  const int k = WienerInverseKernel(psf.kernel, o.deconvolution.nsr).rows / 2;
  if (k > o.deconvolution.spatial_max_radius) return false;
  const CameraEncoding coding = r->clahe_encoding;
  const ClaheOptions clahe = StepClaheOptions(o, coding);
  const int n = src.values(), ring = std::min(2 * k + 1, out.rows);
  cv::Mat rows(ring, n, CV_32F), bins;
  if (o.contrast) bins = ClaheNewBins(clahe, out.size());
  std::vector<float> lum(out.cols);
  int next = 0;  // rows [next - ring, next) are in the ring
  const bool streamed = DeconvolveRowsFrom(
      o.deconvolution, out.size(), 3,
      [&](int y) {
        for (; next <= y; ++next) src.Row(next, rows.ptr<float>(next % ring));
        return rows.ptr<float>(y % ring);
      },
      psf.kernel,
      [&](int y, const float* row) {
        float* dst = out.ptr<float>(y);  // its denoised values were read for ring row y
        // Clamped, and coded when CLAHE equalises the camera-coded image (decoded after it).
        if (o.contrast && coding != CameraEncoding::kLinear) {
          ClaheEncodeRow(row, dst, n, coding);  // clamps to [0, 1] first
        } else {
          ClampUnitCopyRow(row, dst, n);
        }
        if (o.contrast) ClaheBinColorRow(clahe, dst, lum.data(), bins, y);
      });
  if (!streamed) return false;  // another deblur path after all: nothing was read or written
  r->steps.push_back("deblur: " + DeconvolutionMethodName(o.deconvolution.method) +
                     ", PSF radius " + std::to_string(psf.radius_px));
  ClaheStats stats;
  if (o.contrast) {
    // In [0, 1]; each row decoded while in cache when CLAHE equalised the coded image.
    std::function<void(float*, int)> decode;
    if (coding != CameraEncoding::kLinear) {
      decode = [&](float* row, int) { ClaheDecodeRow(row, n, coding); };
    }
    ClaheColorFromBins(clahe, bins, out, &stats, decode);
  }
  ContrastStepLog(o, clahe, stats, r);
  return true;
}

}  // namespace

// Steps 1-5 of `full` for a three-channel image after the geometry (FullEnhanceImpl's).
cv::Mat FullColorStreamed(const FullOptions& o, const cv::Mat& image,
                          const IrradianceOptions& lights, const CameraIntrinsics& camera,
                          const std::vector<double>& beta, bool any_beta, const double* noise_sigma,
                          const enhancer_internal::LinearUpsampler& t_rows, FullResult* r) {
  const cv::Mat denoised = DenoiseStep(o, image, r, noise_sigma, &t_rows);
  LightEstimate light = LightStepUnscaled(o, lights, camera, beta, denoised, r, &t_rows);
  const bool dehaze = o.dehaze && any_beta;
  ColorRowSource src(o, image, denoised, std::move(light), r->transmission, t_rows, dehaze);
  if (dehaze) {
    std::string values;
    for (double b : r->beta_per_m) values += (values.empty() ? "" : "/") + FormatNumber(b);
    r->steps.push_back("dehaze: beta " + values + " 1/m (" + r->beta_source +
                       "), t >= " + FormatNumber(o.t_min));
    ExposureStepRows(o, src, image.rows, r);
  } else {
    r->steps.push_back(o.dehaze ? "dehaze: skipped (beta 0)" : "dehaze: skipped (off)");
  }
  if (o.keep_detail > 0 && o.denoise) {
    r->steps.push_back("detail: the denoising residual added back x" + FormatNumber(o.keep_detail));
  }
  // The output overwrites the denoised image row by row when that is our own buffer.
  cv::Mat out = o.denoise ? denoised : cv::Mat(image.size(), CV_32FC3);
  if (DeblurAndContrastRows(o, src, out, r)) return out;
  // Other deblur paths: the whole deblur input, then the general steps 4-5.
  cv::Mat current(image.size(), CV_32FC3);
  for (int y = 0; y < image.rows; ++y) src.Row(y, current.ptr<float>(y));
  return DeblurAndContrast(o, current, false, r);
}

}  // namespace turbid::paper_internal
