// Metrics by name: `turbid score`, the sweep and `--list` read this one table. Contract used by
// tools/; extend, do not break.
#pragma once

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <map>
#include <memory>
#include <string>
#include <vector>

namespace turbid {

// Analysis of an original (degraded) image that scoring many restorations of it can share (the
// visible-edge mask of the original): create one per original with NewOriginalCache() and pass it
// with every ComputeMetrics call for that original, which must stay alive and unchanged while the
// cache is in use. The values are the same with or without it; a cache handed another original
// (buffer, size, type or range) starts over. Thread-safe.
struct OriginalCache;
std::shared_ptr<OriginalCache> NewOriginalCache();

struct MetricInputs {
  cv::Mat reference;  // ground truth (full-reference metrics), float32 [0,1]
  cv::Mat image;      // the image being scored (e.g. the enhanced one), float32 [0,1]
  cv::Mat original;   // the degraded input the restoration started from (visible-edge metrics)
  // Peak value of the pixel scale shared by all three images: 0 = from the depth (1 for float
  // [0,1], 255 for 8-bit Mats). `turbid score` passes raw 8-bit file values as float with 255,
  // which keeps MSE/PSNR exact (docs/metrics.md, "Inputs").
  double data_range = 0.0;
  OriginalCache* original_cache = nullptr;  // optional, see NewOriginalCache
};

struct MetricInfo {
  std::string name;            // registry key, e.g. "ssim", "psnr", "hautiere_e"
  std::string summary;         // one line, with the reference matched
  bool needs_reference = false;
  bool needs_original = false;
  bool higher_is_better = true;
};

const std::vector<MetricInfo>& ListMetrics();
const MetricInfo& FindMetric(const std::string& name);  // throws Error for unknown names

// Computes exactly the named metrics, sharing intermediate work between them. Throws Error on
// unknown names or unusable inputs (size/channel mismatch, empty). PSNR of identical images is
// +inf. elapsed_ms, when given, receives each metric's wall time in ms (work shared between metrics
// is charged to the first one that needs it).
std::map<std::string, double> ComputeMetrics(const std::vector<std::string>& names,
                                             const MetricInputs& inputs,
                                             std::map<std::string, double>* elapsed_ms = nullptr);

// A metric value as JSON: a number when finite, else the string "inf", "-inf" or "nan".
nlohmann::json MetricValueToJson(double value);
// The same convention as text (CSV and tables): "%.10g" for finite values.
std::string MetricValueToText(double value);

// Splits "ssim,psnr, cnr" into names, validating each with FindMetric. "all" expands to every
// metric whose needs are met by has_reference / has_original.
std::vector<std::string> ParseMetricList(const std::string& list, bool has_reference,
                                         bool has_original);

}  // namespace turbid
