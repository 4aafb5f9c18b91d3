// Internal: the per-row kernels the renderer fuses into two passes over the image (render.cc),
// shared with the component functions (light.cc, noise.cc) so that both give the same bytes. Not
// part of the public API. Every kernel works on one image row and depends only on its inputs, so
// results do not depend on how rows are split across threads.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "simulator/light.h"
#include "simulator/noise.h"

namespace turbid::internal {

// ---- light (light.cc) ---------------------------------------------------------------------------

// One light's constants in the float precision of the row kernel.
struct LightRowConstants {
  float position[3] = {0, 0, 0};  // metres, camera frame
  float axis[3] = {0, 0, 1};      // unit
  float power = 0;                // U0
  double order = 1.0;             // Lambertian order m
  int integer_order = -1;         // m when it is a small integer (0..8), else -1
  float cos_cutoff = 0.0f;        // spot cut-off: no light where cos phi < this (0: none)
  float color[3] = {0, 0, 0};     // colour in image channel order ({gray} or {B, G, R})
};
std::vector<LightRowConstants> LightConstantsFor(const IrradianceOptions& options, int channels);

// Per-row context shared by every light: the camera's column ray slopes (x - cx) / fx as float.
struct LightRowContext {
  bool eq5 = false;  // IncidenceModel::kPaperEq5
  float min_cos = 0.05f;
  float min_distance = 0.01f;
  std::vector<float> ray_x;  // per column, `width` of them
  float RayY(const CameraIntrinsics& camera, int y) const {
    return static_cast<float>((y - camera.cy) / camera.fy);
  }
};
LightRowContext LightContextFor(const IrradianceOptions& options, const CameraIntrinsics& camera,
                                int width);

// Distance l (clamped; NaN where z is NaN) and geometric factor U0 cos^m(phi) f(psi) / l^2 (finite,
// 0 where z is NaN) of one light for one row. normals: the row's unit normals (NaN: facing the
// camera along the ray). cos_scratch: 5 * width floats.
void LightGeometryRow(const LightRowContext& context, const LightRowConstants& light, float ray_y,
                      const float* z, const cv::Vec3f* normals, int width, float* l_out,
                      float* g_out, float* cos_scratch);

// e[x, c] += colour[c] g[x] exp(-beta[c] l[x]); neg_beta = -beta in image channel order. first:
// e is written, not added to (its content is ignored).
void AccumulateLightRow(const float* l, const float* g, int width, int channels,
                        const float* neg_beta, const float* color, bool first, float* e);

// ---- marine snow (noise.cc) ---------------------------------------------------------------------

// The visible particles of RenderMarineSnow as separable Gaussian footprints, with the rows each
// one touches, so the layer can be drawn one row at a time (in particle order: same sums).
struct SnowSplats {
  struct Splat {
    int x0 = 0, x1 = 0, y0 = 0, y1 = 0;  // footprint, inclusive
    double v = 0.0;                      // centre row
    double inv = 0.0;                    // -1 / (2 sigma^2)
    float peak[3] = {0, 0, 0};           // per channel
    int gx_offset = 0;                   // first of x1 - x0 + 1 column weights in gx
  };
  int channels = 1;
  int particles = 0;
  int visible = 0;
  std::vector<Splat> splats;
  std::vector<float> gx;
  std::vector<int> row_start;  // splats touching row y: row_index[row_start[y] .. row_start[y+1])
  std::vector<int> row_index;
};
SnowSplats DrawMarineSnow(const SnowOptions& options, const IrradianceOptions& lights,
                          const CameraIntrinsics& camera, const cv::Mat& range_m,
                          const std::vector<double>& beta_per_m, const std::vector<double>& ambient,
                          uint64_t seed);
// Adds the layer's row y to out (width * channels values). scratch: as many floats, any content.
void AddSnowRow(const SnowSplats& snow, int y, int width, float* scratch, float* out);

// ---- sensor noise (noise.cc) --------------------------------------------------------------------

// Adds sensor noise to row y of an image with per_row values per row (the samples of row y are
// y * per_row ... of the sensor stream). normals_scratch: per_row floats.
void AddSensorNoiseRow(const SensorNoiseOptions& options, uint64_t seed, int y, int per_row,
                       float* p, float* normals_scratch);

}  // namespace turbid::internal
