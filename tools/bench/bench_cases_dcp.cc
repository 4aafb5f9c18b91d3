// `turbid bench` cases of issue 18 item 3: the baselines dcp, udcp and cap and the MMSE oracle,
// at 1360x1024 gray (the hull) and 640x480 colour (the seafloor, as the table1 sweep runs them),
// with the dark channel's minimum filter against cv::erode and the colour-guided refinement
// against cv::ximgproc::guidedFilter.
#include <benchmark/benchmark.h>

#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/ximgproc.hpp>
#include <string>
#include <vector>

#include "enhancer/baselines/cap.h"
#include "enhancer/baselines/dcp.h"
#include "enhancer/blocks/guided_filter.h"
#include "enhancer/oracle/oracle.h"
#include "simulator/render.h"
#include "tools/bench/bench_cases.h"

namespace turbid::bench {
namespace {

const Goal kMethodGoal{0.0, 10.0, "issue 18 item 3 (dcp/udcp/cap <= 10 ms, one core)"};
const Goal kOracleGoal{0.0, 40.0, "issue 18 item 3 (oracle <= 40 ms, one core)"};

// The image a case runs on: the hull (1360x1024 gray) or the seafloor (640x480 colour).
const cv::Mat& Picked(const Inputs& i, bool color) {
  return color ? i.seafloor_degraded_linear : i.degraded_gray_linear;
}
const Scene& PickedScene(const Inputs& i, bool color) { return color ? i.seafloor : i.hull_gray; }

// The oracle reads the render's sidecar, which Inputs does not keep: the same render (Jerlov 3C,
// seed 1, linear camera, as Inputs makes it) is redone once, when the case first runs.
struct OracleInput {
  cv::Mat image;
  RenderRecord sidecar;
};

BenchCase DcpMethodCase(const InputsFn& in, bool color, const char* method) {
  BenchCase c;
  c.name = std::string("baseline/") + method + (color ? "/color" : "/gray");
  const bool underwater = std::string(method) == "udcp";
  c.ours = [in, color, underwater] {
    const cv::Mat& img = Picked(in(), color);
    benchmark::DoNotOptimize(underwater ? UnderwaterDarkChannelPrior({}, img).data
                                        : DarkChannelPrior({}, img).data);
  };
  c.goal = kMethodGoal;
  return c;
}

BenchCase CapCase(const InputsFn& in, bool color) {
  BenchCase c;
  c.name = std::string("baseline/cap") + (color ? "/color" : "/gray");
  c.ours = [in, color] {
    benchmark::DoNotOptimize(ColorAttenuationPrior({}, Picked(in(), color)).data);
  };
  c.goal = kMethodGoal;
  return c;
}

BenchCase OracleCase(const InputsFn& in, bool color) {
  BenchCase c;
  c.name = std::string("baseline/oracle") + (color ? "/color" : "/gray");
  auto cache = std::make_shared<std::unique_ptr<OracleInput>>();
  auto get = [in, color, cache]() -> const OracleInput& {
    if (!*cache) {
      RenderOptions o;
      o.water.type = "3C";
      o.seed = 1;
      o.camera.encoding = CameraEncoding::kLinear;
      RenderResult r = Render(o, PickedScene(in(), color));
      *cache = std::make_unique<OracleInput>(OracleInput{r.image, r.sidecar});
    }
    return **cache;
  };
  c.ours = [in, color, get] {
    const OracleInput& oi = get();
    benchmark::DoNotOptimize(
        OracleEnhance({}, oi.image, PickedScene(in(), color), oi.sidecar).image.data);
  };
  c.agreement = [in, color, get] {
    const OracleInput& oi = get();
    const double diff = cv::norm(oi.image, Picked(in(), color), cv::NORM_INF);
    return "re-rendered input vs the shared one: max |diff| " + Format("%.2g", diff);
  };
  c.goal = kOracleGoal;
  return c;
}

// The dark channel of the input (per-pixel channel minimum, then the 15 x 15 minimum filter,
// replicated border) against cv::erode of the channel minimum with the same window.
BenchCase DarkChannelCase(const InputsFn& in, bool color) {
  BenchCase c;
  c.name = std::string("baseline/dcp/dark_channel") + (color ? "/color" : "/gray");
  c.peer_name = "cv::min + cv::erode 15x15";
  auto erode = [](const cv::Mat& img) {
    cv::Mat m = img;
    if (img.channels() == 3) {
      std::vector<cv::Mat> p;
      cv::split(img, p);
      m = cv::min(cv::min(p[0], p[1]), p[2]);
    }
    cv::Mat out;
    cv::erode(m, out, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(15, 15)),
              cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
    return out;
  };
  c.ours = [in, color] { benchmark::DoNotOptimize(DarkChannel(Picked(in(), color), 15).data); };
  c.peer = [in, color, erode] { benchmark::DoNotOptimize(erode(Picked(in(), color)).data); };
  c.agreement = [in, color, erode] {
    const cv::Mat& img = Picked(in(), color);
    return "max |diff| " + Format("%.2g", cv::norm(DarkChannel(img, 15), erode(img), cv::NORM_INF));
  };
  c.goal = {1.0, 0.0, "issue 18 item 3 (the dark channel's min filter, at least cv::erode)"};
  return c;
}

// DCP's refinement step on colour: the guided filter with the colour guide, r 60, eps 1e-4.
BenchCase RefineCase(const InputsFn& in) {
  BenchCase c;
  c.name = "baseline/dcp/refine/color";
  c.peer_name = "cv::ximgproc::guidedFilter";
  // The raw transmission it refines, made once when the case first runs.
  auto raw = std::make_shared<cv::Mat>();
  auto get = [in, raw]() -> const cv::Mat& {
    if (raw->empty()) *raw = 1.0 - 0.95 * DarkChannel(in().seafloor_degraded_linear, 15);
    return *raw;
  };
  GuidedFilterOptions o;
  o.radius = 60;
  o.eps = 1e-4;
  c.ours = [in, o, get] {
    benchmark::DoNotOptimize(GuidedFilter(o, in().seafloor_degraded_linear, get()).data);
  };
  c.peer = [in, o, get] {
    cv::Mat out;
    cv::ximgproc::guidedFilter(in().seafloor_degraded_linear, get(), out, o.radius, o.eps, CV_32F);
    benchmark::DoNotOptimize(out.data);
  };
  c.agreement = [in, o, get] {
    const cv::Mat& img = in().seafloor_degraded_linear;
    cv::Mat ref;
    cv::ximgproc::guidedFilter(img, get(), ref, o.radius, o.eps, CV_32F);
    return "max |diff| " +
           Format("%.2g", InteriorMaxDiff(GuidedFilter(o, img, get()), ref, 2 * o.radius)) +
           " at >= 2r from the border";
  };
  c.goal = {1.0, 0.0, "issue 18 item 3 (dcp's refinement, at least the OpenCV peer)"};
  return c;
}

}  // namespace

void AddDcpCases(std::vector<BenchCase>& cases, const InputsFn& in) {
  for (bool color : {false, true}) {
    for (const char* method : {"dcp", "udcp"}) cases.push_back(DcpMethodCase(in, color, method));
    cases.push_back(CapCase(in, color));
    cases.push_back(OracleCase(in, color));
    cases.push_back(DarkChannelCase(in, color));
  }
  cases.push_back(RefineCase(in));
}

}  // namespace turbid::bench
