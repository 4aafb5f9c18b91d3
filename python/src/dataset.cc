// The training-data path of the extension module (common.h, DefineDataset): a `turbid generate`
// config planned once (scenes loaded, items expanded), each item's parameters for any epoch
// (epoch 0: exactly generate's), and samples rendered after cropping / resizing the scene with its
// intrinsics adjusted, so that a 256 x 256 crop costs a 256 x 256 render. turbid/data.py is the
// Python half.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <cmath>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "core/error.h"
#include "python/src/common.h"
#include "scenes/builtin.h"
#include "scenes/camera_encoding.h"
#include "scenes/scene_loader.h"
#include "simulator/render.h"
#include "simulator/render_options.h"
#include "tools/harness/generate.h"
#include "tools/harness/param_tree.h"

namespace turbid::pyext {
namespace {

// A generate config with its scenes loaded and items expanded: renders item i on demand.
// `scale` is applied to file scenes too (generate applies it to built-ins only).
struct GeneratePlan {
  GenerateConfig config;
  std::vector<PyScene> scenes;
  std::vector<GenerateItem> items;
};

// A file scene at `scale`: image by area averaging, depth and normals by the nearest sample
// (no depth mixed across an object's edge), intrinsics as ScaleIntrinsics (same field of view).
PyScene ScaledFileScene(const PyScene& full, double scale) {
  const Scene& s = full.scene();
  Scene out = s;
  out.camera = ScaleIntrinsics(s.camera, scale);
  const cv::Size size(out.camera.width, out.camera.height);
  cv::resize(s.image, out.image, size, 0, 0, cv::INTER_AREA);
  cv::resize(s.depth_m, out.depth_m, size, 0, 0, cv::INTER_NEAREST);
  if (!s.normals.empty()) cv::resize(s.normals, out.normals, size, 0, 0, cv::INTER_NEAREST);
  out.dvl_points_in_camera.clear();
  PyScene p = full;
  p.renderer = std::make_shared<Renderer>(out);
  return p;
}

std::shared_ptr<GeneratePlan> PlanFrom(const py::object& config_obj) {
  std::string source;
  const json config = ConfigFrom(config_obj, &source);
  auto plan = std::make_shared<GeneratePlan>();
  plan->config = ParseGenerateConfig(config, source);
  std::vector<std::string> names;
  for (const std::string& spec : plan->config.scene_specs) {
    PyScene scene = SceneFromSpec(spec, plan->config.scale);
    if (plan->config.scale != 1.0 && !IsBuiltinSpec(spec)) {
      WorkScope release;
      scene = ScaledFileScene(scene, plan->config.scale);
    }
    plan->scenes.push_back(scene);
    names.push_back(plan->scenes.back().scene().name);
  }
  WorkScope release;
  plan->items = ExpandGenerateItems(plan->config, names);
  return plan;
}

// Item `index`'s parameters in `epoch`: epoch 0 is generate's item; epoch e draws number
// e * P + (g * samples + r) of the sampler (P draws per scene) and renders with generate's seed
// of item e * N + index (N items): new draws every epoch, the same for the same (epoch, index).
json ItemParams(const GeneratePlan& plan, size_t index, uint64_t epoch) {
  const GenerateItem& item = plan.items.at(index);
  if (epoch == 0) return item.params;
  const GenerateConfig& c = plan.config;
  const uint64_t per_scene = c.combos.size() * static_cast<uint64_t>(c.samples);
  const uint64_t in_scene = index % per_scene;
  const size_t g = in_scene / c.samples;
  json params = DrawItemParams(c, g, epoch * per_scene + in_scene);  // water_from included
  if (!params.contains("seed"))
    params["seed"] = GenerateItemSeed(c.seed, epoch * plan.items.size() + index);
  return RenderOptionsToJson(RenderOptionsFromJson(params));
}

uint64_t SplitMix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// The crop window's origin: centred, or drawn from (seed, epoch, index) with a counter-based
// generator (the same window in any worker, any order).
std::pair<int, int> CropOrigin(uint64_t seed, uint64_t epoch, uint64_t index, int height, int width,
                               int crop_h, int crop_w, bool random) {
  if (crop_h > height || crop_w > width)
    throw Error("crop " + std::to_string(crop_h) + "x" + std::to_string(crop_w) +
                " (h x w) is larger than the frame, " + std::to_string(height) + "x" +
                std::to_string(width));
  if (!random) return {(height - crop_h) / 2, (width - crop_w) / 2};
  const uint64_t key = SplitMix64(SplitMix64(SplitMix64(seed ^ 0x63726f70ull) + epoch) + index);
  const uint64_t y = (key >> 32) % static_cast<uint64_t>(height - crop_h + 1);
  const uint64_t x = (key & 0xffffffffull) % static_cast<uint64_t>(width - crop_w + 1);
  return {static_cast<int>(y), static_cast<int>(x)};
}

struct SampleSpec {
  int crop_h = 0, crop_w = 0;  // 0: no crop
  int y0 = 0, x0 = 0;
  int size_h = 0, size_w = 0;  // 0: no resize
  int channels = 0;            // 0: as the scene; 1 or 3: converted before rendering
  bool Identity(const Scene& s) const {
    return crop_h == 0 && size_h == 0 && (channels == 0 || channels == s.channels());
  }
};

// The scene a sample renders: cropped (intrinsics shifted), resized (intrinsics scaled as
// ScaleIntrinsics does), with 1 or 3 channels.
Scene SampleScene(const Scene& s, const SampleSpec& spec) {
  Scene out;
  out.name = s.name;
  out.input_hashes = s.input_hashes;
  out.dominant_plane = s.dominant_plane;
  out.camera = s.camera;
  cv::Rect box(0, 0, s.width(), s.height());
  if (spec.crop_h > 0) box = cv::Rect(spec.x0, spec.y0, spec.crop_w, spec.crop_h);
  out.camera.cx -= box.x;
  out.camera.cy -= box.y;
  out.camera.width = box.width;
  out.camera.height = box.height;
  out.image = s.image(box).clone();
  out.depth_m = s.depth_m(box).clone();
  if (!s.normals.empty()) out.normals = s.normals(box).clone();
  if (spec.size_h > 0 && (spec.size_h != box.height || spec.size_w != box.width)) {
    const cv::Size size(spec.size_w, spec.size_h);
    const double sx = static_cast<double>(size.width) / box.width;
    const double sy = static_cast<double>(size.height) / box.height;
    const int interp = sx < 1.0 && sy < 1.0 ? cv::INTER_AREA : cv::INTER_LINEAR;
    cv::Mat image, depth, normals;
    cv::resize(out.image, image, size, 0, 0, interp);
    cv::resize(out.depth_m, depth, size, 0, 0, cv::INTER_NEAREST);
    if (!out.normals.empty()) cv::resize(out.normals, normals, size, 0, 0, cv::INTER_NEAREST);
    out.image = image;
    out.depth_m = depth;
    out.normals = normals;
    out.camera.fx *= sx;
    out.camera.fy *= sy;
    out.camera.cx = (out.camera.cx + 0.5) * sx - 0.5;
    out.camera.cy = (out.camera.cy + 0.5) * sy - 0.5;
    out.camera.width = size.width;
    out.camera.height = size.height;
  }
  if (spec.channels == 3 && out.image.channels() == 1) {
    cv::Mat c3;
    cv::cvtColor(out.image, c3, cv::COLOR_GRAY2BGR);
    out.image = c3;
  } else if (spec.channels == 1 && out.image.channels() == 3) {
    cv::Mat c1;
    cv::cvtColor(out.image, c1, cv::COLOR_BGR2GRAY);
    out.image = c1;
  }
  return out;
}

// Where a sample's arrays go: new arrays (`into` None or without the name), or the caller's (a row
// of a batch that RenderDataset.__getitems__ allocated once, in shared memory inside DataLoader
// workers), checked for dtype, shape, C order and writability so that the pixels can be written
// straight in.
py::array Target(const py::object& into, const char* name, const std::vector<py::ssize_t>& shape,
                 const py::dtype& dtype) {
  if (into.is_none() || !into.cast<py::dict>().contains(name)) return py::array(dtype, shape);
  const py::dict d = into.cast<py::dict>();
  py::array a = d[name].cast<py::array>();
  bool ok = a.dtype().is(dtype) && a.ndim() == static_cast<py::ssize_t>(shape.size()) &&
            (a.flags() & py::array::c_style) && a.writeable();
  for (size_t k = 0; ok && k < shape.size(); ++k) ok = a.shape(k) == shape[k];
  if (!ok)
    throw py::value_error(std::string("render_sample: the array for ") + name +
                          " is not a writable C-ordered array of the sample's shape and dtype");
  return a;
}

// An image in its final layout: H x W x C RGB, or C x H x W RGB with `planar` (one pass that
// also reorders B, G, R when `bgr`). Gray images are H x W x 1 / 1 x H x W. A new array over
// an RGB-ordered render is the render's own buffer (no copy).
py::array EmitImage(const py::object& into, const char* name, const cv::Mat& m, bool bgr,
                    bool planar) {
  const int c = m.channels();
  if (into.is_none() && !planar && !bgr) {
    py::array a = WrapNumpy(m);
    return c == 1 ? py::array(a.attr("reshape")(m.rows, m.cols, 1)) : a;
  }
  const std::vector<py::ssize_t> shape = planar ? std::vector<py::ssize_t>{c, m.rows, m.cols}
                                                : std::vector<py::ssize_t>{m.rows, m.cols, c};
  py::array out = Target(into, name, shape, py::dtype::of<float>());
  float* dst = static_cast<float*>(out.mutable_data());
  WorkScope release;
  if (planar) {
    std::vector<cv::Mat> planes;
    for (int k = 0; k < c; ++k) planes.emplace_back(m.rows, m.cols, CV_32F, dst + k * m.total());
    if (bgr && c == 3) std::swap(planes[0], planes[2]);
    cv::split(m, planes);
  } else {
    cv::Mat d(m.rows, m.cols, m.type(), dst);
    if (bgr && c == 3)
      cv::cvtColor(m, d, cv::COLOR_BGR2RGB);
    else
      m.copyTo(d);
  }
  return out;
}

// An image as 8-bit camera codes (uint8, RenderDataset's dtype="uint8"), laid out as EmitImage
// lays out floats: the bytes of the 8-bit file (EncodeCodesRow8), B, G, R reordered when `bgr`.
py::array EmitCodes(const py::object& into, const char* name, const cv::Mat& m, bool bgr,
                    bool planar, CameraEncoding encoding) {
  const int c = m.channels(), w = m.cols, plane = m.rows * m.cols;
  const std::vector<py::ssize_t> shape = planar ? std::vector<py::ssize_t>{c, m.rows, m.cols}
                                                : std::vector<py::ssize_t>{m.rows, m.cols, c};
  py::array out = Target(into, name, shape, py::dtype::of<uint8_t>());
  uint8_t* dst = static_cast<uint8_t*>(out.mutable_data());
  WorkScope release;
  const bool direct = c == 1 || (!planar && !bgr);
  std::vector<uint8_t> row(direct ? 0 : static_cast<size_t>(w) * c);
  for (int y = 0; y < m.rows; ++y) {
    uint8_t* codes = direct ? dst + static_cast<size_t>(y) * w * c : row.data();
    EncodeCodesRow8(m.ptr<float>(y), w * c, encoding, codes);
    if (direct) continue;
    for (int k = 0; k < 3; ++k) {
      const int from = bgr ? 2 - k : k;
      if (planar) {
        uint8_t* p = dst + static_cast<size_t>(k) * plane + static_cast<size_t>(y) * w;
        for (int x = 0; x < w; ++x) p[x] = codes[3 * x + from];
      } else {
        uint8_t* p = dst + static_cast<size_t>(y) * w * 3 + k;
        for (int x = 0; x < w; ++x) p[3 * x] = codes[3 * x + from];
      }
    }
  }
  return out;
}

// A one-channel float map (depth; the psf map) as H x W, or H x W x C RGB for a colour map.
py::array EmitPlain(const py::object& into, const char* name, const cv::Mat& m) {
  if (m.channels() != 1) return EmitImage(into, name, m, /*bgr=*/true, /*planar=*/false);
  py::array out = Target(into, name, {m.rows, m.cols}, py::dtype::of<float>());
  cv::Mat d(m.rows, m.cols, CV_32F, out.mutable_data());
  WorkScope release;
  m.copyTo(d);
  return out;
}

// valid: depth finite and positive, H x W bool.
py::array EmitValid(const py::object& into, const cv::Mat& depth) {
  py::array out = Target(into, "valid", {depth.rows, depth.cols}, py::dtype::of<bool>());
  auto* dst = static_cast<uint8_t*>(out.mutable_data());
  WorkScope release;
  for (int y = 0; y < depth.rows; ++y) {
    const float* d = depth.ptr<float>(y);
    uint8_t* v = dst + static_cast<size_t>(y) * depth.cols;
    for (int x = 0; x < depth.cols; ++x) v[x] = d[x] > 0.0f;  // NaN compares false
  }
  return out;
}

// A rendered sample: {"degraded", "clean" (J with `lit`), "depth", "valid", "K", maps...}, in new
// arrays or written into `into`'s (then the same arrays are returned in the dict). `codes8`:
// degraded and clean as the 8-bit camera's codes (uint8) instead of float32: the render runs
// unquantised (clipped, the same values before the quantiser) and the codes are taken once.
py::dict RenderSample(const Renderer& full, const SampleSpec& spec, const std::string& params_text,
                      const std::string& maps, bool lit, bool float_output, bool planar,
                      const py::object& into, bool codes8) {
  const json params = ParseJsonText(params_text, "params");
  RenderResult result;
  std::unique_ptr<Renderer> own;  // the cropped / resized scene's
  CameraEncoding encoding = CameraEncoding::kSrgb;
  {
    WorkScope release;
    RenderOptions options = RenderOptionsFromJson(params);
    if (codes8 && (float_output || options.camera.bit_depth != 8))
      throw Error("dtype='uint8': 8-bit camera codes only, and this item's camera writes " +
                  (float_output ? std::string("float (format exr)")
                                : std::to_string(options.camera.bit_depth) + "-bit codes") +
                  " (use dtype='float32', or camera.bit_depth 8)");
    encoding = options.camera.encoding;
    if (float_output || codes8) options.camera.bit_depth = 32;
    options.maps = MapSelection::FromList(maps);
    options.rgb_image = true;
    if (!spec.Identity(full.scene()))
      own = std::make_unique<Renderer>(SampleScene(full.scene(), spec));
    result = (own ? *own : full).Render(options);
  }
  const Scene& scene = (own ? *own : full).scene();
  py::dict out;
  const cv::Mat& clean = lit ? result.lit : scene.image;
  if (codes8) {
    out["degraded"] = EmitCodes(into, "degraded", result.image, /*bgr=*/false, planar, encoding);
    out["clean"] = EmitCodes(into, "clean", clean, /*bgr=*/true, planar, encoding);
  } else {
    out["degraded"] = EmitImage(into, "degraded", result.image, /*bgr=*/false, planar);  // RGB
    out["clean"] = EmitImage(into, "clean", clean, /*bgr=*/true, planar);
  }
  out["depth"] = EmitPlain(into, "depth", scene.depth_m);
  out["valid"] = EmitValid(into, scene.depth_m);
  const std::pair<const char*, const cv::Mat*> named[] = {{"transmission", &result.transmission},
                                                          {"light", &result.light},
                                                          {"veil", &result.veil},
                                                          {"psf", &result.psf},
                                                          {"noise", &result.noise}};
  for (const auto& [name, mat] : named)
    if (!mat->empty())
      out[name] = std::string(name) == "psf" ? EmitPlain(into, name, *mat)
                                             : EmitImage(into, name, *mat, true, planar);
  const CameraIntrinsics& c = scene.camera;
  out["K"] = py::make_tuple(c.fx, c.fy, c.cx, c.cy);
  return out;
}

SampleSpec MakeSpec(const Scene& s, int crop_h, int crop_w, int y0, int x0, int size_h, int size_w,
                    int channels) {
  SampleSpec spec;
  if (crop_h > 0 && (crop_h != s.height() || crop_w != s.width())) {
    spec.crop_h = crop_h;
    spec.crop_w = crop_w;
    spec.y0 = y0;
    spec.x0 = x0;
  }
  spec.size_h = size_h;
  spec.size_w = size_w;
  spec.channels = channels;
  return spec;
}

// Keeps freed memory in the process's heap instead of returning it to the system, so that the
// next sample's arrays reuse warm pages (without it every 640 x 480 sample page-faults ~2000
// fresh pages: a quarter of its CPU time). For DataLoader worker processes (turbid/data.py);
// False where the C library has no mallopt (not glibc).
bool KeepFreedMemory() {
#if defined(__GLIBC__)
  return mallopt(M_MMAP_THRESHOLD, 256 << 20) == 1 && mallopt(M_TRIM_THRESHOLD, 512 << 20) == 1;
#else
  return false;
#endif
}

}  // namespace

void DefineDataset(py::module_& m) {
  py::class_<GeneratePlan, std::shared_ptr<GeneratePlan>>(m, "GeneratePlan")
      .def(py::init(&PlanFrom))
      .def("__len__", [](const GeneratePlan& p) { return p.items.size(); })
      .def("item",
           [](const GeneratePlan& p, int64_t i) {
             if (i < 0 || i >= static_cast<int64_t>(p.items.size()))
               throw py::index_error("item " + std::to_string(i) + " out of range");
             const GenerateItem& it = p.items[i];
             return py::make_tuple(it.id, it.scene);  // no params: ItemParams per epoch
           })
      .def("params",
           [](const GeneratePlan& p, int64_t i, uint64_t epoch) {
             WorkScope release;
             return ItemParams(p, static_cast<size_t>(i), epoch).dump();
           })
      .def("scene", [](const GeneratePlan& p, size_t s) { return p.scenes.at(s); })
      .def_property_readonly("scene_count", [](const GeneratePlan& p) { return p.scenes.size(); })
      .def_property_readonly("seed", [](const GeneratePlan& p) { return p.config.seed; })
      .def_property_readonly("format", [](const GeneratePlan& p) { return p.config.format; });
  m.def("crop_origin", &CropOrigin);
  m.def("keep_freed_memory", &KeepFreedMemory);
  m.def(
      "render_sample",
      [](const PyScene& scene, const std::string& params_text, int crop_h, int crop_w, int y0,
         int x0, int size_h, int size_w, int channels, const std::string& maps, bool lit,
         bool float_output, bool planar, const py::object& into, bool codes8) {
        const SampleSpec spec =
            MakeSpec(scene.scene(), crop_h, crop_w, y0, x0, size_h, size_w, channels);
        return RenderSample(*scene.renderer, spec, params_text, maps, lit, float_output, planar,
                            into, codes8);
      },
      py::arg("scene"), py::arg("params_text"), py::arg("crop_h"), py::arg("crop_w"), py::arg("y0"),
      py::arg("x0"), py::arg("size_h"), py::arg("size_w"), py::arg("channels"), py::arg("maps"),
      py::arg("lit"), py::arg("float_output"), py::arg("planar"), py::arg("into") = py::none(),
      py::arg("codes8") = false);
  m.def("draw_params", [](const std::string& base_text, const std::string& random_text,
                          uint64_t random_seed, uint64_t seed, uint64_t index) {
    json params = ExpandDottedParams(ParseJsonText(base_text, "base"), "base");
    const json random = FlattenSamplers(ParseJsonText(random_text, "random.params"), "generate",
                                        "random.params");  // dotted paths or nested objects
    ApplyRandomDraw(params, random, random_seed, index);
    if (!params.contains("seed")) params["seed"] = GenerateItemSeed(seed, index);
    return RenderOptionsToJson(RenderOptionsFromJson(params)).dump();
  });
}

}  // namespace turbid::pyext
