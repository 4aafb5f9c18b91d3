// What `turbid water fit` writes from a WaterFit: the render-parameter file (model `revised`) that
// `turbid render --params` reads as it is, the diagnostics (residuals and per-bin values) and the
// plot (dark pixels vs range with the fitted backscatter, β^D vs range). docs/cli/water.md.
#pragma once

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "enhancer/seathru/water_fit.h"
#include "simulator/render_options.h"

namespace turbid {

// The fit as render options: model revised; water.custom with β^D at the median fitted range in
// beta_* (the LED path), ambient E_A = 2 k_c (Sea-thru's f = 2, grey-world reflectance 0.5),
// backscatter_rgb = B∞; revised.beta_b = β^B, range_dependent with a..d; no lights. Gray values
// are the means over R, G, B. Values are clamped to the options' ranges.
RenderOptions WaterFitRenderOptions(const WaterFit& fit);
// The sections of WaterFitRenderOptions that the fit determines ("model", "water", "revised",
// "light"); the others keep turbid render's defaults.
nlohmann::json WaterFitParamsJson(const WaterFit& fit);
// Diagnostics: every fitted value, the residual RMS per channel, the per-bin tables.
nlohmann::json WaterFitDiagnosticsJson(const WaterFit& fit, const WaterFitOptions& options);
// A 1000x420 BGR float image: left, dark pixels vs range and B_c(r); right, β^D per bin and
// β^D_c(r).
cv::Mat WaterFitPlot(const WaterFit& fit);

}  // namespace turbid
