#include "scenes/image_codecs.h"

// clang-format off: jpeglib.h needs <cstdio> (FILE) first.
#include <cstdio>
#include <jpeglib.h>
// clang-format on
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfVersion.h>
#include <png.h>
#include <zlib.h>

#include <algorithm>
#include <csetjmp>
#include <cstring>
#include <opencv2/imgproc.hpp>
#include <set>
#include <vector>

#include "core/error.h"
#include "core/limits.h"
#include "scenes/plugin/image_plugin.h"
#include "scenes/plugin_loader.h"

namespace turbid::codecs {

namespace {

cv::Mat ToFloat(const cv::Mat& raw) {
  cv::Mat out;
  raw.convertTo(out, CV_32F);
  return out;
}

// ---------------------------------------------------------------------------------------------
// PNG. libpng reports errors by longjmp: the functions that call it keep only trivial locals, and
// every C++ object they fill is created by their caller.

struct PngIo {
  const unsigned char* data = nullptr;
  size_t size = 0;
  size_t pos = 0;
  char message[256] = {0};
};

void PngError(png_structp png, png_const_charp message) {
  auto* io = static_cast<PngIo*>(png_get_error_ptr(png));
  std::snprintf(io->message, sizeof io->message, "%s", message);
  png_longjmp(png, 1);
}

void PngWarning(png_structp, png_const_charp) {}

void PngRead(png_structp png, png_bytep out, size_t n) {
  auto* io = static_cast<PngIo*>(png_get_io_ptr(png));
  if (io->pos + n > io->size) png_error(png, "PNG input buffer is incomplete");
  std::memcpy(out, io->data + io->pos, n);
  io->pos += n;
}

struct PngHeader {
  png_uint_32 width = 0, height = 0;
  int bit_depth = 0, color_type = 0;
  int channels = 0;  // what cv::imdecode(IMREAD_UNCHANGED) made of it: 1, 3 or 4
};

bool PngReadHeader(png_structp png, png_infop info, PngHeader* header) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_read_info(png, info);
  png_get_IHDR(png, info, &header->width, &header->height, &header->bit_depth, &header->color_type,
               nullptr, nullptr, nullptr);
  // OpenCV's PngDecoder::readHeader: RGB and palette images with a tRNS chunk and every image
  // with an alpha channel become 4 channels, gray (with or without tRNS) 1, the rest 3.
  switch (header->color_type) {
    case PNG_COLOR_TYPE_RGB:
    case PNG_COLOR_TYPE_PALETTE: {
      png_bytep trans = nullptr;
      int num_trans = 0;
      png_color_16p trans_values = nullptr;
      png_get_tRNS(png, info, &trans, &num_trans, &trans_values);
      header->channels = num_trans > 0 ? 4 : 3;
      break;
    }
    case PNG_COLOR_TYPE_GRAY_ALPHA:
    case PNG_COLOR_TYPE_RGB_ALPHA:
      header->channels = 4;
      break;
    default:
      header->channels = 1;
  }
  return true;
}

// The transformations of OpenCV's PngDecoder::readData for an image of header->channels channels
// at its own bit depth, in the same order.
bool PngReadPixels(png_structp png, png_infop info, png_infop end_info, const PngHeader& header,
                   png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  const uint16_t probe = 1;
  if (*reinterpret_cast<const unsigned char*>(&probe) == 1) png_set_swap(png);
  if (header.channels < 4) {
    png_set_strip_alpha(png);
  } else {
    png_set_tRNS_to_alpha(png);
  }
  if (header.color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if ((header.color_type & PNG_COLOR_MASK_COLOR) == 0 && header.bit_depth < 8)
    png_set_expand_gray_1_2_4_to_8(png);
  const bool color = header.channels > 1;
  if ((header.color_type & PNG_COLOR_MASK_COLOR) && color) {
    png_set_bgr(png);
  } else if (color) {
    png_set_gray_to_rgb(png);
  } else {
    png_set_rgb_to_gray(png, 1, 0.299, 0.587);
  }
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  png_read_image(png, rows);
  png_read_end(png, end_info);
  return true;
}

// ---------------------------------------------------------------------------------------------
// JPEG, the same way: errors longjmp out of the functions that call libjpeg.

struct JpegError {
  jpeg_error_mgr manager;
  jmp_buf jump;
  char message[JMSG_LENGTH_MAX] = {0};
};

void JpegErrorExit(j_common_ptr cinfo) {
  auto* error = reinterpret_cast<JpegError*>(cinfo->err);
  cinfo->err->format_message(cinfo, error->message);
  longjmp(error->jump, 1);
}

void JpegSilent(j_common_ptr) {}

// Returns 1 (read), 0 (error) or 2 (a variant left to the plugin: CMYK/YCCK, or Motion-JPEG
// frames without Huffman tables, which OpenCV completes with its own tables).
int JpegReadHeader(jpeg_decompress_struct* cinfo, JpegError* error, const std::string* bytes) {
  if (setjmp(error->jump)) return 0;
  jpeg_mem_src(cinfo, reinterpret_cast<const unsigned char*>(bytes->data()),
               static_cast<unsigned long>(bytes->size()));
  jpeg_read_header(cinfo, TRUE);
  if (cinfo->num_components == 4) return 2;
  if (cinfo->ac_huff_tbl_ptrs[0] == nullptr && cinfo->ac_huff_tbl_ptrs[1] == nullptr &&
      cinfo->dc_huff_tbl_ptrs[0] == nullptr && cinfo->dc_huff_tbl_ptrs[1] == nullptr)
    return 2;
  return 1;
}

// As OpenCV's JpegDecoder::readData: colour files decode to BGR, the others to gray, with the
// library's default DCT and upsampling.
bool JpegReadPixels(jpeg_decompress_struct* cinfo, JpegError* error, unsigned char* data,
                    size_t step, int channels) {
  if (setjmp(error->jump)) return false;
  cinfo->out_color_space = channels == 3 ? JCS_EXT_BGR : JCS_GRAYSCALE;
  cinfo->out_color_components = channels;
  jpeg_start_decompress(cinfo);
  while (cinfo->output_scanline < cinfo->output_height) {
    JSAMPROW row = data + step * cinfo->output_scanline;
    jpeg_read_scanlines(cinfo, &row, 1);
  }
  jpeg_finish_decompress(cinfo);
  return true;
}

// ---------------------------------------------------------------------------------------------
// EXR from the bytes already read.

class MemoryStream : public Imf::IStream {
 public:
  MemoryStream(const std::string& path, const std::string& bytes)
      : Imf::IStream(path.c_str()), bytes_(bytes) {}
  bool read(char c[], int n) override {
    if (n < 0 || pos_ + static_cast<uint64_t>(n) > bytes_.size())
      throw std::runtime_error("unexpected end of file (truncated)");
    std::memcpy(c, bytes_.data() + pos_, static_cast<size_t>(n));
    pos_ += static_cast<uint64_t>(n);
    return pos_ < bytes_.size();
  }
  uint64_t tellg() override { return pos_; }
  void seekg(uint64_t pos) override { pos_ = pos; }

 private:
  const std::string& bytes_;
  uint64_t pos_ = 0;
};

}  // namespace

cv::Mat DecodePng(const std::string& path, const std::string& bytes, int* max_value) {
  PngIo io;
  io.data = reinterpret_cast<const unsigned char*>(bytes.data());
  io.size = bytes.size();
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &io, PngError, PngWarning);
  if (!png) throw Error(path, "out of memory");
  png_infop info = png_create_info_struct(png);
  png_infop end_info = png_create_info_struct(png);
  struct Cleanup {
    png_structp* png;
    png_infop* info;
    png_infop* end;
    ~Cleanup() { png_destroy_read_struct(png, info, end); }
  } cleanup{&png, &info, &end_info};
  if (!info || !end_info) throw Error(path, "out of memory");
  png_set_read_fn(png, &io, PngRead);
  PngHeader header;
  if (!PngReadHeader(png, info, &header))
    throw Error(path, std::string("cannot decode PNG: ") + io.message);
  CheckImageSize(path, header.width, header.height);
  const int depth = header.bit_depth == 16 ? CV_16U : CV_8U;
  cv::Mat raw(static_cast<int>(header.height), static_cast<int>(header.width),
              CV_MAKETYPE(depth, header.channels));
  std::vector<png_bytep> rows(header.height);
  for (int y = 0; y < raw.rows; ++y) rows[static_cast<size_t>(y)] = raw.ptr(y);
  if (!PngReadPixels(png, info, end_info, header, rows.data()))
    throw Error(path, std::string("cannot decode PNG: ") + io.message);
  if (raw.channels() == 4) cv::cvtColor(raw, raw, cv::COLOR_BGRA2BGR);
  *max_value = depth == CV_16U ? 65535 : 255;
  return ToFloat(raw);
}

cv::Mat DecodeJpeg(const std::string& path, const std::string& bytes, int* max_value) {
  jpeg_decompress_struct cinfo{};
  JpegError error;
  cinfo.err = jpeg_std_error(&error.manager);
  error.manager.error_exit = JpegErrorExit;
  error.manager.output_message = JpegSilent;  // corrupt-data warnings: decoded as OpenCV did
  jpeg_create_decompress(&cinfo);
  struct Cleanup {
    jpeg_decompress_struct* cinfo;
    ~Cleanup() { jpeg_destroy_decompress(cinfo); }
  } cleanup{&cinfo};
  const int header = JpegReadHeader(&cinfo, &error, &bytes);
  if (header == 0) throw Error(path, std::string("cannot decode JPEG: ") + error.message);
  // The pixel limit (core/limits.h) from the header, for the plugin's variants too.
  CheckImageSize(path, cinfo.image_width, cinfo.image_height);
  if (header == 2) return cv::Mat();
  const int channels = cinfo.num_components > 1 ? 3 : 1;
  cv::Mat raw(static_cast<int>(cinfo.image_height), static_cast<int>(cinfo.image_width),
              CV_8UC(channels));
  if (!JpegReadPixels(&cinfo, &error, raw.data, raw.step[0], channels))
    throw Error(path, std::string("cannot decode JPEG: ") + error.message);
  *max_value = 255;
  return ToFloat(raw);
}

cv::Mat DecodeExr(const std::string& path, const std::string& bytes, int* max_value) {
  *max_value = 0;
  try {
    MemoryStream stream(path, bytes);
    Imf::InputFile file(stream);
    // Multi-part and deep files are the plugin's (OpenImageIO reads their first part).
    if (Imf::isMultiPart(file.version()) || Imf::isNonImage(file.version())) return cv::Mat();
    const Imf::Header& header = file.header();
    std::set<std::string> names;
    for (auto it = header.channels().begin(); it != header.channels().end(); ++it) {
      const Imf::Channel& channel = it.channel();
      if (channel.type == Imf::UINT || channel.xSampling != 1 || channel.ySampling != 1)
        return cv::Mat();
      names.insert(it.name());
    }
    // One channel of any name is gray; R, G, B (and A, dropped) colour. Other sets are the
    // plugin's, which orders channels as OpenImageIO does.
    int channels = 0;
    if (names.size() == 1) {
      channels = 1;
    } else if (names == std::set<std::string>{"B", "G", "R"} ||
               names == std::set<std::string>{"A", "B", "G", "R"}) {
      channels = 3;
    } else {
      return cv::Mat();
    }
    const Imath::Box2i window = header.dataWindow();
    const long width = static_cast<long>(window.max.x) - window.min.x + 1;
    const long height = static_cast<long>(window.max.y) - window.min.y + 1;
    CheckImageSize(path, width, height);
    cv::Mat image(static_cast<int>(height), static_cast<int>(width), CV_32FC(channels));
    const size_t pixel_stride = sizeof(float) * static_cast<size_t>(channels);
    Imf::FrameBuffer frame;
    auto slot = [&](const std::string& name, int index) {
      frame.insert(name, Imf::Slice::Make(Imf::FLOAT,
                                          image.data + sizeof(float) * static_cast<size_t>(index),
                                          window, pixel_stride, image.step[0]));
    };
    if (channels == 1) {
      slot(*names.begin(), 0);
    } else {
      slot("B", 0);
      slot("G", 1);
      slot("R", 2);
    }
    file.setFrameBuffer(frame);
    file.readPixels(window.min.y, window.max.y);
    return image;
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    std::string why = e.what();
    std::replace(why.begin(), why.end(), '\n', ' ');
    throw Error(path, "cannot decode EXR: " + why);
  }
}

cv::Mat DecodeWithPlugin(const std::string& path, const std::string& bytes, int* max_value) {
  std::string why;
  auto* decode = reinterpret_cast<TurbidPluginDecodeFn*>(plugins::LoadPluginSymbol(
      kTurbidPluginFileName, kTurbidPluginDecodeSymbol, "OpenImageIO", &why));
  if (!decode) throw Error(path, "reading this file needs OpenImageIO, but " + why);
  cv::Mat image;
  std::string error;
  if (decode(path.c_str(), &bytes, &image, max_value, &error) != 0) throw Error(path, error);
  return image;
}

namespace {

void PngWriteToString(png_structp png, png_bytep data, size_t n) {
  auto* out = static_cast<std::string*>(png_get_io_ptr(png));
  out->append(reinterpret_cast<const char*>(data), n);
}

void PngFlushNothing(png_structp) {}

}  // namespace

std::string EncodePng(const std::string& path, const cv::Mat& encoded) {
  CV_Assert((encoded.depth() == CV_8U || encoded.depth() == CV_16U) &&
            (encoded.channels() == 1 || encoded.channels() == 3));
  PngIo io;  // only its message is used
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &io, PngError, PngWarning);
  if (!png) throw Error(path, "out of memory");
  png_infop info = png_create_info_struct(png);
  struct Cleanup {
    png_structp* png;
    png_infop* info;
    ~Cleanup() { png_destroy_write_struct(png, info); }
  } cleanup{&png, &info};
  if (!info) throw Error(path, "out of memory");
  std::string bytes;
  std::vector<png_bytep> rows(static_cast<size_t>(encoded.rows));
  for (int y = 0; y < encoded.rows; ++y)
    rows[static_cast<size_t>(y)] = const_cast<png_bytep>(encoded.ptr(y));
  struct Args {
    png_structp png;
    png_infop info;
    std::string* bytes;
    png_uint_32 width, height;
    int bit_depth, color_type;
    png_bytepp rows;
  } args{png,
         info,
         &bytes,
         static_cast<png_uint_32>(encoded.cols),
         static_cast<png_uint_32>(encoded.rows),
         encoded.depth() == CV_8U ? 8 : 16,
         encoded.channels() == 1 ? PNG_COLOR_TYPE_GRAY : PNG_COLOR_TYPE_RGB,
         rows.data()};
  // OpenCV's PngEncoder::write without parameters, call for call.
  const bool ok = [](const Args& a) {
    if (setjmp(png_jmpbuf(a.png))) return false;
    png_set_write_fn(a.png, a.bytes, PngWriteToString, PngFlushNothing);
    png_set_filter(a.png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
    png_set_compression_level(a.png, Z_BEST_SPEED);
    png_set_compression_strategy(a.png, Z_RLE);
    png_set_IHDR(a.png, a.info, a.width, a.height, a.bit_depth, a.color_type, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(a.png, a.info);
    png_set_bgr(a.png);
    const uint16_t probe = 1;
    if (*reinterpret_cast<const unsigned char*>(&probe) == 1) png_set_swap(a.png);
    png_write_image(a.png, a.rows);
    png_write_end(a.png, a.info);
    return true;
  }(args);
  if (!ok) throw Error(path, std::string("PNG encoder failed: ") + io.message);
  return bytes;
}

}  // namespace turbid::codecs
