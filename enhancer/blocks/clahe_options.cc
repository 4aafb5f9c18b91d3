// ClaheOptions: the distribution names and the options' range check (the algorithm is in
// clahe.cc).
#include "enhancer/blocks/clahe.h"

#include <cmath>
#include <string>

#include "core/error.h"

namespace turbid {

ClaheDistribution ClaheDistributionFromName(const std::string& name) {
  if (name == "uniform") return ClaheDistribution::kUniform;
  if (name == "rayleigh") return ClaheDistribution::kRayleigh;
  if (name == "exponential") return ClaheDistribution::kExponential;
  throw Error("clahe: unknown distribution '" + name +
              "' (expected uniform, rayleigh or exponential)");
}

std::string ClaheDistributionName(ClaheDistribution distribution) {
  switch (distribution) {
    case ClaheDistribution::kUniform:
      return "uniform";
    case ClaheDistribution::kRayleigh:
      return "rayleigh";
    case ClaheDistribution::kExponential:
      return "exponential";
  }
  return "uniform";
}

bool ClaheOptions::Check(std::string* why) const {
  if (tiles_x < 2 || tiles_y < 2 || tiles_x > 256 || tiles_y > 256) {
    *why = "tiles must be in [2, 256] along each axis";
    return false;
  }
  if (!std::isfinite(clip_limit) || clip_limit < 0.0 || clip_limit > 1.0) {
    *why = "clip_limit must be in [0, 1], got " + std::to_string(clip_limit);
    return false;
  }
  if (bins < 2 || bins > 65536) {
    *why = "bins must be in [2, 65536], got " + std::to_string(bins);
    return false;
  }
  if (!std::isfinite(alpha) || alpha <= 0.0 || alpha > 1e6) {
    *why = "alpha must be finite and > 0, got " + std::to_string(alpha);
    return false;
  }
  if (!std::isfinite(min_mean) || min_mean < 0.0 || min_mean > 0.6) {
    *why = "min_mean must be in [0, 0.6], got " + std::to_string(min_mean);
    return false;
  }
  return true;
}

}  // namespace turbid
