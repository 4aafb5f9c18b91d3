// `turbid bench` cases of issue 18 item 1: the paper's methods on colour images, one core. At
// 1360x1024 (the colour hull) the peer is the same method on the gray hull, a reference ratio for
// what three channels cost over one; at 640x480 (the seafloor) there is no peer.
#include <benchmark/benchmark.h>

#include <functional>
#include <string>
#include <vector>

#include "enhancer/paper_methods.h"
#include "tools/bench_cases.h"

namespace turbid::bench {

void AddColorCases(std::vector<BenchCase>& cases, const InputsFn& in) {
  const std::string source = "issue 18 item 1 (colour, one core)";
  // Input pickers: the degraded render and its scene, colour or gray.
  struct Pick {
    const cv::Mat* image;
    const Scene* scene;
  };
  using PickFn = Pick (*)(const Inputs&);
  const PickFn hull_color = [](const Inputs& i) {
    return Pick{&i.degraded_color_linear, &i.hull_color};
  };
  const PickFn hull_gray = [](const Inputs& i) {
    return Pick{&i.degraded_gray_linear, &i.hull_gray};
  };
  const PickFn seafloor = [](const Inputs& i) {
    return Pick{&i.seafloor_degraded_linear, &i.seafloor};
  };
  auto full = [in](PickFn pick) -> std::function<void()> {
    return [in, pick] {
      const Pick p = pick(in());
      benchmark::DoNotOptimize(FullEnhance(FullOptions{}, *p.image, p.scene, nullptr).data);
    };
  };
  auto simplified = [in](PickFn pick) -> std::function<void()> {
    return [in, pick] {
      benchmark::DoNotOptimize(SimplifiedEnhance(SimplifiedOptions{}, *pick(in()).image).data);
    };
  };
  const std::string agreement =
      "bit-identical to the pre-optimisation colour path (tests/enhancer/color_paths_test.cc)";
  for (bool is_full : {true, false}) {
    const std::string method = is_full ? "full" : "simplified";
    BenchCase c;
    c.name = "enhance/" + method + "/color";
    c.peer_name = "the same method on the gray hull (reference ratio)";
    c.ours = is_full ? full(hull_color) : simplified(hull_color);
    c.peer = is_full ? full(hull_gray) : simplified(hull_gray);
    c.agreement = [agreement] { return agreement; };
    c.goal = {0.0, is_full ? 15.0 : 10.0, source + ", 1360x1024"};
    cases.push_back(c);

    BenchCase s;
    s.name = "enhance/" + method + "/color640";
    s.ours = is_full ? full(seafloor) : simplified(seafloor);
    s.agreement = [agreement] { return agreement; };
    s.goal = {0.0, is_full ? 4.0 : 3.0, source + ", 640x480"};
    cases.push_back(s);
  }
}

}  // namespace turbid::bench
