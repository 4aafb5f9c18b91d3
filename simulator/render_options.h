// Render options (the JSON every render reads, docs/model.md "JSON options and the sidecar"), the
// presets they name and the render plan. The renderer is simulator/render.h; the record a render
// leaves (its sidecar) simulator/render_record.h.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/fields.h"
#include "scenes/camera_encoding.h"
#include "simulator/light.h"
#include "simulator/models.h"
#include "simulator/noise.h"
#include "simulator/psf.h"
#include "simulator/veil.h"
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
  bool veil = false;          // the veil added: (1 - t) E_L or V (+ (1 - t) B_inf)
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
  // The lights' veil (simulator/veil.h, docs/model.md "The veil"): "paper" = eq. 2's
  // (1 - t) E_L (default); "single_scatter" = the lamps' single-scattered radiance integrated
  // along each view ray with the water's b, c and phase function.
  VeilModel veil = VeilModel::kPaper;
  // The ambient backscatter B_inf (simulator/water.h): "typed" = water.backscatter_* (default);
  // "derived" = omega E_A H from the ambient light, b, c and the phase function, and the
  // (1 - t) B_inf term on.
  AmbientModel ambient = AmbientModel::kTyped;
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
// and values failing Check throw Error "render options: ..." naming the key path (e.g.
// 'psf.forward_scatter').
RenderOptions RenderOptionsFromJson(const nlohmann::json& json);
// Every field, with the values in `options` (the sidecar's "options" object); a Jerlov water
// type is written with its resolved beta values.
nlohmann::json RenderOptionsToJson(const RenderOptions& options);
// The presets of `options` resolved, water.type (ResolveWater) and uwcnn.type (ResolveUwcnn), the
// one place both are applied; a section failing Check is left as it is.
RenderOptions ResolvePresets(const RenderOptions& options);
// RenderOptionsToJson of options whose presets are already resolved (ResolvePresets).
nlohmann::json ResolvedRenderOptionsToJson(const RenderOptions& resolved);

// The field tables behind RenderOptionsFromJson / ToJson (each key declared once, in
// render_options.cc): one per section, "" for the top level and "light.lights[]" for one light.
// For help, docs and the tests that every key reads back.
struct RenderSection {
  std::string name;
  std::vector<FieldInfo> fields;  // key, type, default (RenderOptions{}'s), doc
};
const std::vector<RenderSection>& RenderSections();

// What the renderer did and what it skipped, for --explain and the sidecar.
struct RenderPlan {
  std::vector<std::string> steps;    // e.g. "transmission: exp(-beta r), 3 channels"
  std::vector<std::string> skipped;  // e.g. "psf: kernel is a delta at this pixel scale"
  std::string ToText() const;
  nlohmann::json ToJson() const;
};

}  // namespace turbid
