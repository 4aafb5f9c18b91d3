// `full` (§III-A): the pipeline over the steps of full_steps.cc, full_light.cc and, for colour
// images when nobody inspects the steps, the streamed path of full_rows.cc.
#include "enhancer/paper/full.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>

#include "enhancer/blocks/linear_upsample.h"
#include "enhancer/method.h"
#include "enhancer/paper/full_internal.h"

namespace turbid {
namespace {

using paper_internal::DeblurAndContrast;
using paper_internal::DehazeRows;
using paper_internal::DenoiseStep;
using paper_internal::EstimateNoiseSigma;
using paper_internal::ExposureStep;
using paper_internal::FormatNumber;
using paper_internal::FullColorStreamed;
using paper_internal::LightStep;
using paper_internal::ResolveCamera;
using paper_internal::ResolveLightsAndBeta;
using paper_internal::ResolvePlane;
using paper_internal::TransmissionStep;

// Steps 1-5 of `full` on whole images after the geometry (FullEnhanceImpl's; every channel
// count, and colour images whose steps are inspected).
cv::Mat FullWholeImage(const FullOptions& o, const cv::Mat& image, const IrradianceOptions& lights,
                       const CameraIntrinsics& camera, const std::vector<double>& beta,
                       bool any_beta, bool keep_steps, FullResult* r) {
  cv::Mat current = DenoiseStep(o, image, r);
  r->denoised = current;
  // The layer the denoising removes (noise and texture finer than its epsilon), taken before the
  // dehazing may reuse the denoised buffer.
  cv::Mat detail;
  if (o.keep_detail > 0 && o.denoise) cv::subtract(image, current, detail);
  const cv::Mat e_l = LightStep(o, lights, camera, beta, current, r);
  r->light = e_l;

  if (o.dehaze && any_beta) {
    // In place over the denoised image when nobody inspects it (it is our own buffer then).
    cv::Mat dehazed = !keep_steps && o.denoise ? current : cv::Mat(current.size(), current.type());
    DehazeRows(current, e_l, r->transmission, dehazed);
    current = dehazed;
    std::string values;
    for (double b : r->beta_per_m) values += (values.empty() ? "" : "/") + FormatNumber(b);
    r->steps.push_back("dehaze: beta " + values + " 1/m (" + r->beta_source +
                       "), t >= " + FormatNumber(o.t_min));
    ExposureStep(o, current, r);
  } else {
    r->steps.push_back(o.dehaze ? "dehaze: skipped (beta 0)" : "dehaze: skipped (off)");
  }
  r->dehazed = current;
  if (!detail.empty()) {
    // Added back at its input amplitude, not divided by t: noise is not amplified, and texture
    // visible in the input stays visible (a structure-texture split: only the structure layer is
    // dehazed). In place unless r->dehazed is inspected; `detail` is ours either way.
    if (keep_steps || current.data == image.data) {
      cv::scaleAdd(detail, o.keep_detail, current, detail);
      current = detail;
    } else {
      cv::scaleAdd(detail, o.keep_detail, current, current);
    }
    r->steps.push_back("detail: the denoising residual added back x" + FormatNumber(o.keep_detail));
  }
  return DeblurAndContrast(o, current, keep_steps, r);
}

// The full pipeline. `keep_steps`: fill every inspection-only field of FullResult (range_m);
// FullEnhance passes false and saves the full-size work they cost.
FullResult FullEnhanceImpl(const FullOptions& o, const cv::Mat& image, const Scene* scene,
                           const RenderRecord* sidecar, bool keep_steps) {
  ThrowIfInvalid(o, "full");
  FullResult r;
  const int channels = image.channels();
  // The streamed colour path with adaptive denoising reads the input once for the finiteness
  // check and the noise estimate: every value has a nonzero weight in some |I * N| term of the
  // estimate (3 x 3 and larger), so a non-finite value makes the sum non-finite; only then (or
  // when finite values overflow it) is the input scanned, to name the row as before.
  const bool streamed = !keep_steps && image.channels() == 3;
  double noise_sigma = 0.0;
  const bool sigma_known =
      streamed && o.denoise && o.denoise_adaptive && image.rows >= 3 && image.cols >= 3;
  if (sigma_known) {
    ValidateEnhanceImageLayout(image, "full");
    noise_sigma = EstimateNoiseSigma(image);
    if (!std::isfinite(noise_sigma)) ValidateEnhanceImage(image, "full");
  } else {
    ValidateEnhanceImage(image, "full");
  }

  IrradianceOptions lights;
  std::vector<double> beta;
  enhancer_internal::LinearUpsampler t_rows;  // the streamed path's t, when one beta
  ResolveLightsAndBeta(o, sidecar, channels, &lights, &beta, &r);
  paper_internal::ResolveClaheEncoding(o, sidecar, &r);
  const bool any_beta = std::any_of(beta.begin(), beta.end(), [](double b) { return b > 0; });
  const bool need_light = o.light && !lights.lights.empty();
  const bool need_geometry = need_light || (o.dehaze && any_beta);
  CameraIntrinsics camera;
  if (need_geometry) {
    camera = ResolveCamera(image, scene, sidecar, &r.steps);
    std::string source;
    r.plane = ResolvePlane(o, scene, camera, &source);
    r.plane_source = source;
    r.steps.push_back("plane: from " + source);
    // The streamed path reads t one row at a time (with one beta): no full-size map.
    if (any_beta) {
      TransmissionStep(o, camera, beta, image.size(), keep_steps, &r, streamed ? &t_rows : nullptr);
    }
  }
  if (streamed) {
    r.image = FullColorStreamed(o, image, lights, camera, beta, any_beta,
                                sigma_known ? &noise_sigma : nullptr, t_rows, &r);
    return r;
  }
  r.image = FullWholeImage(o, image, lights, camera, beta, any_beta, keep_steps, &r);
  return r;
}

}  // namespace

FullResult FullEnhanceDetailed(const FullOptions& o, const cv::Mat& image, const Scene* scene,
                               const RenderRecord* sidecar) {
  return FullEnhanceImpl(o, image, scene, sidecar, true);
}

cv::Mat FullEnhance(const FullOptions& o, const cv::Mat& image, const Scene* scene,
                    const RenderRecord* sidecar) {
  return FullEnhanceImpl(o, image, scene, sidecar, false).image;
}

void ReportFullSteps(const FullResult& r, StepSink& sink) {
  const auto image = [&](const std::string& name, const cv::Mat& m, bool comparable) {
    if (!m.empty()) sink.Image(name, m, comparable);
  };
  image("01_denoised", r.denoised, true);
  image("02_light", r.light, false);
  if (!r.light.empty() && !r.transmission.empty()) {
    // The light step's effect: I_de - (1 - t) E_L, the veil removed before dividing by t.
    cv::Mat t = r.transmission;
    if (t.channels() != r.light.channels()) {
      std::vector<cv::Mat> planes(r.light.channels(), t);
      cv::merge(planes, t);
    }
    image("02_veil_removed", r.denoised - (1.0 - t).mul(r.light), true);
  }
  image("03_range_m", r.range_m, false);
  image("03_transmission", r.transmission, false);
  image("04_dehazed", r.dehazed, true);
  image("05_deblurred", r.deblurred, true);
  sink.Note("steps", r.steps);
  sink.Note("light_scale", r.light_scale);
  sink.Note("exposure_scale", r.exposure_scale);
  sink.Note("clahe_alpha", r.clahe_alpha);
  if (r.plane) {
    sink.Note("plane", {{"normal", {r.plane->normal[0], r.plane->normal[1], r.plane->normal[2]}},
                        {"offset_m", r.plane->offset_m},
                        {"source", r.plane_source}});
  }
}

}  // namespace turbid
