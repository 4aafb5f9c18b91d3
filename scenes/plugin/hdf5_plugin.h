// The interface between scenes/nyu_depth_v2.cc and the HDF5 plugin (turbid_hdf5.so), built from
// this tree with the same compiler and libstdc++, so std::string crosses it (as with
// scenes/plugin/image_plugin.h).
#pragma once

#include <string>

// Opens the NYU Depth v2 labelled file `path` (an existing regular file: the caller checks) and
// checks the layout of 'images' (uint8, (N, 3, 640, 480)) and `depth_dataset` (float32/float64,
// (N, 640, 480)); sets *count = N. When 0 <= `index` < N it also reads frame `index`, as stored:
// into `codes` the 3 x 640 x 480 uint8 colour codes ([c][x][y]) and into `depth` the 640 x 480
// depths ([x][y], float32). Returns 0 on success; otherwise 1 with the problem, without the
// path, in *error (the caller prefixes "<path>: "). Never throws.
extern "C" {
typedef int TurbidHdf5ReadNyuFn(const char* path, const char* depth_dataset, int index, int* count,
                                unsigned char* codes, float* depth, std::string* error);
}

inline constexpr const char* kTurbidHdf5ReadNyuSymbol = "turbid_hdf5_read_nyu_v1";
inline constexpr const char* kTurbidHdf5PluginFileName = "turbid_hdf5.so";
