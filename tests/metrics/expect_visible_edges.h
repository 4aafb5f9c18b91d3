// Bit identity of two visible-edge results, every field (NaN equals NaN), for the tests that compare
// two ways of computing them (tests/metrics/no_reference_fast_paths_test.cc,
// original_cache_test.cc).
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "metrics/no_reference.h"

namespace turbid::testing {

inline void ExpectSameResult(const VisibleEdgeResult& a, const VisibleEdgeResult& b,
                             const std::string& what) {
  auto same = [](double x, double y) { return (std::isnan(x) && std::isnan(y)) || x == y; };
  EXPECT_TRUE(same(a.e, b.e)) << what << ": e " << a.e << " vs " << b.e;
  EXPECT_TRUE(same(a.r_mean, b.r_mean)) << what << ": r " << a.r_mean << " vs " << b.r_mean;
  EXPECT_TRUE(same(a.sigma, b.sigma)) << what;
  EXPECT_TRUE(same(a.m, b.m)) << what;
  EXPECT_EQ(a.visible_original, b.visible_original) << what;
  EXPECT_EQ(a.visible_restored, b.visible_restored) << what;
  EXPECT_EQ(a.finite_log_ratios, b.finite_log_ratios) << what;
  EXPECT_EQ(a.black_pixels, b.black_pixels) << what;
  EXPECT_EQ(a.white_pixels, b.white_pixels) << what;
}

}  // namespace turbid::testing
