// What keeps `turbid` quick to start (docs/architecture.md, "Linking"): the executable does not
// load OpenImageIO, OpenCV's imgcodecs, the contrib peers or Google Benchmark; TIFF files still
// read through the OpenImageIO plugin found beside it; `turbid bench` runs turbid_bench.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "tests/support/test_support.h"

namespace turbid {
namespace {

using testing::RunTurbid;
using testing::TempDir;

// The shared libraries the dynamic loader maps for the executable (what ldd prints).
std::string LoadedLibraries(const std::string& binary) {
  const std::string command = "LD_TRACE_LOADED_OBJECTS=1 '" + binary + "' 2>&1";
  FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) return "";
  std::string out;
  char buffer[4096];
  size_t n = 0;
  while ((n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0) out.append(buffer, n);
  ::pclose(pipe);
  return out;
}

TEST(StartupCli, ExecutableLoadsNoHeavyLibraries) {
  const char* bin = std::getenv("TURBID_BIN");
  ASSERT_NE(bin, nullptr) << "run through ctest";
  const std::string libraries = LoadedLibraries(bin);
  ASSERT_NE(libraries.find("libpng16"), std::string::npos) << libraries;  // the trace worked
  for (const char* heavy : {"OpenImageIO", "opencv_imgcodecs", "opencv_ximgproc",
                            "opencv_quality", "libbenchmark", "libgdal", "libavcodec"})
    EXPECT_EQ(libraries.find(heavy), std::string::npos) << heavy << " is linked:\n" << libraries;
}

TEST(StartupCli, TiffInputsReadThroughThePlugin) {
  TempDir dir;
  cv::Mat a(40, 56, CV_8UC3), b;
  cv::randu(a, 0, 256);
  cv::GaussianBlur(a, b, cv::Size(5, 5), 1.2);
  ASSERT_TRUE(cv::imwrite(dir.File("a.tif"), a));
  ASSERT_TRUE(cv::imwrite(dir.File("a.png"), a));
  ASSERT_TRUE(cv::imwrite(dir.File("b.png"), b));
  const auto tiff = RunTurbid({"score", "--ref", dir.File("a.tif"), dir.File("b.png"),
                               "--metrics", "psnr,ssim", "--json"});
  ASSERT_EQ(tiff.exit_code, 0) << tiff.err;
  const auto png = RunTurbid({"score", "--ref", dir.File("a.png"), dir.File("b.png"),
                              "--metrics", "psnr,ssim", "--json"});
  ASSERT_EQ(png.exit_code, 0) << png.err;
  const auto t = nlohmann::json::parse(tiff.out).at("results")[0];
  const auto p = nlohmann::json::parse(png.out).at("results")[0];
  // The same pixels from either file. `score` keeps the integer codes of PNG/JPEG (range 255) but
  // reads TIFF scaled to [0, 1] in float32 (tools/metric_image.cc, as before the plugin), so the
  // two differ by float rounding only: 1e-6 (measured 6e-7 dB and 2e-8).
  EXPECT_NEAR(t.at("psnr").get<double>(), p.at("psnr").get<double>(), 1e-6);
  EXPECT_NEAR(t.at("ssim").get<double>(), p.at("ssim").get<double>(), 1e-6);
}

TEST(StartupCli, BenchRunsTheBenchExecutable) {
  const auto help = RunTurbid({"bench", "--help"});
  EXPECT_EQ(help.exit_code, 0) << help.err;
  EXPECT_NE(help.out.find("--filter"), std::string::npos) << help.out;
  EXPECT_NE(help.out.find("bench"), std::string::npos) << help.out;
  const auto top = RunTurbid({"--help"});
  EXPECT_EQ(top.exit_code, 0);
  EXPECT_NE(top.out.find("time the speed goals"), std::string::npos) << top.out;
}

}  // namespace
}  // namespace turbid
