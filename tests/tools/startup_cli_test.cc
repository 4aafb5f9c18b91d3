// What keeps `turbid` quick to start (docs/architecture.md, "Linking"): the executable does not
// load OpenImageIO, OpenCV's imgcodecs, libhdf5, the contrib peers or Google Benchmark; TIFF files
// still read through the OpenImageIO plugin and NYU .mat files through the HDF5 plugin found
// beside it; `turbid bench` runs turbid_bench.
#include <gtest/gtest.h>
#include <hdf5.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

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
  for (const char* heavy : {"OpenImageIO", "opencv_imgcodecs", "libhdf5", "opencv_ximgproc",
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
  // reads TIFF scaled to [0, 1] in float32 (tools/harness/metric_image.cc, as before the plugin),
  // so the two differ by float rounding only: 1e-6 (measured 6e-7 dB and 2e-8).
  EXPECT_NEAR(t.at("psnr").get<double>(), p.at("psnr").get<double>(), 1e-6);
  EXPECT_NEAR(t.at("ssim").get<double>(), p.at("ssim").get<double>(), 1e-6);
}

TEST(StartupCli, NyuMatFilesReadThroughThePlugin) {
  // A two-frame NYU Depth v2 labelled file as MATLAB v7.3 stores it (scenes/nyu_depth_v2.h):
  // 512-byte user block, images uint8 (2, 3, 640, 480), depths float32 (2, 640, 480).
  TempDir dir;
  const hsize_t image_dims[4] = {2, 3, 640, 480};
  const hsize_t depth_dims[3] = {2, 640, 480};
  std::vector<unsigned char> codes(2 * 3 * 640 * 480);
  for (size_t i = 0; i < codes.size(); ++i) codes[i] = static_cast<unsigned char>((i * 7) % 256);
  std::vector<float> depth(2 * 640 * 480);
  for (size_t i = 0; i < depth.size(); ++i) depth[i] = 0.5f + static_cast<float>(i % 1000) / 250;
  {
    const hid_t create = H5Pcreate(H5P_FILE_CREATE);
    H5Pset_userblock(create, 512);
    const hid_t file = H5Fcreate(dir.File("nyu.mat").c_str(), H5F_ACC_TRUNC, create, H5P_DEFAULT);
    ASSERT_GE(file, 0);
    const auto write = [&](const char* name, int rank, const hsize_t* dims, hid_t file_type,
                           hid_t memory_type, const void* data) {
      const hid_t space = H5Screate_simple(rank, dims, nullptr);
      const hid_t dataset =
          H5Dcreate2(file, name, file_type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
      const herr_t status = H5Dwrite(dataset, memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data);
      H5Dclose(dataset);
      H5Sclose(space);
      return status;
    };
    EXPECT_GE(write("images", 4, image_dims, H5T_STD_U8LE, H5T_NATIVE_UINT8, codes.data()), 0);
    EXPECT_GE(write("depths", 3, depth_dims, H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, depth.data()), 0);
    H5Fclose(file);
    H5Pclose(create);
  }
  {
    std::ofstream spec(dir.File("nyu.json"));
    spec << R"({"type": "nyu_v2", "file": "nyu.mat", "color": "linear"})";
  }
  const auto scene = RunTurbid({"scene", dir.File("nyu.json") + "#1"});
  ASSERT_EQ(scene.exit_code, 0) << scene.err;
  // Frame 1's depths are the stored values 0.5 + k / 250, k in 0..999: 0.500..4.496 m.
  EXPECT_NE(scene.out.find("nyu_1: 640x480, color; depth 0.500..4.496 m"), std::string::npos)
      << scene.out;
  const auto outside = RunTurbid({"scene", dir.File("nyu.json") + "#2"});
  EXPECT_NE(outside.exit_code, 0);
  EXPECT_NE(outside.err.find("no such frame (0-based index, 2 frames)"), std::string::npos)
      << outside.err;
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
