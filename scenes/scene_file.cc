// Scene JSON files and the dataset adapters they drive (TUM / ICL-NUIM RGB-D, float depth, stereo
// disparity, NYU Depth v2 labelled file, RGB-D folders). Schema: docs/formats.md.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/fields.h"
#include "core/json_io.h"
#include "core/limits.h"
#include "core/safe_name.h"
#include "scenes/builtin.h"
#include "scenes/folder_dataset.h"
#include "scenes/image_io.h"
#include "scenes/normals.h"
#include "scenes/nyu_depth_v2.h"
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

std::string FormatNumber(double value) {
  std::ostringstream s;
  s << value;
  return s.str();
}

[[noreturn]] void Fail(const std::string& file, const std::string& problem) {
  throw Error(file, problem);
}

// Reads a JSON object through a sub-table (camera, plane) inside a Custom field: returns the
// problem ("" when read), the key named relative to the field ("unknown key 'skew' (known: ...)",
// "'fx': expected a number"); every key in `required` must be present.
template <typename S>
std::string ReadObject(const Fields<S>& table, const json& v,
                       const std::vector<std::string>& required, S* out) {
  if (!v.is_object()) return "expected an object, got " + fields_detail::ShownValue(v);
  for (auto it = v.begin(); it != v.end(); ++it) {
    const typename Fields<S>::Field* field = table.Find(it.key());
    if (field == nullptr) {
      std::string known;
      for (const std::string& k : table.Keys()) known += (known.empty() ? "" : ", ") + k;
      return "unknown key '" + PrintableName(it.key()) + "' (known: " + known + ")";
    }
    const std::string problem = field->read(it.value(), *out);
    if (!problem.empty()) return "'" + it.key() + "': " + problem;
  }
  for (const std::string& key : required)
    if (!v.contains(key)) return "missing required key '" + key + "'";
  return "";
}

const Fields<CameraIntrinsics>& CameraFields() {
  static const Fields<CameraIntrinsics> fields =
      Fields<CameraIntrinsics>()
          .Number("fx", &CameraIntrinsics::fx, "focal length along x, pixels (non-zero)")
          .Number("fy", &CameraIntrinsics::fy,
                  "focal length along y, pixels (non-zero; negative = image y axis up)")
          .Number("cx", &CameraIntrinsics::cx, "principal point x, pixels")
          .Number("cy", &CameraIntrinsics::cy, "principal point y, pixels")
          .Integer("width", &CameraIntrinsics::width, "image width (checked against the image)", 1,
                   1 << 16)
          .Integer("height", &CameraIntrinsics::height, "image height (checked against the image)",
                   1, 1 << 16);
  return fields;
}

std::string ReadCamera(const json& v, SceneFileSpec& spec) {
  return ReadCameraValue(v, &spec.camera, &spec.camera_unknown);
}

json WriteCamera(const SceneFileSpec& spec) {
  return CameraValue(spec.camera, spec.camera_unknown);
}

struct PlaneKeys {
  cv::Vec3d normal{0.0, 0.0, 0.0};
  double offset_m = 0.0;
};

const Fields<PlaneKeys>& PlaneFields() {
  static const Fields<PlaneKeys> fields =
      Fields<PlaneKeys>()
          .Array("normal", &PlaneKeys::normal, 3, "plane normal n (any length > 0), camera frame")
          .Number("offset_m", &PlaneKeys::offset_m, "d in n.X + d = 0, metres (scaled with n)");
  return fields;
}

std::string ReadPlane(const json& v, SceneFileSpec& spec) {
  PlaneKeys keys;
  std::string problem = ReadObject(PlaneFields(), v, {"normal", "offset_m"}, &keys);
  if (!problem.empty()) return problem;
  const double length = cv::norm(keys.normal);
  if (!(length > 1e-12)) return "'normal' must be non-zero";
  Plane plane{keys.normal / length, keys.offset_m / length};
  if (plane.offset_m < 0.0) {  // orient towards the camera
    plane.normal = -plane.normal;
    plane.offset_m = -plane.offset_m;
  }
  if (plane.offset_m == 0.0) return "passes through the camera centre (offset_m = 0)";
  spec.plane = plane;
  return "";
}

std::string ReadDvl(const json& v, SceneFileSpec& spec) {
  if (!v.is_array() || v.empty()) return "must be a non-empty array of [x, y, z]";
  spec.dvl.clear();
  for (size_t i = 0; i < v.size(); ++i) {
    std::vector<double> p;
    std::string problem = fields_detail::ArrayProblem(v[i], 3, NumberRange::Any(), &p);
    if (!problem.empty()) return "[" + std::to_string(i) + "]: " + problem;
    if (!(p[2] > 0.0))
      return "[" + std::to_string(i) + "] must have z > 0 (in front of the camera)";
    spec.dvl.push_back({p[0], p[1], p[2]});
  }
  return "";
}

// The keys of one scene-file type (docs/formats.md "Scene files"), built once per type.
Fields<SceneFileSpec> MakeSpecFields(const std::string& type) {
  using S = SceneFileSpec;
  Fields<S> f;
  f.String("type", &S::type, "rgbd, depth, stereo, builtin, nyu_v2 or folder")
      .String("name", &S::name, "scene name (default: the file's stem)");
  if (type == "builtin") {
    return f.String("builtin", &S::builtin, "built-in scene name (required)")
        .Number("scale", &S::builtin_scale, "size scale", NumberRange::AboveUpTo(0.0, 1.0));
  }
  if (type == "rgbd" || type == "depth" || type == "stereo")
    f.String("image", &S::image, "clean image file (required)");
  f.Choice("color", &S::color, {{"srgb", Transfer::kSrgb}, {"linear", Transfer::kLinear}},
           "how integer (8/16-bit) image files are coded");
  f.Custom(
      "camera", "preset name, \"unknown\" or object", "",
      "intrinsics: {fx, fy, cx, cy[, width, height]}, a preset, or \"unknown\" (range = depth)",
      [](const json& v, S& out) { return ReadCamera(v, out); },
      [](const S& in) { return WriteCamera(in); });
  if (type == "nyu_v2") {
    return f.String("file", &S::dataset, "the labelled .mat file (required)")
        .Boolean("crop_border", &S::crop_border, "crop to the NYU toolbox's valid region")
        .String("depth_dataset", &S::depth_dataset, "\"depths\" or \"rawDepths\"");
  }
  if (type == "folder") {
    f.String("folder", &S::dataset, "dataset root (required)")
        .String("rgb_dir", &S::rgb_dir, "colour subfolder")
        .String("depth_dir", &S::depth_dir, "depth subfolder");
  } else if (type == "stereo") {
    f.String("disparity", &S::disparity, "disparity file (required)")
        .Number("baseline_m", &S::baseline_m, "baseline, metres (required)", NumberRange::Above(0))
        .Number("disparity_scale", &S::disparity_scale, "file units per pixel of disparity",
                NumberRange::Above(0))
        .Number("doffs_px", &S::doffs_px, "x-difference of principal points, pixels",
                NumberRange::AtLeast(0));
  } else {
    f.String("depth", &S::depth, "depth file (required)");
  }
  if (type != "stereo") {
    f.Number("depth_scale", &S::depth_scale, "file units per metre", NumberRange::Above(0))
        .Choice("depth_kind", &S::depth_is_range, {{"z", false}, {"range", true}, {"ray", true}},
                "z-depth along the optical axis, or range along the ray (\"ray\" = \"range\")")
        .Choice("depth_resize", &S::depth_resize,
                {{"none", DepthResize::kNone}, {"stretch_nearest", DepthResize::kStretchNearest}},
                "a depth map on another grid: none = sizes must match; stretch_nearest")
        .Integer("depth_erode_px", &S::depth_erode_px,
                 "erode the valid-depth mask by this many depth-file pixels", 0, 64);
  }
  if (type != "folder") {
    f.Custom(
        "plane", "object", "", "known dominant plane {normal: [3], offset_m}, camera frame",
        [](const json& v, S& out) { return ReadPlane(v, out); },
        [](const S& in) -> json {
          if (!in.plane) return nullptr;
          return {{"normal", {in.plane->normal[0], in.plane->normal[1], in.plane->normal[2]}},
                  {"offset_m", in.plane->offset_m}};
        });
    f.Custom(
        "dvl", "array of [x, y, z]", "", "DVL beam hits, camera frame, metres (z > 0)",
        [](const json& v, S& out) { return ReadDvl(v, out); },
        [](const S& in) {
          json points = json::array();
          for (const cv::Vec3d& p : in.dvl) points.push_back({p[0], p[1], p[2]});
          return points;
        });
  }
  return f;
}

// What a scene file's keys read into: the spec, and the raw "frames" selection of nyu_v2 and
// folder (resolved once the frames are listed; null = every frame).
struct SceneFileKeys {
  SceneFileSpec spec;
  json frames;
};

const Fields<SceneFileKeys>& KeyFields(const std::string& type) {
  static const std::map<std::string, Fields<SceneFileKeys>> tables = [] {
    std::map<std::string, Fields<SceneFileKeys>> out;
    for (const char* t : {"rgbd", "depth", "stereo", "builtin", "nyu_v2", "folder"}) {
      Fields<SceneFileKeys> f;
      f.Nested("", &SceneFileKeys::spec, MakeSpecFields(t));
      if (std::string(t) == "nyu_v2" || std::string(t) == "folder") {
        f.Custom(
            "frames", "index, array or \"START:STOP[:STEP]\"", "", "frame selection",
            [](const json& v, SceneFileKeys& out) {
              out.frames = v;
              return std::string();
            },
            [](const SceneFileKeys& in) { return in.frames; });
      }
      out.emplace(t, std::move(f));
    }
    return out;
  }();
  return tables.at(type);
}

}  // namespace

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

namespace {

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
        throw Error(path, "negative depth value " + FormatNumber(v) + " at pixel (" +
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
        throw Error(path, "image value " + FormatNumber(row[i]) + " at pixel (" +
                              std::to_string(i / image.channels()) + ", " + std::to_string(y) +
                              ") is outside [0, 1] (float images must be linear albedo in [0, 1])");
    }
  }
}

// "FILE.json#KEY" -> (FILE.json, KEY) when FILE.json#KEY itself is not a file; (spec, "")
// otherwise.
std::pair<std::string, std::string> SplitFrameSuffix(const std::string& spec) {
  const size_t hash = spec.rfind('#');
  std::error_code ec;
  if (hash == std::string::npos || fs::exists(spec, ec)) return {spec, ""};
  return {spec.substr(0, hash), spec.substr(hash + 1)};
}

// Frame selection of a multi-frame scene file over `keys` (every frame, in order): absent = all;
// an index; an array of indices (or, when `stems`, file stems); "START:STOP[:STEP]" (half-open,
// as a Python slice with non-negative bounds; STOP may be empty = to the end).
std::vector<std::string> SelectFrames(const std::string& file, const json& selection,
                                      const std::vector<std::string>& keys, bool stems) {
  if (selection.is_null()) return keys;
  const json* value = &selection;
  struct {
    const std::string& file;
    [[noreturn]] void Fail(const std::string& problem) const { throw Error(file, problem); }
  } reader{file};
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
        reader.Fail("'frames' range '" + text +
                    "' must be START:STOP[:STEP] with non-negative integers");
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

// nyu_v2 and folder: the frame list, the selection and the frame to load.
void ParseMultiFrame(const std::string& json_path, const std::string& frame_suffix,
                     const json& selection, SceneFileSpec& spec) {
  auto fail = [&](const std::string& problem) { Fail(json_path, problem); };
  std::vector<std::string> keys;
  std::vector<FolderFrame> folder_frames;
  if (spec.type == "nyu_v2") {
    NyuFrameOptions options;
    options.depth_dataset = spec.depth_dataset;
    std::string why;
    if (!options.Check(&why)) fail("'depth_dataset': " + why);
    const int count = NyuFrameCount(spec.dataset, options);
    // A (crafted or sparse) file may claim billions of frames: one key each would exhaust memory.
    CheckItemCount(spec.dataset, "the dataset", count);
    for (int i = 0; i < count; ++i) keys.push_back(std::to_string(i));
  } else {  // folder
    FolderDatasetOptions options;
    options.rgb_dir = spec.rgb_dir;
    options.depth_dir = spec.depth_dir;
    folder_frames = ListFolderFrames(spec.dataset, options);
    for (const FolderFrame& f : folder_frames) keys.push_back(f.stem);
  }
  spec.frames = SelectFrames(json_path, selection, keys, spec.type == "folder");
  // A frame's key becomes part of its scene's name, and with it of file names.
  for (const std::string& key : spec.frames) {
    std::string why;
    if (!IsSafeFileComponent(key, &why)) fail("frame key '" + PrintableName(key) + "' " + why);
  }
  if (!frame_suffix.empty()) {
    if (std::find(keys.begin(), keys.end(), frame_suffix) == keys.end())
      fail("'#" + frame_suffix + "': no such frame (" +
           (spec.type == "nyu_v2" ? "0-based index, " + std::to_string(keys.size()) + " frames"
                                  : "a file stem in " + spec.dataset) +
           ")");
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

// The keys each type requires (beyond "type"); "camera" is handled by ParseSceneFile.
std::vector<std::string> RequiredKeys(const std::string& type) {
  if (type == "builtin") return {"builtin"};
  if (type == "rgbd" || type == "depth") return {"image", "depth"};
  if (type == "stereo") return {"image", "disparity", "baseline_m"};
  if (type == "nyu_v2") return {"file"};
  return {"folder"};
}

}  // namespace

std::string ReadCameraValue(const json& v, std::optional<CameraIntrinsics>* camera, bool* unknown) {
  if (v.is_string()) {
    const std::string& name = v.get_ref<const std::string&>();
    if (name == "unknown") {
      *unknown = true;
      camera->reset();
      return "";
    }
    try {
      *camera = CameraPreset(name);
    } catch (const Error& e) {
      return e.what();
    }
    *unknown = false;
    return "";
  }
  CameraIntrinsics read;
  std::string problem = ReadObject(CameraFields(), v, {"fx", "fy", "cx", "cy"}, &read);
  if (!problem.empty()) return problem;
  if (read.fx == 0.0 || read.fy == 0.0) return "'fx' and 'fy' must be non-zero";
  *camera = read;
  *unknown = false;
  return "";
}

json CameraValue(const std::optional<CameraIntrinsics>& camera, bool unknown) {
  if (unknown) return "unknown";
  if (!camera) return nullptr;
  return CameraFields().ToJson(*camera);
}

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
  if (!root.is_object()) fields_detail::ThrowNotAnObject(json_path, "", root);
  if (!root.contains("type")) Fail(json_path, "missing required key 'type'");
  const std::set<std::string> types = {"rgbd", "depth", "stereo", "builtin", "nyu_v2", "folder"};
  const json& type = root.at("type");
  if (!type.is_string() || !types.count(type.get<std::string>()))
    Fail(json_path,
         "'type' must be one of " + Join(types) + ", got " + fields_detail::ShownValue(type));
  SceneFileKeys keys;
  SceneFileSpec& spec = keys.spec;
  spec.type = type.get<std::string>();
  if (spec.type == "rgbd") spec.depth_scale = 5000.0;  // TUM / ICL-NUIM
  if (spec.type == "depth") spec.depth_scale = 1.0;    // float metres
  KeyFields(spec.type).Read(root, &keys, json_path);
  for (const std::string& key : RequiredKeys(spec.type))
    if (!root.contains(key)) Fail(json_path, "missing required key '" + key + "'");
  spec.source = json_path;
  if (!root.contains("name")) spec.name = fs::path(json_path).stem().string();
  // The name becomes a folder (`turbid scene --out`) and part of file names (generate, sweep).
  std::string why;
  if (!IsSafeFileComponent(spec.name, &why))
    Fail(json_path, "scene name '" + PrintableName(spec.name) + "' " + why);
  const fs::path folder = fs::path(json_path).parent_path();
  const bool multi_frame = spec.type == "nyu_v2" || spec.type == "folder";
  if (!frame_suffix.empty() && !multi_frame)
    Fail(json_path, "'#" + frame_suffix +
                        "' selects a frame, which only nyu_v2 and folder scene files have (or no "
                        "file " +
                        spec_path + ")");
  if (spec.type == "builtin") {
    const std::vector<std::string> names = BuiltinSceneNames();
    if (std::find(names.begin(), names.end(), spec.builtin) == names.end())
      Fail(json_path, "'builtin': unknown scene '" + PrintableName(spec.builtin) + "'");
    return spec;
  }
  if (!root.contains("camera")) {
    if (spec.type == "rgbd") {
      spec.camera = CameraPreset("icl_nuim");  // the documented default for RGB-D frames
    } else if (spec.type != "nyu_v2") {        // nyu_v2: NyuKinectRgbCamera(), shifted when cropped
      Fail(json_path,
           "missing required key 'camera' (an object {fx, fy, cx, cy}, a preset name or "
           "\"unknown\")");
    }
  }
  if (spec.camera_unknown && spec.type == "stereo")
    Fail(json_path,
         "'camera': stereo needs the focal length (fx) for depth = B fx / d, not \"unknown\"");
  if (spec.camera_unknown && spec.type == "nyu_v2")
    Fail(json_path,
         "'camera': nyu_v2 frames have known intrinsics; \"unknown\" is for frames without");
  if (!spec.image.empty()) spec.image = Resolve(folder, spec.image, json_path);
  if (!spec.depth.empty()) spec.depth = Resolve(folder, spec.depth, json_path);
  if (!spec.disparity.empty()) spec.disparity = Resolve(folder, spec.disparity, json_path);
  if (!spec.dataset.empty()) spec.dataset = Resolve(folder, spec.dataset, json_path);
  if (multi_frame) ParseMultiFrame(json_path, frame_suffix, keys.frames, spec);
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

namespace {

// The scene's camera: the file's intrinsics (checked against the image size) or, for a frame
// without intrinsics, an unknown one.
void SetCamera(const SceneFileSpec& spec, cv::Size size, Scene* scene) {
  if (spec.camera_unknown) {
    scene->camera = UnknownCamera(size.width, size.height);
    scene->camera_unknown = true;
  } else {
    if (!spec.camera) throw Error(spec.source, "no camera intrinsics");
    scene->camera = *spec.camera;
  }
  if ((scene->camera.width != 0 && scene->camera.width != size.width) ||
      (scene->camera.height != 0 && scene->camera.height != size.height))
    throw Error(spec.source, "camera size " + std::to_string(scene->camera.width) + "x" +
                                 std::to_string(scene->camera.height) + " differs from image " +
                                 spec.image + " (" + SizeText(size) + ")");
  scene->camera.width = size.width;
  scene->camera.height = size.height;
}

// Metric depth from the geometry file: disparity (stereo) or depth in file units, with its
// invalid values, erosion, stretch and range-to-depth conversion.
void SetDepth(const SceneFileSpec& spec, const std::string& geometry_path,
              const RawDepthFile& raw_file, cv::Size size, Scene* scene) {
  const cv::Mat& raw = raw_file.values;
  if (spec.type == "stereo") {
    if (raw.channels() != 1)
      throw Error(geometry_path,
                  "disparity must have 1 channel, found " + std::to_string(raw.channels()));
    for (int y = 0; y < raw.rows; ++y)
      for (int x = 0; x < raw.cols; ++x)
        if (raw.at<float>(y, x) < 0.0f)
          throw Error(geometry_path, "negative disparity at pixel (" + std::to_string(x) + ", " +
                                         std::to_string(y) + ")");
    scene->depth_m = DepthFromDisparity(raw / spec.disparity_scale, scene->camera.fx,
                                        spec.baseline_m, spec.doffs_px);
  } else {
    double depth_scale = spec.depth_scale;
    if (depth_scale == 0.0) {  // folder without "depth_scale"
      if (raw_file.integer)
        throw Error(spec.source, "'depth_scale' is required for integer depth files such as " +
                                     geometry_path + " (file units per metre, e.g. 1000 for mm)");
      depth_scale = 1.0;
    }
    // Invalid first (0 -> NaN), erosion on the file's own grid (where bilinear downsampling left
    // its one-pixel seam of spurious values), then the stretch onto the image.
    scene->depth_m =
        ErodeValidDepth(DepthFromRaw(geometry_path, raw, depth_scale), spec.depth_erode_px);
    if (raw.size() != size) scene->depth_m = StretchNearest(scene->depth_m, size);
    if (spec.depth_is_range) scene->depth_m = DepthFromRange(scene->camera, scene->depth_m);
  }
}

}  // namespace

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
  SetCamera(spec, size, &scene);

  const std::string& geometry_path = spec.type == "stereo" ? spec.disparity : spec.depth;
  const RawDepthFile raw_file = ReadRawDepthFile(geometry_path);
  const cv::Mat& raw = raw_file.values;
  const bool resize = spec.type != "stereo" && spec.depth_resize != DepthResize::kNone;
  if (raw.size() != size && !resize)
    throw Error(geometry_path, "size " + SizeText(raw.size()) + " differs from image " +
                                   spec.image + " (" + SizeText(size) +
                                   "; \"depth_resize\": \"stretch_nearest\" stretches it)");
  SetDepth(spec, geometry_path, raw_file, size, &scene);
  if (cv::countNonZero(scene.depth_m == scene.depth_m) == 0)
    throw Error(geometry_path, "no valid depth pixel (all zero, unknown or non-finite)");
  scene.normals = NormalsFromDepth(
      spec.camera_unknown ? NominalCamera(size.width, size.height) : scene.camera, scene.depth_m);
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
