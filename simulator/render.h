// The renderer: composes the forward model of the paper's eq. 2 (SPEC "The forward model"):
//   J(x) = (E_A + E_L(x)) rho(x)
//   I(x) = [J * h_psf](x) t(x) + (1 - t(x)) E_L(x) [+ (1 - t(x)) B_inf] + S(x) + n(x)
//   t_c(x) = exp(-beta_c r(x)),  r = range along the viewing ray
// with S marine snow and n Poisson-Gaussian sensor noise (noise.h), then the camera's clipping and
// quantisation. Pixels with NaN depth are open water at infinite range: t = 0, E_L = 0, so they
// show only the backscatter (when enabled), marine snow and noise. docs/model.md is the reference.
#pragma once

#include <memory>
#include <opencv2/core.hpp>

#include "scenes/scene.h"
#include "simulator/render_options.h"
#include "simulator/render_record.h"

namespace turbid {

struct RenderResult {
  cv::Mat image;  // degraded I, float32 linear in [0, 1] (decoded codes when bit_depth is 8 or 16)
  cv::Mat lit;    // J = (E_A + E_L) rho: lit, unattenuated, unblurred ground truth (float32)
  cv::Mat transmission;  // optional maps (empty unless selected in options.maps)
  cv::Mat light;
  cv::Mat veil;
  cv::Mat psf;
  cv::Mat noise;
  // What the render used and derived: every parameter, seed, derived values, input hashes,
  // version, plan. Its ToJson() is the sidecar file (OUT.json); methods read it as it is.
  RenderRecord sidecar;
  RenderPlan plan;
};

// One per scene: validates it and computes the range map (and the normals, when the scene has
// none) once; each Render computes everything else in two fused passes over rows (render.cc).
// Render is const and thread-safe (the normals cache is locked). The returned image and J come
// from a recycling allocator (simulator/image_pool.h): repeated renders reuse freed buffers.
class Renderer {
 public:
  // Validates and copies the scene (throws Error when it is inconsistent).
  explicit Renderer(const Scene& scene);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Throws Error when options fail Check.
  RenderResult Render(const RenderOptions& options) const;
  // The plan without rendering (what --explain prints).
  RenderPlan Plan(const RenderOptions& options) const;
  const Scene& scene() const;
  const cv::Mat& range_m() const;  // CV_32FC1, NaN where depth is invalid

 private:
  struct Cache;
  const cv::Mat& Normals() const;  // the scene's, else computed once from its depth
  Scene scene_;
  cv::Mat range_m_;
  std::unique_ptr<Cache> cache_;
};

// One-shot convenience: Renderer(scene).Render(options).
RenderResult Render(const RenderOptions& options, const Scene& scene);

}  // namespace turbid
