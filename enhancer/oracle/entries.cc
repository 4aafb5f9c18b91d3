// The oracles' registry entries and parameter tables (enhancer/params.h); the methods are in
// oracle.cc.
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/fields.h"
#include "enhancer/method.h"
#include "enhancer/oracle/oracle.h"
#include "enhancer/params.h"

namespace turbid {

namespace {

constexpr const char* kInputs =
    "sidecar: water (beta, E_A, B_inf), LED lights with their power, PSF, snow and seed, sensor "
    "noise and bit depth; scene: depth (range, normals), camera";

// The parameters, each declared once (enhancer/params.h).
const Fields<OracleExactOptions>& OracleExactFields() {
  using O = OracleExactOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Member("target", &O::target, "clean: recover rho (ground truth) | lit: recover J")
          .Member("remove_snow", &O::remove_snow,
                  "re-render the marine snow from the seed and subtract")
          .Member("min_transmission", &O::min_transmission, "floor on t when dividing, (0, 1]")
          .Member("min_irradiance", &O::min_irradiance, "floor on E_A + E_L when dividing, > 0")
          .Member("max_iterations", &O::max_iterations,
                  "range-dependent PSF: fixed-point iterations, [1, 1000]")
          .Member("tolerance", &O::tolerance, "range-dependent PSF: residual to stop at, [0, 1]");
  return fields;
}

const Fields<OracleOptions>& OracleFields() {
  using O = OracleOptions;
  constexpr int kRadius = static_cast<int>(SizeBound::kRadius);
  static const Fields<O> fields =
      Fields<O>()
          .Member("target", &O::target, "clean: recover rho (ground truth) | lit: recover J")
          .Member("remove_snow", &O::remove_snow,
                  "re-render the marine snow from the seed and subtract")
          .Member("mask_transmission", &O::mask_transmission,
                  "pixels with t below this are masked (prior mean), (0, 1)")
          .Member("coarse_radius", &O::coarse_radius, "prior's coarse window radius, px")
          .Tag(kRadius)
          .Member("middle_radius", &O::middle_radius, "prior's middle window radius, px (< coarse)")
          .Tag(kRadius)
          .Member("pixel_radius", &O::pixel_radius, "window of the per-pixel prior variance, px")
          .Tag(kRadius)
          .Member("deblur", &O::deblur,
                  "Wiener deconvolution of the true PSF after the MMSE estimate");
  return fields;
}

MethodEntry OracleExactEntry() {
  MethodEntry e;
  e.info.name = "oracle_exact";
  e.info.summary = "algebraic inverse of the simulator with every true parameter (no noise model)";
  e.info.source = "turbid's forward model (docs/model.md): paper eq. 2, or the render's own model";
  e.info.needs_geometry = true;
  e.info.needs_sidecar = true;
  e.info.privileged = true;
  e.info.inputs = kInputs;
  e.info.params = MethodParamsOf(OracleExactFields());
  e.run = [](const nlohmann::json& params, const EnhanceInput& in) {
    const OracleExactOptions o = ReadMethodParams("oracle_exact", params, OracleExactFields());
    if (in.scene == nullptr) throw Error("oracle_exact: needs the scene (--scene)");
    if (in.sidecar == nullptr) throw Error("oracle_exact: needs the render's sidecar (--sidecar)");
    return OracleExactEnhance(o, in.image, *in.scene, *in.sidecar).image;
  };
  return e;
}

MethodEntry OracleEntry() {
  MethodEntry e;
  e.info.name = "oracle";
  e.info.summary =
      "oracle-parameter LMMSE reference: the simulator inverted with every true parameter and the "
      "noise model";
  e.info.source =
      "turbid's forward model (docs/model.md); adaptive Wiener (Lee 1980, Kuan et al. 1985) with "
      "the Poisson-Gaussian variance (Foi et al. 2008); Wiener deconvolution";
  e.info.needs_geometry = true;
  e.info.needs_sidecar = true;
  e.info.privileged = true;
  e.info.inputs = kInputs;
  e.info.params = MethodParamsOf(OracleFields());
  e.run = [](const nlohmann::json& params, const EnhanceInput& in) {
    const OracleOptions o = ReadMethodParams("oracle", params, OracleFields());
    if (in.scene == nullptr) throw Error("oracle: needs the scene (--scene)");
    if (in.sidecar == nullptr) throw Error("oracle: needs the render's sidecar (--sidecar)");
    return OracleEnhance(o, in.image, *in.scene, *in.sidecar).image;
  };
  return e;
}

}  // namespace

std::vector<MethodEntry> OracleMethodEntries() { return {OracleEntry(), OracleExactEntry()}; }

}  // namespace turbid
