// turbid._turbid: the C++ half of the Python package. Thin: every function converts NumPy arrays
// (RGB at the boundary) to the cv::Mat the libraries take (BGR float32 linear [0, 1]), releases
// the GIL, calls the same library functions as the CLI, and converts back. Where the libraries
// can work in R, G, B order (RenderOptions::rgb_image, EnhanceInput::rgb) nothing is reordered
// and the result's buffer becomes the NumPy array. The pure-Python half
// (python/turbid/*.py) adds dict <-> JSON and docstrings. Reference: docs/python.md.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <nlohmann/json.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include <pthread.h>
#include <time.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "enhancer/registry.h"
#include "metrics/feature_matching.h"
#include "metrics/registry.h"
#include "core/error.h"
#include "scenes/image_io.h"
#include "core/input_file.h"
#include "core/json_io.h"
#include "core/limits.h"
#include "scenes/scene_loader.h"
#include "simulator/noise.h"
#include "simulator/phase_function.h"
#include "simulator/render.h"
#include "simulator/water.h"
#include "tools/harness/experiment.h"
#include "tools/harness/generate.h"
#include "tools/harness/harness_runner.h"
#include "tools/harness/metric_image.h"
#include "tools/harness/param_tree.h"
#include "tools/harness/sweep.h"
#include "python/src/common.h"
#include "turbid_version.h"

namespace py = pybind11;
using nlohmann::json;

namespace turbid {
namespace {

using namespace pyext;

// ---- scenes ------------------------------------------------------------------------------------

}  // namespace

PyScene pyext::SceneFromSpec(const std::string& spec, double scale) {
  PyScene s;
  s.spec = spec;
  s.scale = scale;
  WorkScope release;
  LoadSceneOptions options;
  options.builtin_scale = scale;
  ThrowIfInvalid(options, "scale");
  try {
    s.renderer = std::make_shared<Renderer>(LoadScene(spec, options));
  } catch (const Error& e) {
    if (LooksLikeIo(e.what())) throw IoError(e.what());
    throw;
  }
  return s;
}

namespace {

PyScene SceneFromArrays(const py::array& image, const py::array& depth_m, double fx, double fy,
                        double cx, double cy, const std::optional<py::array>& normals,
                        const std::string& name, const std::optional<std::string>& encoding) {
  const Encoding enc = ParseEncoding(encoding);
  const ArrayView iv = ViewArray(image, "image");
  const ArrayView dv = ViewArray(depth_m, "depth_m", /*allow_color=*/false);
  if (dv.mat.depth() != CV_32F) throw Error("depth_m: must be float32 metres (NaN = invalid)");
  if (dv.mat.size() != iv.mat.size()) throw Error("depth_m: size differs from the image's");
  std::optional<ArrayView> nv;
  if (normals) {
    nv = ViewArray(*normals, "normals");
    if (nv->mat.type() != CV_32FC3 || nv->mat.size() != iv.mat.size())
      throw Error("normals: must be float32 H x W x 3 (camera-frame x, y, z) like the image");
  }
  PyScene s;
  WorkScope release;
  Scene scene;
  scene.name = name;
  scene.camera = {fx, fy, cx, cy, iv.mat.cols, iv.mat.rows};
  // The scene outlives the call: it owns its pixels (the Renderer's copy shares them).
  scene.image = ToInternal(iv, enc, "image");
  if (scene.image.data == iv.mat.data) scene.image = scene.image.clone();
  if (cv::checkRange(scene.image, /*quiet=*/true) == false)
    throw Error("image: contains NaN or infinite values");
  scene.depth_m = dv.mat.clone();
  if (nv) scene.normals = nv->mat.clone();
  s.renderer = std::make_shared<Renderer>(scene);
  return s;
}

// ---- render ------------------------------------------------------------------------------------

struct PyRenderResult {
  // result->image is in R, G, B order (RenderOptions::rgb_image).
  std::shared_ptr<RenderResult> result;
};

PyRenderResult RenderScene(const PyScene& scene, const std::string& params_text,
                           std::optional<uint64_t> seed, const std::string& maps) {
  json params = ExpandDottedParams(ParseJsonText(params_text, "params"), "params");
  if (seed) params["seed"] = *seed;  // turbid.render checked it (turbid._seed)
  PyRenderResult out;
  WorkScope release;
  RenderOptions options = RenderOptionsFromJson(params);
  options.maps = MapSelection::FromList(maps);
  options.rgb_image = true;  // written in NumPy's order by the render's last pass: no copy later
  out.result = std::make_shared<RenderResult>(scene.renderer->Render(options));
  if (!scene.spec.empty()) {
    out.result->sidecar.scene.spec = scene.spec;
    out.result->sidecar.scene.builtin_scale = scene.scale;
  }
  return out;
}

// ---- enhance / score -----------------------------------------------------------------------------

py::array EnhanceArray(const py::array& image, const std::string& method,
                       const std::string& params_text, const std::optional<std::string>& sidecar_text,
                       const std::optional<PyScene>& scene, const std::optional<std::string>& encoding) {
  const Encoding enc = ParseEncoding(encoding);
  const ArrayView iv = ViewArray(image, "image");
  const json params = ParseJsonText(params_text, "params");
  std::optional<RenderRecord> sidecar;
  if (sidecar_text)
    sidecar = RenderRecord::FromJson(ParseJsonText(*sidecar_text, "sidecar"), "sidecar");
  cv::Mat out;
  {
    WorkScope release;
    const MethodInfo& info = FindMethod(method);
    EnhanceInput input;
    input.image = ToInternal(iv, enc, "image", /*keep_rgb=*/true);
    input.rgb = true;  // methods that read R, G, B natively skip two reordering passes
    input.sidecar = sidecar ? &*sidecar : nullptr;
    // As the CLI: without a scene, a geometry method uses the scene the sidecar names.
    std::optional<Scene> loaded;
    if (scene) {
      input.scene = &scene->scene();
    } else if (sidecar && info.needs_geometry && sidecar->scene.spec) {
      LoadSceneOptions so;
      so.builtin_scale = sidecar->scene.builtin_scale.value_or(1.0);
      loaded = LoadScene(*sidecar->scene.spec, so);
      input.scene = &*loaded;
    }
    if (info.needs_sidecar && !input.sidecar)
      throw Error("enhance: method '" + method + "' needs sidecar=");
    out = Enhance(method, params, input);
  }
  return WrapNumpy(out);  // R, G, B already
}

std::string MatchArrays(const py::array& a, const py::array& b, const std::string& detector) {
  const MetricImage ia = MetricFromArray(ViewArray(a, "a")), ib = MetricFromArray(ViewArray(b, "b"));
  WorkScope release;
  FeatureMatchOptions options;
  options.detector = ParseFeatureDetector(detector);
  cv::Mat a01, b01;  // each with its own data range, as `turbid score --pairs`
  ia.pixels.convertTo(a01, CV_32F, 1.0 / ia.data_range);
  ib.pixels.convertTo(b01, CV_32F, 1.0 / ib.data_range);
  return MatchFeatures(options, a01, b01, 1.0).ToJson().dump();
}

// ---- generate / sweep / data ---------------------------------------------------------------------

// Experiment methods that name a key of turbid.sweep's `methods` dict become Python methods: a
// string "k" or an object {"name": "k", ...} without command/results/python gets "python": "k".
// Every key must be used; a key may not shadow a built-in method or the reserved rows.
json BindPythonMethods(json doc, const std::set<std::string>& keys) {
  if (keys.empty() || !doc.is_object() || !doc.contains("methods") || !doc["methods"].is_array())
    return doc;
  std::set<std::string> used;
  for (json& entry : doc["methods"]) {
    if (entry.is_string() && keys.count(entry.get<std::string>())) {
      entry = json{{"name", entry}, {"python", entry}};
    } else if (entry.is_object() && entry.contains("name") && entry["name"].is_string() &&
               keys.count(entry["name"].get<std::string>()) && !entry.contains("command") &&
               !entry.contains("results") && !entry.contains("python")) {
      entry["python"] = entry["name"];
    }
    if (entry.is_object() && entry.contains("python") && entry["python"].is_string())
      used.insert(entry["python"].get<std::string>());
  }
  for (const std::string& key : keys)
    if (!used.count(key))
      throw Error("methods: '" + key + "' is not a method of the experiment (list it in its "
                  "'methods', as \"" + key + "\" or {\"name\": \"" + key + "\", ...})");
  return doc;
}

// The first line of the Python exception being handled, "TypeName: message".
std::string PythonErrorLine(const py::error_already_set& e) {
  std::string type = "Exception";
  if (e.type()) type = py::str(e.type().attr("__name__")).cast<std::string>();
  std::string text = e.value() ? py::str(e.value()).cast<std::string>() : std::string();
  const size_t newline = text.find('\n');
  if (newline != std::string::npos) text = text.substr(0, newline);
  return text.empty() ? type : type + ": " + text;
}

// One returned image -> turbid's in-memory image. Lenient where NumPy code usually is: any array-
// like (a torch tensor on the CPU too) and float64 are accepted.
cv::Mat FromCallable(const py::handle& value, Encoding encoding, const std::string& what) {
  py::module_ np = py::module_::import("numpy");
  py::array arr = np.attr("asarray")(value).cast<py::array>();
  if (arr.ndim() >= 2) {  // over the size limit: refused before a copy or a conversion
    const std::string problem = ImageSizeProblem(arr.shape(1), arr.shape(0));
    if (!problem.empty()) throw Error(what + ": " + problem);
  }
  arr = np.attr("ascontiguousarray")(arr).cast<py::array>();
  if (arr.dtype().kind() == 'f' && arr.itemsize() != 4)
    arr = np.attr("ascontiguousarray")(arr.attr("astype")("float32")).cast<py::array>();
  else if (arr.dtype().kind() == 'b')
    throw Error(what + ": a boolean array is not an image");
  const ArrayView v = ViewArray(arr, what);
  cv::Mat m = ToInternal(v, encoding, what);
  return m.data == v.mat.data ? m.clone() : m;
}

// The InProcessMethod of one Python callable (borrowed: turbid.sweep's `methods` dict keeps it
// alive for the whole sweep). Takes the GIL for the call and the conversions.
InProcessMethod PythonCallable(py::handle fn) {
  return [fn](const json& spec, const std::vector<cv::Mat>& degraded,
              const std::vector<std::string>& ids) {
    const bool batch = spec.value("batch", false);
    const Encoding encoding =
        spec.value("encoding", std::string("linear")) == "srgb" ? Encoding::kSrgb : Encoding::kLinear;
    py::gil_scoped_acquire gil;
    std::vector<cv::Mat> out;
    try {
      py::list inputs;
      for (const cv::Mat& image : degraded)
        inputs.append(ToNumpy(encoding == Encoding::kSrgb ? LinearToSrgb(image) : image));
      if (!batch) {
        out.push_back(FromCallable(fn(inputs[0]), encoding, "returned array"));
        return out;
      }
      py::object result = fn(inputs);
      if (!py::isinstance<py::sequence>(result) || py::isinstance<py::str>(result))
        throw Error("a batch method must return a list of arrays, one per input, not " +
                    py::str(py::type::of(result).attr("__name__")).cast<std::string>());
      const py::sequence seq = result.cast<py::sequence>();
      if (seq.size() != degraded.size())
        throw Error("returned " + std::to_string(seq.size()) + " images for " +
                    std::to_string(degraded.size()) + " inputs");
      for (size_t k = 0; k < seq.size(); ++k)
        out.push_back(FromCallable(seq[k], encoding, "returned array for " + ids[k]));
    } catch (py::error_already_set& e) {
      throw Error(PythonErrorLine(e));
    } catch (const py::cast_error& e) {
      throw Error(std::string("returned value: ") + e.what());
    }
    return out;
  };
}

}  // namespace

json pyext::ExpandDottedParams(json params, const std::string& what) {
  return ExpandDottedKeys(std::move(params), what);  // tools/harness/param_tree.h
}

json pyext::ConfigFrom(const py::object& config, std::string* source) {
  if (py::isinstance<py::str>(config) || py::hasattr(config, "__fspath__")) {
    *source = py::str(py::module_::import("os").attr("fspath")(config));
    return ReadConfigFile(*source);
  }
  *source = "<dict>";
  return ParseJsonText(py::module_::import("json").attr("dumps")(config).cast<std::string>(),
                       "config");
}

namespace {

// ---- the module's definitions, by group ----------------------------------------------------------

void DefineScenes(py::module_& m) {
  py::class_<PyScene>(m, "Scene")
      .def_static("builtin", [](const std::string& name, double scale) {
        return SceneFromSpec(name.rfind("builtin:", 0) == 0 ? name : "builtin:" + name, scale);
      }, py::arg("name"), py::arg("scale") = 1.0)
      .def_static("load", [](const std::string& path) { return SceneFromSpec(path, 1.0); },
                  py::arg("path"))
      .def_static("from_arrays", &SceneFromArrays, py::arg("image"), py::arg("depth_m"),
                  py::arg("fx"), py::arg("fy"), py::arg("cx"), py::arg("cy"),
                  py::arg("normals") = py::none(), py::arg("name") = "arrays",
                  py::arg("encoding") = py::none())
      .def_property_readonly("name", [](const PyScene& s) { return s.scene().name; })
      .def_property_readonly("spec", [](const PyScene& s) { return s.spec; })
      .def_property_readonly("scale", [](const PyScene& s) { return s.scale; })
      .def_property_readonly("width", [](const PyScene& s) { return s.scene().width(); })
      .def_property_readonly("height", [](const PyScene& s) { return s.scene().height(); })
      .def_property_readonly("image", [](const PyScene& s) { return ToNumpy(s.scene().image); })
      .def_property_readonly("depth", [](const PyScene& s) { return ToNumpy(s.scene().depth_m); })
      .def_property_readonly("range", [](const PyScene& s) { return ToNumpy(s.renderer->range_m()); })
      .def_property_readonly("normals", [](const PyScene& s) {
        // Vectors, not colours: x, y, z order (no channel reordering).
        const cv::Mat& n = s.scene().normals;
        if (n.empty()) return py::array(py::none());
        py::array_t<float> out({n.rows, n.cols, 3});
        cv::Mat dst(n.rows, n.cols, CV_32FC3, out.mutable_data());
        n.copyTo(dst);
        return py::array(out);
      })
      .def_property_readonly("camera", [](const PyScene& s) {
        const CameraIntrinsics& c = s.scene().camera;
        py::dict d;
        d["fx"] = c.fx; d["fy"] = c.fy; d["cx"] = c.cx; d["cy"] = c.cy;
        d["width"] = c.width; d["height"] = c.height;
        return d;
      });

  py::class_<PyRenderResult>(m, "RenderResult")
      .def("image", [](const PyRenderResult& r) { return WrapNumpy(r.result->image); })
      .def("lit", [](const PyRenderResult& r) { return ToNumpy(r.result->lit); })
      .def("map", [](const PyRenderResult& r, const std::string& name) -> py::object {
        const RenderResult& x = *r.result;
        const cv::Mat* m = name == "transmission" ? &x.transmission : name == "light" ? &x.light
                         : name == "veil" ? &x.veil : name == "psf" ? &x.psf
                         : name == "noise" ? &x.noise : nullptr;
        if (m == nullptr) throw Error("unknown map '" + name + "'");
        if (m->empty()) return py::none();
        return ToNumpy(*m);
      })
      .def("sidecar", [](const PyRenderResult& r) { return r.result->sidecar.ToJson().dump(); })
      .def("plan", [](const PyRenderResult& r) { return r.result->plan.ToText(); });

  m.def("expand_scene_spec", [](const std::string& spec) {
    try {
      return ExpandSceneSpec(spec);
    } catch (const Error& e) {
      if (LooksLikeIo(e.what())) throw IoError(e.what());
      throw;
    }
  }, py::arg("spec"));
}

void DefineCalls(py::module_& m) {
  m.def("render", &RenderScene, py::arg("scene"), py::arg("params"), py::arg("seed"),
        py::arg("maps"));
  m.def("enhance", &EnhanceArray, py::arg("image"), py::arg("method"), py::arg("params"),
        py::arg("sidecar"), py::arg("scene"), py::arg("encoding"));
  m.def("match_features", &MatchArrays, py::arg("a"), py::arg("b"), py::arg("detector"));
  m.def("methods", [] {
    json all = json::array();
    for (const MethodInfo& mi : ListMethods()) {
      json params = json::object();
      json docs = json::object();
      for (const MethodParam& p : mi.params) {
        params[p.name] = p.default_value;
        docs[p.name] = p.doc;
      }
      all.push_back({{"name", mi.name}, {"summary", mi.summary}, {"source", mi.source},
                     {"needs_geometry", mi.needs_geometry}, {"needs_sidecar", mi.needs_sidecar},
                     {"privileged", mi.privileged}, {"params", params}, {"param_docs", docs}});
    }
    return all.dump();
  });
  m.def("metrics", [] {
    json all = json::array();
    for (const MetricInfo& mi : ListMetrics())
      all.push_back({{"name", mi.name}, {"summary", mi.summary},
                     {"needs_reference", mi.needs_reference},
                     {"needs_original", mi.needs_original},
                     {"higher_is_better", mi.higher_is_better}});
    return all.dump();
  });
  m.def("default_params", [] { return RenderOptionsToJson(RenderOptions{}).dump(); });
  m.def("resolve_params", [](const std::string& text) {
    return RenderOptionsToJson(
               RenderOptionsFromJson(ExpandDottedParams(ParseJsonText(text, "params"), "params")))
        .dump();
  });
}

void DefineFilesAndThreads(py::module_& m) {
  m.def("read_image", [](const std::string& path, const std::string& encoding) {
    ReadImageOptions o;
    o.transfer = ParseEncoding(encoding) == Encoding::kSrgb ? Transfer::kSrgb : Transfer::kLinear;
    cv::Mat image;
    {
      WorkScope release;
      image = ReadImage(path, o);
    }
    return ToNumpy(image);
  }, py::arg("path"), py::arg("encoding"));
  m.def("write_image", [](const std::string& path, const py::array& image, int bit_depth,
                          const std::string& encoding, bool overwrite) {
    const ArrayView v = ViewArray(image, "image");
    WorkScope release;
    // A new Mat for the BGR copy: converting into v.mat's header would swap the caller's array.
    cv::Mat m;
    if (v.channels == 3) {
      cv::cvtColor(v.mat, m, cv::COLOR_RGB2BGR);
    } else {
      m = v.mat;
    }
    WriteImageOptions o;
    o.bit_depth = bit_depth;
    o.raw = v.mat.depth() != CV_32F;  // uint8 / uint16 codes are written as they are
    o.transfer = ParseEncoding(encoding) == Encoding::kSrgb ? Transfer::kSrgb : Transfer::kLinear;
    o.overwrite = overwrite;
    try {
      WriteImage(path, m, o);
    } catch (const Error& e) {  // write_image's keyword is overwrite=, not the CLI's --force
      std::string message = e.what();
      const size_t at = message.find("--force");
      if (at != std::string::npos) message.replace(at, 7, "overwrite=True");
      if (LooksLikeIo(e.what())) throw IoError(message);
      throw Error(message);
    }
  }, py::arg("path"), py::arg("image"), py::arg("bit_depth"), py::arg("encoding"),
     py::arg("overwrite"));
  m.def("set_num_threads", &SetNumThreads, py::arg("n"));
  m.def("get_num_threads", [] { return cv::getNumThreads(); });
  m.def("_max_num_threads", &MaxNumThreads);
  // The limit files obey (TURBID_MAX_PIXELS), checked by the Python half before it converts.
  m.def("_check_image_size", [](const std::string& what, int64_t width, int64_t height) {
    const std::string problem = ImageSizeProblem(width, height);
    if (!problem.empty()) throw Error(what + ": " + problem);
  });
}

void DefineRuns(py::module_& m) {
  m.def("generate", [](const py::object& config_obj, const std::string& out, int threads) {
    // `turbid generate --threads` accepts [1, 256]; each is a std::thread of its own.
    if (threads < 1 || threads > 256)
      throw Error("generate: threads must be in [1, 256] (None: all cores), not " +
                  std::to_string(threads));
    std::string source;
    const json config = ConfigFrom(config_obj, &source);
    const GenerateConfig parsed = ParseGenerateConfig(config, source);
    WorkScope release;
    RunGenerate(parsed, out, threads);
  });
  m.def("sweep", [](const py::object& experiment_obj, const std::string& out, int threads,
                    const std::string& shard, bool force, bool reuse, bool retry_failed,
                    const py::dict& methods, bool allow_commands) {
    std::string source;
    json doc = ConfigFrom(experiment_obj, &source);
    HarnessRunnerOptions ro;
    ro.reuse = reuse;
    ro.allow_commands = allow_commands;
    ro.allow_commands_how = "allow_commands=True";
    std::set<std::string> keys;
    for (const auto& [key_obj, fn] : methods) {
      if (!py::isinstance<py::str>(key_obj)) throw Error("methods: keys must be strings");
      const std::string key = key_obj.cast<std::string>();
      if (!PyCallable_Check(fn.ptr())) throw Error("methods: '" + key + "' is not callable");
      const auto& listed = ListMethods();
      const bool builtin = std::any_of(listed.begin(), listed.end(),
                                       [&](const MethodInfo& info) { return info.name == key; });
      if (key == "none" || builtin)
        throw Error("methods: '" + key + "' is the name of a built-in method; choose another");
      keys.insert(key);
      ro.in_process[key] = PythonCallable(fn);
    }
    doc = BindPythonMethods(std::move(doc), keys);
    WorkScope release;
    const Experiment experiment = ParseExperiment(doc, source, RegistryCatalog());
    CheckCommandsAllowed(experiment, allow_commands, "allow_commands=True");  // before any work
    SweepOptions options;
    options.out_dir = out;
    options.threads = threads;
    options.shard = ParseShard(shard);
    options.force = force;
    options.retry_failed = retry_failed;
    options.progress = false;
    ThrowIfInvalid(options, "sweep");
    HarnessRunner r2(experiment, out, ro);
    const SweepSummary s = RunSweep(experiment, options, r2.Hooks());
    return json({{"items_total", s.items_total},
                 {"items_in_shard", s.items_in_shard},
                 {"ran", s.ran},
                 {"already_done", s.already_done},
                 {"retried", s.retried},
                 {"failed_rows", s.failed_rows},
                 {"tables_written", s.tables_written},
                 {"notes", s.notes}})
        .dump();
  }, py::arg("experiment"), py::arg("out"), py::arg("threads"), py::arg("shard"),
     py::arg("force"), py::arg("reuse"), py::arg("retry_failed") = false,
     py::arg("methods") = py::dict(), py::arg("allow_commands") = false);

}

void DefineData(py::module_& m) {
  // For python/benchmarks/bench.py: the C++ time alone (no conversion, no Python), seconds of
  // process CPU time per call (all threads; time spent waiting for a busy core is not counted).
  m.def("_cpp_render_seconds", [](const PyScene& scene, const std::string& params_text, int n) {
    WorkScope release;
    const RenderOptions options = RenderOptionsFromJson(ParseJsonText(params_text, "params"));
    const double t0 = ProcessCpuSeconds();
    for (int i = 0; i < n; ++i) scene.renderer->Render(options);
    return (ProcessCpuSeconds() - t0) / n;
  });
  // For turbid.torch (python/turbid/_torch_*.py): the sensor stream's standard normals of a seed
  // (RandomNormals, float32) and the water's phase function tabulated by cos theta as the
  // single-scatter veil uses it (simulator/veil.cc).
  m.def("_standard_normals", [](uint64_t seed, int64_t count) {
    if (count < 0 || count > (int64_t{1} << 31) - 1) throw Error("standard_normals", "count");
    py::array_t<float> out(count);
    float* p = out.mutable_data();
    WorkScope release;
    RandomNormals(RandomKey(seed, 2), 0, static_cast<int>(count), p);
    return out;
  });
  m.def("_phase_table", [](const std::string& params_text, int n) {
    const RenderOptions o = RenderOptionsFromJson(ParseJsonText(params_text, "params"));
    if (n < 2) throw Error("phase_table", "n >= 2");
    const std::vector<float> t = PhaseFunction(o.water.phase).TabulateByCosine(n);
    return py::array_t<float>(static_cast<py::ssize_t>(t.size()), t.data());
  });
  m.def("_ambient_share", [](const std::string& params_text) {  // H of ambient "derived"
    const RenderOptions o = RenderOptionsFromJson(ParseJsonText(params_text, "params"));
    return AmbientBackscatterShare(PhaseFunction(o.water.phase),
                                   o.water.ambient_view_elevation_deg);
  });
  m.def("_cpp_enhance_seconds", [](const py::array& image, const std::string& method, int n) {
    const ArrayView v = ViewArray(image, "image");
    WorkScope release;
    EnhanceInput input;
    input.image = ToInternal(v, Encoding::kNone, "image");
    const double t0 = ProcessCpuSeconds();
    for (int i = 0; i < n; ++i) Enhance(method, json::object(), input);
    return (ProcessCpuSeconds() - t0) / n;
  });
}

}  // namespace
}  // namespace turbid

PYBIND11_MODULE(_turbid, m) {
  using namespace turbid;
  using namespace turbid::pyext;
  m.doc() = "turbid's C++ core (use the `turbid` package, not this module)";
  m.attr("__version__") = TURBID_VERSION;

  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const IoError& e) {
      PyErr_SetString(PyExc_OSError, PythonSpelling(e.what()).c_str());
    } catch (const Error& e) {
      PyErr_SetString(LooksLikeIo(e.what()) ? PyExc_OSError : PyExc_ValueError,
                      PythonSpelling(e.what()).c_str());
    } catch (const std::filesystem::filesystem_error& e) {
      PyErr_SetString(PyExc_OSError, e.what());
    } catch (const nlohmann::json::exception& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    }
  });

  DefineScenes(m);
  DefineCalls(m);
  DefineFilesAndThreads(m);
  DefineRuns(m);
  DefineData(m);
  DefineBatch(m);
  DefineDataset(m);
  DefineHarness(m);
  DefineWater(m);
}
