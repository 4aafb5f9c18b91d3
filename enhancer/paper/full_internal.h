// Internal to enhancer/paper/: the steps of `full` shared by the whole-image pipeline (full.cc,
// full_steps.cc, full_light.cc) and the streamed colour path (full_rows.cc).
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "enhancer/blocks/clahe.h"
#include "enhancer/blocks/linear_upsample.h"
#include "enhancer/paper/full.h"

namespace turbid::paper_internal {

// NaN -> 0, then clamped to [0, 1], in place.
void ClampUnit(cv::Mat& m);
// *why = message; returns false (Check's helper).
bool Fail(std::string* why, const std::string& message);
// %g-style number for the step log (0.7, not 0.700000).
std::string FormatNumber(double v);
// A vector whose resize leaves new elements uninitialised (scratch that is written before it is
// read: no memset of megabytes per call).
template <typename T>
struct UninitializedAllocator : std::allocator<T> {
  template <typename U>
  struct rebind {
    using other = UninitializedAllocator<U>;
  };
  UninitializedAllocator() = default;
  template <typename U>
  UninitializedAllocator(const UninitializedAllocator<U>&) noexcept {}
  template <typename U>
  void construct(U* p) noexcept {
    ::new (static_cast<void*>(p)) U;
  }
  template <typename U, typename... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};
template <typename T>
using ScratchVector = std::vector<T, UninitializedAllocator<T>>;

// The value at `percentile` (%) of `values` (no NaN), by rank floor(p/100 (n - 1)).
double PercentileOf(std::vector<float>& values, double percentile);
double PercentileOf(ScratchVector<float>& values, double percentile);

// Geometry (full_steps.cc): the camera for an image (scene's, sidecar's, else a pinhole), the
// dehazing plane, a camera at 1/subsample, the plane's z-depth capped at max_range_m, a bilinear
// upsampling to `size` (the map itself when already that size).
CameraIntrinsics ResolveCamera(const cv::Mat& image, const Scene* scene,
                               const RenderRecord* sidecar, std::vector<std::string>* steps);
Plane ResolvePlane(const FullOptions& o, const Scene* scene, const CameraIntrinsics& camera,
                   std::string* source);
CameraIntrinsics Downscaled(const CameraIntrinsics& c, int subsample);
cv::Mat PlaneDepth(const Plane& plane, const CameraIntrinsics& camera, double max_range_m);
cv::Mat Upsample(const cv::Mat& small, cv::Size size);

// Immerkaer's noise standard deviation of a float image (all channels).
double EstimateNoiseSigma(const cv::Mat& image);

// Step 1 (eq. 4). `noise_sigma`: the image's EstimateNoiseSigma when already known (else null);
// `t_rows`: t as rows (the streamed colour path; r->transmission empty then), or null.
cv::Mat DenoiseStep(const FullOptions& o, const cv::Mat& image, FullResult* r,
                    const double* noise_sigma = nullptr,
                    const enhancer_internal::LinearUpsampler* t_rows = nullptr);
// The LED specification and beta (one value when every channel has the same).
void ResolveLightsAndBeta(const FullOptions& o, const RenderRecord* sidecar, int channels,
                          IrradianceOptions* lights, std::vector<double>* beta, FullResult* r);
// t = exp(-beta r) on the plane into r->transmission (r->range_m when keep_steps), or *t_rows.
void TransmissionStep(const FullOptions& o, const CameraIntrinsics& camera,
                      const std::vector<double>& beta, cv::Size size, bool keep_steps,
                      FullResult* r, enhancer_internal::LinearUpsampler* t_rows = nullptr);

// Step 2 (eq. 5): E_L on the plane, scaled into image units blind, by the range fit, or as is.
// Returned as `map` times `scale` per channel (scale empty: the map as is); the map has one
// channel per distinct beta except with range scaling (image channels, scaled). The streamed
// colour path may get a one-channel map as `rows` instead (`map` empty).
struct LightEstimate {
  cv::Mat map;
  enhancer_internal::LinearUpsampler rows;
  std::vector<double> scale;
  bool empty() const { return map.empty() && rows.empty(); }
};
// full_light.cc. `t_rows`: the streamed colour path's t (r->transmission empty then).
LightEstimate LightStepUnscaled(const FullOptions& o, const IrradianceOptions& lights,
                                const CameraIntrinsics& camera, const std::vector<double>& beta,
                                const cv::Mat& denoised, FullResult* r,
                                const enhancer_internal::LinearUpsampler* t_rows = nullptr);
// LightStepUnscaled's E_L as one image with the image's channels.
cv::Mat LightStep(const FullOptions& o, const IrradianceOptions& lights,
                  const CameraIntrinsics& camera, const std::vector<double>& beta,
                  const cv::Mat& denoised, FullResult* r);

// Step 3 (eq. 6) into `dehazed` (may be `current`); the exposure scale of J_plane.
void DehazeRows(const cv::Mat& current, const cv::Mat& e_l, const cv::Mat& tm, cv::Mat& dehazed);
void ExposureStep(const FullOptions& o, cv::Mat& dehazed, FullResult* r);
// The contrast step's log line.
void ContrastStepLog(const FullOptions& o, const ClaheOptions& clahe, const ClaheStats& stats,
                     FullResult* r);
// The CLAHE domain (full_coding.cc): the curve step 5 equalises through (r->clahe_encoding and
// its source) from clahe_domain and the sidecar's camera; a row clipped to [0, 1] (NaN -> 0) and
// coded with it (in == out allowed); an equalised image (values in [0, 1]) or one row decoded in
// place (a no-op for kLinear); one linear value coded (clamped). With AVX2 and FMA the sRGB
// curve is a polynomial (within 1e-5 relative of the double curve, ~1e-6 measured), otherwise
// tables.
void ResolveClaheEncoding(const FullOptions& o, const RenderRecord* sidecar, FullResult* r);
void ClaheEncodeRow(const float* in, float* out, int n, CameraEncoding encoding);
void ClaheDecodeImage(cv::Mat& image, CameraEncoding encoding);
void ClaheDecodeRow(float* row, int n, CameraEncoding encoding);
double ClaheEncodeValue(double v, CameraEncoding encoding);
// The CLAHE options of step 5: o.clahe with the brightness-keeping target, its floor coded.
ClaheOptions StepClaheOptions(const FullOptions& o, CameraEncoding encoding);

// Steps 4 (eq. 7) and 5 (CLAHE).
cv::Mat DeblurAndContrast(const FullOptions& o, cv::Mat current, bool keep_steps, FullResult* r);

// Steps 1-5 of `full` for a three-channel image after the geometry, streamed (full_rows.cc).
cv::Mat FullColorStreamed(const FullOptions& o, const cv::Mat& image,
                          const IrradianceOptions& lights, const CameraIntrinsics& camera,
                          const std::vector<double>& beta, bool any_beta, const double* noise_sigma,
                          const enhancer_internal::LinearUpsampler& t_rows, FullResult* r);

}  // namespace turbid::paper_internal
