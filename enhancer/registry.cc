// The one method table: the paper's methods (paper_methods.h), the oracles (oracle.h) and the
// baselines (baselines.h), in that order.
#include "enhancer/registry.h"

#include <map>
#include <mutex>

#include "enhancer/baselines.h"
#include "enhancer/method.h"
#include "enhancer/oracle.h"
#include "enhancer/paper_methods.h"
#include "scenes/error.h"

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

cv::Mat Enhance(const std::string& name, const nlohmann::json& params, const EnhanceInput& input) {
  const MethodEntry& entry = FindEntry(name);
  if (!params.is_null() && !params.is_object()) {
    throw Error(name + ": parameters must be a JSON object");
  }
  ValidateEnhanceImage(input.image, name);
  const nlohmann::json empty = nlohmann::json::object();
  cv::Mat out = entry.run(params.is_null() ? empty : params, input);
  if (out.size() != input.image.size() || out.channels() != input.image.channels() ||
      out.depth() != CV_32F) {
    throw Error(name + ": internal error: output size, channels or type differ from the input");
  }
  cv::patchNaNs(out, 0.0);
  cv::min(out, 1.0, out);
  cv::max(out, 0.0, out);
  return out;
}

}  // namespace turbid
