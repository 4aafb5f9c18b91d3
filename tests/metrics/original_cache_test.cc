// Scoring many restorations of one original with its analysis shared (AnalyseVisibleEdgeOriginal,
// the registry's OriginalCache, as a sweep does per item) gives exactly the values of scoring each
// pair from scratch.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "metrics/no_reference.h"
#include "metrics/registry.h"
#include "core/error.h"
#include "tests/metrics/expect_visible_edges.h"

namespace turbid {
namespace {

// A textured original and restorations of it: stretched, blurred, noisy, the original itself, and
// one whose 8-bit gray values equal the original's (float values that round alike).
struct Set {
  cv::Mat original;
  std::vector<cv::Mat> restored;
};

Set MakeSet(int rows, int cols, int channels, uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat base(rows, cols, CV_32FC(channels));
  rng.fill(base, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::GaussianBlur(base, base, cv::Size(0, 0), 2.0);
  Set s;
  s.original = base * 0.5 + 0.2;
  cv::Mat stretched = (s.original - 0.2) * 1.8, blurred, noisy = s.original.clone(), near;
  cv::GaussianBlur(s.original, blurred, cv::Size(0, 0), 1.5);
  cv::Mat noise(noisy.size(), noisy.type());
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 0.03);
  noisy += noise;
  cv::min(cv::max(stretched, 0.0), 1.0, stretched);
  cv::min(cv::max(noisy, 0.0), 1.0, noisy);
  near = s.original + 1e-4;  // the same 8-bit codes almost everywhere
  s.restored = {stretched, blurred, noisy, s.original, near};
  return s;
}

TEST(OriginalCache, VisibleEdgesFromTheAnalysedOriginalEqualThePair) {
  for (int channels : {1, 3})
    for (const cv::Size size : {cv::Size(97, 61), cv::Size(8, 9)}) {
      const Set set = MakeSet(size.height, size.width, channels, 7 + channels);
      for (VisibleEdgeVariant variant : {VisibleEdgeVariant::kPaper, VisibleEdgeVariant::kIfsttar}) {
        VisibleEdgeOptions o;
        o.variant = variant;
        const VisibleEdgeOriginal analysed = AnalyseVisibleEdgeOriginal(o, set.original);
        for (size_t k = 0; k < set.restored.size(); ++k) {
          testing::ExpectSameResult(
              VisibleEdges(o, analysed, set.restored[k]),
              VisibleEdges(o, set.original, set.restored[k]),
              VisibleEdgeVariantName(variant) + " restoration " + std::to_string(k) + " " +
                  std::to_string(channels) + "ch " + std::to_string(size.width));
        }
      }
    }
}

TEST(OriginalCache, MismatchedOptionsAndSizesAreErrors) {
  const Set set = MakeSet(40, 50, 3, 3);
  VisibleEdgeOptions paper, ifsttar, other;
  ifsttar.variant = VisibleEdgeVariant::kIfsttar;
  other.visibility_threshold = 0.1;
  const VisibleEdgeOriginal analysed = AnalyseVisibleEdgeOriginal(paper, set.original);
  EXPECT_THROW(VisibleEdges(ifsttar, analysed, set.restored[0]), Error);
  EXPECT_THROW(VisibleEdges(other, analysed, set.restored[0]), Error);
  EXPECT_THROW(VisibleEdges(paper, analysed, cv::Mat(41, 50, CV_32FC3, cv::Scalar::all(0.5))),
               Error);
  EXPECT_THROW(VisibleEdges(paper, VisibleEdgeOriginal{}, set.restored[0]), Error);
}

TEST(OriginalCache, RegistryValuesAreTheSameWithTheCache) {
  const std::vector<std::string> names = {"hautiere_e", "hautiere_r", "hautiere_sigma",
                                          "hautiere_m", "hautiere_e_ifsttar", "ssim", "psnr"};
  const Set a = MakeSet(61, 83, 3, 11), b = MakeSet(61, 83, 3, 12);
  const std::shared_ptr<OriginalCache> cache = NewOriginalCache();
  // Two originals through one cache (it starts over for the second), each with its restorations.
  for (const Set* set : {&a, &b, &a}) {
    for (const cv::Mat& restored : set->restored) {
      MetricInputs in;
      in.reference = set->original;
      in.original = set->original;
      in.image = restored;
      const auto plain = ComputeMetrics(names, in);
      in.original_cache = cache.get();
      const auto cached = ComputeMetrics(names, in);
      for (const std::string& name : names) {
        const double x = plain.at(name), y = cached.at(name);
        EXPECT_TRUE((std::isnan(x) && std::isnan(y)) || x == y) << name << ": " << x << " vs " << y;
      }
    }
  }
  // Raw 8-bit values held as float (the CLI's data range 255) key the cache apart from [0, 1].
  MetricInputs in;
  in.original = a.original * 255.0;
  in.image = a.restored[0] * 255.0;
  cv::Mat o8, r8;
  in.original.convertTo(o8, CV_8U);
  in.image.convertTo(r8, CV_8U);
  o8.convertTo(in.original, CV_32F);
  r8.convertTo(in.image, CV_32F);
  in.data_range = 255.0;
  const double plain = ComputeMetrics({"hautiere_e"}, in).at("hautiere_e");
  in.original_cache = cache.get();
  EXPECT_EQ(ComputeMetrics({"hautiere_e"}, in).at("hautiere_e"), plain);
}

}  // namespace
}  // namespace turbid
