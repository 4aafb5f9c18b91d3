// NYU Depth v2 labelled-file reader (scenes/nyu_depth_v2.h), HDF5 C API.
#include "scenes/nyu_depth_v2.h"

#include <hdf5.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <mutex>
#include <sstream>
#include <vector>

#include "scenes/atomic_file.h"
#include "scenes/error.h"

namespace turbid {
namespace {

constexpr int kWidth = 640;
constexpr int kHeight = 480;

// The HDF5 library keeps global state (error stacks, open-object tables) and Debian's serial build
// is not guaranteed thread-safe: every call in this file runs under this lock.
std::mutex& Hdf5Mutex() {
  static std::mutex mutex;
  return mutex;
}

// Owns an HDF5 identifier and closes it with the matching function.
class Handle {
 public:
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~Handle() {
    if (id_ >= 0) close_(id_);
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

std::string ShapeText(const std::vector<hsize_t>& dims) {
  std::ostringstream s;
  s << "(";
  for (size_t i = 0; i < dims.size(); ++i) s << (i ? ", " : "") << dims[i];
  s << ")";
  return s.str();
}

// An open file and one of its datasets, with its element type and shape checked.
struct Dataset {
  hid_t id = -1;
  std::vector<hsize_t> dims;  // as HDF5 lists them, slowest first, leading frame axis included
};

Handle OpenFile(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw Error(path, "file not found");
  if (!std::filesystem::is_regular_file(path, ec)) throw Error(path, "is not a regular file");
  hid_t id = -1;
  H5E_BEGIN_TRY { id = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT); }
  H5E_END_TRY;
  if (id < 0)
    throw Error(path, "not an HDF5 file (NYU Depth v2 labelled .mat files are MATLAB v7.3 = HDF5; "
                      "older .mat versions must be re-saved with -v7.3)");
  return Handle(id, H5Fclose);
}

// Opens `name`, checks its element type (`want_float`: float32/64; else uint8) and returns its shape
// with a leading frame axis of 1 added when MATLAB dropped a trailing singleton (one-frame files).
std::vector<hsize_t> CheckDataset(const std::string& path, hid_t file, const std::string& name,
                                  bool want_float, int rank_with_frames) {
  htri_t exists = -1;
  H5E_BEGIN_TRY { exists = H5Lexists(file, name.c_str(), H5P_DEFAULT); }
  H5E_END_TRY;
  if (exists <= 0)
    throw Error(path, "has no dataset '" + name +
                          "' (the NYU Depth v2 labelled file holds 'images' and 'depths')");
  hid_t dataset_id = -1;
  H5E_BEGIN_TRY { dataset_id = H5Dopen2(file, name.c_str(), H5P_DEFAULT); }
  H5E_END_TRY;
  Handle dataset_holder(dataset_id, H5Dclose);
  if (!dataset_holder.ok()) throw Error(path, "'" + name + "' is not a dataset");
  Handle type(H5Dget_type(dataset_holder.get()), H5Tclose);
  const H5T_class_t type_class = H5Tget_class(type.get());
  const size_t type_size = H5Tget_size(type.get());
  if (want_float) {
    if (type_class != H5T_FLOAT || (type_size != 4 && type_size != 8))
      throw Error(path, "'" + name + "' must hold float32 or float64 metres, found another type");
  } else if (type_class != H5T_INTEGER || type_size != 1 || H5Tget_sign(type.get()) != H5T_SGN_NONE) {
    throw Error(path, "'" + name + "' must hold uint8 colour codes, found another type");
  }
  Handle space(H5Dget_space(dataset_holder.get()), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 1 || rank > 8) throw Error(path, "'" + name + "' has an unsupported dataspace");
  std::vector<hsize_t> dims(rank);
  H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
  if (rank == rank_with_frames - 1) dims.insert(dims.begin(), 1);
  return dims;
}

// Both datasets' layout checked; returns N.
int CheckLayout(const std::string& path, hid_t file, const NyuFrameOptions& options) {
  const std::vector<hsize_t> images = CheckDataset(path, file, "images", false, 4);
  const std::vector<hsize_t> expected_images = {images.empty() ? 0 : images[0], 3, kWidth, kHeight};
  if (images != expected_images) {
    std::string hint;
    if (images.size() == 4 && images[2] == kHeight && images[3] == kWidth)
      hint = "; it looks transposed (H, W order, e.g. written from NumPy without reversing the axes)";
    throw Error(path, "'images' has shape " + ShapeText(images) +
                          ", expected (N, 3, 640, 480) as MATLAB v7.3 stores 480x640x3xN" + hint);
  }
  const std::vector<hsize_t> depths = CheckDataset(path, file, options.depth_dataset, true, 3);
  const std::vector<hsize_t> expected_depths = {images[0], kWidth, kHeight};
  if (depths != expected_depths)
    throw Error(path, "'" + options.depth_dataset + "' has shape " + ShapeText(depths) +
                          ", expected " + ShapeText(expected_depths) +
                          " (MATLAB 480x640xN, the same N as 'images')");
  if (images[0] == 0) throw Error(path, "'images' holds no frame");
  if (images[0] > static_cast<hsize_t>(std::numeric_limits<int>::max()))
    throw Error(path, "too many frames");
  return static_cast<int>(images[0]);
}

// Reads frame `index` of `name` (rank 3 or 4 with the frame axis first) into `out`.
void ReadFrame(const std::string& path, hid_t file, const std::string& name, int index,
               hid_t memory_type, void* out) {
  Handle dataset(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose);
  Handle space(H5Dget_space(dataset.get()), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space.get());
  std::vector<hsize_t> dims(rank);
  H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
  const bool has_frame_axis = rank == (name == "images" ? 4 : 3);
  std::vector<hsize_t> start(rank, 0), count = dims;
  if (has_frame_axis) {
    start[0] = static_cast<hsize_t>(index);
    count[0] = 1;
  }
  herr_t status = -1;
  H5E_BEGIN_TRY {
    if (H5Sselect_hyperslab(space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(),
                            nullptr) >= 0) {
      Handle memory(H5Screate_simple(rank, count.data(), nullptr), H5Sclose);
      status = H5Dread(dataset.get(), memory_type, memory.get(), space.get(), H5P_DEFAULT, out);
    }
  }
  H5E_END_TRY;
  if (status < 0)
    throw Error(path, "cannot read frame " + std::to_string(index) + " of '" + name +
                          "' (truncated or corrupt file)");
}

}  // namespace

CameraIntrinsics NyuKinectRgbCamera() {
  return {5.1885790117450188e+02, 5.1946961112127485e+02, 3.2558244941119034e+02,
          2.5373616633400465e+02, kWidth, kHeight};
}

cv::Rect NyuBorderCropBox() { return cv::Rect(40, 44, 561, 427); }

bool NyuFrameOptions::Check(std::string* why) const {
  if (depth_dataset != "depths" && depth_dataset != "rawDepths") {
    if (why) *why = "depth dataset must be 'depths' or 'rawDepths', got '" + depth_dataset + "'";
    return false;
  }
  return true;
}

int NyuFrameCount(const std::string& path, const NyuFrameOptions& options) {
  ThrowIfInvalid(options, path);
  std::lock_guard<std::mutex> lock(Hdf5Mutex());
  const Handle file = OpenFile(path);
  return CheckLayout(path, file.get(), options);
}

NyuFrame ReadNyuFrame(const std::string& path, int index, const NyuFrameOptions& options) {
  ThrowIfInvalid(options, path);
  std::vector<uint8_t> codes(size_t{3} * kWidth * kHeight);
  std::vector<float> depth(size_t{kWidth} * kHeight);
  {
    std::lock_guard<std::mutex> lock(Hdf5Mutex());
    const Handle file = OpenFile(path);
    const int count = CheckLayout(path, file.get(), options);
    if (index < 0 || index >= count)
      throw Error(path, "frame " + std::to_string(index) + " out of range (the file holds " +
                            std::to_string(count) + " frames, 0.." + std::to_string(count - 1) + ")");
    ReadFrame(path, file.get(), "images", index, H5T_NATIVE_UINT8, codes.data());
    ReadFrame(path, file.get(), options.depth_dataset, index, H5T_NATIVE_FLOAT, depth.data());
  }
  NyuFrame frame;
  frame.sha256 = Sha256Bytes(std::string(reinterpret_cast<const char*>(codes.data()), codes.size()) +
                             std::string(reinterpret_cast<const char*>(depth.data()),
                                         depth.size() * sizeof(float)));
  // Stored element [c][x][y] (y fastest, MATLAB column-major) -> row y, column x, BGR.
  cv::Mat image(kHeight, kWidth, CV_32FC3);
  cv::Mat depth_m(kHeight, kWidth, CV_32FC1);
  const size_t plane = size_t{kWidth} * kHeight;
  for (int y = 0; y < kHeight; ++y) {
    cv::Vec3f* row = image.ptr<cv::Vec3f>(y);
    float* z = depth_m.ptr<float>(y);
    for (int x = 0; x < kWidth; ++x) {
      const size_t at = size_t{static_cast<size_t>(x)} * kHeight + y;
      for (int c = 0; c < 3; ++c) row[x][2 - c] = codes[c * plane + at] / 255.0f;
      const float v = depth[at];
      if (!std::isfinite(v) || v < 0.0f) {
        std::ostringstream value;
        value << v;
        throw Error(path, "'" + options.depth_dataset + "' frame " + std::to_string(index) +
                              " has depth " + value.str() + " at pixel (" + std::to_string(x) +
                              ", " + std::to_string(y) +
                              ") (must be finite and >= 0 metres; 0 = unknown)");
      }
      z[x] = v == 0.0f ? std::numeric_limits<float>::quiet_NaN() : v;
    }
  }
  if (options.color == Transfer::kSrgb) image = SrgbToLinear(image);
  frame.camera = NyuKinectRgbCamera();
  if (options.crop_border) {
    const cv::Rect box = NyuBorderCropBox();
    image = image(box).clone();
    depth_m = depth_m(box).clone();
    frame.camera.cx -= box.x;
    frame.camera.cy -= box.y;
    frame.camera.width = box.width;
    frame.camera.height = box.height;
  }
  frame.image = image;
  frame.depth_m = depth_m;
  return frame;
}

}  // namespace turbid
