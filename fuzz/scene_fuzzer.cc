// Scene files and the files they name. The input is the scene JSON, optionally followed by a NUL
// byte, one byte that picks an extension and the bytes of a file "blob.<ext>" the JSON may name.
// Beside it lie small valid files the seeds point at: image.png (8-bit colour), depth16.png (16-bit
// depth codes), depth.pfm, depth.exr, depth.npy, and an RGB-D folder dataset "set" (two frames).
// ParseSceneFile, ExpandSceneSpec and LoadScene of every frame spec (at most four).
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <string_view>

#include "fuzz/fuzz_support.h"
#include "scenes/image_io.h"
#include "scenes/scene_loader.h"

namespace {
namespace fs = std::filesystem;
using namespace turbid;

void WriteFixtures() {
  const int w = 8, h = 6;
  cv::Mat rgb(h, w, CV_32FC3), depth(h, w, CV_32FC1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      rgb.at<cv::Vec3f>(y, x) = cv::Vec3f(x / 8.f, y / 6.f, 0.5f);
      depth.at<float>(y, x) = 1.0f + 0.1f * static_cast<float>(x + y);
    }
  WriteImageOptions png;
  png.overwrite = true;
  WriteImage(fuzz::ScratchPath("image.png"), rgb, png);
  WriteImageOptions raw16 = png;
  raw16.bit_depth = 16;
  raw16.raw = true;
  WriteImage(fuzz::ScratchPath("depth16.png"), depth * 5000.0, raw16);
  WriteImage(fuzz::ScratchPath("depth.pfm"), depth, png);
  WriteImage(fuzz::ScratchPath("depth.exr"), depth, png);
  // .npy version 1.0, '<f4', C order, (6, 8): header padded so that the data starts at byte 128.
  std::string header = "{'descr': '<f4', 'fortran_order': False, 'shape': (6, 8), }";
  header.append(128 - 10 - header.size() - 1, ' ');
  header += '\n';
  std::string npy = std::string("\x93NUMPY\x01\x00", 8);
  npy += static_cast<char>(header.size() & 0xff);
  npy += static_cast<char>(header.size() >> 8);
  npy += header;
  npy.append(reinterpret_cast<const char*>(depth.ptr<float>()), depth.total() * sizeof(float));
  fuzz::WriteFile(fuzz::ScratchPath("depth.npy"), npy);
  for (const char* sub : {"set/rgb", "set/depth"}) fs::create_directories(fuzz::ScratchPath(sub));
  for (const char* stem : {"f1", "f2"}) {
    WriteImage(fuzz::ScratchPath(std::string("set/rgb/") + stem + ".png"), rgb, png);
    WriteImage(fuzz::ScratchPath(std::string("set/depth/") + stem + ".pfm"), depth, png);
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  WriteFixtures();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  const auto [json_text, rest] = fuzz::SplitAt(input, std::string_view("\0", 1));
  if (!rest.empty()) {
    static const char* const kExtensions[] = {".png", ".jpg", ".tif", ".exr",
                                              ".pfm", ".pgm", ".npy", ".mat"};
    fuzz::WriteFile(fuzz::ScratchPath(std::string("blob") +
                                    kExtensions[static_cast<unsigned char>(rest[0]) % 8]),
                    rest.substr(1));
  }
  const std::string path = fuzz::ScratchPath("scene.json");
  fuzz::WriteFile(path, json_text);
  fuzz::ExpectOnlyErrors([&] { ParseSceneFile(path); });
  fuzz::ExpectOnlyErrors([&] {
    int loaded = 0;
    for (const std::string& spec : ExpandSceneSpec(path)) {
      if (++loaded > 4) break;
      fuzz::ExpectOnlyErrors([&] { LoadScene(spec); });
    }
  });
  return 0;
}
