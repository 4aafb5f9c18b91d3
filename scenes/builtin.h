// Procedural built-in scenes: ray-cast planes, boxes and spheres with textures rich enough for
// feature matching, exact depth, normals and plane equation. No external files. Contract used by
// every module's tests; extend, do not break.
//
// Geometry: every pixel's z-depth, normal and the dominant plane are exact (ray casting through the
// pixel centre (u, v) = (column, row), the OpenCV convention that CameraIntrinsics::Ray uses). The
// clean image is the surface albedo (no shading: lights are the simulator's job), linear, kept
// inside [0.05, 0.95], anti-aliased by supersampling each pixel. See docs/formats.md.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "scenes/pose.h"
#include "scenes/scene.h"

namespace turbid {

struct BuiltinSceneOptions {
  // Output size scale in (0, 1]: 1 gives the scene's native size (hull 1360x1024, seafloor and room
  // 640x480); smaller values shrink the image and scale the intrinsics for fast tests.
  double scale = 1.0;
  // Samples per pixel side for the clean image (1..8): the albedo is averaged over
  // supersampling^2 sub-pixel rays so textures do not alias. Depth and normals always come from the
  // pixel-centre ray.
  int supersampling = 2;
  // The camera's pose in the scene's world (camera-to-world, metres; BuiltinScenePose gives the
  // scene's own): a sequence flies the camera along a trajectory (scenes/sequence.h). Depth,
  // normals, the dominant plane and the DVL hits follow the pose; the rotation must be
  // orthonormal (1e-6) and the position finite.
  std::optional<Pose> pose;
  bool Check(std::string* why) const;
};

// "hull" (oblique ship-hull plate, gray), "seafloor" (seafloor with rocks, color),
// "room" (ICL-NUIM-like box room, color).
std::vector<std::string> BuiltinSceneNames();
// Throws Error for an unknown name. Deterministic: same name and options give the same bytes
// whatever the number of threads.
Scene MakeBuiltinScene(const std::string& name, const BuiltinSceneOptions& options = {});

// The scene's own camera pose (camera-to-world in its world); throws Error for an unknown name.
Pose BuiltinScenePose(const std::string& name);

// Native (scale 1) intrinsics of a built-in scene; throws Error for an unknown name.
CameraIntrinsics BuiltinSceneCamera(const std::string& name);

// Intrinsics resized by `scale` (same field of view): width and height are rounded, focal lengths
// scale by the exact size ratio, the principal point maps pixel centres (c + 0.5) * s - 0.5.
CameraIntrinsics ScaleIntrinsics(const CameraIntrinsics& camera, double scale);

// Half-angle of the built-in DVL's four Janus beams from its axis (the camera's optical axis),
// radians. Beams point at azimuths 45, 135, 225 and 315 degrees around the axis.
inline constexpr double kBuiltinDvlBeamHalfAngleRad = 0.5235987755982988;  // 30 degrees

// The four beam hits of a DVL at the camera centre looking along +z, intersected with `plane`
// (camera frame, metres). Beams that miss (parallel or behind) are left out.
std::vector<cv::Vec3d> DvlBeamHits(const Plane& plane,
                                   double beam_half_angle_rad = kBuiltinDvlBeamHalfAngleRad);

}  // namespace turbid
