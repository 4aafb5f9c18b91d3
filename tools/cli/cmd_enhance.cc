// `turbid enhance --method M IN OUT [--sidecar S.json] [--scene SPEC] [--param k=v ...]
//  [--dump-steps DIR] [--force]` and `turbid enhance --list`. docs/cli/enhance.md.
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/json_io.h"
#include "enhancer/registry.h"
#include "metrics/registry.h"
#include "scenes/image_io.h"
#include "scenes/scene_loader.h"
#include "tools/cli/cli.h"
#include "tools/harness/file_context.h"
#include "tools/harness/file_encoding.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct EnhanceArgs {
  bool list = false;
  bool json_list = false;
  std::string method;
  std::string in, out;
  std::string sidecar, scene;
  double scale = 0.0;  // built-in scene scale; 0: the sidecar's, else 1
  std::vector<std::string> params;
  std::string dump_steps;
  std::string transfer = "auto";
  int bit_depth = 8;
  bool force = false;
};

// "k=v": v parsed as JSON when it is valid JSON (numbers, true/false, quoted strings), else taken
// as a bare string (so --param clahe_distribution=uniform works).
json ParseParams(const std::vector<std::string>& items) {
  json params = json::object();
  for (const std::string& item : items) {
    const size_t eq = item.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw Error("--param '" + item + "': expected key=value");
    }
    const std::string key = item.substr(0, eq), text = item.substr(eq + 1);
    const std::string shown = item.size() > 60 ? item.substr(0, 57) + "..." : item;
    std::optional<json> value = ParseJsonIfValid(text, "--param '" + shown + "'");
    params[key] = value ? std::move(*value) : json(text);
  }
  return params;
}

void PrintList(bool as_json) {
  if (as_json) {
    json all = json::array();
    for (const MethodInfo& m : ListMethods()) {
      json params = json::array();
      for (const MethodParam& p : m.params) {
        params.push_back({{"name", p.name}, {"default", p.default_value}, {"doc", p.doc}});
      }
      all.push_back({{"name", m.name},
                     {"summary", m.summary},
                     {"source", m.source},
                     {"needs_geometry", m.needs_geometry},
                     {"needs_sidecar", m.needs_sidecar},
                     {"privileged", m.privileged},
                     {"inputs", m.inputs.empty() ? "the image alone" : m.inputs},
                     {"params", params}});
    }
    std::cout << all.dump(2) << "\n";
    return;
  }
  for (const MethodInfo& m : ListMethods()) {
    std::cout << m.name << (m.privileged ? " [privileged]" : "") << " — " << m.summary
              << "\n  source: " << m.source
              << "\n  reads: " << (m.inputs.empty() ? "the image alone" : m.inputs) << "\n";
    if (m.needs_geometry || m.needs_sidecar) {
      std::cout << "  uses:" << (m.needs_geometry ? " --scene" : "")
                << (m.needs_sidecar ? " --sidecar" : "") << "\n";
    }
    for (const MethodParam& p : m.params) {
      std::cout << "    " << p.name << " = " << p.default_value.dump() << "  " << p.doc << "\n";
    }
  }
}

json ReadJsonObjectFile(const std::string& path) {
  json j = ReadJsonFile(path);
  if (!j.is_object()) throw Error(path, "not a JSON object");
  return j;
}

// --dump-steps: the method's named steps (EnhanceInput::steps) as EXR files in `dir`, with
// Hautiere's e of each image step against the input (visible edges lost show) printed and
// collected; the method's notes and the edges go to steps.json.
class StepDumper : public StepSink {
 public:
  StepDumper(std::string dir, const cv::Mat& input, const WriteImageOptions& wo)
      : dir_(std::move(dir)), input_(input), options_(wo) {
    options_.bit_depth = 16;
    options_.overwrite = true;
  }

  void Image(const std::string& name, const cv::Mat& image, bool comparable) override {
    if (image.empty()) return;
    if (name != "00_input" && name != "99_output") names_.push_back(name);
    WriteImage((fs::path(dir_) / (name + ".exr")).string(), image, options_);
    if (comparable) EdgeGain(name, image);
  }
  void Note(const std::string& key, const json& value) override { notes_[key] = value; }

  void EdgeGain(const std::string& name, const cv::Mat& m) {
    cv::Mat clamped = cv::min(cv::max(m, 0.0), 1.0);
    MetricInputs mi;
    mi.image = clamped;
    mi.original = input_;
    const double e = ComputeMetrics({"hautiere_e"}, mi).at("hautiere_e");
    edges_.push_back({{"step", name}, {"hautiere_e", MetricValueToJson(e)}});
    std::cout << "  " << name << ": e = " << MetricValueToText(e) << "\n";
  }
  const json& notes() const { return notes_; }
  const json& edges() const { return edges_; }
  const std::vector<std::string>& names() const { return names_; }

 private:
  std::string dir_;
  const cv::Mat& input_;
  WriteImageOptions options_;
  json notes_ = json::object();
  json edges_ = json::array();
  std::vector<std::string> names_;  // the method's steps, in the order reported
};

// Enhance with every named step of the method written into a.dump_steps (docs/cli/enhance.md).
cv::Mat EnhanceDumpingSteps(const EnhanceArgs& a, const MethodInfo& info, const json& params,
                            EnhanceInput input, const WriteImageOptions& wo) {
  fs::create_directories(a.dump_steps);
  StepDumper dumper(a.dump_steps, input.image, wo);
  dumper.Image("00_input", input.image, false);
  std::cout << "visible edges against the input (Hautiere e, clamped to [0, 1]):\n";
  input.steps = &dumper;
  const cv::Mat out = Enhance(info.name, params, input);
  dumper.Image("99_output", out, true);
  json steps = {{"method", a.method}, {"params", params}};
  for (const auto& [key, value] : dumper.notes().items()) steps[key] = value;
  // Methods that log no "steps" note: the steps they reported, else one step.
  if (!steps.contains("steps")) {
    steps["steps"] =
        dumper.names().empty() ? json::array({"single step: " + a.method}) : json(dumper.names());
  }
  steps["visible_edges"] = dumper.edges();
  AtomicWriteText((fs::path(a.dump_steps) / "steps.json").string(), steps.dump(2) + "\n", true);
  return out;
}

void Run(const EnhanceArgs& a) {
  if (a.list) {
    PrintList(a.json_list);
    return;
  }
  if (a.method.empty()) throw Error("enhance: --method is required (see --list)");
  if (a.in.empty() || a.out.empty()) throw Error("enhance: IN and OUT are required");
  const MethodInfo& info = FindMethod(a.method);
  const json params = ParseParams(a.params);
  if (a.transfer != "auto" && a.transfer != "linear" && a.transfer != "srgb") {
    throw Error("enhance: --transfer must be auto, linear or srgb");
  }
  if (a.bit_depth != 8 && a.bit_depth != 16) throw Error("enhance: --bit-depth must be 8 or 16");
  if (!a.force && fs::exists(a.out)) throw Error(a.out, "exists (use --force to replace it)");

  std::optional<json> sidecar_json;
  std::optional<RenderRecord> sidecar;
  if (!a.sidecar.empty()) {
    sidecar_json = ReadJsonObjectFile(a.sidecar);
    sidecar = RenderRecord::FromJson(*sidecar_json, a.sidecar);
  }
  // How the input's integer values are coded: --transfer, else what the sidecar (given, or the
  // render's OUT.json / scene.json beside the input) records, else sRGB as a camera writes.
  // Every method works on the decoded, linear image.
  std::optional<KnownEncoding> recorded;
  if (sidecar) {
    if (auto name = SidecarEncoding(*sidecar_json)) recorded = KnownEncoding{*name, a.sidecar};
  }
  if (!recorded) recorded = EncodingBeside(a.in);
  std::string transfer = a.transfer;
  if (transfer == "auto") {
    transfer = recorded ? recorded->name : "srgb";
  } else {
    WarnOnEncodingMismatch("enhance", "--transfer", KnownEncoding{transfer, "given"}, a.in,
                           recorded);
  }
  ReadImageOptions ro;
  ro.transfer = transfer == "srgb" ? Transfer::kSrgb : Transfer::kLinear;
  EnhanceInput input;
  input.image = WithFileContext(a.in, "reading it", [&] { return ReadImage(a.in, ro); });
  input.sidecar = sidecar ? &*sidecar : nullptr;
  // The scene: --scene, else the one the sidecar names (turbid render records its spec).
  std::string spec = a.scene;
  double scale = a.scale;
  const bool sidecar_names_scene = sidecar && sidecar->scene.spec;
  if (spec.empty() && sidecar_names_scene && info.needs_geometry) {
    spec = *sidecar->scene.spec;
  }
  // The render's scale, also when --scene names the same scene the sidecar does.
  if (scale == 0.0 && sidecar_names_scene && *sidecar->scene.spec == spec) {
    scale = sidecar->scene.builtin_scale.value_or(1.0);
  }
  std::optional<Scene> scene;
  if (!spec.empty()) {
    LoadSceneOptions so;
    so.builtin_scale = scale == 0.0 ? 1.0 : scale;
    scene = LoadScene(spec, so);
  }
  input.scene = scene ? &*scene : nullptr;
  if (info.needs_sidecar && !input.sidecar) {
    throw Error("enhance: method '" + a.method + "' needs --sidecar");
  }

  WriteImageOptions wo;
  wo.bit_depth = a.bit_depth;
  wo.transfer = ro.transfer;
  wo.overwrite = a.force;
  cv::Mat out;
  if (!a.dump_steps.empty()) {
    out = EnhanceDumpingSteps(a, info, params, input, wo);
  } else {
    out = Enhance(a.method, params, input);
  }
  WriteImage(a.out, out, wo);
  std::cout << "wrote " << a.out << "\n";
}

}  // namespace

void AddEnhanceCommand(CLI::App& app) {
  auto args = std::make_shared<EnhanceArgs>();
  CLI::App* cmd = app.add_subcommand("enhance", "enhance a degraded image with a named method");
  cmd->add_flag("--list", args->list, "list the methods with their parameters and defaults");
  cmd->add_flag("--json", args->json_list, "with --list: print JSON");
  cmd->add_option("--method,-m", args->method, "method name (see --list)");
  PathOption(cmd->add_option("IN", args->in, "degraded image"));
  PathOption(cmd->add_option("OUT", args->out, "output image (.png, .exr, .pfm)"));
  PathOption(cmd->add_option("--sidecar", args->sidecar,
                             "the render's sidecar JSON (oracle; lights for full)"));
  PathOption(cmd->add_option("--scene", args->scene,
                             "scene spec (builtin:NAME or scene JSON) for geometry"));
  cmd->add_option("--scale", args->scale, "built-in scene scale (default: the sidecar's, else 1)");
  cmd->add_option("--param,-p", args->params, "parameter override KEY=VALUE (repeatable)")
      ->type_name("KEY=VALUE")
      ->allow_extra_args(false);  // one value per -p, so positionals may follow
  PathOption(cmd->add_option("--dump-steps", args->dump_steps,
                             "write every intermediate into this folder"));
  cmd->add_option("--transfer", args->transfer,
                  "input/output coding: auto (the sidecar's encoding, else srgb), srgb or linear");
  cmd->add_option("--bit-depth", args->bit_depth, "PNG output bits: 8 or 16");
  cmd->add_flag("--force", args->force, "replace existing outputs");
  cmd->callback([args] {
    if (args->list || args->in.empty()) return Run(*args);
    // Out of memory or an OpenCV failure in a method names the input and the method.
    WithFileContext(args->in, "enhancing it with '" + args->method + "'", [&] { Run(*args); });
  });
  cmd->footer("Example: turbid enhance -m dcp sea.png sea_dcp.png");
}

}  // namespace turbid
