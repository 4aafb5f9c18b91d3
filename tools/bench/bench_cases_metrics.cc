// `turbid bench` cases of issue 18 item 2 (no-reference metrics at 1360x1024, one core): the
// visible-edge pair in both variants, UIQM and UCIQE. None has a fast published peer (the
// published visible-edge code is an Octave triple loop, UIQM/UCIQE are NumPy scripts), so the
// goals are absolute; the agreement column prints the values, which the tests pin to the
// pre-optimisation implementation and to the published references
// (tests/metrics/no_reference_fast_paths_test.cc, no_reference_*_test.cc).
#include <benchmark/benchmark.h>

#include <memory>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "metrics/no_reference.h"
#include "metrics/registry.h"
#include "tools/bench/bench_cases.h"
#include "tools/harness/score_domain.h"

namespace turbid::bench {

namespace {

// The sweep's full-reference scores in the encoded domain against the same on linear floats.
BenchCase EncodedDomainCase(const InputsFn& in) {
  // The sweep's full-reference scores in the encoded domain (issue 32 item 1): code the result
  // (sRGB 8-bit, once per image; the reference is coded once per item, outside the loop) and
  // score SSIM + PSNR + MSE on the codes, against the same metrics on the linear floats.
  BenchCase c;
  c.name = "metrics/full_reference/encoded_domain";
  c.peer_name = "the same metrics on linear floats";
  const CameraCoding camera{CameraEncoding::kSrgb, 8};
  const auto reference = std::make_shared<cv::Mat>();
  const auto coded_reference = [in, camera, reference]() -> const cv::Mat& {
    if (reference->empty()) *reference = EncodeForScoring(in().seafloor.image, camera);
    return *reference;
  };
  const std::vector<std::string> names = {"ssim", "psnr", "mse"};
  c.ours = [in, camera, coded_reference, names] {
    MetricInputs m;
    m.reference = coded_reference();
    m.image = EncodeForScoring(in().seafloor_degraded_linear, camera);
    m.data_range = camera.DataRange();
    benchmark::DoNotOptimize(ComputeMetrics(names, m).size());
  };
  c.peer = [in, names] {
    MetricInputs m;
    m.reference = in().seafloor.image;
    m.image = in().seafloor_degraded_linear;
    benchmark::DoNotOptimize(ComputeMetrics(names, m).size());
  };
  c.agreement = [in, camera, coded_reference, names] {
    MetricInputs m;
    m.reference = coded_reference();
    m.image = EncodeForScoring(in().seafloor_degraded_linear, camera);
    m.data_range = camera.DataRange();
    const double coded = ComputeMetrics(names, m).at("ssim");
    MetricInputs l;
    l.reference = in().seafloor.image;
    l.image = in().seafloor_degraded_linear;
    return "SSIM encoded " + Format("%.4f", coded) + ", linear " +
           Format("%.4f", ComputeMetrics(names, l).at("ssim"));
  };
  c.goal = {0.8, 0.0, "issue 32 item 1 (scoring coded must not slow sweeps noticeably)"};
  return c;
}

}  // namespace

void AddMetricsCases(std::vector<BenchCase>& cases, const InputsFn& in) {
  cases.push_back(EncodedDomainCase(in));
  for (VisibleEdgeVariant variant : {VisibleEdgeVariant::kPaper, VisibleEdgeVariant::kIfsttar}) {
    BenchCase c;
    c.name = "metrics/visible_edges/pair/" + VisibleEdgeVariantName(variant);
    VisibleEdgeOptions o;
    o.variant = variant;
    // The degraded hull render is the "original", the clean hull the "restored" image.
    c.ours = [in, o] {
      benchmark::DoNotOptimize(VisibleEdges(o, in().degraded_color8, in().clean_color8).e);
    };
    c.agreement = [in, o] {
      const VisibleEdgeResult r = VisibleEdges(o, in().degraded_color8, in().clean_color8);
      return "e " + Format("%.6f", r.e) + ", r " + Format("%.6f", r.r_mean) + ", n_o " +
             Format("%.0f", static_cast<double>(r.visible_original)) + ", n_r " +
             Format("%.0f", static_cast<double>(r.visible_restored));
    };
    c.goal = {0.0, 50.0, "issue 18 item 2 (colour 1360x1024 pair, one core)"};
    cases.push_back(c);
  }
  {
    BenchCase c;
    c.name = "metrics/uiqm/color/8bit";
    c.ours = [in] { benchmark::DoNotOptimize(Uiqm({}, in().degraded_color8).uiqm); };
    c.agreement = [in] {
      const UiqmResult r = Uiqm({}, in().degraded_color8);
      return "UIQM " + Format("%.9f", r.uiqm) + " (funiegan-compat)";
    };
    c.goal = {0.0, 20.0, "issue 18 item 2 (colour 1360x1024, one core)"};
    cases.push_back(c);
  }
  {
    BenchCase c;
    c.name = "metrics/uciqe/color/8bit";
    // Not a competitor: the OpenCV 8-bit Lab conversion UCIQE must start with (the reference's
    // own cv2 call), timed alone to show how much of UCIQE it is.
    c.peer_name = "cv::cvtColor BGR2Lab alone";
    c.ours = [in] { benchmark::DoNotOptimize(Uciqe({}, in().degraded_color8).uciqe); };
    c.peer = [in] {
      cv::Mat lab;
      cv::cvtColor(in().degraded_color8, lab, cv::COLOR_BGR2Lab);
      benchmark::DoNotOptimize(lab.data);
    };
    c.agreement = [in] {
      return "UCIQE " + Format("%.9f", Uciqe({}, in().degraded_color8).uciqe) + " (jou-uip-compat)";
    };
    c.goal = {0.0, 10.0, "issue 18 item 2 (colour 1360x1024, one core)"};
    cases.push_back(c);
  }
}

}  // namespace turbid::bench
