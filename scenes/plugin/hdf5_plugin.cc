// turbid_hdf5.so: the NYU Depth v2 labelled-file reader's HDF5 part (scenes/nyu_depth_v2.h), in a
// shared library that scenes/nyu_depth_v2.cc opens only when an NYU .mat file is read, so that no
// other run pays for loading libhdf5 and its dependencies (docs/architecture.md, "Linking").
#include "scenes/plugin/hdf5_plugin.h"

#include <hdf5.h>

#include <exception>
#include <limits>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

constexpr int kWidth = 640;
constexpr int kHeight = 480;

// A problem with the file; the entry point returns its text (the caller adds the path).
class Problem : public std::runtime_error {
 public:
  explicit Problem(const std::string& what) : std::runtime_error(what) {}
};

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

hid_t OpenFile(const std::string& path) {
  hid_t id = -1;
  H5E_BEGIN_TRY { id = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT); }
  H5E_END_TRY;
  if (id < 0)
    throw Problem(
        "not an HDF5 file (NYU Depth v2 labelled .mat files are MATLAB v7.3 = HDF5; "
        "older .mat versions must be re-saved with -v7.3)");
  return id;
}

// Opens `name`, checks its element type (`want_float`: float32/64; else uint8) and returns its
// shape with a leading frame axis of 1 added when MATLAB dropped a trailing singleton (one-frame
// files).
std::vector<hsize_t> CheckDataset(hid_t file, const std::string& name, bool want_float,
                                  int rank_with_frames) {
  htri_t exists = -1;
  H5E_BEGIN_TRY { exists = H5Lexists(file, name.c_str(), H5P_DEFAULT); }
  H5E_END_TRY;
  if (exists <= 0)
    throw Problem("has no dataset '" + name +
                  "' (the NYU Depth v2 labelled file holds 'images' and 'depths')");
  hid_t dataset_id = -1;
  H5E_BEGIN_TRY { dataset_id = H5Dopen2(file, name.c_str(), H5P_DEFAULT); }
  H5E_END_TRY;
  Handle dataset_holder(dataset_id, H5Dclose);
  if (!dataset_holder.ok()) throw Problem("'" + name + "' is not a dataset");
  Handle type(H5Dget_type(dataset_holder.get()), H5Tclose);
  const H5T_class_t type_class = H5Tget_class(type.get());
  const size_t type_size = H5Tget_size(type.get());
  if (want_float) {
    if (type_class != H5T_FLOAT || (type_size != 4 && type_size != 8))
      throw Problem("'" + name + "' must hold float32 or float64 metres, found another type");
  } else if (type_class != H5T_INTEGER || type_size != 1 ||
             H5Tget_sign(type.get()) != H5T_SGN_NONE) {
    throw Problem("'" + name + "' must hold uint8 colour codes, found another type");
  }
  Handle space(H5Dget_space(dataset_holder.get()), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 1 || rank > 8) throw Problem("'" + name + "' has an unsupported dataspace");
  std::vector<hsize_t> dims(rank);
  H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
  if (rank == rank_with_frames - 1) dims.insert(dims.begin(), 1);
  return dims;
}

// Both datasets' layout checked; returns N.
int CheckLayout(hid_t file, const std::string& depth_dataset) {
  const std::vector<hsize_t> images = CheckDataset(file, "images", false, 4);
  const std::vector<hsize_t> expected_images = {images.empty() ? 0 : images[0], 3, kWidth, kHeight};
  if (images != expected_images) {
    std::string hint;
    if (images.size() == 4 && images[2] == kHeight && images[3] == kWidth)
      hint =
          "; it looks transposed (H, W order, e.g. written from NumPy without reversing the axes)";
    throw Problem("'images' has shape " + ShapeText(images) +
                  ", expected (N, 3, 640, 480) as MATLAB v7.3 stores 480x640x3xN" + hint);
  }
  const std::vector<hsize_t> depths = CheckDataset(file, depth_dataset, true, 3);
  const std::vector<hsize_t> expected_depths = {images[0], kWidth, kHeight};
  if (depths != expected_depths)
    throw Problem("'" + depth_dataset + "' has shape " + ShapeText(depths) + ", expected " +
                  ShapeText(expected_depths) + " (MATLAB 480x640xN, the same N as 'images')");
  if (images[0] == 0) throw Problem("'images' holds no frame");
  if (images[0] > static_cast<hsize_t>(std::numeric_limits<int>::max()))
    throw Problem("too many frames");
  return static_cast<int>(images[0]);
}

// Reads frame `index` of `name` (rank 3 or 4 with the frame axis first) into `out`.
void ReadFrame(hid_t file, const std::string& name, int index, hid_t memory_type, void* out) {
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
    throw Problem("cannot read frame " + std::to_string(index) + " of '" + name +
                  "' (truncated or corrupt file)");
}

}  // namespace

extern "C" __attribute__((visibility("default"))) int turbid_hdf5_read_nyu_v1(
    const char* path, const char* depth_dataset, int index, int* count, unsigned char* codes,
    float* depth, std::string* error) {
  try {
    std::lock_guard<std::mutex> lock(Hdf5Mutex());
    const Handle file(OpenFile(path), H5Fclose);
    *count = CheckLayout(file.get(), depth_dataset);
    if (index >= 0 && index < *count) {
      ReadFrame(file.get(), "images", index, H5T_NATIVE_UINT8, codes);
      ReadFrame(file.get(), depth_dataset, index, H5T_NATIVE_FLOAT, depth);
    }
    return 0;
  } catch (const std::exception& e) {
    *error = e.what();
    return 1;
  } catch (...) {
    *error = "unknown error in the HDF5 plugin";
    return 1;
  }
}
