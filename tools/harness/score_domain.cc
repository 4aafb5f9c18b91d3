#include "tools/harness/score_domain.h"

#include "core/error.h"
#include "core/safe_name.h"

namespace turbid {

std::string ScoreDomainName(ScoreDomain domain) {
  return domain == ScoreDomain::kLinear ? "linear" : "encoded";
}

ScoreDomain ScoreDomainFromName(const std::string& name, const std::string& what) {
  if (name == "encoded") return ScoreDomain::kEncoded;
  if (name == "linear") return ScoreDomain::kLinear;
  throw Error(what, "unknown score domain '" + PrintableName(name) +
                        "' (\"encoded\": camera-coded images, the default; \"linear\")");
}

double CameraCoding::DataRange() const {
  if (bit_depth == 8) return 255.0;
  if (bit_depth == 16) return 65535.0;
  return 1.0;
}

std::string CameraCoding::Describe() const {
  if (bit_depth != 8 && bit_depth != 16) return "linear float";
  return CameraEncodingName(encoding) + " " + std::to_string(bit_depth) + "-bit";
}

cv::Mat EncodeForScoring(const cv::Mat& linear, const CameraCoding& camera) {
  if (linear.depth() != CV_32F) throw Error("score: images must be float32 to be encoded");
  if (camera.bit_depth == 8 || camera.bit_depth == 16) {
    return EncodeCodes(linear, camera.encoding, camera.bit_depth);
  }
  cv::Mat clipped = linear.clone();
  cv::patchNaNs(clipped, 0.0);
  cv::min(cv::max(clipped, 0.0), 1.0, clipped);
  return clipped;
}

std::string MetricDomain(ScoreDomain domain, bool needs_reference) {
  return needs_reference ? ScoreDomainName(domain) : "linear";
}

}  // namespace turbid
