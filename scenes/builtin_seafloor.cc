// The built-in seafloor scene (docs/formats.md): its textures and model.
#include <cmath>
#include <opencv2/core.hpp>

#include "scenes/builtin_model.h"

namespace turbid::builtin_model {
namespace {

// ---------------------------------------------------------------------------------------------
// Seafloor: sloped sand plane with ripples, shell fragments and sediment patches; rocks as
// spheres and boxes partly sunk into it. Colours are RGB albedos.

cv::Vec3d SandTexture(const SurfacePoint& p) {
  const double u = p.local[0], v = p.local[1];
  const cv::Vec3d sand{0.60, 0.53, 0.38};
  double shade = 0.85 + 0.30 * (Fbm2(u * 2.5, v * 2.5, 4, 31u) - 0.5);
  const double phase = 2.0 * kPi * (v / 0.11 + 0.8 * Fbm2(u * 1.5, v * 1.5, 3, 32u));
  const double ripple = std::sin(phase);
  shade *= 0.88 + 0.12 * ripple * std::abs(ripple) + 0.05 * (Noise2(u * 140, v * 140, 33u) - 0.5);
  cv::Vec3d color = sand * shade;
  // Sediment / algae patches.
  const double patch = SmoothStep(0.58, 0.66, Fbm2(u * 0.9 + 5, v * 0.9, 4, 34u));
  color = MixColor(color, cv::Vec3d(0.22, 0.28, 0.16) * (0.8 + 0.4 * Noise2(u * 60, v * 60, 35u)),
                   patch * 0.85);
  // Shell fragments and pebbles.
  const Cell cell = Cellular2(u / 0.06, v / 0.06, 36u);
  const double size = 0.12 + 0.18 * Lattice(static_cast<int64_t>(cell.id * 1e6), 0, 0, 37u);
  if (cell.distance < size) {
    color = cell.id < 0.5 ? cv::Vec3d(0.88, 0.84, 0.76) : cv::Vec3d(0.18, 0.16, 0.15);
  }
  return color;
}

cv::Vec3d RockTexture(const SurfacePoint& p, const cv::Vec3d& tint, uint32_t seed) {
  const cv::Vec3d q = p.local * 7.0;
  double shade = 0.45 + 0.9 * (Fbm3(q, 5, seed) - 0.5);
  // Cracks: thin dark veins where a noise field crosses its median.
  const double vein = std::abs(Fbm3(p.local * 3.0, 3, seed + 7) - 0.5);
  if (vein < 0.012) shade *= 0.45;
  cv::Vec3d color = tint * (0.6 + shade);
  // Encrusting growth: orange / green spots.
  const double growth = Fbm3(p.local * 12.0 + cv::Vec3d(3, 1, 2), 3, seed + 9);
  if (growth > 0.66)
    color = (growth > 0.72) ? cv::Vec3d(0.85, 0.45, 0.20) : cv::Vec3d(0.30, 0.55, 0.30);
  return color;
}

}  // namespace

Model SeafloorModel() {
  Model model;
  model.camera = {560.0, 560.0, 319.5, 239.5, 640, 480};
  // Seabed below and ahead of a camera pitched down; slight roll. Depth from ~1.6 m (bottom rows)
  // to ~6 m (top rows).
  const cv::Vec3d n = Normalized({0.10, -0.80, -0.60});  // towards the camera (y is down)
  const cv::Vec3d base{0, 0, 2.5};
  model.objects.push_back(MakePlane(base, n, {1, 0, 0}, SandTexture));
  // The seabed's in-plane axes, copied: the push_backs below reallocate model.objects, so a
  // reference to the plane would dangle.
  const cv::Vec3d seabed_u = model.objects.back().axis_u;
  const cv::Vec3d seabed_v = model.objects.back().axis_v;
  // "Up" off the seabed is the plane normal facing the camera.
  const cv::Vec3d up = n;
  auto on_seabed = [&](double u, double v) { return base + seabed_u * u + seabed_v * v; };
  struct Rock {
    double u, v, radius, sink;
    cv::Vec3d tint;
  };
  const Rock spheres[] = {{-0.55, 0.45, 0.28, 0.35, {0.42, 0.40, 0.36}},
                          {0.70, -0.40, 0.35, 0.45, {0.38, 0.36, 0.34}},
                          {0.15, 1.30, 0.22, 0.30, {0.46, 0.40, 0.32}},
                          {-1.10, -0.90, 0.40, 0.50, {0.34, 0.34, 0.36}},
                          {0.95, 1.00, 0.18, 0.25, {0.45, 0.42, 0.38}}};
  uint32_t seed = 40;
  for (const Rock& r : spheres) {
    const cv::Vec3d c = on_seabed(r.u, r.v) + up * (r.radius * (1.0 - 2.0 * r.sink));
    const cv::Vec3d tint = r.tint;
    const uint32_t s = seed++;
    model.objects.push_back(MakeSphere(
        c, r.radius, [tint, s](const SurfacePoint& p) { return RockTexture(p, tint, s); }));
  }
  // Two slab rocks.
  model.objects.push_back(MakeBox(on_seabed(-0.05, -0.15) + up * 0.08, up, seabed_u, 0.5,
                                  {0.30, 0.18, 0.12}, [](const SurfacePoint& p) {
                                    return RockTexture(p, {0.40, 0.38, 0.33}, 61u);
                                  }));
  model.objects.push_back(MakeBox(on_seabed(-0.60, 1.90) + up * 0.10, up, seabed_u, -0.3,
                                  {0.35, 0.25, 0.15}, [](const SurfacePoint& p) {
                                    return RockTexture(p, {0.36, 0.37, 0.38}, 62u);
                                  }));
  return model;
}

}  // namespace turbid::builtin_model
