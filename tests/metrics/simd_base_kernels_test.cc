// The portable copies of the visible-edge kernels (metrics/simd_kernels.inc, which the library
// runs on CPUs without AVX2) against the ones the library picks on this machine: compiled here a
// second time, in a namespace of their own, so that they are tested even where AVX2 is present.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "metrics/simd_dispatch.h"
#include "metrics/visible_edge_search.h"

namespace turbid::simd::portable {
#define TURBID_NO_CONTRACT(...) __asm__("" : "+m"(__VA_ARGS__))
#include "metrics/simd_kernels.inc"
#undef TURBID_NO_CONTRACT
}  // namespace turbid::simd::portable

namespace turbid::simd {
namespace {

TEST(PortableKernels, OctaveGrayEqualsTheDispatchedCopy) {
  std::mt19937 rng(1);
  std::vector<uint8_t> bgr(3 * 1001);
  for (uint8_t& v : bgr) v = static_cast<uint8_t>(rng());
  std::vector<uint8_t> a(1001), b(1001);
  portable::OctaveGrayU8(bgr.data(), 1001, a.data());
  OctaveGrayU8(bgr.data(), 1001, b.data());
  EXPECT_EQ(a, b);
}

// The pixels a visible window marks: portable and dispatched copies against a pixel-by-pixel
// reading of the rule (a vertical pair at window column k marks columns k and k − 1 of its row, a
// horizontal one column k of its row and of the row above), with pair ends drawn near s0 so that
// both comparisons hit their edges, over strides, thresholds and OR-ed starting bits.
TEST(PortableKernels, SeparatedPairRowsMarkThePairsThresholdSeparates) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 4000; ++trial) {
    const int stride = 8 + static_cast<int>(rng() % 20);
    const int s0 = trial < 255 ? trial : static_cast<int>(rng() % 255);
    std::vector<uint8_t> tests(4 * (static_cast<size_t>(5) * stride + 8));
    for (uint8_t& v : tests) {
      const int near = s0 + static_cast<int>(rng() % 5) - 2;
      v = static_cast<uint8_t>(rng() % 4 == 0 ? rng() % 256 : std::clamp(near, 0, 255));
    }
    unsigned start[7];
    for (unsigned& b : start) b = rng() % 4 == 0 ? rng() % 128 : 0;
    unsigned expected[7], a[7], b[7];
    std::copy(start, start + 7, expected);
    for (int nn = 1; nn < 7; ++nn) {
      for (int k = 1; k < 7; ++k) {
        const uint8_t* t = &tests[4 * (static_cast<size_t>(nn - 1) * stride + (k - 1))];
        if (t[0] <= s0 && s0 < t[1]) expected[nn] |= 3u << (k - 1);
        if (t[2] <= s0 && s0 < t[3]) expected[nn] |= 1u << k, expected[nn - 1] |= 1u << k;
      }
    }
    std::copy(start, start + 7, a);
    std::copy(start, start + 7, b);
    portable::SeparatedPairRows(tests.data(), stride, s0, a);
    SeparatedPairRows(tests.data(), stride, s0, b);
    for (int nn = 0; nn < 7; ++nn) {
      ASSERT_EQ(a[nn], expected[nn]) << "portable, trial " << trial << " row " << nn;
      ASSERT_EQ(b[nn], expected[nn]) << "dispatched, trial " << trial << " row " << nn;
    }
  }
}

// The ifsttar variant's weak-pair test (visible_edges::StrongLimits has the proof): a pair it
// calls weak has no term above τ anywhere on its interval. Every pair of values (p, q), each over
// the intervals whose ends sit where the proof's cases change (1, p − 1, p, p + 1, √(pq), q − 1,
// q, q + 1, 255) and a few random ones; the largest term by scanning the thresholds, with the
// published code's Weber contrast. Portable and dispatched copies must give the same flags.
TEST(PortableKernels, IfsttarStrongRowNeverCallsAVisiblePairWeak) {
  std::mt19937 rng(5);
  auto weber = [](double s, double v) { return std::abs(s - v) / std::max(s, v); };
  std::vector<uint8_t> row, up, tests, flags_a, flags_b;
  for (double tau : {0.005, 0.025, 0.1, 1.0 / 3.0, 0.5}) {
    const visible_edges::StrongLimits limits = visible_edges::StrongPairLimits(tau);
    row.assign(1, 0);
    up.assign(1, 0);
    tests.assign(4, 0);
    for (int x = 0; x < 256; ++x) {
      for (int y = 0; y < 256; ++y) {
        const int p = std::min(x, y), q = std::max(x, y);
        const int mid = static_cast<int>(std::lround(std::sqrt(static_cast<double>(p) * q)));
        std::vector<int> ends = {1, p - 1, p, p + 1, mid, q - 1, q, q + 1, 255};
        for (int r = 0; r < 3; ++r) ends.push_back(static_cast<int>(rng() % 256));
        for (int& e : ends) e = std::clamp(e, 0, 255);
        for (size_t i = 0; i < ends.size(); ++i) {
          for (size_t j = 0; j < ends.size(); ++j) {
            // Vertical pair empty ([255, 0)); horizontal pair (x, y) over [ends[i], ends[j]).
            row.push_back(static_cast<uint8_t>(x));
            up.push_back(static_cast<uint8_t>(y));
            tests.insert(tests.end(), {255, 0, static_cast<uint8_t>(ends[i]),
                                       static_cast<uint8_t>(ends[j])});
          }
        }
      }
    }
    const int n = static_cast<int>(row.size());
    flags_a.assign(n, 0);
    flags_b.assign(n, 0);
    portable::IfsttarStrongRow(tests.data(), row.data(), up.data(), n, limits.k, limits.k_ratio,
                               flags_a.data());
    IfsttarStrongRow(tests.data(), row.data(), up.data(), n, limits.k, limits.k_ratio,
                     flags_b.data());
    ASSERT_EQ(flags_a, flags_b) << "tau " << tau;
    int weak = 0;
    for (int c = 1; c < n; ++c) {
      if (flags_a[c] != 0) continue;
      ++weak;
      const double p = row[c], q = up[c];
      double largest = 0.0;
      for (int s = std::max<int>(tests[4 * c + 2], 1); s < tests[4 * c + 3]; ++s)
        largest = std::max(largest, std::min(weber(s, p), weber(s, q)));
      ASSERT_LE(largest, tau) << "tau " << tau << " p " << p << " q " << q << " interval ["
                              << int{tests[4 * c + 2]} << ", " << int{tests[4 * c + 3]} << ")";
    }
    EXPECT_GT(weak, n / 10) << "tau " << tau;  // the test prunes something
  }
}

// Both pairs of every pixel with random values and intervals (ends drawn near the values so
// that the comparisons hit their edges), random limits, and row lengths that leave every tail:
// the dispatched copy (16 pixels per step in AVX2) gives the portable copy's flags.
TEST(PortableKernels, IfsttarStrongRowEqualsTheDispatchedCopy) {
  std::mt19937 rng(17);
  std::vector<uint8_t> row, up, tests, flags_a, flags_b;
  for (int trial = 0; trial < 400; ++trial) {
    const int n = 1 + static_cast<int>(rng() % 300);
    const int k = 1 + static_cast<int>(rng() % 256), k_ratio = 1 + static_cast<int>(rng() % 256);
    row.resize(n);
    up.resize(n);
    tests.resize(4 * static_cast<size_t>(n));
    for (int c = 0; c < n; ++c) {
      row[c] = static_cast<uint8_t>(rng());
      up[c] = static_cast<uint8_t>(rng());
    }
    for (int c = 0; c < n; ++c) {
      const int values[3] = {row[c], c > 0 ? row[c - 1] : 0, up[c]};
      for (int d = 0; d < 4; ++d) {
        const int near = values[rng() % 3] + static_cast<int>(rng() % 5) - 2;
        tests[4 * c + d] = static_cast<uint8_t>(rng() % 2 ? std::clamp(near, 0, 255) : rng() % 256);
      }
    }
    flags_a.assign(n, 0);
    flags_b.assign(n, 0);
    portable::IfsttarStrongRow(tests.data(), row.data(), up.data(), n, k, k_ratio, flags_a.data());
    IfsttarStrongRow(tests.data(), row.data(), up.data(), n, k, k_ratio, flags_b.data());
    ASSERT_EQ(flags_a, flags_b) << "trial " << trial << " n " << n << " k " << k << " k_ratio "
                                << k_ratio;
  }
}

TEST(PortableKernels, PackedSumsAndContrastsAgreeWithTheDispatchedCopies) {
  std::mt19937 rng(2);
  constexpr int kStride = 16;
  for (int trial = 0; trial < 300; ++trial) {
    const bool paper = trial % 2 == 0;
    std::vector<uint8_t> value(8 * kStride), tests(4 * value.size());
    const int level = static_cast<int>(rng() % 200);
    const int spread = 1 + static_cast<int>(rng() % 56);
    for (uint8_t& v : value) v = static_cast<uint8_t>(level + rng() % spread);
    for (size_t k = kStride + 1; k < value.size(); ++k) {
      uint8_t* t = &tests[4 * k];
      const uint8_t p = value[k], left = value[k - 1], up = value[k - kStride];
      if (paper) {
        t[0] = std::min(p, left);
        t[1] = std::max(p, left);
        t[2] = std::min(p, up);
        t[3] = std::max(p, up);
      } else {
        for (int d = 0; d < 4; d += 2) {
          const int x = static_cast<int>(rng() % 256), y = static_cast<int>(rng() % 256);
          t[d] = static_cast<uint8_t>(std::min(x, y));
          t[d + 1] = static_cast<uint8_t>(std::max(x, y));
        }
      }
    }
    const int lo = std::max(level, 1), hi = std::max(level + spread - 1, 1);
    alignas(32) double a[2][kPackedStride] = {}, b[2][kPackedStride] = {};  // finite everywhere
    const uint8_t* v0 = &value[kStride + 1];
    const uint8_t* t0 = &tests[4 * (kStride + 1)];
    PackedBlock pa[2] = {{0, 0, 6, 4, lo, hi, true, a[0]}, {0, 4, 6, 2, lo, hi, true, a[1]}};
    PackedBlock pb[2] = {{0, 0, 6, 4, lo, hi, true, b[0]}, {0, 4, 6, 2, lo, hi, true, b[1]}};
    portable::AddPackedBlocks(v0, t0, kStride, paper, pa, 2);
    AddPackedBlocks(v0, t0, kStride, paper, pb, 2);
    for (int s = lo; s <= hi; ++s) {
      for (int m = 0; m < 2; ++m) {
        ASSERT_NEAR(a[m][s], b[m][s], 1e-10) << "trial " << trial << " s " << s;
        ASSERT_EQ(std::floor(a[m][s] / 128), std::floor(b[m][s] / 128));  // the same counts
      }
    }
    // Blocks 2 pixels high and 2, 4 or 6 wide (the window's shapes, which the AVX2 copy unrolls),
    // the last one adding to the sums of the first.
    {
      alignas(32) double c[3][kPackedStride] = {}, d[3][kPackedStride] = {};
      PackedBlock qa[4] = {{0, 0, 2, 6, lo, hi, true, c[0]},
                           {2, 0, 2, 4, lo, hi, true, c[1]},
                           {4, 2, 2, 2, lo, hi, true, c[2]},
                           {2, 4, 2, 2, lo, hi, false, c[0]}};
      PackedBlock qb[4] = {qa[0], qa[1], qa[2], qa[3]};
      for (int m = 0; m < 4; ++m) qb[m].acc = d[m % 3];
      portable::AddPackedBlocks(v0, t0, kStride, paper, qa, 4);
      AddPackedBlocks(v0, t0, kStride, paper, qb, 4);
      for (int s = lo; s <= hi; ++s) {
        for (int m = 0; m < 3; ++m) {
          ASSERT_NEAR(c[m][s], d[m][s], 1e-10) << "trial " << trial << " s " << s << " m " << m;
          ASSERT_EQ(std::floor(c[m][s] / 128), std::floor(d[m][s] / 128));
        }
      }
    }
    alignas(32) double sum_a[kPackedStride];
    for (int s = lo & ~3; s <= (hi | 3); ++s) sum_a[s] = a[0][s] + a[1][s];
    alignas(32) double ca[kPackedStride], cb[kPackedStride];
    const double* one_a[1] = {sum_a};
    const PackedMaximum ma = portable::PackedContrasts(one_a, 1, lo, hi, 1e-9, ca);
    const PackedMaximum mb = PackedContrasts(one_a, 1, lo, hi, 1e-9, cb);
    EXPECT_EQ(ma.best, mb.best);
    EXPECT_EQ(ma.near, mb.near);
    EXPECT_EQ(ma.first, mb.first);
    for (int s = lo; s <= hi; ++s) ASSERT_EQ(ca[s], cb[s]);
    // The strip pass: strip += the adds on a range around [lo, hi], then the contrasts of the
    // parts and the strip; the same strip and contrasts from both copies.
    const int strip_lo = std::max(1, lo - static_cast<int>(rng() % 9));
    const int strip_hi = std::min(256, hi + static_cast<int>(rng() % 9));
    alignas(32) double strip_a[kPackedStride], strip_b[kPackedStride];
    for (int s = 0; s < kPackedStride; ++s) strip_a[s] = strip_b[s] = a[1][s] + b[0][s];
    const double* adds[2] = {a[0], b[1]};
    // Every count of parts (1-3) and adds (0-2): the AVX2 copy has its own loops for the
    // window's combinations (adds = parts − 1).
    const int n_parts = 1 + trial % 3, n_add = trial / 3 % 3;
    const double* parts_s[3] = {b[0], a[1], b[1]};
    const PackedMaximum sa = portable::PackedContrastsWithStrip(
        parts_s, n_parts, strip_a, adds, n_add, strip_lo, strip_hi, lo, hi, 1e-9, ca);
    const PackedMaximum sb = PackedContrastsWithStrip(parts_s, n_parts, strip_b, adds, n_add,
                                                      strip_lo, strip_hi, lo, hi, 1e-9, cb);
    EXPECT_EQ(sa.best, sb.best);
    EXPECT_EQ(sa.near, sb.near);
    EXPECT_EQ(sa.first, sb.first);
    for (int s = lo; s <= hi; ++s) ASSERT_EQ(ca[s], cb[s]) << "trial " << trial << " s " << s;
    for (int s = strip_lo & ~3; s <= (strip_hi | 3); ++s) {
      double expected = a[1][s] + b[0][s];
      for (int m = 0; m < n_add; ++m) expected += adds[m][s];
      ASSERT_EQ(strip_b[s], expected) << "trial " << trial << " s " << s;
      ASSERT_EQ(strip_a[s], expected);
    }
    // The contrasts are those of PackedContrasts() with the completed strip as the last part.
    const double* with_strip[4] = {b[0], a[1], b[1], strip_a};
    with_strip[n_parts] = strip_a;
    const PackedMaximum sp = PackedContrasts(with_strip, n_parts + 1, lo, hi, 1e-9, ca);
    EXPECT_EQ(sp.best, sb.best);
    EXPECT_EQ(sp.first, sb.first);
    for (int s = lo; s <= hi; ++s) ASSERT_EQ(ca[s], cb[s]);
    portable::ZeroPacked(a[0], lo, hi);
    for (int s = lo & ~3; s < hi + 8; ++s) ASSERT_EQ(a[0][s], 0.0);
    // AddPackedBlocks zeroes every zero_first accumulator before adding any block, whatever
    // their count (1 to 5; the AVX2 copy has a loop per count up to 4).
    alignas(32) double z[5][kPackedStride];
    const int n_zero = 1 + trial % 5;
    PackedBlock none[5];
    for (int m = 0; m < n_zero; ++m) {
      std::fill(std::begin(z[m]), std::end(z[m]), 7.0);
      const int zlo = std::max(1, lo - static_cast<int>(rng() % 9));
      none[m] = {0, 0, 0, 0, zlo, hi, true, z[m]};
    }
    AddPackedBlocks(v0, t0, kStride, paper, none, n_zero);
    for (int m = 0; m < n_zero; ++m)
      for (int s = none[m].clip_lo & ~3; s < hi + 8; ++s) ASSERT_EQ(z[m][s], 0.0) << "m " << m;
  }
}

}  // namespace
}  // namespace turbid::simd
