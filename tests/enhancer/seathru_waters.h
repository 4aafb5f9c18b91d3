// The Sea-thru closed loops' known waters and scene preparation, shared by
// seathru_closed_loop_test.cc (built-in scenes) and seathru_real_frames_test.cc (ICL-NUIM, TUM).
#pragma once

#include <opencv2/core.hpp>

#include "scenes/scene.h"
#include "simulator/render.h"

namespace turbid::seathru_test {

struct Water {
  const char* name;
  Rgb beta_d, beta_b, b_inf;
};

// Three waters (R, G, B): coastal green, open-ocean blue, turbid harbour.
inline const Water kWaters[] = {
    {"coastal", {0.60, 0.25, 0.30}, {0.55, 0.40, 0.45}, {0.06, 0.28, 0.30}},
    {"oceanic", {0.45, 0.12, 0.08}, {0.40, 0.25, 0.22}, {0.03, 0.16, 0.32}},
    {"harbour", {0.90, 0.45, 0.60}, {0.80, 0.60, 0.65}, {0.12, 0.30, 0.22}},
};

// `revised` water lit by ambient light only (no LEDs, PSF or snow); noise: sensor noise and
// 8-bit codes, else float.
inline RenderOptions RevisedWater(const Water& w, bool noise) {
  RenderOptions o;
  o.model = ImageModel::kRevised;
  o.water.type = "custom";
  o.water.beta_rgb_per_m = w.beta_d;
  o.water.ambient_rgb = {1.0, 1.0, 1.0};
  o.water.backscatter = true;
  o.water.backscatter_rgb = w.b_inf;
  o.revised.beta_b_rgb_per_m = w.beta_b;
  o.light.lights.clear();
  o.psf.enabled = false;
  o.snow.enabled = false;
  o.sensor.enabled = noise;
  o.camera.bit_depth = noise ? 8 : 32;
  return o;
}

// Sea-thru assumes dark pixels (shadows, black surfaces) at every range: every 37th pixel (a
// lattice, ~2.7 %) gets albedo 0.
inline Scene WithShadows(Scene scene) {
  scene.image = scene.image.clone();
  for (int y = 0; y < scene.height(); ++y)
    for (int x = 0; x < scene.width(); ++x)
      if ((y * scene.width() + x) % 37 == 0) scene.image.at<cv::Vec3f>(y, x) = {0, 0, 0};
  return scene;
}

}  // namespace turbid::seathru_test
