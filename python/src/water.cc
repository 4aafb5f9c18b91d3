// The C++ half of turbid.water (python/turbid/water.py): Sea-thru's water fit over NumPy frames
// with the same FitWater and the same writers of FIT.json, FIT.diagnostics.json and FIT.plot.png
// as `turbid water fit` (tools/cli/cmd_water.cc), so one frame gives the same numbers both ways.
#include <pybind11/stl.h>

#include <optional>
#include <string>
#include <vector>

#include "enhancer/seathru/water_fit.h"
#include "enhancer/seathru/water_report.h"
#include "python/src/common.h"
#include "scenes/scene.h"

namespace turbid::pyext {
namespace {

// One frame as the caller passed it (checked and wrapped, nothing converted yet).
struct FrameIn {
  ArrayView image, depth;
  std::optional<CameraIntrinsics> camera;  // nullopt: the depth is the range already
  std::string name;
};

FrameIn CheckFrame(const py::array& image, const py::array& depth, const py::object& k,
                   const std::string& name) {
  FrameIn f;
  f.name = name;
  f.image = ViewArray(image, name + ": image");
  if (f.image.channels != 3) throw Error(name + ": image: water fit needs a colour (RGB) image");
  f.depth = ViewArray(depth, name + ": depth", /*allow_color=*/false);
  if (f.depth.mat.depth() != CV_32F) throw Error(name + ": depth: must be float32 metres");
  if (f.depth.mat.size() != f.image.mat.size())
    throw Error(name + ": depth is " + std::to_string(f.depth.mat.cols) + "x" +
                std::to_string(f.depth.mat.rows) + ", the image " +
                std::to_string(f.image.mat.cols) + "x" + std::to_string(f.image.mat.rows) +
                " (W x H): they must be on the same grid");
  if (!k.is_none()) {
    const auto v = k.cast<std::vector<double>>();
    if (v.size() != 4) throw Error(name + ": K: (fx, fy, cx, cy) expected");
    CameraIntrinsics c{v[0], v[1], v[2], v[3], f.image.mat.cols, f.image.mat.rows};
    std::string why;
    if (!c.Check(&why)) throw Error(name + ": K: " + why);
    f.camera = c;
  }
  return f;
}

// Linear BGR image and range along the ray, as the CLI builds them from a scene (call without
// the GIL).
WaterFitFrame ToFitFrame(const FrameIn& f, Encoding encoding) {
  WaterFitFrame out;
  out.name = f.name;
  out.image = ToInternal(f.image, encoding, f.name + ": image");
  if (out.image.data == f.image.mat.data) out.image = out.image.clone();
  out.range_m = f.camera ? RangeFromDepth(*f.camera, f.depth.mat) : f.depth.mat.clone();
  return out;
}

}  // namespace

void DefineWater(py::module_& m) {
  // water_fit(images, depths, Ks, encoding, options JSON) -> (FIT.json text, diagnostics text,
  // plot RGB float32). Ks: per frame None (depth is range) or (fx, fy, cx, cy) (depth is z).
  m.def("water_fit",
        [](const std::vector<py::array>& images, const std::vector<py::array>& depths,
           const std::vector<py::object>& ks, const std::optional<std::string>& encoding,
           const std::string& options_text) {
          if (images.empty()) throw Error("water.fit: no frames");
          if (depths.size() != images.size() || ks.size() != images.size())
            throw Error("water.fit: as many depth maps and intrinsics as images are needed");
          WaterFitOptions options;
          WaterFitFields().Read(ParseJsonText(options_text, "options"), &options, "options");
          std::string why;
          if (!options.Check(&why)) throw Error("options", why);
          const Encoding enc = ParseEncoding(encoding);
          std::vector<FrameIn> in;
          for (size_t i = 0; i < images.size(); ++i)
            in.push_back(CheckFrame(images[i], depths[i], ks[i],
                                    images.size() == 1 ? "frame" : "frame " + std::to_string(i)));
          std::string params, diagnostics;
          cv::Mat plot;
          {
            WorkScope release;
            std::vector<WaterFitFrame> frames;
            for (const FrameIn& f : in) frames.push_back(ToFitFrame(f, enc));
            const WaterFit fit = FitWater(frames, options);
            params = WaterFitParamsJson(fit).dump();
            diagnostics = WaterFitDiagnosticsJson(fit, options).dump();
            plot = WaterFitPlot(fit);
          }
          return py::make_tuple(params, diagnostics, ToNumpy(plot));
        });
}

}  // namespace turbid::pyext
