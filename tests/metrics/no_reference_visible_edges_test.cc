// Visible-edge indicators (e, r̄, σ): every hautiere_* entry of the reference folder
// reference/metrics-nr/expected.json (published IFSTTAR code run in Octave), the paper variant
// against the reference's documented "intended"/"==255" values, the fast window search against a
// direct transcription of the published triple loop, and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <random>
#include <regex>
#include <string>

#include "metrics/no_reference.h"
#include "core/error.h"
#include "scenes/image_io.h"

namespace turbid {
namespace {
namespace fs = std::filesystem;

// reference/metrics-nr from $TURBID_REFERENCE, else "$TURBID_DATA/../reference".
std::optional<fs::path> NrReferenceDir() {
  fs::path base;
  if (const char* ref = std::getenv("TURBID_REFERENCE"); ref && *ref) {
    base = ref;
  } else if (const char* data = std::getenv("TURBID_DATA"); data && *data) {
    base = fs::path(data) / ".." / "reference";
  } else {
    return std::nullopt;
  }
  std::error_code ec;
  if (!fs::is_regular_file(base / "metrics-nr" / "expected.json", ec)) return std::nullopt;
  return base / "metrics-nr";
}

#define REQUIRE_NR_REFERENCE(var)                                                          \
  const auto var##_opt = NrReferenceDir();                                                 \
  if (!var##_opt)                                                                          \
    GTEST_SKIP() << "reference/metrics-nr not found: set TURBID_REFERENCE or TURBID_DATA " \
                    "(reference = $TURBID_DATA/../reference); skipping";                   \
  const fs::path var = *var##_opt

nlohmann::json LoadExpected(const fs::path& dir) {
  std::ifstream in(dir / "expected.json");
  return nlohmann::json::parse(in);
}

cv::Mat Read8(const fs::path& path) {
  cv::Mat image = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  if (image.empty()) throw Error(path.string(), "cannot read");
  if (image.channels() == 4) cv::cvtColor(image, image, cv::COLOR_BGRA2BGR);
  return image;
}

// The number after `prefix` in an entry's notes.
std::optional<double> NoteValue(const std::string& notes, const std::string& prefix) {
  const size_t at = notes.find(prefix);
  if (at == std::string::npos) return std::nullopt;
  return std::stod(notes.substr(at + prefix.size()));
}

// Tolerances. e and σ are ratios of integer counts: the same counts give the same double, so 1e-15
// relative only absorbs the last bit of the printed decimal. r̄ sums ~2000 logs; the reference
// README measured a 1-ulp spread between ports from log/exp/summation order: 1e-12 relative.
constexpr double kCountTolerance = 1e-15;
constexpr double kRatioTolerance = 1e-12;

void ExpectRelative(double actual, double expected, double tolerance, const std::string& what) {
  const double scale = std::max(std::abs(expected), 1e-300);
  if (expected == 0.0) {
    EXPECT_EQ(actual, 0.0) << what;
  } else {
    EXPECT_LE(std::abs(actual - expected) / scale, tolerance)
        << what << ": got " << actual << " expected " << expected;
  }
}

struct HautiereEntry {
  std::string id, metric, original, restored, original_gray, restored_gray, notes;
  double value;
};

std::vector<HautiereEntry> HautiereEntries(const nlohmann::json& all) {
  std::vector<HautiereEntry> out;
  for (const auto& e : all) {
    const std::string metric = e.at("metric");
    if (metric.rfind("hautiere_", 0) != 0) continue;
    HautiereEntry h;
    h.id = e.value("id", "");
    h.metric = metric;
    h.original = e.at("original");
    h.restored = e.at("restored");
    h.original_gray = e.value("original_gray", "");
    h.restored_gray = e.value("restored_gray", "");
    h.notes = e.value("notes", "");
    h.value = e.at("value").get<double>();
    out.push_back(h);
  }
  return out;
}

double Pick(const VisibleEdgeResult& r, const std::string& metric) {
  if (metric == "hautiere_e") return r.e;
  if (metric == "hautiere_r") return r.r_mean;
  if (metric == "hautiere_sigma") return r.sigma;
  ADD_FAILURE() << "unknown metric " << metric;
  return 0;
}

double Tolerance(const std::string& metric) {
  return metric == "hautiere_r" ? kRatioTolerance : kCountTolerance;
}

VisibleEdgeOptions Ifsttar() {
  VisibleEdgeOptions o;
  o.variant = VisibleEdgeVariant::kIfsttar;
  return o;
}

TEST(NoReferenceVisibleEdges, DefaultsPassCheck) {
  std::string why;
  EXPECT_TRUE(VisibleEdgeOptions{}.Check(&why)) << why;
  EXPECT_EQ(VisibleEdgeOptions{}.variant, VisibleEdgeVariant::kPaper);
  EXPECT_TRUE(Ifsttar().Check(&why)) << why;
}

TEST(NoReferenceVisibleEdges, BadOptionsAndNames) {
  VisibleEdgeOptions o;
  std::string why;
  o.visibility_threshold = 0.0;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("visibility_threshold"), std::string::npos);
  o.visibility_threshold = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(o.Check(&why));
  const cv::Mat img(8, 8, CV_8UC1, cv::Scalar(10));
  EXPECT_THROW(VisibleEdges(o, img, img), Error);
  EXPECT_EQ(ParseVisibleEdgeVariant("ifsttar"), VisibleEdgeVariant::kIfsttar);
  EXPECT_EQ(ParseVisibleEdgeVariant("paper"), VisibleEdgeVariant::kPaper);
  EXPECT_EQ(VisibleEdgeVariantName(VisibleEdgeVariant::kIfsttar), "ifsttar");
  EXPECT_THROW(ParseVisibleEdgeVariant("matlab"), Error);
}

// Every hautiere_* entry: the ifsttar variant from the reference's own gray images (the exact
// arrays the Octave code saw) and from the original files through our RGB→gray path.
TEST(NoReferenceVisibleEdges, IfsttarMatchesPublishedCode) {
  REQUIRE_NR_REFERENCE(dir);
  const auto entries = HautiereEntries(LoadExpected(dir));
  ASSERT_EQ(entries.size(), 18u);
  for (const auto& h : entries) {
    ASSERT_EQ(h.original.rfind("../", 0), std::string::npos) << "pairs are local files";
    const std::string what = h.id + " " + h.metric;
    const cv::Mat original = Read8(dir / h.original);
    const cv::Mat restored = Read8(dir / h.restored);
    const VisibleEdgeResult from_files = VisibleEdges(Ifsttar(), original, restored);
    ExpectRelative(Pick(from_files, h.metric), h.value, Tolerance(h.metric), what + " (files)");
    if (!h.original_gray.empty()) {
      const VisibleEdgeResult from_gray =
          VisibleEdges(Ifsttar(), Read8(dir / h.original_gray), Read8(dir / h.restored_gray));
      ExpectRelative(Pick(from_gray, h.metric), h.value, Tolerance(h.metric),
                     what + " (octave gray)");
    }
    if (h.metric == "hautiere_sigma") continue;
    // Edge counts the reference reports (from its bit-exact port).
    const std::regex counts("restored (\\d+), original (\\d+); finite log-ratio terms (\\d+)");
    std::smatch m;
    ASSERT_TRUE(std::regex_search(h.notes, m, counts)) << what;
    EXPECT_EQ(from_files.visible_restored, std::stoll(m[1])) << what;
    EXPECT_EQ(from_files.visible_original, std::stoll(m[2])) << what;
    EXPECT_EQ(from_files.finite_log_ratios, std::stoll(m[3])) << what;
  }
}

// Float32 [0,1] input (the turbid in-memory convention) gives the same numbers as 8-bit input.
TEST(NoReferenceVisibleEdges, FloatInputMatchesEightBit) {
  REQUIRE_NR_REFERENCE(dir);
  const cv::Mat o8 = Read8(dir / "astronaut_c__haze.png");
  const cv::Mat r8 = Read8(dir / "astronaut_c__haze_stretch.png");
  const cv::Mat of = ReadImage((dir / "astronaut_c__haze.png").string());
  const cv::Mat rf = ReadImage((dir / "astronaut_c__haze_stretch.png").string());
  ASSERT_EQ(of.depth(), CV_32F);
  for (auto variant : {VisibleEdgeVariant::kPaper, VisibleEdgeVariant::kIfsttar}) {
    VisibleEdgeOptions o;
    o.variant = variant;
    const auto a = VisibleEdges(o, o8, r8);
    const auto b = VisibleEdges(o, of, rf);
    EXPECT_EQ(a.e, b.e);
    EXPECT_EQ(a.r_mean, b.r_mean);
    EXPECT_EQ(a.sigma, b.sigma);
  }
}

// Our Octave rgb2gray reproduces the gray images the reference fed to the MATLAB code, pixel for
// pixel.
TEST(NoReferenceVisibleEdges, OctaveRgbToGrayMatchesReferenceGray) {
  REQUIRE_NR_REFERENCE(dir);
  int compared = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    const std::string suffix = "__octave_gray.png";
    if (name.size() <= suffix.size() || name.substr(name.size() - suffix.size()) != suffix) {
      continue;
    }
    const std::string colour = name.substr(0, name.size() - suffix.size()) + ".png";
    const cv::Mat expected = Read8(dir / name);
    const cv::Mat ours = OctaveRgbToGray(Read8(dir / colour));
    ASSERT_EQ(expected.type(), CV_8UC1) << name;
    EXPECT_EQ(cv::countNonZero(expected != ours), 0) << name;
    ++compared;
  }
  EXPECT_GE(compared, 3);
}

// The paper variant against the values the reference README gives for the "intended" algorithm
// (min/max over the same pixel pair, no shift, `==255`), computed by its verified NumPy port.
// e and σ are counts (exact); r̄ is quoted in the README to 4-5 significant digits only.
TEST(NoReferenceVisibleEdges, PaperVariantMatchesIntendedAlgorithm) {
  REQUIRE_NR_REFERENCE(dir);
  const auto entries = HautiereEntries(LoadExpected(dir));
  int checked = 0;
  for (const auto& h : entries) {
    const auto paper = VisibleEdges({}, Read8(dir / h.original), Read8(dir / h.restored));
    if (h.metric == "hautiere_e") {
      const auto intended = NoteValue(h.notes, "over the same pixel pair) ");
      ASSERT_TRUE(intended) << h.id;
      ExpectRelative(paper.e, *intended, kCountTolerance, h.id + " paper e");
      ++checked;
    } else if (h.metric == "hautiere_sigma") {
      const auto fixed = NoteValue(h.notes, "'==255' test would give ");
      ASSERT_TRUE(fixed) << h.id;
      ExpectRelative(paper.sigma, *fixed, kCountTolerance, h.id + " paper sigma");
      ++checked;
    }
    if (h.id == "ve01") {
      EXPECT_NEAR(paper.r_mean, 2.2220, 5e-5);
    }
    if (h.id == "ve06") {
      EXPECT_NEAR(paper.r_mean, 2.794, 5e-4);
      EXPECT_NEAR(paper.sigma, 0.0916, 5e-5);
    }
  }
  EXPECT_EQ(checked, 12);
}

// Straight transcription of the published window loop (explicit threshold loop and Fcube), on
// small random images: the interval/accumulation search must give the same mask, both variants.
cv::Mat SlowMask(VisibleEdgeVariant variant, const cv::Mat& gray) {
  const int nl = gray.rows, nc = gray.cols, S = 7;
  auto refl = [](int i, int n) {
    if (n == 1) return 0;
    int k = ((i % (2 * n)) + 2 * n) % (2 * n);
    return k < n ? k : 2 * n - 1 - k;
  };
  auto I = [&](int i, int j) { return gray.at<double>(refl(i, nl), refl(j, nc)); };
  // Pair-test maps defined in image coordinates and mirrored like an image beyond the border (the
  // code pads the maps, not the image, before the window loop).
  auto gmin = [&](int i, int j) {
    i = refl(i, nl), j = refl(j, nc);
    if (variant == VisibleEdgeVariant::kPaper) return std::min(I(i, j), I(i, j - 1));
    return std::min(I(i - 1, j - 2), I(i - 1, j - 1));
  };
  auto gmax = [&](int i, int j) {
    i = refl(i, nl), j = refl(j, nc);
    if (variant == VisibleEdgeVariant::kPaper) return std::max(I(i, j), I(i, j - 1));
    return std::max(I(i - 1, j - 1), I(i - 1, j));
  };
  auto hmin = [&](int i, int j) {
    i = refl(i, nl), j = refl(j, nc);
    if (variant == VisibleEdgeVariant::kPaper) return std::min(I(i, j), I(i - 1, j));
    return std::min(I(i - 2, j - 1), I(i - 1, j - 1));
  };
  auto hmax = [&](int i, int j) {
    i = refl(i, nl), j = refl(j, nc);
    if (variant == VisibleEdgeVariant::kPaper) return std::max(I(i, j), I(i - 1, j));
    return std::max(I(i - 1, j - 1), I(i, j - 1));
  };
  cv::Mat mask = cv::Mat::zeros(nl + S, nc + S, CV_8UC1);
  for (int ii = 0; ii < nl; ii += 4) {
    for (int jj = 0; jj < nc; jj += 4) {
      double lo = 1e9, hi = -1e9;
      for (int a = 0; a < S; ++a) {
        for (int b = 0; b < S; ++b) {
          lo = std::min(lo, I(ii + a, jj + b));
          hi = std::max(hi, I(ii + a, jj + b));
        }
      }
      int smin = std::clamp(static_cast<int>(std::round(lo)), 1, 256);
      int smax = std::clamp(static_cast<int>(std::round(hi)), 1, 256);
      std::vector<double> C(smax + 1, 0.0);
      std::vector<cv::Mat> cube;
      for (int s = smin; s <= smax; ++s) {
        cv::Mat f = cv::Mat::zeros(S, S, CV_8UC1);
        int F = 0;
        double sg = 0, sh = 0;
        for (int nn = 1; nn < S; ++nn) {
          for (int mm = 1; mm < S; ++mm) {
            const int i = ii + nn, j = jj + mm;
            auto w = [&](double v) { return std::abs(s - v) / std::max<double>(s, v); };
            if (gmin(i, j) <= s && gmax(i, j) > s) {
              sg += std::min(w(I(i, j)), w(I(i, j - 1)));
              ++F;
              f.at<uint8_t>(nn, mm) = f.at<uint8_t>(nn, mm - 1) = 1;
            }
            if (hmin(i, j) <= s && hmax(i, j) > s) {
              sh += std::min(w(I(i, j)), w(I(i - 1, j)));
              ++F;
              f.at<uint8_t>(nn, mm) = f.at<uint8_t>(nn - 1, mm) = 1;
            }
          }
        }
        if (F > 0) C[s] = (1.0 / F) * (sg + sh);
        cube.push_back(f);
      }
      int s0 = 1;
      for (int s = 1; s <= smax; ++s) {
        if (C[s] > C[s0]) s0 = s;
      }
      s0 = std::max(s0, smin);
      if (C[s0] > 0.025) {
        cv::Mat roi = mask(cv::Rect(jj, ii, S, S));
        roi.setTo(255, cube[s0 - smin]);
      }
    }
  }
  return mask(cv::Rect(0, 0, nc, nl)).clone();
}

TEST(NoReferenceVisibleEdges, FastSearchEqualsPublishedLoop) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 12; ++trial) {
    const int rows = 5 + static_cast<int>(rng() % 30), cols = 5 + static_cast<int>(rng() % 30);
    cv::Mat gray(rows, cols, CV_64F);
    // Smooth gradient + blocky edges + noise: many windows near the 2.5 % decision.
    const int levels = trial % 3 == 0 ? 256 : 24;
    for (int i = 0; i < rows; ++i)
      for (int j = 0; j < cols; ++j)
        gray.at<double>(i, j) = std::clamp<int>(
            static_cast<int>(3 * i + ((j / 5) % 2) * (trial * 9) + rng() % levels), 0, 255);
    for (auto variant : {VisibleEdgeVariant::kPaper, VisibleEdgeVariant::kIfsttar}) {
      VisibleEdgeOptions o;
      o.variant = variant;
      const cv::Mat fast = VisibleEdgeMask(o, gray);
      const cv::Mat slow = SlowMask(variant, gray);
      EXPECT_EQ(cv::countNonZero(fast != slow), 0)
          << "trial " << trial << " variant " << VisibleEdgeVariantName(variant);
    }
  }
}

TEST(NoReferenceVisibleEdges, IdenticalImagesGiveNoChange) {
  cv::Mat img(40, 50, CV_8UC1);
  for (int i = 0; i < img.rows; ++i)
    for (int j = 0; j < img.cols; ++j)
      img.at<uint8_t>(i, j) = static_cast<uint8_t>((i * 7 + j * 13) % 200 + 20);
  for (auto variant : {VisibleEdgeVariant::kPaper, VisibleEdgeVariant::kIfsttar}) {
    VisibleEdgeOptions o;
    o.variant = variant;
    const auto r = VisibleEdges(o, img, img);
    EXPECT_GT(r.visible_original, 0);
    EXPECT_EQ(r.e, 0.0);
    EXPECT_DOUBLE_EQ(r.r_mean, 1.0);
    EXPECT_EQ(r.sigma, 0.0);
  }
}

// Saturation: ifsttar counts only black (its `== 256` never matches 8-bit data), paper both.
TEST(NoReferenceVisibleEdges, SaturationCounting) {
  cv::Mat original(20, 20, CV_8UC1, cv::Scalar(100));
  cv::Mat restored = original.clone();
  restored(cv::Rect(0, 0, 20, 2)).setTo(0);     // 40 black
  restored(cv::Rect(0, 10, 20, 3)).setTo(255);  // 60 white
  const auto paper = VisibleEdges({}, original, restored);
  const auto ifsttar = VisibleEdges(Ifsttar(), original, restored);
  EXPECT_EQ(paper.black_pixels, 40);
  EXPECT_EQ(paper.white_pixels, 60);
  EXPECT_DOUBLE_EQ(paper.sigma, 100.0 / 400.0);
  EXPECT_DOUBLE_EQ(ifsttar.sigma, 40.0 / 400.0);
  EXPECT_DOUBLE_EQ(paper.m, 40.0 / 400.0);
}

// A flat original has no visible edge: e is +inf (n_o = 0), NaN when neither image has any;
// r̄ is NaN when the restored image has no visible edge. The JSON writes them as strings.
TEST(NoReferenceVisibleEdges, UndefinedRatiosFollowIeee) {
  const cv::Mat flat(24, 24, CV_8UC1, cv::Scalar(90));
  cv::Mat edges = flat.clone();
  edges(cv::Rect(0, 0, 12, 24)).setTo(200);
  const auto new_edges = VisibleEdges({}, flat, edges);
  EXPECT_GT(new_edges.visible_restored, 0);
  EXPECT_TRUE(std::isinf(new_edges.e) && new_edges.e > 0);
  // Gradients of the flat original are 0: every log ratio is non-finite and dropped, so r̄ = 1.
  EXPECT_EQ(new_edges.finite_log_ratios, 0);
  EXPECT_EQ(new_edges.r_mean, 1.0);
  const auto none = VisibleEdges({}, flat, flat);
  EXPECT_TRUE(std::isnan(none.e));
  EXPECT_TRUE(std::isnan(none.r_mean));
  const auto json = none.ToJson();
  EXPECT_EQ(json.at("e"), "nan");
  EXPECT_EQ(new_edges.ToJson().at("e"), "inf");
  EXPECT_EQ(json.at("variant"), "paper");
}

TEST(NoReferenceVisibleEdges, BadInputThrows) {
  const cv::Mat a(10, 12, CV_8UC1, cv::Scalar(50));
  const cv::Mat b(10, 13, CV_8UC1, cv::Scalar(50));
  EXPECT_THROW(VisibleEdges({}, a, b), Error);
  EXPECT_THROW(VisibleEdges({}, cv::Mat(), a), Error);
  cv::Mat nan_img(10, 12, CV_32FC1, cv::Scalar(0.5));
  nan_img.at<float>(3, 3) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(VisibleEdges({}, a, nan_img), Error);
  EXPECT_THROW(VisibleEdges({}, a, cv::Mat(10, 12, CV_16UC1, cv::Scalar(0))), Error);
  EXPECT_THROW(VisibleEdges({}, a, cv::Mat(10, 12, CV_8UC2, cv::Scalar(0))), Error);
  try {
    VisibleEdges({}, a, b);
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("12x10"), std::string::npos) << e.what();
  }
}

// Tiny images (smaller than a window) use the mirrored padding without reading out of bounds.
TEST(NoReferenceVisibleEdges, TinyImages) {
  for (auto size : {cv::Size(1, 1), cv::Size(2, 3), cv::Size(7, 1)}) {
    cv::Mat a(size, CV_8UC1), b(size, CV_8UC1);
    cv::randu(a, 0, 255);
    cv::randu(b, 0, 255);
    for (auto variant : {VisibleEdgeVariant::kPaper, VisibleEdgeVariant::kIfsttar}) {
      VisibleEdgeOptions o;
      o.variant = variant;
      const auto r = VisibleEdges(o, a, b);
      EXPECT_LE(r.visible_restored, r.pixels);
      EXPECT_GE(r.sigma, 0.0);
    }
  }
}

}  // namespace
}  // namespace turbid
