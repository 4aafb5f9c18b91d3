#include "scenes/scene.h"

#include <cmath>
#include <cstdint>
#include <vector>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "core/cpu.h"
#include "core/error.h"

namespace turbid {

bool CameraIntrinsics::Check(std::string* why) const {
  auto fail = [&](const std::string& message) {
    if (why) *why = message;
    return false;
  };
  if (!std::isfinite(fx) || !std::isfinite(fy) || fx == 0.0 || fy == 0.0)
    return fail("focal lengths fx, fy must be finite and non-zero");
  if (!std::isfinite(cx) || !std::isfinite(cy)) return fail("principal point must be finite");
  if (width <= 0 || height <= 0) return fail("image size must be positive");
  return true;
}

void Scene::ValidateLayout() const {
  const std::string context = name.empty() ? std::string("scene") : "scene " + name;
  ThrowIfInvalid(camera, context);
  if (image.empty()) throw Error(context, "has no image");
  if (image.depth() != CV_32F || (image.channels() != 1 && image.channels() != 3))
    throw Error(context, "image must be float32 with 1 or 3 channels");
  if (image.cols != camera.width || image.rows != camera.height)
    throw Error(context, "image size " + std::to_string(image.cols) + "x" +
                             std::to_string(image.rows) + " differs from the camera's " +
                             std::to_string(camera.width) + "x" + std::to_string(camera.height));
  if (depth_m.empty() || depth_m.type() != CV_32FC1)
    throw Error(context, "depth must be float32, 1 channel");
  if (depth_m.size() != image.size())
    throw Error(context, "depth size " + std::to_string(depth_m.cols) + "x" +
                             std::to_string(depth_m.rows) + " differs from image size " +
                             std::to_string(image.cols) + "x" + std::to_string(image.rows));
  if (!normals.empty() && (normals.type() != CV_32FC3 || normals.size() != image.size()))
    throw Error(context, "normals must be float32, 3 channels, image-sized");
}

void Scene::Validate() const {
  ValidateLayout();
  const std::string context = name.empty() ? std::string("scene") : "scene " + name;
  // Fast check on the float bits (integer compares vectorise): NaN is
  // (bits & 0x7fffffff) > 0x7f800000; positive, finite and non-zero is bits in [1, 0x7f7fffff].
  // The loop below only runs to name the first bad pixel.
  int64_t valid = 0, bad = 0;
  for (int y = 0; y < depth_m.rows; ++y) {
    const uint32_t* bits = depth_m.ptr<uint32_t>(y);
    for (int x = 0; x < depth_m.cols; ++x) {
      const uint32_t nan = (bits[x] & 0x7fffffffu) > 0x7f800000u;
      const uint32_t good = bits[x] - 1u < 0x7f7fffffu;
      valid += good;
      bad += (nan | good) ^ 1u;
    }
  }
  for (int y = 0; y < depth_m.rows && bad > 0; ++y) {
    const float* row = depth_m.ptr<float>(y);
    for (int x = 0; x < depth_m.cols; ++x) {
      if (std::isnan(row[x])) continue;
      if (!std::isfinite(row[x]) || row[x] <= 0.0f)
        throw Error(context, "depth must be positive and finite or NaN (invalid) at pixel (" +
                                 std::to_string(x) + ", " + std::to_string(y) + ")");
    }
  }
  if (valid == 0) throw Error(context, "depth has no valid pixel");
}

namespace {

// One row of RangeFromDepth: r = z sqrt(dx^2 + dy^2 + 1) in double, dx from the column's table.
// The square root is correctly rounded in both the scalar and the vector form, and no FMA is
// used, so both give the same values.
void RangeRowScalar(const float* z, const double* dx, double dy2, int from, int w, float* r) {
  for (int x = from; x < w; ++x)
    r[x] = static_cast<float>(z[x] * std::sqrt(dx[x] * dx[x] + dy2 + 1.0));
}

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
// std::sqrt keeps errno semantics, so the compiler leaves the scalar loop as it is; this is the
// same arithmetic four pixels at a time.
__attribute__((target("avx2"))) void RangeRowAvx2(const float* z, const double* dx, double dy2,
                                                  int w, float* r) {
  const __m256d vdy2 = _mm256_set1_pd(dy2), one = _mm256_set1_pd(1.0);
  int x = 0;
  for (; x + 4 <= w; x += 4) {
    const __m256d d = _mm256_loadu_pd(dx + x);
    const __m256d q = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(d, d), vdy2), one);
    const __m256d v = _mm256_mul_pd(_mm256_cvtps_pd(_mm_loadu_ps(z + x)), _mm256_sqrt_pd(q));
    _mm_storeu_ps(r + x, _mm256_cvtpd_ps(v));
  }
  RangeRowScalar(z, dx, dy2, x, w, r);
}
#endif

}  // namespace

std::vector<double> RangeColumnTable(const CameraIntrinsics& camera, int cols) {
  std::vector<double> dx(cols);
  for (int x = 0; x < cols; ++x) dx[x] = (x - camera.cx) / camera.fx;
  return dx;
}

void RangeFromDepthRow(const CameraIntrinsics& camera, const std::vector<double>& dx,
                       const float* z, int y, float* r) {
  const int cols = static_cast<int>(dx.size());
  const double dy = (y - camera.cy) / camera.fy;
  const double dy2 = dy * dy;
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
  if (CpuHas(CpuLevel::kAvx2)) {
    RangeRowAvx2(z, dx.data(), dy2, cols, r);
    return;
  }
#endif
  RangeRowScalar(z, dx.data(), dy2, 0, cols, r);
}

cv::Mat RangeFromDepth(const CameraIntrinsics& camera, const cv::Mat& depth_m) {
  CV_Assert(depth_m.type() == CV_32FC1);
  cv::Mat range(depth_m.size(), CV_32FC1);
  const std::vector<double> dx = RangeColumnTable(camera, depth_m.cols);
  for (int y = 0; y < depth_m.rows; ++y)
    RangeFromDepthRow(camera, dx, depth_m.ptr<float>(y), y, range.ptr<float>(y));
  return range;
}

}  // namespace turbid
