#include "scenes/image_io.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfOutputFile.h>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "core/atomic_file.h"
#include "core/error.h"
#include "scenes/image_codecs.h"
#include "core/input_file.h"
#include "core/limits.h"

namespace turbid {
namespace fs = std::filesystem;

bool ReadImageOptions::Check(std::string* /*why*/) const { return true; }

bool WriteImageOptions::Check(std::string* why) const {
  if (bit_depth != 8 && bit_depth != 16) {
    if (why) *why = "bit_depth must be 8 or 16";
    return false;
  }
  return true;
}

cv::Mat SrgbToLinear(const cv::Mat& srgb) {
  CV_Assert(srgb.depth() == CV_32F);
  cv::Mat out = srgb.clone();
  // forEach<float> on a multi-channel Mat visits only cols elements per row: work on one channel.
  cv::Mat flat = out.reshape(1);
  flat.forEach<float>([](float& v, const int*) {
    v = v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
  });
  return out;
}

cv::Mat LinearToSrgb(const cv::Mat& linear) {
  CV_Assert(linear.depth() == CV_32F);
  cv::Mat out = linear.clone();
  cv::Mat flat = out.reshape(1);
  flat.forEach<float>([](float& v, const int*) {
    v = v <= 0.0031308f ? v * 12.92f : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
  });
  return out;
}

namespace {

std::string ReadAllBytes(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error(path, "file not found");
  if (fs::is_directory(path, ec)) throw Error(path, "is a folder, not an image file");
  return ReadInputFile(path);  // a FIFO or device: "not a regular file", before any read
}

ImageFormat FormatFromMagic(const std::string& head) {
  auto starts = [&](const char* magic, size_t n) {
    return head.size() >= n && std::memcmp(head.data(), magic, n) == 0;
  };
  if (starts("\x89PNG\r\n\x1a\n", 8)) return ImageFormat::kPng;
  if (starts("\xff\xd8\xff", 3)) return ImageFormat::kJpeg;
  if (starts("II*\0", 4) || starts("MM\0*", 4)) return ImageFormat::kTiff;
  if (starts("\x76\x2f\x31\x01", 4)) return ImageFormat::kExr;
  if (starts("PF", 2) || starts("Pf", 2)) return ImageFormat::kPfm;
  if (starts("P5", 2) || starts("P6", 2)) return ImageFormat::kPnm;
  return ImageFormat::kUnknown;
}

// Header tokens of the Netpbm family: whitespace-separated, '#' comments to end of line.
class HeaderReader {
 public:
  HeaderReader(const std::string& path, const std::string& bytes) : path_(path), bytes_(bytes) {}
  std::string Token() {
    while (pos_ < bytes_.size()) {
      if (bytes_[pos_] == '#') {
        while (pos_ < bytes_.size() && bytes_[pos_] != '\n') ++pos_;
      } else if (std::isspace(static_cast<unsigned char>(bytes_[pos_]))) {
        ++pos_;
      } else {
        break;
      }
    }
    const size_t start = pos_;
    while (pos_ < bytes_.size() && !std::isspace(static_cast<unsigned char>(bytes_[pos_]))) ++pos_;
    if (start == pos_) throw Error(path_, "truncated header");
    return bytes_.substr(start, pos_ - start);
  }
  long Integer(const char* what, long lo, long hi) {
    const std::string token = Token();
    char* end = nullptr;
    const long value = std::strtol(token.c_str(), &end, 10);
    if (end == token.c_str() || *end != '\0' || value < lo || value > hi)
      throw Error(path_, std::string("bad ") + what + " '" + token + "' in header");
    return value;
  }
  // Exactly one whitespace byte separates the header from the pixel data.
  size_t DataStart() {
    if (pos_ >= bytes_.size() || !std::isspace(static_cast<unsigned char>(bytes_[pos_])))
      throw Error(path_, "truncated header");
    return pos_ + 1;
  }

 private:
  const std::string& path_;
  const std::string& bytes_;
  size_t pos_ = 0;
};

// Header sides are parsed up to this, then checked against the pixel limit (core/limits.h).
constexpr long kMaxHeaderSide = 2147483647L;

// Portable Float Map: "PF" (RGB) or "Pf" (gray), width height, scale (< 0: little-endian), then
// rows from the bottom of the image to the top.
cv::Mat ReadPfm(const std::string& path, const std::string& bytes) {
  HeaderReader header(path, bytes);
  const std::string magic = header.Token();
  if (magic != "PF" && magic != "Pf") throw Error(path, "not a PFM file (magic '" + magic + "')");
  const int channels = magic == "PF" ? 3 : 1;
  const long width = header.Integer("width", 1, kMaxHeaderSide);
  const long height = header.Integer("height", 1, kMaxHeaderSide);
  CheckImageSize(path, width, height);
  const std::string scale_token = header.Token();
  char* end = nullptr;
  const double scale = std::strtod(scale_token.c_str(), &end);
  if (end == scale_token.c_str() || *end != '\0' || !std::isfinite(scale) || scale == 0.0)
    throw Error(path, "bad scale '" + scale_token + "' in PFM header (must be non-zero)");
  const size_t start = header.DataStart();
  const size_t expected = static_cast<size_t>(width) * height * channels * 4;
  if (bytes.size() - start < expected)
    throw Error(path, "truncated: " + std::to_string(bytes.size() - start) + " bytes of pixel data, " +
                          std::to_string(expected) + " expected for " + std::to_string(width) + "x" +
                          std::to_string(height) + "x" + std::to_string(channels));
  const bool little_endian_file = scale < 0.0;
  const uint16_t probe = 1;
  const bool little_endian_host = *reinterpret_cast<const unsigned char*>(&probe) == 1;
  cv::Mat image(static_cast<int>(height), static_cast<int>(width), CV_32FC(channels));
  const size_t row_bytes = static_cast<size_t>(width) * channels * 4;
  for (long row = 0; row < height; ++row) {
    // File row 0 is the bottom image row.
    unsigned char* dst = image.ptr<unsigned char>(static_cast<int>(height - 1 - row));
    std::memcpy(dst, bytes.data() + start + row * row_bytes, row_bytes);
    if (little_endian_file != little_endian_host) {
      for (size_t i = 0; i < row_bytes; i += 4) {
        std::swap(dst[i], dst[i + 3]);
        std::swap(dst[i + 1], dst[i + 2]);
      }
    }
  }
  if (channels == 3) cv::cvtColor(image, image, cv::COLOR_RGB2BGR);
  return image;
}

// Binary PGM (P5) / PPM (P6), maxval up to 65535 (16-bit samples are big-endian). Returns the
// raw integer values as float32 and the maxval.
cv::Mat ReadPnm(const std::string& path, const std::string& bytes, int* max_value) {
  HeaderReader header(path, bytes);
  const std::string magic = header.Token();
  if (magic != "P5" && magic != "P6") throw Error(path, "unsupported Netpbm type '" + magic + "'");
  const int channels = magic == "P6" ? 3 : 1;
  const long width = header.Integer("width", 1, kMaxHeaderSide);
  const long height = header.Integer("height", 1, kMaxHeaderSide);
  CheckImageSize(path, width, height);
  *max_value = static_cast<int>(header.Integer("maxval", 1, 65535));
  const size_t start = header.DataStart();
  const int sample_bytes = *max_value > 255 ? 2 : 1;
  const size_t expected = static_cast<size_t>(width) * height * channels * sample_bytes;
  if (bytes.size() - start < expected)
    throw Error(path, "truncated: " + std::to_string(bytes.size() - start) + " bytes of pixel data, " +
                          std::to_string(expected) + " expected");
  cv::Mat image(static_cast<int>(height), static_cast<int>(width), CV_32FC(channels));
  const auto* src = reinterpret_cast<const unsigned char*>(bytes.data() + start);
  for (int y = 0; y < image.rows; ++y) {
    float* dst = image.ptr<float>(y);
    for (int i = 0; i < image.cols * channels; ++i, src += sample_bytes) {
      const int value = sample_bytes == 2 ? (src[0] << 8) | src[1] : src[0];
      if (value > *max_value)
        throw Error(path, "sample " + std::to_string(value) + " exceeds maxval " +
                              std::to_string(*max_value));
      dst[i] = static_cast<float>(value);
    }
  }
  if (channels == 3) cv::cvtColor(image, image, cv::COLOR_RGB2BGR);
  return image;
}

// PNG and JPEG decoders tolerate some truncations silently (libjpeg fills the missing part with
// gray), so the end markers are checked first.
void CheckEndMarker(const std::string& path, const std::string& bytes, ImageFormat format) {
  if (format == ImageFormat::kPng) {
    static const char kIend[] = "IEND";
    if (bytes.size() < 12 || bytes.compare(bytes.size() - 8, 4, kIend) != 0)
      throw Error(path, "truncated PNG (no IEND chunk at the end)");
  } else if (format == ImageFormat::kJpeg) {
    // EOI marker FF D9, possibly followed by padding.
    const size_t tail = std::min<size_t>(bytes.size(), 4096);
    if (bytes.substr(bytes.size() - tail).find("\xff\xd9") == std::string::npos)
      throw Error(path, "truncated JPEG (no end-of-image marker)");
  }
}

std::string EncodePfm(const cv::Mat& data) {
  cv::Mat rgb = data;
  if (data.channels() == 3) cv::cvtColor(data, rgb, cv::COLOR_BGR2RGB);
  std::string bytes = std::string(rgb.channels() == 3 ? "PF" : "Pf") + "\n" +
                      std::to_string(rgb.cols) + " " + std::to_string(rgb.rows) + "\n-1.0\n";
  const uint16_t probe = 1;
  const bool little_endian_host = *reinterpret_cast<const unsigned char*>(&probe) == 1;
  const size_t row_bytes = static_cast<size_t>(rgb.cols) * rgb.channels() * 4;
  bytes.reserve(bytes.size() + row_bytes * static_cast<size_t>(rgb.rows));
  std::vector<unsigned char> row(row_bytes);
  for (int y = rgb.rows - 1; y >= 0; --y) {
    std::memcpy(row.data(), rgb.ptr(y), row.size());
    if (!little_endian_host) {
      for (size_t i = 0; i < row.size(); i += 4) {
        std::swap(row[i], row[i + 3]);
        std::swap(row[i + 1], row[i + 2]);
      }
    }
    bytes.append(reinterpret_cast<const char*>(row.data()), row.size());
  }
  return bytes;
}

// An OpenEXR output stream into memory (OpenEXR seeks back to fill in the line offset table).
class MemoryOStream : public Imf::OStream {
 public:
  explicit MemoryOStream(const std::string& name) : Imf::OStream(name.c_str()) {}
  void write(const char c[], int n) override {
    const size_t end = pos_ + static_cast<size_t>(n);
    if (bytes_.size() < end) bytes_.resize(end);
    std::memcpy(bytes_.data() + pos_, c, static_cast<size_t>(n));
    pos_ = end;
  }
  uint64_t tellp() override { return pos_; }
  void seekp(uint64_t pos) override { pos_ = static_cast<size_t>(pos); }
  std::string& bytes() { return bytes_; }

 private:
  std::string bytes_;
  size_t pos_ = 0;
};

// Encoded with OpenEXR directly: OIIO's writer stamps a capture date into every file, and a
// rerun must reproduce the same bytes. Float channels R,G,B (or Y), ZIP compression.
std::string EncodeExr(const std::string& path, const cv::Mat& data) {
  cv::Mat planar = data.isContinuous() ? data : data.clone();
  const int width = planar.cols;
  const int height = planar.rows;
  const int channels = planar.channels();
  try {
    Imf::Header header(width, height);
    header.compression() = Imf::ZIP_COMPRESSION;
    Imf::FrameBuffer frame;
    const size_t pixel_stride = sizeof(float) * static_cast<size_t>(channels);
    const size_t row_stride = planar.step[0];
    char* base = reinterpret_cast<char*>(planar.data);
    if (channels == 3) {
      // OpenCV keeps BGR in memory; name each interleaved slot by its colour.
      const char* names[3] = {"B", "G", "R"};
      for (int c = 0; c < 3; ++c) {
        header.channels().insert(names[c], Imf::Channel(Imf::FLOAT));
        frame.insert(names[c], Imf::Slice(Imf::FLOAT, base + sizeof(float) * static_cast<size_t>(c),
                                          pixel_stride, row_stride));
      }
    } else {
      header.channels().insert("Y", Imf::Channel(Imf::FLOAT));
      frame.insert("Y", Imf::Slice(Imf::FLOAT, base, pixel_stride, row_stride));
    }
    MemoryOStream stream(path);
    {
      // The file is complete (offset table written) when OutputFile is destroyed.
      Imf::OutputFile file(stream, header);
      file.setFrameBuffer(frame);
      file.writePixels(height);
    }
    return std::move(stream.bytes());
  } catch (const std::exception& e) {
    throw Error(path, std::string("EXR write failed: ") + e.what());
  }
}

}  // namespace

ImageFormat DetectImageFormat(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error(path, "file not found");
  CheckInputFile(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, "cannot open for reading");
  std::string head(8, '\0');
  in.read(head.data(), 8);
  head.resize(static_cast<size_t>(in.gcount()));
  return FormatFromMagic(head);
}

cv::Mat ReadImage(const std::string& path, const ReadImageOptions& options) {
  ThrowIfInvalid(options, path);
  const std::string bytes = ReadAllBytes(path);
  if (bytes.empty()) throw Error(path, "empty file");
  const ImageFormat format = FormatFromMagic(bytes.substr(0, 8));
  cv::Mat image;
  int max_value = 0;  // integer formats: the value that maps to 1.0; 0 for float formats
  switch (format) {
    case ImageFormat::kPng:
      CheckEndMarker(path, bytes, format);
      image = codecs::DecodePng(path, bytes, &max_value);
      break;
    case ImageFormat::kJpeg:
      CheckEndMarker(path, bytes, format);
      image = codecs::DecodeJpeg(path, bytes, &max_value);
      if (image.empty()) image = codecs::DecodeWithPlugin(path, bytes, &max_value);
      break;
    case ImageFormat::kExr:
      image = codecs::DecodeExr(path, bytes, &max_value);
      if (image.empty()) image = codecs::DecodeWithPlugin(path, bytes, &max_value);
      break;
    case ImageFormat::kTiff:
      image = codecs::DecodeWithPlugin(path, bytes, &max_value);
      break;
    case ImageFormat::kPfm:
      image = ReadPfm(path, bytes);
      break;
    case ImageFormat::kPnm:
      image = ReadPnm(path, bytes, &max_value);
      break;
    case ImageFormat::kUnknown:
      throw Error(path, "unrecognised image format (expected PNG, JPEG, TIFF, EXR, PFM or PGM/PPM)");
  }
  if (max_value > 0 && !options.keep_raw) {
    image *= 1.0 / max_value;
    if (options.transfer == Transfer::kSrgb) image = SrgbToLinear(image);
  }
  return image;
}

void WriteImage(const std::string& path, const cv::Mat& image, const WriteImageOptions& options) {
  ThrowIfInvalid(options, path);
  if (image.empty()) throw Error(path, "refusing to write an empty image");
  if (image.channels() != 1 && image.channels() != 3)
    throw Error(path, "can only write 1 or 3 channels, not " + std::to_string(image.channels()));
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  cv::Mat data;
  image.convertTo(data, CV_32F);
  if (ext == ".exr" || ext == ".pfm") {
    // Encoded in memory, then written with checked writes into a temporary file that is renamed
    // into place: a full disk or a file-size limit is one clear error and no partial file.
    AtomicWriteText(path, ext == ".exr" ? EncodeExr(path, data) : EncodePfm(data),
                    options.overwrite);
    return;
  }
  if (ext != ".png") throw Error(path, "unsupported output format (use .png, .exr or .pfm)");
  const double max_value = options.bit_depth == 16 ? 65535.0 : 255.0;
  cv::Mat scaled;
  if (options.raw) {
    scaled = data;
  } else {
    if (options.transfer == Transfer::kSrgb) data = LinearToSrgb(data);
    scaled = data * max_value;
  }
  cv::patchNaNs(scaled, 0.0);
  cv::Mat clipped = cv::min(cv::max(scaled, 0.0), max_value);
  cv::Mat encoded;
  clipped.convertTo(encoded, options.bit_depth == 16 ? CV_16U : CV_8U);  // rounds to nearest
  AtomicWriteText(path, codecs::EncodePng(path, encoded), options.overwrite);
}

}  // namespace turbid
