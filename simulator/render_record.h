// The record of one render: what the renderer used and derived, typed. The renderer fills it
// (RenderResult::sidecar); the tools add where the render came from and what they wrote (scene
// spec, scale, outputs, generate's item); its ToJson is the sidecar file (OUT.json,
// docs/model.md "JSON options and the sidecar") and FromJson the one reader of sidecars, so
// methods (enhancer/registry.h EnhanceInput) receive this struct, never the JSON.
#pragma once

#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "simulator/render_options.h"

namespace turbid {

struct RenderRecord {
  std::string tool = "turbid render";
  std::string version;  // TURBID_VERSION of the build that rendered

  struct SceneInfo {
    std::string name;
    int width = 0, height = 0, channels = 0;
    // Pinhole intrinsics, pixels (0 when a sidecar does not give them).
    double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
    std::map<std::string, std::string> input_hashes;  // input file -> sha256
    // Set by the tools: the spec the scene was loaded from and the built-in scale.
    std::optional<std::string> spec;
    std::optional<double> builtin_scale;
  } scene;

  uint64_t seed = 0;
  // Every option used, presets resolved (RenderOptionsToJson's form); nullopt when a sidecar has
  // no "options" object.
  std::optional<RenderOptions> options;

  struct Turbidity {  // the turbidity-dependent PSF's levels
    uint64_t levels = 0;
    bool exact = false;
    std::vector<double> thickness;
    std::vector<int> radius_px;
  };
  struct Derived {
    std::string channel_order;  // "BGR" or "gray"
    std::string model;          // ImageModelName; empty in sidecars older than the models
    std::vector<double> beta_per_m, ambient;          // image channel order
    std::optional<std::vector<double>> beta_b_per_m;  // model "revised"
    std::optional<std::vector<double>> backscatter;   // B_inf when the term is on
    std::vector<double> lambertian_order_m;           // one per light
    double range_min_m = 0.0, range_max_m = 0.0;      // +inf / 0 without valid depth
    double valid_depth_fraction = 0.0;
    struct Psf {
      double p = 0.0, sigma_px = 0.0, scale_a_px = 0.0;
      int radius_px = 0;
      double tail_mass_outside = 0.0;
      bool is_delta = false, separable = false;
      std::optional<Turbidity> turbidity;
    } psf;
    int snow_particles = 0, snow_visible = 0;
  } derived;

  RenderPlan plan;
  std::string encoding;  // how the image file's values are coded; empty in older sidecars

  // Set by the tools: the files written (role -> file name, relative to the sidecar), the PSF
  // map's peak (its PNG is scaled to peak 1), and generate's item.
  std::map<std::string, std::string> outputs;
  std::optional<double> psf_peak;
  struct Item {
    int64_t index = 0;
    std::string id;
  };
  std::optional<Item> item;

  // The sidecar JSON: every field above (those the tools set only when set).
  nlohmann::json ToJson() const;
  // Reads a sidecar strictly: unknown keys and wrong types throw Error "<source>: sidecar:
  // <key path>: <problem>"; missing keys keep the defaults above, so every sidecar turbid wrote
  // before reads. "options" goes through RenderOptionsFromJson.
  static RenderRecord FromJson(const nlohmann::json& json, const std::string& source);
};

}  // namespace turbid
