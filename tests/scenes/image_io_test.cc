// Image I/O: round trips, each reader against bytes the test writes itself, truncated and corrupt
// files, atomic and non-overwriting writes.
#include "scenes/image_io.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "core/atomic_file.h"
#include "core/error.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {
namespace fs = std::filesystem;
using testing::TempDir;

void WriteBytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

std::string ReadBytes(const std::string& path) { return testing::ReadFileText(path); }

// Truncates a file to `fraction` of its size.
void Truncate(const std::string& path, double fraction) {
  const std::string bytes = ReadBytes(path);
  WriteBytes(path, bytes.substr(0, static_cast<size_t>(bytes.size() * fraction)));
}

// The message must have the "<path>: <problem>" shape.
void ExpectErrorNamingFile(const std::string& path, const ReadImageOptions& options = {}) {
  try {
    ReadImage(path, options);
    ADD_FAILURE() << "no error for " << path;
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
    EXPECT_GT(message.size(), path.size() + 4) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << "one line: " << message;
  }
}

cv::Mat Ramp(int rows, int cols, int channels) {
  cv::Mat image(rows, cols, CV_32FC(channels));
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < cols * channels; ++x)
      image.ptr<float>(y)[x] = static_cast<float>((x * 7 + y * 13) % 101) / 100.0f;
  return image;
}

std::string FloatBytes(const std::vector<float>& values, bool big_endian) {
  std::string out;
  for (float v : values) {
    unsigned char b[4];
    std::memcpy(b, &v, 4);
    const uint16_t probe = 1;
    const bool host_little = *reinterpret_cast<const unsigned char*>(&probe) == 1;
    if (host_little == big_endian) std::swap(b[0], b[3]), std::swap(b[1], b[2]);
    out.append(reinterpret_cast<const char*>(b), 4);
  }
  return out;
}

TEST(ImageIo, DefaultOptionsPassCheck) {
  std::string why;
  EXPECT_TRUE(ReadImageOptions{}.Check(&why));
  EXPECT_TRUE(WriteImageOptions{}.Check(&why));
  WriteImageOptions bad;
  bad.bit_depth = 12;
  EXPECT_FALSE(bad.Check(&why));
}

TEST(ImageIo, SrgbCurveMatchesIec61966) {
  cv::Mat v(1, 4, CV_32FC3);
  for (int i = 0; i < 4; ++i) v.at<cv::Vec3f>(0, i) = {0.0f, 0.5f, 1.0f};
  const cv::Mat linear = SrgbToLinear(v);
  // Every channel of every pixel is converted (a 3-channel Mat once had only its first third done).
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(linear.at<cv::Vec3f>(0, i)[0], 0.0, 1e-7);
    EXPECT_NEAR(linear.at<cv::Vec3f>(0, i)[1], 0.2140411, 1e-6);  // ((0.5 + 0.055) / 1.055)^2.4
    EXPECT_NEAR(linear.at<cv::Vec3f>(0, i)[2], 1.0, 1e-6);
  }
  cv::Mat small(1, 1, CV_32FC1, cv::Scalar(0.02));
  EXPECT_NEAR(SrgbToLinear(small).at<float>(0, 0), 0.02 / 12.92, 1e-8);  // linear segment
  const cv::Mat ramp = Ramp(8, 8, 3);
  EXPECT_LT(cv::norm(SrgbToLinear(LinearToSrgb(ramp)), ramp, cv::NORM_INF), 1e-5);
}

TEST(ImageIo, Png8And16RoundTrip) {
  TempDir dir;
  for (int bits : {8, 16}) {
    for (int channels : {1, 3}) {
      SCOPED_TRACE(std::to_string(bits) + " bit, " + std::to_string(channels) + " channels");
      const cv::Mat image = Ramp(6, 9, channels);
      const std::string path =
          dir.File("ramp" + std::to_string(bits) + "_" + std::to_string(channels) + ".png");
      WriteImageOptions options;
      options.bit_depth = bits;
      WriteImage(path, image, options);
      const cv::Mat back = ReadImage(path);
      ASSERT_EQ(back.type(), image.type());
      EXPECT_LE(cv::norm(back, image, cv::NORM_INF), 0.5 / (bits == 8 ? 255.0 : 65535.0) + 1e-7);
      // The file really has that bit depth (OpenCV as the independent reader).
      const cv::Mat raw = cv::imread(path, cv::IMREAD_UNCHANGED);
      EXPECT_EQ(raw.depth(), bits == 8 ? CV_8U : CV_16U);
      EXPECT_EQ(raw.channels(), channels);
    }
  }
}

TEST(ImageIo, SrgbEncodedPngDecodesToLinear) {
  TempDir dir;
  cv::Mat srgb8(1, 3, CV_8UC3, cv::Scalar(0, 128, 255));  // B, G, R
  const std::string path = dir.File("srgb.png");
  ASSERT_TRUE(cv::imwrite(path, srgb8));
  ReadImageOptions options;
  options.transfer = Transfer::kSrgb;
  const cv::Mat linear = ReadImage(path, options);
  EXPECT_NEAR(linear.at<cv::Vec3f>(0, 0)[0], 0.0, 1e-7);
  EXPECT_NEAR(linear.at<cv::Vec3f>(0, 0)[1], std::pow((128 / 255.0 + 0.055) / 1.055, 2.4), 1e-6);
  EXPECT_NEAR(linear.at<cv::Vec3f>(0, 0)[2], 1.0, 1e-6);
  // Writing with the sRGB transfer gives the original code values back.
  WriteImageOptions write;
  write.transfer = Transfer::kSrgb;
  WriteImage(dir.File("again.png"), linear, write);
  EXPECT_EQ(cv::norm(cv::imread(dir.File("again.png"), cv::IMREAD_UNCHANGED), srgb8, cv::NORM_INF),
            0.0);
}

TEST(ImageIo, RawPng16KeepsIntegerDepthCodes) {
  TempDir dir;
  cv::Mat depth_m(2, 3, CV_32FC1);
  depth_m.at<float>(0, 0) = std::numeric_limits<float>::quiet_NaN();
  for (int i = 1; i < 6; ++i) depth_m.at<float>(i / 3, i % 3) = 0.5f * i + 0.0002f * i;
  WriteImageOptions options;
  options.bit_depth = 16;
  options.raw = true;
  WriteImage(dir.File("depth.png"), depth_m * 5000.0, options);
  ReadImageOptions raw;
  raw.keep_raw = true;
  const cv::Mat back = ReadImage(dir.File("depth.png"), raw);
  EXPECT_EQ(back.at<float>(0, 0), 0.0f);  // NaN -> 0 = invalid
  for (int i = 1; i < 6; ++i)
    EXPECT_EQ(back.at<float>(i / 3, i % 3), std::round(depth_m.at<float>(i / 3, i % 3) * 5000.0f));
}

TEST(ImageIo, ExrFloatRoundTripKeepsNanAndRange) {
  TempDir dir;
  for (int channels : {1, 3}) {
    cv::Mat image = Ramp(5, 7, channels) * 4.0 - 1.0;  // values outside [0, 1] survive
    image.ptr<float>(2)[3] = std::numeric_limits<float>::quiet_NaN();
    const std::string path = dir.File("x" + std::to_string(channels) + ".exr");
    WriteImage(path, image);
    EXPECT_EQ(DetectImageFormat(path), ImageFormat::kExr);
    const cv::Mat back = ReadImage(path);
    ASSERT_EQ(back.type(), image.type());
    EXPECT_TRUE(std::isnan(back.ptr<float>(2)[3]));
    cv::Mat a = image.clone(), b = back.clone();
    cv::patchNaNs(a, 0);
    cv::patchNaNs(b, 0);
    EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0) << "float EXR must be lossless";
  }
}

// Reruns must reproduce files byte for byte: no capture date or other clock-dependent header,
// and the colour channels are named for what they hold (OpenCV's BGR memory order is not leaked).
TEST(ImageIo, ExrBytesAreReproducibleAndChannelsNamedByColour) {
  TempDir dir;
  cv::Mat image(4, 6, CV_32FC3, cv::Scalar(0.25, 0.5, 0.75));  // B, G, R
  const std::string a = dir.File("a.exr"), b = dir.File("b.exr");
  WriteImage(a, image);
  WriteImage(b, image);
  const std::string bytes = ReadBytes(a);
  EXPECT_EQ(bytes, ReadBytes(b));
  EXPECT_EQ(bytes.find("capDate"), std::string::npos);
  auto in = OIIO::ImageInput::open(a);
  ASSERT_TRUE(in);
  const OIIO::ImageSpec& spec = in->spec();
  ASSERT_EQ(spec.nchannels, 3);
  std::vector<float> pixels(static_cast<size_t>(spec.width * spec.height * 3));
  ASSERT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeDesc::FLOAT, pixels.data()));
  for (int c = 0; c < 3; ++c) {
    const float expected = spec.channelnames[c] == "R"   ? 0.75f
                           : spec.channelnames[c] == "G" ? 0.5f
                                                         : 0.25f;
    EXPECT_EQ(pixels[static_cast<size_t>(c)], expected) << spec.channelnames[c];
  }
}

// PFM written byte by byte: little-endian (negative scale) and big-endian, bottom-to-top rows,
// RGB order in the file, inf kept (Middlebury's "unknown").
TEST(ImageIo, PfmReaderHandlesEndiannessRowOrderAndInf) {
  TempDir dir;
  const float inf = std::numeric_limits<float>::infinity();
  // Image rows (top first): [1 2 3], [4 5 inf]. File rows are bottom first.
  const std::vector<float> file_order = {4, 5, inf, 1, 2, 3};
  for (bool big : {false, true}) {
    const std::string path = dir.File(big ? "big.pfm" : "little.pfm");
    WriteBytes(path, std::string("Pf\n3 2\n") + (big ? "1.0" : "-1.0") + "\n" +
                         FloatBytes(file_order, big));
    const cv::Mat m = ReadImage(path);
    ASSERT_EQ(m.type(), CV_32FC1);
    ASSERT_EQ(m.size(), cv::Size(3, 2));
    EXPECT_EQ(m.at<float>(0, 0), 1.0f);
    EXPECT_EQ(m.at<float>(0, 2), 3.0f);
    EXPECT_EQ(m.at<float>(1, 1), 5.0f);
    EXPECT_TRUE(std::isinf(m.at<float>(1, 2)));
  }
  // Colour: file stores R, G, B; memory is BGR.
  WriteBytes(dir.File("rgb.pfm"), "PF\n1 1\n-1\n" + FloatBytes({0.1f, 0.2f, 0.3f}, false));
  const cv::Vec3f bgr = ReadImage(dir.File("rgb.pfm")).at<cv::Vec3f>(0, 0);
  EXPECT_EQ(bgr, cv::Vec3f(0.3f, 0.2f, 0.1f));
  // Our writer produces what the reader reads.
  const cv::Mat ramp = Ramp(4, 5, 3);
  WriteImage(dir.File("ramp.pfm"), ramp);
  EXPECT_EQ(cv::norm(ReadImage(dir.File("ramp.pfm")), ramp, cv::NORM_INF), 0.0);
}

TEST(ImageIo, PgmReaderScalesOrKeepsRawValues) {
  TempDir dir;
  WriteBytes(dir.File("a.pgm"),
             std::string("P5\n# comment\n3 1\n255\n") + std::string("\x00\x32\xff", 3));
  cv::Mat scaled = ReadImage(dir.File("a.pgm"));
  EXPECT_NEAR(scaled.at<float>(0, 1), 50.0 / 255.0, 1e-7);
  ReadImageOptions raw;
  raw.keep_raw = true;
  cv::Mat values = ReadImage(dir.File("a.pgm"), raw);
  EXPECT_EQ(values.at<float>(0, 0), 0.0f);
  EXPECT_EQ(values.at<float>(0, 1), 50.0f);
  EXPECT_EQ(values.at<float>(0, 2), 255.0f);
  // 16-bit samples are big-endian.
  WriteBytes(dir.File("b.pgm"), std::string("P5 2 1 1000\n") + std::string("\x03\xe8\x01\x00", 4));
  values = ReadImage(dir.File("b.pgm"), raw);
  EXPECT_EQ(values.at<float>(0, 0), 1000.0f);
  EXPECT_EQ(values.at<float>(0, 1), 256.0f);
  EXPECT_NEAR(ReadImage(dir.File("b.pgm")).at<float>(0, 1), 0.256, 1e-7);
}

TEST(ImageIo, TiffAndJpegReadThroughTheirDecoders) {
  TempDir dir;
  const cv::Mat ramp = Ramp(16, 16, 3);
  cv::Mat u8, u16;
  ramp.convertTo(u8, CV_8U, 255.0);
  ramp.convertTo(u16, CV_16U, 65535.0);
  ASSERT_TRUE(cv::imwrite(dir.File("a8.tif"), u8));
  ASSERT_TRUE(cv::imwrite(dir.File("a16.tif"), u16));
  // Plain IEEE float TIFF (as datasets ship it): our own writer's PFM data re-encoded by OIIO is
  // not independent, so write it with OpenCV's LogLuv float encoder too and check both paths.
  ASSERT_TRUE(cv::imwrite(dir.File("logluv.tif"), ramp));
  EXPECT_LT(cv::norm(ReadImage(dir.File("logluv.tif")), ramp, cv::NORM_INF), 0.02)
      << "LogLuv TIFF (lossy, ~1% steps) must decode to the float values";
  {
    auto out = OIIO::ImageOutput::create(dir.File("af.tif"));
    ASSERT_TRUE(out);
    cv::Mat rgb;
    cv::cvtColor(ramp, rgb, cv::COLOR_BGR2RGB);
    ASSERT_TRUE(out->open(dir.File("af.tif"),
                          OIIO::ImageSpec(rgb.cols, rgb.rows, 3, OIIO::TypeDesc::FLOAT)));
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, rgb.data));
    ASSERT_TRUE(out->close());
  }
  EXPECT_EQ(DetectImageFormat(dir.File("a8.tif")), ImageFormat::kTiff);
  EXPECT_LE(cv::norm(ReadImage(dir.File("a8.tif")), ramp, cv::NORM_INF), 0.5 / 255 + 1e-6);
  EXPECT_LE(cv::norm(ReadImage(dir.File("a16.tif")), ramp, cv::NORM_INF), 0.5 / 65535 + 1e-6);
  EXPECT_EQ(cv::norm(ReadImage(dir.File("af.tif")), ramp, cv::NORM_INF), 0.0);
  ReadImageOptions raw;
  raw.keep_raw = true;
  const cv::Mat raw16 = ReadImage(dir.File("a16.tif"), raw);
  cv::Mat u16f;
  u16.convertTo(u16f, CV_32F);
  EXPECT_EQ(cv::norm(raw16, u16f, cv::NORM_INF), 0.0);
  // JPEG: compare with OpenCV's own decode of the same file (independent path, exact).
  ASSERT_TRUE(cv::imwrite(dir.File("a.jpg"), u8, {cv::IMWRITE_JPEG_QUALITY, 95}));
  EXPECT_EQ(DetectImageFormat(dir.File("a.jpg")), ImageFormat::kJpeg);
  const cv::Mat jpeg = ReadImage(dir.File("a.jpg"));
  ASSERT_EQ(jpeg.type(), CV_32FC3);
  cv::Mat reference;
  cv::imread(dir.File("a.jpg"), cv::IMREAD_UNCHANGED).convertTo(reference, CV_32F, 1.0 / 255);
  EXPECT_LT(cv::norm(jpeg, reference, cv::NORM_INF), 1e-6);
}

// Truncated files of every format: one-line "<path>: <problem>" errors, never a partial image.
TEST(ImageIo, TruncatedFilesAreErrors) {
  TempDir dir;
  const cv::Mat ramp = Ramp(64, 64, 3);
  cv::Mat u8;
  ramp.convertTo(u8, CV_8U, 255.0);
  WriteImage(dir.File("t.png"), ramp);
  WriteImage(dir.File("t.exr"), ramp);
  WriteImage(dir.File("t.pfm"), ramp);
  ASSERT_TRUE(cv::imwrite(dir.File("t.jpg"), u8));
  ASSERT_TRUE(cv::imwrite(dir.File("t.tif"), u8));
  cv::Mat gray;
  cv::extractChannel(u8, gray, 0);
  ASSERT_TRUE(cv::imwrite(dir.File("t.pgm"), gray));
  for (const char* name : {"t.png", "t.exr", "t.pfm", "t.jpg", "t.tif", "t.pgm"}) {
    SCOPED_TRACE(name);
    ASSERT_NO_THROW(ReadImage(dir.File(name)));
    Truncate(dir.File(name), 0.6);
    ExpectErrorNamingFile(dir.File(name));
  }
}

TEST(ImageIo, CorruptMissingAndEmptyFilesAreErrors) {
  TempDir dir;
  ExpectErrorNamingFile(dir.File("missing.png"));
  WriteBytes(dir.File("empty.png"), "");
  ExpectErrorNamingFile(dir.File("empty.png"));
  WriteBytes(dir.File("text.png"), "hello, not an image");
  ExpectErrorNamingFile(dir.File("text.png"));
  ExpectErrorNamingFile(dir.path());  // a folder
  // PNG with its pixel data scrambled but its end intact.
  WriteImage(dir.File("c.png"), Ramp(32, 32, 3));
  std::string bytes = ReadBytes(dir.File("c.png"));
  for (size_t i = 60; i < bytes.size() - 20; ++i) bytes[i] = static_cast<char>(i * 31);
  WriteBytes(dir.File("c.png"), bytes);
  ExpectErrorNamingFile(dir.File("c.png"));
  // Bad headers.
  WriteBytes(dir.File("h.pfm"), "Pf\n-3 2\n-1\n");
  ExpectErrorNamingFile(dir.File("h.pfm"));
  WriteBytes(dir.File("s.pfm"), "Pf\n1 1\n0\n" + FloatBytes({1.0f}, false));
  ExpectErrorNamingFile(dir.File("s.pfm"));
  WriteBytes(dir.File("m.pgm"), std::string("P5 1 1 100\n\xc8", 12));  // sample above maxval
  ExpectErrorNamingFile(dir.File("m.pgm"));
}

TEST(ImageIo, WritesAreAtomicAndNeverOverwriteUnlessAsked) {
  TempDir dir;
  const std::string path = dir.File("a.png");
  WriteImage(path, Ramp(4, 4, 1));
  const std::string first = ReadBytes(path);
  EXPECT_THROW(WriteImage(path, Ramp(4, 4, 1) * 0.5), Error);
  EXPECT_EQ(ReadBytes(path), first) << "refused write must leave the file untouched";
  WriteImageOptions force;
  force.overwrite = true;
  WriteImage(path, Ramp(4, 4, 1) * 0.5, force);
  EXPECT_NE(ReadBytes(path), first);
  EXPECT_THROW(WriteImage(dir.File("a.bmp"), Ramp(4, 4, 1)), Error);
  EXPECT_THROW(WriteImage(dir.File("no/such/folder/a.png"), Ramp(4, 4, 1)), Error);
  EXPECT_THROW(WriteImage(dir.File("e.png"), cv::Mat()), Error);
  // Only the one finished file is left: no temporaries.
  int files = 0;
  for (const auto& entry : fs::directory_iterator(dir.path())) {
    ++files;
    EXPECT_EQ(entry.path().filename(), "a.png");
  }
  EXPECT_EQ(files, 1);
}

// A process interrupted (SIGINT, SIGTERM) in the middle of a write removes its temporary file
// and still dies of that signal; nothing is left under the final name.
TEST(AtomicFile, SignalDuringAWriteRemovesTheTemporaryFile) {
  for (int signal_number : {SIGINT, SIGTERM}) {
    TempDir dir;
    const std::string started = dir.File("started");
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      RemoveTemporaryFilesOnSignal();
      AtomicWrite(dir.File("out.txt"), false, [&](const std::string& temp) {
        WriteBytes(temp, "half of it");
        WriteBytes(started, "");
        ::sleep(30);  // interrupted here
      });
      ::_exit(0);
    }
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (!fs::exists(started) && std::chrono::steady_clock::now() < deadline) ::usleep(2000);
    ASSERT_TRUE(fs::exists(started));
    ASSERT_EQ(::kill(child, signal_number), 0);
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == signal_number) << status;
    std::vector<std::string> left;
    for (const auto& entry : fs::directory_iterator(dir.path()))
      left.push_back(entry.path().filename().string());
    EXPECT_EQ(left, std::vector<std::string>{"started"}) << "signal " << signal_number;
  }
}

}  // namespace
}  // namespace turbid
