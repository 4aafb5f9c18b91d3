// NYU Depth v2 labelled .mat files (HDF5), read through the plugin turbid_hdf5.so as a nyu_v2
// scene does: NyuFrameCount (layout checks), then the first and last frame, with and without the
// border crop and from both depth datasets. libhdf5 itself is not instrumented: a crash inside it
// shows as a plain SEGV whose stack names libhdf5.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "fuzz/fuzz_support.h"
#include "scenes/nyu_depth_v2.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace turbid;
  const std::string path = fuzz::ScratchPath("nyu.mat");
  fuzz::WriteFile(path, std::string_view(reinterpret_cast<const char*>(data), size));
  for (const char* dataset : {"depths", "rawDepths"}) {
    NyuFrameOptions options;
    options.depth_dataset = dataset;
    fuzz::ExpectOnlyErrors([&] {
      const int count = NyuFrameCount(path, options);
      ReadNyuFrame(path, 0, options);
      options.crop_border = true;
      ReadNyuFrame(path, count - 1, options);
    });
  }
  return 0;
}
