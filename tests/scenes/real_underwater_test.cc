// Real underwater RGB-D through scene files (issue 31 item 1): the keys depth_resize,
// depth_erode_px, depth_kind and "camera": "unknown" on small synthetic files with hand-written
// expectations, then the Sea-thru D1/D3 and FLSea frames from $TURBID_DATA (skipped when unset;
// expected values transcribed from each folder's SOURCE.md).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>

#include "core/error.h"
#include "scenes/image_io.h"
#include "scenes/scene_loader.h"
#include "scenes/scene_summary.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {
using testing::TempDir;

Scene Load(const TempDir& dir, const std::string& json) {
  std::ofstream(dir.File("scene.json")) << json;
  return LoadScene(dir.File("scene.json"));
}

std::string LoadError(const TempDir& dir, const std::string& json) {
  try {
    Load(dir, json);
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

// A 6x4 grey image and a depth map of `depth_size` whose pixel (x, y) holds 1 + x + 10 y metres.
void WriteFrame(const TempDir& dir, cv::Size depth_size) {
  cv::imwrite(dir.File("rgb.png"), cv::Mat(4, 6, CV_8UC3, cv::Scalar(128, 128, 128)));
  cv::Mat depth(depth_size, CV_32FC1);
  for (int y = 0; y < depth.rows; ++y)
    for (int x = 0; x < depth.cols; ++x) depth.at<float>(y, x) = 1.0f + x + 10.0f * y;
  WriteImage(dir.File("depth.exr"), depth, {.overwrite = true});
}

int CountNan(const cv::Mat& m) {
  int n = 0;
  const cv::Mat flat = m.reshape(1);
  for (int y = 0; y < flat.rows; ++y)
    for (int x = 0; x < flat.cols; ++x) n += std::isnan(flat.at<float>(y, x)) ? 1 : 0;
  return n;
}

const char* kBase = R"("type": "depth", "image": "rgb.png", "depth": "depth.exr")";

TEST(RealUnderwater, DepthResizeNoneRefusesAnotherGrid) {
  TempDir dir;
  WriteFrame(dir, {3, 2});
  const std::string message =
      LoadError(dir, std::string("{") + kBase + R"(, "camera": "unknown"})");
  EXPECT_NE(message.find("size 3x2 differs from image"), std::string::npos) << message;
  EXPECT_NE(message.find("stretch_nearest"), std::string::npos) << message;
}

TEST(RealUnderwater, StretchNearestTakesTheCellHoldingEachPixelCentre) {
  TempDir dir;
  WriteFrame(dir, {3, 2});  // 3x2 -> 6x4: x_d = floor((x + 0.5) / 2), y_d alike
  const Scene s = Load(dir, std::string("{") + kBase +
                                R"(, "camera": "unknown", "depth_resize": "stretch_nearest"})");
  const int xd[6] = {0, 0, 1, 1, 2, 2};
  const int yd[4] = {0, 0, 1, 1};
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 6; ++x)
      EXPECT_EQ(s.depth_m.at<float>(y, x), 1.0f + xd[x] + 10.0f * yd[y]) << x << "," << y;
  // Shrinking: 7 columns onto 3 take columns floor((2i + 1) 7 / 6) = 1, 3, 5.
  const cv::Mat src(1, 7, CV_32FC1, cv::Scalar(0));
  cv::Mat row = src.clone();
  for (int x = 0; x < 7; ++x) row.at<float>(0, x) = static_cast<float>(x);
  const cv::Mat out = StretchNearest(row, {3, 1});
  EXPECT_EQ(out.at<float>(0, 0), 1.0f);
  EXPECT_EQ(out.at<float>(0, 1), 3.0f);
  EXPECT_EQ(out.at<float>(0, 2), 5.0f);
}

TEST(RealUnderwater, ErodeRemovesASquareAroundEachHoleNotAtTheBorder) {
  cv::Mat depth(5, 7, CV_32FC1, cv::Scalar(2.0f));
  depth.at<float>(2, 3) = std::numeric_limits<float>::quiet_NaN();
  depth.at<float>(0, 0) = std::numeric_limits<float>::quiet_NaN();
  const cv::Mat e0 = ErodeValidDepth(depth, 0);
  EXPECT_EQ(CountNan(e0), 2);
  const cv::Mat e1 = ErodeValidDepth(depth, 1);
  // 3x3 around (3, 2) = 9 and the 2x2 inside the image around (0, 0) = 4; disjoint.
  EXPECT_EQ(CountNan(e1), 13);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 7; ++x) {
      const bool hole = (std::abs(x - 3) <= 1 && std::abs(y - 2) <= 1) || (x <= 1 && y <= 1);
      EXPECT_EQ(std::isnan(e1.at<float>(y, x)), hole) << x << "," << y;
    }
  const cv::Mat e2 = ErodeValidDepth(depth, 2);
  EXPECT_EQ(CountNan(e2), 25 + 9 - 6);  // 5x5 and 3x3 squares overlap on 2x3
}

TEST(RealUnderwater, ErosionRunsOnTheDepthGridBeforeTheStretch) {
  TempDir dir;
  WriteFrame(dir, {3, 2});
  cv::Mat depth = ReadImage(dir.File("depth.exr"));
  depth.at<float>(0, 0) = 0.0f;  // one hole on the 3x2 grid
  WriteImage(dir.File("depth.exr"), depth, {.overwrite = true});
  const Scene s = Load(dir, std::string("{") + kBase +
                                R"(, "camera": "unknown", "depth_resize": "stretch_nearest",
                                   "depth_erode_px": 1})");
  // On the 3x2 grid the hole at (0, 0) erodes (0..1, 0..1); stretched, columns 0..3 of all rows.
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 6; ++x) EXPECT_EQ(std::isnan(s.depth_m.at<float>(y, x)), x <= 3) << x;
}

TEST(RealUnderwater, BadValuesOfTheNewKeysNameTheKey) {
  TempDir dir;
  WriteFrame(dir, {6, 4});
  const std::string base = std::string("{") + kBase + R"(, "camera": "unknown", )";
  EXPECT_NE(LoadError(dir, base + R"("depth_erode_px": -1})")
                .find("'depth_erode_px': must be in [0, 64]"),
            std::string::npos);
  EXPECT_NE(LoadError(dir, base + R"("depth_erode_px": 1.5})")
                .find("'depth_erode_px': expected an integer"),
            std::string::npos);
  EXPECT_NE(LoadError(dir, base + R"("depth_resize": "bilinear"})")
                .find("'depth_resize': expected one of none, stretch_nearest"),
            std::string::npos);
  EXPECT_NE(
      LoadError(dir, base + R"("depth_kind": "x"})").find("'depth_kind': expected one of z, range"),
      std::string::npos);
  EXPECT_NE(LoadError(dir, R"({"type": "stereo", "image": "rgb.png", "disparity": "depth.exr",
                              "baseline_m": 0.1, "camera": "unknown"})")
                .find("stereo needs the focal length"),
            std::string::npos);
  EXPECT_NE(LoadError(dir, R"({"type": "builtin", "builtin": "room", "depth_kind": "z"})")
                .find("unknown key 'depth_kind'"),
            std::string::npos);
}

TEST(RealUnderwater, DepthKindRangeDividesByTheRayLength) {
  TempDir dir;
  WriteFrame(dir, {6, 4});
  const std::string camera = R"("camera": {"fx": 3, "fy": 2, "cx": 2.5, "cy": 1.5})";
  const Scene z = Load(dir, std::string("{") + kBase + ", " + camera + "}");
  const Scene r =
      Load(dir, std::string("{") + kBase + ", " + camera + R"(, "depth_kind": "range"})");
  const Scene ray =
      Load(dir, std::string("{") + kBase + ", " + camera + R"(, "depth_kind": "ray"})");
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 6; ++x) {
      const double norm =
          std::sqrt(1.0 + std::pow((x - 2.5) / 3.0, 2) + std::pow((y - 1.5) / 2.0, 2));
      EXPECT_NEAR(r.depth_m.at<float>(y, x), z.depth_m.at<float>(y, x) / norm, 1e-5);
      EXPECT_EQ(ray.depth_m.at<float>(y, x), r.depth_m.at<float>(y, x));
    }
}

TEST(RealUnderwater, UnknownCameraMakesRangeEqualDepthAndSaysSo) {
  TempDir dir;
  WriteFrame(dir, {6, 4});
  const Scene s = Load(dir, std::string("{") + kBase + R"(, "camera": "unknown"})");
  EXPECT_TRUE(s.camera_unknown);
  const cv::Mat range = RangeFromDepth(s.camera, s.depth_m);
  EXPECT_EQ(cv::norm(range, s.depth_m, cv::NORM_INF), 0.0);
  // The same under "range": z = r / |ray| with |ray| = 1 to float precision.
  const Scene r =
      Load(dir, std::string("{") + kBase + R"(, "camera": "unknown", "depth_kind": "range"})");
  EXPECT_EQ(cv::norm(r.depth_m, s.depth_m, cv::NORM_INF), 0.0);
  const nlohmann::json summary = SceneSummaryJson(s);
  EXPECT_EQ(summary["camera"]["unknown"], true);
  EXPECT_NE(summary["camera"]["note"].get<std::string>().find("range = depth"), std::string::npos);
  EXPECT_FALSE(Load(dir, std::string("{") + kBase + R"(, "camera": "icl_nuim"})").camera_unknown);
}

TEST(RealUnderwater, SixteenBitImagesLinearAndSrgb) {
  TempDir dir;
  WriteFrame(dir, {6, 4});
  cv::imwrite(dir.File("rgb16.png"), cv::Mat(4, 6, CV_16UC3, cv::Scalar(16384, 32768, 65535)));
  const std::string tail = R"(, "depth": "depth.exr", "camera": "unknown")";
  const Scene lin =
      Load(dir, R"({"type": "depth", "image": "rgb16.png", "color": "linear")" + tail + "}");
  EXPECT_NEAR(lin.image.at<cv::Vec3f>(0, 0)[0], 16384.0 / 65535.0, 1e-6);
  EXPECT_NEAR(lin.image.at<cv::Vec3f>(0, 0)[2], 1.0, 1e-6);
  const Scene srgb =
      Load(dir, R"({"type": "depth", "image": "rgb16.png", "color": "srgb")" + tail + "}");
  const double v = 32768.0 / 65535.0;  // IEC 61966-2-1 decode
  EXPECT_NEAR(srgb.image.at<cv::Vec3f>(0, 0)[1], std::pow((v + 0.055) / 1.055, 2.4), 1e-5);
}

TEST(RealUnderwater, FloatDepthFromTiffAndPng16) {
  TempDir dir;
  WriteFrame(dir, {6, 4});
  cv::Mat depth(4, 6, CV_32FC1, cv::Scalar(2.5f));
  depth.at<float>(1, 1) = 0.0f;
  cv::imwrite(dir.File("d.tif"), depth);
  const Scene tif =
      Load(dir, R"({"type": "depth", "image": "rgb.png", "depth": "d.tif", "camera": "unknown"})");
  EXPECT_EQ(tif.depth_m.at<float>(0, 0), 2.5f);
  EXPECT_TRUE(std::isnan(tif.depth_m.at<float>(1, 1)));
  cv::Mat mm;
  depth.convertTo(mm, CV_16UC1, 1000.0);
  cv::imwrite(dir.File("d.png"), mm);
  const Scene png = Load(dir, R"({"type": "depth", "image": "rgb.png", "depth": "d.png",
                                  "depth_scale": 1000, "camera": "unknown"})");
  EXPECT_FLOAT_EQ(png.depth_m.at<float>(0, 0), 2.5f);
  EXPECT_TRUE(std::isnan(png.depth_m.at<float>(1, 1)));
}

// --- real frames ------------------------------------------------------------------------------

TEST(RealUnderwater, SeathruD3LinearStretchedEroded) {
  TURBID_REQUIRE_DATA(data);
  TempDir dir;
  const std::string base = data + "/seathru_d1_d3/D3_T_S04856_";
  const std::string json = R"({"type": "depth", "image": ")" + base + R"(image_wbNeutral.png",
      "depth": ")" + base + R"(depth.exr", "color": "linear", "camera": "unknown",
      "depth_resize": "stretch_nearest")";
  const Scene raw = Load(dir, json + "}");
  EXPECT_EQ(raw.width(), 1000);
  EXPECT_EQ(raw.height(), 665);
  // 994x663 -> 1000x665 enlarges: every depth pixel appears, so min and max are the file's.
  const DepthStats d = ComputeDepthStats(raw.depth_m);
  EXPECT_NEAR(d.min_m, 0.294, 1e-3);
  EXPECT_NEAR(d.max_m, 2.779, 1e-3);
  EXPECT_NEAR(d.valid_fraction, 0.713, 0.003);
  const cv::Scalar mean = cv::mean(raw.image);  // BGR; SOURCE.md mean RGB [43.3, 48.0, 42.3]
  EXPECT_NEAR(mean[2] * 255.0, 43.3, 0.06);
  EXPECT_NEAR(mean[1] * 255.0, 48.0, 0.06);
  EXPECT_NEAR(mean[0] * 255.0, 42.3, 0.06);
  const Scene eroded = Load(dir, json + R"(, "depth_erode_px": 1})");
  const DepthStats e = ComputeDepthStats(eroded.depth_m);
  EXPECT_NEAR(e.min_m, 0.776, 1e-3);  // SOURCE.md: min after a 3x3 erosion
  EXPECT_NEAR(e.valid_fraction, 0.710, 0.003);
}

TEST(RealUnderwater, SeathruD1DepthOnAHalfGrid) {
  TURBID_REQUIRE_DATA(data);
  TempDir dir;
  const std::string base = data + "/seathru_d1_d3/D1_T_S03047_";
  const Scene s = Load(dir, R"({"type": "depth", "image": ")" + base + R"(image.png", "depth": ")" +
                                base + R"(depth.exr", "color": "linear", "camera": "unknown",
                                "depth_resize": "stretch_nearest", "depth_erode_px": 1})");
  EXPECT_EQ(s.depth_m.size(), cv::Size(1000, 665));
  const DepthStats d = ComputeDepthStats(s.depth_m);
  EXPECT_NEAR(d.min_m, 0.965, 1e-3);  // SOURCE.md: min after erosion
  EXPECT_NEAR(d.max_m, 2.286, 1e-3);
  EXPECT_NEAR(d.valid_fraction, 0.993, 0.003);
}

TEST(RealUnderwater, FlseaCanyonsAndRedSeaFrames) {
  TURBID_REQUIRE_DATA(data);
  TempDir dir;
  struct Case {
    const char* stem;
    const char* camera;
    double min_m, max_m, valid;
  };
  const char* canyons = R"({"fx": 1175.39, "fy": 1174.28, "cx": 466.26, "cy": 271.21})";
  const char* red_sea = R"({"fx": 1296.67, "fy": 1300.83, "cx": 501.50, "cy": 276.16})";
  for (const Case& c : {Case{"16233045486672034", canyons, 0.813, 3.924, 0.801},
                        Case{"16315129396993518", red_sea, 1.103, 8.448, 0.863}}) {
    SCOPED_TRACE(c.stem);
    const std::string base = data + "/flsea/" + c.stem;
    const Scene s =
        Load(dir, R"({"type": "depth", "image": ")" + base + R"(.tiff", "depth": ")" + base +
                      R"(_SeaErra_abs_depth.tif", "color": "srgb", "camera": )" + c.camera + "}");
    EXPECT_EQ(s.depth_m.size(), cv::Size(968, 608));
    const DepthStats d = ComputeDepthStats(s.depth_m);
    EXPECT_NEAR(d.min_m, c.min_m, 1e-3);
    EXPECT_NEAR(d.max_m, c.max_m, 1e-3);
    EXPECT_NEAR(d.valid_fraction, c.valid, 0.001);
    EXPECT_FALSE(s.camera_unknown);
  }
}

}  // namespace
}  // namespace turbid
