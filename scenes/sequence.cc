#include "scenes/sequence.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/input_file.h"
#include "core/json_io.h"
#include "scenes/image_io.h"
#include "scenes/scene_loader.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

class BuiltinSequence : public Sequence {
 public:
  BuiltinSequence(const std::string& scene, const BuiltinSceneOptions& options,
                  const TrajectoryOptions& trajectory)
      : scene_(scene), options_(options) {
    name_ = scene + "_" + trajectory.kind;
    poses_ = BuiltinTrajectory(scene, trajectory);
    for (int i = 0; i < size(); ++i) timestamps_s_.push_back(i / trajectory.frame_rate_hz);
  }
  Scene Frame(int i) const override {
    BuiltinSceneOptions options = options_;
    options.pose = pose(i);
    Scene scene = MakeBuiltinScene(scene_, options);
    scene.name = name_ + "#" + std::to_string(i);
    return scene;
  }

 private:
  std::string scene_;
  BuiltinSceneOptions options_;
};

// One associated frame of an RGB-D sequence.
struct RgbdFrame {
  double t = 0;
  std::string rgb, depth;  // resolved paths
};

class RgbdSequence : public Sequence {
 public:
  RgbdSequence(RgbdSequenceSpec spec, std::vector<RgbdFrame> frames, std::vector<Pose> poses)
      : spec_(std::move(spec)), frames_(std::move(frames)) {
    name_ = spec_.name;
    poses_ = std::move(poses);
    for (const RgbdFrame& f : frames_) timestamps_s_.push_back(f.t);
  }
  Scene Frame(int i) const override {
    const RgbdFrame& f = frames_.at(i);
    SceneFileSpec s;
    s.source = spec_.source;
    s.name = name_ + "#" + std::to_string(i);
    s.type = "rgbd";
    s.image = f.rgb;
    s.depth = f.depth;
    s.depth_scale = spec_.depth_scale;
    s.color = spec_.srgb ? Transfer::kSrgb : Transfer::kLinear;
    s.camera = spec_.camera;
    s.camera_unknown = spec_.camera_unknown;
    return BuildScene(s);
  }

 private:
  RgbdSequenceSpec spec_;
  std::vector<RgbdFrame> frames_;
};

// The lines of a text file that are neither empty nor comments ('#'), with their line numbers.
std::vector<std::pair<int, std::string>> DataLines(const std::string& path) {
  CheckInputFile(path);  // never open a FIFO or a device
  std::ifstream in(path);
  if (!in) throw Error(path, "cannot read");
  std::vector<std::pair<int, std::string>> lines;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    lines.emplace_back(number, line);
  }
  return lines;
}

bool FolderNamed(const std::string& path, const std::string& name) {
  return fs::path(path).parent_path().filename() == name;
}

// TUM associations "t_rgb rgb t_depth depth"; ICL-NUIM's files list depth first ("id depth/N.png
// id rgb/N.png"): a pair whose first path is in a folder named depth and second in one named rgb
// is taken in that order.
std::vector<RgbdFrame> ReadAssociations(const std::string& path) {
  std::vector<RgbdFrame> frames;
  const fs::path folder = fs::path(path).parent_path();
  for (const auto& [number, line] : DataLines(path)) {
    std::istringstream in(line);
    double t1 = 0, t2 = 0;
    std::string p1, p2, extra;
    if (!(in >> t1 >> p1 >> t2 >> p2) || (in >> extra) || !std::isfinite(t1) || !std::isfinite(t2))
      throw Error(path, "line " + std::to_string(number) +
                            ": expected 'timestamp rgb_path timestamp depth_path'");
    const bool depth_first = FolderNamed(p1, "depth") && FolderNamed(p2, "rgb");
    RgbdFrame f;
    f.t = depth_first ? t2 : t1;
    f.rgb = (folder / (depth_first ? p2 : p1)).string();
    f.depth = (folder / (depth_first ? p1 : p2)).string();
    frames.push_back(std::move(f));
  }
  if (frames.empty()) throw Error(path, "no associations");
  return frames;
}

// TUM ground truth "t tx ty tz qx qy qz qw", sorted by time.
std::vector<std::pair<double, Pose>> ReadGroundTruth(const std::string& path) {
  std::vector<std::pair<double, Pose>> poses;
  for (const auto& [number, line] : DataLines(path)) {
    std::istringstream in(line);
    double v[8];
    std::string extra;
    bool ok = true;
    for (double& x : v) ok = ok && static_cast<bool>(in >> x) && std::isfinite(x);
    if (!ok || (in >> extra))
      throw Error(path, "line " + std::to_string(number) + ": expected 't tx ty tz qx qy qz qw'");
    try {
      poses.emplace_back(
          v[0], Pose::FromTranslationQuaternion({v[1], v[2], v[3]}, {v[4], v[5], v[6], v[7]}));
    } catch (const Error& e) {
      throw Error(path, "line " + std::to_string(number) + ": " + e.what());
    }
  }
  if (poses.empty()) throw Error(path, "no poses");
  std::stable_sort(poses.begin(), poses.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  return poses;
}

// The ground-truth pose nearest in time to t; Error when none is within max_difference.
Pose NearestPose(const std::vector<std::pair<double, Pose>>& gt, double t, double max_difference,
                 const std::string& path) {
  const auto it = std::lower_bound(gt.begin(), gt.end(), t,
                                   [](const auto& p, double v) { return p.first < v; });
  const std::pair<double, Pose>* best = nullptr;
  if (it != gt.end()) best = &*it;
  if (it != gt.begin() && (!best || t - (it - 1)->first < best->first - t)) best = &*(it - 1);
  if (!best || std::abs(best->first - t) > max_difference) {
    char text[128];
    std::snprintf(text, sizeof text, "no pose within %g s of frame time %.6f", max_difference, t);
    throw Error(path, text);
  }
  return best->second;
}

const Fields<RgbdSequenceSpec>& RgbdSequenceFields() {
  using O = RgbdSequenceSpec;
  static const Fields<O> fields =
      Fields<O>()
          .Custom(
              "type", "string", "", "\"rgbd_sequence\"",
              [](const json& v, O&) -> std::string {
                return v == "rgbd_sequence" ? "" : "expected \"rgbd_sequence\"";
              },
              [](const O&) { return json("rgbd_sequence"); })
          .String("name", &O::name, "sequence name (default: the file's stem)")
          .String("associations", &O::associations, "TUM associations file")
          .String("groundtruth", &O::groundtruth, "TUM ground-truth trajectory")
          .Custom(
              "camera", "string or object", "",
              "a camera preset, \"unknown\" or {fx, fy, cx, cy} (as scene files)",
              [](const json& v, O& out) {
                return ReadCameraValue(v, &out.camera, &out.camera_unknown);
              },
              [](const O& in) { return CameraValue(in.camera, in.camera_unknown); })
          .Number("depth_scale", &O::depth_scale, "depth units per metre", NumberRange::Above(0))
          .Custom(
              "color", "one of: srgb, linear", "", "how the colour files are coded",
              [](const json& v, O& out) -> std::string {
                if (v != "srgb" && v != "linear") return "expected \"srgb\" or \"linear\"";
                out.srgb = v == "srgb";
                return "";
              },
              [](const O& in) { return json(in.srgb ? "srgb" : "linear"); })
          .Integer("first_frame", &O::first_frame, "first association used (0-based)", 0, 100000000)
          .Integer("frames", &O::frames, "frames used (0: all)", 0, 100000000)
          .Number("time_offset_s", &O::time_offset_s, "added to frame times for the lookup",
                  NumberRange::Between(-1e9, 1e9))
          .Number("max_time_difference_s", &O::max_time_difference_s,
                  "largest frame-to-pose time difference", NumberRange::Between(0, 1e9));
  return fields;
}

}  // namespace

std::unique_ptr<Sequence> MakeBuiltinSequence(const std::string& scene,
                                              const BuiltinSceneOptions& options,
                                              const TrajectoryOptions& trajectory) {
  return std::make_unique<BuiltinSequence>(scene, options, trajectory);
}

RgbdSequenceSpec ParseRgbdSequenceFile(const std::string& json_path) {
  const json root = ReadJsonFile(json_path);
  RgbdSequenceSpec spec;
  spec.source = json_path;
  spec.name = fs::path(json_path).stem().string();
  RgbdSequenceFields().Read(root, &spec, json_path);
  for (const char* key : {"type", "associations", "groundtruth", "camera"})
    if (!root.contains(key)) throw Error(json_path, std::string("missing key '") + key + "'");
  // "${TURBID_DATA}/..." as in scene files; relative paths are relative to the file's folder.
  const fs::path folder = fs::path(json_path).parent_path();
  const auto resolve = [&](const std::string& raw) {
    const fs::path p(ExpandEnvironment(raw, json_path));
    return p.is_absolute() ? p.string() : (folder / p).string();
  };
  spec.associations = resolve(spec.associations);
  spec.groundtruth = resolve(spec.groundtruth);
  return spec;
}

std::unique_ptr<Sequence> LoadRgbdSequence(const std::string& json_path) {
  const RgbdSequenceSpec spec = ParseRgbdSequenceFile(json_path);
  std::vector<RgbdFrame> all = ReadAssociations(spec.associations);
  const auto gt = ReadGroundTruth(spec.groundtruth);
  if (spec.first_frame >= static_cast<int>(all.size()))
    throw Error(json_path, "first_frame " + std::to_string(spec.first_frame) + " is past the " +
                               std::to_string(all.size()) + " associations");
  const int available = static_cast<int>(all.size()) - spec.first_frame;
  const int count = spec.frames == 0 ? available : std::min(spec.frames, available);
  if (spec.frames > available)
    throw Error(json_path, "frames " + std::to_string(spec.frames) + " asked, " +
                               std::to_string(available) + " associations from first_frame");
  std::vector<RgbdFrame> frames(all.begin() + spec.first_frame,
                                all.begin() + spec.first_frame + count);
  std::vector<Pose> poses;
  for (const RgbdFrame& f : frames)
    poses.push_back(
        NearestPose(gt, f.t + spec.time_offset_s, spec.max_time_difference_s, spec.groundtruth));
  return std::make_unique<RgbdSequence>(spec, std::move(frames), std::move(poses));
}

bool IsRgbdSequenceFile(const std::string& path) {
  std::error_code ec;
  if (fs::path(path).extension() != ".json" || !fs::is_regular_file(path, ec)) return false;
  try {
    const json root = ReadJsonFile(path);
    return root.is_object() && root.contains("type") && root["type"] == "rgbd_sequence";
  } catch (const Error&) {
    return false;
  }
}

std::unique_ptr<Sequence> OpenSequence(const std::string& spec, double builtin_scale,
                                       const json& trajectory, const std::string& source) {
  const bool builtin = spec.rfind("builtin:", 0) == 0 ||
                       (spec.find('/') == std::string::npos && fs::path(spec).extension().empty());
  if (!builtin) {
    if (!trajectory.is_null())
      throw Error(source, "'trajectory' is for built-in scenes; '" + spec +
                              "' is a file (an rgbd_sequence file brings its own poses)");
    return LoadRgbdSequence(spec);
  }
  TrajectoryOptions options;
  TrajectoryFields().Read(trajectory, &options, source, "trajectory");
  std::string why;
  if (!options.Check(&why)) throw Error(source, "trajectory: " + why);
  BuiltinSceneOptions scene;
  scene.scale = builtin_scale;
  return MakeBuiltinSequence(spec.substr(spec.rfind(':') + 1), scene, options);
}

void WriteTumSequence(const Sequence& sequence, const std::string& folder, bool overwrite) {
  fs::create_directories(fs::path(folder) / "rgb");
  fs::create_directories(fs::path(folder) / "depth");
  std::ostringstream associations, groundtruth;
  associations.precision(17);
  groundtruth.precision(17);
  associations << "# turbid sequence " << sequence.name() << ": timestamp rgb timestamp depth\n";
  groundtruth << "# camera-to-world: timestamp tx ty tz qx qy qz qw\n";
  CameraIntrinsics camera;
  for (int i = 0; i < sequence.size(); ++i) {
    const Scene frame = sequence.Frame(i);
    camera = frame.camera;
    char stem[32];
    std::snprintf(stem, sizeof stem, "%06d.png", i);
    WriteImageOptions rgb;
    rgb.transfer = Transfer::kSrgb;
    rgb.overwrite = overwrite;
    WriteImage((fs::path(folder) / "rgb" / stem).string(), frame.image, rgb);
    WriteImageOptions depth;
    depth.bit_depth = 16;
    depth.raw = true;
    depth.overwrite = overwrite;
    cv::Mat units = frame.depth_m * 5000.0;  // NaN stays NaN: written as 0 (invalid)
    WriteImage((fs::path(folder) / "depth" / stem).string(), units, depth);
    const double t = sequence.timestamp_s(i);
    associations << t << " rgb/" << stem << " " << t << " depth/" << stem << "\n";
    const Pose& p = sequence.pose(i);
    const cv::Vec4d q = p.Quaternion();
    groundtruth << t << " " << p.position_m[0] << " " << p.position_m[1] << " " << p.position_m[2]
                << " " << q[0] << " " << q[1] << " " << q[2] << " " << q[3] << "\n";
  }
  const json spec = {{"type", "rgbd_sequence"},
                     {"name", sequence.name()},
                     {"associations", "associations.txt"},
                     {"groundtruth", "groundtruth.txt"},
                     {"camera", CameraValue(camera, false)},
                     {"depth_scale", 5000.0},
                     {"max_time_difference_s", 1e-6}};
  AtomicWriteText((fs::path(folder) / "associations.txt").string(), associations.str(), overwrite);
  AtomicWriteText((fs::path(folder) / "groundtruth.txt").string(), groundtruth.str(), overwrite);
  AtomicWriteText((fs::path(folder) / "sequence.json").string(), spec.dump(2) + "\n", overwrite);
}

}  // namespace turbid
