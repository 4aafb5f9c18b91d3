// `turbid score` end to end through the built binary.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "metrics/ssim.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {

using testing::RunTurbid;
using testing::TempDir;

cv::Mat TexturedImage(int width, int height, int channels, uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat img(height, width, CV_8UC(channels));
  rng.fill(img, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(img, img, cv::Size(0, 0), 1.5);
  return img;
}

struct Files {
  TempDir dir;
  std::string gt, blur, same, small;
  cv::Mat gt_img, blur_img;
  Files() {
    gt_img = TexturedImage(64, 48, 3, 1);
    cv::GaussianBlur(gt_img, blur_img, cv::Size(5, 5), 1.2);
    gt = dir.File("gt.png");
    blur = dir.File("blur.png");
    same = dir.File("same.png");
    small = dir.File("small.png");
    cv::imwrite(gt, gt_img);
    cv::imwrite(blur, blur_img);
    cv::imwrite(same, gt_img);
    cv::imwrite(small, TexturedImage(32, 32, 3, 2));
  }
};

TEST(ScoreCli, JsonMatchesLibraryOnRawEightBitValues) {
  Files f;
  const auto run = RunTurbid({"score", "--ref", f.gt, f.blur, f.same, "--metrics", "ssim,psnr",
                              "--json"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json doc = nlohmann::json::parse(run.out);
  ASSERT_EQ(doc.at("results").size(), 2u);
  const nlohmann::json& r = doc.at("results")[0];
  EXPECT_NEAR(r.at("ssim").get<double>(), Ssim({}, f.gt_img, f.blur_img).mean, 1e-12);
  cv::Mat diff;
  cv::absdiff(f.gt_img, f.blur_img, diff);
  diff.convertTo(diff, CV_64F);
  const cv::Scalar per_channel = cv::sum(diff.mul(diff));
  const double mse = (per_channel[0] + per_channel[1] + per_channel[2]) / (64.0 * 48 * 3);
  EXPECT_NEAR(r.at("psnr").get<double>(), 10 * std::log10(255.0 * 255.0 / mse), 1e-9);
  EXPECT_FALSE(r.contains("mse"));  // only what was asked
  EXPECT_EQ(doc.at("results")[1].at("psnr"), "inf");
  EXPECT_NEAR(doc.at("results")[1].at("ssim").get<double>(), 1.0, 1e-12);
}

TEST(ScoreCli, TableAndCsvOutputs) {
  Files f;
  const auto table = RunTurbid({"score", "--ref", f.gt, f.blur, "--metrics", "psnr,mse,cnr"});
  ASSERT_EQ(table.exit_code, 0) << table.err;
  EXPECT_NE(table.out.find("psnr"), std::string::npos);
  EXPECT_NE(table.out.find("blur.png"), std::string::npos);
  const auto csv = RunTurbid({"score", "--ref", f.gt, f.blur, f.same, "--csv"});
  ASSERT_EQ(csv.exit_code, 0) << csv.err;
  EXPECT_EQ(csv.out.substr(0, csv.out.find('\n')), "image,ssim,psnr");
  EXPECT_EQ(std::count(csv.out.begin(), csv.out.end(), '\n'), 3);
  EXPECT_NE(csv.out.find(",inf"), std::string::npos);
}

TEST(ScoreCli, BadInputsExitOneWithOneLine) {
  Files f;
  const auto mismatch = RunTurbid({"score", "--ref", f.gt, f.small});
  EXPECT_EQ(mismatch.exit_code, 1);
  EXPECT_NE(mismatch.err.find("must match"), std::string::npos) << mismatch.err;
  const auto unknown = RunTurbid({"score", "--ref", f.gt, f.blur, "--metrics", "ssim,foo"});
  EXPECT_EQ(unknown.exit_code, 1);
  EXPECT_NE(unknown.err.find("unknown metric 'foo'"), std::string::npos) << unknown.err;
  const auto no_ref = RunTurbid({"score", f.blur, "--metrics", "ssim"});
  EXPECT_EQ(no_ref.exit_code, 1);
  EXPECT_NE(no_ref.err.find("--ref"), std::string::npos) << no_ref.err;
  const auto missing = RunTurbid({"score", "--ref", f.gt, f.dir.File("nope.png")});
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find("nope.png"), std::string::npos) << missing.err;
}

TEST(ScoreCli, ManifestBatchFindsColumnsAndResolvesRelativePaths) {
  Files f;
  std::ofstream(f.dir.File("manifest.csv")) << "id,degraded,ground_truth,beta\n"
                                            << "a,blur.png,gt.png,0.1\n"
                                            << "b,same.png,gt.png,0.2\n";
  const auto run = RunTurbid({"score", "--manifest", f.dir.File("manifest.csv"), "--metrics",
                              "psnr,hautiere_e", "--json"});
  // hautiere_e needs an original: the degraded column is the scored image, so there is none.
  EXPECT_EQ(run.exit_code, 1);
  const auto ok = RunTurbid({"score", "--manifest", f.dir.File("manifest.csv"), "--json"});
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  const nlohmann::json doc = nlohmann::json::parse(ok.out);
  EXPECT_EQ(doc.at("image_column"), "degraded");
  EXPECT_EQ(doc.at("reference_column"), "ground_truth");
  ASSERT_EQ(doc.at("results").size(), 2u);
  EXPECT_EQ(doc.at("results")[0].at("image"), "a");
  EXPECT_EQ(doc.at("results")[1].at("psnr"), "inf");
  // JSON-lines manifests and explicit column names work the same way.
  std::ofstream(f.dir.File("m.jsonl")) << R"({"out":"blur.png","truth_image":"gt.png"})" << "\n";
  const auto jl = RunTurbid({"score", "--manifest", f.dir.File("m.jsonl"), "--image-column",
                             "out", "--ref-column", "truth_image", "--csv"});
  ASSERT_EQ(jl.exit_code, 0) << jl.err;
  EXPECT_NE(jl.out.find("blur.png"), std::string::npos);
}

TEST(ScoreCli, PairsReportActiveSetsPerDetector) {
  Files f;
  cv::Mat big = TexturedImage(240, 180, 1, 5);
  cv::Mat shifted;
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 6, 0, 1, 4);
  cv::warpAffine(big, shifted, shift, big.size());
  cv::imwrite(f.dir.File("p0.png"), big);
  cv::imwrite(f.dir.File("p1.png"), shifted);
  std::ofstream(f.dir.File("pairs.csv")) << "a,b\np0.png,p1.png\n";
  const auto run = RunTurbid({"score", "--pairs", f.dir.File("pairs.csv"), "--detector", "all",
                              "--json"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json doc = nlohmann::json::parse(run.out);
  ASSERT_EQ(doc.at("detectors").size(), 3u);
  for (const auto& d : doc.at("detectors")) {
    EXPECT_EQ(d.at("pairs"), 1);
    EXPECT_EQ(d.at("pairs_detail")[0].at("a").get<std::string>().find("p0.png") !=
                  std::string::npos,
              true);
  }
}

TEST(ScoreCli, ListShowsEveryMetric) {
  const auto run = RunTurbid({"score", "--list"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  for (const char* name : {"ssim", "psnr", "mse", "cnr", "hautiere_e", "uiqm", "uciqe"})
    EXPECT_NE(run.out.find(name), std::string::npos) << name;
}

TEST(ScoreCli, ReferenceFilesMatchScikitImageThroughTheCli) {
  std::string root;
  if (const char* r = std::getenv("TURBID_REFERENCE"); r && *r) root = r;
  else if (const char* d = std::getenv("TURBID_DATA"); d && *d) root = std::string(d) + "/../reference";
  const std::string dir = root + "/metrics";
  if (root.empty() || !std::filesystem::exists(dir + "/expected.json"))
    GTEST_SKIP() << "metrics reference not found (TURBID_REFERENCE / TURBID_DATA unset)";
  std::ifstream in(dir + "/expected.json");
  const nlohmann::json expected = nlohmann::json::parse(in);
  const nlohmann::json& c = expected.at("cases")[5];  // astronaut blur, colour
  const auto run = RunTurbid({"score", "--ref", dir + "/" + c.at("reference").get<std::string>(),
                              dir + "/" + c.at("image").get<std::string>(), "--metrics",
                              "ssim,psnr", "--json"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json r = nlohmann::json::parse(run.out).at("results")[0];
  EXPECT_NEAR(r.at("ssim").get<double>(), c.at("ssim_uint8_range255").get<double>(), 1e-6);
  EXPECT_NEAR(r.at("psnr").get<double>(), c.at("psnr_uint8_range255").get<double>(),
              1e-9 * c.at("psnr_uint8_range255").get<double>());
}

}  // namespace
}  // namespace turbid
