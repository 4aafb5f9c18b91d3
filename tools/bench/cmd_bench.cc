// `turbid bench`: the speed goals of the issues, ours against the peer in the same process and on
// the same inputs (Google Benchmark timing loops), with the peer/ours ratio, the goal, and how far
// the two outputs agree. The inputs are rendered from the built-in hull scene (1360x1024 at scale
// 1). The per-module benchmark binaries (benchmarks/*_bench.cc) hold the finer variants.
#include <benchmark/benchmark.h>
#include <malloc.h>
#include <stdlib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/quality/qualityssim.hpp>
#include <opencv2/ximgproc.hpp>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "core/atomic_file.h"
#include "core/error.h"
#include "enhancer/blocks/clahe.h"
#include "enhancer/blocks/guided_filter.h"
#include "enhancer/paper/full.h"
#include "enhancer/paper/simplified.h"
#include "metrics/full_reference.h"
#include "metrics/ssim.h"
#include "scenes/builtin.h"
#include "simulator/psf.h"
#include "simulator/render.h"
#include "tools/bench/bench_cases.h"
#include "tools/cli/cli.h"
#include "tools/harness/experiment.h"
#include "tools/harness/harness_runner.h"
#include "tools/harness/stage_profile.h"
#include "tools/harness/sweep.h"
#include "turbid_version.h"

namespace turbid {
namespace {

using bench::BenchCase;
using bench::Format;
using bench::Goal;
using bench::Inputs;
using bench::InteriorMaxDiff;

struct BenchArgs {
  std::string filter = ".*";
  double min_time_s = 0.3;
  int repetitions = 1;
  int threads = 1;
  double scale = 1.0;
  std::string json_path;
  bool list = false;
  bool force = false;
  bool warm_allocator = false;  // keep freed memory in the heap (no fresh pages per call)
  std::string sweep;            // --sweep EXPERIMENT: time a whole sweep by stage instead
  std::string out;              // the sweep's folder (default: a temporary one, removed after)
  bool allow_commands = false;  // --allow-commands: the experiment's "command" methods may run
  bool threads_given = false;
};

// SSIM and PSNR against OpenCV.
void AddMetricPeerCases(std::vector<BenchCase>& cases, const std::function<const Inputs&()>& in) {
  const Goal ssim_goal{5.0, 0.0, "issue 4 item 8"};
  auto ssim_case = [&](const std::string& name, bool color, bool as_float) {
    BenchCase c;
    c.name = name;
    c.peer_name = "cv::quality::QualitySSIM";
    auto pick = [in, color, as_float]() -> std::pair<const cv::Mat*, const cv::Mat*> {
      const Inputs& i = in();
      if (as_float) return {&i.clean_gray_f, &i.degraded_gray_f};
      return color ? std::make_pair(&i.clean_color8, &i.degraded_color8)
                   : std::make_pair(&i.clean_gray8, &i.degraded_gray8);
    };
    c.ours = [pick] {
      auto [r, x] = pick();
      benchmark::DoNotOptimize(Ssim({}, *r, *x).mean);
    };
    c.peer = [pick, as_float] {
      auto [r, x] = pick();
      // QualitySSIM assumes data range 255; give it 0..255 floats when our input is [0, 1].
      if (as_float) {
        cv::Mat r255 = *r * 255.0, x255 = *x * 255.0;
        benchmark::DoNotOptimize(cv::quality::QualitySSIM::compute(r255, x255, cv::noArray()));
      } else {
        benchmark::DoNotOptimize(cv::quality::QualitySSIM::compute(*r, *x, cv::noArray()));
      }
    };
    c.agreement = [pick, as_float, color] {
      auto [r, x] = pick();
      const double ours = Ssim({}, *r, *x).mean;
      cv::Mat r2 = *r, x2 = *x;
      if (as_float) r2 = *r * 255.0, x2 = *x * 255.0;
      const cv::Scalar s = cv::quality::QualitySSIM::compute(r2, x2, cv::noArray());
      const int n = color ? 3 : 1;
      double peer = 0.0;
      for (int k = 0; k < n; ++k) peer += s[k] / n;
      return "SSIM " + Format("%.6f", ours) + " vs " + Format("%.6f", peer) + " (peer: no crop)";
    };
    c.goal = ssim_goal;
    cases.push_back(c);
  };
  ssim_case("ssim/gray/8bit", false, false);
  ssim_case("ssim/color/8bit", true, false);
  ssim_case("ssim/gray/float", false, true);

  {
    BenchCase c;
    c.name = "psnr/color/8bit";
    c.peer_name = "cv::PSNR";
    c.ours = [in] { benchmark::DoNotOptimize(Psnr({}, in().clean_color8, in().degraded_color8)); };
    c.peer = [in] { benchmark::DoNotOptimize(cv::PSNR(in().clean_color8, in().degraded_color8)); };
    c.agreement = [in] {
      const double a = Psnr({}, in().clean_color8, in().degraded_color8);
      const double b = cv::PSNR(in().clean_color8, in().degraded_color8);
      return "PSNR " + Format("%.6f", a) + " vs " + Format("%.6f", b) + " dB";
    };
    c.goal = {1.0, 0.0, "issue 4 item 8 (memory-bandwidth speed; bench_metrics has GB/s)"};
    cases.push_back(c);
  }
}

// The guided filter, CLAHE and the PSF convolution against OpenCV.
void AddFilterCases(std::vector<BenchCase>& cases, const std::function<const Inputs&()>& in) {
  for (int radius : {2, 8}) {
    BenchCase c;
    c.name = "guided_filter/gray/r" + std::to_string(radius);
    c.peer_name = "cv::ximgproc::guidedFilter";
    const double eps = radius == 2 ? 0.01 : 0.16;
    GuidedFilterOptions o;
    o.radius = radius;
    o.eps = eps;
    c.ours = [in, o] {
      const cv::Mat& img = in().degraded_gray_linear;
      benchmark::DoNotOptimize(GuidedFilter(o, img, img).data);
    };
    c.peer = [in, radius, eps] {
      const cv::Mat& img = in().degraded_gray_linear;
      cv::Mat out;
      cv::ximgproc::guidedFilter(img, img, out, radius, eps, CV_32F);
      benchmark::DoNotOptimize(out.data);
    };
    c.agreement = [in, o, radius, eps] {
      const cv::Mat& img = in().degraded_gray_linear;
      cv::Mat ref;
      cv::ximgproc::guidedFilter(img, img, ref, radius, eps, CV_32F);
      return "max |diff| " +
             Format("%.2g", InteriorMaxDiff(GuidedFilter(o, img, img), ref, 2 * radius)) +
             " away from the border";
    };
    c.goal = {3.0, 0.0, "issue 5 item 8"};
    cases.push_back(c);
  }

  for (bool rayleigh : {false, true}) {
    BenchCase c;
    c.name = rayleigh ? "clahe/rayleigh" : "clahe/uniform";
    c.peer_name = "cv::CLAHE (uniform, 8-bit, conversions counted)";
    ClaheOptions o;
    o.distribution = rayleigh ? ClaheDistribution::kRayleigh : ClaheDistribution::kUniform;
    c.ours = [in, o] { benchmark::DoNotOptimize(Clahe(o, in().degraded_gray_linear).data); };
    c.peer = [in] {
      cv::Ptr<cv::CLAHE> clahe = cv::createCLAHE(2.56, cv::Size(8, 8));
      cv::Mat u8, out, f;
      in().degraded_gray_linear.convertTo(u8, CV_8U, 255.0);
      clahe->apply(u8, out);
      out.convertTo(f, CV_32F, 1.0 / 255.0);
      benchmark::DoNotOptimize(f.data);
    };
    c.goal = {0.5, 0.0, "issue 5 item 8 (within 2x)"};
    cases.push_back(c);
  }

  {
    BenchCase c;
    c.name = "psf/color/paper";
    c.peer_name = "cv::GaussianBlur";
    c.ours = [in] {
      const Psf psf = PsfKernel(PsfOptions{});
      benchmark::DoNotOptimize(ApplyPsf(psf, in().hull_color.image).data);
    };
    c.peer = [in] {
      const Psf psf = PsfKernel(PsfOptions{});
      cv::Mat out;
      cv::GaussianBlur(in().hull_color.image, out,
                       cv::Size(2 * psf.radius_px + 1, 2 * psf.radius_px + 1), psf.sigma_px,
                       psf.sigma_px, cv::BORDER_REFLECT_101);
      benchmark::DoNotOptimize(out.data);
    };
    c.goal = {1.0, 0.0, "issue 3 item 7 (PSF convolution against OpenCV)"};
    cases.push_back(c);
  }
}

// The renderer: eq. 2, the turbidity-dependent PSF and the other models.
void AddRenderCases(std::vector<BenchCase>& cases, const std::function<const Inputs&()>& in) {
  for (bool color : {true, false}) {
    BenchCase c;
    c.name = color ? "render/color/full" : "render/gray/full";
    c.ours = [in, color] {
      RenderOptions o;
      o.water.type = "3C";
      o.seed = 1;
      benchmark::DoNotOptimize(Render(o, color ? in().hull_color : in().hull_gray).image.data);
    };
    c.goal = {0.0, color ? 40.0 : 15.0, "issue 3 item 7 (at 1360x1024, one core)"};
    cases.push_back(c);
  }
  // Turbidity-dependent forward scatter (T = beta r per pixel) against the same render with the
  // paper's one kernel: the goal is a ratio (at most 3x the fixed-PSF render's time).
  for (bool color : {true, false}) {
    BenchCase c;
    c.name = color ? "render/color/turbidity_psf" : "render/gray/turbidity_psf";
    c.peer_name = "the same render, fixed PSF";
    const auto render = [in, color](bool turbidity) {
      RenderOptions o;
      o.water.type = "3C";
      o.seed = 1;
      o.psf.turbidity_dependent = turbidity;
      benchmark::DoNotOptimize(Render(o, color ? in().hull_color : in().hull_gray).image.data);
    };
    c.ours = [render] { render(true); };
    c.peer = [render] { render(false); };
    c.goal = {1.0 / 3.0, 0.0, "issue 16 item 2 (at most 3x the fixed-PSF render, 1360x1024)"};
    cases.push_back(c);
  }
  // The single-scatter veil of the lights against the same render with eq. 2's veil (seafloor,
  // 640x480 colour, all terms on): at most 3x its time.
  {
    BenchCase c;
    c.name = "render/color/single_scatter_veil";
    c.peer_name = "the same render, paper veil";
    const auto render = [in](VeilModel veil) {
      RenderOptions o;
      o.water.type = "3C";
      o.seed = 1;
      o.veil = veil;
      benchmark::DoNotOptimize(Render(o, in().seafloor).image.data);
    };
    c.ours = [render] { render(VeilModel::kSingleScatter); };
    c.peer = [render] { render(VeilModel::kPaper); };
    c.goal = {1.0 / 3.0, 0.0, "issue 30 item 1 (at most 3x the paper veil's render, 640x480)"};
    cases.push_back(c);
  }
  // The other image-formation models beside eq. 2 (same scene, same light, PSF, snow and noise).
  for (const char* model : {"revised", "revised_seathru", "uwcnn"}) {
    BenchCase c;
    c.name = std::string("render/color/") + model;
    const std::string name = model;
    c.ours = [in, name] {
      RenderOptions o;
      o.water.type = "3C";
      o.seed = 1;
      if (name == "uwcnn") {
        o.model = ImageModel::kUwcnn;
        o.uwcnn.type = "3C";
      } else {
        o.model = ImageModel::kRevised;
        o.revised.beta_b_rgb_per_m = {0.3, 0.4, 0.5};
        if (name == "revised_seathru") {
          o.revised.range_dependent = true;
          o.revised.a_rgb = {0.6, 0.3, 0.3};
          o.revised.b_rgb = {-0.2, -0.1, -0.1};
          o.revised.c_rgb = {0.1, 0.05, 0.05};
          o.revised.d_rgb = {-0.01, -0.01, -0.01};
        }
      }
      benchmark::DoNotOptimize(Render(o, in().hull_color).image.data);
    };
    c.goal = {0.0, 0.0, "issue 16 item 1 (timed beside render/color/full; no goal set)"};
    cases.push_back(c);
  }
}

// The paper's methods on the gray hull.
void AddEnhanceCases(std::vector<BenchCase>& cases, const std::function<const Inputs&()>& in) {
  {
    BenchCase c;
    c.name = "enhance/full";
    c.ours = [in] {
      const Inputs& i = in();
      benchmark::DoNotOptimize(
          FullEnhance(FullOptions{}, i.degraded_gray_linear, &i.hull_gray, nullptr).data);
    };
    c.goal = {0.0, 40.0, "issue 5 item 8 (at 1360x1024 gray, one core)"};
    cases.push_back(c);
  }
  {
    BenchCase c;
    c.name = "enhance/simplified";
    c.ours = [in] {
      benchmark::DoNotOptimize(
          SimplifiedEnhance(SimplifiedOptions{}, in().degraded_gray_linear).data);
    };
    c.goal = {0.0, 10.0, "issue 5 item 8 (at 1360x1024 gray, one core)"};
    cases.push_back(c);
  }
}

std::vector<BenchCase> MakeCases(const std::function<const Inputs&()>& in) {
  std::vector<BenchCase> cases;
  AddMetricPeerCases(cases, in);
  AddFilterCases(cases, in);
  AddRenderCases(cases, in);
  AddEnhanceCases(cases, in);
  bench::AddColorCases(cases, in);
  bench::AddMetricsCases(cases, in);
  bench::AddBaselineCases(cases, in);
  bench::AddDcpCases(cases, in);
  bench::AddSeathruCases(cases, in);
  bench::AddMachineCases(cases, in);
  return cases;
}

// Collects the per-benchmark time (median over repetitions when there are several) in ms.
class CollectingReporter : public benchmark::BenchmarkReporter {
 public:
  explicit CollectingReporter(bool real_time) : real_time_(real_time) {}
  bool ReportContext(const Context& /*context*/) override { return true; }
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& run : runs) {
      if (run.error_occurred) {
        errors_[run.run_name.function_name] = run.error_message;
        continue;
      }
      const bool aggregate = run.run_type == Run::RT_Aggregate;
      if (aggregate && run.aggregate_name != "median") continue;
      const double t = real_time_ ? run.GetAdjustedRealTime() : run.GetAdjustedCPUTime();
      const double ms = t * ToMs(run.time_unit);
      const std::string name = run.run_name.function_name;
      if (aggregate) {
        median_ms_[name] = ms;
      } else {
        samples_[name].push_back(ms);
      }
      std::cerr << "  " << name << (aggregate ? " (median)" : "") << ": " << Format("%.3f", ms)
                << " ms\n";
    }
  }
  // Median if reported, else the mean of the samples; negative when missing.
  double Ms(const std::string& name) const {
    if (auto it = median_ms_.find(name); it != median_ms_.end()) return it->second;
    auto it = samples_.find(name);
    if (it == samples_.end() || it->second.empty()) return -1.0;
    double sum = 0.0;
    for (double v : it->second) sum += v;
    return sum / static_cast<double>(it->second.size());
  }
  const std::map<std::string, std::string>& errors() const { return errors_; }

 private:
  static double ToMs(benchmark::TimeUnit unit) {
    switch (unit) {
      case benchmark::kNanosecond:
        return 1e-6;
      case benchmark::kMicrosecond:
        return 1e-3;
      case benchmark::kMillisecond:
        return 1.0;
      case benchmark::kSecond:
        return 1e3;
    }
    return 1.0;
  }
  bool real_time_;
  std::map<std::string, std::vector<double>> samples_;
  std::map<std::string, double> median_ms_;
  std::map<std::string, std::string> errors_;
};

// The checks of the arguments, in order; returns the --filter expression.
std::regex CheckBenchArgs(const BenchArgs& args) {
  if (!(args.min_time_s > 0.0 && args.min_time_s <= 60.0))
    throw Error("bench", "--min-time must be in (0, 60] seconds");
  if (args.repetitions < 1 || args.repetitions > 50)
    throw Error("bench", "--repetitions must be in [1, 50]");
  if (!(args.scale > 0.0 && args.scale <= 1.0)) throw Error("bench", "--scale must be in (0, 1]");
  if (args.threads < 1 || args.threads > 1024) throw Error("bench", "--threads must be >= 1");
  try {
    return std::regex(args.filter);
  } catch (const std::regex_error& e) {
    throw Error("bench", "--filter: not a valid regular expression: " + args.filter);
  }
}

// Registers ours and the peer of each case with Google Benchmark.
void RegisterCases(const std::vector<BenchCase>& cases, const BenchArgs& args, bool real_time) {
  for (const BenchCase& c : cases) {
    auto add = [&](const std::string& name, const std::function<void()>& fn) {
      benchmark::internal::Benchmark* b =
          benchmark::RegisterBenchmark(name.c_str(), [fn](benchmark::State& state) {
            for (auto _ : state) fn();
          });
      b->Unit(benchmark::kMillisecond)->MinTime(args.min_time_s);
      if (args.repetitions > 1) b->Repetitions(args.repetitions)->ReportAggregatesOnly(true);
      if (real_time) b->UseRealTime();
    };
    add(c.name + "@ours", c.ours);
    if (c.peer) add(c.name + "@peer", c.peer);
  }
}

// One table row (printed) and one JSON entry (into report["cases"]) per case.
void ReportCases(const std::vector<BenchCase>& cases, const CollectingReporter& reporter,
                 const BenchArgs& args, nlohmann::json* report) {
  std::cout << "\n| case | ours ms | peer | peer ms | peer/ours | goal | status | agreement |\n"
            << "|---|---|---|---|---|---|---|---|\n";
  for (const BenchCase& c : cases) {
    const double ours = reporter.Ms(c.name + "@ours");
    const double peer = c.peer ? reporter.Ms(c.name + "@peer") : -1.0;
    const double ratio = (ours > 0.0 && peer > 0.0) ? peer / ours : 0.0;
    std::string goal = "-", status = "-";
    if (c.goal.min_ratio > 0.0) {
      goal = ">= " + Format("%g", c.goal.min_ratio) + "x";
      status = ratio >= c.goal.min_ratio ? "met" : "not met";
    } else if (c.goal.max_ms > 0.0) {
      goal = "<= " + Format("%g", c.goal.max_ms) + " ms";
      status = ours > 0.0 && ours <= c.goal.max_ms ? "met" : "not met";
      if (args.scale != 1.0) status += " (goal is at scale 1)";
    }
    const std::string agreement = c.agreement ? c.agreement() : "";
    std::cout << "| " << c.name << " | " << Format("%.3f", ours) << " | "
              << (c.peer_name.empty() ? "-" : c.peer_name) << " | "
              << (peer > 0.0 ? Format("%.3f", peer) : "-") << " | "
              << (ratio > 0.0 ? Format("%.2f", ratio) + "x" : "-") << " | " << goal << " | "
              << status << " | " << agreement << " |\n";
    (*report)["cases"].push_back({{"name", c.name},
                                  {"ours_ms", ours},
                                  {"peer", c.peer_name},
                                  {"peer_ms", peer > 0.0 ? nlohmann::json(peer) : nlohmann::json()},
                                  {"ratio", ratio > 0.0 ? nlohmann::json(ratio) : nlohmann::json()},
                                  {"goal", goal},
                                  {"goal_source", c.goal.source},
                                  {"status", status},
                                  {"agreement", agreement}});
  }
}

void RunBench(const BenchArgs& args) {
  const std::regex filter = CheckBenchArgs(args);
  std::unique_ptr<Inputs> inputs;
  auto get_inputs = [&]() -> const Inputs& {
    if (!inputs) inputs = std::make_unique<Inputs>(args.scale);
    return *inputs;
  };
  std::vector<BenchCase> cases;
  for (BenchCase& c : MakeCases(get_inputs)) {
    if (std::regex_search(c.name, filter)) cases.push_back(std::move(c));
  }
  if (args.list) {
    for (const BenchCase& c : MakeCases(get_inputs)) {
      std::cout << c.name << (c.peer_name.empty() ? "" : "  vs " + c.peer_name) << "\n";
    }
    return;
  }
  if (cases.empty()) throw Error("bench", "--filter matches no case (see --list)");
  if (!args.json_path.empty() && !args.force && std::filesystem::exists(args.json_path))
    throw Error(args.json_path, "exists (use --force to replace it)");

  cv::setNumThreads(args.threads);
  // Full-size images allocated per call: with glibc's defaults, blocks above its (dynamic) mmap
  // threshold, or freed at the top of a heap above the trim threshold, go back to the kernel, and
  // the next call pays ~2 ms of page faults per 5 MB image. That is what a program gets by
  // default, so it is the default here; --warm-allocator keeps freed memory for reuse, so that
  // the timings show the arithmetic alone (a peer with many temporaries gains most).
  if (args.warm_allocator) {
    mallopt(M_MMAP_THRESHOLD, 256 << 20);
    mallopt(M_TRIM_THRESHOLD, 512 << 20);
  }
  std::cerr << "bench: building inputs (built-in hull at scale " << args.scale << ")\n";
  get_inputs();
  const bool real_time = args.threads > 1;  // CPU time of the main thread misses the workers
  benchmark::ClearRegisteredBenchmarks();
  RegisterCases(cases, args, real_time);
  CollectingReporter reporter(real_time);
  benchmark::RunSpecifiedBenchmarks(&reporter, ".*");
  benchmark::ClearRegisteredBenchmarks();
  for (const auto& [name, why] : reporter.errors())
    std::cerr << "bench: " << name << ": " << why << "\n";

  nlohmann::json report = {{"turbid_version", TURBID_VERSION},
                           {"scale", args.scale},
                           {"width", get_inputs().hull_gray.image.cols},
                           {"height", get_inputs().hull_gray.image.rows},
                           {"threads", args.threads},
                           {"time", real_time ? "wall" : "cpu"},
                           {"min_time_s", args.min_time_s},
                           {"repetitions", args.repetitions},
                           {"warm_allocator", args.warm_allocator},
                           {"cases", nlohmann::json::array()}};
  ReportCases(cases, reporter, args, &report);
  std::cout << "\n"
            << (real_time ? "wall" : "CPU") << " time per call, " << args.threads << " thread(s), "
            << get_inputs().hull_gray.image.cols << "x" << get_inputs().hull_gray.image.rows
            << (args.warm_allocator ? ", freed memory kept for reuse (--warm-allocator)"
                                    : ", glibc allocator defaults")
            << "; ratios compare runs of one process on one machine (noisy machines: rerun with "
               "--repetitions 3)\n";
  if (!args.json_path.empty()) {
    AtomicWriteText(args.json_path, report.dump(2) + "\n", args.force);
    std::cout << "wrote " << args.json_path << "\n";
  }
}

// The sweep's folder: --out (a sweep there only with --force, started over), else a new
// temporary folder.
std::string SweepBenchDir(const BenchArgs& args) {
  std::string dir = args.out;
  if (dir.empty()) {
    std::string pattern = (std::filesystem::temp_directory_path() / "turbid-bench-sweep-XXXXXX");
    if (mkdtemp(pattern.data()) == nullptr)
      throw Error(pattern, "cannot create a temporary folder");
    dir = pattern;
  } else if (std::filesystem::exists(dir + "/journal.jsonl") && !args.force) {
    throw Error(dir, "holds a sweep already (use --force to start it over)");
  } else if (std::filesystem::exists(dir + "/journal.jsonl")) {
    std::filesystem::remove(dir + "/journal.jsonl");
  }
  return dir;
}

// The stages' table, longest first, against the threads' capacity (wall time x threads); each
// stage also goes into report["stages"].
void ReportStages(const StageProfile& profile, double capacity_ms, nlohmann::json* report) {
  const std::map<std::string, StageProfile::Entry> stages = profile.Snapshot();
  std::vector<std::pair<std::string, StageProfile::Entry>> rows(stages.begin(), stages.end());
  std::sort(rows.begin(), rows.end(),
            [](const auto& a, const auto& b) { return a.second.ms > b.second.ms; });
  double timed_ms = 0.0;
  for (const auto& row : rows) timed_ms += row.second.ms;
  std::cout << "| stage | thread-s | share of thread time | calls | ms per call |\n"
            << "|---|---|---|---|---|\n";
  for (const auto& [name, e] : rows) {
    std::cout << "| " << name << " | " << Format("%.2f", e.ms / 1e3) << " | "
              << Format("%.1f", 100.0 * e.ms / capacity_ms) << " % | " << e.calls << " | "
              << Format("%.1f", e.ms / static_cast<double>(std::max<int64_t>(1, e.calls)))
              << " |\n";
    (*report)["stages"].push_back({{"stage", name}, {"ms", e.ms}, {"calls", e.calls}});
  }
  const double rest_ms = std::max(0.0, capacity_ms - timed_ms);
  std::cout << "| (untimed: idle threads, glue) | " << Format("%.2f", rest_ms / 1e3) << " | "
            << Format("%.1f", 100.0 * rest_ms / capacity_ms) << " % | - | - |\n"
            << "\nthread time = wall time x threads (" << Format("%.2f", capacity_ms / 1e3)
            << " s); each stage is wall time summed over the threads. Metrics' shared work is "
               "charged to the first metric that needs it.\n";
}

// `turbid bench --sweep EXPERIMENT`: one whole sweep, from scratch, timed end to end and by stage.
// Stage times are wall times summed over the sweep's threads, so with N threads they add up to at
// most N x the wall time; the rest is threads waiting (the last items, locks) or untimed glue.
void RunSweepBench(const BenchArgs& args) {
  const Experiment experiment = LoadExperimentFile(args.sweep, RegistryCatalog());
  CheckCommandsAllowed(experiment, args.allow_commands, "--allow-commands");
  const int threads = args.threads_given
                          ? args.threads
                          : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  if (!args.json_path.empty() && !args.force && std::filesystem::exists(args.json_path))
    throw Error(args.json_path, "exists (use --force to replace it)");
  const bool temporary = args.out.empty();
  const std::string dir = SweepBenchDir(args);
  StageProfile profile;
  SweepOptions options;
  options.out_dir = dir;
  options.threads = threads;
  options.force = true;
  options.profile = &profile;
  HarnessRunnerOptions runner_options;
  runner_options.profile = &profile;
  runner_options.allow_commands = args.allow_commands;
  std::cerr << "bench: sweep " << experiment.name << " (" << experiment.ItemCount() << " items, "
            << experiment.methods.size() << " methods, " << experiment.metrics.size()
            << " metrics) on " << threads << " thread(s) into " << dir << "\n";
  const auto start = std::chrono::steady_clock::now();
  SweepSummary summary;
  try {
    HarnessRunner runner(experiment, dir, runner_options);
    summary = RunSweep(experiment, options, runner.Hooks());
  } catch (...) {
    if (temporary) std::filesystem::remove_all(dir);
    throw;
  }
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (temporary) std::filesystem::remove_all(dir);

  nlohmann::json report = {{"turbid_version", TURBID_VERSION},
                           {"experiment", experiment.name},
                           {"items", summary.ran},
                           {"threads", threads},
                           {"wall_s", wall_s},
                           {"failed_rows", summary.failed_rows},
                           {"stages", nlohmann::json::array()}};
  std::cout << "\nsweep " << experiment.name << ": " << summary.ran << " items in "
            << Format("%.2f", wall_s) << " s wall on " << threads << " thread(s) ("
            << summary.failed_rows << " failed method runs)\n\n";
  ReportStages(profile, wall_s * 1e3 * threads, &report);
  if (!args.json_path.empty()) {
    AtomicWriteText(args.json_path, report.dump(2) + "\n", args.force);
    std::cout << "wrote " << args.json_path << "\n";
  }
}

}  // namespace

void AddBenchCommand(CLI::App& app) {
  auto args = std::make_shared<BenchArgs>();
  CLI::App* cmd = app.add_subcommand("bench", kBenchDescription);
  cmd->add_option("--filter", args->filter, "regular expression on case names (see --list)");
  cmd->add_option("--min-time", args->min_time_s, "minimum seconds per timing loop (default 0.3)");
  cmd->add_option("--repetitions", args->repetitions,
                  "repeat each loop and report the median (default 1)");
  CLI::Option* threads = cmd->add_option(
      "--threads", args->threads,
      "OpenCV / worker threads for ours and the peer (default 1: the goals are single-core; >1 "
      "reports wall time); with --sweep the sweep's threads (default: all cores)");
  cmd->add_option("--scale", args->scale, "input size scale in (0, 1] (1 = 1360x1024)");
  PathOption(cmd->add_option("--json", args->json_path, "also write the results as JSON"));
  cmd->add_flag("--force", args->force, "replace an existing --json file");
  cmd->add_flag("--list", args->list, "list the cases and exit");
  cmd->add_flag("--warm-allocator", args->warm_allocator,
                "keep freed memory for reuse (no page faults per call; default: glibc defaults)");
  PathOption(
      cmd->add_option("--sweep", args->sweep,
                      "time a whole sweep of this experiment JSON end to end and by stage (render, "
                      "each method, each metric, I/O, tables) instead of the kernel cases"));
  PathOption(cmd->add_option(
      "--out", args->out,
      "with --sweep: the sweep's output folder (default: a temporary folder, removed)"));
  cmd->add_flag("--allow-commands", args->allow_commands,
                "with --sweep: run the experiment's external \"command\" methods (as sweep)");
  cmd->footer("Example: turbid bench --list");
  cmd->callback([args, threads] {
    if (args->allow_commands && args->sweep.empty())
      throw Error("bench", "--allow-commands needs --sweep");
    args->threads_given = threads->count() > 0;
    if (!args->sweep.empty()) {
      RunSweepBench(*args);
    } else {
      if (!args->out.empty()) throw Error("bench", "--out needs --sweep");
      RunBench(*args);
    }
  });
}

}  // namespace turbid
