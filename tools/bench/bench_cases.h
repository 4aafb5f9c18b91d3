// The cases of `turbid bench` (tools/bench/cmd_bench.cc): the shared types and inputs. Each group
// of cases lives in its own file (tools/bench/bench_cases_*.cc) and MakeCases adds it.
#ifndef TURBID_TOOLS_BENCH_CASES_H_
#define TURBID_TOOLS_BENCH_CASES_H_

#include <functional>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "scenes/scene.h"

namespace turbid::bench {

// A goal: the ratio peer/ours at least `min_ratio`, or ours at most `max_ms` milliseconds.
struct Goal {
  double min_ratio = 0.0;
  double max_ms = 0.0;
  std::string source;  // the issue item it comes from
};

struct BenchCase {
  std::string name;
  std::string peer_name;  // empty: no peer (absolute goal)
  std::function<void()> ours;
  std::function<void()> peer;
  std::function<std::string()> agreement;  // how far the outputs agree; run once, untimed
  Goal goal;
};

// The shared inputs, built once and only when a selected case needs them. The hull is 1360x1024
// at scale 1 (`--scale` shrinks it); the seafloor is the built-in 640x480 colour scene, also scaled.
// All renders: Jerlov 3C, seed 1, linear camera encoding.
struct Inputs {
  double scale = 1.0;
  Scene hull_gray;
  Scene hull_color;  // the hull's gray texture tinted per channel (B, G, R order inside turbid)
  cv::Mat clean_gray8, degraded_gray8, clean_color8, degraded_color8;
  cv::Mat clean_gray_f, degraded_gray_f;
  cv::Mat degraded_gray_linear;   // float render output, the enhancers' input
  cv::Mat degraded_color_linear;  // the same for hull_color (CV_32FC3)
  Scene seafloor;                 // built-in seafloor, 640x480 colour at scale 1
  cv::Mat seafloor_degraded_linear;  // its render (CV_32FC3)
  cv::Mat seafloor_clean8, seafloor_degraded8;  // 8-bit copies (value * 255, rounded)

  explicit Inputs(double s);
};

using InputsFn = std::function<const Inputs&()>;

// printf-style formatting of one number.
std::string Format(const char* format, double value);

// max |a - b| at least `border` pixels from the image edge (over the whole image when too small).
double InteriorMaxDiff(const cv::Mat& a, const cv::Mat& b, int border);

// The groups of cases, one file each (tools/bench/bench_cases_*.cc).
void AddColorCases(std::vector<BenchCase>& cases, const InputsFn& in);     // 18.1: full, simplified
void AddMetricsCases(std::vector<BenchCase>& cases, const InputsFn& in);   // 18.2: no-reference
void AddBaselineCases(std::vector<BenchCase>& cases, const InputsFn& in);  // 18.3: tarel, fusion
void AddDcpCases(std::vector<BenchCase>& cases, const InputsFn& in);       // 18.3: dcp, cap, oracle
void AddMachineCases(std::vector<BenchCase>& cases, const InputsFn& in);   // bandwidth, peak flops
void AddSeathruCases(std::vector<BenchCase>& cases, const InputsFn& in);   // 31.7: water fit, seathru

}  // namespace turbid::bench

#endif  // TURBID_TOOLS_BENCH_CASES_H_
