// `turbid scene`: load and validate scenes (built-in or scene files), write their clean image,
// depth and normals, print a summary. Reference: docs/cli/scene.md.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/safe_name.h"
#include "scenes/builtin.h"
#include "scenes/camera_encoding.h"
#include "scenes/image_io.h"
#include "scenes/scene_loader.h"
#include "scenes/scene_summary.h"
#include "tools/cli/cli.h"
#include "turbid_version.h"

namespace turbid {
namespace {
namespace fs = std::filesystem;

// TUM / ICL-NUIM depth PNG convention: 5000 units per metre, so 16 bits reach 13.107 m.
constexpr double kPng16DepthUnitsPerM = 5000.0;

struct SceneArgs {
  std::vector<std::string> specs;
  std::vector<std::string> builtins;
  std::string out_dir;
  bool force = false;
  std::string depth_format = "exr";
  std::string normals_format = "png";
  bool image_exr = false;
  std::string encoding = "srgb";
  double scale = 1.0;
};

std::string Fixed(double value, int digits) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*f", digits, value);
  return buffer;
}

// Normals as an image: channel order (z, y, x) so that file R = x, G = y, B = z.
cv::Mat NormalsForFile(const cv::Mat& normals, bool visualise) {
  std::vector<cv::Mat> xyz;
  cv::split(normals, xyz);
  std::vector<cv::Mat> zyx = {xyz[2], xyz[1], xyz[0]};
  cv::Mat out;
  cv::merge(zyx, out);
  if (visualise) {
    out.convertTo(out, -1, 0.5, 0.5);  // [-1, 1] -> [0, 1]; NaN stays NaN, written as 0
  }
  return out;
}

struct PlannedFile {
  std::string path;
  std::function<void(const std::string& path, bool overwrite)> write;
};

// Clean image: 8-bit PNG coded with --encoding (sRGB by default) through the same camera
// quantiser as `turbid render`, so an identity render scores SSIM 1 against it; linear float
// EXR on request (lossless).
void PlanImage(const Scene& scene, const SceneArgs& args, const fs::path& dir,
               std::vector<PlannedFile>* plan, nlohmann::json* files, nlohmann::json* scene_file) {
  const CameraEncoding encoding = CameraEncodingFromName(args.encoding, "--encoding");
  plan->push_back(
      {(dir / "image.png").string(), [&scene, encoding](const std::string& path, bool overwrite) {
         WriteImageOptions options;
         options.transfer = TransferFor(encoding);
         options.overwrite = overwrite;
         WriteImage(path, QuantiseEncoded(scene.image, encoding, 8), options);
       }});
  (*files)["image"] = "image.png";
  (*files)["image_encoding"] = CameraEncodingName(encoding);
  if (args.image_exr) {
    plan->push_back(
        {(dir / "image.exr").string(), [&scene](const std::string& path, bool overwrite) {
           WriteImageOptions options;
           options.overwrite = overwrite;
           WriteImage(path, scene.image, options);
         }});
    (*files)["image_exr"] = "image.exr";
    (*scene_file)["image"] = "image.exr";
    (*scene_file)["color"] = "linear";
  } else {
    (*scene_file)["image"] = "image.png";
    (*scene_file)["color"] = CameraEncodingName(encoding);
  }
}

// Depth: float metres in EXR (NaN = invalid), or TUM-style 16-bit PNG (x5000, 0 = invalid).
void PlanDepth(const Scene& scene, const SceneArgs& args, const fs::path& dir,
               std::vector<PlannedFile>* plan, nlohmann::json* files, nlohmann::json* scene_file) {
  if (args.depth_format == "png16") {
    const DepthStats stats = ComputeDepthStats(scene.depth_m);
    if (stats.max_m * kPng16DepthUnitsPerM > 65535.0)
      throw Error(
          "scene " + scene.name,
          "depth reaches " + Fixed(stats.max_m, 3) +
              " m, beyond the 16-bit PNG range (13.107 m at 5000/m); use --depth-format exr");
    plan->push_back(
        {(dir / "depth.png").string(), [&scene](const std::string& path, bool overwrite) {
           WriteImageOptions options;
           options.bit_depth = 16;
           options.raw = true;
           options.overwrite = overwrite;
           WriteImage(path, scene.depth_m * kPng16DepthUnitsPerM, options);
         }});
    (*files)["depth"] = "depth.png";
    (*scene_file)["type"] = "rgbd";
    (*scene_file)["depth"] = "depth.png";
    (*scene_file)["depth_scale"] = kPng16DepthUnitsPerM;
  } else {
    plan->push_back(
        {(dir / "depth.exr").string(), [&scene](const std::string& path, bool overwrite) {
           WriteImageOptions options;
           options.overwrite = overwrite;
           WriteImage(path, scene.depth_m, options);
         }});
    (*files)["depth"] = "depth.exr";
    (*scene_file)["type"] = "depth";
    (*scene_file)["depth"] = "depth.exr";
    (*scene_file)["depth_scale"] = 1.0;
  }
}

void PlanNormals(const Scene& scene, const SceneArgs& args, const fs::path& dir,
                 std::vector<PlannedFile>* plan, nlohmann::json* files) {
  if (args.normals_format == "png" || args.normals_format == "both") {
    plan->push_back(
        {(dir / "normals.png").string(), [&scene](const std::string& path, bool overwrite) {
           WriteImageOptions options;
           options.overwrite = overwrite;
           WriteImage(path, NormalsForFile(scene.normals, true), options);
         }});
    (*files)["normals"] = "normals.png";
  }
  if (args.normals_format == "exr" || args.normals_format == "both") {
    plan->push_back(
        {(dir / "normals.exr").string(), [&scene](const std::string& path, bool overwrite) {
           WriteImageOptions options;
           options.overwrite = overwrite;
           WriteImage(path, NormalsForFile(scene.normals, false), options);
         }});
    (*files)["normals_exr"] = "normals.exr";
  }
}

// Everything one scene writes, decided before anything is written.
std::vector<PlannedFile> PlanOutputs(const Scene& scene, const SceneArgs& args, const fs::path& dir,
                                     nlohmann::json* files) {
  std::vector<PlannedFile> plan;
  nlohmann::json scene_file = {
      {"name", scene.name},
      {"camera", scene.camera_unknown ? nlohmann::json("unknown") : CameraToJson(scene.camera)}};
  PlanImage(scene, args, dir, &plan, files, &scene_file);
  PlanDepth(scene, args, dir, &plan, files, &scene_file);
  PlanNormals(scene, args, dir, &plan, files);
  if (scene.dominant_plane) scene_file["plane"] = PlaneToJson(*scene.dominant_plane);
  if (!scene.dvl_points_in_camera.empty()) {
    nlohmann::json dvl = nlohmann::json::array();
    for (const cv::Vec3d& p : scene.dvl_points_in_camera) dvl.push_back({p[0], p[1], p[2]});
    scene_file["dvl"] = dvl;
  }
  const std::string scene_text = scene_file.dump(2) + "\n";
  plan.push_back(
      {(dir / "scene.json").string(), [scene_text](const std::string& path, bool overwrite) {
         AtomicWriteText(path, scene_text, overwrite);
       }});
  (*files)["scene"] = "scene.json";
  return plan;
}

std::string HumanSummary(const Scene& scene) {
  const DepthStats depth = ComputeDepthStats(scene.depth_m);
  std::ostringstream s;
  s << scene.name << ": " << scene.width() << "x" << scene.height() << ", "
    << (scene.channels() == 1 ? "gray" : "color") << "; depth " << Fixed(depth.min_m, 3) << ".."
    << Fixed(depth.max_m, 3) << " m (median " << Fixed(depth.median_m, 3) << "), "
    << Fixed(100.0 * depth.valid_fraction, 1) << "% valid\n";
  s << "  camera fx " << Fixed(scene.camera.fx, 2) << " fy " << Fixed(scene.camera.fy, 2) << " cx "
    << Fixed(scene.camera.cx, 2) << " cy " << Fixed(scene.camera.cy, 2)
    << (scene.camera_unknown ? " (camera unknown: range = depth)" : "") << "\n";
  if (scene.dominant_plane) {
    const Plane& p = *scene.dominant_plane;
    s << "  plane n (" << Fixed(p.normal[0], 3) << ", " << Fixed(p.normal[1], 3) << ", "
      << Fixed(p.normal[2], 3) << "), d " << Fixed(p.offset_m, 3) << " m";
  } else {
    s << "  plane: none";
  }
  s << "; " << scene.dvl_points_in_camera.size() << " DVL points\n";
  return s.str();
}

// The specs given and the --builtin names (all: every built-in scene).
std::vector<std::string> SceneSpecs(const SceneArgs& args) {
  std::vector<std::string> specs = args.specs;
  for (const std::string& name : args.builtins) {
    if (name == "all") {
      for (const std::string& n : BuiltinSceneNames()) specs.push_back("builtin:" + n);
    } else {
      specs.push_back("builtin:" + name);
    }
  }
  if (specs.empty()) throw Error("turbid scene", "no scene given (SPEC... or --builtin NAME|all)");
  return specs;
}

// 1. Load and validate everything before writing anything; `sources` gets each scene's spec.
std::vector<Scene> LoadScenes(const std::vector<std::string>& specs, const SceneArgs& args,
                              std::vector<std::string>* sources) {
  LoadSceneOptions load;
  load.builtin_scale = args.scale;
  std::vector<Scene> scenes;
  std::set<std::string> names;
  std::map<std::string, std::string> folder_names;  // FileNameKey -> scene name
  for (const std::string& spec : specs) {
    if (spec.rfind("builtin:", 0) == 0) {
      const std::string name = spec.substr(8);
      bool known = false;
      for (const std::string& n : BuiltinSceneNames()) known = known || n == name;
      if (!known) {
        std::string list;
        for (const std::string& n : BuiltinSceneNames()) list += (list.empty() ? "" : ", ") + n;
        throw Error("--builtin " + name, "unknown built-in scene (known: " + list + ", all)");
      }
    }
    Scene scene = LoadScene(spec, load);
    if (!names.insert(scene.name).second) {
      if (args.out_dir.empty()) continue;  // the same scene twice: nothing to write twice
      throw Error(spec, "scene name '" + scene.name +
                            "' is used twice; outputs would collide (set a different \"name\")");
    }
    if (!args.out_dir.empty()) {
      // The name is the scene's folder under --out: one plain component, one folder per scene.
      std::string why;
      if (!IsSafeFileComponent(scene.name, &why))
        throw Error(spec, "scene name '" + PrintableName(scene.name) + "' " + why);
      const auto [it, inserted] = folder_names.emplace(FileNameKey(scene.name), scene.name);
      if (!inserted) {
        throw Error(spec, "scene names '" + it->second + "' and '" + scene.name +
                              "' differ only in case; their folders would collide on a "
                              "case-insensitive file system (set a different \"name\")");
      }
    }
    scenes.push_back(std::move(scene));
    sources->push_back(spec);
  }
  return scenes;
}

// 2. Plan every output and refuse before writing if one exists (unless --force).
std::vector<std::vector<PlannedFile>> PlanScenes(const std::vector<Scene>& scenes,
                                                 const std::vector<std::string>& sources,
                                                 const SceneArgs& args) {
  std::vector<std::vector<PlannedFile>> plans(scenes.size());
  if (args.out_dir.empty()) return plans;
  std::error_code ec;
  if (fs::exists(args.out_dir, ec) && !fs::is_directory(args.out_dir, ec))
    throw Error(args.out_dir, "exists and is not a folder");
  for (size_t i = 0; i < scenes.size(); ++i) {
    nlohmann::json files;
    plans[i] = PlanOutputs(scenes[i], args, fs::path(args.out_dir) / scenes[i].name, &files);
    files["summary"] = "summary.json";
    nlohmann::json summary = SceneSummaryJson(scenes[i]);
    summary["source"] = sources[i];
    summary["files"] = files;
    summary["turbid_version"] = TURBID_VERSION;
    const std::string text = summary.dump(2) + "\n";
    plans[i].push_back({(fs::path(args.out_dir) / scenes[i].name / "summary.json").string(),
                        [text](const std::string& path, bool overwrite) {
                          AtomicWriteText(path, text, overwrite);
                        }});
    if (!args.force) {
      for (const PlannedFile& file : plans[i])
        if (fs::exists(file.path, ec))
          throw Error(file.path, "already exists (use --force to overwrite)");
    }
  }
  return plans;
}

void RunScene(const SceneArgs& args) {
  if (!(args.scale > 0.0 && args.scale <= 1.0)) throw Error("--scale", "must be in (0, 1]");
  const std::vector<std::string> specs = SceneSpecs(args);
  std::vector<std::string> sources;
  const std::vector<Scene> scenes = LoadScenes(specs, args, &sources);
  const std::vector<std::vector<PlannedFile>> plans = PlanScenes(scenes, sources, args);

  // 3. Write (each file atomically) and report.
  for (size_t i = 0; i < scenes.size(); ++i) {
    std::cout << HumanSummary(scenes[i]);
    if (args.out_dir.empty()) continue;
    const fs::path dir = fs::path(args.out_dir) / scenes[i].name;
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) throw Error(dir.string(), "cannot create folder: " + ec.message());
    std::string written;
    for (const PlannedFile& file : plans[i]) {
      file.write(file.path, args.force);
      written += " " + fs::path(file.path).filename().string();
    }
    std::cout << "  wrote " << dir.string() << "/:" << written << "\n";
  }
}

}  // namespace

void AddSceneCommand(CLI::App& app) {
  auto args = std::make_shared<SceneArgs>();
  CLI::App* cmd = app.add_subcommand(
      "scene", "load and validate scenes; write clean image, depth and normals; print a summary");
  PathOption(cmd->add_option(
      "specs", args->specs,
      "scenes: builtin:NAME, a built-in name (hull, seafloor, room) or a scene JSON file"));
  cmd->add_option("--builtin", args->builtins, "a built-in scene to add, or 'all' (repeatable)")
      ->type_name("NAME")
      ->allow_extra_args(false);
  PathOption(
      cmd->add_option("--out", args->out_dir,
                      "output folder (one sub-folder per scene); without it nothing is written"));
  cmd->add_flag("--force", args->force, "overwrite existing outputs");
  cmd->add_option("--depth-format", args->depth_format,
                  "exr: float32 metres, NaN = invalid; png16: 16-bit, 5000 per metre, 0 = invalid")
      ->check(CLI::IsMember({"exr", "png16"}))
      ->capture_default_str();
  cmd->add_option("--normals-format", args->normals_format,
                  "png: 8-bit visualisation (n + 1) / 2; exr: float32 unit vectors; both")
      ->check(CLI::IsMember({"png", "exr", "both"}))
      ->capture_default_str();
  cmd->add_flag("--image-exr", args->image_exr,
                "also write the clean image as linear float32 EXR (scene.json then points at it)");
  cmd->add_option("--scale", args->scale, "size scale for built-in scenes, in (0, 1]")
      ->capture_default_str();
  cmd->add_option("--encoding", args->encoding,
                  "image.png coding: srgb (as cameras, the default) or linear")
      ->check(CLI::IsMember({"srgb", "linear"}))
      ->capture_default_str();
  cmd->callback([args]() { RunScene(*args); });
  cmd->footer("Example: turbid scene builtin:seafloor --out clean");
}

}  // namespace turbid
