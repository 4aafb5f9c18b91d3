// The registry's internal entry type (a method's parameters are read by enhancer/params.h).
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
// strictly (ReadMethodParams with its field table, enhancer/params.h), run, and return float32
// [0,1] with the input's channel count.
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
