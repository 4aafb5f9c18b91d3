// Scene files and dataset adapters on small files the tests write: units, invalid values, the
// strict schema, and every bad-input case naming the file.
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>

#include "core/atomic_file.h"
#include "scenes/builtin.h"
#include "core/error.h"
#include "scenes/image_io.h"
#include "scenes/scene_loader.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {
using testing::TempDir;

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

// A 6x4 RGB-D frame in TUM / ICL-NUIM encoding: 8-bit sRGB colour, 16-bit depth x5000, some zeros.
struct RgbdFiles {
  explicit RgbdFiles(const TempDir& dir) {
    rgb = cv::Mat(4, 6, CV_8UC3);
    depth16 = cv::Mat(4, 6, CV_16UC1);
    for (int y = 0; y < 4; ++y) {
      for (int x = 0; x < 6; ++x) {
        rgb.at<cv::Vec3b>(y, x) = {static_cast<uchar>(10 * x), static_cast<uchar>(40 * y), 200};
        depth16.at<uint16_t>(y, x) = static_cast<uint16_t>(5000 + 250 * x + 1000 * y);
      }
    }
    depth16.at<uint16_t>(1, 2) = 0;
    depth16.at<uint16_t>(3, 5) = 0;
    cv::imwrite(dir.File("rgb.png"), rgb);
    cv::imwrite(dir.File("depth.png"), depth16);
  }
  cv::Mat rgb, depth16;
};

void ExpectError(const std::string& json_path, const std::string& file_in_message,
                 const std::string& problem_part) {
  try {
    LoadScene(json_path);
    ADD_FAILURE() << "no error; expected '" << problem_part << "'";
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(file_in_message + ": ", 0), 0u) << message;
    EXPECT_NE(message.find(problem_part), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

TEST(SceneFile, DefaultOptionsPassCheck) {
  std::string why;
  EXPECT_TRUE(LoadSceneOptions{}.Check(&why)) << why;
  LoadSceneOptions bad;
  bad.builtin_scale = 2.0;
  EXPECT_FALSE(bad.Check(&why));
}

TEST(SceneFile, RgbdFrameUnitsAndInvalidDepth) {
  TempDir dir;
  RgbdFiles files(dir);
  WriteText(dir.File("s.json"), R"({"name": "frame", "type": "rgbd", "image": "rgb.png", "depth": "depth.png"})");
  const Scene scene = LoadScene(dir.File("s.json"));
  EXPECT_EQ(scene.name, "frame");
  ASSERT_EQ(scene.image.size(), cv::Size(6, 4));
  ASSERT_EQ(scene.channels(), 3);
  // Default intrinsics: ICL-NUIM, with its negative fy.
  EXPECT_DOUBLE_EQ(scene.camera.fx, 481.20);
  EXPECT_DOUBLE_EQ(scene.camera.fy, -480.00);
  EXPECT_EQ(scene.camera.width, 6);
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 6; ++x) {
      const uint16_t code = files.depth16.at<uint16_t>(y, x);
      const float z = scene.depth_m.at<float>(y, x);
      if (code == 0) {
        EXPECT_TRUE(std::isnan(z));
        EXPECT_TRUE(std::isnan(scene.normals.at<cv::Vec3f>(y, x)[0]));
      } else {
        EXPECT_FLOAT_EQ(z, code / 5000.0f);
      }
      // sRGB decoding, channel order kept (BGR in memory as in the file's OpenCV view).
      const cv::Vec3b srgb = files.rgb.at<cv::Vec3b>(y, x);
      for (int c = 0; c < 3; ++c) {
        const double v = srgb[c] / 255.0;
        const double linear = v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
        EXPECT_NEAR(scene.image.at<cv::Vec3f>(y, x)[c], linear, 1e-6);
      }
    }
  }
  ASSERT_EQ(scene.input_hashes.size(), 3u);
  EXPECT_EQ(scene.input_hashes.at(dir.File("depth.png")), Sha256File(dir.File("depth.png")));
  EXPECT_EQ(scene.input_hashes.at(dir.File("s.json")), Sha256File(dir.File("s.json")));
  EXPECT_FALSE(scene.dominant_plane.has_value());
}

TEST(SceneFile, LinearColourGrayImageCameraObjectPlaneAndDvl) {
  TempDir dir;
  RgbdFiles files(dir);
  cv::Mat gray(4, 6, CV_8UC1, cv::Scalar(128));
  cv::imwrite(dir.File("gray.png"), gray);
  WriteText(dir.File("s.json"), R"({"type": "rgbd", "image": "gray.png", "depth": "depth.png",
    "depth_scale": 1000, "color": "linear",
    "camera": {"fx": 100, "fy": 101, "cx": 2.5, "cy": 1.5, "width": 6, "height": 4},
    "plane": {"normal": [0, 0, 2], "offset_m": -3}, "dvl": [[0.1, 0.2, 3.0], [0, 0, 2.9]]})");
  const Scene scene = LoadScene(dir.File("s.json"));
  EXPECT_EQ(scene.name, "s");
  EXPECT_EQ(scene.channels(), 1) << "gray images stay gray";
  EXPECT_NEAR(scene.image.at<float>(0, 0), 128 / 255.0, 1e-7) << "linear: no sRGB decoding";
  EXPECT_FLOAT_EQ(scene.depth_m.at<float>(0, 0), 5.0f) << "5000 / 1000";
  EXPECT_DOUBLE_EQ(scene.camera.fy, 101.0);
  ASSERT_TRUE(scene.dominant_plane);
  // Normalised and oriented towards the camera: 2z - 3 = 0 -> -z + 1.5 = 0.
  EXPECT_EQ(scene.dominant_plane->normal, cv::Vec3d(0, 0, -1));
  EXPECT_DOUBLE_EQ(scene.dominant_plane->offset_m, 1.5);
  ASSERT_EQ(scene.dvl_points_in_camera.size(), 2u);
  EXPECT_EQ(scene.dvl_points_in_camera[0], cv::Vec3d(0.1, 0.2, 3.0));
}

TEST(SceneFile, DepthTypeReadsFloatMetresFromExrAndPfm) {
  TempDir dir;
  RgbdFiles files(dir);
  cv::Mat depth(4, 6, CV_32FC1, 2.5f);
  depth.at<float>(0, 0) = std::numeric_limits<float>::infinity();  // unknown
  depth.at<float>(0, 1) = 0.0f;                                    // unknown
  WriteImage(dir.File("d.exr"), depth);
  WriteImage(dir.File("d.pfm"), depth);
  for (const char* file : {"d.exr", "d.pfm"}) {
    WriteText(dir.File("s.json"), std::string(R"({"type": "depth", "image": "rgb.png", "depth": ")") + file +
                                      R"(", "camera": {"fx": 50, "fy": 50, "cx": 3, "cy": 2}})");
    const Scene scene = LoadScene(dir.File("s.json"));
    EXPECT_TRUE(std::isnan(scene.depth_m.at<float>(0, 0)));
    EXPECT_TRUE(std::isnan(scene.depth_m.at<float>(0, 1)));
    EXPECT_EQ(scene.depth_m.at<float>(2, 3), 2.5f);
    std::remove(dir.File("s.json").c_str());
  }
}

TEST(SceneFile, DepthFromDisparityClosedForm) {
  cv::Mat d = (cv::Mat_<float>(1, 5) << 10.0f, 0.0f, std::numeric_limits<float>::infinity(), -5.0f, 20.0f);
  const cv::Mat z = DepthFromDisparity(d, 1000.0, 0.2, 10.0);
  EXPECT_FLOAT_EQ(z.at<float>(0, 0), 0.2f * 1000.0f / 20.0f);
  EXPECT_TRUE(std::isnan(z.at<float>(0, 1)));
  EXPECT_TRUE(std::isnan(z.at<float>(0, 2)));
  EXPECT_FLOAT_EQ(z.at<float>(0, 3), 0.2f * 1000.0f / 5.0f);  // d + doffs > 0 is valid
  EXPECT_FLOAT_EQ(z.at<float>(0, 4), 0.2f * 1000.0f / 30.0f);
}

// Middlebury 2003 style: 8-bit PGM disparity x4, 0 = unknown; and Middlebury 2014 style PFM with
// inf and doffs.
TEST(SceneFile, StereoDisparityFromPgmAndPfm) {
  TempDir dir;
  RgbdFiles files(dir);
  std::string pixels(24, '\0');
  for (int i = 0; i < 24; ++i) pixels[i] = static_cast<char>(i == 5 ? 0 : 40 + 4 * i);
  WriteText(dir.File("disp.pgm"), "P5\n6 4\n255\n" + pixels);
  WriteText(dir.File("s.json"), R"({"type": "stereo", "image": "rgb.png", "disparity": "disp.pgm",
    "disparity_scale": 4, "baseline_m": 0.16, "camera": {"fx": 400, "fy": 400, "cx": 3, "cy": 2}})");
  Scene scene = LoadScene(dir.File("s.json"));
  for (int i = 0; i < 24; ++i) {
    const float z = scene.depth_m.at<float>(i / 6, i % 6);
    if (i == 5) {
      EXPECT_TRUE(std::isnan(z));
    } else {
      EXPECT_FLOAT_EQ(z, static_cast<float>(0.16 * 400.0 / ((40 + 4 * i) / 4.0)));
    }
  }
  cv::Mat disparity(4, 6, CV_32FC1, 12.5f);
  disparity.at<float>(3, 0) = std::numeric_limits<float>::infinity();
  WriteImage(dir.File("disp.pfm"), disparity);
  WriteText(dir.File("t.json"), R"({"type": "stereo", "image": "rgb.png", "disparity": "disp.pfm",
    "baseline_m": 0.193, "doffs_px": 31.0, "camera": {"fx": 995, "fy": 995, "cx": 3, "cy": 2}})");
  scene = LoadScene(dir.File("t.json"));
  EXPECT_TRUE(std::isnan(scene.depth_m.at<float>(3, 0)));
  EXPECT_FLOAT_EQ(scene.depth_m.at<float>(0, 0), static_cast<float>(0.193 * 995 / (12.5 + 31.0)));
}

TEST(SceneFile, BuiltinSpecsAndBuiltinType) {
  const Scene a = LoadScene("builtin:seafloor", {.builtin_scale = 0.1});
  const Scene b = LoadScene("seafloor", {.builtin_scale = 0.1});
  EXPECT_EQ(a.width(), 64);
  EXPECT_EQ(cv::norm(a.image, b.image, cv::NORM_INF), 0.0);
  EXPECT_TRUE(IsBuiltinSpec("builtin:hull"));
  EXPECT_TRUE(IsBuiltinSpec("room"));
  EXPECT_FALSE(IsBuiltinSpec("room.json"));
  EXPECT_THROW(LoadScene("builtin:reef"), Error);
  TempDir dir;
  WriteText(dir.File("b.json"), R"({"type": "builtin", "builtin": "room", "scale": 0.1, "name": "tiny_room"})");
  const Scene c = LoadScene(dir.File("b.json"));
  EXPECT_EQ(c.name, "tiny_room");
  EXPECT_EQ(c.width(), 64);
  EXPECT_EQ(c.input_hashes.size(), 1u);
}

TEST(SceneFile, CameraPresets) {
  EXPECT_DOUBLE_EQ(CameraPreset("tum_fr2").fx, 520.9);
  EXPECT_DOUBLE_EQ(CameraPreset("icl_nuim").fy, -480.0);
  for (const std::string& name : CameraPresetNames()) EXPECT_NO_THROW(CameraPreset(name));
  EXPECT_THROW(CameraPreset("kinect9"), Error);
}

// Every bad input: one line "<file>: <problem>".
TEST(SceneFile, BadInputsNameTheFileAndProblem) {
  TempDir dir;
  RgbdFiles files(dir);
  const std::string json = dir.File("s.json");
  auto expect = [&](const std::string& text, const std::string& file, const std::string& problem) {
    SCOPED_TRACE(text);
    WriteText(json, text);
    ExpectError(json, file, problem);
  };
  const std::string rgbd = R"("type": "rgbd", "image": "rgb.png", "depth": "depth.png")";
  expect("{" + rgbd + R"(, "colour": "srgb"})", json, "unknown key 'colour'");
  expect(R"({"type": "rgbd", "image": "rgb.png"})", json, "missing required key 'depth'");
  expect(R"({"type": "mesh"})", json, "'type' must be one of");
  expect("{" + rgbd + R"(, "depth_scale": -5})", json, "'depth_scale': must be > 0");
  expect("{" + rgbd + R"(, "depth_scale": "5000"})", json, "'depth_scale': expected a number");
  expect("{" + rgbd + R"(, "color": "gamma"})", json, "'color': expected one of srgb, linear");
  expect("{" + rgbd + R"(, "camera": {"fx": 1, "fy": 1, "cx": 0, "cy": 0, "skew": 0}})", json,
         "'camera': unknown key 'skew'");
  expect("{" + rgbd + R"(, "camera": {"fx": 0, "fy": 1, "cx": 0, "cy": 0}})", json, "non-zero");
  expect("{" + rgbd + R"(, "camera": "kinect9"})", json, "unknown");
  expect("{" + rgbd + R"(, "camera": {"fx": 1, "fy": 1, "cx": 0, "cy": 0, "width": 640}})", json,
         "differs from image");
  expect("{" + rgbd + R"(, "plane": {"normal": [0, 0, 0], "offset_m": 1}})", json, "non-zero");
  expect("{" + rgbd + R"(, "plane": {"normal": [0, 0], "offset_m": 1}})", json, "3 numbers");
  expect("{" + rgbd + R"(, "dvl": [[0, 0, -1]]})", json, "z > 0");
  expect("{" + rgbd + R"(, "depth_scale": 1e999})", json, "");  // not finite or not JSON: an error either way
  expect(R"({"type": "rgbd", "image": "rgb.png", )", json, "invalid JSON");
  expect(R"([1, 2])", json, "object");
  expect(R"({"type": "rgbd", "image": "nope.png", "depth": "depth.png"})", dir.File("nope.png"), "file not found");
  expect(R"({"type": "stereo", "image": "rgb.png", "disparity": "depth.png", "camera": "icl_nuim"})", json,
         "missing required key 'baseline_m'");
  expect(R"({"type": "depth", "image": "rgb.png", "depth": "depth.png"})", json, "missing required key 'camera'");
  expect(R"({"type": "builtin", "builtin": "reef"})", json, "unknown scene 'reef'");
  expect(R"({"type": "builtin", "builtin": "room", "image": "rgb.png"})", json, "unknown key 'image'");
  // Size mismatch names the depth file.
  cv::imwrite(dir.File("small_depth.png"), cv::Mat(3, 6, CV_16UC1, cv::Scalar(5000)));
  expect(R"({"type": "rgbd", "image": "rgb.png", "depth": "small_depth.png"})", dir.File("small_depth.png"),
         "differs from image");
  // All-invalid depth.
  cv::imwrite(dir.File("zero_depth.png"), cv::Mat(4, 6, CV_16UC1, cv::Scalar(0)));
  expect(R"({"type": "rgbd", "image": "rgb.png", "depth": "zero_depth.png"})", dir.File("zero_depth.png"),
         "no valid depth");
  // Negative float depth and out-of-range float image values.
  WriteImage(dir.File("neg.exr"), cv::Mat(4, 6, CV_32FC1, cv::Scalar(-1.0)));
  expect(R"({"type": "depth", "image": "rgb.png", "depth": "neg.exr", "camera": "icl_nuim"})", dir.File("neg.exr"),
         "negative depth");
  WriteImage(dir.File("hdr.exr"), cv::Mat(4, 6, CV_32FC3, cv::Scalar(1.5, 0.2, 0.2)));
  WriteImage(dir.File("ok.exr"), cv::Mat(4, 6, CV_32FC1, cv::Scalar(2.0)));
  expect(R"({"type": "depth", "image": "hdr.exr", "depth": "ok.exr", "camera": "icl_nuim"})", dir.File("hdr.exr"),
         "outside [0, 1]");
  // Three-channel depth.
  expect(R"({"type": "rgbd", "image": "rgb.png", "depth": "rgb.png"})", dir.File("rgb.png"), "1 channel");
  // A truncated depth PNG.
  std::string bytes = testing::ReadFileText(dir.File("depth.png"));
  WriteText(dir.File("cut.png"), bytes.substr(0, bytes.size() / 2));
  expect(R"({"type": "rgbd", "image": "rgb.png", "depth": "cut.png"})", dir.File("cut.png"), "truncated");
  ExpectError(dir.File("missing.json"), dir.File("missing.json"), "file not found");
}

}  // namespace
}  // namespace turbid
