// Scene JSON files and the dataset adapters they drive (TUM / ICL-NUIM RGB-D, float depth, stereo
// disparity, NYU Depth v2 labelled file, RGB-D folders). Schema: docs/formats.md.
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include "core/atomic_file.h"
#include "scenes/builtin.h"
#include "core/error.h"
#include "scenes/folder_dataset.h"
#include "scenes/image_io.h"
#include "core/json_io.h"
#include "core/limits.h"
#include "scenes/normals.h"
#include "scenes/nyu_depth_v2.h"
#include "core/safe_name.h"
#include "scenes/scene_loader.h"

namespace turbid {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr float kNan = std::numeric_limits<float>::quiet_NaN();

std::string Join(const std::set<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

// Strict reader over one JSON object: every accessed key is recorded, and Finish() rejects the
// rest.
class ObjectReader {
 public:
  ObjectReader(const std::string& file, const std::string& where, const json& object)
      : file_(file), where_(where), object_(object) {
    if (!object_.is_object()) Fail(where_.empty() ? "top level must be a JSON object" : where_ + " must be an object");
  }

  bool Has(const std::string& key) {
    allowed_.insert(key);
    return object_.contains(key);
  }
  void Allow(const std::string& key) { allowed_.insert(key); }

  std::string String(const std::string& key) {
    const json& v = Get(key);
    if (!v.is_string()) Fail(Key(key) + " must be a string");
    return v.get<std::string>();
  }
  double Number(const std::string& key) {
    const json& v = Get(key);
    if (!v.is_number()) Fail(Key(key) + " must be a number");
    const double value = v.get<double>();
    if (!std::isfinite(value)) Fail(Key(key) + " must be finite");
    return value;
  }
  double Positive(const std::string& key) {
    const double value = Number(key);
    if (!(value > 0.0)) Fail(Key(key) + " must be > 0, got " + Format(value));
    return value;
  }
  int PositiveInt(const std::string& key) {
    const json& v = Get(key);
    if (!v.is_number_integer() || v.get<long long>() <= 0 || v.get<long long>() > (1 << 16))
      Fail(Key(key) + " must be a positive integer");
    return static_cast<int>(v.get<long long>());
  }
  cv::Vec3d Vector3(const json& v, const std::string& what) {
    if (!v.is_array() || v.size() != 3) Fail(what + " must be an array of 3 numbers");
    cv::Vec3d out;
    for (int i = 0; i < 3; ++i) {
      if (!v[i].is_number() || !std::isfinite(v[i].get<double>()))
        Fail(what + " must be an array of 3 finite numbers");
      out[i] = v[i].get<double>();
    }
    return out;
  }
  const json& Get(const std::string& key) {
    allowed_.insert(key);
    if (!object_.contains(key)) Fail("missing required key " + Key(key));
    return object_.at(key);
  }
  void Finish() {
    for (const auto& [key, value] : object_.items()) {
      if (!allowed_.count(key))
        Fail("unknown key " + Key(key) + " (allowed here: " + Join(allowed_) + ")");
    }
  }
  [[noreturn]] void Fail(const std::string& problem) const { throw Error(file_, problem); }
  std::string Key(const std::string& key) const {
    return "'" + (where_.empty() ? key : where_ + "." + key) + "'";
  }
  static std::string Format(double value) {
    std::ostringstream s;
    s << value;
    return s.str();
  }

 private:
  const std::string& file_;
  std::string where_;
  const json& object_;
  std::set<std::string> allowed_;
};

CameraIntrinsics ParseCamera(const std::string& file, const json& value) {
  if (value.is_string()) {
    try {
      return CameraPreset(value.get<std::string>());
    } catch (const Error& e) {
      throw Error(file, std::string("'camera': ") + e.what());
    }
  }
  ObjectReader reader(file, "camera", value);
  CameraIntrinsics camera;
  camera.fx = reader.Number("fx");
  camera.fy = reader.Number("fy");
  camera.cx = reader.Number("cx");
  camera.cy = reader.Number("cy");
  if (camera.fx == 0.0 || camera.fy == 0.0) reader.Fail("'camera.fx' and 'camera.fy' must be non-zero");
  if (reader.Has("width")) camera.width = reader.PositiveInt("width");
  if (reader.Has("height")) camera.height = reader.PositiveInt("height");
  reader.Finish();
  return camera;
}

// "${NAME}" in a path is replaced by the environment variable NAME (e.g. ${TURBID_DATA}, where the
// real datasets live), so that committed scene files can name data that is not committed. An unset
// or empty variable is an error naming it; "$" not followed by "{" is kept as is.
std::string ExpandEnvironment(const std::string& path, const std::string& json_path) {
  std::string out;
  size_t at = 0;
  while (true) {
    const size_t open = path.find("${", at);
    if (open == std::string::npos) break;
    const size_t close = path.find('}', open + 2);
    if (close == std::string::npos) {
      throw Error(json_path, "path '" + path + "' has '${' without a closing '}'");
    }
    const std::string name = path.substr(open + 2, close - open - 2);
    const char* value = name.empty() ? nullptr : std::getenv(name.c_str());
    if (value == nullptr || *value == '\0') {
      throw Error(json_path, "path '" + path + "' names ${" + name +
                                 "}, which is not set (e.g. export " +
                                 (name.empty() ? std::string("NAME") : name) + "=...)");
    }
    out += path.substr(at, open - at) + value;
    at = close + 1;
  }
  return out + path.substr(at);
}

std::string Resolve(const fs::path& folder, const std::string& raw, const std::string& json_path) {
  const fs::path p(ExpandEnvironment(raw, json_path));
  return p.is_absolute() ? p.string() : (folder / p).lexically_normal().string();
}

std::string SizeText(const cv::Size& size) {
  return std::to_string(size.width) + "x" + std::to_string(size.height);
}

// Depth in metres from a raw depth file: value / units_per_m; 0 and non-finite = invalid (NaN);
// negative values are an error.
cv::Mat DepthFromRaw(const std::string& path, const cv::Mat& raw, double units_per_m) {
  if (raw.channels() != 1)
    throw Error(path, "depth must have 1 channel, found " + std::to_string(raw.channels()));
  cv::Mat depth(raw.size(), CV_32FC1);
  for (int y = 0; y < raw.rows; ++y) {
    const float* src = raw.ptr<float>(y);
    float* dst = depth.ptr<float>(y);
    for (int x = 0; x < raw.cols; ++x) {
      const float v = src[x];
      if (v < 0.0f)
        throw Error(path, "negative depth value " + ObjectReader::Format(v) + " at pixel (" +
                              std::to_string(x) + ", " + std::to_string(y) + ")");
      dst[x] = (v == 0.0f || !std::isfinite(v)) ? kNan : static_cast<float>(v / units_per_m);
    }
  }
  return depth;
}

void CheckImageRange(const std::string& path, const cv::Mat& image) {
  for (int y = 0; y < image.rows; ++y) {
    const float* row = image.ptr<float>(y);
    for (int i = 0; i < image.cols * image.channels(); ++i) {
      if (!(row[i] >= 0.0f && row[i] <= 1.0f))
        throw Error(path, "image value " + ObjectReader::Format(row[i]) + " at pixel (" +
                              std::to_string(i / image.channels()) + ", " + std::to_string(y) +
                              ") is outside [0, 1] (float images must be linear albedo in [0, 1])");
    }
  }
}

// "FILE.json#KEY" -> (FILE.json, KEY) when FILE.json#KEY itself is not a file; (spec, "") otherwise.
std::pair<std::string, std::string> SplitFrameSuffix(const std::string& spec) {
  const size_t hash = spec.rfind('#');
  std::error_code ec;
  if (hash == std::string::npos || fs::exists(spec, ec)) return {spec, ""};
  return {spec.substr(0, hash), spec.substr(hash + 1)};
}

// Frame selection of a multi-frame scene file over `keys` (every frame, in order): absent = all;
// an index; an array of indices (or, when `stems`, file stems); "START:STOP[:STEP]" (half-open,
// as a Python slice with non-negative bounds; STOP may be empty = to the end).
std::vector<std::string> SelectFrames(ObjectReader& reader, const json* value,
                                      const std::vector<std::string>& keys, bool stems) {
  if (value == nullptr) return keys;
  const long long count = static_cast<long long>(keys.size());
  auto index = [&](const json& v, const std::string& what) -> std::string {
    if (!v.is_number_integer())
      reader.Fail(what + " must be an integer frame index" + (stems ? " or a file stem" : ""));
    const long long i = v.get<long long>();
    if (i < 0 || i >= count)
      reader.Fail(what + " = " + std::to_string(i) + " is out of range (" + std::to_string(count) +
                  " frames, 0.." + std::to_string(count - 1) + ")");
    return keys[static_cast<size_t>(i)];
  };
  std::vector<std::string> out;
  if (value->is_number_integer()) return {index(*value, "'frames'")};
  if (value->is_array()) {
    if (value->empty()) reader.Fail("'frames' must not be empty");
    std::set<std::string> seen;
    for (size_t i = 0; i < value->size(); ++i) {
      const json& v = (*value)[i];
      const std::string what = "'frames[" + std::to_string(i) + "]'";
      std::string key;
      if (stems && v.is_string()) {
        key = v.get<std::string>();
        if (std::find(keys.begin(), keys.end(), key) == keys.end())
          reader.Fail(what + ": no frame with stem '" + key + "'");
      } else {
        key = index(v, what);
      }
      if (!seen.insert(key).second) reader.Fail(what + ": frame '" + key + "' is listed twice");
      out.push_back(key);
    }
    return out;
  }
  if (value->is_string()) {
    const std::string text = value->get<std::string>();
    std::vector<std::string> parts;
    std::stringstream stream(text);
    std::string part;
    while (std::getline(stream, part, ':')) parts.push_back(part);
    if (!text.empty() && text.back() == ':') parts.push_back("");
    auto number = [&](const std::string& p, long long fallback) {
      if (p.empty()) return fallback;
      if (p.find_first_not_of("0123456789") != std::string::npos || p.size() > 12)
        reader.Fail("'frames' range '" + text + "' must be START:STOP[:STEP] with non-negative integers");
      return std::stoll(p);
    };
    if (parts.size() < 2 || parts.size() > 3)
      reader.Fail("'frames' range '" + text + "' must be START:STOP[:STEP] (half-open)");
    const long long start = number(parts[0], 0);
    const long long stop = std::min(number(parts[1], count), count);
    const long long step = parts.size() == 3 ? number(parts[2], 1) : 1;
    if (step <= 0) reader.Fail("'frames' range '" + text + "' needs STEP >= 1");
    for (long long i = start; i < stop; i += step) out.push_back(keys[static_cast<size_t>(i)]);
    if (out.empty())
      reader.Fail("'frames' range '" + text + "' selects no frame (" + std::to_string(count) +
                  " frames)");
    return out;
  }
  reader.Fail("'frames' must be an index, an array, or a \"START:STOP[:STEP]\" range");
}

// nyu_v2 and folder: the dataset, its frame list, the selection and the frame to load.
void ParseMultiFrame(ObjectReader& reader, const json& root, const fs::path& folder,
                     const std::string& json_path, const std::string& frame_suffix,
                     SceneFileSpec& spec) {
  std::vector<std::string> keys;
  std::vector<FolderFrame> folder_frames;
  if (spec.type == "nyu_v2") {
    spec.dataset = Resolve(folder, reader.String("file"), json_path);
    if (reader.Has("crop_border")) {
      const json& v = root.at("crop_border");
      if (!v.is_boolean()) reader.Fail("'crop_border' must be true or false");
      spec.crop_border = v.get<bool>();
    }
    if (reader.Has("depth_dataset")) spec.depth_dataset = reader.String("depth_dataset");
    NyuFrameOptions options;
    options.depth_dataset = spec.depth_dataset;
    std::string why;
    if (!options.Check(&why)) reader.Fail("'depth_dataset': " + why);
    const int count = NyuFrameCount(spec.dataset, options);
    // A (crafted or sparse) file may claim billions of frames: one key each would exhaust memory.
    CheckItemCount(spec.dataset, "the dataset", count);
    for (int i = 0; i < count; ++i) keys.push_back(std::to_string(i));
  } else {  // folder
    spec.dataset = Resolve(folder, reader.String("folder"), json_path);
    if (reader.Has("rgb_dir")) spec.rgb_dir = reader.String("rgb_dir");
    if (reader.Has("depth_dir")) spec.depth_dir = reader.String("depth_dir");
    if (reader.Has("depth_scale")) spec.depth_scale = reader.Positive("depth_scale");
    if (reader.Has("depth_kind")) {
      const std::string kind = reader.String("depth_kind");
      if (kind != "z" && kind != "ray")
        reader.Fail("'depth_kind' must be 'z' (along the optical axis) or 'ray' (distance from "
                    "the camera centre), got '" + kind + "'");
      spec.depth_is_range = kind == "ray";
    }
    FolderDatasetOptions options;
    options.rgb_dir = spec.rgb_dir;
    options.depth_dir = spec.depth_dir;
    folder_frames = ListFolderFrames(spec.dataset, options);
    for (const FolderFrame& f : folder_frames) keys.push_back(f.stem);
  }
  reader.Allow("frames");
  spec.frames = SelectFrames(reader, root.contains("frames") ? &root.at("frames") : nullptr, keys,
                             spec.type == "folder");
  // A frame's key becomes part of its scene's name, and with it of file names.
  for (const std::string& key : spec.frames) {
    std::string why;
    if (!IsSafeFileComponent(key, &why))
      reader.Fail("frame key '" + PrintableName(key) + "' " + why);
  }
  if (!frame_suffix.empty()) {
    if (std::find(keys.begin(), keys.end(), frame_suffix) == keys.end())
      reader.Fail("'#" + frame_suffix + "': no such frame (" +
                  (spec.type == "nyu_v2" ? "0-based index, " + std::to_string(keys.size()) + " frames"
                                         : "a file stem in " + spec.dataset) + ")");
    spec.frame = frame_suffix;
  } else if (spec.frames.size() == 1) {
    spec.frame = spec.frames.front();
  }
  if (spec.type == "folder" && !spec.frame.empty()) {
    for (const FolderFrame& f : folder_frames)
      if (f.stem == spec.frame) {
        spec.image = f.rgb_path;
        spec.depth = f.depth_path;
      }
  }
}

}  // namespace

std::vector<std::string> CameraPresetNames() {
  return {"icl_nuim", "tum_default", "tum_fr1", "tum_fr2", "tum_fr3"};
}

CameraIntrinsics CameraPreset(const std::string& name) {
  // ICL-NUIM: Handa et al., ICRA 2014 (negative fy is the dataset's own convention).
  // TUM RGB-D: Sturm et al., IROS 2012, calibrated RGB intrinsics per Freiburg sensor; "default"
  // is the uncalibrated ROS default the TUM page lists.
  if (name == "icl_nuim") return {481.20, -480.00, 319.5, 239.5, 0, 0};
  if (name == "tum_default") return {525.0, 525.0, 319.5, 239.5, 0, 0};
  if (name == "tum_fr1") return {517.3, 516.5, 318.6, 255.3, 0, 0};
  if (name == "tum_fr2") return {520.9, 521.0, 325.1, 249.7, 0, 0};
  if (name == "tum_fr3") return {535.4, 539.2, 320.1, 247.6, 0, 0};
  std::string known;
  for (const std::string& n : CameraPresetNames()) known += (known.empty() ? "" : ", ") + n;
  throw Error("camera preset '" + name + "'", "unknown (known: " + known + ")");
}

cv::Mat DepthFromDisparity(const cv::Mat& disparity_px, double fx_px, double baseline_m,
                           double doffs_px) {
  CV_Assert(disparity_px.type() == CV_32FC1);
  cv::Mat depth(disparity_px.size(), CV_32FC1);
  const double numerator = baseline_m * std::abs(fx_px);
  for (int y = 0; y < disparity_px.rows; ++y) {
    const float* d = disparity_px.ptr<float>(y);
    float* z = depth.ptr<float>(y);
    for (int x = 0; x < disparity_px.cols; ++x) {
      const double denominator = static_cast<double>(d[x]) + doffs_px;
      z[x] = (d[x] == 0.0f || !std::isfinite(d[x]) || !(denominator > 0.0))
                 ? kNan
                 : static_cast<float>(numerator / denominator);
    }
  }
  return depth;
}

SceneFileSpec ParseSceneFile(const std::string& spec_path) {
  const auto [json_path, frame_suffix] = SplitFrameSuffix(spec_path);
  std::error_code ec;
  if (fs::is_directory(json_path, ec)) throw Error(json_path, "is a folder, not a scene file");
  const json root = ReadJsonFile(json_path);  // regular file, strict (depth, duplicate keys)
  ObjectReader reader(json_path, "", root);
  SceneFileSpec spec;
  spec.source = json_path;
  spec.type = reader.String("type");
  const std::set<std::string> types = {"rgbd", "depth", "stereo", "builtin", "nyu_v2", "folder"};
  if (!types.count(spec.type))
    reader.Fail("'type' must be one of " + Join(types) + ", got '" + spec.type + "'");
  spec.name = reader.Has("name") ? reader.String("name") : fs::path(json_path).stem().string();
  // The name becomes a folder (`turbid scene --out`) and part of file names (generate, sweep).
  std::string why;
  if (!IsSafeFileComponent(spec.name, &why))
    reader.Fail("scene name '" + PrintableName(spec.name) + "' " + why);
  const fs::path folder = fs::path(json_path).parent_path();
  const bool multi_frame = spec.type == "nyu_v2" || spec.type == "folder";
  if (!frame_suffix.empty() && !multi_frame)
    reader.Fail("'#" + frame_suffix + "' selects a frame, which only nyu_v2 and folder scene files "
                "have (or no file " + spec_path + ")");

  if (spec.type == "builtin") {
    spec.builtin = reader.String("builtin");
    if (reader.Has("scale")) spec.builtin_scale = reader.Number("scale");
    if (!(spec.builtin_scale > 0.0 && spec.builtin_scale <= 1.0))
      reader.Fail("'scale' must be in (0, 1]");
    bool known = false;
    for (const std::string& n : BuiltinSceneNames()) known = known || n == spec.builtin;
    if (!known) reader.Fail("'builtin': unknown scene '" + spec.builtin + "'");
    reader.Finish();
    return spec;
  }

  if (!multi_frame) spec.image = Resolve(folder, reader.String("image"), json_path);
  if (reader.Has("color")) {
    const std::string color = reader.String("color");
    if (color == "srgb") {
      spec.color = Transfer::kSrgb;
    } else if (color == "linear") {
      spec.color = Transfer::kLinear;
    } else {
      reader.Fail("'color' must be 'srgb' or 'linear', got '" + color + "'");
    }
  }
  if (reader.Has("camera")) {
    spec.camera = ParseCamera(json_path, root.at("camera"));
  } else if (spec.type == "nyu_v2") {
    // BuildScene uses NyuKinectRgbCamera(), shifted when cropped.
  } else if (spec.type == "rgbd") {
    spec.camera = CameraPreset("icl_nuim");  // the issue's documented default for RGB-D frames
  } else {
    reader.Fail("missing required key 'camera' (an object {fx, fy, cx, cy} or a preset name)");
  }
  if (multi_frame) {
    ParseMultiFrame(reader, root, folder, json_path, frame_suffix, spec);
    reader.Finish();
    return spec;
  }
  if (spec.type == "rgbd" || spec.type == "depth") {
    spec.depth = Resolve(folder, reader.String("depth"), json_path);
    spec.depth_scale = spec.type == "rgbd" ? 5000.0 : 1.0;
    if (reader.Has("depth_scale")) spec.depth_scale = reader.Positive("depth_scale");
  } else {  // stereo
    spec.disparity = Resolve(folder, reader.String("disparity"), json_path);
    spec.baseline_m = reader.Positive("baseline_m");
    if (reader.Has("disparity_scale")) spec.disparity_scale = reader.Positive("disparity_scale");
    if (reader.Has("doffs_px")) spec.doffs_px = reader.Number("doffs_px");
    if (spec.doffs_px < 0.0) reader.Fail("'doffs_px' must be >= 0");
  }
  if (reader.Has("plane")) {
    ObjectReader plane_reader(json_path, "plane", root.at("plane"));
    const cv::Vec3d normal = plane_reader.Vector3(plane_reader.Get("normal"), "'plane.normal'");
    const double length = cv::norm(normal);
    if (!(length > 1e-12)) plane_reader.Fail("'plane.normal' must be non-zero");
    Plane plane{normal / length, plane_reader.Number("offset_m") / length};
    plane_reader.Finish();
    if (plane.offset_m < 0.0) {  // orient towards the camera
      plane.normal = -plane.normal;
      plane.offset_m = -plane.offset_m;
    }
    if (plane.offset_m == 0.0) reader.Fail("'plane' passes through the camera centre (offset_m = 0)");
    spec.plane = plane;
  }
  if (reader.Has("dvl")) {
    const json& points = root.at("dvl");
    if (!points.is_array() || points.empty()) reader.Fail("'dvl' must be a non-empty array of [x, y, z]");
    for (size_t i = 0; i < points.size(); ++i) {
      const cv::Vec3d p = reader.Vector3(points[i], "'dvl[" + std::to_string(i) + "]'");
      if (!(p[2] > 0.0)) reader.Fail("'dvl[" + std::to_string(i) + "]' must have z > 0 (in front of the camera)");
      spec.dvl.push_back(p);
    }
  }
  reader.Finish();
  return spec;
}

namespace {

// Distance along the viewing ray -> z-depth: z = r / |K^-1 [u v 1]| (inverse of RangeFromDepth).
cv::Mat DepthFromRange(const CameraIntrinsics& camera, const cv::Mat& range_m) {
  cv::Mat depth(range_m.size(), CV_32FC1);
  for (int y = 0; y < range_m.rows; ++y) {
    const float* r = range_m.ptr<float>(y);
    float* z = depth.ptr<float>(y);
    for (int x = 0; x < range_m.cols; ++x)
      z[x] = static_cast<float>(r[x] / cv::norm(camera.Ray(x, y)));
  }
  return depth;
}

Scene BuildNyuScene(const SceneFileSpec& spec) {
  NyuFrameOptions options;
  options.crop_border = spec.crop_border;
  options.depth_dataset = spec.depth_dataset;
  options.color = spec.color;
  const int index = std::stoi(spec.frame);
  NyuFrame frame = ReadNyuFrame(spec.dataset, index, options);
  Scene scene;
  scene.name = spec.name + "_" + spec.frame;
  scene.image = frame.image;
  scene.depth_m = frame.depth_m;
  scene.camera = frame.camera;
  if (spec.camera) {
    const CameraIntrinsics& c = *spec.camera;
    if ((c.width != 0 && c.width != frame.camera.width) ||
        (c.height != 0 && c.height != frame.camera.height))
      throw Error(spec.source, "camera size " + std::to_string(c.width) + "x" +
                                   std::to_string(c.height) + " differs from the frame (" +
                                   SizeText(frame.image.size()) + ")");
    scene.camera = {c.fx, c.fy, c.cx, c.cy, frame.camera.width, frame.camera.height};
  }
  const std::string frame_source = spec.dataset + "#" + spec.frame;
  if (cv::countNonZero(scene.depth_m == scene.depth_m) == 0)
    throw Error(frame_source, "no valid depth pixel (all zero)");
  scene.normals = NormalsFromDepth(scene.camera, scene.depth_m);
  scene.input_hashes[spec.source] = Sha256File(spec.source);
  // The .mat file is gigabytes: the hash covers the frame's values as read, not the whole file.
  scene.input_hashes[frame_source] = frame.sha256;
  try {
    scene.Validate();
  } catch (const Error& e) {
    throw Error(spec.source, e.what());
  }
  return scene;
}

}  // namespace

std::vector<std::string> ExpandSceneSpec(const std::string& spec) {
  if (IsBuiltinSpec(spec)) return {spec};
  const auto [json_path, frame_suffix] = SplitFrameSuffix(spec);
  std::error_code ec;
  // A spec naming a frame, or no file at all (LoadScene reports that in its place), stays as is.
  if (!frame_suffix.empty() || !fs::is_regular_file(json_path, ec)) return {spec};
  const SceneFileSpec parsed = ParseSceneFile(json_path);
  if (parsed.type != "nyu_v2" && parsed.type != "folder") return {spec};
  std::vector<std::string> out;
  for (const std::string& key : parsed.frames) out.push_back(json_path + "#" + key);
  return out;
}

Scene BuildScene(const SceneFileSpec& spec) {
  if (spec.type == "builtin") {
    BuiltinSceneOptions options;
    options.scale = spec.builtin_scale;
    Scene scene = MakeBuiltinScene(spec.builtin, options);
    scene.name = spec.name;
    scene.input_hashes[spec.source] = Sha256File(spec.source);
    return scene;
  }
  const bool multi_frame = spec.type == "nyu_v2" || spec.type == "folder";
  if (multi_frame && spec.frame.empty())
    throw Error(spec.source, "selects " + std::to_string(spec.frames.size()) + " frames (" +
                                 spec.frames.front() + " .. " + spec.frames.back() +
                                 "); load one as '" + spec.source + "#" + spec.frames.front() +
                                 "', or list the file in a generate config (it expands to every "
                                 "selected frame)");
  if (spec.type == "nyu_v2") return BuildNyuScene(spec);
  Scene scene;
  scene.name = multi_frame ? spec.name + "_" + spec.frame : spec.name;
  ReadImageOptions image_options;
  image_options.transfer = spec.color;
  scene.image = ReadImage(spec.image, image_options);
  CheckImageRange(spec.image, scene.image);
  const cv::Size size = scene.image.size();
  if (!spec.camera) throw Error(spec.source, "no camera intrinsics");
  scene.camera = *spec.camera;
  if ((scene.camera.width != 0 && scene.camera.width != size.width) ||
      (scene.camera.height != 0 && scene.camera.height != size.height))
    throw Error(spec.source, "camera size " + std::to_string(scene.camera.width) + "x" +
                                 std::to_string(scene.camera.height) + " differs from image " +
                                 spec.image + " (" + SizeText(size) + ")");
  scene.camera.width = size.width;
  scene.camera.height = size.height;

  const std::string& geometry_path = spec.type == "stereo" ? spec.disparity : spec.depth;
  const RawDepthFile raw_file = ReadRawDepthFile(geometry_path);
  const cv::Mat& raw = raw_file.values;
  if (raw.size() != size)
    throw Error(geometry_path, "size " + SizeText(raw.size()) + " differs from image " + spec.image +
                                   " (" + SizeText(size) + ")");
  if (spec.type == "stereo") {
    if (raw.channels() != 1)
      throw Error(geometry_path, "disparity must have 1 channel, found " + std::to_string(raw.channels()));
    for (int y = 0; y < raw.rows; ++y)
      for (int x = 0; x < raw.cols; ++x)
        if (raw.at<float>(y, x) < 0.0f)
          throw Error(geometry_path, "negative disparity at pixel (" + std::to_string(x) + ", " +
                                         std::to_string(y) + ")");
    scene.depth_m = DepthFromDisparity(raw / spec.disparity_scale, scene.camera.fx, spec.baseline_m,
                                       spec.doffs_px);
  } else {
    double depth_scale = spec.depth_scale;
    if (depth_scale == 0.0) {  // folder without "depth_scale"
      if (raw_file.integer)
        throw Error(spec.source, "'depth_scale' is required for integer depth files such as " +
                                     geometry_path + " (file units per metre, e.g. 1000 for mm)");
      depth_scale = 1.0;
    }
    scene.depth_m = DepthFromRaw(geometry_path, raw, depth_scale);
    if (spec.depth_is_range) scene.depth_m = DepthFromRange(scene.camera, scene.depth_m);
  }
  if (cv::countNonZero(scene.depth_m == scene.depth_m) == 0)
    throw Error(geometry_path, "no valid depth pixel (all zero, unknown or non-finite)");
  scene.normals = NormalsFromDepth(scene.camera, scene.depth_m);
  scene.dominant_plane = spec.plane;
  scene.dvl_points_in_camera = spec.dvl;
  scene.input_hashes[spec.source] = Sha256File(spec.source);
  scene.input_hashes[spec.image] = Sha256File(spec.image);
  scene.input_hashes[geometry_path] = Sha256File(geometry_path);
  try {
    scene.Validate();
  } catch (const Error& e) {
    throw Error(spec.source, e.what());
  }
  return scene;
}

Scene LoadSceneFile(const std::string& json_path) { return BuildScene(ParseSceneFile(json_path)); }

}  // namespace turbid
