// `turbid bench` cases of issue 18 item 1: the paper's methods on colour images, one core. At
// 1360x1024 (the colour hull) the peer is the same method on the gray hull, a reference ratio for
// what three channels cost over one; at 640x480 (the seafloor) there is no peer.
#include <benchmark/benchmark.h>

#include <functional>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "enhancer/blocks/clahe.h"
#include "enhancer/blocks/guided_filter.h"
#include "enhancer/paper/full.h"
#include "enhancer/paper/simplified.h"
#include "tools/bench/bench_cases.h"

namespace turbid::bench {

namespace {

// Input pickers: the degraded render and its scene, colour or gray.
struct Pick {
  const cv::Mat* image;
  const Scene* scene;
};
using PickFn = Pick (*)(const Inputs&);
Pick HullColor(const Inputs& i) { return Pick{&i.degraded_color_linear, &i.hull_color}; }
Pick HullGray(const Inputs& i) { return Pick{&i.degraded_gray_linear, &i.hull_gray}; }
Pick Seafloor(const Inputs& i) { return Pick{&i.seafloor_degraded_linear, &i.seafloor}; }

std::function<void()> Full(const InputsFn& in, PickFn pick) {
  return [in, pick] {
    const Pick p = pick(in());
    benchmark::DoNotOptimize(FullEnhance(FullOptions{}, *p.image, p.scene, nullptr).data);
  };
}

std::function<void()> Simplified(const InputsFn& in, PickFn pick) {
  return [in, pick] {
    benchmark::DoNotOptimize(SimplifiedEnhance(SimplifiedOptions{}, *pick(in()).image).data);
  };
}

// Agreement: the streamed output against the whole-image pipeline on the same input (for
// `full` FullEnhanceDetailed; for `simplified` its steps with every channel filtered alone).
std::function<std::string()> FullAgreement(const InputsFn& in, PickFn pick) {
  return [in, pick] {
    const Pick p = pick(in());
    const cv::Mat fast = FullEnhance(FullOptions{}, *p.image, p.scene, nullptr);
    const cv::Mat whole = FullEnhanceDetailed(FullOptions{}, *p.image, p.scene, nullptr).image;
    return "max |diff| " + Format("%g", cv::norm(fast, whole, cv::NORM_INF)) +
           " vs FullEnhanceDetailed (whole-image steps)";
  };
}

std::function<std::string()> SimplifiedAgreement(const InputsFn& in, PickFn pick) {
  return [in, pick] {
    const cv::Mat& img = *pick(in()).image;
    const SimplifiedOptions o;
    GuidedFilterOptions fine, coarse;
    fine.radius = o.fine_radius, fine.eps = o.fine_eps;
    coarse.radius = o.coarse_radius, coarse.eps = o.coarse_eps;
    std::vector<cv::Mat> planes, f(3), g(3);
    cv::split(img, planes);
    for (int c = 0; c < 3; ++c) {
      f[c] = GuidedFilter(fine, planes[c], planes[c]);
      g[c] = GuidedFilter(coarse, planes[c], planes[c]);
    }
    cv::Mat i_f, i_g, whole;
    cv::merge(f, i_f);
    cv::merge(g, i_g);
    cv::addWeighted(i_g, 1.0 - o.alpha, i_f, o.alpha, 0.0, whole);
    whole = cv::min(cv::max(whole, 0.0), 1.0);
    whole = Clahe(o.clahe, whole);
    return "max |diff| " + Format("%g", cv::norm(SimplifiedEnhance(o, img), whole, cv::NORM_INF)) +
           " vs the whole-image steps, channel by channel";
  };
}

}  // namespace

void AddColorCases(std::vector<BenchCase>& cases, const InputsFn& in) {
  const std::string source = "issue 18 item 1 (colour, one core)";
  for (bool is_full : {true, false}) {
    const std::string method = is_full ? "full" : "simplified";
    const auto run = is_full ? Full : Simplified;
    const auto agreement = is_full ? FullAgreement : SimplifiedAgreement;
    BenchCase c;
    c.name = "enhance/" + method + "/color";
    c.peer_name = "the same method on the gray hull (reference ratio)";
    c.ours = run(in, HullColor);
    c.peer = run(in, HullGray);
    c.agreement = agreement(in, HullColor);
    c.goal = {0.0, is_full ? 15.0 : 10.0, source + ", 1360x1024"};
    cases.push_back(c);

    if (is_full) {
      // Issue 32: CLAHE on the camera-coded image (the default) against linear light (the
      // default before), the same image: the cost of coding and decoding around step 5.
      BenchCase d;
      d.name = "enhance/full/clahe_encoded";
      d.peer_name = "full with clahe_domain linear (before issue 32)";
      d.ours = Full(in, HullColor);
      d.peer = [in] {
        const Pick p = HullColor(in());
        static const FullOptions linear = FullOptionsFromJson({{"clahe_domain", "linear"}});
        benchmark::DoNotOptimize(FullEnhance(linear, *p.image, p.scene, nullptr).data);
      };
      d.goal = {0.0, 0.0, "issue 32 item 2 (reference ratio), 1360x1024 colour"};
      cases.push_back(d);
    }
    BenchCase s;
    s.name = "enhance/" + method + "/color640";
    s.ours = run(in, Seafloor);
    s.agreement = agreement(in, Seafloor);
    s.goal = {0.0, is_full ? 4.0 : 3.0, source + ", 640x480"};
    cases.push_back(s);
  }
}

}  // namespace turbid::bench
