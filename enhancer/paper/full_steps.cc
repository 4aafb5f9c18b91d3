// `full`'s whole-image steps (§III-A): the geometry (camera, plane), the noise estimate, the
// denoising (step 1), t, the dehazing (step 3) with its exposure scale, the deblur (step 4) and
// CLAHE (step 5); the light estimate (step 2) is in full_light.cc, the streamed colour path in
// full_rows.cc, the pipeline in full.cc.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "core/error.h"
#include "enhancer/blocks/guided_filter.h"
#include "enhancer/paper/full.h"
#include "enhancer/paper/full_internal.h"
#include "enhancer/paper/kernels.h"
#include "enhancer/blocks/plane_fit.h"
#include "enhancer/select.h"
#include "enhancer/simd_switch.h"
#include "simulator/psf.h"
#include "simulator/render.h"
#include "simulator/water.h"

namespace turbid {
namespace paper_internal {

void ClampUnit(cv::Mat& m) {
  cv::patchNaNs(m, 0.0);
  cv::min(m, 1.0, m);
  cv::max(m, 0.0, m);
}

bool Fail(std::string* why, const std::string& message) {
  *why = message;
  return false;
}

// Camera for an image: the scene's, else the sidecar's, else a 53-degree pinhole (fx = max side).
CameraIntrinsics ResolveCamera(const cv::Mat& image, const Scene* scene,
                               const RenderRecord* sidecar, std::vector<std::string>* steps) {
  if (scene != nullptr) {
    if (scene->camera.width != image.cols || scene->camera.height != image.rows) {
      throw Error("full: image is " + std::to_string(image.cols) + "x" +
                  std::to_string(image.rows) + " but the scene's camera is " +
                  std::to_string(scene->camera.width) + "x" + std::to_string(scene->camera.height));
    }
    return scene->camera;
  }
  CameraIntrinsics c;
  c.width = image.cols;
  c.height = image.rows;
  if (sidecar != nullptr) {
    const RenderRecord::SceneInfo& s = sidecar->scene;
    c.fx = s.fx, c.fy = s.fy, c.cx = s.cx, c.cy = s.cy;
    if (s.width == image.cols && s.height == image.rows && c.fx != 0 && c.fy != 0) {
      steps->push_back("camera: from the sidecar");
      return c;
    }
  }
  c.fx = c.fy = std::max(image.cols, image.rows);
  c.cx = (image.cols - 1) / 2.0;
  c.cy = (image.rows - 1) / 2.0;
  steps->push_back("camera: none given, assumed pinhole with fx = fy = max(width, height)");
  return c;
}

Plane ResolvePlane(const FullOptions& o, const Scene* scene, const CameraIntrinsics& camera,
                   std::string* source) {
  const std::string& want = o.plane;
  const bool any = want == "auto";
  if (scene != nullptr && (any || want == "dvl") && scene->dvl_points_in_camera.size() >= 3) {
    try {
      *source = "dvl";
      return FitPlaneToPoints(scene->dvl_points_in_camera);
    } catch (const Error&) {
      if (!any) throw;
    }
  }
  if (scene != nullptr && (any || want == "depth") && !scene->depth_m.empty()) {
    try {
      *source = "depth";
      return FitPlaneToDepth(PlaneFitOptions{}, camera, scene->depth_m).plane;
    } catch (const Error&) {
      if (!any) throw;
    }
  }
  if (scene != nullptr && (any || want == "scene") && scene->dominant_plane) {
    *source = "scene";
    return *scene->dominant_plane;
  }
  if (!any && want != "frontal") {
    throw Error("full: plane source '" + want + "' is not available for this input");
  }
  *source = "frontal";
  return Plane{cv::Vec3d(0, 0, -1), o.frontal_distance_m};
}

CameraIntrinsics Downscaled(const CameraIntrinsics& c, int subsample) {
  CameraIntrinsics s = c;
  s.width = std::max(1, (c.width + subsample - 1) / subsample);
  s.height = std::max(1, (c.height + subsample - 1) / subsample);
  const double kx = static_cast<double>(s.width) / c.width;
  const double ky = static_cast<double>(s.height) / c.height;
  s.fx = c.fx * kx, s.fy = c.fy * ky;
  s.cx = (c.cx + 0.5) * kx - 0.5, s.cy = (c.cy + 0.5) * ky - 0.5;
  return s;
}

cv::Mat PlaneDepth(const Plane& plane, const CameraIntrinsics& camera, double max_range_m) {
  cv::Mat z = DepthFromPlane(plane, camera);
  // Rays that miss the plane see open water: the farthest range we consider, as z-depth.
  for (int y = 0; y < z.rows; ++y) {
    float* p = z.ptr<float>(y);
    for (int x = 0; x < z.cols; ++x) {
      const cv::Vec3d ray = camera.Ray(x, y);
      const float zmax = static_cast<float>(max_range_m / cv::norm(ray));
      if (!std::isfinite(p[x]) || p[x] > zmax) p[x] = zmax;
    }
  }
  return z;
}

cv::Mat Upsample(const cv::Mat& small, cv::Size size) {
  if (small.size() == size) return small;
  cv::Mat out;
  cv::resize(small, out, size, 0, 0, cv::INTER_LINEAR);
  return out;
}

// The value at `percentile` (%) of `values` (no NaN), by rank floor(p/100 (n - 1)).
double PercentileOf(std::vector<float>& values, double percentile) {
  const size_t k = static_cast<size_t>(std::floor(percentile / 100.0 * (values.size() - 1)));
  return enhancer_internal::SelectKth<float, uint32_t>(values, k);
}
double PercentileOf(ScratchVector<float>& values, double percentile) {
  const size_t k = static_cast<size_t>(std::floor(percentile / 100.0 * (values.size() - 1)));
  return enhancer_internal::SelectKth<float, uint32_t>(values, k);
}

// %g-style number for the step log (0.7, not 0.700000).
std::string FormatNumber(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%g", v);
  return buf;
}

// Noise standard deviation of a float image (all channels), J. Immerkaer, "Fast noise variance
// estimation", CVIU 64(2) 1996, eq. 2: sqrt(pi/2) / (6 (W-2)(H-2)) sum |I * N| with the 3x3
// Laplacian-difference mask N = [1 -2 1; -2 4 -2; 1 -2 1], over interior pixels.
double EstimateNoiseSigma(const cv::Mat& image) {
  if (image.rows < 3 || image.cols < 3) return 0.0;
  CV_Assert(image.depth() == CV_32F);
  const int ch = image.channels(), n = (image.cols - 2) * ch;
  // Each row's sum is one float accumulation in order (accumulated in double over the rows, in
  // order); kRows rows are summed side by side so their dependent additions overlap (16 with
  // AVX-512: the same sums).
  constexpr int kRows = 8, kWideRows = 16;
#ifdef TURBID_HAVE_NOISE_AVX2
  const bool avx2 = enhancer_internal::UseHandWrittenAvx2();
  const bool wide = KernelCpuLevel() >= CpuLevel::kAvx512;
#else
  const bool avx2 = false;
#endif
  std::vector<float> v(avx2 ? 0 : static_cast<size_t>(kRows) * n);
  double total = 0.0;
  for (int y0 = 1; y0 + 1 < image.rows; y0 += kRows) {
    const int m = std::min(kRows, image.rows - 1 - y0);
    float row[kWideRows] = {};
#ifdef TURBID_HAVE_NOISE_AVX2
    if (avx2 && m == kRows) {
      const float* rows[kWideRows + 2];
      if (wide && image.rows - 1 - y0 >= kWideRows) {
        for (int k = 0; k < kWideRows + 2; ++k) rows[k] = image.ptr<float>(y0 - 1 + k);
        LaplacianAbsSums16(rows, ch, n, row);
        for (int k = 0; k < kWideRows; ++k) total += row[k];
        y0 += kWideRows - kRows;
        continue;
      }
      for (int k = 0; k < kRows + 2; ++k) rows[k] = image.ptr<float>(y0 - 1 + k);
      LaplacianAbsSums8(rows, ch, n, row);
      for (int k = 0; k < m; ++k) total += row[k];
      continue;
    }
#endif
    if (avx2) v.resize(static_cast<size_t>(kRows) * n);
    for (int k = 0; k < m; ++k) {
      const int y = y0 + k;
      LaplacianAbsRow(image.ptr<float>(y - 1), image.ptr<float>(y), image.ptr<float>(y + 1), ch,
                      v.data() + static_cast<size_t>(k) * n, n);
    }
    if (m == kRows) {
      const float* p = v.data();
      for (int i = 0; i < n; ++i) {
        for (int k = 0; k < kRows; ++k) row[k] += p[static_cast<size_t>(k) * n + i];
      }
    } else {
      for (int k = 0; k < m; ++k) {
        for (int i = 0; i < n; ++i) row[k] += v[static_cast<size_t>(k) * n + i];
      }
    }
    for (int k = 0; k < m; ++k) total += row[k];
  }
  const double count = 6.0 * (image.cols - 2) * (image.rows - 2) * ch;
  return std::sqrt(CV_PI / 2.0) * total / count;
}

// Step 1 (eq. 4): self-guided filter per channel; with denoise_adaptive the epsilon follows the
// haze (t_med) and the noise.
// `noise_sigma`: the image's EstimateNoiseSigma when already known (else null: computed here).
// `t_rows`: t as rows (the streamed colour path; r->transmission empty then), or null.
cv::Mat DenoiseStep(const FullOptions& o, const cv::Mat& image, FullResult* r,
                    const double* noise_sigma, const enhancer_internal::LinearUpsampler* t_rows) {
  if (!o.denoise) {
    r->steps.push_back("denoise: skipped (off)");
    return image;
  }
  GuidedFilterOptions g;
  g.radius = o.denoise_radius;
  g.eps = o.denoise_eps;
  std::string how;
  if (o.denoise_adaptive) {
    double t_med = 1.0;
    const bool t_as_rows = t_rows != nullptr && !t_rows->empty();
    if (!r->transmission.empty() || t_as_rows) {
      // Every fourth value of every fourth row of t.
      const cv::Mat& t = r->transmission;
      const int n = t_as_rows ? image.cols : t.cols * t.channels();
      std::vector<float> sample, row(t_as_rows ? n : 0);
      for (int y = 0; y < image.rows; y += 4) {
        const float* p = t_as_rows ? t_rows->Row(y, row.data()) : t.ptr<float>(y);
        for (int i = 0; i < n; i += 4) sample.push_back(p[i]);
      }
      if (!sample.empty()) t_med = PercentileOf(sample, 50.0);
    }
    r->noise_sigma = noise_sigma != nullptr ? *noise_sigma : EstimateNoiseSigma(image);
    const double noise_eps = std::pow(o.denoise_noise_factor * r->noise_sigma, 2);
    g.eps = std::min(o.denoise_eps, std::max(o.denoise_eps * t_med * t_med, noise_eps));
    g.eps = std::max(g.eps, 1e-8);
    how = " (adaptive: t_med " + FormatNumber(t_med) + ", noise sigma " +
          FormatNumber(r->noise_sigma) + ")";
  }
  r->denoise_eps = g.eps;
  r->steps.push_back("denoise: guided filter r " + std::to_string(o.denoise_radius) + ", eps " +
                     FormatNumber(g.eps) + how);
  return GuidedFilterSelf(g, image);
}

// The LED specification (the sidecar's lights, else the simulator's default LED) and beta: the
// fixed beta_per_m, or with beta_source=auto the sidecar's water per channel. One value when every
// channel has the same beta.
void ResolveLightsAndBeta(const FullOptions& o, const RenderRecord* sidecar, int channels,
                          IrradianceOptions* lights, std::vector<double>* beta, FullResult* r) {
  *beta = {o.beta_per_m};
  r->beta_source = "beta_per_m";
  if (sidecar != nullptr && sidecar->options) {
    const RenderOptions& rendered = *sidecar->options;
    *lights = rendered.light;
    if (o.beta_source == "auto") {
      const WaterOptions& water = rendered.water;
      *beta = ChannelValues(water.beta_rgb_per_m, water.beta_gray_per_m, channels);
      r->beta_source = "sidecar water";
    }
  }
  if (std::all_of(beta->begin(), beta->end(), [&](double b) { return b == (*beta)[0]; })) {
    beta->resize(1);
  }
  r->beta_per_m = beta->size() == 1 ? std::vector<double>(channels, (*beta)[0]) : *beta;
}

// t = exp(-beta r) on the plane, clamped to t_min, at 1/light_subsample and upsampled; one map per
// distinct beta. Fills r->transmission (and r->range_m when inspecting); with `t_rows` and one
// beta, *t_rows instead (the rows of the upsampled map, one at a time).
void TransmissionStep(const FullOptions& o, const CameraIntrinsics& camera,
                      const std::vector<double>& beta, cv::Size size, bool keep_steps,
                      FullResult* r, enhancer_internal::LinearUpsampler* t_rows) {
  const CameraIntrinsics small = Downscaled(camera, o.light_subsample);
  const cv::Mat range = RangeFromDepth(small, PlaneDepth(*r->plane, small, o.max_range_m));
  std::vector<cv::Mat> t_planes;
  for (double b : beta) {
    cv::Mat t;
    cv::exp(range * -b, t);
    cv::max(t, o.t_min, t);
    if (t_rows != nullptr && beta.size() == 1) {
      *t_rows = enhancer_internal::LinearUpsampler(t, size);
      return;
    }
    t_planes.push_back(Upsample(t, size));
  }
  if (keep_steps) r->range_m = Upsample(range, size);
  if (t_planes.size() == 1) {
    r->transmission = t_planes[0];
  } else {
    cv::merge(t_planes, r->transmission);
  }
}

// Step 3 (eq. 6): (I - E_L) / t + E_L, or I / t without light; a one-channel t serves every
// channel. Written into `dehazed`, which may be `current` itself.
void DehazeRows(const cv::Mat& current, const cv::Mat& e_l, const cv::Mat& tm, cv::Mat& dehazed) {
  const int channels = current.channels();
  const bool t_per_value = tm.channels() == channels;  // else one t for every channel
  const int n = current.cols * channels;
  for (int y = 0; y < current.rows; ++y) {
    const float* in = current.ptr<float>(y);
    const float* t = tm.ptr<float>(y);
    const float* e = e_l.empty() ? nullptr : e_l.ptr<float>(y);
    float* d = dehazed.ptr<float>(y);
    if (t_per_value && e == nullptr) {
      for (int i = 0; i < n; ++i) d[i] = in[i] / t[i];
    } else if (t_per_value) {
      for (int i = 0; i < n; ++i) d[i] = (in[i] - e[i]) / t[i] + e[i];
    } else {
      for (int x = 0; x < current.cols; ++x) {
        const float ti = t[x];
        for (int i = x * channels; i < (x + 1) * channels; ++i) {
          d[i] = e == nullptr ? in[i] / ti : (in[i] - e[i]) / ti + e[i];
        }
      }
    }
  }
}

// Divides J_plane by its exposure_percentile percentile when that exceeds 1 (sampled on a
// stride-2 grid, every channel).
void ExposureStep(const FullOptions& o, cv::Mat& dehazed, FullResult* r) {
  if (o.exposure_percentile <= 0) return;
  std::vector<float> sample;
  sample.reserve(static_cast<size_t>(dehazed.total() * dehazed.channels() / 4 + 16));
  const int n = dehazed.cols * dehazed.channels();
  for (int y = 0; y < dehazed.rows; y += 2) {
    const float* p = dehazed.ptr<float>(y);
    for (int i = 0; i < n; i += 2) {
      if (std::isfinite(p[i])) sample.push_back(p[i]);
    }
  }
  if (sample.empty()) return;
  const double level = PercentileOf(sample, o.exposure_percentile);
  if (level > 1.0) {
    r->exposure_scale = level;
    dehazed.convertTo(dehazed, CV_32F, 1.0 / level);
    r->steps.push_back("exposure: J_plane divided by its " + FormatNumber(o.exposure_percentile) +
                       "th percentile " + FormatNumber(level));
  }
}

// The contrast step's log line.
void ContrastStepLog(const FullOptions& o, const ClaheOptions& clahe, const ClaheStats& stats,
                     FullResult* r) {
  if (!o.contrast) {
    r->steps.push_back("contrast: skipped (off)");
    return;
  }
  r->clahe_alpha = stats.alpha;
  std::string what = "contrast: CLAHE " + ClaheDistributionName(clahe.distribution);
  if (clahe.distribution != ClaheDistribution::kUniform) {
    what += ", alpha " + FormatNumber(stats.alpha);
    if (clahe.keep_mean) {
      what += " (chosen for the mean " + FormatNumber(stats.target_mean) + "; mean in " +
              FormatNumber(stats.input_mean) + ")";
    }
  }
  what += o.clahe_domain == ClaheDomain::kLinear
              ? ", on linear light"
              : ", on " + CameraEncodingName(r->clahe_encoding) + "-coded values (" +
                    r->clahe_encoding_source + "), decoded back to linear";
  r->steps.push_back(what);
}

// Steps 4 (eq. 7) and 5 (CLAHE). Without inspection, a one-channel spatial Wiener deblur streams
// its rows straight into CLAHE's bin indices: no full-size deblurred image.
cv::Mat DeblurAndContrast(const FullOptions& o, cv::Mat current, bool keep_steps, FullResult* r) {
  const int channels = current.channels();
  const CameraEncoding coding = r->clahe_encoding;
  const bool coded = coding != CameraEncoding::kLinear;
  const ClaheOptions clahe = StepClaheOptions(o, coding);
  cv::Mat bins;
  // One row into CLAHE's bins, coded first when CLAHE equalises the camera-coded image.
  const auto bin_row = [&](const float* row, int y) {
    if (!coded) return ClaheBinRow(clahe, row, bins, y);
    thread_local std::vector<float> buffer;
    buffer.resize(static_cast<size_t>(bins.cols));
    ClaheEncodeRow(row, buffer.data(), bins.cols, coding);
    ClaheBinRow(clahe, buffer.data(), bins, y);
  };
  if (o.deblur) {
    PsfOptions p;
    p.optical_thickness = o.psf_optical_thickness;
    p.forward_scatter = o.psf_forward_scatter;
    const Psf psf = PsfKernel(p);
    if (psf.is_delta) {
      r->steps.push_back("deblur: skipped (PSF is a delta at this pixel scale)");
    } else {
      bool streamed = false;
      if (!keep_steps && o.contrast && channels == 1) {
        bins = ClaheNewBins(o.clahe, current.size());
        try {
          streamed = DeconvolveRows(o.deconvolution, current, psf.kernel,
                                    [&](int y, const float* row) { bin_row(row, y); });
        } catch (const Error&) {
          streamed = false;  // non-finite values: the general path below
        }
      }
      if (!streamed) {
        bins.release();
        current = Deconvolve(o.deconvolution, current, psf.kernel);
      }
      r->steps.push_back("deblur: " + DeconvolutionMethodName(o.deconvolution.method) +
                         ", PSF radius " + std::to_string(psf.radius_px));
    }
  } else {
    r->steps.push_back("deblur: skipped (off)");
  }
  if (bins.empty()) r->deblurred = current;

  ClaheStats stats;
  cv::Mat out;
  if (!bins.empty()) {
    out = ClaheFromBins(clahe, bins, &stats);  // in [0, 1]
  } else if (o.contrast && channels == 1) {
    // CLAHE clamps while binning, so the clamped copy is not needed; its output is in [0, 1].
    // Non-finite values (ClampUnit turns NaN into 0) take the general path below.
    bins = ClaheNewBins(clahe, current.size());
    try {
      for (int y = 0; y < current.rows; ++y) bin_row(current.ptr<float>(y), y);
      out = ClaheFromBins(clahe, bins, &stats);
    } catch (const Error&) {
      out.release();
    }
  }
  if (out.empty()) {
    out = current.clone();
    ClampUnit(out);
    if (o.contrast && coded) {
      const int n = out.cols * out.channels();
      for (int y = 0; y < out.rows; ++y)
        ClaheEncodeRow(out.ptr<float>(y), out.ptr<float>(y), n, coding);
    }
    if (o.contrast) out = Clahe(clahe, out, &stats);
    ClampUnit(out);
  }
  if (o.contrast) ClaheDecodeImage(out, coding);
  ContrastStepLog(o, clahe, stats, r);
  return out;
}

ClaheOptions StepClaheOptions(const FullOptions& o, CameraEncoding encoding) {
  ClaheOptions clahe = o.clahe;
  clahe.keep_mean = o.clahe_target_mean;
  // The floor is a linear mean (middle grey); in the coded domain the kept means are of codes.
  clahe.min_mean = ClaheEncodeValue(o.clahe_min_mean, encoding);
  return clahe;
}

}  // namespace paper_internal

using paper_internal::Fail;

// ---------------------------------------------------------------------------------------------

bool FullOptions::Check(std::string* why) const {
  if (denoise_radius < 1 || denoise_radius > 1000)
    return Fail(why, "denoise_radius must be in [1, 1000]");
  if (!std::isfinite(denoise_eps) || denoise_eps <= 0) return Fail(why, "denoise_eps must be > 0");
  if (light_scaling != "blind" && light_scaling != "range" && light_scaling != "physical") {
    return Fail(
        why, "light_scaling must be 'blind', 'range' or 'physical', got '" + light_scaling + "'");
  }
  if (!std::isfinite(denoise_noise_factor) || denoise_noise_factor < 0 ||
      denoise_noise_factor > 100) {
    return Fail(why, "denoise_noise_factor must be in [0, 100]");
  }
  if (!std::isfinite(light_scale_percentile) || light_scale_percentile <= 0 ||
      light_scale_percentile > 50) {
    return Fail(why, "light_scale_percentile must be in (0, 50]");
  }
  if (!std::isfinite(light_scale_support) || light_scale_support <= 0 || light_scale_support >= 1) {
    return Fail(why, "light_scale_support must be in (0, 1)");
  }
  if (!std::isfinite(keep_detail) || keep_detail < 0 || keep_detail > 10) {
    return Fail(why, "keep_detail must be in [0, 10]");
  }
  if (!std::isfinite(exposure_percentile) || exposure_percentile < 0 || exposure_percentile > 100) {
    return Fail(why, "exposure_percentile must be in [0, 100]");
  }
  if (light_subsample < 1 || light_subsample > 64)
    return Fail(why, "light_subsample must be in [1, 64]");
  if (!std::isfinite(clahe_min_mean) || clahe_min_mean < 0 || clahe_min_mean > 0.6) {
    return Fail(why, "clahe_min_mean must be in [0, 0.6]");
  }
  if (!std::isfinite(beta_per_m) || beta_per_m < 0 || beta_per_m > 10) {
    return Fail(why, "beta_per_m must be in [0, 10]");
  }
  if (beta_source != "auto" && beta_source != "fixed") {
    return Fail(why, "beta_source must be 'auto' or 'fixed', got '" + beta_source + "'");
  }
  if (!std::isfinite(t_min) || t_min <= 0 || t_min > 1) return Fail(why, "t_min must be in (0, 1]");
  if (plane != "auto" && plane != "dvl" && plane != "depth" && plane != "scene" &&
      plane != "frontal") {
    return Fail(why, "plane must be auto, dvl, depth, scene or frontal, got '" + plane + "'");
  }
  if (!std::isfinite(frontal_distance_m) || frontal_distance_m <= 0 || frontal_distance_m > 1000) {
    return Fail(why, "frontal_distance_m must be in (0, 1000]");
  }
  if (!std::isfinite(max_range_m) || max_range_m <= 0 || max_range_m > 1e4) {
    return Fail(why, "max_range_m must be in (0, 1e4]");
  }
  PsfOptions psf;
  psf.optical_thickness = psf_optical_thickness;
  psf.forward_scatter = psf_forward_scatter;
  std::string sub;
  if (!psf.Check(&sub)) return Fail(why, "psf: " + sub);
  if (!deconvolution.Check(&sub)) return Fail(why, "deconvolution: " + sub);
  if (!clahe.Check(&sub)) return Fail(why, "clahe: " + sub);
  return true;
}

}  // namespace turbid
