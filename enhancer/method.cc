#include "enhancer/method.h"

#include <cmath>
#include <cstdint>
#include <cstring>

namespace turbid {

ParamBinder::ParamBinder(std::string method, const nlohmann::json& params)
    : method_(std::move(method)), params_(params) {
  if (!params_.is_null() && !params_.is_object()) {
    throw Error(method_ + ": parameters must be a JSON object, got " + params_.dump());
  }
}

const nlohmann::json* ParamBinder::Find(const std::string& key) {
  bound_.insert(key);
  if (!params_.is_object()) return nullptr;
  auto it = params_.find(key);
  if (it == params_.end()) return nullptr;
  return &*it;
}

void ParamBinder::Fail(const std::string& key, const std::string& problem) const {
  throw Error(method_ + ": parameter '" + key + "': " + problem);
}

void ParamBinder::Bind(const std::string& key, double* field) {
  const nlohmann::json* value = Find(key);
  if (value == nullptr) return;
  if (!value->is_number()) Fail(key, "expected a number, got " + value->dump());
  const double v = value->get<double>();
  if (!std::isfinite(v)) Fail(key, "must be finite");
  *field = v;
}

void ParamBinder::Bind(const std::string& key, int* field) {
  const nlohmann::json* value = Find(key);
  if (value == nullptr) return;
  if (!value->is_number()) Fail(key, "expected an integer, got " + value->dump());
  const double v = value->get<double>();
  if (!std::isfinite(v) || v != std::floor(v) || std::fabs(v) > 2147483647.0) {
    Fail(key, "expected an integer, got " + value->dump());
  }
  *field = static_cast<int>(v);
}

void ParamBinder::Bind(const std::string& key, bool* field) {
  const nlohmann::json* value = Find(key);
  if (value == nullptr) return;
  if (!value->is_boolean()) Fail(key, "expected true or false, got " + value->dump());
  *field = value->get<bool>();
}

void ParamBinder::Bind(const std::string& key, std::string* field) {
  const nlohmann::json* value = Find(key);
  if (value == nullptr) return;
  if (!value->is_string()) Fail(key, "expected a string, got " + value->dump());
  *field = value->get<std::string>();
}

void ParamBinder::FinishKeys() {
  if (!params_.is_object()) return;
  for (auto it = params_.begin(); it != params_.end(); ++it) {
    if (bound_.count(it.key()) == 0) {
      std::string known;
      for (const std::string& k : bound_) known += (known.empty() ? "" : ", ") + k;
      throw Error(method_ + ": unknown parameter '" + it.key() +
                  "' (known: " + (known.empty() ? "none" : known) + ")");
    }
  }
}

// True when every float of the row is finite: a float is NaN or ±inf exactly when its exponent
// bits are all ones. An integer OR over the row vectorises (cv::checkRange is a scalar pass, ~1.5
// ms on a 1360x1024 image, a tenth of `simplified`).
bool RowIsFinite(const float* row, size_t count) {
  uint32_t all_ones_exponent = 0;
  for (size_t i = 0; i < count; ++i) {
    uint32_t bits;
    std::memcpy(&bits, row + i, sizeof(bits));
    all_ones_exponent |= static_cast<uint32_t>((bits & 0x7f800000u) == 0x7f800000u);
  }
  return all_ones_exponent == 0;
}

void ValidateEnhanceImageLayout(const cv::Mat& image, const std::string& method) {
  if (image.empty()) throw Error(method + ": empty input image");
  if (image.depth() != CV_32F) throw Error(method + ": input image must be float32");
  if (image.channels() != 1 && image.channels() != 3) {
    throw Error(method + ": input image must have 1 or 3 channels, got " +
                std::to_string(image.channels()));
  }
}

void ValidateEnhanceImage(const cv::Mat& image, const std::string& method) {
  ValidateEnhanceImageLayout(image, method);
  const size_t row_floats = static_cast<size_t>(image.cols) * image.channels();
  for (int y = 0; y < image.rows; ++y) {
    if (!RowIsFinite(image.ptr<float>(y), row_floats)) {
      throw Error(method + ": input image has non-finite values (row " + std::to_string(y) + ")");
    }
  }
}

}  // namespace turbid
