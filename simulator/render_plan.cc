#include "simulator/render_plan.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/error.h"

namespace turbid {
namespace {

std::string Format(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

std::string ListText(const std::vector<double>& values) {
  std::string s = "[";
  for (size_t i = 0; i < values.size(); ++i) s += (i ? ", " : "") + Format(values[i]);
  return s + "]";
}

// model revised with water.iop: the direct and backscatter transmissions tabulated over the
// scene's ranges from the spectra (Akkaynak & Treibitz 2018), per image channel.
void DeriveRevisedFromIop(const WaterOptions& w, int channels, double max_range, Decisions& d) {
  if (d.sea_thru)
    throw Error(
        "render options: revised.range_dependent: water.iop derives beta^D(r) already (set "
        "revised.from_iop false to use Sea-thru's form)");
  const EffectiveWater e =
      Effective(WaterSpectraFor(w.iop), CameraSensitivityFor(w.camera_sensitivity),
                IlluminantFor(w.illuminant));
  for (int ch = 0; ch < channels; ++ch) {
    const int k = channels == 1 ? 3 : 2 - ch;  // image order B, G, R -> R, G, B, gray
    d.direct_table.push_back(TabulateTransmission(e, k, 'd', max_range));
    d.backscatter_table.push_back(TabulateTransmission(e, k, 'b', max_range));
    d.beta_b[ch] = e.BackscatterBeta(k, 0.0);
  }
}

// The image model's values (beta, E_A, B_inf, beta^B, Sea-thru) and its plan line.
void DecideModel(const RenderOptions& options, int channels, double max_range, Decisions& d) {
  RenderPlan& plan = d.plan;
  bool& lights_used = d.lights_used;
  if (options.model == ImageModel::kRevised) {
    const RevisedOptions& v = options.revised;
    d.revised = true;
    d.backscatter_on = true;
    d.beta_b = ChannelValues(v.beta_b_rgb_per_m, v.beta_b_gray_per_m, channels);
    d.sea_thru = v.range_dependent;
    if (d.sea_thru) {
      d.sea_a = ChannelValues(v.a_rgb, v.a_gray, channels);
      d.sea_b = ChannelValues(v.b_rgb, v.b_gray, channels);
      d.sea_c = ChannelValues(v.c_rgb, v.c_gray, channels);
      d.sea_d = ChannelValues(v.d_rgb, v.d_gray, channels);
    }
    d.iop_tables = v.from_iop && !d.used.water.iop.empty();
    if (d.iop_tables) DeriveRevisedFromIop(d.used.water, channels, max_range, d);
    plan.steps.push_back(
        "model: revised (Akkaynak & Treibitz 2018): I = [J*h] exp(-beta^D r) + (1 - exp(-beta^B "
        "r)) (B_inf + E_L), beta^B = " +
        ListText(d.beta_b) + " 1/m" + (d.iop_tables ? " at r -> 0" : "") +
        (d.sea_thru ? ", beta^D(r) = a exp(b r) + c exp(d r) (Sea-thru)" : "") +
        (d.iop_tables ? ", beta^D(r) and beta^B(r) from the spectra of water.iop " +
                            d.used.water.iop + " (tabulated over range)"
                      : ""));
  } else if (options.model == ImageModel::kUwcnn) {
    // t = N^d = exp(d ln N): beta = -ln N, scaled when distances are rescaled; J = A rho (no
    // ambient or artificial light in this recipe); background A = scale N^exponent.
    const UwcnnOptions& u = d.used.uwcnn;
    const bool rescale = u.max_distance_m > 0.0 && std::isfinite(max_range) && max_range > 0.0;
    const double distance_scale = rescale ? u.max_distance_m / max_range : 1.0;
    d.uwcnn = UwcnnChannelConstants(u, channels, distance_scale);
    d.uwcnn_gray = channels == 1;
    d.uwcnn_encoded = u.domain == UwcnnDomain::kEncoded;
    for (int c = 0; c < channels; ++c) {
      d.beta[c] = d.uwcnn.beta[c];
      d.ambient[c] = d.uwcnn.light[c];
      d.backscatter[c] = d.uwcnn.light[c];
    }
    d.backscatter_on = true;
    lights_used = false;
    const std::vector<double> n = ChannelValues(u.n_rgb_per_m, u.n_gray_per_m, 3);
    const std::vector<double> a = UwcnnChannelConstants(u, 3, 1.0).light;
    plan.steps.push_back(
        "model: uwcnn (Li, Anwar & Porikli 2020): I = A rho N^d + A (1 - N^d), type " + u.type +
        ", N = " + ListText(n) + ", A = " + ListText(a) +
        (rescale ? ", d = r x " + Format(distance_scale) : ", d = r") +
        (d.uwcnn_encoded ? ", on 8-bit sRGB codes / 255 (as the scripts)"
                         : ", on linear light (turbid's variant)") +
        (d.uwcnn_gray ? ", gray = mean of the B, G, R recipes" : ""));
    plan.skipped.push_back("uwcnn: no ambient E_A or artificial light (J = A rho)");
  } else {
    plan.steps.push_back("model: paper (eq. 2): I = [J*h] t + (1 - t) E_L");
  }
}

// psf.model "small_angle": b = omega c of the water and its phase function.
void DecideSmallAnglePsf(const RenderOptions& options, Decisions& d) {
  const int channels = static_cast<int>(d.beta.size());
  const std::vector<double> albedo =
      ChannelValues(d.water.scattering_albedo_rgb, d.water.scattering_albedo_gray, channels);
  d.psf_water.c_per_m = d.beta;
  d.psf_water.b_per_m.clear();
  for (int c = 0; c < channels; ++c) d.psf_water.b_per_m.push_back(albedo[c] * d.beta[c]);
  d.psf_water.phase = d.water.phase;
  d.blur = std::any_of(d.psf_water.b_per_m.begin(), d.psf_water.b_per_m.end(),
                       [](double b) { return b > 0.0; });
  if (!d.blur) {
    d.plan.skipped.push_back("psf: small_angle with b = 0: no forward scattering");
    return;
  }
  d.plan.steps.push_back(
      "psf: small_angle, ballistic exp(-c r) J + glow (exp(-(c - b_f) r) - exp(-c r)) J, b = " +
      ListText(d.psf_water.b_per_m) + " 1/m, b_f = b (1 - b_b/b), phase " + d.water.phase.model +
      ", Gaussian glow <psi^2> = b_f r <theta^2> / (3 (1 - exp(-b_f r))) x focal length, up to " +
      std::to_string(options.psf.glow_levels) + " widths");
}

// The PSF kernel and whether (and how) J is blurred.
void DecidePsf(const RenderOptions& options, Decisions& d) {
  RenderPlan& plan = d.plan;
  if (!options.psf.enabled) {
    plan.skipped.push_back("psf: disabled");
  } else {
    d.psf = PsfKernel(options.psf);
    if (options.psf.model == PsfModel::kSmallAngle) {
      DecideSmallAnglePsf(options, d);
    } else if (options.psf.turbidity_dependent) {
      d.blur = true;
      plan.steps.push_back(
          "psf: turbidity-dependent, T = beta r per pixel and channel, h = exp(-T) delta + (1 - "
          "exp(-T)) g_T (eq. 7 at p = sqrt(T), sigma = " +
          Format(d.psf.sigma_px) + " px), up to " + std::to_string(options.psf.thickness_levels) +
          " kernels");
    } else if (d.psf.is_delta && !options.psf.depth_dependent) {
      plan.skipped.push_back("psf: kernel is a delta at this pixel scale (sigma " +
                             Format(d.psf.sigma_px) + " px)");
    } else {
      d.blur = true;
      plan.steps.push_back(std::string("psf: generalized Gaussian p = ") + Format(d.psf.p) +
                           ", sigma = " + Format(d.psf.sigma_px) + " px, radius " +
                           std::to_string(d.psf.radius_px) + " px, " +
                           (d.psf.separable ? "separable (Gaussian)" : "2-D") +
                           (options.psf.depth_dependent ? ", range-dependent width" : ""));
    }
  }
}

// Which veil of the lights runs (render option "veil") and its plan line.
void DecideVeil(const RenderOptions& options, Decisions& d) {
  if (!d.any_light || d.zero_beta) return;  // no lights' veil at all (said above)
  if (options.veil == VeilModel::kPaper) {
    d.plan.steps.push_back(std::string("veil: paper, (1 - ") + (d.revised ? "t_B" : "t") +
                           ") E_L at the surface point (eq. 2)");
    return;
  }
  const int channels = static_cast<int>(d.beta.size());
  const std::vector<double> albedo = ChannelValues(
      d.water.scattering_albedo_rgb, d.water.scattering_albedo_gray, channels);
  d.single_scatter = true;
  d.veil_water.c_per_m = d.beta;
  for (int c = 0; c < channels; ++c) d.veil_water.b_per_m.push_back(albedo[c] * d.beta[c]);
  d.veil_water.phase = d.water.phase;
  d.plan.steps.push_back(
      "veil: single_scatter, pi integral_0^R b p(theta) E_lamp exp(-c s) ds along each view ray "
      "(R = range, infinity in open water), b = " +
      ListText(d.veil_water.b_per_m) + " 1/m, c = beta, phase " + d.water.phase.model +
      ", tables on rays every 5 deg of field, Hermite at the exact range");
}

}  // namespace

Decisions Decide(const RenderOptions& options, const Scene& scene, double min_range,
                 double max_range) {
  ThrowIfInvalid(options, "render options");
  Decisions d;
  d.used = ResolvePresets(options);
  d.water = d.used.water;
  const int channels = scene.channels();
  d.beta = ChannelValues(d.water.beta_rgb_per_m, d.water.beta_gray_per_m, channels);
  d.ambient = ChannelValues(d.water.ambient_rgb, d.water.ambient_gray, channels);
  d.backscatter = ChannelValues(d.water.backscatter_rgb, d.water.backscatter_gray, channels);
  d.backscatter_on = options.water.backscatter;
  RenderPlan& plan = d.plan;
  if (options.ambient == AmbientModel::kDerived && options.model != ImageModel::kUwcnn) {
    d.backscatter = DerivedBackscatter(d.water, channels);
    d.backscatter_on = true;
    plan.steps.push_back(
        "ambient: derived, B_inf = (b/c) E_A H = " + ListText(d.backscatter) +
        " (single scattering of a diffuse downwelling light, infinite water, view elevation " +
        Format(d.water.ambient_view_elevation_deg) + " deg)");
  }
  bool& lights_used = d.lights_used;
  DecideModel(options, channels, max_range, d);
  const std::string what = channels == 1 ? "1 channel (gray)" : "3 channels (BGR)";
  plan.steps.push_back("input: " + scene.name + " " + std::to_string(scene.width()) + "x" +
                       std::to_string(scene.height()) + ", " + what);
  if (channels == 1) plan.skipped.push_back("colour: gray input, every term computed on 1 channel");
  for (const LightOptions& l : options.light.lights)
    d.any_light = d.any_light || (lights_used && l.power > 0.0);
  if (d.any_light)
    plan.steps.push_back("light: " + std::to_string(options.light.lights.size()) + " LED(s), " +
                         IncidenceModelName(options.light.incidence) + " incidence");
  else
    plan.skipped.push_back("light: no light (or zero power): E_L = 0, no veiling term");
  // The revised model always takes the general path (two transmissions, maybe range-dependent).
  d.zero_beta =
      !d.revised && std::all_of(d.beta.begin(), d.beta.end(), [](double b) { return b == 0.0; });
  d.uniform_range =
      !d.revised && !d.uwcnn_gray && max_range - min_range <= 1e-7 * std::max(max_range, 1.0);
  if (d.zero_beta)
    plan.skipped.push_back(
        "attenuation: beta = 0, t = 1 (no exp, no veil; t = 0 where depth is invalid)");
  else if (d.uniform_range)
    plan.steps.push_back("attenuation: uniform range " + Format(min_range) +
                         " m, t constant per channel");
  else
    plan.steps.push_back(std::string(d.revised ? "attenuation: direct t = exp(-beta^D r)"
                                               : "attenuation: t = exp(-beta r)") +
                         ", beta = " + ListText(d.beta) + " 1/m");
  DecideVeil(options, d);
  if (d.backscatter_on && !d.zero_beta)
    plan.steps.push_back("backscatter: (1 - t) B_inf, B_inf = " + ListText(d.backscatter));
  DecidePsf(options, d);
  if (options.snow.enabled && options.snow.density_per_m3 > 0.0)
    plan.steps.push_back("snow: " + Format(options.snow.density_per_m3) + " particles/m^3");
  else
    plan.skipped.push_back("snow: none");
  if (options.sensor.enabled &&
      (options.sensor.photons_at_white > 0.0 || options.sensor.read_noise > 0.0))
    plan.steps.push_back("sensor noise: Poisson-Gaussian, " +
                         Format(options.sensor.photons_at_white) + " e-/full scale, read " +
                         Format(options.sensor.read_noise));
  else
    plan.skipped.push_back("sensor noise: none");
  plan.steps.push_back(options.camera.bit_depth == 32
                           ? std::string("camera: clip to [0, 1], float, linear")
                           : "camera: clip, " + CameraEncodingName(options.camera.encoding) +
                                 " encoding, quantise to " +
                                 std::to_string(options.camera.bit_depth) + " bit");
  return d;
}

}  // namespace turbid
