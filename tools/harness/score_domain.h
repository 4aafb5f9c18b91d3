// The scoring domain of a sweep (experiment key "score_domain", docs/experiments.md "Scoring
// domain"): where the full-reference metrics (SSIM, PSNR, MSE) compare a result with the ground
// truth.
//
// "encoded" (the default): both images as the item's camera writes them — clipped to [0, 1],
// coded with the render's camera encoding (sRGB by default) and quantised to its bit depth — and
// scored on those integer codes with the data range 2^bits - 1, exactly as `turbid score` (and
// scikit-image with that data_range) scores the PNG files. A float camera (bit_depth 32) writes
// linear values: they are scored clipped to [0, 1] with range 1. "linear": the linear-light float
// images as the libraries hold them (what every sweep did before issue 32).
//
// No-reference metrics (CNR, Hautiere e/r/sigma, UIQM, UCIQE) are not changed by the domain: they
// read the linear images as before (their inputs are documented in docs/metrics-no-reference.md);
// tables state each metric's domain.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "scenes/camera_encoding.h"

namespace turbid {

enum class ScoreDomain { kEncoded, kLinear };

// "encoded" / "linear".
std::string ScoreDomainName(ScoreDomain domain);
// Parses "encoded" / "linear"; throws Error(what, ...) naming the value otherwise.
ScoreDomain ScoreDomainFromName(const std::string& name, const std::string& what);

// How an item's camera writes images: its encoding and bit depth (8, 16 or 32 = float).
struct CameraCoding {
  CameraEncoding encoding = CameraEncoding::kSrgb;
  int bit_depth = 8;
  // The data range the coded images are scored with: 2^bits - 1, or 1 for a float camera.
  double DataRange() const;
  // "srgb 8-bit", "linear 16-bit", "linear float".
  std::string Describe() const;
};

// A linear float32 [0, 1] image as the camera writes it (see above): float32 integer codes for 8
// and 16 bits, clipped linear values for 32. One pass over the image.
cv::Mat EncodeForScoring(const cv::Mat& linear, const CameraCoding& camera);

// The domain a metric is scored in, as tables state it: `domain` for full-reference metrics
// (needs_reference), "linear" for the others.
std::string MetricDomain(ScoreDomain domain, bool needs_reference);

}  // namespace turbid
