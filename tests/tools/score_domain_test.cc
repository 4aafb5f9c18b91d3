// The scoring domain (issue 32 item 1): full-reference metrics of a sweep compare the images as
// the camera writes them by default. Encoding checked against the IEC 61966-2-1 closed form; the
// harness's coded scores checked against the same images written as PNG files and scored from the
// files (`turbid score`'s path); the key's parsing, the tables' domain column and regress's refusal
// to compare across domains.
#include "tools/harness/score_domain.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "core/error.h"
#include "enhancer/registry.h"
#include "metrics/registry.h"
#include "scenes/image_io.h"
#include "scenes/scene_loader.h"
#include "simulator/render.h"
#include "tests/support/test_support.h"
#include "tests/tools/harness_fakes.h"
#include "tools/harness/experiment.h"
#include "tools/harness/harness_runner.h"
#include "tools/harness/metric_image.h"
#include "tools/harness/tables.h"

namespace turbid {
namespace {

using testing::FakeCatalog;
using testing::FakeExperimentJson;
using testing::ReadFileText;
using testing::TempDir;

// The sRGB code of v by the standard's formula, in double.
double SrgbCode(double v, double levels) {
  const double c = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
  return std::round(c * levels);
}

TEST(ScoreDomain, CodesFollowTheClosedForm) {
  cv::Mat linear(1, 2001, CV_32F);
  for (int i = 0; i < linear.cols; ++i) linear.at<float>(i) = static_cast<float>(i) / 2000.0f;
  for (const int bits : {8, 16}) {
    const double levels = bits == 8 ? 255.0 : 65535.0;
    const cv::Mat srgb = EncodeForScoring(linear, {CameraEncoding::kSrgb, bits});
    const cv::Mat lin = EncodeForScoring(linear, {CameraEncoding::kLinear, bits});
    for (int i = 0; i < linear.cols; ++i) {
      const double v = linear.at<float>(i);
      const double c = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
      // Away from a decision threshold (1e-2 of a code: the camera rounds v L in float), the code
      // is the rounded curve exactly.
      if (std::fabs(c * levels - std::floor(c * levels) - 0.5) > 1e-2) {
        EXPECT_EQ(srgb.at<float>(i), SrgbCode(v, levels)) << "v " << v << " bits " << bits;
      }
      if (std::fabs(v * levels - std::floor(v * levels) - 0.5) > 1e-2) {
        EXPECT_EQ(lin.at<float>(i), std::round(v * levels)) << "v " << v << " bits " << bits;
      }
    }
  }
  // Hand-checked codes: sRGB(0.5) = 0.7354 -> 187.52 -> 188; sRGB(0.18) = 0.4614 -> 117.66 -> 118.
  cv::Mat few = (cv::Mat_<float>(1, 6) << 0.5f, 0.18f, 0.0f, 1.0f, -0.3f, 1.7f);
  const cv::Mat codes = EncodeForScoring(few, {CameraEncoding::kSrgb, 8});
  EXPECT_EQ(codes.at<float>(0), 188.0f);
  EXPECT_EQ(codes.at<float>(1), 118.0f);
  EXPECT_EQ(codes.at<float>(2), 0.0f);
  EXPECT_EQ(codes.at<float>(3), 255.0f);
  EXPECT_EQ(codes.at<float>(4), 0.0f);    // clipped
  EXPECT_EQ(codes.at<float>(5), 255.0f);  // clipped
  // A float camera writes clipped linear values; NaN becomes 0.
  cv::Mat odd = (cv::Mat_<float>(1, 3) << 0.25f, 1.5f, std::nanf(""));
  const cv::Mat flt = EncodeForScoring(odd, {CameraEncoding::kSrgb, 32});
  EXPECT_EQ(flt.at<float>(0), 0.25f);
  EXPECT_EQ(flt.at<float>(1), 1.0f);
  EXPECT_EQ(flt.at<float>(2), 0.0f);
  EXPECT_EQ((CameraCoding{CameraEncoding::kSrgb, 8}.DataRange()), 255.0);
  EXPECT_EQ((CameraCoding{CameraEncoding::kLinear, 16}.DataRange()), 65535.0);
  EXPECT_EQ((CameraCoding{CameraEncoding::kSrgb, 32}.DataRange()), 1.0);
  EXPECT_EQ((CameraCoding{CameraEncoding::kSrgb, 8}.Describe()), "srgb 8-bit");
}

TEST(ScoreDomain, ExperimentKeyDefaultsToEncodedAndIsStrict) {
  nlohmann::json in = FakeExperimentJson();
  EXPECT_EQ(ParseExperiment(in, "x.json", FakeCatalog()).score_domain, ScoreDomain::kEncoded);
  in["score_domain"] = "linear";
  const Experiment linear = ParseExperiment(in, "x.json", FakeCatalog());
  EXPECT_EQ(linear.score_domain, ScoreDomain::kLinear);
  EXPECT_EQ(linear.ToJson()["score_domain"], "linear");
  EXPECT_EQ(ExperimentFromResolvedJson(linear.ToJson(), "e.json").score_domain,
            ScoreDomain::kLinear);
  in["score_domain"] = "srgb8";
  try {
    ParseExperiment(in, "x.json", FakeCatalog());
    FAIL() << "srgb8 accepted";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what())
                  .find("x.json: 'score_domain': expected one of encoded, linear, got \"srgb8\""),
              std::string::npos)
        << error.what();
  }
  in["score_domain"] = 3;
  EXPECT_THROW(ParseExperiment(in, "x.json", FakeCatalog()), Error);
  // A folder swept before the key existed was scored in linear light.
  in.erase("score_domain");
  nlohmann::json resolved = ParseExperiment(in, "x.json", FakeCatalog()).ToJson();
  EXPECT_EQ(resolved["score_domain"], "encoded");
  resolved.erase("score_domain");
  EXPECT_EQ(ExperimentFromResolvedJson(resolved, "old.json").score_domain, ScoreDomain::kLinear);
}

// The harness's scores of one real item (hull at 0.1 scale, the degraded input and `clahe`)
// equal the scores of the same images written as sRGB 8-bit PNG files and read back raw.
TEST(ScoreDomain, SweepScoresEqualScoresOfTheWrittenFiles) {
  TempDir dir;
  const char* text = R"({"name": "dom", "seed": 3, "scale": 0.1, "scenes": ["builtin:hull"],
    "grid": {"water.beta_gray_per_m": [0.7]}, "methods": ["clahe"],
    "reference_methods": false, "metrics": ["ssim", "psnr", "mse", "hautiere_e"],
    "thumbnails": false})";
  nlohmann::json in = nlohmann::json::parse(text);
  const Experiment coded = ParseExperiment(in, dir.File("dom.json"), RegistryCatalog());
  in["score_domain"] = "linear";
  const Experiment linear = ParseExperiment(in, dir.File("dom.json"), RegistryCatalog());
  const std::vector<ItemSpec> items = ExpandItems(coded);
  ASSERT_EQ(items.size(), 1u);
  const ItemResult a = HarnessRunner(coded, dir.File("a")).Run(items[0]);
  const ItemResult b = HarnessRunner(linear, dir.File("b")).Run(ExpandItems(linear)[0]);
  ASSERT_EQ(a.methods.size(), 1u);
  ASSERT_TRUE(a.methods[0].error.empty()) << a.methods[0].error;

  // The same render and enhancement, written as the camera writes them.
  LoadSceneOptions load;
  load.builtin_scale = 0.1;
  const Scene scene = LoadScene("builtin:hull", load);
  RenderOptions options = *items[0].render;
  options.seed = items[0].seed;
  const RenderResult render = Renderer(scene).Render(options);
  EnhanceInput enhance;
  enhance.image = render.image;
  const cv::Mat enhanced = Enhance("clahe", nlohmann::json::object(), enhance);
  WriteImageOptions write;
  write.transfer = Transfer::kSrgb;
  WriteImage(dir.File("clean.png"), scene.image, write);
  WriteImage(dir.File("clahe.png"), enhanced, write);
  MetricImage reference = LoadMetricImage(dir.File("clean.png"));
  MetricImage image = LoadMetricImage(dir.File("clahe.png"));
  MetricInputs files;
  files.reference = reference.pixels;
  files.image = image.pixels;
  files.data_range = 255.0;
  const auto from_files = ComputeMetrics({"ssim", "psnr", "mse"}, files);
  // The PNG writer codes with the float curve, the camera with exact thresholds: a code may
  // differ by one at a threshold, hence 1e-4 on SSIM and 1e-3 dB.
  EXPECT_NEAR(a.methods[0].metrics.at("ssim"), from_files.at("ssim"), 1e-4);
  EXPECT_NEAR(a.methods[0].metrics.at("psnr"), from_files.at("psnr"), 1e-3);
  EXPECT_NEAR(a.methods[0].metrics.at("mse"), from_files.at("mse"), 1e-6);
  // Linear domain: today's numbers, the linear images as they are.
  MetricInputs lin;
  lin.reference = scene.image;
  lin.image = enhanced;
  lin.original = render.image;
  const auto from_linear = ComputeMetrics({"ssim", "psnr", "hautiere_e"}, lin);
  EXPECT_DOUBLE_EQ(b.methods[0].metrics.at("ssim"), from_linear.at("ssim"));
  EXPECT_DOUBLE_EQ(b.methods[0].metrics.at("psnr"), from_linear.at("psnr"));
  EXPECT_GT(std::fabs(a.methods[0].metrics.at("ssim") - b.methods[0].metrics.at("ssim")), 1e-3);
  // No-reference metrics read linear light in both domains.
  EXPECT_DOUBLE_EQ(a.methods[0].metrics.at("hautiere_e"), from_linear.at("hautiere_e"));
  EXPECT_DOUBLE_EQ(b.methods[0].metrics.at("hautiere_e"), from_linear.at("hautiere_e"));
}

TEST(ScoreDomain, TablesStateTheDomainAndRegressRefusesToMixThem) {
  TempDir dir;
  nlohmann::json in = FakeExperimentJson();
  const Experiment coded = ParseExperiment(in, "x.json", FakeCatalog());
  in["score_domain"] = "linear";
  const Experiment linear = ParseExperiment(in, "x.json", FakeCatalog());
  std::vector<ItemResult> items;
  testing::FakeRunner runner{&coded};
  for (const ItemSpec& spec : ExpandItems(coded)) {
    ItemResult r = runner(spec);
    r.index = spec.index;
    r.id = spec.id;
    r.level = spec.level;
    items.push_back(r);
  }
  std::filesystem::create_directories(dir.File("coded"));
  std::filesystem::create_directories(dir.File("linear"));
  WriteTables(coded, items, dir.File("coded"));
  WriteTables(linear, items, dir.File("linear"));
  const std::string summary = ReadFileText(dir.File("coded/summary.csv"));
  EXPECT_EQ(summary.rfind("level,method,metric,domain,n,mean,sd,", 0), 0u) << summary;
  EXPECT_NE(summary.find(",up,encoded,"), std::string::npos);
  EXPECT_NE(summary.find(",nr,linear,"), std::string::npos);  // no-reference: linear light
  EXPECT_NE(ReadFileText(dir.File("linear/summary.csv")).find(",up,linear,"), std::string::npos);
  EXPECT_NE(ReadFileText(dir.File("coded/items.csv")).find(",method,score_domain,up,"),
            std::string::npos);
  const std::string md = ReadFileText(dir.File("coded/summary.md"));
  EXPECT_NE(md.find("Score domain: **encoded**"), std::string::npos) << md;
  EXPECT_NE(md.find("| up ↑ (encoded) |"), std::string::npos) << md;
  for (const char* table : {"summary.csv", "items.csv"}) {
    RegressOptions options;
    EXPECT_FALSE(Regress(dir.File(std::string("coded/") + table),
                         dir.File(std::string("coded/") + table), options)
                     .failed());
    try {
      Regress(dir.File(std::string("linear/") + table), dir.File(std::string("coded/") + table),
              options);
      FAIL() << table << ": domains mixed silently";
    } catch (const Error& error) {
      EXPECT_NE(std::string(error.what()).find("scored in the 'encoded' domain"), std::string::npos)
          << error.what();
    }
  }
}

}  // namespace
}  // namespace turbid
