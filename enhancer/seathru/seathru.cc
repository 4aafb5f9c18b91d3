// enhancer/seathru/seathru.h and the method's registry entry (enhancer/seathru/entries.h).
#include "enhancer/seathru/seathru.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/error.h"
#include "enhancer/method.h"
#include "enhancer/params.h"
#include "enhancer/seathru/entries.h"

namespace turbid {

bool SeathruOptions::Check(std::string* why) const {
  if (!fit.Check(why)) return false;
  if (!(mean_reflectance > 0 && mean_reflectance <= 1)) {
    if (why) *why = "mean_reflectance must be in (0, 1]";
    return false;
  }
  return true;
}

const Fields<SeathruOptions>& SeathruFields() {
  static const Fields<SeathruOptions> fields =
      Fields<SeathruOptions>()
          .Nested("", &SeathruOptions::fit, WaterFitFields())
          .Number(
              "mean_reflectance", &SeathruOptions::mean_reflectance,
              "white balance: the mean reflectance the illuminant stands for (Sea-thru's f = 2: "
              "0.5)",
              NumberRange::AboveUpTo(0, 1));
  return fields;
}

cv::Mat SeathruRestore(const WaterFit& fit, double mean_reflectance, const cv::Mat& image,
                       const cv::Mat& range_m, const cv::Mat& direct_in) {
  const cv::Mat direct =
      direct_in.empty() ? DirectSignal({image, range_m, ""}, fit.backscatter) : direct_in;
  cv::Mat out = image.clone();
  const AttenuationFit& att = fit.attenuation;
  // g_c(r) = e^{β^D_c(r) r} / k_c · mean_reflectance depends on r alone: a table of 4096 nodes
  // over the fitted ranges, interpolated linearly (relative error below 1e-6 for these smooth
  // curves), instead of three exps per channel and pixel.
  constexpr int kNodes = 4096;
  const double lo = fit.min_range_m, hi = std::max(fit.max_range_m, lo + 1e-6);
  const double step = (hi - lo) / (kNodes - 1);
  std::vector<float> table(3 * kNodes);
  for (int i = 0; i < kNodes; ++i) {
    const double r = lo + i * step;
    for (int c = 0; c < 3; ++c)  // B, G, R order, as the image
      table[3 * i + c] = static_cast<float>(
          mean_reflectance * std::exp(att.Beta(2 - c, r) * r - att.log_scale[2 - c]));
  }
  for (int y = 0; y < out.rows; ++y) {
    const float* r = range_m.ptr<float>(y);
    const cv::Vec3f* d = direct.ptr<cv::Vec3f>(y);
    cv::Vec3f* o = out.ptr<cv::Vec3f>(y);
    for (int x = 0; x < out.cols; ++x) {
      if (!(std::isfinite(r[x]) && r[x] > 0)) continue;
      const double u = std::clamp((r[x] - lo) / step, 0.0, kNodes - 1.0);
      const int i = std::min(static_cast<int>(u), kNodes - 2);
      const float t = static_cast<float>(u - i);
      for (int c = 0; c < 3; ++c) {
        const float g = table[3 * i + c] + t * (table[3 * i + 3 + c] - table[3 * i + c]);
        o[x][c] = std::min(1.0f, std::max(0.0f, d[x][c] * g));
      }
    }
  }
  return out;
}

SeathruResult Seathru(const SeathruOptions& options, const cv::Mat& image, const cv::Mat& range_m) {
  std::string why;
  if (!options.Check(&why)) throw Error("seathru: " + why);
  if (image.type() != CV_32FC3) throw Error("seathru: needs a 3-channel colour image");
  if (range_m.size() != image.size())
    throw Error("seathru: the scene's depth map is not the image's size");
  SeathruResult result;
  const WaterFitFrame frame{image, range_m, "seathru"};
  result.fit = FitWater({frame}, options.fit);
  result.direct = DirectSignal(frame, result.fit.backscatter);
  result.image =
      SeathruRestore(result.fit, options.mean_reflectance, image, range_m, result.direct);
  return result;
}

std::vector<MethodEntry> SeathruMethodEntries() {
  MethodEntry e;
  e.info.name = "seathru";
  e.info.summary =
      "Sea-thru: backscatter from dark pixels per range bin, range-dependent attenuation from the "
      "illuminant, fitted to the image itself";
  e.info.source = "Akkaynak, Treibitz, CVPR 2019 (docs/cli/water.md for our choices)";
  e.info.needs_geometry = true;
  e.info.inputs = "scene depth (range along the ray)";
  e.info.params = MethodParamsOf(SeathruFields());
  e.run = [](const nlohmann::json& params, const EnhanceInput& input) {
    const SeathruOptions o = ReadMethodParams("seathru", params, SeathruFields());
    if (input.scene == nullptr) throw Error("seathru: needs the scene's depth (--scene)");
    ValidateEnhanceImage(input.image, "seathru");
    // A gray image runs as three equal channels (each is fitted alike) and comes back as one.
    const bool gray = input.image.channels() == 1;
    cv::Mat colour = input.image;
    if (gray) cv::merge(std::vector<cv::Mat>{input.image, input.image, input.image}, colour);
    const cv::Mat range = RangeFromDepth(input.scene->camera, input.scene->depth_m);
    SeathruResult r = Seathru(o, colour, range);
    if (gray) cv::extractChannel(r.image, r.image, 0);
    if (input.steps != nullptr) {
      input.steps->Image("01_direct", r.direct, true);
      input.steps->Image("02_restored", r.image, true);
      const BackscatterFit& b = r.fit.backscatter;
      input.steps->Note("b_inf_rgb", {b.b_inf[0], b.b_inf[1], b.b_inf[2]});
      input.steps->Note("beta_b_rgb_per_m", {b.beta_b[0], b.beta_b[1], b.beta_b[2]});
    }
    return r.image;
  };
  return {e};
}

}  // namespace turbid
