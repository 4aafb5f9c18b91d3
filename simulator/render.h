// The renderer: composes the forward model of the paper's eq. 2 (SPEC "The forward model"):
//   J(x) = (E_A + E_L(x)) rho(x)
//   I(x) = [J * h_psf](x) t(x) + (1 - t(x)) E_L(x) [+ (1 - t(x)) B_inf] + S(x) + n(x)
//   t_c(x) = exp(-beta_c r(x)),  r = range along the viewing ray
// with S marine snow and n Poisson-Gaussian sensor noise (noise.h), then the camera's clipping and
// quantisation. Pixels with NaN depth are open water at infinite range: t = 0, E_L = 0, so they
// show only the backscatter (when enabled), marine snow and noise. docs/model.md is the reference.
#pragma once

#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "scenes/camera_encoding.h"
#include "scenes/scene.h"
#include "simulator/light.h"
#include "simulator/models.h"
#include "simulator/noise.h"
#include "simulator/psf.h"
#include "simulator/water.h"

namespace turbid {

struct CameraOutputOptions {
  // 8 or 16: values clipped to [0, 1] and quantised to 2^bits - 1 codes of `encoding` (the
  // in-memory image stays linear: it holds the decoded codes, which is what reading the PNG back
  // with that encoding returns); 32: float32, clipped to [0, 1], not quantised (EXR), linear.
  int bit_depth = 8;
  // Transfer curve applied before quantisation (scenes/camera_encoding.h): sRGB by default, as a
  // camera writes integer images; ignored for bit_depth 32.
  CameraEncoding encoding = CameraEncoding::kSrgb;
  // The encoding of the written file: `encoding` for integer outputs, linear for float.
  CameraEncoding FileEncoding() const {
    return bit_depth == 32 ? CameraEncoding::kLinear : encoding;
  }
  bool Check(std::string* why) const;
};

// Optional outputs besides the image and J.
struct MapSelection {
  bool transmission = false;  // t (channels of the image)
  bool light = false;         // E_L
  bool veil = false;          // (1 - t) E_L (+ (1 - t) B_inf)
  bool psf = false;           // the PSF kernel
  bool noise = false;         // snow + sensor noise layer (noisy - clean before clipping)
  // "transmission,light,veil,psf,noise" (any subset, comma-separated) -> selection; Error
  // otherwise.
  static MapSelection FromList(const std::string& list);
};

struct RenderOptions {
  // Image-formation model (simulator/models.h, docs/model.md "Models"): the paper's eq. 2 by
  // default; "revised" (Akkaynak & Treibitz 2018) and "uwcnn" (Li, Anwar & Porikli 2020) read
  // their own sections below as well.
  ImageModel model = ImageModel::kPaper;
  RevisedOptions revised;
  UwcnnOptions uwcnn;
  WaterOptions water;
  IrradianceOptions light;
  PsfOptions psf;
  SnowOptions snow;
  SensorNoiseOptions sensor;
  CameraOutputOptions camera;
  uint64_t seed = 0;  // seeds snow and sensor noise (counter-based: any thread count, same bytes)
  MapSelection maps;  // not part of the JSON options (a CLI / caller choice)
  // Not part of the JSON options either: write RenderResult::image's colour channels in R, G, B
  // order instead of turbid's B, G, R (the Python package hands the buffer to NumPy as it is). The
  // swap happens in the last pass over each row, so the values are the same bytes reordered.
  bool rgb_image = false;

  bool Check(std::string* why) const;
};

// JSON <-> options. The JSON object mirrors the struct: {"water": {...}, "light": {"lights": [...],
// "incidence": "lambertian", ...}, "psf": {...}, "snow": {...}, "sensor": {...}, "camera":
// {"bit_depth": 8}, "seed": 0}. Missing keys keep the in-class defaults; unknown keys, wrong types
// and values failing Check throw Error naming the key path (e.g. "psf.forward_scatter").
RenderOptions RenderOptionsFromJson(const nlohmann::json& json);
// Every field, with the values in `options` (the sidecar's "options" object); a Jerlov water
// type is written with its resolved beta values.
nlohmann::json RenderOptionsToJson(const RenderOptions& options);

// What the renderer did and what it skipped, for --explain and the sidecar.
struct RenderPlan {
  std::vector<std::string> steps;    // e.g. "transmission: exp(-beta r), 3 channels"
  std::vector<std::string> skipped;  // e.g. "psf: kernel is a delta at this pixel scale"
  std::string ToText() const;
  nlohmann::json ToJson() const;
};

struct RenderResult {
  cv::Mat image;  // degraded I, float32 linear in [0, 1] (decoded codes when bit_depth is 8 or 16)
  cv::Mat lit;           // J = (E_A + E_L) rho: lit, unattenuated, unblurred ground truth (float32)
  cv::Mat transmission;  // optional maps (empty unless selected in options.maps)
  cv::Mat light;
  cv::Mat veil;
  cv::Mat psf;
  cv::Mat noise;
  nlohmann::json
      sidecar;  // every parameter used, seed, derived values, input hashes, version, plan
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
  Scene scene_;
  cv::Mat range_m_;
  std::unique_ptr<Cache> cache_;
};

// One-shot convenience: Renderer(scene).Render(options).
RenderResult Render(const RenderOptions& options, const Scene& scene);

}  // namespace turbid
