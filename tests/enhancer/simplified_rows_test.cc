// `simplified`'s colour output step (enhancer/paper/simplified_rows.h, issue 29 item 6, third
// round) against a transcription written here: the boost in double precision (tolerance 1e-6 of
// max(1, |q|); the kernels round the product once or twice in float), the clamp and NaN rule, the
// luminance bit for bit against colour CLAHE's own (clahe_internal::LuminanceRow of the written
// row), nothing written past the image, the finiteness flag. Both kernel sets, with the 8- and the
// 16-lane layout (guided_segments' AVX2 and AVX-512 paths).
#include "enhancer/paper/simplified_rows.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "core/cpu.h"
#include "enhancer/blocks/clahe_luminance.h"
#include "enhancer/blocks/guided_filter.h"
#include "enhancer/blocks/guided_segments.h"
#include "enhancer/paper/simplified.h"

namespace turbid {
namespace {

using simplified_internal::BoostOutArgs;
using simplified_internal::BoostOutFn;

constexpr double kTolerance = 1e-6;

std::vector<std::pair<std::string, BoostOutFn>> KernelSets() {
  std::vector<std::pair<std::string, BoostOutFn>> sets = {
      {"portable", simplified_internal::BoostOutPortable}};
  if (CpuHas(CpuLevel::kAvx2Fma) && simplified_internal::BoostOutAvx2Fma() != nullptr) {
    sets.emplace_back("avx2+fma", simplified_internal::BoostOutAvx2Fma());
  }
  if (CpuHas(CpuLevel::kAvx512) && simplified_internal::BoostOutAvx512() != nullptr) {
    sets.emplace_back("avx512", simplified_internal::BoostOutAvx512());
  }
  return sets;
}

// One case: segment rows of random values in [-0.3, 1.3] (so that both clamps act).
struct Rows {
  int cols, lanes, L;
  guided_segments::Buffer f, g;
};

Rows MakeRows(int cols, int lanes, uint64_t seed) {
  Rows r{cols, lanes, guided_segments::MakeGeometry(cols, 1, lanes).L, {}, {}};
  const size_t n = static_cast<size_t>(r.L) * 3 * lanes;
  r.f.Assign(n);
  r.g.Assign(n);
  cv::RNG rng(seed);
  for (size_t i = 0; i < n; ++i) {
    r.g.data[i] = rng.uniform(-0.1f, 1.1f);
    r.f.data[i] = r.g.data[i] + rng.uniform(-0.1f, 0.1f);
  }
  return r;
}

TEST(SimplifiedRows, BoostClampAndLuminanceMatchTheTranscription) {
  for (const auto& [name, kernel] : KernelSets()) {
    for (int lanes : {8, 16}) {
      for (int cols : {1, 7, 8, 63, 64, 65, 127, 128, 129, 200, 640, 1360}) {
        for (bool rgb : {false, true}) {
          for (bool stream : {false, true}) {
            SCOPED_TRACE(name + " lanes " + std::to_string(lanes) + " cols " +
                         std::to_string(cols) + (rgb ? " rgb" : " bgr") +
                         (stream ? " stream" : ""));
            Rows r = MakeRows(cols, lanes, 1000 + cols);
            guided_segments::Buffer out, lum;
            out.Assign(static_cast<size_t>(cols) * 3 + 32);
            lum.Assign(static_cast<size_t>(r.L) * lanes);
            const float sentinel = -7.0f;
            std::fill(out.data, out.data + cols * 3 + 32, sentinel);
            BoostOutArgs a;
            a.i_f = r.f.data;
            a.i_g = r.g.data;
            a.L = r.L;
            a.lanes = lanes;
            a.cols = cols;
            a.alpha = 5.0f;
            a.rgb = rgb;
            a.stream = stream;
            a.dst = out.data;
            a.lum = lum.data;
            EXPECT_TRUE(kernel(a));
            double worst = 0.0;
            for (int p = 0; p < cols; ++p) {
              const int k = p / r.L, s = p % r.L;
              for (int c = 0; c < 3; ++c) {
                const size_t at = (static_cast<size_t>(s) * 3 + c) * lanes + k;
                const double g = r.g.data[at], f = r.f.data[at];
                const double q = std::clamp(g + 5.0 * (f - g), 0.0, 1.0);
                worst = std::max(worst, std::abs(out.data[p * 3 + c] - q) / std::max(1.0, q));
              }
            }
            EXPECT_LE(worst, kTolerance);
            for (int i = cols * 3; i < cols * 3 + 32; ++i) ASSERT_EQ(out.data[i], sentinel) << i;
            std::vector<float> want(cols);
            clahe_internal::LuminanceRow(out.data, want.data(), cols, rgb);
            for (int p = 0; p < cols; ++p) ASSERT_EQ(lum.data[p], want[p]) << "pixel " << p;
            // Without the luminance: the same row.
            std::vector<float> first(out.data, out.data + cols * 3);
            a.lum = nullptr;
            EXPECT_TRUE(kernel(a));
            EXPECT_TRUE(std::equal(first.begin(), first.end(), out.data));
          }
        }
      }
    }
  }
}

// Non-temporal writes (staged, then streamed from the first 64-byte line of dst on) give the plain
// stores' row bit for bit at any alignment of dst, and nothing outside the row.
TEST(SimplifiedRows, StreamedRowsEqualPlainRowsAtAnyAlignment) {
  for (const auto& [name, kernel] : KernelSets()) {
    for (int lanes : {8, 16}) {
      for (int cols : {1, 5, 200, 1360}) {
        for (int offset : {0, 1, 7, 15}) {
          SCOPED_TRACE(name + " lanes " + std::to_string(lanes) + " cols " + std::to_string(cols) +
                       " offset " + std::to_string(offset));
          Rows r = MakeRows(cols, lanes, 77 + cols);
          const size_t n = static_cast<size_t>(cols) * 3;
          guided_segments::Buffer plain, streamed;
          plain.Assign(n);
          streamed.Assign(n + 48);
          std::fill(streamed.data, streamed.data + n + 48, -7.0f);
          BoostOutArgs a;
          a.i_f = r.f.data;
          a.i_g = r.g.data;
          a.L = r.L;
          a.lanes = lanes;
          a.cols = cols;
          a.alpha = 5.0f;
          a.dst = plain.data;
          EXPECT_TRUE(kernel(a));
          a.stream = true;
          a.dst = streamed.data + offset;
          EXPECT_TRUE(kernel(a));
          for (int i = 0; i < offset; ++i) ASSERT_EQ(streamed.data[i], -7.0f) << i;
          ASSERT_TRUE(std::equal(plain.data, plain.data + n, streamed.data + offset));
          for (size_t i = n + offset; i < n + 48; ++i) ASSERT_EQ(streamed.data[i], -7.0f) << i;
        }
      }
    }
  }
}

TEST(SimplifiedRows, NonFiniteValuesAreReportedAndWrittenAsClamped) {
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (const auto& [name, kernel] : KernelSets()) {
    for (int lanes : {8, 16}) {
      for (float bad : {nan, inf, -inf}) {
        SCOPED_TRACE(name + " lanes " + std::to_string(lanes) + " " + std::to_string(bad));
        Rows r = MakeRows(100, lanes, 7);
        for (float& v : r.f.storage) v = 0.5f;
        r.f.data[(5 * 3 + 1) * lanes + 2] = bad;  // pixel 2 L + 5, green
        guided_segments::Buffer out;
        out.Assign(300);
        BoostOutArgs a;
        a.i_f = r.f.data;
        a.i_g = r.g.data;
        a.L = r.L;
        a.lanes = lanes;
        a.cols = 100;
        a.alpha = 5.0f;
        a.dst = out.data;
        EXPECT_FALSE(kernel(a));
        const float v = out.data[(2 * r.L + 5) * 3 + 1];
        EXPECT_EQ(v, bad > 0 ? 1.0f : 0.0f);  // NaN and -inf to 0, +inf to 1
      }
    }
  }
}

TEST(SimplifiedRows, SimplifiedColourAtEveryCpuLevelIsItsFiltersBoosted) {
  // The whole streamed path (the shared input, both streams, the output step with the lane count
  // of the level's kernels) at each CPU level against the whole-image filters of the same level,
  // boosted and clamped in double (CLAHE off). Widths: one and several 16-column blocks, partial
  // last blocks, segments past the image.
  for (CpuLevel level : {CpuLevel::kAvx512, CpuLevel::kAvx2Fma, CpuLevel::kScalar}) {
    SetCpuLevelCap(level);
    for (const cv::Size& size : {cv::Size(333, 41), cv::Size(1031, 23), cv::Size(17, 9)}) {
      SCOPED_TRACE(std::string("level ") + CpuLevelName(KernelCpuLevel()) + " " +
                   std::to_string(size.width) + "x" + std::to_string(size.height));
      cv::Mat img(size, CV_32FC3);
      cv::RNG(size.area()).fill(img, cv::RNG::UNIFORM, 0.0, 1.0);
      cv::GaussianBlur(img, img, cv::Size(0, 0), 1.5);
      SimplifiedOptions o;
      o.contrast = false;
      GuidedFilterOptions fine, coarse;
      fine.radius = o.fine_radius;
      fine.eps = o.fine_eps;
      coarse.radius = o.coarse_radius;
      coarse.eps = o.coarse_eps;
      const cv::Mat out = SimplifiedEnhance(o, img);
      const cv::Mat f = GuidedFilterSelf(fine, img), g = GuidedFilterSelf(coarse, img);
      double worst = 0.0;
      for (int y = 0; y < size.height; ++y) {
        for (int i = 0; i < size.width * 3; ++i) {
          const double gv = g.ptr<float>(y)[i], fv = f.ptr<float>(y)[i];
          const double q = std::clamp(gv + o.alpha * (fv - gv), 0.0, 1.0);
          worst = std::max(worst, std::abs(out.ptr<float>(y)[i] - q) / std::max(1.0, q));
        }
      }
      EXPECT_LE(worst, kTolerance);
    }
  }
  SetCpuLevelCap(CpuLevel::kAvx512);
}

}  // namespace
}  // namespace turbid
