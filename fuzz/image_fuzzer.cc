// Image decoding as a scene file's image/depth path reaches it: the first byte picks the file
// name's extension, the rest is the file. ReadRawDepthFile (our .npy reader, else ReadImage with
// keep_raw) and ReadImage with the sRGB decode, the two ways the adapters read a file. Formats are
// told apart by their first bytes (PNG, JPEG, EXR, PFM, PGM/PPM; TIFF through the OpenImageIO
// plugin), .npy by the extension.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "fuzz/fuzz_support.h"
#include "scenes/folder_dataset.h"
#include "scenes/image_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace turbid;
  if (size < 1) return 0;
  static const char* const kExtensions[] = {".png", ".jpg", ".tif", ".exr", ".pfm", ".pgm", ".npy"};
  const std::string path = fuzz::ScratchPath(std::string("image") + kExtensions[data[0] % 7]);
  fuzz::WriteFile(path, std::string_view(reinterpret_cast<const char*>(data) + 1, size - 1));
  fuzz::ExpectOnlyErrors([&] { ReadRawDepthFile(path); });
  fuzz::ExpectOnlyErrors([&] {
    ReadImageOptions options;
    options.transfer = Transfer::kSrgb;
    ReadImage(path, options);
  });
  return 0;
}
