// Registry entries of the baselines: each method's parameters declared once, in a field table
// (enhancer/params.h, core/fields.h) that reads them strictly and lists them with their defaults.
#include "enhancer/baselines/registry.h"

#include <nlohmann/json.hpp>

#include "enhancer/baselines/cap.h"
#include "enhancer/baselines/clahe.h"
#include "enhancer/baselines/common.h"
#include "enhancer/baselines/dcp.h"
#include "enhancer/baselines/fusion.h"
#include "enhancer/baselines/tarel.h"
#include "enhancer/method.h"
#include "enhancer/params.h"

namespace turbid {
namespace {

constexpr int kWindow = static_cast<int>(SizeBound::kWindow);
constexpr int kRadius = static_cast<int>(SizeBound::kRadius);
constexpr int kPerAxis = static_cast<int>(SizeBound::kPerAxis);

// dcp and udcp share their keys; only the prior's name differs in one doc line.
template <typename Options>
Fields<Options> DcpFields(const std::string& prior) {
  return Fields<Options>()
      .Member("patch_size", &DcpOptions::patch_size,
              "side of the square " + prior + " window, pixels, odd >= 1 (He 2011: 15)")
      .Tag(kWindow)
      .Member("omega", &DcpOptions::omega, "fraction of haze removed, (0,1] (He 2011 eq. 12: 0.95)")
      .Member("t0", &DcpOptions::t0,
              "lower bound on transmission in the recovery, (0,1] (He 2011: 0.1)")
      .Member("airlight_fraction", &DcpOptions::airlight_fraction,
              "fraction of brightest dark-channel pixels searched for A, (0,1] (He 2011: 0.001)")
      .Member("refine", &DcpOptions::refine,
              "guided-filter refinement of the transmission (He 2013)")
      .Member("guided_radius", &DcpOptions::guided_radius,
              "guided-filter radius, pixels >= 1 (He 2013: 60)")
      .Tag(kRadius)
      .Member("guided_eps", &DcpOptions::guided_eps,
              "guided-filter epsilon on [0,1] data, > 0 (He 2013: 1e-4)");
}

const Fields<DcpOptions>& DcpTable() {
  static const Fields<DcpOptions> fields = DcpFields<DcpOptions>("dark-channel");
  return fields;
}

const Fields<UdcpOptions>& UdcpTable() {
  static const Fields<UdcpOptions> fields = DcpFields<UdcpOptions>("G-B dark-channel");
  return fields;
}

const Fields<ClaheBaselineOptions>& ClaheTable() {
  using O = ClaheBaselineOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Member("tiles_x", &O::tiles_x, "contextual regions along x, >= 2 (adapthisteq: 8)")
          .Tag(kPerAxis)
          .Member("tiles_y", &O::tiles_y, "contextual regions along y, >= 2 (adapthisteq: 8)")
          .Tag(kPerAxis)
          .Member("clip_limit", &O::clip_limit,
                  "clip limit as a fraction, [0,1] (adapthisteq: 0.01)")
          .Member("bins", &O::bins, "histogram bins, [2, 65536] (adapthisteq: 256)");
  return fields;
}

const Fields<CapOptions>& CapTable() {
  using O = CapOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Member("theta0", &O::theta0, "depth model intercept (Zhu 2015: 0.121779)")
          .Member("theta1", &O::theta1, "depth model HSV-value coefficient (Zhu 2015: 0.959710)")
          .Member("theta2", &O::theta2,
                  "depth model HSV-saturation coefficient (Zhu 2015: -0.780245)")
          .Member("patch_size", &O::patch_size,
                  "minimum-filter side, pixels, odd >= 1 (Zhu 2015: 15)")
          .Tag(kWindow)
          .Member("beta", &O::beta, "scattering coefficient in t = exp(-beta d), > 0 (Zhu 2015: 1)")
          .Member("t_min", &O::t_min, "lower transmission clamp, (0, t_max) (Zhu 2015: 0.05)")
          .Member("t_max", &O::t_max, "upper transmission clamp, (t_min, 1] (Zhu 2015: 1)")
          .Member("airlight_fraction", &O::airlight_fraction,
                  "fraction of farthest pixels searched for A, (0,1] (Zhu 2015: 0.001)")
          .Member("refine", &O::refine, "guided-filter refinement of the depth")
          .Member("guided_radius", &O::guided_radius,
                  "guided-filter radius, pixels >= 1 (Zhu's code: 60x60 window, radius 30)")
          .Tag(kRadius)
          .Member("guided_eps", &O::guided_eps,
                  "guided-filter epsilon on [0,1] data (Zhu's code: 1e-3)");
  return fields;
}

const Fields<TarelOptions>& TarelTable() {
  using O = TarelOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Member("p", &O::p, "fraction of the veil removed, (0,1) (Tarel 2009: 0.95)")
          .Member("sv", &O::sv,
                  "median window side (largest white object), pixels, odd >= 1 (Tarel: 11)")
          .Tag(kWindow)
          .Member("balance", &O::balance,
                  "white balance: < 0 none, 0 global, > 0 local strength (reference code values)")
          .Member("tone_map", &O::tone_map,
                  "final gamma correction and tone mapping (reference code)")
          .Member("gamma_factor", &O::gamma_factor,
                  "extra gamma factor, > 0 (reference code: 1.3)");
  return fields;
}

const Fields<FusionOptions>& FusionTable() {
  using O = FusionOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Member("levels", &O::levels, "Laplacian pyramid levels, >= 1 (capped by the image size)")
          .Member("white_balance", &O::white_balance,
                  "gray-world white balance of input 1 (colour)")
          .Member("max_white_balance_gain", &O::max_white_balance_gain,
                  "largest gray-world gain on one channel, >= 1")
          .Member("exposedness_sigma", &O::exposedness_sigma,
                  "exposedness Gaussian width around 0.5, > 0 (Ancuti 2012: 0.25)")
          .Nested("clahe_", &O::clahe, ClaheTable());
  return fields;
}

// Intermediate steps (EnhanceInput::steps), reported only when asked: the Detailed functions
// return the same image as the plain ones and keep their intermediates.
cv::Mat ReportDcpSteps(const DcpResult& r, StepSink& sink) {
  sink.Image("01_dark_channel", r.dark_channel, false);
  sink.Image("02_raw_transmission", r.raw_transmission, false);
  sink.Image("03_transmission", r.transmission, false);
  sink.Note("airlight", {r.airlight[0], r.airlight[1], r.airlight[2]});
  return r.image;
}

cv::Mat ReportCapSteps(const CapResult& r, StepSink& sink) {
  sink.Image("01_raw_depth", r.raw_depth, false);
  sink.Image("02_depth", r.depth, false);
  sink.Image("03_transmission", r.transmission, false);
  sink.Note("airlight", {r.airlight[0], r.airlight[1], r.airlight[2]});
  return r.image;
}

cv::Mat ReportTarelSteps(const TarelResult& r, StepSink& sink) {
  sink.Image("01_balanced", r.balanced, true);
  sink.Image("02_whiteness", r.whiteness, false);
  sink.Image("03_veil", r.veil, false);
  sink.Image("04_restored", r.restored, true);
  sink.Note("white", {r.white[0], r.white[1], r.white[2]});
  return r.image;
}

cv::Mat ReportFusionSteps(const FusionResult& r, StepSink& sink) {
  for (size_t k = 0; k < r.inputs.size(); ++k) {
    sink.Image("0" + std::to_string(k + 1) + "_input", r.inputs[k], true);
    sink.Image("0" + std::to_string(k + 1) + "_weight", r.weights[k], false);
  }
  return r.image;
}

MethodEntry ClaheEntry() {
  MethodEntry e;
  e.info.name = "clahe";
  e.info.summary = "CLAHE alone, uniform target, on luminance for colour";
  e.info.source = "Zuiderveld, Graphics Gems IV, 1994; MATLAB adapthisteq defaults";
  e.info.params = MethodParamsOf(ClaheTable());
  e.run = [](const nlohmann::json& params, const EnhanceInput& input) {
    const ClaheBaselineOptions o = ReadMethodParams("clahe", params, ClaheTable());
    if (input.steps != nullptr) {
      input.steps->Image("01_luminance", baselines_internal::Luminance(input.image, input.rgb),
                         input.image.channels() == 1);
    }
    return ClaheBaseline(o, input.image, input.rgb);
  };
  e.rgb_native = true;  // luminance weights follow the order; the channels share one gain
  return e;
}

MethodEntry DcpEntry() {
  MethodEntry e;
  e.info.name = "dcp";
  e.info.summary = "dark channel prior dehazing with guided-filter refinement";
  e.info.source =
      "He, Sun, Tang, TPAMI 2011 (CVPR 2009); He, Sun, Tang, TPAMI 2013 (guided filter)";
  e.info.params = MethodParamsOf(DcpTable());
  e.run = [](const nlohmann::json& params, const EnhanceInput& input) {
    const DcpOptions o = ReadMethodParams("dcp", params, DcpTable());
    if (input.steps != nullptr) {
      return ReportDcpSteps(DarkChannelPriorDetailed(o, input.image), *input.steps);
    }
    return DarkChannelPrior(o, input.image);
  };
  return e;
}

MethodEntry UdcpEntry() {
  MethodEntry e;
  e.info.name = "udcp";
  e.info.summary = "underwater dark channel prior: dark channel over G and B only";
  e.info.source = "Drews, do Nascimento, Moraes, Botelho, Campos, ICCV Workshops 2013";
  e.info.params = MethodParamsOf(UdcpTable());
  e.run = [](const nlohmann::json& params, const EnhanceInput& input) {
    const UdcpOptions o = ReadMethodParams("udcp", params, UdcpTable());
    if (input.steps != nullptr) {
      return ReportDcpSteps(UnderwaterDarkChannelPriorDetailed(o, input.image), *input.steps);
    }
    return UnderwaterDarkChannelPrior(o, input.image);
  };
  return e;
}

MethodEntry CapEntry() {
  MethodEntry e;
  e.info.name = "cap";
  e.info.summary = "colour attenuation prior dehazing (deterministic, no random term)";
  e.info.source = "Zhu, Mai, Shao, IEEE TIP 24(11) 2015";
  e.info.params = MethodParamsOf(CapTable());
  e.run = [](const nlohmann::json& params, const EnhanceInput& input) {
    const CapOptions o = ReadMethodParams("cap", params, CapTable());
    if (input.steps != nullptr) {
      return ReportCapSteps(ColorAttenuationPriorDetailed(o, input.image), *input.steps);
    }
    return ColorAttenuationPrior(o, input.image);
  };
  return e;
}

MethodEntry TarelEntry() {
  MethodEntry e;
  e.info.name = "tarel";
  e.info.summary = "fast visibility restoration: atmospheric veil from a median of medians";
  e.info.source = "Tarel, Hautiere, ICCV 2009, and the authors' reference code";
  e.info.params = MethodParamsOf(TarelTable());
  e.run = [](const nlohmann::json& params, const EnhanceInput& input) {
    const TarelOptions o = ReadMethodParams("tarel", params, TarelTable());
    if (input.steps != nullptr)
      return ReportTarelSteps(TarelDetailed(o, input.image), *input.steps);
    return Tarel(o, input.image);
  };
  return e;
}

MethodEntry FusionEntry() {
  MethodEntry e;
  e.info.name = "fusion";
  e.info.summary = "multi-scale fusion of a white-balanced and a CLAHE-enhanced input";
  e.info.source = "Ancuti, Ancuti, Haber, Bekaert, CVPR 2012";
  e.info.params = MethodParamsOf(FusionTable());
  e.run = [](const nlohmann::json& params, const EnhanceInput& input) {
    const FusionOptions o = ReadMethodParams("fusion", params, FusionTable());
    if (input.steps != nullptr)
      return ReportFusionSteps(FusionDetailed(o, input.image), *input.steps);
    return Fusion(o, input.image);
  };
  return e;
}

}  // namespace

std::vector<MethodEntry> BaselineMethodEntries() {
  return {ClaheEntry(), DcpEntry(), UdcpEntry(), CapEntry(), TarelEntry(), FusionEntry()};
}

}  // namespace turbid
