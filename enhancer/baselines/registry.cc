// Registry entries of the baselines: parameter schemas read from the Options defaults, strict
// JSON binding through ParamBinder (enhancer/method.h).
#include "enhancer/baselines/registry.h"

#include <nlohmann/json.hpp>

#include "enhancer/baselines/cap.h"
#include "enhancer/baselines/clahe.h"
#include "enhancer/baselines/common.h"
#include "enhancer/baselines/dcp.h"
#include "enhancer/baselines/fusion.h"
#include "enhancer/baselines/tarel.h"
#include "enhancer/method.h"

namespace turbid {
namespace {

void BindDcp(ParamBinder& b, DcpOptions* o) {
  b.Bind("patch_size", &o->patch_size);
  b.Bind("omega", &o->omega);
  b.Bind("t0", &o->t0);
  b.Bind("airlight_fraction", &o->airlight_fraction);
  b.Bind("refine", &o->refine);
  b.Bind("guided_radius", &o->guided_radius);
  b.Bind("guided_eps", &o->guided_eps);
}

std::vector<MethodParam> DcpParams(const DcpOptions& d, const std::string& prior) {
  return {
      Param("patch_size", d.patch_size,
            "side of the square " + prior + " window, pixels, odd >= 1 (He 2011: 15)",
            SizeBound::kWindow),
      Param("omega", d.omega, "fraction of haze removed, (0,1] (He 2011 eq. 12: 0.95)"),
      Param("t0", d.t0, "lower bound on transmission in the recovery, (0,1] (He 2011: 0.1)"),
      Param("airlight_fraction", d.airlight_fraction,
            "fraction of brightest dark-channel pixels searched for A, (0,1] (He 2011: 0.001)"),
      Param("refine", d.refine, "guided-filter refinement of the transmission (He 2013)"),
      Param("guided_radius", d.guided_radius, "guided-filter radius, pixels >= 1 (He 2013: 60)",
            SizeBound::kRadius),
      Param("guided_eps", d.guided_eps, "guided-filter epsilon on [0,1] data, > 0 (He 2013: 1e-4)"),
  };
}

void BindClahe(ParamBinder& b, const std::string& prefix, ClaheBaselineOptions* o) {
  b.Bind(prefix + "tiles_x", &o->tiles_x);
  b.Bind(prefix + "tiles_y", &o->tiles_y);
  b.Bind(prefix + "clip_limit", &o->clip_limit);
  b.Bind(prefix + "bins", &o->bins);
}

std::vector<MethodParam> ClaheParams(const ClaheBaselineOptions& d, const std::string& prefix) {
  return {
      Param(prefix + "tiles_x", d.tiles_x, "contextual regions along x, >= 2 (adapthisteq: 8)",
            SizeBound::kPerAxis),
      Param(prefix + "tiles_y", d.tiles_y, "contextual regions along y, >= 2 (adapthisteq: 8)",
            SizeBound::kPerAxis),
      Param(prefix + "clip_limit", d.clip_limit,
            "clip limit as a fraction, [0,1] (adapthisteq: 0.01)"),
      Param(prefix + "bins", d.bins, "histogram bins, [2, 65536] (adapthisteq: 256)"),
  };
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
  e.info.params = ClaheParams(ClaheBaselineOptions{}, "");
  e.run = [](const nlohmann::json& params, const EnhanceInput& input) {
    ClaheBaselineOptions o;
    ParamBinder b("clahe", params);
    BindClahe(b, "", &o);
    b.Finish(o);
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
  e.info.params = DcpParams(DcpOptions{}, "dark-channel");
  e.run = [](const nlohmann::json& params, const EnhanceInput& input) {
    DcpOptions o;
    ParamBinder b("dcp", params);
    BindDcp(b, &o);
    b.Finish(o);
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
  e.info.params = DcpParams(UdcpOptions{}, "G-B dark-channel");
  e.run = [](const nlohmann::json& params, const EnhanceInput& input) {
    UdcpOptions o;
    ParamBinder b("udcp", params);
    BindDcp(b, &o);
    b.Finish(o);
    if (input.steps != nullptr) {
      return ReportDcpSteps(UnderwaterDarkChannelPriorDetailed(o, input.image), *input.steps);
    }
    return UnderwaterDarkChannelPrior(o, input.image);
  };
  return e;
}

MethodEntry CapEntry() {
  const CapOptions d;
  MethodEntry e;
  e.info.name = "cap";
  e.info.summary = "colour attenuation prior dehazing (deterministic, no random term)";
  e.info.source = "Zhu, Mai, Shao, IEEE TIP 24(11) 2015";
  e.info.params = {
      Param("theta0", d.theta0, "depth model intercept (Zhu 2015: 0.121779)"),
      Param("theta1", d.theta1, "depth model HSV-value coefficient (Zhu 2015: 0.959710)"),
      Param("theta2", d.theta2, "depth model HSV-saturation coefficient (Zhu 2015: -0.780245)"),
      Param("patch_size", d.patch_size, "minimum-filter side, pixels, odd >= 1 (Zhu 2015: 15)",
            SizeBound::kWindow),
      Param("beta", d.beta, "scattering coefficient in t = exp(-beta d), > 0 (Zhu 2015: 1)"),
      Param("t_min", d.t_min, "lower transmission clamp, (0, t_max) (Zhu 2015: 0.05)"),
      Param("t_max", d.t_max, "upper transmission clamp, (t_min, 1] (Zhu 2015: 1)"),
      Param("airlight_fraction", d.airlight_fraction,
            "fraction of farthest pixels searched for A, (0,1] (Zhu 2015: 0.001)"),
      Param("refine", d.refine, "guided-filter refinement of the depth"),
      Param("guided_radius", d.guided_radius,
            "guided-filter radius, pixels >= 1 (Zhu's code: 60x60 window, radius 30)",
            SizeBound::kRadius),
      Param("guided_eps", d.guided_eps, "guided-filter epsilon on [0,1] data (Zhu's code: 1e-3)"),
  };
  e.run = [](const nlohmann::json& params, const EnhanceInput& input) {
    CapOptions o;
    ParamBinder b("cap", params);
    b.Bind("theta0", &o.theta0);
    b.Bind("theta1", &o.theta1);
    b.Bind("theta2", &o.theta2);
    b.Bind("patch_size", &o.patch_size);
    b.Bind("beta", &o.beta);
    b.Bind("t_min", &o.t_min);
    b.Bind("t_max", &o.t_max);
    b.Bind("airlight_fraction", &o.airlight_fraction);
    b.Bind("refine", &o.refine);
    b.Bind("guided_radius", &o.guided_radius);
    b.Bind("guided_eps", &o.guided_eps);
    b.Finish(o);
    if (input.steps != nullptr) {
      return ReportCapSteps(ColorAttenuationPriorDetailed(o, input.image), *input.steps);
    }
    return ColorAttenuationPrior(o, input.image);
  };
  return e;
}

MethodEntry TarelEntry() {
  const TarelOptions d;
  MethodEntry e;
  e.info.name = "tarel";
  e.info.summary = "fast visibility restoration: atmospheric veil from a median of medians";
  e.info.source = "Tarel, Hautiere, ICCV 2009, and the authors' reference code";
  e.info.params = {
      Param("p", d.p, "fraction of the veil removed, (0,1) (Tarel 2009: 0.95)"),
      Param("sv", d.sv, "median window side (largest white object), pixels, odd >= 1 (Tarel: 11)",
            SizeBound::kWindow),
      Param("balance", d.balance,
            "white balance: < 0 none, 0 global, > 0 local strength (reference code values)"),
      Param("tone_map", d.tone_map, "final gamma correction and tone mapping (reference code)"),
      Param("gamma_factor", d.gamma_factor, "extra gamma factor, > 0 (reference code: 1.3)"),
  };
  e.run = [](const nlohmann::json& params, const EnhanceInput& input) {
    TarelOptions o;
    ParamBinder b("tarel", params);
    b.Bind("p", &o.p);
    b.Bind("sv", &o.sv);
    b.Bind("balance", &o.balance);
    b.Bind("tone_map", &o.tone_map);
    b.Bind("gamma_factor", &o.gamma_factor);
    b.Finish(o);
    if (input.steps != nullptr)
      return ReportTarelSteps(TarelDetailed(o, input.image), *input.steps);
    return Tarel(o, input.image);
  };
  return e;
}

MethodEntry FusionEntry() {
  const FusionOptions d;
  MethodEntry e;
  e.info.name = "fusion";
  e.info.summary = "multi-scale fusion of a white-balanced and a CLAHE-enhanced input";
  e.info.source = "Ancuti, Ancuti, Haber, Bekaert, CVPR 2012";
  e.info.params = {
      Param("levels", d.levels, "Laplacian pyramid levels, >= 1 (capped by the image size)"),
      Param("white_balance", d.white_balance, "gray-world white balance of input 1 (colour)"),
      Param("max_white_balance_gain", d.max_white_balance_gain,
            "largest gray-world gain on one channel, >= 1"),
      Param("exposedness_sigma", d.exposedness_sigma,
            "exposedness Gaussian width around 0.5, > 0 (Ancuti 2012: 0.25)"),
  };
  for (MethodParam& p : ClaheParams(d.clahe, "clahe_")) e.info.params.push_back(std::move(p));
  e.run = [](const nlohmann::json& params, const EnhanceInput& input) {
    FusionOptions o;
    ParamBinder b("fusion", params);
    b.Bind("levels", &o.levels);
    b.Bind("white_balance", &o.white_balance);
    b.Bind("max_white_balance_gain", &o.max_white_balance_gain);
    b.Bind("exposedness_sigma", &o.exposedness_sigma);
    BindClahe(b, "clahe_", &o.clahe);
    b.Finish(o);
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
