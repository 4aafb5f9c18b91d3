// The light codecs (libpng, libjpeg, OpenEXR) against the decoders they replaced, on the same
// files: cv::imread(IMREAD_UNCHANGED) for PNG and JPEG, OpenImageIO for EXR, and cv::imwrite for
// the bytes of PNG files. Every comparison is exact (tolerance 0): same pixels, same file bytes.
// The variant files are written here with libpng / libjpeg / OpenEXR directly.
// clang-format off
#include <cstdio>
#include <jpeglib.h>
// clang-format on
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfTiledOutputFile.h>
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <png.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <tuple>
#include <vector>

#include "core/error.h"
#include "scenes/image_io.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {
using testing::TempDir;

ReadImageOptions Raw() {
  ReadImageOptions options;
  options.keep_raw = true;
  return options;
}

// What ReadImage returned before: OpenCV's decode, alpha dropped, as float32 codes.
cv::Mat OpenCvReference(const std::string& path) {
  cv::Mat raw = cv::imread(path, cv::IMREAD_UNCHANGED);
  EXPECT_FALSE(raw.empty()) << path;
  if (raw.channels() == 4) cv::cvtColor(raw, raw, cv::COLOR_BGRA2BGR);
  cv::Mat out;
  raw.convertTo(out, CV_32F);
  return out;
}

// What ReadImage returned before for EXR: OpenImageIO, the first 3 channels (RGB order) or the
// first one, as float, in BGR order.
cv::Mat OiioReference(const std::string& path) {
  auto in = OIIO::ImageInput::open(path);
  EXPECT_TRUE(in) << path;
  if (!in) return cv::Mat();
  const OIIO::ImageSpec spec = in->spec();
  const int channels = spec.nchannels >= 3 ? 3 : 1;
  cv::Mat out(spec.height, spec.width, CV_32FC(channels));
  EXPECT_TRUE(in->read_image(0, 0, 0, channels, OIIO::TypeDesc::FLOAT, out.data));
  if (channels == 3) cv::cvtColor(out, out, cv::COLOR_RGB2BGR);
  return out;
}

// Exact equality, NaN equal to NaN.
void ExpectIdentical(const cv::Mat& ours, const cv::Mat& reference) {
  ASSERT_EQ(ours.type(), reference.type());
  ASSERT_EQ(ours.size(), reference.size());
  const cv::Mat a = ours.reshape(1), b = reference.reshape(1);
  long differing = 0;
  for (int y = 0; y < a.rows; ++y)
    for (int x = 0; x < a.cols; ++x) {
      const float u = a.at<float>(y, x), v = b.at<float>(y, x);
      if (!(u == v || (std::isnan(u) && std::isnan(v)))) ++differing;
    }
  EXPECT_EQ(differing, 0);
}

// A PNG written with libpng from interleaved samples in file order (RGB, gray, palette indices
// packed as libpng expects for < 8 bits).
void WritePng(const std::string& path, int width, int height, int bit_depth, int color_type,
              bool interlaced, const std::vector<uint8_t>& samples, int palette_size = 0,
              int transparent_entries = 0, bool gray_trns = false) {
  FILE* f = std::fopen(path.c_str(), "wb");
  ASSERT_TRUE(f);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  ASSERT_EQ(setjmp(png_jmpbuf(png)), 0);
  png_init_io(png, f);
  png_set_IHDR(png, info, width, height, bit_depth, color_type,
               interlaced ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  std::vector<png_color> palette(static_cast<size_t>(palette_size));
  for (int i = 0; i < palette_size; ++i)
    palette[static_cast<size_t>(i)] = {static_cast<png_byte>(i * 37), static_cast<png_byte>(i * 11),
                                       static_cast<png_byte>(255 - i * 5)};
  if (palette_size > 0) png_set_PLTE(png, info, palette.data(), palette_size);
  std::vector<png_byte> alpha(static_cast<size_t>(std::max(transparent_entries, 1)), 17);
  png_color_16 trns_color{};
  trns_color.gray = 3;
  trns_color.red = 10;
  trns_color.green = 20;
  trns_color.blue = 30;
  if (transparent_entries > 0 || gray_trns)
    png_set_tRNS(png, info, alpha.data(), transparent_entries, &trns_color);
  png_write_info(png, info);
  const size_t row_bytes = png_get_rowbytes(png, info);
  std::vector<png_bytep> rows(static_cast<size_t>(height));
  for (int y = 0; y < height; ++y)
    rows[static_cast<size_t>(y)] = const_cast<png_bytep>(samples.data() + row_bytes * y);
  EXPECT_EQ(samples.size(), row_bytes * height);
  png_write_image(png, rows.data());
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  std::fclose(f);
}

std::vector<uint8_t> Pattern(size_t n, int modulo = 256) {
  std::vector<uint8_t> v(n);
  for (size_t i = 0; i < n; ++i) v[i] = static_cast<uint8_t>((i * 89 + i / 7 * 13) % modulo);
  return v;
}

TEST(ImageCodecs, PngVariantsDecodeAsOpenCvDid) {
  TempDir dir;
  const int w = 13, h = 7;
  struct Variant {
    const char* name;
    int bit_depth, color_type, samples_per_pixel;
    int palette_size = 0, transparent = 0;
    bool gray_trns = false;
  };
  const std::vector<Variant> variants = {
      {"gray1", 1, PNG_COLOR_TYPE_GRAY, 1},
      {"gray2", 2, PNG_COLOR_TYPE_GRAY, 1},
      {"gray4", 4, PNG_COLOR_TYPE_GRAY, 1},
      {"gray8", 8, PNG_COLOR_TYPE_GRAY, 1},
      {"gray16", 16, PNG_COLOR_TYPE_GRAY, 1},
      {"gray8_trns", 8, PNG_COLOR_TYPE_GRAY, 1, 0, 0, true},
      {"gray_alpha8", 8, PNG_COLOR_TYPE_GRAY_ALPHA, 2},
      {"gray_alpha16", 16, PNG_COLOR_TYPE_GRAY_ALPHA, 2},
      {"rgb8", 8, PNG_COLOR_TYPE_RGB, 3},
      {"rgb16", 16, PNG_COLOR_TYPE_RGB, 3},
      {"rgb8_trns", 8, PNG_COLOR_TYPE_RGB, 3, 0, 0, true},
      {"rgba8", 8, PNG_COLOR_TYPE_RGB_ALPHA, 4},
      {"rgba16", 16, PNG_COLOR_TYPE_RGB_ALPHA, 4},
      {"palette8", 8, PNG_COLOR_TYPE_PALETTE, 1, 40},
      {"palette4_trns", 4, PNG_COLOR_TYPE_PALETTE, 1, 16, 5},
  };
  for (const Variant& v : variants) {
    for (bool interlaced : {false, true}) {
      SCOPED_TRACE(std::string(v.name) + (interlaced ? " interlaced" : ""));
      const size_t row_bits = static_cast<size_t>(w) * v.samples_per_pixel * v.bit_depth;
      const size_t row_bytes = (row_bits + 7) / 8;
      const int modulo = v.palette_size > 0 && v.bit_depth == 8 ? v.palette_size : 256;
      const std::string path =
          dir.File(std::string(v.name) + (interlaced ? "_i" : "") + ".png");
      WritePng(path, w, h, v.bit_depth, v.color_type, interlaced, Pattern(row_bytes * h, modulo),
               v.palette_size, v.transparent, v.gray_trns);
      ExpectIdentical(ReadImage(path, Raw()), OpenCvReference(path));
    }
  }
}

TEST(ImageCodecs, PngWritesTheBytesOfCvImwrite) {
  TempDir dir;
  for (int bits : {8, 16}) {
    for (int channels : {1, 3}) {
      SCOPED_TRACE(std::to_string(bits) + " bit, " + std::to_string(channels) + " channels");
      cv::Mat codes(37, 53, CV_MAKETYPE(bits == 8 ? CV_8U : CV_16U, channels));
      cv::randu(codes, 0, bits == 8 ? 256 : 65536);
      codes.rowRange(0, 10).setTo(cv::Scalar::all(bits == 8 ? 200 : 40000));  // runs for Z_RLE
      cv::Mat values;
      codes.convertTo(values, CV_32F);
      WriteImageOptions options;
      options.bit_depth = bits;
      options.raw = true;  // integer codes written as they are
      const std::string ours = dir.File("ours" + std::to_string(bits * 10 + channels) + ".png");
      const std::string theirs = dir.File("cv" + std::to_string(bits * 10 + channels) + ".png");
      WriteImage(ours, values, options);
      ASSERT_TRUE(cv::imwrite(theirs, codes));
      EXPECT_EQ(testing::ReadFileText(ours), testing::ReadFileText(theirs));
      // And the codes (channel order included) come back from an independent decoder.
      const cv::Mat decoded = cv::imread(ours, cv::IMREAD_UNCHANGED);
      ASSERT_EQ(decoded.type(), codes.type());
      EXPECT_EQ(cv::norm(decoded, codes, cv::NORM_INF), 0.0);
    }
  }
}

// A JPEG written with libjpeg from interleaved samples (RGB, gray or CMYK), with the luma
// sampling factors given (2,2 = 4:2:0, 2,1 = 4:2:2, 1,1 = 4:4:4 or gray), quality 90.
void WriteJpeg(const std::string& path, int w, int h, int components, J_COLOR_SPACE space,
               const std::vector<uint8_t>& samples, int luma_h = 2, int luma_v = 2) {
  ASSERT_EQ(samples.size(), static_cast<size_t>(w) * h * components);
  jpeg_compress_struct cinfo{};
  jpeg_error_mgr jerr{};
  cinfo.err = jpeg_std_error(&jerr);
  jpeg_create_compress(&cinfo);
  FILE* f = std::fopen(path.c_str(), "wb");
  ASSERT_TRUE(f);
  jpeg_stdio_dest(&cinfo, f);
  cinfo.image_width = static_cast<JDIMENSION>(w);
  cinfo.image_height = static_cast<JDIMENSION>(h);
  cinfo.input_components = components;
  cinfo.in_color_space = space;
  jpeg_set_defaults(&cinfo);
  jpeg_set_quality(&cinfo, 90, TRUE);
  cinfo.comp_info[0].h_samp_factor = luma_h;
  cinfo.comp_info[0].v_samp_factor = luma_v;
  jpeg_start_compress(&cinfo, TRUE);
  while (cinfo.next_scanline < cinfo.image_height) {
    JSAMPROW row = const_cast<JSAMPROW>(samples.data()) +
                   static_cast<size_t>(cinfo.next_scanline) * w * components;
    jpeg_write_scanlines(&cinfo, &row, 1);
  }
  jpeg_finish_compress(&cinfo);
  jpeg_destroy_compress(&cinfo);
  std::fclose(f);
}

TEST(ImageCodecs, JpegVariantsDecodeAsOpenCvDid) {
  TempDir dir;
  cv::Mat color(45, 61, CV_8UC3), gray(45, 61, CV_8UC1);
  cv::randu(color, 0, 256);
  cv::GaussianBlur(color, color, cv::Size(5, 5), 1.5);  // some structure besides noise
  cv::randu(gray, 0, 256);
  struct Variant {
    const char* name;
    const cv::Mat* image;
    std::vector<int> params;
  };
  const std::vector<Variant> variants = {
      {"c420", &color, {cv::IMWRITE_JPEG_QUALITY, 90}},
      {"progressive", &color, {cv::IMWRITE_JPEG_PROGRESSIVE, 1}},
      {"restart", &color, {cv::IMWRITE_JPEG_RST_INTERVAL, 3}},
      {"optimized", &color, {cv::IMWRITE_JPEG_OPTIMIZE, 1, cv::IMWRITE_JPEG_QUALITY, 40}},
      {"gray", &gray, {}},
  };
  for (const Variant& v : variants) {
    SCOPED_TRACE(v.name);
    const std::string path = dir.File(std::string(v.name) + ".jpg");
    ASSERT_TRUE(cv::imwrite(path, *v.image, v.params));
    ExpectIdentical(ReadImage(path, Raw()), OpenCvReference(path));
  }
  // Chroma sampling 4:4:4 and 4:2:2 (OpenCV 4.6's imwrite has no option for them).
  cv::Mat rgb;
  cv::cvtColor(color, rgb, cv::COLOR_BGR2RGB);
  const std::vector<uint8_t> samples(rgb.datastart, rgb.dataend);
  for (const auto& [name, luma_h, luma_v] :
       {std::tuple{"c444", 1, 1}, std::tuple{"c422", 2, 1}, std::tuple{"c440", 1, 2}}) {
    SCOPED_TRACE(name);
    const std::string path = dir.File(std::string(name) + ".jpg");
    WriteJpeg(path, rgb.cols, rgb.rows, 3, JCS_RGB, samples, luma_h, luma_v);
    ExpectIdentical(ReadImage(path, Raw()), OpenCvReference(path));
  }
}

// CMYK JPEGs are left to the plugin, which decodes them with OpenCV as before.
TEST(ImageCodecs, CmykJpegGoesThroughThePlugin) {
  TempDir dir;
  const std::string path = dir.File("cmyk.jpg");
  const int w = 24, h = 16;
  WriteJpeg(path, w, h, 4, JCS_CMYK, Pattern(static_cast<size_t>(w) * h * 4), 1, 1);
  ExpectIdentical(ReadImage(path, Raw()), OpenCvReference(path));
}

// EXR files of several layouts written with OpenEXR: each decodes as OpenImageIO decoded it.
TEST(ImageCodecs, ExrVariantsDecodeAsOpenImageIoDid) {
  TempDir dir;
  const int w = 19, h = 11;
  struct Variant {
    const char* name;
    std::vector<std::string> channels;
    Imf::PixelType type;
    bool tiled;
    Imf::Compression compression;
    Imf::LineOrder order;
    int x0, y0;  // data window origin
  };
  const std::vector<Variant> variants = {
      {"rgb_half_zip", {"R", "G", "B"}, Imf::HALF, false, Imf::ZIP_COMPRESSION, Imf::INCREASING_Y, 0, 0},
      {"rgb_float_piz", {"R", "G", "B"}, Imf::FLOAT, false, Imf::PIZ_COMPRESSION, Imf::INCREASING_Y, 0, 0},
      {"rgba_half_tiled", {"R", "G", "B", "A"}, Imf::HALF, true, Imf::ZIPS_COMPRESSION, Imf::INCREASING_Y, 0, 0},
      {"y_float_window", {"Y"}, Imf::FLOAT, false, Imf::NO_COMPRESSION, Imf::DECREASING_Y, 5, -3},
      {"z_float", {"Z"}, Imf::FLOAT, false, Imf::RLE_COMPRESSION, Imf::INCREASING_Y, 0, 0},
      {"depth_half_tiled", {"depth"}, Imf::HALF, true, Imf::PIZ_COMPRESSION, Imf::INCREASING_Y, 0, 0},
      // Left to the plugin (OpenImageIO): two channels, and RGB with an extra channel.
      {"ya_half", {"Y", "A"}, Imf::HALF, false, Imf::ZIP_COMPRESSION, Imf::INCREASING_Y, 0, 0},
      {"rgbz_float", {"R", "G", "B", "Z"}, Imf::FLOAT, false, Imf::ZIP_COMPRESSION, Imf::INCREASING_Y, 0, 0},
  };
  for (const Variant& v : variants) {
    SCOPED_TRACE(v.name);
    const std::string path = dir.File(std::string(v.name) + ".exr");
    const int n = static_cast<int>(v.channels.size());
    // Values with NaN, inf, negatives and a range beyond [0, 1].
    std::vector<float> data(static_cast<size_t>(w) * h * n);
    for (size_t i = 0; i < data.size(); ++i) data[i] = std::sin(0.37f * i) * 3.0f + 0.01f * i;
    data[5] = std::numeric_limits<float>::quiet_NaN();
    data[7] = std::numeric_limits<float>::infinity();
    std::vector<half> halves(data.begin(), data.end());
    Imath::Box2i window({v.x0, v.y0}, {v.x0 + w - 1, v.y0 + h - 1});
    Imf::Header header(window, window);
    header.compression() = v.compression;
    header.lineOrder() = v.order;
    if (v.tiled) header.setTileDescription(Imf::TileDescription(8, 4));
    Imf::FrameBuffer frame;
    const size_t elem = v.type == Imf::HALF ? sizeof(half) : sizeof(float);
    char* base = v.type == Imf::HALF ? reinterpret_cast<char*>(halves.data())
                                     : reinterpret_cast<char*>(data.data());
    for (int c = 0; c < n; ++c) {
      header.channels().insert(v.channels[c], Imf::Channel(v.type));
      frame.insert(v.channels[c], Imf::Slice::Make(v.type, base + elem * c, window, elem * n,
                                                   elem * n * w));
    }
    if (v.tiled) {
      Imf::TiledOutputFile file(path.c_str(), header);
      file.setFrameBuffer(frame);
      file.writeTiles(0, file.numXTiles() - 1, 0, file.numYTiles() - 1);
    } else {
      Imf::OutputFile file(path.c_str(), header);
      file.setFrameBuffer(frame);
      file.writePixels(h);
    }
    ExpectIdentical(ReadImage(path), OiioReference(path));
  }
}

// The real EXR of the test data (DeepSeaRenderer depth, float "Y").
TEST(ImageCodecs, RealExrDecodesAsOpenImageIoDid) {
  TURBID_REQUIRE_DATA(data);
  const std::string path = data + "/deepsea_renderer_synthetic/bomb_0001.exr";
  ExpectIdentical(ReadImage(path), OiioReference(path));
}

// The real PNGs and JPEGs of the test data decode exactly as OpenCV decoded them.
TEST(ImageCodecs, RealPngAndJpegDecodeAsOpenCvDid) {
  TURBID_REQUIRE_DATA(data);
  int checked = 0;
  std::map<std::string, int> per_folder;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(data)) {
    const std::string ext = entry.path().extension().string();
    if (ext != ".png" && ext != ".jpg" && ext != ".jpeg") continue;
    // A bounded sample: two files of every folder.
    if (++per_folder[entry.path().parent_path().string()] > 2) continue;
    SCOPED_TRACE(entry.path().string());
    ExpectIdentical(ReadImage(entry.path().string(), Raw()),
                    OpenCvReference(entry.path().string()));
    ++checked;
  }
  EXPECT_GT(checked, 0);
}

}  // namespace
}  // namespace turbid
