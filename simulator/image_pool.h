// Internal: a recycling allocator for the renderer's image-sized buffers (not public API).
//
// Why: a 1360x1024 colour render returns two 16 MiB images. When callers free them, the C library
// gives such blocks back to the kernel, and the next render takes ~4000 fresh page faults per
// image (each zeroes a page), which on the measurement VM cost more than the rendering arithmetic
// (docs/performance-simulator.md). Buffers allocated here return to a small free list when their
// last cv::Mat goes away and are handed out again for the next buffer of the same byte size, so a
// sequence of renders (a sweep, a dataset, a benchmark loop) touches fresh memory only once.
//
// Semantics are those of OpenCV's default allocator (any Mat may use it; contents of a new buffer
// are unspecified), except that up to kMaxPooledBytes of freed buffers stay allocated for reuse.
#pragma once

#include <cstddef>
#include <opencv2/core.hpp>

namespace turbid::internal {

// Freed buffers kept for reuse, in total; older ones are released first beyond this.
inline constexpr size_t kMaxPooledBytes = size_t{160} << 20;
// Buffers smaller than this are left to OpenCV's allocator (the C library reuses those anyway).
inline constexpr size_t kMinPooledBytes = size_t{1} << 20;

// The process-wide pool (never destroyed: Mats may outlive static destruction).
cv::MatAllocator* ImagePool();

// A Mat of the given size and type whose buffer comes from ImagePool().
cv::Mat PooledMat(cv::Size size, int type);

}  // namespace turbid::internal
