#include "simulator/models.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "simulator/fast_math.h"

namespace turbid {
namespace {

bool InRange(double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; }

}  // namespace

std::string ImageModelName(ImageModel model) {
  switch (model) {
    case ImageModel::kRevised:
      return "revised";
    case ImageModel::kUwcnn:
      return "uwcnn";
    case ImageModel::kPaper:
      break;
  }
  return "paper";
}

ImageModel ImageModelFromName(const std::string& name) {
  if (name == "paper") return ImageModel::kPaper;
  if (name == "revised") return ImageModel::kRevised;
  if (name == "uwcnn") return ImageModel::kUwcnn;
  throw Error("render options: model: unknown model '" + name + "' (paper, revised, uwcnn)");
}

bool RevisedOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& message) {
    if (why) *why = message;
    return false;
  };
  for (double v : beta_b_rgb_per_m)
    if (!InRange(v, 0.0, 10.0)) return fail("beta_b_rgb_per_m: each value must be in [0, 10] 1/m");
  if (!InRange(beta_b_gray_per_m, 0.0, 10.0))
    return fail("beta_b_gray_per_m: must be in [0, 10] 1/m");
  for (int i = 0; i < 3; ++i) {
    if (!InRange(a_rgb[i], 0.0, 10.0) || !InRange(c_rgb[i], 0.0, 10.0))
      return fail("a_rgb, c_rgb: each value must be in [0, 10] 1/m");
    if (!InRange(b_rgb[i], -10.0, 0.0) || !InRange(d_rgb[i], -10.0, 0.0))
      return fail("b_rgb, d_rgb: each value must be in [-10, 0] 1/m");
  }
  if (!InRange(a_gray, 0.0, 10.0) || !InRange(c_gray, 0.0, 10.0))
    return fail("a_gray, c_gray: must be in [0, 10] 1/m");
  if (!InRange(b_gray, -10.0, 0.0) || !InRange(d_gray, -10.0, 0.0))
    return fail("b_gray, d_gray: must be in [-10, 0] 1/m");
  return true;
}

bool UwcnnOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& message) {
    if (why) *why = message;
    return false;
  };
  if (type != "custom") {
    try {
      CanonicalJerlovType(type);
    } catch (const Error&) {
      return fail("type: unknown water type '" + type +
                  "' (custom, I, IA, IB, II, III, 1C, 3C, 5C, 7C, 9C)");
    }
  }
  for (double v : n_rgb_per_m)
    if (!(std::isfinite(v) && v > 0.0 && v <= 1.0))
      return fail("n_rgb_per_m: each value must be in (0, 1]");
  if (!(std::isfinite(n_gray_per_m) && n_gray_per_m > 0.0 && n_gray_per_m <= 1.0))
    return fail("n_gray_per_m: must be in (0, 1]");
  if (!InRange(backlight_scale, 0.0, 10.0)) return fail("backlight_scale: must be in [0, 10]");
  if (!InRange(backlight_exponent, 0.0, 50.0))
    return fail("backlight_exponent: must be in [0, 50]");
  if (!InRange(max_distance_m, 0.0, 1000.0)) return fail("max_distance_m: must be in [0, 1000] m");
  return true;
}

UwcnnConstants UwcnnChannelConstants(const UwcnnOptions& u, int channels, double distance_scale) {
  CV_Assert(channels == 1 || channels == 3);
  UwcnnConstants k;
  const std::vector<double> n = ChannelValues(u.n_rgb_per_m, u.n_gray_per_m, 3);  // B, G, R
  double light_sum = 0.0;
  std::array<double, 3> beta{}, light{};
  for (int c = 0; c < 3; ++c) {
    beta[c] = -std::log(n[c]) * distance_scale;
    light[c] = u.backlight_scale * std::pow(n[c], u.backlight_exponent);
    light_sum += light[c];
  }
  if (channels == 3) {
    k.beta.assign(beta.begin(), beta.end());
    k.light.assign(light.begin(), light.end());
    return k;
  }
  // Gray: I = mean_c (A_c rho t_c + A_c (1 - t_c)) = A' rho t' + A' (1 - t') with A' = mean A_c
  // and t' = sum A_c t_c / sum A_c (equal weights when every A_c is 0).
  double t_one = 0.0;
  for (int c = 0; c < 3; ++c) {
    k.gray_neg_beta[c] = static_cast<float>(-beta[c]);
    k.gray_weight[c] = static_cast<float>(light_sum > 0.0 ? light[c] / light_sum : 1.0 / 3.0);
    t_one += k.gray_weight[c] * std::exp(-beta[c]);
  }
  k.beta = {-std::log(std::max(t_one, 1e-300))};  // its value at 1 m (snow, plan)
  k.light = {light_sum / 3.0};
  return k;
}

void UwcnnGrayTransmissionRow(const float* range_row, int width, const float* neg_beta,
                              const float* weight, float* out) {
  for (int x = 0; x < width; ++x) {
    const float r = range_row[x];
    if (!(r == r)) {
      out[x] = 0.0f;
      continue;
    }
    const float rr = std::max(r, 0.0f);
    float t = 0.0f;
    for (int c = 0; c < 3; ++c) t += weight[c] * internal::ExpNonPositive(neg_beta[c] * rr);
    out[x] = t;
  }
}

void UwcnnEncodeRow(const float* linear, int n, float* coded) {
  for (int i = 0; i < n; ++i) {
    const double v =
        std::clamp(static_cast<double>(linear[i] == linear[i] ? linear[i] : 0.0f), 0.0, 1.0);
    const double e = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
    coded[i] = static_cast<float>(std::round(255.0 * e) / 255.0);
  }
}

void UwcnnDecodeRow(float* values, int n) {
  for (int i = 0; i < n; ++i) {
    const double c = values[i];
    const double a = std::abs(c);
    const double v = a <= 0.04045 ? a / 12.92 : std::pow((a + 0.055) / 1.055, 2.4);
    values[i] = static_cast<float>(c < 0 ? -v : v);
  }
}

UwcnnOptions ResolveUwcnn(const UwcnnOptions& options) {
  UwcnnOptions resolved = options;
  if (options.type == "custom") return resolved;
  resolved.type = CanonicalJerlovType(options.type);
  resolved.n_rgb_per_m = UwcnnResidualEnergy(resolved.type);
  resolved.n_gray_per_m =
      (resolved.n_rgb_per_m[0] + resolved.n_rgb_per_m[1] + resolved.n_rgb_per_m[2]) / 3.0;
  return resolved;
}

namespace {

// beta^D(r) = a exp(b r) + c exp(d r) of channel ch at range rr >= 0 (b, d <= 0).
inline float SeaThruBeta(const float* a, const float* b, const float* c, const float* d, int ch,
                         float rr) {
  return a[ch] * internal::ExpNonPositive(b[ch] * rr) + c[ch] * internal::ExpNonPositive(d[ch] * rr);
}

}  // namespace

void SeaThruTransmissionRow(const float* range_row, int width, int channels, const float* a,
                            const float* b, const float* c, const float* d, float* out) {
  for (int x = 0; x < width; ++x) {
    const float r = range_row[x];
    for (int ch = 0; ch < channels; ++ch) {
      if (!(r == r)) {  // open water: infinite range
        out[x * channels + ch] = 0.0f;
        continue;
      }
      const float rr = std::max(r, 0.0f);
      out[x * channels + ch] = internal::ExpNonPositive(-SeaThruBeta(a, b, c, d, ch, rr) * rr);
    }
  }
}

void SeaThruThicknessRow(const float* range_row, int width, int channels, const float* a,
                         const float* b, const float* c, const float* d, float* out) {
  for (int x = 0; x < width; ++x) {
    const float r = range_row[x];
    const float rr = std::max(r, 0.0f);
    for (int ch = 0; ch < channels; ++ch)
      out[x * channels + ch] = r == r ? SeaThruBeta(a, b, c, d, ch, rr) * rr : r;  // NaN stays
  }
}

}  // namespace turbid
