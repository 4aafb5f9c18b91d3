// Images for metrics (tools/harness/metric_image.h), moved out of tools/cli/cmd_score.cc unchanged.
#include "tools/harness/metric_image.h"

#include <fstream>

#include "scenes/image_io.h"
#include "core/input_file.h"
#include "tools/harness/file_context.h"

namespace turbid {

int IntegerBitDepth(const std::string& path) {
  CheckInputFile(path);
  std::ifstream in(path, std::ios::binary);
  unsigned char header[26] = {};
  in.read(reinterpret_cast<char*>(header), sizeof(header));
  const std::streamsize got = in.gcount();
  if (got >= 26 && header[0] == 0x89 && header[1] == 'P' && header[2] == 'N' && header[3] == 'G')
    return header[24] == 16 ? 16 : 8;  // 1/2/4-bit PNGs are expanded to 8 bits on read
  if (got >= 2 && header[0] == 0xFF && header[1] == 0xD8) return 8;
  return 0;
}

MetricImage LoadMetricImage(const std::string& path) {
  MetricImage out;
  const int bits = IntegerBitDepth(path);
  ReadImageOptions options;
  options.keep_raw = bits != 0;
  out.pixels = WithFileContext(path, "reading it", [&] { return ReadImage(path, options); });
  out.data_range = bits == 16 ? 65535.0 : (bits == 8 ? 255.0 : 1.0);
  return out;
}

double CommonScale(std::vector<MetricImage*> images) {
  double range = 0.0;
  bool mixed = false;
  for (const MetricImage* m : images) {
    if (m == nullptr || m->pixels.empty()) continue;
    if (range == 0.0) range = m->data_range;
    mixed |= m->data_range != range;
  }
  if (!mixed) return range == 0.0 ? 1.0 : range;
  for (MetricImage* m : images) {
    if (m == nullptr || m->pixels.empty() || m->data_range == 1.0) continue;
    cv::Mat scaled;  // new buffer: callers share pixels between rows
    m->pixels.convertTo(scaled, CV_32F, 1.0 / m->data_range);
    m->pixels = scaled;
    m->data_range = 1.0;
  }
  return 1.0;
}

}  // namespace turbid
