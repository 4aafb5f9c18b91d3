// The batch entry points of the extension module (common.h, DefineBatch): enhance and score over
// N x H x W x C arrays, one item per task of OpenCV's thread pool with the GIL released (the
// libraries' own parallel loops inside an item then run serially: OpenCV does not nest), score's
// domains (issue 32: camera-coded sRGB 8-bit by default), and the sRGB curve as array functions.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/limits.h"
#include "enhancer/registry.h"
#include "metrics/registry.h"
#include "python/src/common.h"
#include "scenes/image_io.h"
#include "scenes/scene_loader.h"

namespace turbid::pyext {
namespace {

// The items of an N x H x W x C C-contiguous array (checked as ViewArray checks one image).
std::vector<ArrayView> ViewBatch(const py::array& a, const std::string& what) {
  if (a.ndim() != 4) throw Error(what + ": a batch must be N x H x W x C");
  const py::ssize_t n = a.shape(0);
  std::vector<ArrayView> views;
  if (n < 1) throw Error(what + ": the batch is empty");
  // One image's header checks the dtype, shape, size and layout of all.
  py::array first = py::array(a.dtype(), {a.shape(1), a.shape(2), a.shape(3)},
                              {a.strides(1), a.strides(2), a.strides(3)}, a.data(), a);
  if (!(a.flags() & py::array::c_style))
    throw Error(what + ": array is not C-contiguous (use numpy.ascontiguousarray)");
  const ArrayView v0 = ViewArray(first, what);
  const size_t step = static_cast<size_t>(a.strides(0));
  for (py::ssize_t i = 0; i < n; ++i) {
    ArrayView v = v0;
    v.mat = cv::Mat(v0.mat.rows, v0.mat.cols, v0.mat.type(),
                    const_cast<char*>(static_cast<const char*>(a.data())) + i * step);
    views.push_back(v);
  }
  return views;
}

// Runs body(i) for every item in parallel; the error of the lowest failing item is thrown, named
// "what[i]: ...". Call without the GIL.
template <typename Body>
void ForEachItem(size_t n, const std::string& what, const Body& body) {
  std::mutex mutex;
  std::optional<std::pair<size_t, std::string>> failure;
  cv::parallel_for_(cv::Range(0, static_cast<int>(n)), [&](const cv::Range& r) {
    for (int i = r.start; i < r.end; ++i) {
      try {
        body(static_cast<size_t>(i));
      } catch (const std::exception& e) {
        std::lock_guard<std::mutex> lock(mutex);
        if (!failure || failure->first > static_cast<size_t>(i)) failure.emplace(i, e.what());
      }
    }
  });
  if (failure) throw Error(what + "[" + std::to_string(failure->first) + "]: " + failure->second);
}

py::array EnhanceBatch(const py::array& batch, const std::string& method,
                       const std::string& params_text,
                       const std::vector<std::string>& sidecar_texts,
                       const std::optional<PyScene>& scene,
                       const std::optional<std::string>& encoding) {
  const Encoding enc = ParseEncoding(encoding);
  const std::vector<ArrayView> views = ViewBatch(batch, "image");
  const json params = ParseJsonText(params_text, "params");
  if (sidecar_texts.size() > 1 && sidecar_texts.size() != views.size())
    throw Error("sidecar: " + std::to_string(sidecar_texts.size()) + " sidecars for a batch of " +
                std::to_string(views.size()) + " images (one, or one per image)");
  std::vector<RenderRecord> sidecars;
  for (const std::string& text : sidecar_texts)
    sidecars.push_back(RenderRecord::FromJson(ParseJsonText(text, "sidecar"), "sidecar"));
  const cv::Mat& first = views[0].mat;
  py::array_t<float> out({batch.shape(0), batch.shape(1), batch.shape(2), batch.shape(3)});
  float* out_data = out.mutable_data();
  const size_t item_floats = static_cast<size_t>(first.total()) * views[0].channels;
  {
    WorkScope release;
    const MethodInfo& info = FindMethod(method);
    if (info.needs_sidecar && sidecars.empty())
      throw Error("enhance: method '" + method + "' needs sidecar=");
    if (info.needs_geometry && !scene)
      throw Error("enhance: method '" + method + "' needs scene= for a batch");
    ForEachItem(views.size(), "image", [&](size_t i) {
      EnhanceInput input;
      input.image = ToInternal(views[i], enc, "image", /*keep_rgb=*/true);
      input.rgb = true;
      input.sidecar = sidecars.empty() ? nullptr : &sidecars[sidecars.size() == 1 ? 0 : i];
      input.scene = scene ? &scene->scene() : nullptr;
      const cv::Mat result = Enhance(method, params, input);
      if (result.size() != first.size() || result.channels() != views[i].channels ||
          result.depth() != CV_32F)
        throw Error("method '" + method + "' returned another size or channel count");
      cv::Mat slot(first.rows, first.cols, CV_32FC(views[i].channels), out_data + i * item_floats);
      result.copyTo(slot);
    });
  }
  return out;
}

// ---- score
// ---------------------------------------------------------------------------------------

enum class Domain { kSrgb8, kLinear, kAsGiven };

Domain ParseDomain(const std::string& text) {
  if (text == "srgb8") return Domain::kSrgb8;
  if (text == "linear") return Domain::kLinear;
  if (text == "as_given") return Domain::kAsGiven;
  throw Error("domain must be 'srgb8', 'linear' or 'as_given', not '" + text + "'");
}

void CheckFinite(const cv::Mat& m, const std::string& what) {
  if (m.depth() == CV_32F && !cv::checkRange(m, /*quiet=*/true))
    throw Error(what + ": contains NaN or infinite values");
}

// A linear [0, 1] float image as an 8-bit sRGB camera writes it (scenes/image_io.cc WriteImage:
// clipped, NaN -> 0, the sRGB curve, x 255 rounded), as float32 codes 0..255.
cv::Mat CodeSrgb8(const cv::Mat& linear) {
  cv::Mat clipped = linear.clone();
  cv::patchNaNs(clipped, 0.0);
  cv::min(cv::max(clipped, 0.0), 1.0, clipped);
  cv::Mat codes, out;
  LinearToSrgb(clipped).convertTo(codes, CV_8U, 255.0);  // rounds to nearest, saturates
  codes.convertTo(out, CV_32F);
  return out;
}

struct ScoreSide {
  cv::Mat full;    // what full-reference metrics compare
  cv::Mat linear;  // what the no-reference metrics read
  double full_range = 1.0;
};

// One argument in the domain. Floats are linear light; integer arrays are camera codes in
// `encoding` (sRGB unless told otherwise).
ScoreSide ToDomain(const ArrayView& v, Domain domain, Encoding encoding, const std::string& what) {
  ScoreSide s;
  CheckFinite(v.mat, what);
  if (domain == Domain::kAsGiven) {
    const MetricImage m = MetricFromArray(v);
    s.full = s.linear = m.pixels;
    s.full_range = m.data_range;
    return s;
  }
  // Floats are linear light whatever `encoding` says (it describes integer codes).
  const Encoding enc = v.mat.depth() == CV_32F       ? Encoding::kLinear
                       : encoding == Encoding::kNone ? Encoding::kSrgb
                                                     : encoding;
  s.linear = ToInternal(v, enc, what);
  if (domain == Domain::kLinear) {
    s.full = s.linear;
    return s;
  }
  s.full_range = 255.0;
  if (enc == Encoding::kSrgb && v.mat.depth() != CV_32F) {  // codes already: requantise only
    cv::Mat bgr = v.mat, codes;
    if (v.channels == 3) cv::cvtColor(v.mat, bgr, cv::COLOR_RGB2BGR);
    bgr.convertTo(codes, CV_8U, v.mat.depth() == CV_8U ? 1.0 : 255.0 / 65535.0);
    codes.convertTo(s.full, CV_32F);
  } else {
    s.full = CodeSrgb8(s.linear);
  }
  return s;
}

struct ScoreArgs {
  std::vector<std::string> full_metrics, other_metrics;
  Domain domain = Domain::kSrgb8;
  Encoding encoding = Encoding::kNone;
};

ScoreArgs MakeScoreArgs(const std::string& metric_list, bool has_ref, bool has_original,
                        const std::string& domain, const std::optional<std::string>& encoding) {
  ScoreArgs args;
  args.domain = ParseDomain(domain);
  args.encoding = ParseEncoding(encoding);
  const std::string list = metric_list.empty() ? (has_ref ? "ssim,psnr" : "cnr") : metric_list;
  for (const std::string& name : ParseMetricList(list, has_ref, has_original))
    (FindMetric(name).needs_reference ? args.full_metrics : args.other_metrics).push_back(name);
  return args;
}

std::map<std::string, double> ScoreOne(const ScoreArgs& args, const ArrayView& image,
                                       const ArrayView* ref, const ArrayView* original) {
  const ScoreSide img = ToDomain(image, args.domain, args.encoding, "image");
  ScoreSide r, o;
  if (ref) r = ToDomain(*ref, args.domain, args.encoding, "ref");
  if (original) o = ToDomain(*original, args.domain, args.encoding, "original");
  std::map<std::string, double> out;
  if (args.domain == Domain::kAsGiven) {  // `turbid score`'s reading of files
    MetricImage mi{img.full, img.full_range}, mr{r.full, r.full_range}, mo{o.full, o.full_range};
    MetricInputs in;
    in.data_range = CommonScale({&mr, &mi, &mo});
    in.reference = mr.pixels;
    in.image = mi.pixels;
    in.original = mo.pixels;
    std::vector<std::string> all = args.full_metrics;
    all.insert(all.end(), args.other_metrics.begin(), args.other_metrics.end());
    return ComputeMetrics(all, in);
  }
  if (!args.full_metrics.empty()) {
    MetricInputs in;
    in.data_range = img.full_range;
    in.reference = r.full;
    in.image = img.full;
    out = ComputeMetrics(args.full_metrics, in);
  }
  if (!args.other_metrics.empty()) {
    MetricInputs in;
    in.data_range = 1.0;
    in.reference = r.linear;
    in.image = img.linear;
    in.original = o.linear;
    for (const auto& [k, v] : ComputeMetrics(args.other_metrics, in)) out[k] = v;
  }
  return out;
}

std::map<std::string, double> ScoreArrays(const py::array& image,
                                          const std::optional<py::array>& ref,
                                          const std::optional<py::array>& original,
                                          const std::string& metric_list, const std::string& domain,
                                          const std::optional<std::string>& encoding) {
  const ArrayView iv = ViewArray(image, "image");
  std::optional<ArrayView> rv, ov;
  if (ref) rv = ViewArray(*ref, "ref");
  if (original) ov = ViewArray(*original, "original");
  WorkScope release;
  const ScoreArgs args = MakeScoreArgs(metric_list, bool(ref), bool(original), domain, encoding);
  return ScoreOne(args, iv, rv ? &*rv : nullptr, ov ? &*ov : nullptr);
}

std::vector<std::map<std::string, double>> ScoreBatch(const py::array& image,
                                                      const std::optional<py::array>& ref,
                                                      const std::optional<py::array>& original,
                                                      const std::string& metric_list,
                                                      const std::string& domain,
                                                      const std::optional<std::string>& encoding) {
  const std::vector<ArrayView> iv = ViewBatch(image, "image");
  std::vector<ArrayView> rv, ov;
  if (ref) rv = ViewBatch(*ref, "ref");
  if (original) ov = ViewBatch(*original, "original");
  for (const auto* other : {&rv, &ov})
    if (!other->empty() && other->size() != iv.size())
      throw Error(std::string(other == &rv ? "ref" : "original") + ": a batch of " +
                  std::to_string(other->size()) + " for " + std::to_string(iv.size()) + " images");
  std::vector<std::map<std::string, double>> out(iv.size());
  WorkScope release;
  const ScoreArgs args = MakeScoreArgs(metric_list, bool(ref), bool(original), domain, encoding);
  ForEachItem(iv.size(), "image", [&](size_t i) {
    out[i] = ScoreOne(args, iv[i], rv.empty() ? nullptr : &rv[i], ov.empty() ? nullptr : &ov[i]);
  });
  return out;
}

// ---- the sRGB curve
// ------------------------------------------------------------------------------

// Any C-contiguous array, element by element (scenes/image_io.h's curve, IEC 61966-2-1).
// decode: uint8 / uint16 codes are scaled to [0, 1] first (as ReadImage); encode: `bits` 8 or 16
// clips, scales and rounds to that integer type (as WriteImage), 0 keeps float32.
py::array SrgbCurve(const py::array& a, bool encode, int bits) {
  const char kind = a.dtype().kind();
  const int size = a.itemsize();
  const bool is_u8 = kind == 'u' && size == 1, is_u16 = kind == 'u' && size == 2;
  if (!(kind == 'f' && size == 4) && !(!encode && (is_u8 || is_u16)))
    throw Error(std::string(encode ? "srgb_encode" : "srgb_decode") + ": dtype " +
                std::string(py::str(a.dtype())) + " is not supported");
  if (!(a.flags() & py::array::c_style)) throw Error("array is not C-contiguous");
  const int total = static_cast<int>(a.size());
  std::vector<py::ssize_t> shape(a.shape(), a.shape() + a.ndim());
  py::array out = bits == 8    ? py::array(py::dtype::of<uint8_t>(), shape)
                  : bits == 16 ? py::array(py::dtype::of<uint16_t>(), shape)
                               : py::array(py::dtype::of<float>(), shape);
  if (total == 0) return out;
  const int depth = is_u8 ? CV_8U : is_u16 ? CV_16U : CV_32F;
  cv::Mat in(1, total, depth, const_cast<void*>(a.data()));
  cv::Mat dst(1, total, bits == 8 ? CV_8U : bits == 16 ? CV_16U : CV_32F, out.mutable_data());
  WorkScope release;
  cv::Mat f = in;
  if (depth != CV_32F) in.convertTo(f, CV_32F, 1.0 / (depth == CV_8U ? 255.0 : 65535.0));
  cv::Mat r = encode ? LinearToSrgb(f) : SrgbToLinear(f);
  if (bits == 0) {
    r.copyTo(dst);
  } else {
    cv::patchNaNs(r, 0.0);
    const double max_value = bits == 8 ? 255.0 : 65535.0;
    cv::Mat scaled = r * max_value;
    cv::min(cv::max(scaled, 0.0), max_value, scaled);
    scaled.convertTo(dst, dst.type());  // rounds to nearest
  }
  return out;
}

}  // namespace

void DefineBatch(py::module_& m) {
  m.def("enhance_batch", &EnhanceBatch, py::arg("images"), py::arg("method"), py::arg("params"),
        py::arg("sidecars"), py::arg("scene"), py::arg("encoding"));
  m.def("score", &ScoreArrays, py::arg("image"), py::arg("ref"), py::arg("original"),
        py::arg("metrics"), py::arg("domain"), py::arg("encoding"));
  m.def("score_batch", &ScoreBatch, py::arg("images"), py::arg("ref"), py::arg("original"),
        py::arg("metrics"), py::arg("domain"), py::arg("encoding"));
  m.def("srgb_curve", &SrgbCurve, py::arg("array"), py::arg("encode"), py::arg("bits"));
}

}  // namespace turbid::pyext
