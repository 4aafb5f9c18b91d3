// Sequences: frames with camera poses (docs/formats.md "Sequences"), loaded or rendered on demand
// so a long sequence never sits in memory. Two sources:
//   - a built-in scene flown along a trajectory (scenes/trajectory.h), rendered per pose with
//     exact depth;
//   - an RGB-D dataset with ground truth in TUM RGB-D's formats: a scene file
//     {"type": "rgbd_sequence", "associations": "associations.txt", "groundtruth":
//      "groundtruth.txt", "camera": ...}.
// Poses are camera-to-world, metres (scenes/pose.h).
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "scenes/builtin.h"
#include "scenes/pose.h"
#include "scenes/scene.h"
#include "scenes/trajectory.h"

namespace turbid {

class Sequence {
 public:
  virtual ~Sequence() = default;
  const std::string& name() const { return name_; }
  int size() const { return static_cast<int>(poses_.size()); }
  const Pose& pose(int i) const { return poses_.at(i); }
  double timestamp_s(int i) const { return timestamps_s_.at(i); }
  const std::vector<Pose>& poses() const { return poses_; }
  // Frame i (0-based), loaded or rendered now; its name is "<sequence>#<i>". Throws Error.
  virtual Scene Frame(int i) const = 0;

 protected:
  std::string name_;
  std::vector<Pose> poses_;
  std::vector<double> timestamps_s_;
};

// A built-in scene along a trajectory; timestamps i / frame_rate_hz.
std::unique_ptr<Sequence> MakeBuiltinSequence(const std::string& scene,
                                              const BuiltinSceneOptions& options,
                                              const TrajectoryOptions& trajectory);

// The keys of an "rgbd_sequence" scene file.
struct RgbdSequenceSpec {
  std::string source;        // the JSON file (messages)
  std::string name;          // default: the file's stem
  std::string associations;  // TUM associations: "t_rgb rgb_path t_depth depth_path" per line
  std::string groundtruth;   // TUM ground truth: "t tx ty tz qx qy qz qw" per line
  // "camera": a preset name, "unknown" or {fx, fy, cx, cy} (scenes/scene_loader.h
  // ReadCameraValue, as scene files); size from the images.
  std::optional<CameraIntrinsics> camera;
  bool camera_unknown = false;
  double depth_scale = 5000.0;  // depth file units per metre (TUM / ICL-NUIM: 5000)
  bool srgb = true;             // colour files are sRGB-coded ("color": "srgb" | "linear")
  int first_frame = 0;          // the first association line used (0-based)
  int frames = 0;               // how many (0: all from first_frame)
  // Added to the associations' rgb timestamps before looking up the ground truth (ICL-NUIM's
  // ground-truth ids start at 1 for frame 0: 1).
  double time_offset_s = 0.0;
  // The nearest ground-truth line must be this close in time (TUM's associate.py default 0.02).
  double max_time_difference_s = 0.02;
};

// Parses an "rgbd_sequence" file and its two text files (no image is read). Throws
// Error("<file>: <problem>").
RgbdSequenceSpec ParseRgbdSequenceFile(const std::string& json_path);
std::unique_ptr<Sequence> LoadRgbdSequence(const std::string& json_path);

// Whether `path` is a JSON file whose "type" is "rgbd_sequence" (false for anything else,
// including files that cannot be read: their own loader reports those).
bool IsRgbdSequenceFile(const std::string& path);

// A sequence as an experiment names it: a built-in scene ("builtin:NAME" or a bare name) at
// `builtin_scale` flown along `trajectory` (TrajectoryFields keys, strict; read with `source` in
// messages), or an rgbd_sequence file (`trajectory` must be null). Throws Error.
std::unique_ptr<Sequence> OpenSequence(const std::string& spec, double builtin_scale,
                                       const nlohmann::json& trajectory, const std::string& source);

// Writes `sequence` as a TUM RGB-D folder that LoadRgbdSequence reads back: rgb/NNNNNN.png (8-bit
// sRGB, gray scenes as gray), depth/NNNNNN.png (16-bit, 5000 per metre, 0 = invalid),
// associations.txt, groundtruth.txt (timestamps, camera-to-world) and sequence.json (the
// rgbd_sequence file, with the camera). Refuses existing files unless overwrite.
void WriteTumSequence(const Sequence& sequence, const std::string& folder, bool overwrite);

}  // namespace turbid
