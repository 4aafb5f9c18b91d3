// Seeded random valid render parameters for the property tests (issue 17), as the JSON that
// RenderOptionsFromJson reads: every section drawn within its documented range (simulator/*.h).
#pragma once

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <random>
#include <string>

namespace turbid::testing {

inline nlohmann::json RandomRenderParams(std::mt19937_64& rng) {
  using nlohmann::json;
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * unit(rng); };
  const auto log_uniform = [&](double lo, double hi) {
    return std::exp(std::log(lo) + (std::log(hi) - std::log(lo)) * unit(rng));
  };
  const auto coin = [&] { return unit(rng) < 0.5; };
  json p = json::object();
  static const char* kWater[] = {"custom", "I", "IA", "IB", "II", "III", "1C", "3C", "5C", "7C", "9C"};
  const std::string type = kWater[rng() % 11];
  p["water"] = {{"type", type},
                {"ambient_rgb", {uniform(0, 1.5), uniform(0, 1.5), uniform(0, 1.5)}},
                {"ambient_gray", uniform(0, 1.5)},
                {"backscatter", coin()},
                {"backscatter_rgb", {unit(rng), unit(rng), unit(rng)}},
                {"backscatter_gray", unit(rng)}};
  if (type == "custom") {
    p["water"]["beta_rgb_per_m"] = {uniform(0, 3), uniform(0, 3), uniform(0, 3)};
    p["water"]["beta_gray_per_m"] = uniform(0, 3);
  }
  json lights = json::array();
  const int count = static_cast<int>(rng() % 4);  // 0..3 LEDs
  for (int i = 0; i < count; ++i) {
    lights.push_back({{"position_in_camera_m", {uniform(-0.5, 0.5), uniform(-0.5, 0.5), uniform(-0.2, 0.2)}},
                      {"axis_in_camera", {uniform(-0.3, 0.3), uniform(-0.3, 0.3), 1.0}},
                      {"power", log_uniform(0.01, 50)},
                      {"half_power_angle_deg", uniform(5, 85)},
                      {"color_rgb", {uniform(0.2, 2), uniform(0.2, 2), uniform(0.2, 2)}}});
  }
  p["light"] = {{"lights", lights}, {"incidence", coin() ? "lambertian" : "paper_eq5"}};
  p["psf"] = {{"enabled", unit(rng) < 0.8},
              {"optical_thickness", log_uniform(1e-3, 50)},
              {"forward_scatter", log_uniform(0.01, 1)},
              {"depth_dependent", coin()},
              {"max_radius_px", 1 + static_cast<int>(rng() % 24)}};
  p["snow"] = {{"enabled", coin()}, {"density_per_m3", uniform(0, 300)}};
  p["sensor"] = {{"enabled", coin()},
                 {"photons_at_white", log_uniform(10, 1e6)},
                 {"read_noise", uniform(0, 0.05)}};
  static const int kBits[] = {8, 16, 32};
  p["camera"] = {{"bit_depth", kBits[rng() % 3]}, {"encoding", coin() ? "srgb" : "linear"}};
  p["seed"] = rng() >> 1;
  return p;
}

}  // namespace turbid::testing
