// The shared pieces of the bindings (common.h).
#include "python/src/common.h"

#include <time.h>

#include <algorithm>
#include <cctype>
#include <cstring>
#include <opencv2/imgproc.hpp>
#include <thread>
#include <utility>

#include "core/input_file.h"
#include "core/json_io.h"
#include "core/limits.h"
#include "scenes/image_io.h"

namespace turbid::pyext {

double ProcessCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// ---- threads -----------------------------------------------------------------------------------

// set_num_threads accepts 0 (all cores) up to this many threads: more only adds overhead (TBB
// starts no more workers than cores anyway), and an arena of 10^5 slots (cv::setNumThreads(1e5))
// segfaults in TBB 2021.8 at the next parallel_for_ (3 x 10^4 still ran).
int64_t MaxNumThreads() {
  return 4 * static_cast<int64_t>(std::max(1u, std::thread::hardware_concurrency()));
}

void SetNumThreads(const py::int_& value) {
  int overflow = 0;
  const long long n = PyLong_AsLongLongAndOverflow(value.ptr(), &overflow);
  if (n == -1 && PyErr_Occurred()) throw py::error_already_set();
  const int64_t limit = MaxNumThreads();
  if (overflow < 0 || (overflow == 0 && n < 0))
    throw Error("set_num_threads: n must be >= 0 (0: all cores), not " +
                py::repr(value).cast<std::string>());
  if (overflow > 0 || n > limit)
    throw Error("set_num_threads: n=" + py::repr(value).cast<std::string>() + " is more than " +
                std::to_string(limit) + " (4 per core; 0: all cores)");
  ThreadCount::Get().Request(n == 0 ? -1 : static_cast<int>(n));  // OpenCV: -1 is its default
}

bool LooksLikeIo(const std::string& m) {
  for (const char* s : {": cannot open", ": file not found", ": write failed", ": cannot rename",
                        "exists (use --force", "already exists", ": is a folder", ": empty file"})
    if (m.find(s) != std::string::npos) return true;
  return false;
}

// A library message in Python's words: the CLI flags it names become the keyword arguments that
// stand for them (`--force` -> `force=True`, `--sidecar` -> `sidecar=`). Only whole flags of the
// table are rewritten; anything else (a method's own command line, say) is left as it is.
std::string PythonSpelling(std::string message) {
  static const std::pair<const char*, const char*> kFlags[] = {
      {"--force", "force=True"},
      {"--retry-failed", "retry_failed=True"},
      {"--allow-commands", "allow_commands=True"},
      {"--allow-partial", "allow_partial=True"},
      {"--sidecar", "sidecar="},
      {"--scene", "scene="},
      {"--ref", "ref="},
      {"--original", "original="},
      {"--metrics", "metrics="},
      {"--maps", "maps="},
      {"--out", "out="},
      {"--shard", "shard="},
      {"--threads", "threads="},
      {"--seed", "seed="},
      {"--scale", "scale="},
      {"--params", "params="},
      {"--set", "params="},
      {"--method", "method="},
      {"--encoding", "encoding="},
  };
  const auto is_name_char = [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_';
  };
  for (const auto& [flag, keyword] : kFlags) {
    const std::string f = flag;
    for (size_t at = message.find(f); at != std::string::npos; at = message.find(f, at)) {
      const size_t end = at + f.size();
      const bool whole = (at == 0 || !is_name_char(message[at - 1])) &&
                         (end == message.size() || !is_name_char(message[end]));
      if (!whole) {
        at = end;
        continue;
      }
      // A quoted value after a keyword joins it: "--shard '3/2'" -> "shard='3/2'".
      const bool joins_value = keyword[std::strlen(keyword) - 1] == '=' &&
                               end + 1 < message.size() && message[end] == ' ' &&
                               (message[end + 1] == '\'' || message[end + 1] == '"');
      message.replace(at, f.size() + (joins_value ? 1 : 0), keyword);
      at += std::strlen(keyword);
    }
  }
  return message;
}

// The strict parse of core/json_io.h (depth, duplicate keys, numbers in range).
json ParseJsonText(const std::string& text, const std::string& what) {
  return ParseJson(text, what);
}

// The CLI's reading of JSON files (core/json_io.h); a path that is not a readable regular file
// is an OSError.
json ReadConfigFile(const std::string& path) {
  const std::string problem = InputFileProblem(path);
  if (!problem.empty()) throw IoError(path, problem);
  return ReadJsonFile(path);
}

// ---- arrays ------------------------------------------------------------------------------------

Encoding ParseEncoding(const std::optional<std::string>& text) {
  if (!text) return Encoding::kNone;
  if (*text == "linear") return Encoding::kLinear;
  if (*text == "srgb") return Encoding::kSrgb;
  throw Error("encoding must be 'srgb' or 'linear', not '" + *text + "'");
}

// Checks dtype, shape and layout and wraps the buffer. `allow_channels_3`: H x W x 3 accepted.
ArrayView ViewArray(const py::array& a, const std::string& what, bool allow_color) {
  int depth = -1;
  if (a.dtype().kind() == 'u' && a.itemsize() == 1)
    depth = CV_8U;
  else if (a.dtype().kind() == 'u' && a.itemsize() == 2)
    depth = CV_16U;
  else if (a.dtype().kind() == 'f' && a.itemsize() == 4)
    depth = CV_32F;
  if (depth < 0)
    throw Error(what + ": dtype " + std::string(py::str(a.dtype())) +
                " is not supported (uint8, uint16 or float32)");
  const char order = a.dtype().attr("byteorder").cast<std::string>()[0];
  if (order == '>') throw Error(what + ": byte order must be native (little-endian)");
  const bool shape_ok = a.ndim() == 2 || (a.ndim() == 3 && (a.shape(2) == 1 || a.shape(2) == 3));
  if (!shape_ok || (!allow_color && a.ndim() == 3 && a.shape(2) != 1)) {
    std::string shape = "(";
    for (py::ssize_t i = 0; i < a.ndim(); ++i) {
      if (i > 0) shape += ", ";
      shape += std::to_string(a.shape(i));
    }
    throw Error(what + ": shape " + shape + ") is not H x W" +
                (allow_color ? " or H x W x 3" : ""));
  }
  if (a.shape(0) < 1 || a.shape(1) < 1) throw Error(what + ": array is empty");
  // As files are (core/limits.h): nothing is converted or copied for an array over the limit.
  const std::string size_problem = ImageSizeProblem(a.shape(1), a.shape(0));
  if (!size_problem.empty()) throw Error(what + ": " + size_problem);
  if (!(a.flags() & py::array::c_style))
    throw Error(what + ": array is not C-contiguous (use numpy.ascontiguousarray)");
  ArrayView v;
  v.channels = a.ndim() == 3 ? static_cast<int>(a.shape(2)) : 1;
  v.mat = cv::Mat(static_cast<int>(a.shape(0)), static_cast<int>(a.shape(1)),
                  CV_MAKETYPE(depth, v.channels), const_cast<void*>(a.data()));
  return v;
}

// NumPy image -> turbid's in-memory image (float32 linear [0, 1], BGR). Integer arrays are decoded
// as ReadImage decodes integer files (scale by 1 / max, then the sRGB curve), so an array holding a
// PNG's values gives the bytes ReadImage gives for that PNG. A float32 gray array is wrapped, not
// copied; a float32 RGB array costs one channel-reordering pass, unless keep_rgb (the caller
// passes EnhanceInput::rgb): then float32 arrays are wrapped and others keep their R, G, B order.
// Call without the GIL.
cv::Mat ToInternal(const ArrayView& v, Encoding encoding, const std::string& what, bool keep_rgb) {
  cv::Mat m = v.mat;
  if (m.depth() != CV_32F) {
    if (encoding == Encoding::kNone)
      throw Error(what + ": integer arrays need encoding='srgb' or 'linear'");
    const double max_value = m.depth() == CV_8U ? 255.0 : 65535.0;
    cv::Mat f;
    m.convertTo(f, CV_32F);
    f *= 1.0 / max_value;  // the same two steps as ReadImage
    m = f;
  }
  if (encoding == Encoding::kSrgb) m = SrgbToLinear(m);
  if (v.channels == 3 && !keep_rgb) {
    cv::Mat bgr;
    cv::cvtColor(m, bgr, cv::COLOR_RGB2BGR);
    return bgr;
  }
  return m;
}

// A float32 Mat -> NumPy as it is (no reordering), sharing the Mat's buffer: the array keeps the
// Mat alive. A Mat over memory it does not own (e.g. a NumPy input passed through) is copied.
py::array WrapNumpy(const cv::Mat& mat) {
  if (mat.empty()) return py::none();
  CV_Assert(mat.depth() == CV_32F);
  auto* keep = new cv::Mat(mat.isContinuous() && mat.u != nullptr ? mat : mat.clone());
  py::capsule owner(keep, [](void* p) { delete static_cast<cv::Mat*>(p); });
  const py::ssize_t c = keep->channels();
  const py::ssize_t rows = keep->rows, cols = keep->cols;
  if (c == 1) {
    return py::array_t<float>({rows, cols}, {cols * 4, py::ssize_t{4}}, keep->ptr<float>(), owner);
  }
  return py::array_t<float>({rows, cols, c}, {cols * c * 4, c * 4, py::ssize_t{4}},
                            keep->ptr<float>(), owner);
}

// turbid's image -> NumPy (RGB for 3 channels). One-channel results share the Mat's buffer.
py::array ToNumpy(const cv::Mat& mat) {
  if (mat.empty()) return py::none();
  // A Mat over memory it does not own (a NumPy input passed through) is copied.
  cv::Mat m = mat.isContinuous() && mat.u != nullptr ? mat : mat.clone();
  CV_Assert(m.depth() == CV_32F);
  const int c = m.channels();
  if (c == 1) return WrapNumpy(m);
  py::array_t<float> out({m.rows, m.cols, c});
  cv::Mat dst(m.rows, m.cols, m.type(), out.mutable_data());
  {
    WorkScope release;
    if (c == 3)
      cv::cvtColor(m, dst, cv::COLOR_BGR2RGB);
    else
      m.copyTo(dst);
  }
  return out;
}

MetricImage MetricFromArray(const ArrayView& v) {
  MetricImage m;
  m.data_range = v.mat.depth() == CV_8U ? 255.0 : (v.mat.depth() == CV_16U ? 65535.0 : 1.0);
  cv::Mat f = v.mat;
  if (f.depth() != CV_32F) f.convertTo(f, CV_32F);
  if (v.channels == 3) {
    cv::Mat bgr;
    cv::cvtColor(f, bgr, cv::COLOR_RGB2BGR);
    f = bgr;
  }
  m.pixels = f;
  return m;
}

}  // namespace turbid::pyext
