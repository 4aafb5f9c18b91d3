// turbid_oiio.so: the readers that need OpenImageIO or OpenCV's imgcodecs, in a shared library
// that scenes/image_codecs.cc opens only when a file needs it (TIFF, and the EXR and JPEG variants
// the light decoders leave out), so that no other run pays for loading OpenImageIO's ~260
// libraries. This is the code every read went through before the light decoders existed.
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cstring>
#include <exception>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "core/limits.h"
#include "scenes/plugin/image_plugin.h"

namespace {

std::string OneLine(std::string text) {
  std::replace(text.begin(), text.end(), '\n', ' ');
  return text;
}

// EXR and TIFF through OpenImageIO: it reports truncated and corrupt files as errors. Integer
// TIFFs come back with their raw values and the type's maximum in *max_value (0 for floats).
// Returns an empty Mat for LogLuv TIFFs (see below).
cv::Mat ReadWithOiio(const std::string& path, int* max_value) {
  auto input = OIIO::ImageInput::open(path);
  if (!input) {
    std::string why = OIIO::geterror();
    if (why.empty()) why = "cannot decode";
    throw std::runtime_error(OneLine(why));
  }
  const OIIO::ImageSpec spec = input->spec();
  // The pixel limit (core/limits.h) before anything is allocated, for every path below.
  const std::string size_problem = turbid::ImageSizeProblem(spec.width, spec.height);
  if (!size_problem.empty()) throw std::runtime_error(size_problem);
  // OpenImageIO hands SGI LogLuv TIFFs (what OpenCV writes for float data) over as 8-bit
  // tone-mapped RGB; return nothing so that the caller decodes them with OpenCV instead.
  const int photometric = spec.get_int_attribute("tiff:PhotometricInterpretation", 0);
  if (photometric == 32844 || photometric == 32845) return cv::Mat();
  if (spec.depth > 1) throw std::runtime_error("volume images are not supported");
  const int file_channels = spec.nchannels;
  if (file_channels < 1 || file_channels > 4)
    throw std::runtime_error("unsupported channel count " + std::to_string(file_channels));
  // 2 channels: gray + alpha; 4: RGB + alpha. Alpha is dropped.
  const int channels = file_channels >= 3 ? 3 : 1;
  OIIO::TypeDesc read_type = OIIO::TypeDesc::FLOAT;
  int cv_depth = CV_32F;
  *max_value = 0;
  if (spec.format == OIIO::TypeDesc::UINT8) {
    read_type = OIIO::TypeDesc::UINT8;
    cv_depth = CV_8U;
    *max_value = 255;
  } else if (spec.format == OIIO::TypeDesc::UINT16) {
    read_type = OIIO::TypeDesc::UINT16;
    cv_depth = CV_16U;
    *max_value = 65535;
  }
  cv::Mat raw(spec.height, spec.width, CV_MAKETYPE(cv_depth, channels));
  if (!input->read_image(0, 0, 0, channels, read_type, raw.data)) {
    std::string why = input->geterror();
    if (why.empty()) why = "cannot read pixel data (corrupt or truncated)";
    throw std::runtime_error(OneLine(why));
  }
  input->close();
  cv::Mat out;
  raw.convertTo(out, CV_32F);
  if (channels == 3) cv::cvtColor(out, out, cv::COLOR_RGB2BGR);
  return out;
}

// OpenCV's decoders (cv::imdecode, IMREAD_UNCHANGED): LogLuv TIFFs, CMYK and Motion-JPEG files.
cv::Mat ReadWithOpenCv(const std::string& bytes, int* max_value) {
  const std::vector<uchar> buffer(bytes.begin(), bytes.end());
  cv::Mat raw;
  try {
    raw = cv::imdecode(buffer, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    throw std::runtime_error(std::string("cannot decode: ") + e.err);
  }
  if (raw.empty()) throw std::runtime_error("cannot decode image (corrupt file)");
  if (raw.channels() == 4) cv::cvtColor(raw, raw, cv::COLOR_BGRA2BGR);
  if (raw.channels() == 2) cv::extractChannel(raw, raw, 0);
  if (raw.channels() != 1 && raw.channels() != 3)
    throw std::runtime_error("unsupported channel count " + std::to_string(raw.channels()));
  switch (raw.depth()) {
    case CV_8U: *max_value = 255; break;
    case CV_16U: *max_value = 65535; break;
    case CV_32F: *max_value = 0; break;
    default: throw std::runtime_error("unsupported sample type");
  }
  cv::Mat out;
  raw.convertTo(out, CV_32F);
  return out;
}

bool StartsWith(const std::string& bytes, const char* magic, size_t n) {
  return bytes.size() >= n && std::memcmp(bytes.data(), magic, n) == 0;
}

}  // namespace

extern "C" __attribute__((visibility("default"))) int turbid_plugin_decode_v1(
    const char* path, const std::string* bytes, cv::Mat* image, int* max_value,
    std::string* error) {
  try {
    const bool oiio_format = StartsWith(*bytes, "II*\0", 4) || StartsWith(*bytes, "MM\0*", 4) ||
                             StartsWith(*bytes, "\x76\x2f\x31\x01", 4);
    cv::Mat out;
    if (oiio_format) out = ReadWithOiio(path, max_value);
    if (out.empty()) out = ReadWithOpenCv(*bytes, max_value);
    *image = out;
    return 0;
  } catch (const std::exception& e) {
    *error = OneLine(e.what());
  } catch (...) {
    *error = "unknown error in the OpenImageIO plugin";
  }
  return 1;
}

static_assert(std::is_same_v<decltype(turbid_plugin_decode_v1), TurbidPluginDecodeFn>);
