// The metric registry: names, only-requested computation, agreement with the direct calls.
#include "metrics/registry.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <set>

#include "metrics/full_reference.h"
#include "metrics/no_reference.h"
#include "metrics/ssim.h"
#include "core/error.h"

namespace turbid {
namespace {

MetricInputs MakeInputs() {
  cv::RNG rng(11);
  cv::Mat ref(48, 64, CV_8UC3);
  rng.fill(ref, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(ref, ref, cv::Size(5, 5), 1.5);
  cv::Mat img, orig;
  cv::GaussianBlur(ref, img, cv::Size(3, 3), 1.0);
  ref.convertTo(orig, -1, 0.5, 60);  // a hazy, low-contrast "original"
  MetricInputs in;
  ref.convertTo(in.reference, CV_32F, 1.0 / 255);
  img.convertTo(in.image, CV_32F, 1.0 / 255);
  orig.convertTo(in.original, CV_32F, 1.0 / 255);
  return in;
}

TEST(MetricRegistry, ListsUniqueNamesAndFindsThem) {
  std::set<std::string> names;
  for (const MetricInfo& info : ListMetrics()) {
    EXPECT_TRUE(names.insert(info.name).second) << info.name;
    EXPECT_FALSE(info.summary.empty());
    EXPECT_EQ(&FindMetric(info.name), &info);
  }
  for (const char* required : {"ssim", "psnr", "mse", "cnr", "hautiere_e", "hautiere_r",
                               "hautiere_sigma", "hautiere_e_ifsttar", "uiqm", "uciqe"})
    EXPECT_TRUE(names.count(required)) << required;
  EXPECT_THROW(FindMetric("nope"), Error);
}

TEST(MetricRegistry, ComputesOnlyRequestedAndAgreesWithDirectCalls) {
  const MetricInputs in = MakeInputs();
  const auto values = ComputeMetrics({"psnr", "ssim"}, in);
  ASSERT_EQ(values.size(), 2u);
  EXPECT_DOUBLE_EQ(values.at("ssim"), Ssim({}, in.reference, in.image).mean);
  EXPECT_DOUBLE_EQ(values.at("psnr"), Psnr({}, in.reference, in.image));
  // No-reference metrics through the registry equal the direct calls.
  const auto nr = ComputeMetrics({"hautiere_e", "hautiere_sigma", "uiqm", "uciqe", "cnr"}, in);
  const VisibleEdgeResult edges = VisibleEdges({}, in.original, in.image);
  EXPECT_EQ(nr.at("hautiere_e"), edges.e);
  EXPECT_EQ(nr.at("hautiere_sigma"), edges.sigma);
  EXPECT_EQ(nr.at("uiqm"), Uiqm({}, in.image).uiqm);
  EXPECT_EQ(nr.at("uciqe"), Uciqe({}, in.image).uciqe);
  EXPECT_EQ(nr.at("cnr"), Cnr({}, in.image).cnr);
}

TEST(MetricRegistry, RawEightBitScaleGivesTheSameNumbers) {
  const MetricInputs unit = MakeInputs();
  MetricInputs raw;
  unit.reference.convertTo(raw.reference, CV_32F, 255.0);
  unit.image.convertTo(raw.image, CV_32F, 255.0);
  unit.original.convertTo(raw.original, CV_32F, 255.0);
  raw.data_range = 255.0;
  const std::vector<std::string> names = {"ssim", "psnr", "mse", "cnr", "hautiere_r", "uciqe"};
  const auto a = ComputeMetrics(names, unit);
  const auto b = ComputeMetrics(names, raw);
  for (const std::string& n : names) EXPECT_NEAR(a.at(n), b.at(n), 1e-5 * std::abs(a.at(n))) << n;
}

TEST(MetricRegistry, IdenticalImagesGiveInfinitePsnrAndJsonString) {
  MetricInputs in = MakeInputs();
  in.image = in.reference.clone();
  const auto v = ComputeMetrics({"psnr", "mse"}, in);
  EXPECT_TRUE(std::isinf(v.at("psnr")));
  EXPECT_EQ(v.at("mse"), 0.0);
  EXPECT_EQ(MetricValueToJson(v.at("psnr")), "inf");
  EXPECT_EQ(MetricValueToJson(-INFINITY), "-inf");
  EXPECT_EQ(MetricValueToJson(NAN), "nan");
  EXPECT_EQ(MetricValueToJson(0.5), 0.5);
  EXPECT_EQ(MetricValueToText(0.5), "0.5");
}

TEST(MetricRegistry, MissingInputsAndBadNamesGiveClearErrors) {
  MetricInputs in = MakeInputs();
  EXPECT_THROW(ComputeMetrics({"ssim", "bogus"}, in), Error);
  MetricInputs no_ref = in;
  no_ref.reference = cv::Mat();
  EXPECT_THROW(ComputeMetrics({"ssim"}, no_ref), Error);
  EXPECT_NO_THROW(ComputeMetrics({"cnr"}, no_ref));  // no-reference metric: fine
  MetricInputs no_orig = in;
  no_orig.original = cv::Mat();
  EXPECT_THROW(ComputeMetrics({"hautiere_e"}, no_orig), Error);
  MetricInputs mismatch = in;
  mismatch.image = in.image(cv::Rect(0, 0, 32, 32)).clone();
  EXPECT_THROW(ComputeMetrics({"psnr"}, mismatch), Error);
}

TEST(MetricRegistry, ParseMetricListValidatesNeeds) {
  EXPECT_EQ(ParseMetricList("ssim, psnr,ssim", true, false),
            (std::vector<std::string>{"ssim", "psnr"}));
  EXPECT_THROW(ParseMetricList("ssim", false, false), Error);
  EXPECT_THROW(ParseMetricList("hautiere_e", true, false), Error);
  EXPECT_THROW(ParseMetricList("", true, true), Error);
  const auto all_nr = ParseMetricList("all", false, false);
  for (const std::string& n : all_nr) {
    EXPECT_FALSE(FindMetric(n).needs_reference) << n;
    EXPECT_FALSE(FindMetric(n).needs_original) << n;
  }
}

}  // namespace
}  // namespace turbid
