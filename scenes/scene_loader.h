// One entry point for every scene source: built-in procedural scenes and scene files (JSON) that
// point at dataset frames (TUM / ICL-NUIM RGB-D, stereo disparity, float depth, NYU Depth v2
// labelled file, RGB-D folders). The harness,
// `turbid render` and `turbid scene` all call LoadScene. Schema and units: docs/formats.md.
#pragma once

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "scenes/image_io.h"
#include "scenes/scene.h"

namespace turbid {

struct LoadSceneOptions {
  // Size scale in (0, 1] applied to built-in scenes (file scenes are loaded at their own size).
  double builtin_scale = 1.0;
  bool Check(std::string* why) const;
};

// spec: "builtin:NAME", a bare built-in name ("hull", "seafloor", "room"), the path of a scene
// JSON file, or "FILE.json#KEY" for one frame of a multi-frame scene file (nyu_v2: KEY is the
// 0-based frame index; folder: the file stem). The result has passed Scene::Validate(). Throws
// Error("<file>: <problem>").
Scene LoadScene(const std::string& spec, const LoadSceneOptions& options = {});

// True when `spec` names a built-in scene ("builtin:NAME" or a bare known name that is not an
// existing file).
bool IsBuiltinSpec(const std::string& spec);
// The built-in scene's name in a spec IsBuiltinSpec accepts: "builtin:NAME" -> NAME, a bare name
// as it is.
std::string BuiltinSpecName(const std::string& spec);

// The single-frame specs a spec stands for, in order: "FILE.json#KEY" for every frame a nyu_v2 or
// folder scene file selects ("frames"); the spec itself otherwise (built-ins, single-frame types,
// specs that already name a frame). `generate` expands its "scenes" with it. Throws Error.
std::vector<std::string> ExpandSceneSpec(const std::string& spec);

// Loads a scene JSON file (strict schema: unknown keys and bad values are errors naming the file).
// Relative paths inside the file are resolved against the file's folder. input_hashes records the
// sha256 of the JSON file and of every file it references.
Scene LoadSceneFile(const std::string& json_path);

// How a depth map on a grid other than the image's is brought onto it (scene-file key
// "depth_resize"): kNone = the sizes must match; kStretchNearest = each image pixel takes the depth
// pixel whose cell holds its centre, x_d = floor((x + 0.5) * W_d / W), y alike (both axes
// stretched independently, no averaging, so no depth is invented at silhouettes).
enum class DepthResize { kNone, kStretchNearest };

// Nearest-neighbour stretch of a CV_32FC1 depth map to `size` by the kStretchNearest rule above.
cv::Mat StretchNearest(const cv::Mat& depth, const cv::Size& size);
// Marks invalid (NaN) every pixel within `radius_px` (Chebyshev distance, i.e. a (2r+1)^2 square)
// of an invalid pixel; pixels outside the map do not count as invalid. radius 0 = unchanged.
cv::Mat ErodeValidDepth(const cv::Mat& depth_m, int radius_px);
// The intrinsics "camera": "unknown" stands for: fx = fy = 1e9 px, principal point at the centre,
// so that |K^-1 [u v 1]| - 1 < 6e-10 on any image up to 65536 px (float resolution is 6e-8):
// range = depth. (Normals come from a nominal camera with fx = fy = max(width, height), a 53 degree
// field of view, since a 1e9 px focal length makes every depth step a wall.)
CameraIntrinsics UnknownCamera(int width, int height);
// The nominal camera normals of an "unknown"-camera scene are computed with: fx = fy =
// max(width, height), principal point at the centre.
CameraIntrinsics NominalCamera(int width, int height);

// A parsed scene file; every field is documented in docs/formats.md ("Scene files").
struct SceneFileSpec {
  std::string source;     // the JSON file's path (used in messages and input_hashes)
  std::string name;       // default: the JSON file's stem
  std::string type;       // "rgbd", "depth", "stereo", "builtin", "nyu_v2" or "folder"
  std::string image;      // clean image path, resolved against the JSON's folder
  std::string depth;      // rgbd / depth: depth file path
  std::string disparity;  // stereo: disparity file path
  // rgbd / depth: file units per metre, depth_m = value / depth_scale (rgbd default 5000 as
  // TUM / ICL-NUIM; depth default 1, i.e. float metres). 0 in the file = invalid.
  double depth_scale = 0.0;
  double disparity_scale = 1.0;  // stereo: file units per pixel of disparity (Middlebury 2003: 4)
  double baseline_m = 0.0;       // stereo: baseline, metres (> 0)
  double doffs_px = 0.0;         // stereo: x-difference of principal points (Middlebury doffs), px
  Transfer color = Transfer::kSrgb;        // how integer image files are encoded
  std::optional<CameraIntrinsics> camera;  // width/height 0 = taken from the image
  std::optional<Plane> plane;              // known dominant plane, camera frame
  std::vector<cv::Vec3d> dvl;              // DVL beam hits, camera frame, metres
  std::string builtin;                     // builtin: scene name
  double builtin_scale = 1.0;              // builtin: size scale in (0, 1]
  // nyu_v2 and folder (multi-frame datasets). depth_scale 0 = not given (folder: required for
  // integer depth files, 1 for float ones).
  std::string dataset;  // nyu_v2: the labelled .mat file; folder: the dataset root
  std::vector<std::string>
      frames;         // selected frame keys in order (NYU: 0-based index; folder: stem)
  std::string frame;  // the frame BuildScene loads: "#KEY" of the spec, or the only selected one
  bool crop_border = false;              // nyu_v2: crop to the NYU toolbox's valid region
  std::string depth_dataset = "depths";  // nyu_v2: "depths" or "rawDepths"
  std::string rgb_dir = "rgb";           // folder: colour subfolder
  std::string depth_dir = "depth";       // folder: depth subfolder
  // rgbd / depth / folder: files hold distance along the ray ("depth_kind": "range"), not z.
  bool depth_is_range = false;
  DepthResize depth_resize = DepthResize::kNone;  // rgbd / depth / folder
  int depth_erode_px = 0;       // rgbd / depth / folder: valid-mask erosion, depth-file pixels
  bool camera_unknown = false;  // "camera": "unknown": UnknownCamera(), range = depth
};

// Parses and checks a scene JSON file (no image is read; multi-frame types list their frames).
// json_path may end in "#KEY" (see LoadScene). Throws Error("<json>: <problem>").
SceneFileSpec ParseSceneFile(const std::string& json_path);
// "${NAME}" in a path replaced by the environment variable NAME (scene files, rgbd_sequence
// files); Error("<json_path>: ...") for an unset or empty variable or a missing '}'.
std::string ExpandEnvironment(const std::string& path, const std::string& json_path);
// Reads the files a spec names and builds a validated Scene.
Scene BuildScene(const SceneFileSpec& spec);

// Named intrinsics presets accepted for "camera" in scene files: "icl_nuim" (fx 481.20,
// fy -480.00, cx 319.5, cy 239.5), "tum_fr1", "tum_fr2", "tum_fr3", "tum_default" (TUM RGB-D
// published calibrations). Throws Error for an unknown name.
CameraIntrinsics CameraPreset(const std::string& name);
// The "camera" value of scene and sequence files: a preset name, "unknown" (sets *unknown,
// resets *camera) or {fx, fy, cx, cy[, width, height]}. Returns the problem, "" when read.
std::string ReadCameraValue(const nlohmann::json& value, std::optional<CameraIntrinsics>* camera,
                            bool* unknown);
// The "camera" value that ReadCameraValue reads back ("unknown", the object, or null).
nlohmann::json CameraValue(const std::optional<CameraIntrinsics>& camera, bool unknown);
std::vector<std::string> CameraPresetNames();

// Stereo disparity (pixels) to z-depth (metres): z = baseline_m * fx_px / (d + doffs_px), the
// Middlebury 2014 relation (doffs = 0 for rectified pairs with equal principal points). NaN where
// d is 0, NaN or infinite (unknown) or d + doffs <= 0.
cv::Mat DepthFromDisparity(const cv::Mat& disparity_px, double fx_px, double baseline_m,
                           double doffs_px = 0.0);

}  // namespace turbid
