// enhancer/seathru/water_report.h.
#include "enhancer/seathru/water_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>

namespace turbid {
namespace {

double Mean3(const Rgb3& v) { return (v[0] + v[1] + v[2]) / 3.0; }

nlohmann::json Json3(const Rgb3& v) { return nlohmann::json::array({v[0], v[1], v[2]}); }

Rgb Clamp3(const Rgb3& v, double lo, double hi) {
  return {std::clamp(v[0], lo, hi), std::clamp(v[1], lo, hi), std::clamp(v[2], lo, hi)};
}

std::string Label(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.2f", v);
  return text;
}

// One panel: axes over [x0, x1] x [y0, y1] in the rectangle `area` of `canvas`.
struct Panel {
  cv::Mat canvas;
  cv::Rect area;
  double x0, x1, y0, y1;
  cv::Point At(double x, double y) const {
    const double u = (x - x0) / std::max(x1 - x0, 1e-12), v = (y - y0) / std::max(y1 - y0, 1e-12);
    return {area.x + static_cast<int>(std::lround(u * area.width)),
            area.y + area.height - static_cast<int>(std::lround(v * area.height))};
  }
  void Axes(const std::string& title, const std::string& x_label) {
    const cv::Scalar black(0, 0, 0);
    cv::rectangle(canvas, area, black, 1);
    cv::putText(canvas, title, {area.x, area.y - 8}, cv::FONT_HERSHEY_SIMPLEX, 0.45, black, 1,
                cv::LINE_AA);
    cv::putText(canvas, x_label, {area.x + area.width / 2 - 30, area.y + area.height + 34},
                cv::FONT_HERSHEY_SIMPLEX, 0.4, black, 1, cv::LINE_AA);
    for (int i = 0; i <= 4; ++i) {
      const double x = x0 + (x1 - x0) * i / 4, y = y0 + (y1 - y0) * i / 4;
      cv::putText(canvas, Label(x), At(x, y0) + cv::Point(-12, 16), cv::FONT_HERSHEY_SIMPLEX, 0.35,
                  black, 1, cv::LINE_AA);
      cv::putText(canvas, Label(y), At(x0, y) + cv::Point(-40, 4), cv::FONT_HERSHEY_SIMPLEX, 0.35,
                  black, 1, cv::LINE_AA);
    }
  }
};

const cv::Scalar kChannel[3] = {{0.1, 0.1, 0.85}, {0.1, 0.6, 0.1}, {0.85, 0.3, 0.1}};  // R, G, B
const cv::Scalar kLight[3] = {{0.65, 0.65, 1.0}, {0.65, 0.9, 0.65}, {1.0, 0.8, 0.65}};

}  // namespace

RenderOptions WaterFitRenderOptions(const WaterFit& fit) {
  RenderOptions o;
  o.model = ImageModel::kRevised;
  const AttenuationFit& att = fit.attenuation;
  const double r_mid = 0.5 * (fit.min_range_m + fit.max_range_m);
  Rgb3 beta_mid{}, ambient{};
  for (int c = 0; c < 3; ++c) {
    beta_mid[c] = att.Beta(c, r_mid);
    ambient[c] = 2.0 * std::exp(att.log_scale[c]);
  }
  o.water.type = "custom";
  o.water.beta_rgb_per_m = Clamp3(beta_mid, 0, 10);
  o.water.beta_gray_per_m = std::clamp(Mean3(beta_mid), 0.0, 10.0);
  o.water.ambient_rgb = Clamp3(ambient, 0, 10);
  o.water.ambient_gray = std::clamp(Mean3(ambient), 0.0, 10.0);
  o.water.backscatter = true;
  o.water.backscatter_rgb = Clamp3(fit.backscatter.b_inf, 0, 1);
  o.water.backscatter_gray = std::clamp(Mean3(fit.backscatter.b_inf), 0.0, 1.0);
  o.revised.beta_b_rgb_per_m = Clamp3(fit.backscatter.beta_b, 0, 10);
  o.revised.beta_b_gray_per_m = std::clamp(Mean3(fit.backscatter.beta_b), 0.0, 10.0);
  o.revised.range_dependent = true;
  o.revised.a_rgb = Clamp3(att.a, 0, 10);
  o.revised.b_rgb = Clamp3(att.b, -10, 0);
  o.revised.c_rgb = Clamp3(att.c, 0, 10);
  o.revised.d_rgb = Clamp3(att.d, -10, 0);
  o.revised.a_gray = std::clamp(Mean3(att.a), 0.0, 10.0);
  o.revised.b_gray = std::clamp(Mean3(att.b), -10.0, 0.0);
  o.revised.c_gray = std::clamp(Mean3(att.c), 0.0, 10.0);
  o.revised.d_gray = std::clamp(Mean3(att.d), -10.0, 0.0);
  o.light.lights.clear();  // real frames: ambient light only
  return o;
}

nlohmann::json WaterFitParamsJson(const WaterFit& fit) {
  const nlohmann::json all = RenderOptionsToJson(WaterFitRenderOptions(fit));
  return {{"model", all.at("model")},
          {"water", all.at("water")},
          {"revised", all.at("revised")},
          {"light", {{"lights", nlohmann::json::array()}}}};
}

nlohmann::json WaterFitDiagnosticsJson(const WaterFit& fit, const WaterFitOptions& options) {
  const BackscatterFit& bs = fit.backscatter;
  const AttenuationFit& att = fit.attenuation;
  nlohmann::json bins = nlohmann::json::array();
  for (size_t i = 0; i < bs.bin_range_m.size(); ++i)
    bins.push_back({{"range_m", bs.bin_range_m[i]},
                    {"dark_median_rgb", Json3(bs.bin_dark_median[i])},
                    {"fitted_rgb", Json3(bs.bin_fitted[i])}});
  nlohmann::json att_bins = nlohmann::json::array();
  for (size_t i = 0; i < att.bin_range_m.size(); ++i)
    att_bins.push_back({{"range_m", att.bin_range_m[i]},
                        {"pixels", att.bin_count[i]},
                        {"beta_d_rgb_per_m", Json3(att.bin_beta[i])},
                        {"fitted_rgb_per_m", Json3(att.bin_fitted[i])}});
  return {{"frames", fit.frames},
          {"valid_pixels", fit.valid_pixels},
          {"range_m", {fit.min_range_m, fit.max_range_m}},
          {"options", WaterFitFields().ToJson(options)},
          {"backscatter",
           {{"b_inf_rgb", Json3(bs.b_inf)},
            {"beta_b_rgb_per_m", Json3(bs.beta_b)},
            {"j_prime_rgb", Json3(bs.j_prime)},
            {"beta_prime_rgb_per_m", Json3(bs.beta_prime)},
            {"dark_pixels", bs.dark.size()},
            {"residual_rms_rgb", Json3(bs.rms)},
            {"bins", bins}}},
          {"attenuation",
           {{"a_rgb", Json3(att.a)},
            {"b_rgb", Json3(att.b)},
            {"c_rgb", Json3(att.c)},
            {"d_rgb", Json3(att.d)},
            {"log_illuminant_scale_rgb", Json3(att.log_scale)},
            {"residual_rms_log_rgb", Json3(att.rms)},
            {"bins", att_bins}}}};
}

cv::Mat WaterFitPlot(const WaterFit& fit) {
  cv::Mat canvas(420, 1000, CV_32FC3, cv::Scalar::all(1));
  const BackscatterFit& bs = fit.backscatter;
  const AttenuationFit& att = fit.attenuation;
  const double r0 = fit.min_range_m, r1 = std::max(fit.max_range_m, r0 + 1e-3);
  double top = 0.0;
  for (const auto& d : bs.dark) top = std::max({top, double(d[1]), double(d[2]), double(d[3])});
  Panel left{canvas, {60, 40, 400, 320}, r0, r1, 0.0, std::max(top * 1.1, 1e-3)};
  for (const auto& d : bs.dark)
    for (int c = 0; c < 3; ++c) cv::circle(canvas, left.At(d[0], d[1 + c]), 1, kLight[c], -1);
  double beta_top = 0.0;
  for (const Rgb3& b : att.bin_beta) beta_top = std::max({beta_top, b[0], b[1], b[2]});
  for (const Rgb3& b : att.bin_fitted) beta_top = std::max({beta_top, b[0], b[1], b[2]});
  Panel right{canvas, {570, 40, 400, 320}, r0, r1, 0.0, std::max(beta_top * 1.1, 1e-3)};
  for (int c = 0; c < 3; ++c) {
    for (int i = 0; i < 100; ++i) {
      const double ra = r0 + (r1 - r0) * i / 100, rb = r0 + (r1 - r0) * (i + 1) / 100;
      cv::line(canvas, left.At(ra, bs.Evaluate(c, ra)), left.At(rb, bs.Evaluate(c, rb)),
               kChannel[c], 2, cv::LINE_AA);
      cv::line(canvas, right.At(ra, att.Beta(c, ra)), right.At(rb, att.Beta(c, rb)), kChannel[c], 2,
               cv::LINE_AA);
    }
    for (size_t i = 0; i < att.bin_range_m.size(); ++i)
      cv::circle(canvas, right.At(att.bin_range_m[i], std::max(0.0, att.bin_beta[i][c])), 3,
                 kChannel[c], 1, cv::LINE_AA);
  }
  left.Axes("dark pixels (dots) and fitted backscatter B_c(r)", "range (m)");
  right.Axes("beta^D per range bin (circles) and fitted beta^D_c(r), 1/m", "range (m)");
  return canvas;
}

}  // namespace turbid
