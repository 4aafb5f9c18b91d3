// The registry's internal entry type and the strict JSON -> Options binder every method uses.
// enhancer/registry.h is the public contract (ListMethods, FindMethod, Enhance); this header is
// for method implementers (enhancer/*.cc, including enhancer/paper/ and enhancer/baselines/).
#pragma once

#include <functional>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <set>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "enhancer/registry.h"
#include "core/error.h"

namespace turbid {

// One method: its self-description and how to run it. `run` receives the caller's overrides (a
// JSON object, possibly empty; the registry already checked it is an object) and must bind them
// strictly (ParamBinder below), run, and return float32 [0,1] with the input's channel count.
struct MethodEntry {
  MethodInfo info;
  std::function<cv::Mat(const nlohmann::json& params, const EnhanceInput& input)> run;
  // Optional: whether these parameter overrides make the method privileged (a variant that reads
  // true simulation parameters); info.privileged covers the defaults. Throws like `run`'s binding.
  std::function<bool(const nlohmann::json& params)> privileged_with;
  // `run` honours EnhanceInput::rgb (a 3-channel image in R, G, B order) and returns the same
  // order; otherwise Enhance hands it B, G, R and reorders the result.
  bool rgb_native = false;
};

// Binds a JSON params object onto an Options struct strictly:
//   ParamBinder b("dcp", params);
//   b.Bind("omega", &options.omega);        // double / int / bool / std::string fields
//   b.Bind("distribution", &name_string);   // enums: bind a string, convert after
//   b.Finish(options);                      // unknown keys -> Error; then options.Check -> Error
// Errors name the method and key: "dcp: parameter 'omega': expected a number, got \"x\"".
// Integers accept JSON integers or numbers with an integral value; doubles accept any finite
// number; bools accept only true/false. Non-finite numbers are rejected.
class ParamBinder {
 public:
  ParamBinder(std::string method, const nlohmann::json& params);

  void Bind(const std::string& key, double* field);
  void Bind(const std::string& key, int* field);
  void Bind(const std::string& key, bool* field);
  void Bind(const std::string& key, std::string* field);

  // Throws Error for keys never passed to Bind; then Check()s `options` (if it has Check).
  template <typename Options>
  void Finish(const Options& options) {
    FinishKeys();
    std::string why;
    if (!options.Check(&why)) throw Error(method_ + ": " + why);
  }
  void FinishKeys();  // the unknown-key check alone

  const std::string& method() const { return method_; }

 private:
  const nlohmann::json* Find(const std::string& key);
  [[noreturn]] void Fail(const std::string& key, const std::string& problem) const;

  std::string method_;
  const nlohmann::json& params_;
  std::set<std::string> bound_;
};

// Helper for MethodInfo::params: {name, default (as JSON), doc, how the image bounds it}.
inline MethodParam Param(std::string name, nlohmann::json default_value, std::string doc,
                         SizeBound bound = SizeBound::kNone) {
  return MethodParam{std::move(name), std::move(default_value), std::move(doc), bound};
}

// Shared input validation for methods: non-empty CV_32F, 1 or 3 channels, all finite. Throws
// Error("<method>: ...").
void ValidateEnhanceImage(const cv::Mat& image, const std::string& method);
// The same without the finiteness scan (a pass over the image), for methods whose own arithmetic
// turns any non-finite input into a non-finite value they detect anyway; they call
// ValidateEnhanceImage then, for its message.
void ValidateEnhanceImageLayout(const cv::Mat& image, const std::string& method);
// True when every one of `count` floats is finite (no NaN, no ±inf); vectorises.
bool RowIsFinite(const float* row, size_t count);

}  // namespace turbid
