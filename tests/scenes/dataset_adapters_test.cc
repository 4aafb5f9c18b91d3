// NYU Depth v2 labelled-file and RGB-D folder adapters, and the .npy reader, on small files the
// tests write in exactly the datasets' layouts: an HDF5 file with a 512-byte user block (as MATLAB
// v7.3 writes) holding `images` uint8 (N, 3, 640, 480) and `depths` float (N, 640, 480), and
// rgb/ + depth/ folders. Expected values come from the closed-form patterns written, never from the
// readers.
#include <gtest/gtest.h>
#include <hdf5.h>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>

#include "core/error.h"
#include "scenes/folder_dataset.h"
#include "scenes/image_io.h"
#include "scenes/npy_io.h"
#include "scenes/nyu_depth_v2.h"
#include "scenes/scene_loader.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {
using testing::TempDir;

constexpr int kW = 640;
constexpr int kH = 480;

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

double SrgbDecode(double v) {  // IEC 61966-2-1
  return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

// Colour codes and depth of the synthetic NYU frames: every channel and axis has its own slope, so a
// transposed, channel-swapped or frame-shifted read gives other values.
uint8_t Code(int n, int c, int x, int y) {
  if (c == 0) return static_cast<uint8_t>(x / 3);        // R: columns
  if (c == 1) return static_cast<uint8_t>(y / 2);        // G: rows
  return static_cast<uint8_t>(40 * n + 7);               // B: frame
}
float Depth(int n, int x, int y) { return 1.0f + x / 640.0f + 2.0f * y / 480.0f + n; }

// Writes an HDF5 file like MATLAB's -v7.3 .mat (512-byte user block). Datasets get `dims`
// (HDF5 order, slowest first) and element types as given; values come from Code / `depth`.
struct NyuFile {
  std::vector<hsize_t> image_dims{2, 3, kW, kH};
  hid_t image_type = H5T_STD_U8LE;
  std::string depth_name = "depths";
  std::vector<hsize_t> depth_dims{2, kW, kH};
  hid_t depth_type = H5T_IEEE_F32LE;
  bool write_images = true;
  std::function<float(int, int, int)> depth = Depth;

  void Write(const std::string& path) const {
    const hid_t create = H5Pcreate(H5P_FILE_CREATE);
    H5Pset_userblock(create, 512);
    const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, create, H5P_DEFAULT);
    ASSERT_GE(file, 0);
    if (write_images) {
      size_t count = 1;
      for (hsize_t d : image_dims) count *= d;
      std::vector<uint8_t> codes(count);
      if (image_dims.size() == 4 && image_dims[1] == 3 && image_dims[2] == kW && image_dims[3] == kH) {
        for (hsize_t n = 0; n < image_dims[0]; ++n)
          for (int c = 0; c < 3; ++c)
            for (int x = 0; x < kW; ++x)
              for (int y = 0; y < kH; ++y)
                codes[((n * 3 + c) * kW + x) * kH + y] = Code(n, c, x, y);
      }
      WriteDataset(file, "images", image_dims, image_type, H5T_NATIVE_UINT8, codes.data());
    }
    size_t count = 1;
    for (hsize_t d : depth_dims) count *= d;
    std::vector<float> values(count, 1.0f);
    if (depth_dims.size() == 3 && depth_dims[1] == kW && depth_dims[2] == kH) {
      for (hsize_t n = 0; n < depth_dims[0]; ++n)
        for (int x = 0; x < kW; ++x)
          for (int y = 0; y < kH; ++y) values[(n * kW + x) * kH + y] = depth(n, x, y);
    }
    WriteDataset(file, depth_name, depth_dims, depth_type, H5T_NATIVE_FLOAT, values.data());
    H5Fclose(file);
    H5Pclose(create);
  }

  static void WriteDataset(hid_t file, const std::string& name, const std::vector<hsize_t>& dims,
                           hid_t file_type, hid_t memory_type, const void* data) {
    const hid_t space = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
    const hid_t dataset = H5Dcreate2(file, name.c_str(), file_type, space, H5P_DEFAULT,
                                     H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(dataset, 0);
    ASSERT_GE(H5Dwrite(dataset, memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), 0);
    H5Dclose(dataset);
    H5Sclose(space);
  }
};

void ExpectLoadError(const std::string& spec, const std::string& file_in_message,
                     const std::string& problem_part) {
  try {
    LoadScene(spec);
    ADD_FAILURE() << "no error; expected '" << problem_part << "'";
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(file_in_message + ": ", 0), 0u) << message;
    EXPECT_NE(message.find(problem_part), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

// ---- NYU Depth v2 --------------------------------------------------------------------------------

class NyuTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir();
    NyuFile().Write(dir_->File("nyu.mat"));
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static std::string File(const std::string& name) { return dir_->File(name); }
  static TempDir* dir_;
};
TempDir* NyuTest::dir_ = nullptr;

TEST_F(NyuTest, DefaultOptionsPassCheck) {
  std::string why;
  EXPECT_TRUE(NyuFrameOptions{}.Check(&why)) << why;
  NyuFrameOptions bad;
  bad.depth_dataset = "labels";
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_TRUE(FolderDatasetOptions{}.Check(&why)) << why;
}

TEST_F(NyuTest, AxisOrderChannelsUnitsAndIntrinsics) {
  EXPECT_EQ(NyuFrameCount(File("nyu.mat")), 2);
  NyuFrameOptions linear;
  linear.color = Transfer::kLinear;
  const NyuFrame frame = ReadNyuFrame(File("nyu.mat"), 1, linear);
  ASSERT_EQ(frame.image.size(), cv::Size(kW, kH));
  ASSERT_EQ(frame.image.type(), CV_32FC3);
  for (const cv::Point p : {cv::Point(0, 0), cv::Point(600, 10), cv::Point(10, 470), cv::Point(639, 479),
                            cv::Point(333, 123)}) {
    const cv::Vec3f bgr = frame.image.at<cv::Vec3f>(p.y, p.x);
    EXPECT_EQ(bgr[2], Code(1, 0, p.x, p.y) / 255.0f) << p;  // R
    EXPECT_EQ(bgr[1], Code(1, 1, p.x, p.y) / 255.0f) << p;  // G
    EXPECT_EQ(bgr[0], Code(1, 2, p.x, p.y) / 255.0f) << p;  // B
    EXPECT_EQ(frame.depth_m.at<float>(p.y, p.x), Depth(1, p.x, p.y)) << p;
  }
  EXPECT_DOUBLE_EQ(frame.camera.fx, 518.85790117450188);
  EXPECT_DOUBLE_EQ(frame.camera.fy, 519.46961112127485);
  EXPECT_DOUBLE_EQ(frame.camera.cx, 325.58244941119034);
  EXPECT_DOUBLE_EQ(frame.camera.cy, 253.73616633400465);
  EXPECT_EQ(frame.camera.width, kW);
  EXPECT_EQ(frame.camera.height, kH);
  // Another frame hashes differently; the same frame the same.
  EXPECT_NE(ReadNyuFrame(File("nyu.mat"), 0, linear).sha256, frame.sha256);
  EXPECT_EQ(ReadNyuFrame(File("nyu.mat"), 1, linear).sha256, frame.sha256);
}

TEST_F(NyuTest, SceneFileSrgbCropAndFrameSelection) {
  WriteText(File("one.json"), R"({"type": "nyu_v2", "file": "nyu.mat", "frames": 1,
                                  "crop_border": true})");
  const Scene scene = LoadScene(File("one.json"));
  EXPECT_EQ(scene.name, "one_1");
  // The toolbox's mask(45:471, 41:601): 561 x 427 from column 40, row 44 (0-based).
  ASSERT_EQ(scene.image.size(), cv::Size(561, 427));
  EXPECT_NEAR(scene.camera.cx, 325.58244941119034 - 40.0, 1e-12);
  EXPECT_NEAR(scene.camera.cy, 253.73616633400465 - 44.0, 1e-12);
  EXPECT_DOUBLE_EQ(scene.camera.fx, 518.85790117450188);
  for (const cv::Point p : {cv::Point(0, 0), cv::Point(560, 426), cv::Point(200, 17)}) {
    const int x = p.x + 40, y = p.y + 44;
    const cv::Vec3f bgr = scene.image.at<cv::Vec3f>(p.y, p.x);
    EXPECT_NEAR(bgr[2], SrgbDecode(Code(1, 0, x, y) / 255.0), 1e-6) << p;
    EXPECT_NEAR(bgr[0], SrgbDecode(Code(1, 2, x, y) / 255.0), 1e-6) << p;
    EXPECT_EQ(scene.depth_m.at<float>(p.y, p.x), Depth(1, x, y)) << p;
  }
  EXPECT_EQ(scene.input_hashes.size(), 2u);
  EXPECT_EQ(scene.input_hashes.count(File("nyu.mat") + "#1"), 1u);

  WriteText(File("range.json"), R"({"type": "nyu_v2", "file": "nyu.mat", "frames": "0:2"})");
  EXPECT_EQ(ExpandSceneSpec(File("range.json")),
            (std::vector<std::string>{File("range.json") + "#0", File("range.json") + "#1"}));
  const Scene zero = LoadScene(File("range.json") + "#0");
  EXPECT_EQ(zero.name, "range_0");
  EXPECT_EQ(zero.depth_m.at<float>(5, 7), Depth(0, 7, 5));
  EXPECT_EQ(zero.image.size(), cv::Size(kW, kH));
  WriteText(File("list.json"), R"({"type": "nyu_v2", "file": "nyu.mat", "frames": [1, 0]})");
  EXPECT_EQ(ExpandSceneSpec(File("list.json")),
            (std::vector<std::string>{File("list.json") + "#1", File("list.json") + "#0"}));
  WriteText(File("all.json"), R"({"type": "nyu_v2", "file": "nyu.mat", "frames": "1:"})");
  EXPECT_EQ(ExpandSceneSpec(File("all.json")), (std::vector<std::string>{File("all.json") + "#1"}));
  EXPECT_EQ(ExpandSceneSpec("builtin:room"), (std::vector<std::string>{"builtin:room"}));

  // A camera in the file overrides the preset.
  WriteText(File("cam.json"), R"({"type": "nyu_v2", "file": "nyu.mat", "frames": 0,
                                  "camera": {"fx": 500, "fy": 500, "cx": 320, "cy": 240}})");
  EXPECT_DOUBLE_EQ(LoadScene(File("cam.json")).camera.fx, 500.0);
}

TEST_F(NyuTest, SelectionErrors) {
  WriteText(File("range.json"), R"({"type": "nyu_v2", "file": "nyu.mat"})");
  ExpectLoadError(File("range.json"), File("range.json"), "selects 2 frames");
  ExpectLoadError(File("range.json") + "#2", File("range.json"), "'#2': no such frame");
  ExpectLoadError(File("range.json") + "#x", File("range.json"), "'#x': no such frame");
  WriteText(File("bad.json"), R"({"type": "nyu_v2", "file": "nyu.mat", "frames": 5})");
  ExpectLoadError(File("bad.json"), File("bad.json"), "out of range (2 frames, 0..1)");
  WriteText(File("bad.json"), R"({"type": "nyu_v2", "file": "nyu.mat", "frames": "2:9"})");
  ExpectLoadError(File("bad.json"), File("bad.json"), "selects no frame");
  WriteText(File("bad.json"), R"({"type": "nyu_v2", "file": "nyu.mat", "frames": "a-b"})");
  ExpectLoadError(File("bad.json"), File("bad.json"), "START:STOP");
  WriteText(File("bad.json"), R"({"type": "nyu_v2", "file": "nyu.mat", "frames": [0, 0]})");
  ExpectLoadError(File("bad.json"), File("bad.json"), "listed twice");
  WriteText(File("bad.json"), R"({"type": "nyu_v2", "file": "nyu.mat", "depth_dataset": "labels"})");
  ExpectLoadError(File("bad.json"), File("bad.json"), "'depths' or 'rawDepths'");
  WriteText(File("bad.json"), R"({"type": "nyu_v2", "file": "nyu.mat", "plane": {}})");
  ExpectLoadError(File("bad.json"), File("bad.json"), "unknown key 'plane'");
  WriteText(File("depth.json"), R"({"type": "depth", "image": "a.png", "depth": "b.exr",
                                    "camera": "tum_fr1"})");
  ExpectLoadError(File("depth.json") + "#1", File("depth.json"), "only nyu_v2 and folder");
}

TEST_F(NyuTest, BadFilesGiveOneLine) {
  TempDir dir;
  auto expect = [&](const NyuFile& file, int frame, const std::string& problem) {
    file.Write(dir.File("x.mat"));
    try {
      ReadNyuFrame(dir.File("x.mat"), frame);
      ADD_FAILURE() << "no error; expected '" << problem << "'";
    } catch (const Error& e) {
      const std::string message = e.what();
      EXPECT_EQ(message.rfind(dir.File("x.mat") + ": ", 0), 0u) << message;
      EXPECT_NE(message.find(problem), std::string::npos) << message;
      EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    }
  };
  NyuFile missing_images;
  missing_images.write_images = false;
  missing_images.depth_dims = {1, kW, kH};
  expect(missing_images, 0, "has no dataset 'images'");
  NyuFile missing_depths;
  missing_depths.image_dims = {1, 3, kW, kH};
  missing_depths.depth_name = "depth";
  missing_depths.depth_dims = {1, kW, kH};
  expect(missing_depths, 0, "has no dataset 'depths'");
  NyuFile transposed;  // as a NumPy (N, 3, H, W) array written without reversing the axes
  transposed.image_dims = {1, 3, kH, kW};
  transposed.depth_dims = {1, kW, kH};
  expect(transposed, 0, "expected (N, 3, 640, 480) as MATLAB v7.3 stores 480x640x3xN; it looks transposed");
  NyuFile frames_differ;
  frames_differ.image_dims = {1, 3, kW, kH};
  frames_differ.depth_dims = {2, kW, kH};
  expect(frames_differ, 0, "'depths' has shape (2, 640, 480), expected (1, 640, 480)");
  NyuFile float_images;
  float_images.image_dims = {1, 3, kW, kH};
  float_images.image_type = H5T_IEEE_F32LE;
  float_images.depth_dims = {1, kW, kH};
  expect(float_images, 0, "'images' must hold uint8");
  NyuFile int_depths;
  int_depths.image_dims = {1, 3, kW, kH};
  int_depths.depth_dims = {1, kW, kH};
  int_depths.depth_type = H5T_STD_U16LE;
  expect(int_depths, 0, "'depths' must hold float32 or float64");
  NyuFile nan_depth;
  nan_depth.image_dims = {1, 3, kW, kH};
  nan_depth.depth_dims = {1, kW, kH};
  nan_depth.depth = [](int, int x, int y) {
    return x == 17 && y == 3 ? std::numeric_limits<float>::quiet_NaN() : 2.0f;
  };
  expect(nan_depth, 0, "'depths' frame 0 has depth nan at pixel (17, 3)");
  NyuFile negative_depth = nan_depth;
  negative_depth.depth = [](int, int x, int y) { return x == 600 && y == 400 ? -1.5f : 2.0f; };
  expect(negative_depth, 0, "has depth -1.5 at pixel (600, 400)");
  expect(NyuFile(), 2, "frame 2 out of range (the file holds 2 frames, 0..1)");

  WriteText(dir.File("v5.mat"), "MATLAB 5.0 MAT-file, this is not HDF5");
  EXPECT_THROW(
      {
        try {
          NyuFrameCount(dir.File("v5.mat"));
        } catch (const Error& e) {
          EXPECT_NE(std::string(e.what()).find("not an HDF5 file"), std::string::npos) << e.what();
          throw;
        }
      },
      Error);
  EXPECT_THROW(NyuFrameCount(dir.File("absent.mat")), Error);
}

TEST_F(NyuTest, Float64OneFrameFileAndRawDepthsZeroIsUnknown) {
  TempDir dir;
  // MATLAB drops a trailing singleton: a one-frame file stores (3, 640, 480) and (640, 480).
  NyuFile one;
  one.image_dims = {3, kW, kH};
  one.depth_name = "rawDepths";
  one.depth_dims = {kW, kH};
  one.depth_type = H5T_IEEE_F64LE;
  one.depth = [](int, int x, int y) { return x < 10 ? 0.0f : Depth(0, x, y); };
  // The writer fills values only for the 4-D / 3-D layouts; write this one by hand.
  {
    const hid_t create = H5Pcreate(H5P_FILE_CREATE);
    H5Pset_userblock(create, 512);
    const hid_t file = H5Fcreate(dir.File("one.mat").c_str(), H5F_ACC_TRUNC, create, H5P_DEFAULT);
    std::vector<uint8_t> codes(size_t{3} * kW * kH);
    std::vector<double> depth(size_t{kW} * kH);
    for (int c = 0; c < 3; ++c)
      for (int x = 0; x < kW; ++x)
        for (int y = 0; y < kH; ++y) codes[(size_t{static_cast<size_t>(c)} * kW + x) * kH + y] = Code(0, c, x, y);
    for (int x = 0; x < kW; ++x)
      for (int y = 0; y < kH; ++y) depth[size_t{static_cast<size_t>(x)} * kH + y] = one.depth(0, x, y);
    NyuFile::WriteDataset(file, "images", one.image_dims, H5T_STD_U8LE, H5T_NATIVE_UINT8, codes.data());
    NyuFile::WriteDataset(file, "rawDepths", one.depth_dims, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, depth.data());
    H5Fclose(file);
    H5Pclose(create);
  }
  WriteText(dir.File("s.json"), R"({"type": "nyu_v2", "file": "one.mat", "depth_dataset": "rawDepths"})");
  const Scene scene = LoadScene(dir.File("s.json"));
  EXPECT_EQ(scene.name, "s_0");
  EXPECT_TRUE(std::isnan(scene.depth_m.at<float>(100, 9)));
  EXPECT_FLOAT_EQ(scene.depth_m.at<float>(100, 10), Depth(0, 10, 100));
  EXPECT_NEAR(scene.image.at<cv::Vec3f>(100, 300)[1], SrgbDecode(Code(0, 1, 300, 100) / 255.0), 1e-6);
  // Without "depth_dataset" the file lacks 'depths'.
  WriteText(dir.File("t.json"), R"({"type": "nyu_v2", "file": "one.mat"})");
  ExpectLoadError(dir.File("t.json"), dir.File("one.mat"), "has no dataset 'depths'");
}

// ---- .npy ----------------------------------------------------------------------------------------

// Bytes of a version-1.0 .npy file, header padded to a multiple of 64 as NumPy pads it.
std::string NpyBytes(const std::string& descr, const std::string& shape, const std::string& data,
                     bool fortran = false) {
  std::string header = "{'descr': '" + descr + "', 'fortran_order': " +
                       (fortran ? "True" : "False") + ", 'shape': " + shape + ", }";
  const size_t total = 10 + header.size() + 1;
  header += std::string((64 - total % 64) % 64, ' ') + "\n";
  std::string out = std::string("\x93NUMPY\x01\x00", 8);
  out += static_cast<char>(header.size() & 0xff);
  out += static_cast<char>(header.size() >> 8);
  return out + header + data;
}

template <typename T>
std::string RawBytes(const std::vector<T>& values) {
  return std::string(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
}

TEST(Npy, ReadsFloat32Float64Uint16InCOrder) {
  TempDir dir;
  std::vector<float> f32(6);
  std::vector<double> f64(6);
  std::vector<uint16_t> u16(6);
  for (int i = 0; i < 6; ++i) {
    f32[i] = 0.5f + i;
    f64[i] = 1.0 / 3.0 + i;
    u16[i] = static_cast<uint16_t>(60000 + i);
  }
  WriteText(dir.File("f4.npy"), NpyBytes("<f4", "(2, 3)", RawBytes(f32)));
  WriteText(dir.File("f8.npy"), NpyBytes("<f8", "(2, 3)", RawBytes(f64)));
  WriteText(dir.File("u2.npy"), NpyBytes("<u2", "(3, 2)", RawBytes(u16)));
  const NpyArray a = ReadNpy(dir.File("f4.npy"));
  ASSERT_EQ(a.values.size(), cv::Size(3, 2));
  EXPECT_FALSE(a.integer);
  EXPECT_EQ(a.values.at<float>(1, 0), 3.5f) << "row-major: element [1][0] is the 4th";
  const NpyArray b = ReadNpy(dir.File("f8.npy"));
  EXPECT_EQ(b.values.at<float>(1, 2), static_cast<float>(1.0 / 3.0 + 5));
  const NpyArray c = ReadNpy(dir.File("u2.npy"));
  ASSERT_EQ(c.values.size(), cv::Size(2, 3));
  EXPECT_TRUE(c.integer);
  EXPECT_EQ(c.values.at<float>(2, 1), 60005.0f);
  EXPECT_TRUE(IsNpyFile(dir.File("u2.npy")));
}

TEST(Npy, BadFilesGiveOneLine) {
  TempDir dir;
  const std::string four_floats = RawBytes(std::vector<float>(4, 1.0f));
  const std::vector<std::pair<std::string, std::string>> cases = {
      {NpyBytes("<f4", "(2, 2)", four_floats, true), "Fortran-order"},
      {NpyBytes("<f4", "(1, 2, 2)", four_floats), "3 dimensions (1, 2, 2), a depth map must be 2-D"},
      {NpyBytes(">f4", "(2, 2)", four_floats), "dtype '>f4' is not supported"},
      {NpyBytes("<i8", "(2, 1)", four_floats), "dtype '<i8' is not supported"},
      {NpyBytes("<f4", "(2, 3)", four_floats), "holds 16 data bytes, shape (2, 3) of <f4 needs 24 (truncated)"},
      {NpyBytes("<f4", "(0, 3)", ""), "must have at least one row and column"},
      {std::string("\x93NUMPY\x01\x00\x40\x00{'descr': '<f4'", 26), "truncated .npy header"},
      {"P5\n2 2\n255\nabcd", "not a .npy file"},
  };
  for (const auto& [bytes, problem] : cases) {
    WriteText(dir.File("x.npy"), bytes);
    try {
      ReadNpy(dir.File("x.npy"));
      ADD_FAILURE() << "no error; expected '" << problem << "'";
    } catch (const Error& e) {
      const std::string message = e.what();
      EXPECT_EQ(message.rfind(dir.File("x.npy") + ": ", 0), 0u) << message;
      EXPECT_NE(message.find(problem), std::string::npos) << message;
      EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    }
  }
}

// ---- folder datasets -----------------------------------------------------------------------------

constexpr int kFw = 8;
constexpr int kFh = 6;

// Depth pattern of frame `f` at (x, y), metres.
float FolderDepth(int f, int x, int y) { return 1.5f + 0.1f * x + 0.25f * y + f; }

void WriteRgb(const std::string& path, int f) {
  cv::Mat rgb(kFh, kFw, CV_8UC3);
  for (int y = 0; y < kFh; ++y)
    for (int x = 0; x < kFw; ++x)
      rgb.at<cv::Vec3b>(y, x) = {static_cast<uchar>(20 * x), static_cast<uchar>(30 * y),
                                 static_cast<uchar>(50 * f + 5)};
  cv::imwrite(path, rgb);
}

TEST(FolderDataset, NaturalOrder) {
  EXPECT_TRUE(NaturalLess("f2", "f10"));
  EXPECT_FALSE(NaturalLess("f10", "f2"));
  EXPECT_TRUE(NaturalLess("a", "b"));
  EXPECT_TRUE(NaturalLess("7", "007"));
  EXPECT_TRUE(NaturalLess("img_9_b", "img_10_a"));
  EXPECT_FALSE(NaturalLess("x", "x"));
}

TEST(FolderDataset, NpyExrPfmAndPng16Depth) {
  TempDir dir;
  namespace fs = std::filesystem;
  for (const char* sub : {"npy/rgb", "npy/depth", "exr/rgb", "exr/depth", "pfm/rgb", "pfm/depth", "mm/rgb", "mm/depth"})
    fs::create_directories(dir.File(sub));
  const std::vector<std::string> stems = {"f10", "f2", "f1"};
  for (size_t i = 0; i < stems.size(); ++i) {
    const int f = static_cast<int>(i);
    std::vector<float> values;
    cv::Mat depth(kFh, kFw, CV_32FC1);
    cv::Mat mm(kFh, kFw, CV_16UC1);
    for (int y = 0; y < kFh; ++y)
      for (int x = 0; x < kFw; ++x) {
        depth.at<float>(y, x) = FolderDepth(f, x, y);
        mm.at<uint16_t>(y, x) = static_cast<uint16_t>(std::lround(1000.0 * FolderDepth(f, x, y)));
        values.push_back(FolderDepth(f, x, y));
      }
    depth.at<float>(0, 0) = std::numeric_limits<float>::quiet_NaN();  // Hypersim-style hole
    values[0] = std::numeric_limits<float>::quiet_NaN();
    mm.at<uint16_t>(0, 0) = 0;
    for (const char* set : {"npy", "exr", "pfm", "mm"}) WriteRgb(dir.File(std::string(set) + "/rgb/" + stems[i] + ".png"), f);
    WriteText(dir.File("npy/depth/" + stems[i] + ".npy"),
              NpyBytes("<f4", "(" + std::to_string(kFh) + ", " + std::to_string(kFw) + ")", RawBytes(values)));
    WriteImage(dir.File("exr/depth/" + stems[i] + ".exr"), depth);
    WriteImage(dir.File("pfm/depth/" + stems[i] + ".pfm"), depth);
    cv::imwrite(dir.File("mm/depth/" + stems[i] + ".png"), mm);
  }
  const std::string camera = R"("camera": {"fx": 10, "fy": 11, "cx": 3.5, "cy": 2.5})";
  WriteText(dir.File("npy.json"), R"({"type": "folder", "folder": "npy", "color": "linear", )" + camera + "}");
  WriteText(dir.File("exr.json"), R"({"type": "folder", "folder": "exr", "frames": ["f2", "f10"], )" + camera + "}");
  WriteText(dir.File("pfm.json"), R"({"type": "folder", "folder": "pfm", )" + camera + "}");
  WriteText(dir.File("mm.json"), R"({"type": "folder", "folder": "mm", "depth_scale": 1000, "frames": "1:3", )" + camera + "}");
  // Natural stem order: f1, f2, f10.
  EXPECT_EQ(ExpandSceneSpec(dir.File("npy.json")),
            (std::vector<std::string>{dir.File("npy.json#f1"), dir.File("npy.json#f2"), dir.File("npy.json#f10")}));
  EXPECT_EQ(ExpandSceneSpec(dir.File("exr.json")),
            (std::vector<std::string>{dir.File("exr.json#f2"), dir.File("exr.json#f10")}));
  EXPECT_EQ(ExpandSceneSpec(dir.File("mm.json")),
            (std::vector<std::string>{dir.File("mm.json#f2"), dir.File("mm.json#f10")}));
  for (const char* set : {"npy", "exr", "pfm", "mm"}) {
    const Scene scene = LoadScene(dir.File(std::string(set) + ".json#f10"));  // written as frame 0
    EXPECT_EQ(scene.name, std::string(set) + "_f10");
    ASSERT_EQ(scene.image.size(), cv::Size(kFw, kFh));
    EXPECT_DOUBLE_EQ(scene.camera.fy, 11.0);
    EXPECT_TRUE(std::isnan(scene.depth_m.at<float>(0, 0))) << set;
    const float tolerance = std::string(set) == "mm" ? 0.0005f : 0.0f;  // mm rounding
    for (int y = 0; y < kFh; ++y)
      for (int x = 0; x < kFw; ++x)
        if (x + y > 0) {
          EXPECT_NEAR(scene.depth_m.at<float>(y, x), FolderDepth(0, x, y), tolerance) << set;
        }
    // WriteRgb's codes in OpenCV's BGR order: B = 20x, G = 30y, R = 50f + 5 (frame 0 here).
    const bool linear = std::string(set) == "npy";
    const cv::Vec3f bgr = scene.image.at<cv::Vec3f>(3, 4);
    const double codes[3] = {20 * 4 / 255.0, 30 * 3 / 255.0, 5 / 255.0};
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(bgr[c], linear ? codes[c] : SrgbDecode(codes[c]), 1e-6) << set << " channel " << c;
    EXPECT_EQ(scene.input_hashes.size(), 3u);
  }
  const Scene f2 = LoadScene(dir.File("npy.json#f2"));
  EXPECT_EQ(f2.depth_m.at<float>(5, 7), FolderDepth(1, 7, 5));
  EXPECT_NEAR(f2.image.at<cv::Vec3f>(0, 0)[2], 55 / 255.0, 1e-6) << "colour of frame f2 (R = 50 + 5)";

  // Distance along the ray -> z: z = r / |((x - cx) / fx, (y - cy) / fy, 1)|.
  WriteText(dir.File("ray.json"), R"({"type": "folder", "folder": "exr", "depth_kind": "ray", "frames": 0, )" + camera + "}");
  const Scene ray = LoadScene(dir.File("ray.json"));
  EXPECT_EQ(ray.name, "ray_f1");
  for (const cv::Point p : {cv::Point(1, 1), cv::Point(7, 5), cv::Point(3, 2)}) {
    const double u = (p.x - 3.5) / 10.0, v = (p.y - 2.5) / 11.0;
    EXPECT_NEAR(ray.depth_m.at<float>(p.y, p.x), FolderDepth(2, p.x, p.y) / std::sqrt(u * u + v * v + 1), 1e-5);
  }
  // A uint16 PNG needs an explicit scale.
  WriteText(dir.File("noscale.json"), R"({"type": "folder", "folder": "mm", "frames": 0, )" + camera + "}");
  ExpectLoadError(dir.File("noscale.json"), dir.File("noscale.json"), "'depth_scale' is required for integer depth files");
  ExpectLoadError(dir.File("mm.json#f3"), dir.File("mm.json"), "'#f3': no such frame");
  WriteText(dir.File("bad.json"), R"({"type": "folder", "folder": "mm", "frames": ["f7"], )" + camera + "}");
  ExpectLoadError(dir.File("bad.json"), dir.File("bad.json"), "no frame with stem 'f7'");
  WriteText(dir.File("bad.json"), R"({"type": "folder", "folder": "mm", "depth_kind": "euclid", )" + camera + "}");
  ExpectLoadError(dir.File("bad.json"), dir.File("bad.json"), "'depth_kind': expected one of z, range, ray");
  WriteText(dir.File("bad.json"), R"({"type": "folder", "folder": "mm"})");
  ExpectLoadError(dir.File("bad.json"), dir.File("bad.json"), "missing required key 'camera'");
}

TEST(FolderDataset, BadFoldersAndDepthGiveOneLine) {
  TempDir dir;
  namespace fs = std::filesystem;
  fs::create_directories(dir.File("d/rgb"));
  fs::create_directories(dir.File("d/depth"));
  const std::string camera = R"("camera": {"fx": 10, "fy": 10, "cx": 3.5, "cy": 2.5})";
  WriteText(dir.File("s.json"), R"({"type": "folder", "folder": "d", "frames": 0, )" + camera + "}");
  ExpectLoadError(dir.File("s.json"), dir.File("d"), "no frames");
  WriteRgb(dir.File("d/rgb/a.png"), 0);
  WriteRgb(dir.File("d/rgb/b.jpg"), 0);
  WriteText(dir.File("d/rgb/notes.txt"), "ignored");
  WriteText(dir.File("d/depth/a.npy"), NpyBytes("<f4", "(6, 8)", RawBytes(std::vector<float>(48, 2.0f))));
  ExpectLoadError(dir.File("s.json"), dir.File("d/rgb"), "1 colour file(s) without a depth file of the same stem in " + dir.File("d/depth") + ": b.jpg");
  fs::remove(dir.File("d/rgb/b.jpg"));
  WriteText(dir.File("d/depth/c.npy"), NpyBytes("<f4", "(6, 8)", RawBytes(std::vector<float>(48, 2.0f))));
  ExpectLoadError(dir.File("s.json"), dir.File("d/depth"), "without a colour file of the same stem");
  fs::remove(dir.File("d/depth/c.npy"));
  WriteRgb(dir.File("d/rgb/a.jpg"), 0);
  ExpectLoadError(dir.File("s.json"), dir.File("d/rgb"), "two colour files with stem 'a' (a.jpg, a.png)");
  fs::remove(dir.File("d/rgb/a.jpg"));
  EXPECT_EQ(LoadScene(dir.File("s.json")).depth_m.at<float>(3, 3), 2.0f);

  std::vector<float> negative(48, 2.0f);
  negative[8 * 2 + 5] = -0.25f;
  WriteText(dir.File("d/depth/a.npy"), NpyBytes("<f4", "(6, 8)", RawBytes(negative)));
  ExpectLoadError(dir.File("s.json"), dir.File("d/depth/a.npy"), "negative depth value -0.25 at pixel (5, 2)");
  WriteText(dir.File("d/depth/a.npy"),
            NpyBytes("<f4", "(6, 8)", RawBytes(std::vector<float>(48, std::numeric_limits<float>::quiet_NaN()))));
  ExpectLoadError(dir.File("s.json"), dir.File("d/depth/a.npy"), "no valid depth pixel");
  WriteText(dir.File("d/depth/a.npy"), NpyBytes("<f4", "(8, 6)", RawBytes(std::vector<float>(48, 2.0f))));
  ExpectLoadError(dir.File("s.json"), dir.File("d/depth/a.npy"), "size 6x8 differs from image");
  WriteText(dir.File("m.json"), R"({"type": "folder", "folder": "missing", )" + camera + "}");
  ExpectLoadError(dir.File("m.json"), dir.File("missing"), "dataset folder not found");
}

}  // namespace
}  // namespace turbid
