// The renderer's decisions for one set of options and one scene: resolved presets, per-channel
// values in image order, which terms run and the plan that says so. Shared by Renderer::Plan and
// Renderer::Render (simulator/render.cc); internal to the simulator.
#pragma once

#include <string>
#include <vector>

#include "scenes/scene.h"
#include "simulator/iop.h"
#include "simulator/models.h"
#include "simulator/psf.h"
#include "simulator/render_options.h"
#include "simulator/veil.h"
#include "simulator/water.h"

namespace turbid {

// Decisions shared by Plan and Render.
struct Decisions {
  RenderOptions used;  // the options with their presets resolved (the one ResolvePresets)
  WaterOptions water;
  std::vector<double> beta, ambient, backscatter;
  bool backscatter_on = false;  // the (1 - t) B_inf term
  // model "revised": beta^B (image channel order) and, when range-dependent, Sea-thru's a, b, c, d.
  bool revised = false, sea_thru = false;
  bool lights_used = true;  // false for uwcnn (its recipe has no illumination)
  // model uwcnn: the recipe on sRGB codes (rho encoded in pass A, I decoded after composing), and
  // for gray images the transmission sum_c w_c exp(-beta_c r) (simulator/models.h).
  bool uwcnn_encoded = false, uwcnn_gray = false;
  UwcnnConstants uwcnn;
  // model revised with water.iop: t_D(r) and exp(-beta^B(r) r) tabulated per image channel.
  bool iop_tables = false;
  std::vector<RangeTable> direct_table, backscatter_table;
  std::vector<double> beta_b, sea_a, sea_b, sea_c, sea_d;
  bool any_light = false;
  // veil "single_scatter" with lights on and beta > 0: the veil is simulator/veil.h's V, not
  // (1 - t) E_L; veil_water holds its c, b (image channel order) and phase function.
  bool single_scatter = false;
  VeilWater veil_water;
  bool zero_beta = false;
  bool uniform_range = false;
  bool blur = false;
  Psf psf;
  // psf.model "small_angle": the water's c, b (image channel order) and phase function.
  VeilWater psf_water;
  RenderPlan plan;
};

// Throws Error when options fail Check. min_range / max_range: the valid ranges of the scene.
Decisions Decide(const RenderOptions& options, const Scene& scene, double min_range,
                 double max_range);

}  // namespace turbid
