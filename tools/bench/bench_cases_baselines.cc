// `turbid bench` cases for the baselines tarel and fusion (issue 18 item 3): the whole methods at
// 1360x1024 gray (the goals) and at 640x480 colour (how the table1 sweep runs them), and
// tarel's median step against OpenCV's 8-bit median, the one peer that exists for it.
#include <benchmark/benchmark.h>

#include <opencv2/imgproc.hpp>

#include "enhancer/baselines/fusion.h"
#include "enhancer/baselines/median.h"
#include "enhancer/baselines/tarel.h"
#include "tools/bench/bench_cases.h"

namespace turbid::bench {

void AddBaselineCases(std::vector<BenchCase>& cases, const InputsFn& in) {
  const std::string source = "issue 18 item 3 (at 1360x1024 gray, one core)";
  const std::string colour_source =
      "issue 18 item 3 (640x480 colour, as the table1 sweep runs it; the goal is set at 1360x1024 "
      "gray)";
  for (bool color : {false, true}) {
    auto image = [in, color]() -> const cv::Mat& {
      return color ? in().seafloor_degraded_linear : in().degraded_gray_linear;
    };
    const std::string kind = color ? "color" : "gray";
    {
      BenchCase c;
      c.name = "baseline/tarel/" + kind;
      c.ours = [image] { benchmark::DoNotOptimize(Tarel(TarelOptions{}, image()).data); };
      c.goal = color ? Goal{0.0, 0.0, colour_source} : Goal{0.0, 100.0, source};
      cases.push_back(c);
    }
    {
      BenchCase c;
      c.name = "baseline/fusion/" + kind;
      c.ours = [image] { benchmark::DoNotOptimize(Fusion(FusionOptions{}, image()).data); };
      c.goal = color ? Goal{0.0, 0.0, colour_source} : Goal{0.0, 30.0, source};
      cases.push_back(c);
    }
  }
  // Tarel's median (11x11, exact) on the 8-bit render read as floats, against cv::medianBlur on
  // the same 8-bit codes (OpenCV's float median stops at 5x5). OpenCV replicates the border, we
  // reflect it, so the outputs are compared away from the border.
  {
    BenchCase c;
    c.name = "baseline/tarel/median11/gray";
    c.peer_name = "cv::medianBlur (8-bit)";
    c.ours = [in] { benchmark::DoNotOptimize(MedianFilter(in().degraded_gray_f, 11).data); };
    c.peer = [in] {
      cv::Mat out;
      cv::medianBlur(in().degraded_gray8, out, 11);
      benchmark::DoNotOptimize(out.data);
    };
    c.agreement = [in] {
      cv::Mat peer, peer_f;
      cv::medianBlur(in().degraded_gray8, peer, 11);
      peer.convertTo(peer_f, CV_32F, 1.0 / 255.0);
      return "max |diff| " +
             Format("%.2g", InteriorMaxDiff(MedianFilter(in().degraded_gray_f, 11), peer_f, 5)) +
             " away from the border";
    };
    c.goal = {0.0, 0.0, "issue 18 item 3 (peer for the median step; no goal set)"};
    cases.push_back(c);
  }
}

}  // namespace turbid::bench
