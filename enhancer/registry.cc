// The one method table: the paper's methods (paper/entries.h), the oracles (oracle.h) and the
// baselines (baselines/registry.h), in that order.
#include "enhancer/registry.h"

#include <algorithm>
#include <cstdint>
#include <map>
#include <mutex>
#include <opencv2/imgproc.hpp>

#include "enhancer/baselines/registry.h"
#include "enhancer/method.h"
#include "enhancer/oracle/oracle.h"
#include "enhancer/paper/entries.h"
#include "enhancer/seathru/entries.h"
#include "core/error.h"

namespace turbid {
namespace {

struct Table {
  std::vector<MethodEntry> entries;
  std::vector<MethodInfo> infos;
};

const Table& GetTable() {
  static const Table table = [] {
    Table t;
    t.entries = PaperMethodEntries();
    for (MethodEntry& e : OracleMethodEntries()) t.entries.push_back(std::move(e));
    for (MethodEntry& e : BaselineMethodEntries()) t.entries.push_back(std::move(e));
    for (MethodEntry& e : SeathruMethodEntries()) t.entries.push_back(std::move(e));
    for (const MethodEntry& e : t.entries) t.infos.push_back(e.info);
    return t;
  }();
  return table;
}

const MethodEntry& FindEntry(const std::string& name) {
  const Table& t = GetTable();
  for (const MethodEntry& e : t.entries) {
    if (e.info.name == name) return e;
  }
  std::string known;
  for (const MethodEntry& e : t.entries) known += (known.empty() ? "" : ", ") + e.info.name;
  throw Error("unknown method '" + name + "' (known: " + known + ")");
}

}  // namespace

const std::vector<MethodInfo>& ListMethods() { return GetTable().infos; }

const MethodInfo& FindMethod(const std::string& name) { return FindEntry(name).info; }

bool IsPrivileged(const std::string& name, const nlohmann::json& params) {
  const MethodEntry& entry = FindEntry(name);
  if (!entry.privileged_with) return entry.info.privileged;
  if (!params.is_null() && !params.is_object()) {
    throw Error(name + ": parameters must be a JSON object");
  }
  return entry.privileged_with(params.is_null() ? nlohmann::json::object() : params);
}

int64_t SizeBoundLimit(SizeBound bound, cv::Size size) {
  const int64_t side = std::max<int64_t>(1, std::max(size.width, size.height));
  switch (bound) {
    case SizeBound::kWindow:
      return 2 * side + 1;
    case SizeBound::kRadius:
    case SizeBound::kPerAxis:
      return side;
    case SizeBound::kNone:
      break;
  }
  return INT64_MAX;
}

void CheckSizeParams(const MethodInfo& info, const nlohmann::json& params, cv::Size image_size) {
  for (const MethodParam& p : info.params) {
    if (p.bound == SizeBound::kNone) continue;
    const nlohmann::json* value = &p.default_value;
    if (params.is_object() && params.contains(p.name)) value = &params[p.name];
    if (!value->is_number() || !p.default_value.is_number()) continue;  // the binder says why
    const double v = value->get<double>();
    const int64_t limit =
        std::max(SizeBoundLimit(p.bound, image_size), p.default_value.get<int64_t>());
    if (!(v > static_cast<double>(limit))) continue;
    const char* rule = p.bound == SizeBound::kWindow   ? "2 x its larger side + 1"
                       : p.bound == SizeBound::kRadius ? "its larger side"
                                                       : "its larger side (regions per axis)";
    throw Error(info.name + ": parameter '" + p.name + "' = " + value->dump() + " exceeds " +
                std::to_string(limit) + ", the bound for a " + std::to_string(image_size.width) +
                "x" + std::to_string(image_size.height) + " image (" + rule + ")");
  }
}

cv::Mat Enhance(const std::string& name, const nlohmann::json& params, const EnhanceInput& input) {
  const MethodEntry& entry = FindEntry(name);
  if (!params.is_null() && !params.is_object()) {
    throw Error(name + ": parameters must be a JSON object");
  }
  ValidateEnhanceImage(input.image, name);
  CheckSizeParams(entry.info, params, input.image.size());
  const nlohmann::json empty = nlohmann::json::object();
  const bool reorder = input.rgb && input.image.channels() == 3 && !entry.rgb_native;
  cv::Mat out;
  if (reorder) {
    EnhanceInput bgr = input;
    bgr.image = cv::Mat();  // a new buffer: the copied header still points at the caller's pixels
    cv::cvtColor(input.image, bgr.image, cv::COLOR_RGB2BGR);
    bgr.rgb = false;
    out = entry.run(params.is_null() ? empty : params, bgr);
  } else {
    out = entry.run(params.is_null() ? empty : params, input);
  }
  if (out.size() != input.image.size() || out.channels() != input.image.channels() ||
      out.depth() != CV_32F) {
    throw Error(name + ": internal error: output size, channels or type differ from the input");
  }
  // An output that shares the input's memory (a method returning its input) is copied first.
  if (out.data == input.image.data) out = out.clone();
  ClampEnhanceOutput(out);
  if (reorder) cv::cvtColor(out, out, cv::COLOR_BGR2RGB);
  return out;
}

void ClampEnhanceOutput(cv::Mat& image) {
  CV_Assert(image.depth() == CV_32F);
  const int n = image.cols * image.channels();
  for (int y = 0; y < image.rows; ++y) {
    float* p = image.ptr<float>(y);
    // max(0, v) is 0 for NaN and -0 (the comparison 0 < v is false), as patchNaNs then cv::max.
    for (int i = 0; i < n; ++i) p[i] = std::min(std::max(0.0f, p[i]), 1.0f);
  }
}

}  // namespace turbid
