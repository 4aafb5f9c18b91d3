// Resource limits (core/limits.h): tiny crafted files whose headers claim 10^5 x 10^5 pixels (or
// 10^9 frames) in every format turbid decodes are refused from the header, before any allocation,
// with one line naming TURBID_MAX_PIXELS / TURBID_MAX_ITEMS; raising the variable lets a file
// through; a bad value of the variable is one clear error.
#include "core/limits.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfOutputFile.h>
#include <gtest/gtest.h>
#include <hdf5.h>
#include <zlib.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "core/error.h"
#include "scenes/image_io.h"
#include "scenes/npy_io.h"
#include "scenes/scene_loader.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {
using testing::TempDir;

void WriteBytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

std::string BigEndian32(uint32_t v) {
  return {static_cast<char>(v >> 24), static_cast<char>(v >> 16), static_cast<char>(v >> 8),
          static_cast<char>(v)};
}

std::string LittleEndian(uint64_t v, int bytes) {
  std::string out;
  for (int i = 0; i < bytes; ++i) out += static_cast<char>((v >> (8 * i)) & 0xff);
  return out;
}

std::string PngChunk(const std::string& type, const std::string& data) {
  const std::string body = type + data;
  const uLong crc =
      crc32(0, reinterpret_cast<const Bytef*>(body.data()), static_cast<uInt>(body.size()));
  return BigEndian32(static_cast<uint32_t>(data.size())) + body +
         BigEndian32(static_cast<uint32_t>(crc));
}

// A PNG header (IHDR) claiming width x height, an empty IDAT, IEND: 57 bytes.
std::string HugePng(uint32_t width, uint32_t height) {
  std::string ihdr = BigEndian32(width) + BigEndian32(height);
  ihdr += std::string("\x08\x02\x00\x00\x00", 5);  // 8-bit RGB, no interlace
  return std::string("\x89PNG\r\n\x1a\n", 8) + PngChunk("IHDR", ihdr) + PngChunk("IDAT", "") +
         PngChunk("IEND", "");
}

// A baseline JPEG header (SOF0 3 components, SOS) claiming width x height, no tables, EOI.
std::string HugeJpeg(uint16_t width, uint16_t height) {
  std::string j("\xff\xd8", 2);
  j += std::string("\xff\xc0\x00\x11\x08", 5);
  j += static_cast<char>(height >> 8);
  j += static_cast<char>(height & 0xff);
  j += static_cast<char>(width >> 8);
  j += static_cast<char>(width & 0xff);
  j += std::string("\x03\x01\x11\x00\x02\x11\x00\x03\x11\x00", 10);
  j += std::string("\xff\xda\x00\x0c\x03\x01\x00\x02\x00\x03\x00\x00\x3f\x00", 14);
  j += std::string("\x00\xff\xd9", 3);
  return j;
}

// A little-endian TIFF whose one IFD claims width x height 8-bit gray pixels in one strip.
std::string HugeTiff(uint32_t width, uint32_t height) {
  std::string t("II*\0", 4);
  t += LittleEndian(8, 4);
  const struct {
    uint16_t tag, type;
    uint32_t value;
  } entries[] = {{256, 4, width}, {257, 4, height}, {258, 3, 8},      {259, 3, 1}, {262, 3, 1},
                 {273, 4, 200},   {277, 3, 1},      {278, 4, height}, {279, 4, 16}};
  t += LittleEndian(std::size(entries), 2);
  for (const auto& e : entries) {
    t += LittleEndian(e.tag, 2) + LittleEndian(e.type, 2) + LittleEndian(1, 4);
    t += e.type == 3 ? LittleEndian(e.value, 2) + std::string(2, '\0') : LittleEndian(e.value, 4);
  }
  t += LittleEndian(0, 4);
  t.resize(216, '\0');
  return t;
}

std::string HugeNpy(int64_t rows, int64_t cols) {
  std::string header = "{'descr': '<f4', 'fortran_order': False, 'shape': (" +
                       std::to_string(rows) + ", " + std::to_string(cols) + "), }";
  while ((10 + header.size() + 1) % 64 != 0) header += ' ';
  header += '\n';
  return std::string("\x93NUMPY\x01\x00", 8) + LittleEndian(header.size(), 2) + header;
}

// An EXR whose header claims width x height float RGB and holds no pixel data.
void WriteHugeExr(const std::string& path, int width, int height) {
  Imf::Header header(width, height);
  header.compression() = Imf::ZIP_COMPRESSION;
  for (const char* name : {"R", "G", "B"}) header.channels().insert(name, Imf::Channel(Imf::FLOAT));
  Imf::OutputFile file(path.c_str(), header);  // no writePixels: a header and an offset table
}

// Expects `read` to throw one line "<path>: ... exceeds the limit ... TURBID_MAX_PIXELS ...".
void ExpectPixelLimit(const std::string& path, const std::function<void()>& read) {
  try {
    read();
    ADD_FAILURE() << path << ": no error";
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
    EXPECT_NE(message.find("exceeds the limit of 100000000 pixels per image"), std::string::npos)
        << message;
    EXPECT_NE(message.find("TURBID_MAX_PIXELS"), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

// Sets an environment variable for one scope.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    if (value) {
      setenv(name, value, 1);
    } else {
      unsetenv(name);
    }
  }
  ~ScopedEnv() {
    if (old_.empty()) {
      unsetenv(name_);
    } else {
      setenv(name_, old_.c_str(), 1);
    }
  }

 private:
  const char* name_;
  std::string old_;
};

TEST(Limits, HugeImageHeadersAreRefusedInEveryFormat) {
  const ScopedEnv unset("TURBID_MAX_PIXELS", nullptr);
  TempDir dir;
  const std::vector<std::pair<std::string, std::string>> files = {
      {"huge.png", HugePng(100000, 100000)},
      {"huge.jpg", HugeJpeg(65000, 65000)},
      {"huge.tif", HugeTiff(100000, 100000)},
      {"huge.pfm", "PF\n100000 100000\n-1.0\n" + std::string(16, '\0')},
      {"huge_gray.pfm", "Pf\n100000 100000\n-1.0\n" + std::string(16, '\0')},
      {"huge.pgm", "P5\n100000 100000\n255\n" + std::string(16, '\0')},
      {"huge.ppm", "P6\n100000 100000\n65535\n" + std::string(16, '\0')},
  };
  for (const auto& [name, bytes] : files) {
    WriteBytes(dir.File(name), bytes);
    EXPECT_LT(bytes.size(), 300u);
    const std::string path = dir.File(name);  // clang 14 cannot capture a structured binding
    ExpectPixelLimit(path, [&] { ReadImage(path); });
  }
  WriteHugeExr(dir.File("huge.exr"), 100000, 100000);
  ExpectPixelLimit(dir.File("huge.exr"), [&] { ReadImage(dir.File("huge.exr")); });
  WriteBytes(dir.File("huge.npy"), HugeNpy(100000, 100000));
  ExpectPixelLimit(dir.File("huge.npy"), [&] { ReadNpy(dir.File("huge.npy")); });
}

TEST(Limits, TheVariableRaisesAndLowersThePixelLimit) {
  TempDir dir;
  // A real 40x30 image: refused under a 1000-pixel limit, read under the default.
  cv::Mat image(30, 40, CV_32FC3, cv::Scalar(0.2, 0.4, 0.6));
  WriteImageOptions options;
  for (const char* name : {"small.png", "small.pfm", "small.exr"}) {
    WriteImage(dir.File(name), image, options);
    {
      const ScopedEnv low("TURBID_MAX_PIXELS", "1000");
      try {
        ReadImage(dir.File(name));
        ADD_FAILURE() << name << ": read under a 1000-pixel limit";
      } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("image size 40x30 exceeds the limit of 1000 pixels"),
                  std::string::npos)
            << e.what();
      }
    }
    {
      const ScopedEnv enough("TURBID_MAX_PIXELS", "1200");
      EXPECT_EQ(ReadImage(dir.File(name)).size(), cv::Size(40, 30)) << name;
    }
  }
  // Raised, a huge header gets past the limit and fails on its missing data instead.
  WriteBytes(dir.File("huge.pgm"), "P5\n20000 10000\n255\n" + std::string(16, '\0'));
  {
    const ScopedEnv raised("TURBID_MAX_PIXELS", "300000000");
    try {
      ReadImage(dir.File("huge.pgm"));
      ADD_FAILURE() << "no error";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
    }
  }
  for (const char* bad : {"abc", "0", "-5", "1e9", "99999999999"}) {
    const ScopedEnv wrong("TURBID_MAX_PIXELS", bad);
    try {
      ReadImage(dir.File("small.png"));
      ADD_FAILURE() << bad;
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()).rfind(std::string("TURBID_MAX_PIXELS='") + bad, 0), 0u)
          << e.what();
    }
  }
}

TEST(Limits, ItemCountsSaturateInsteadOfOverflowing) {
  const ScopedEnv unset("TURBID_MAX_ITEMS", nullptr);
  EXPECT_EQ(SaturatingProduct(int64_t{1} << 40, int64_t{1} << 40), INT64_MAX);
  EXPECT_EQ(SaturatingProduct(0, INT64_MAX), 0);
  EXPECT_NO_THROW(CheckItemCount("x.json", "the sweep", kDefaultMaxItems));
  try {
    CheckItemCount("x.json", "the sweep", INT64_MAX);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              "x.json: the sweep has more than 9.2e18 items, more than the limit of 1000000 "
              "(raise it with the environment variable TURBID_MAX_ITEMS)");
  }
}

// A MATLAB v7.3 (HDF5) file whose chunked datasets claim 10^9 NYU frames and hold none: a few KB.
TEST(Limits, ADatasetClaimingABillionFramesIsRefused) {
  const ScopedEnv unset("TURBID_MAX_ITEMS", nullptr);
  TempDir dir;
  const std::string path = dir.File("huge.mat");
  const hid_t create = H5Pcreate(H5P_FILE_CREATE);
  H5Pset_userblock(create, 512);
  const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, create, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  const hsize_t frames = 1000000000;
  const auto add = [&](const char* name, std::vector<hsize_t> dims, hid_t type) {
    std::vector<hsize_t> chunk = dims;
    chunk[0] = 1;
    const hid_t space = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
    const hid_t properties = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(properties, static_cast<int>(chunk.size()), chunk.data());
    const hid_t dataset = H5Dcreate2(file, name, type, space, H5P_DEFAULT, properties, H5P_DEFAULT);
    ASSERT_GE(dataset, 0) << name;
    H5Dclose(dataset);
    H5Pclose(properties);
    H5Sclose(space);
  };
  add("images", {frames, 3, 640, 480}, H5T_STD_U8LE);
  add("depths", {frames, 640, 480}, H5T_IEEE_F32LE);
  H5Fclose(file);
  H5Pclose(create);
  WriteBytes(dir.File("huge.json"), R"({"type": "nyu_v2", "file": "huge.mat", "frames": 0})");
  try {
    LoadScene(dir.File("huge.json"));
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("huge.mat: the dataset has 1000000000 items, more than the limit of "
                           "1000000 (raise it with the environment variable TURBID_MAX_ITEMS)"),
              std::string::npos)
        << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

}  // namespace
}  // namespace turbid
