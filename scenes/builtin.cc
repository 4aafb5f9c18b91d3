// Built-in scenes: a model (builtin_hull.cc, builtin_seafloor.cc, builtin_room.cc) ray-cast
// through every pixel into image, depth, normals, plane and DVL hits.
#include "scenes/builtin.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <opencv2/core/utility.hpp>

#include "core/error.h"
#include "scenes/builtin_internal.h"
#include "scenes/builtin_model.h"

namespace turbid {
namespace {

using namespace builtin_model;  // NOLINT: the models' internals, this module's own

// Albedo bounds: textures never saturate, so every later stage (haze, noise, enhancement) has
// headroom on both sides.
constexpr double kAlbedoMin = 0.05;
constexpr double kAlbedoMax = 0.95;

Model ModelFor(const std::string& name) {
  if (name == "hull") return HullModel();
  if (name == "seafloor") return SeafloorModel();
  if (name == "room") return RoomModel();
  std::string known;
  for (const std::string& n : BuiltinSceneNames()) known += (known.empty() ? "" : ", ") + n;
  throw Error("builtin scene '" + name + "'", "unknown (known: " + known + ")");
}

// Nearest hit along a world ray among `objects` (indices into model.objects, ascending); returns
// the object index or -1.
int Trace(const Model& model, const std::vector<int>& objects, const cv::Vec3d& dir_world,
          SurfacePoint* hit, double* t_hit) {
  int best = -1;
  double best_t = kNoHit;
  for (const int i : objects) {
    // Fills *hit only when nearer than the best so far: *hit ends as the nearest's.
    const double t =
        model.objects[i].Intersect(model.camera_in_world, dir_world, 1e-6, hit, best_t);
    if (t < best_t) {
      best_t = t;
      best = i;
    }
  }
  *t_hit = best_t;
  return best;
}

// The objects (indices, ascending) that a ray of one of the image rows `rows_v` (v coordinates)
// can hit: every plane, and each sphere or box whose bounding sphere comes within reach of one of
// the rows' planes of rays. The camera-frame rays of row v, (a, s, 1) with s = (v - cy) / fy, lie
// in the plane through the camera with normal m = (0, -1, s); an object whose centre is farther
// from every such plane than its bounding radius (plus 1e-6 of it and 1 um, far above the
// rounding of the rays and of Intersect) is missed by all of them: Intersect returns kNoHit, so
// leaving it out changes no hit and no byte. Cuts the seafloor's 8 intersections per ray to the
// few objects a row can see.
void RowObjects(const Model& model, const CameraIntrinsics& cam, const cv::Matx33d& rotation,
                const std::vector<double>& rows_v, std::vector<int>* out) {
  out->clear();
  for (size_t i = 0; i < model.objects.size(); ++i) {
    const Object& o = model.objects[i];
    double radius = 0.0;
    if (o.kind == Object::Kind::kSphere) {
      radius = o.radius;
    } else if (o.kind == Object::Kind::kBox) {
      radius = cv::norm(o.half_size);
    } else {
      out->push_back(static_cast<int>(i));
      continue;
    }
    const cv::Vec3d offset = o.center - model.camera_in_world;
    const double reach = radius * (1.0 + 1e-6) + 1e-6;
    for (const double v : rows_v) {
      const double s = (v - cam.cy) / cam.fy;
      const cv::Vec3d normal = rotation * cv::Vec3d(0.0, -1.0, s);  // |normal| = |m|
      if (std::abs(normal.dot(offset)) <= reach * std::sqrt(1.0 + s * s)) {
        out->push_back(static_cast<int>(i));
        break;
      }
    }
  }
}

cv::Vec3d ClampAlbedo(const cv::Vec3d& rgb) {
  return {std::clamp(rgb[0], kAlbedoMin, kAlbedoMax), std::clamp(rgb[1], kAlbedoMin, kAlbedoMax),
          std::clamp(rgb[2], kAlbedoMin, kAlbedoMax)};
}

// Scratch space of Albedos, reused across rows.
struct AlbedoScratch {
  std::vector<SurfacePoint> points, group;
  std::vector<int> owner;
  std::vector<cv::Vec3d> group_rgb;
  std::vector<int> objects;  // RowObjects of the row
  std::vector<double> rows_v;
};

// Clamped albedos of n sample rays (world frame) of the rows scratch->rows_v, whose objects are
// scratch->objects (RowObjects): each is the texture of the nearest hit, or the background. Objects
// with a batch texture get all their points in one call.
void Albedos(const Model& model, const cv::Vec3d* dirs_world, int n, cv::Vec3d* rgb,
             AlbedoScratch* scratch) {
  std::vector<SurfacePoint>& points = scratch->points;
  std::vector<int>& owner = scratch->owner;
  points.resize(n);
  owner.resize(n);
  bool any_batch = false;
  for (int k = 0; k < n; ++k) {
    double t;
    const int index = Trace(model, scratch->objects, dirs_world[k], &points[k], &t);
    owner[k] = index;
    if (index < 0) {
      rgb[k] = model.background;
    } else if (model.objects[index].texture_batch) {
      any_batch = true;
    } else {
      rgb[k] = model.objects[index].texture(points[k]);
    }
  }
  if (any_batch) {
    std::vector<SurfacePoint>& group = scratch->group;
    std::vector<cv::Vec3d>& group_rgb = scratch->group_rgb;
    for (const int o : scratch->objects) {  // the only objects the row's rays can hit
      if (!model.objects[o].texture_batch) continue;
      group.clear();
      for (int k = 0; k < n; ++k)
        if (owner[k] == o) group.push_back(points[k]);
      if (group.empty()) continue;
      group_rgb.resize(group.size());
      model.objects[o].texture_batch(group.data(), static_cast<int>(group.size()),
                                     group_rgb.data());
      size_t next = 0;
      for (int k = 0; k < n; ++k)
        if (owner[k] == o) rgb[k] = group_rgb[next++];
    }
  }
  for (int k = 0; k < n; ++k) rgb[k] = ClampAlbedo(rgb[k]);
}

// The plane object seen at the most pixel centres, in the camera frame.
std::optional<Plane> DominantPlane(const Model& model, const cv::Mat& labels) {
  std::vector<int> counts(model.objects.size(), 0);
  for (int y = 0; y < labels.rows; ++y)
    for (int x = 0; x < labels.cols; ++x)
      if (labels.at<int>(y, x) >= 0) ++counts[labels.at<int>(y, x)];
  int best = -1;
  for (size_t i = 0; i < model.objects.size(); ++i) {
    if (model.objects[i].kind != Object::Kind::kPlane) continue;
    if (best < 0 || counts[i] > counts[best]) best = static_cast<int>(i);
  }
  if (best < 0 || counts[best] == 0) return std::nullopt;
  const Object& o = model.objects[best];
  // Camera-frame plane: X_w = R X_c + C, n_w . (X_w - P) = 0 -> (R^T n_w) . X_c + n_w . (C - P) =
  // 0.
  const cv::Matx33d camera_from_world = model.world_from_camera.t();
  Plane plane;
  plane.normal = camera_from_world * o.axis_w;
  plane.offset_m = o.axis_w.dot(model.camera_in_world - o.center);
  if (plane.offset_m < 0) {  // orient towards the camera
    plane.normal = -plane.normal;
    plane.offset_m = -plane.offset_m;
  }
  return plane;
}

}  // namespace

bool BuiltinSceneOptions::Check(std::string* why) const {
  if (!std::isfinite(scale) || scale <= 0.0 || scale > 1.0) {
    if (why) *why = "scale must be in (0, 1]";
    return false;
  }
  if (supersampling < 1 || supersampling > 8) {
    if (why) *why = "supersampling must be in 1..8";
    return false;
  }
  if (pose) {
    const cv::Matx33d e = pose->rotation.t() * pose->rotation - cv::Matx33d::eye();
    if (!(cv::norm(e, cv::NORM_INF) < 1e-6) || !(cv::determinant(pose->rotation) > 0) ||
        !std::isfinite(cv::norm(pose->position_m))) {
      if (why) *why = "pose: the rotation must be orthonormal and the position finite";
      return false;
    }
  }
  return true;
}

std::vector<std::string> BuiltinSceneNames() { return {"hull", "seafloor", "room"}; }

CameraIntrinsics BuiltinSceneCamera(const std::string& name) { return ModelFor(name).camera; }

CameraIntrinsics ScaleIntrinsics(const CameraIntrinsics& camera, double scale) {
  CameraIntrinsics out = camera;
  out.width = std::max(1, static_cast<int>(std::lround(camera.width * scale)));
  out.height = std::max(1, static_cast<int>(std::lround(camera.height * scale)));
  const double sx = static_cast<double>(out.width) / camera.width;
  const double sy = static_cast<double>(out.height) / camera.height;
  out.fx = camera.fx * sx;
  out.fy = camera.fy * sy;
  out.cx = (camera.cx + 0.5) * sx - 0.5;
  out.cy = (camera.cy + 0.5) * sy - 0.5;
  return out;
}

std::vector<cv::Vec3d> DvlBeamHits(const Plane& plane, double beam_half_angle_rad) {
  std::vector<cv::Vec3d> hits;
  const double s = std::sin(beam_half_angle_rad), c = std::cos(beam_half_angle_rad);
  for (int k = 0; k < 4; ++k) {
    const double azimuth = (45.0 + 90.0 * k) * kPi / 180.0;
    const cv::Vec3d beam{s * std::cos(azimuth), s * std::sin(azimuth), c};
    const double denom = plane.normal.dot(beam);
    if (std::abs(denom) < 1e-12) continue;
    const double t = -plane.offset_m / denom;
    if (t > 0) hits.push_back(beam * t);
  }
  return hits;
}

Pose BuiltinScenePose(const std::string& name) {
  const Model model = ModelFor(name);
  return {model.world_from_camera, model.camera_in_world};
}

Scene MakeBuiltinScene(const std::string& name, const BuiltinSceneOptions& options) {
  ThrowIfInvalid(options, "builtin scene '" + name + "'");
  Model model = ModelFor(name);
  if (options.pose) {
    model.world_from_camera = options.pose->rotation;
    model.camera_in_world = options.pose->position_m;
  }
  Scene scene;
  scene.name = name;
  scene.camera = ScaleIntrinsics(model.camera, options.scale);
  const CameraIntrinsics& cam = scene.camera;
  const cv::Size size(cam.width, cam.height);
  cv::Mat color(size, CV_32FC3);
  scene.depth_m.create(size, CV_32FC1);
  scene.normals.create(size, CV_32FC3);
  cv::Mat labels(size, CV_32SC1);
  const int ss = options.supersampling;
  const cv::Matx33d& rotation = model.world_from_camera;
  const cv::Matx33d camera_from_world = rotation.t();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  // Each pixel depends only on its own coordinates, so any row split gives the same bytes.
  cv::parallel_for_(cv::Range(0, cam.height), [&](const cv::Range& rows) {
    // One row's sample rays, then their albedos in one call (batch textures), summed per pixel in
    // sample order.
    std::vector<cv::Vec3d> dirs(static_cast<size_t>(cam.width) * ss * ss), albedo(dirs.size());
    AlbedoScratch scratch;
    for (int y = rows.start; y < rows.end; ++y) {
      for (int x = 0; x < cam.width; ++x) {
        for (int j = 0; j < ss; ++j) {
          for (int i = 0; i < ss; ++i) {
            const double u = x + (i + 0.5) / ss - 0.5, v = y + (j + 0.5) / ss - 0.5;
            dirs[(static_cast<size_t>(x) * ss + j) * ss + i] = rotation * cam.Ray(u, v);
          }
        }
      }
      scratch.rows_v.clear();
      for (int j = 0; j < ss; ++j) scratch.rows_v.push_back(y + (j + 0.5) / ss - 0.5);
      scratch.rows_v.push_back(y);  // the pixel centres' rays: depth and normals
      RowObjects(model, cam, rotation, scratch.rows_v, &scratch.objects);
      Albedos(model, dirs.data(), static_cast<int>(dirs.size()), albedo.data(), &scratch);
      auto* rgb_row = color.ptr<cv::Vec3f>(y);
      auto* depth_row = scene.depth_m.ptr<float>(y);
      auto* normal_row = scene.normals.ptr<cv::Vec3f>(y);
      auto* label_row = labels.ptr<int>(y);
      for (int x = 0; x < cam.width; ++x) {
        const cv::Vec3d ray = cam.Ray(x, y);
        SurfacePoint hit;
        double t;
        const int index = Trace(model, scratch.objects, rotation * ray, &hit, &t);
        label_row[x] = index;
        if (index < 0) {
          depth_row[x] = nan;
          normal_row[x] = {nan, nan, nan};
        } else {
          depth_row[x] = static_cast<float>(t);
          cv::Vec3d n = camera_from_world * hit.normal_world;
          if (n.dot(ray) > 0) n = -n;
          n /= cv::norm(n);
          normal_row[x] = cv::Vec3f(n);
        }
        cv::Vec3d sum{0, 0, 0};
        const cv::Vec3d* samples = &albedo[static_cast<size_t>(x) * ss * ss];
        for (int k = 0; k < ss * ss; ++k) sum += samples[k];
        sum /= static_cast<double>(ss * ss);
        rgb_row[x] = cv::Vec3f(static_cast<float>(sum[2]), static_cast<float>(sum[1]),
                               static_cast<float>(sum[0]));  // BGR, as OpenCV
      }
    }
  });
  if (model.gray) {
    cv::extractChannel(color, scene.image, 0);
  } else {
    scene.image = color;
  }
  scene.dominant_plane = DominantPlane(model, labels);
  if (scene.dominant_plane) scene.dvl_points_in_camera = DvlBeamHits(*scene.dominant_plane);
  scene.Validate();
  return scene;
}

namespace builtin_internal {

void Cellular2ForTest(double x, double y, uint32_t seed, double* distance, double* id) {
  const Cell cell = Cellular2(x, y, seed);
  *distance = cell.distance;
  *id = cell.id;
}

}  // namespace builtin_internal

}  // namespace turbid
