// Internal to the extension module (python/src/): the shared pieces of the bindings — thread
// count and GIL release (ThreadCount, WorkScope), errors in Python's words, JSON text, and the
// NumPy <-> cv::Mat conversions. The bindings are module.cc.
#pragma once

#include <pthread.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <optional>
#include <string>

#include "core/error.h"
#include "simulator/render.h"
#include "tools/harness/metric_image.h"

namespace turbid::pyext {

namespace py = pybind11;
using nlohmann::json;

// OpenCV runs every parallel_for_ (ours and its own, cvtColor included) in one process-wide TBB
// arena, and cv::setNumThreads terminates and re-creates that arena: done while another thread is
// inside it, the process crashes. So the count changes only while no turbid call does work without
// the GIL: every such stretch is a WorkScope (it replaces py::gil_scoped_release), and a change
// asked for while one is open waits for the last to close, which applies it holding the GIL (no
// GIL-holding code runs OpenCV meanwhile). Enter and leave happen holding the GIL, never waiting.
class ThreadCount {
 public:
  static ThreadCount& Get() {
    static ThreadCount* const instance = new ThreadCount();  // never destroyed (atexit order)
    return *instance;
  }
  void Enter() {
    std::lock_guard<std::mutex> lock(mutex_);
    ++active_;
  }
  void Leave() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (--active_ == 0 && pending_) {
      cv::setNumThreads(*pending_);
      pending_.reset();
    }
  }
  // Applies `n` (OpenCV's meaning: > 0 threads, -1 its default) now when nothing runs, else when
  // the last running call returns.
  void Request(int n) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (active_ == 0) {
      cv::setNumThreads(n);
      pending_.reset();
    } else {
      pending_ = n;
    }
  }
  // The child of fork() has one thread, which is in no WorkScope of its own.
  static void AfterForkInChild() { Get().active_ = 0; }

 private:
  ThreadCount() { pthread_atfork(nullptr, nullptr, &ThreadCount::AfterForkInChild); }
  std::mutex mutex_;
  int active_ = 0;
  std::optional<int> pending_;
};

// Releases the GIL for C++ work, as py::gil_scoped_release, and holds the thread count still.
class WorkScope {
 public:
  WorkScope() {
    ThreadCount::Get().Enter();  // holding the GIL
    release_.emplace();
  }
  WorkScope(const WorkScope&) = delete;
  WorkScope& operator=(const WorkScope&) = delete;
  ~WorkScope() {
    release_.reset();  // the GIL first: a pending change is applied holding it
    ThreadCount::Get().Leave();
  }

 private:
  std::optional<py::gil_scoped_release> release_;
};

// turbid::Error is raised as ValueError, except the messages of failed file access (OSError).
class IoError : public Error {
 public:
  using Error::Error;
};

enum class Encoding { kNone, kLinear, kSrgb };

struct ArrayView {
  cv::Mat mat;  // header over the NumPy buffer (no copy); depth CV_8U, CV_16U or CV_32F
  int channels = 1;
};

// A scene as the Python class holds it: the renderer owns the scene (module.cc).
struct PyScene {
  std::shared_ptr<const Renderer> renderer;
  std::string spec;  // how it was loaded ("" for arrays)
  double scale = 1.0;
  const Scene& scene() const { return renderer->scene(); }
};

double ProcessCpuSeconds();
int64_t MaxNumThreads();
void SetNumThreads(const py::int_& value);
bool LooksLikeIo(const std::string& message);
std::string PythonSpelling(std::string message);
json ParseJsonText(const std::string& text, const std::string& what);
json ReadConfigFile(const std::string& path);
Encoding ParseEncoding(const std::optional<std::string>& text);
// Checks dtype, shape and layout and wraps the buffer; `allow_color`: H x W x 3 accepted.
ArrayView ViewArray(const py::array& a, const std::string& what, bool allow_color = true);
// NumPy image -> turbid's in-memory image (float32 linear [0, 1], BGR unless keep_rgb); common.cc.
cv::Mat ToInternal(const ArrayView& v, Encoding encoding, const std::string& what,
                   bool keep_rgb = false);
py::array WrapNumpy(const cv::Mat& mat);
// As `turbid score` reads files: integer arrays keep their raw values (data range 255 / 65535),
// float32 is [0, 1]; R, G, B becomes B, G, R. Call without the GIL.
MetricImage MetricFromArray(const ArrayView& v);
// The batch entry points (batch.cc): enhance, score and the sRGB curve over N x H x W x C arrays,
// the items in parallel with the GIL released; score's domains.
void DefineBatch(py::module_& m);
// module.cc: a scene from a spec (builtin scale), a config from a dict or a JSON path.
PyScene SceneFromSpec(const std::string& spec, double scale);
json ConfigFrom(const py::object& config, std::string* source);
// Render parameters as Python callers write them: top-level dotted keys ("water.type",
// "light.lights.0.power") are set into the nested object as `turbid render --set` sets them,
// after the nested keys (module.cc).
json ExpandDottedParams(json params, const std::string& what);
// The training-data path (dataset.cc): generate plans, per-epoch draws, crops before rendering.
void DefineDataset(py::module_& m);
// report, merge and regress (harness.cc).
void DefineHarness(py::module_& m);
// turbid.water.fit (water.cc).
void DefineWater(py::module_& m);
py::array ToNumpy(const cv::Mat& mat);

}  // namespace turbid::pyext
