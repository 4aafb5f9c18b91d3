// The pre-optimisation oracles (commit 6722196), the reference of oracle_test.cc.
#pragma once

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "enhancer/oracle/oracle.h"
#include "enhancer/oracle/oracle_internal.h"
#include "scenes/scene.h"

namespace turbid::oracle_reference {

OracleResult OracleExactEnhance(const OracleExactOptions& options, const cv::Mat& image,
                                const Scene& scene, const RenderRecord& sidecar);
OracleResult OracleEnhance(const OracleOptions& options, const cv::Mat& image, const Scene& scene,
                           const RenderRecord& sidecar);
cv::Mat DeconvolveReflect101(const cv::Mat& image, const cv::Mat& kernel, double nsr);
// The data term and hierarchical MMSE on given truth maps (the step oracle_internal::OracleMmse
// replaced).
oracle_internal::OracleMmseResult OracleMmse(const OracleOptions& o, const cv::Mat& image,
                                             const cv::Mat& transmission, const cv::Mat& irradiance,
                                             const cv::Mat& snow, const cv::Mat& veil, double gain,
                                             double floor_var, double clip_level);

}  // namespace turbid::oracle_reference
