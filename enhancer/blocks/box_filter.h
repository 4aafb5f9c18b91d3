// The box filters of the enhancer: sums and means of a float image over (2r+1)x(2r+1) windows,
// in two border rules that the algorithms above them are defined by:
//   clipped  — the window is clipped to the image and the mean divides by the number of pixels
//              inside it (He's guided-filter normalisation, N = boxfilter(ones)); float running
//              sums, one output row at a time (BoxMeansRows, BoxMean). The guided filter's
//              colour and subsampled paths use it; its one-channel stream fuses the same window
//              sums into its coefficient kernels (guided_kernels.cc).
//   reflect  — BORDER_REFLECT, the values of cv::boxFilter on CV_32F bit for bit (its sums in
//              double, in its order), streamed over several planes and two radii at once
//              (box_stream.h: BoxStream, BoxStreamTwoRadii, BoxCount). The oracle's MMSE is
//              defined on it (it reproduces the reference implementation's cv::boxFilter calls).
#pragma once

#include <functional>
#include <opencv2/core.hpp>
#include <vector>

namespace turbid {

// ---- Clipped windows ------------------------------------------------------------------------

// The rows of K planes for BoxMeansRows: row(k, y, scratch) returns row y of plane k (w floats),
// either a pointer into an image or `scratch` filled with the row (a product plane formed on the
// fly: the same float products as a stored plane, without the full-size image).
using PlaneRows = std::function<const float*(int, int, float*)>;

// Rows of stored one-channel float planes (`planes` must outlive the result).
PlaneRows StoredPlanes(const std::vector<cv::Mat>& planes);

// Box means of K planar one-channel float images of the same size (h x w) over the clipped
// (2r+1)x(2r+1) window, one output row at a time: `emit(y, means)` receives K row pointers of
// width w, for y = 0 .. h-1.
void BoxMeansRows(int k_count, int h, int w, int r, const PlaneRows& plane_row,
                  const std::function<void(int, const std::vector<const float*>&)>& emit);
void BoxMeansRows(const std::vector<cv::Mat>& planes, int r,
                  const std::function<void(int, const std::vector<const float*>&)>& emit);

// Box mean over the clipped (2r+1)x(2r+1) window, CV_32F, any channels.
cv::Mat BoxMean(const cv::Mat& src, int radius);

// ---- Reflected borders ----------------------------------------------------------------------

// dst = the sums of src (CV_32F, any channel count) over (2 radius + 1)^2 windows, reflected
// borders (BORDER_REFLECT), divided by the window's area when `normalize`: the values
// cv::boxFilter(src, dst, -1, window, anchor (-1, -1), normalize, BORDER_REFLECT) gives, bit for
// bit (its sums in double, in its order: box_stream.h says which). dst may be src.
void BoxFilterReflect(const cv::Mat& src, cv::Mat& dst, int radius, bool normalize);

}  // namespace turbid
