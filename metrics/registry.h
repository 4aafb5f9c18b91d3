// Metrics by name: `turbid score`, the sweep and `--list` read this one table. Contract used by
// tools/; extend, do not break.
#pragma once

#include <opencv2/core.hpp>

#include <map>
#include <string>
#include <vector>

namespace turbid {

struct MetricInputs {
  cv::Mat reference;  // ground truth (full-reference metrics), float32 [0,1]
  cv::Mat image;      // the image being scored (e.g. the enhanced one), float32 [0,1]
  cv::Mat original;   // the degraded input the restoration started from (visible-edge metrics)
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
// unknown names or unusable inputs (size/channel mismatch, empty). PSNR of identical images is +inf.
std::map<std::string, double> ComputeMetrics(const std::vector<std::string>& names,
                                             const MetricInputs& inputs);

}  // namespace turbid
