// Inputs that were silent or unclear (issue 28, items 13 and 14) are one line naming the flag, the
// file or the key: numeric flags CLI11 misread ('' as 0, '0.3x', saturated or wrapped seeds),
// empty paths, seeds out of [0, 2^64 - 1], manifest rows with missing or extra fields, control
// characters in level labels, non-finite references, images too small to match, and
// out-of-memory or OpenCV failures. Every bad input below is counted in bad_inputs (the figure
// docs/reliability.md quotes; each test prints its count).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <iostream>
#include <limits>
#include <new>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "tests/support/asan.h"
#include "tests/support/test_support.h"
#include "tools/cli/cli.h"


namespace turbid {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::CliRun;
using testing::RunTurbid;
using testing::TempDir;

int bad_inputs = 0;  // counted by ExpectRefused

// Prints how many bad inputs each test tried (ctest runs each test in a process of its own).
class MessagesCli : public ::testing::Test {
 protected:
  void SetUp() override { bad_inputs = 0; }
  void TearDown() override { std::cout << "bad inputs tried: " << bad_inputs << "\n"; }
};

// The run failed with `code` and exactly one stderr line "turbid: error: ..." holding `part`.
void ExpectRefused(const CliRun& run, int code, const std::string& part) {
  ++bad_inputs;
  EXPECT_EQ(run.exit_code, code) << run.err;
  EXPECT_EQ(run.err.rfind("turbid: error: ", 0), 0u) << run.err;
  EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
  EXPECT_NE(run.err.find(part), std::string::npos) << "expected '" << part << "' in " << run.err;
}

// A PFM (float, read without decoding) of `width` x `height` gray pixels all `value`.
std::string WritePfm(const TempDir& dir, const std::string& name, int width, int height,
                     float value) {
  std::string text = "Pf\n" + std::to_string(width) + " " + std::to_string(height) + "\n-1.0\n";
  for (int i = 0; i < width * height; ++i)
    text.append(reinterpret_cast<const char*>(&value), sizeof value);
  return dir.Write(name, text);
}

std::string WritePng(const TempDir& dir, const std::string& name, int width, int height) {
  cv::Mat image(height, width, CV_8UC3);
  cv::randu(image, 0, 256);
  const std::string path = dir.File(name);
  cv::imwrite(path, image);
  return path;
}

const char* kExperiment = R"({
  "name": "messages", "seed": 5, "scale": 0.05,
  "scenes": ["builtin:hull"],
  "grid": {"water.type": ["I", "II"]},
  "methods": ["clahe"], "metrics": ["ssim"], "thumbnails": 0
})";

// kExperiment with `key` set to `value` (JSON text).
std::string ExperimentWith(const std::string& key, const std::string& value) {
  json e = json::parse(kExperiment);
  e[key] = json::parse(value);
  return e.dump();
}

TEST_F(MessagesCli, NumericFlagsTakeOnlyDecimalNumbersInRange) {
  TempDir dir;
  const std::string out = dir.File("r.png");
  const std::vector<std::string> render = {"render", "--scene", "builtin:hull", "--scale", "0.05"};
  const auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = render;
    args.insert(args.end(), extra.begin(), extra.end());
    args.insert(args.end(), {"--out", out});
    return RunTurbid(args);
  };
  // '' was beta = 0; '0.3x', hex, nan, inf, 1e999 and blanks are no numbers either.
  ExpectRefused(with({"--beta", ""}), 2, "empty value given for --beta");
  for (const std::string bad : {"0.3x", "0x1p-2", "nan", "inf", "1e999", " 0.3", "0.1,0.2,1e"})
    ExpectRefused(with({"--beta", bad}), 2, "is not a finite decimal number");
  for (const std::string bad : {"0.1,,0.3", "0.1,0.2,0.3,"})
    ExpectRefused(with({"--beta", bad}), 2, "--beta '" + bad + "': empty item");
  // Seeds: '-1' was "no seed" (the parameters' 0), 2^64 and more saturated.
  ExpectRefused(with({"--seed", ""}), 2, "empty value given for --seed");
  for (const std::string bad : {"-1", "18446744073709551616", "1.5", "010x", "0x10"})
    ExpectRefused(with({"--seed=" + bad}), 2,
                  "--seed: '" + bad + "' is not an integer in [0, 18446744073709551615]");
  ExpectRefused(with({"--scale", ""}), 2, "empty value given for --scale");
  ExpectRefused(with({"--bit-depth", "16.0"}), 2, "--bit-depth: '16.0' is not an integer");
  ExpectRefused(RunTurbid({"enhance", "-m", "clahe", "--bit-depth", "", "a.png", "b.png"}), 2,
                "empty value given for --bit-depth");
  ExpectRefused(RunTurbid({"sweep", "e.json", "--out", out, "--threads", ""}), 2,
                "empty value given for --threads");
  ExpectRefused(RunTurbid({"sweep", "e.json", "--out", out, "--threads", "2000"}), 2,
                "--threads: 2000 is not in [0, 1024]");
  ExpectRefused(RunTurbid({"generate", "g.json", "--out", out, "--threads", "4x"}), 2,
                "--threads: '4x' is not");
  ExpectRefused(RunTurbid({"score", "--manifest", "m.csv", "--threads=-3"}), 2,
                "--threads: -3 is not in [0, 1024]");
  ExpectRefused(RunTurbid({"regress", "--baseline", "b.csv", "r.csv", "--tol", "ssim="}), 2,
                "--tol 'ssim=': tolerances must be finite numbers >= 0");
  ExpectRefused(RunTurbid({"regress", "--baseline", "b.csv", "r.csv", "--tol", "ssim=0.1:nan"}), 2,
                "--tol 'ssim=0.1:nan'");
  EXPECT_FALSE(fs::exists(out));

  // The whole seed range works: 2^64 - 1 reaches the sidecar as given.
  const CliRun top = with({"--seed", "18446744073709551615"});
  ASSERT_EQ(top.exit_code, 0) << top.err;
  const json sidecar = json::parse(testing::ReadFileText(dir.File("r.json")));
  EXPECT_EQ(sidecar.at("options").at("seed").get<uint64_t>(), std::numeric_limits<uint64_t>::max())
      << sidecar.dump();
}

TEST_F(MessagesCli, EmptyPathsNameTheFlag) {
  TempDir dir;
  const std::string png = WritePng(dir, "a.png", 16, 16);
  // Each of these was "not given" (score without its reference, the default output) or
  // ": file not found".
  ExpectRefused(RunTurbid({"score", "--ref", "", png}), 2, "empty path given for --ref");
  ExpectRefused(RunTurbid({"score", "--original", "", png}), 2, "empty path given for --original");
  ExpectRefused(RunTurbid({"score", "--ref", png, ""}), 2, "empty path given for images");
  ExpectRefused(RunTurbid({"score", "--manifest", ""}), 2, "empty path given for --manifest");
  ExpectRefused(RunTurbid({"score", "--pairs", ""}), 2, "empty path given for --pairs");
  ExpectRefused(RunTurbid({"enhance", "-m", "clahe", "", dir.File("o.png")}), 2,
                "empty path given for IN");
  ExpectRefused(RunTurbid({"enhance", "-m", "clahe", png, ""}), 2, "empty path given for OUT");
  ExpectRefused(RunTurbid({"render", "--scene", "", "--out", dir.File("o.png")}), 2,
                "empty path given for --scene");
  ExpectRefused(RunTurbid({"render", "--scene", "builtin:hull", "--out", ""}), 2,
                "empty path given for --out");
  ExpectRefused(RunTurbid({"sweep", "", "--out", dir.File("s")}), 2,
                "empty path given for experiment");
  ExpectRefused(RunTurbid({"generate", "g.json", "--out", ""}), 2, "empty path given for --out");
  ExpectRefused(RunTurbid({"scene", ""}), 2, "empty path given for specs");
  ExpectRefused(RunTurbid({"regress", "--baseline", "", "r.csv"}), 2,
                "empty path given for --baseline");
  ExpectRefused(RunTurbid({"report", ""}), 2, "empty path given for dir");
  // Values that are not paths: an empty one is no silent default either.
  ExpectRefused(RunTurbid({"score", "--ref", png, png, "--metrics", ""}), 2,
                "empty value given for --metrics");
  ExpectRefused(RunTurbid({"enhance", "-m", "", png, dir.File("o.png")}), 2,
                "empty value given for --method");
  EXPECT_FALSE(fs::exists(dir.File("o.png")));
}

TEST_F(MessagesCli, SeedsOutsideTheRangeNameTheKey) {
  TempDir dir;
  const std::string range = "must be an integer in [0, 18446744073709551615]";
  for (const std::string bad : {"-1", "18446744073709551616", "1.5", "\"7\""}) {
    const std::string exp = dir.Write("e.json", ExperimentWith("seed", bad));
    ExpectRefused(RunTurbid({"sweep", exp, "--out", dir.File("s"), "--dry-run"}), 1,
                  "e.json: 'seed': " + range);
    const std::string gen =
        dir.Write("g.json", R"({"scenes": ["builtin:hull"], "scale": 0.05, "seed": )" + bad + "}");
    ExpectRefused(RunTurbid({"generate", gen, "--out", dir.File("g")}), 1,
                  "g.json: 'seed': " + range);
    const std::string params = dir.Write("p.json", R"({"seed": )" + bad + "}");
    ExpectRefused(RunTurbid({"render", "--scene", "builtin:hull", "--scale", "0.05", "--params",
                             params, "--out", dir.File("r.png")}),
                  1, "p.json: render options: 'seed': " + range);
  }
  const std::string samples = dir.Write(
      "s.json", R"({"name": "s", "scale": 0.05, "scenes": ["builtin:hull"], "methods": ["clahe"],
      "metrics": ["ssim"], "samples": {"count": 2, "seed": -4,
      "params": {"water.beta_gray_per_m": {"uniform": [0.1, 0.5]}}}})");
  ExpectRefused(RunTurbid({"sweep", samples, "--out", dir.File("s"), "--dry-run"}), 1,
                "s.json: 'samples.seed': " + range);
  // 2^63 and more are seeds like any other (the experiment reader refused them as negative).
  const std::string big = dir.Write("big.json", ExperimentWith("seed", "18446744073709551615"));
  const CliRun dry = RunTurbid({"sweep", big, "--out", dir.File("s"), "--dry-run"});
  EXPECT_EQ(dry.exit_code, 0) << dry.err;
  EXPECT_FALSE(fs::exists(dir.File("g")));
  EXPECT_FALSE(fs::exists(dir.File("r.png")));
}

TEST_F(MessagesCli, ManifestRowsWithMissingOrExtraFieldsNameTheLine) {
  TempDir dir;
  WritePng(dir, "a.png", 16, 16);
  WritePng(dir, "b.png", 16, 16);
  const auto score = [&](const std::string& name, const std::string& text) {
    return RunTurbid({"score", "--manifest", dir.Write(name, text)});
  };
  // The second row lacks its reference: it was scored without it (or against its folder).
  ExpectRefused(score("m.csv", "image,ground_truth\na.png,b.png\nb.png\n"), 1,
                "m.csv: line 3 has 1 fields, the header has 2");
  ExpectRefused(score("m.csv", "# comment\nimage,ground_truth\na.png,b.png,x\n"), 1,
                "m.csv: line 3 has 3 fields, the header has 2");
  ExpectRefused(score("m.csv", "image,ground_truth\na.png,\n"), 1,
                "m.csv: line 2: empty 'ground_truth'");
  ExpectRefused(score("m.jsonl",
                      "{\"image\": \"a.png\", \"ground_truth\": \"b.png\"}\n\n"
                      "{\"image\": \"b.png\"}\n"),
                1, "m.jsonl: line 3 has no 'ground_truth' (line 1 has");
  ExpectRefused(score("m.jsonl",
                      "{\"image\": \"a.png\", \"ground_truth\": \"b.png\"}\n"
                      "{\"image\": \"b.png\", \"ground_truth\": \"a.png\", \"gt\": \"a.png\"}\n"),
                1, "m.jsonl: line 2 has 'gt', which line 1 has not");
  ExpectRefused(score("m.jsonl", "{\"image\": \"a.png\", \"ground_truth\": \"b\\n.png\"}\n"), 1,
                "m.jsonl: line 1: column 'ground_truth' holds a control character");
  ExpectRefused(score("m.csv", "image,ground_truth\na.png,b.png\t\n"), 1,
                "m.csv: line 2: column 'ground_truth' holds a control character");
  // Well-formed (CRLF included) still scores every row against its reference.
  const CliRun good = score("m.csv", "image,ground_truth\r\na.png,b.png\r\nb.png,a.png\r\n");
  EXPECT_EQ(good.exit_code, 0) << good.err;
  EXPECT_NE(good.out.find("ssim"), std::string::npos) << good.out;
}

TEST_F(MessagesCli, ControlCharactersInLabelsAndAxisNamesAreRefused) {
  TempDir dir;
  const auto dry = [&](const std::string& text) {
    return RunTurbid({"sweep", dir.Write("e.json", text), "--out", dir.File("s"), "--dry-run"});
  };
  const std::string head =
      R"({"name": "c", "scale": 0.05, "scenes": ["builtin:hull"], "methods": ["clahe"],
      "metrics": ["ssim"], )";
  // A level label with a newline split regress's rows, summary.md and the plots.
  ExpectRefused(dry(head + R"("grid": {"water.type": ["I", "II\nx"]}})"), 1,
                R"(e.json: grid 'water.type' value "II\nx" holds a control character)");
  ExpectRefused(
      dry(head + R"("grid": {"@turbidity": [{"label": "low\r", "water.beta_gray_per_m": 0.1}]}})"),
      1, R"(grid '@turbidity' label "low\r" holds a control character)");
  ExpectRefused(dry(head + R"("grid": {"@turb\tidity": [{"water.beta_gray_per_m": 0.1}]}})"), 1,
                R"(e.json: grid axis "@turb\tidity" holds a control character)");
  ExpectRefused(dry(head + R"("grid": {"@t": [{"water.beta_gray_per_m\n": 0.1}]}})"), 1,
                R"(grid '@t' key "water.beta_gray_per_m\n" holds a control character)");
  ExpectRefused(dry(head + R"("samples": {"count": 2, "params": {"water.type":
      {"choice": ["I", "3C\u001b[31m"]}}}})"),
                1, R"(samples param 'water.type' choice "3C\u001b[31m" holds a control)");
  ExpectRefused(dry(head + R"("samples": {"count": 2, "params": {"water.beta\n": {"uniform": [0.1,
      0.2]}}}})"),
                1, R"(e.json: samples param "water.beta\n" holds a control character)");
  EXPECT_FALSE(fs::exists(dir.File("s")));
}

TEST_F(MessagesCli, NonFiniteImagesAreNamedByTheirOwnFile) {
  TempDir dir;
  const std::string nan = WritePfm(dir, "nan.pfm", 16, 16, std::nanf(""));
  const std::string inf = WritePfm(dir, "inf.pfm", 16, 16, INFINITY);
  const std::string ok = WritePfm(dir, "ok.pfm", 16, 16, 0.5f);
  // The reference holds the NaN: the message named ok.pfm ("reference: non-finite").
  ExpectRefused(RunTurbid({"score", "--ref", nan, ok}), 1, "nan.pfm: non-finite pixel value");
  ExpectRefused(RunTurbid({"score", "--ref", ok, inf}), 1, "inf.pfm:");
  ExpectRefused(RunTurbid({"score", "--original", inf, ok, "--metrics", "hautiere_e"}), 1,
                "inf.pfm: non-finite pixel value");
  ExpectRefused(RunTurbid({"score", "--manifest",
                           dir.Write("m.csv", "image,ground_truth\nok.pfm,nan.pfm\n")}),
                1, "nan.pfm: non-finite pixel value");
  const CliRun run = RunTurbid({"score", "--ref", nan, ok});
  EXPECT_EQ(run.err.find("ok.pfm"), std::string::npos) << run.err;
}

TEST_F(MessagesCli, ImagesTooSmallForAMetricOrMatchingAreOneLine) {
  TempDir dir;
  const std::string tiny = WritePng(dir, "tiny.png", 1, 1);
  const std::string other = WritePng(dir, "other.png", 1, 1);
  const std::string big = WritePng(dir, "big.png", 64, 64);
  dir.Write("pairs.txt", "tiny.png,other.png\n");
  // Was a raw OpenCV assertion over several lines.
  for (const std::string detector : {"orb", "akaze", "all"})
    ExpectRefused(RunTurbid({"score", "--pairs", dir.File("pairs.txt"), "--detector", detector}), 1,
                  "tiny.png: image is 1x1, feature matching with ");
  dir.Write("pairs2.txt", "big.png,tiny.png\n");
  ExpectRefused(RunTurbid({"score", "--pairs", dir.File("pairs2.txt")}), 1,
                "tiny.png: image is 1x1, feature matching with orb needs at least 2x2 pixels");
  // SIFT takes any size (it finds no keypoint in one pixel).
  const CliRun sift =
      RunTurbid({"score", "--pairs", dir.File("pairs.txt"), "--detector", "sift", "--csv"});
  EXPECT_EQ(sift.exit_code, 0) << sift.err;
  // Metrics with a window or blocks name the file and the size they need; the others score it.
  const std::vector<std::string> scored = {"--ref", other, "--original", other, tiny, "--metrics"};
  const auto score = [&](const std::string& metric) {
    std::vector<std::string> args = {"score"};
    args.insert(args.end(), scored.begin(), scored.end());
    args.push_back(metric);
    return RunTurbid(args);
  };
  ExpectRefused(score("ssim"), 1,
                "tiny.png: ssim: image is 1x1 but the Gaussian window needs at least 11x11 pixels");
  for (const std::string metric : {"uiqm", "uicm", "uiqm_corrected"})
    ExpectRefused(score(metric), 1, "tiny.png: uiqm: image 1x1 is smaller than one 10-pixel block");
  for (const std::string metric : {"psnr", "mse", "cnr", "uciqe", "hautiere_e", "hautiere_r"}) {
    const CliRun run = score(metric);
    EXPECT_EQ(run.exit_code, 0) << metric << ": " << run.err;
  }
}

TEST_F(MessagesCli, OutOfMemoryIsOneLineNamingTheFile) {
#ifdef TURBID_TEST_ASAN
  GTEST_SKIP() << "ulimit -v and AddressSanitizer do not mix";
#endif
  TempDir dir;
  // A 6000x6000 image (36 Mpixel, under TURBID_MAX_PIXELS) under a 600 MB address-space limit:
  // decoding it to float RGB (432 MB) and enhancing it need more than the limit leaves. Was
  // OpenCV's "Failed to allocate" over several lines, or std::bad_alloc's what().
  cv::Mat big(6000, 6000, CV_8UC1, cv::Scalar(100));
  const std::string path = dir.File("big.png");
  cv::imwrite(path, big);
  const char* bin = std::getenv("TURBID_BIN");
  ASSERT_NE(bin, nullptr);
  const std::string command = "ulimit -v 600000; '" + std::string(bin) + "' enhance -m clahe '" +
                              path + "' '" + dir.File("o.png") + "' 2>'" + dir.File("err") +
                              "' >/dev/null";
  const int status = std::system(("bash -c \"" + command + "\"").c_str());
  CliRun run;
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  run.err = testing::ReadFileText(dir.File("err"));
  ExpectRefused(run, 1, "big.png: out of memory while ");
}

// The dispatcher itself: what a command throws becomes one line, with the command's name.
int RunThrowing(const std::function<void()>& body, std::string* err) {
  CLI::App app{"test"};
  app.add_subcommand("boom", "throws")->callback(body);
  const char* argv[] = {"turbid", "boom"};
  ::testing::internal::CaptureStderr();
  const int code = RunApp(app, 2, argv);
  *err = ::testing::internal::GetCapturedStderr();
  return code;
}

TEST_F(MessagesCli, DispatcherTurnsBadAllocAndOpenCvErrorsIntoOneLine) {
  std::string err;
  EXPECT_EQ(RunThrowing([] { throw std::bad_alloc(); }, &err), 1);
  EXPECT_EQ(err,
            "turbid: error: out of memory while running 'turbid boom' (try smaller inputs, "
            "a smaller --scale or fewer --threads)\n");
  ++bad_inputs;
  EXPECT_EQ(RunThrowing([] { CV_Assert(1 + 1 == 3); }, &err), 1);
  EXPECT_EQ(err.rfind("turbid: error: turbid boom: OpenCV error in ", 0), 0u) << err;
  EXPECT_NE(err.find("1 + 1 == 3"), std::string::npos) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  ++bad_inputs;
  EXPECT_EQ(RunThrowing([] { throw Error("a\nb.png", "two\nlines"); }, &err), 1);
  EXPECT_EQ(err, "turbid: error: a b.png: two lines\n");
  ++bad_inputs;
  // CLI11's own usage errors are one line too, and still exit 2.
  const CliRun unknown = RunTurbid({"score", "--no-such-flag"});
  ExpectRefused(unknown, 2, "--no-such-flag");
}

}  // namespace
}  // namespace turbid
