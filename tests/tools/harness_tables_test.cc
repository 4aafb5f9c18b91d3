// Summary statistics, best-value marking by metric direction, number formats and CSV quoting.
#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "tests/support/test_support.h"
#include "tests/tools/harness_fakes.h"
#include "tools/harness/tables.h"

namespace turbid {
namespace {

using testing::FakeCatalog;
using testing::ReadFileText;
using testing::TempDir;

TEST(HarnessTables, StatsIgnoreNanAndUseSampleSd) {
  const Stats s = ComputeStats({1.0, 2.0, 3.0, 4.0, std::nan("")});
  EXPECT_EQ(s.n, 4);
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_NEAR(s.sd, std::sqrt(5.0 / 3.0), 1e-15);  // closed form of the sample sd of 1..4
  EXPECT_EQ(s.min, 1.0);
  EXPECT_EQ(s.max, 4.0);
  EXPECT_EQ(ComputeStats({7.0}).sd, 0.0);
  EXPECT_EQ(ComputeStats({}).n, 0);
  EXPECT_TRUE(std::isinf(ComputeStats({1.0, HUGE_VAL}).mean));
}

TEST(HarnessTables, ValueFormatRoundTrips) {
  for (double v : {0.0, 1.5, -2.25e-7, 123456.789, HUGE_VAL, -HUGE_VAL}) {
    EXPECT_EQ(ParseValue(FormatValue(v)), v);
  }
  EXPECT_TRUE(std::isnan(ParseValue(FormatValue(std::nan("")))));
  EXPECT_THROW(ParseValue("12abc"), Error);
  EXPECT_EQ(CsvEscape("a,b"), "\"a,b\"");
  EXPECT_EQ(CsvEscape("say \"hi\""), "\"say \"\"hi\"\"\"");
  EXPECT_EQ(SplitCsvLine("x,\"a,b\",\"say \"\"hi\"\"\","),
            (std::vector<std::string>{"x", "a,b", "say \"hi\"", ""}));
}

TEST(HarnessTables, BestValueRespectsMetricDirection) {
  nlohmann::json in = testing::FakeExperimentJson();
  in.erase("samples");
  in["grid"] = {{"water.beta", {0.5, 0.6, 0.7}}};  // 2 scenes: 2 items per level, 6 in all
  in["metrics"] = {"up", "down"};
  in["methods"] = {"fake_a", "fake_b"};
  const Experiment e = ParseExperiment(in, "exp.json", FakeCatalog());
  std::vector<ItemResult> items;
  for (const ItemSpec& spec : ExpandItems(e)) {
    ItemResult item;
    item.index = spec.index;
    item.id = spec.id;
    item.level = spec.level;
    item.width = 8;
    item.height = 8;
    // none, oracle, fake_a, fake_b. oracle is best at everything but is excluded from "best".
    const double up[] = {0.1, 0.99, 0.6, 0.4};
    const double down[] = {0.9, 0.01, 0.5, 0.2};
    for (size_t m = 0; m < e.methods.size(); ++m) {
      item.methods.push_back({e.methods[m].label, {{"up", up[m]}, {"down", down[m]}}, "", 1.0});
    }
    items.push_back(item);
  }
  TempDir dir;
  WriteTables(e, items, dir.path());
  const std::string md = ReadFileText(dir.path() + "/summary.md");
  // Over all 6 items fake_a beats fake_b on every item: Wilcoxon p = 2/2^6 = 0.031 < 5 %, bold.
  EXPECT_NE(md.find("| up ↑ (encoded) | 0.1 | 0.99 | **0.6** | 0.4 | fake_a > fake_b (p = 0.031, "
                    "n = 6) |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| down ↓ (encoded) | 0.9 | 0.01 | 0.5 | **0.2** | fake_b > fake_a (p = "
                    "0.031, n = 6) |"),
            std::string::npos)
      << md;
  // Per level only 2 items: p = 0.5, no bold, "tied".
  EXPECT_NE(md.find("| up ↑ (encoded) | 0.1 | 0.99 | 0.6 | 0.4 | tied: fake_a ≈ fake_b (p = 0.5, "
                    "n = 2) |"),
            std::string::npos)
      << md;
  const std::string csv = ReadFileText(dir.path() + "/summary.csv");
  EXPECT_NE(csv.find("all,fake_a,up,encoded,6,0.6,0,0.6,0.6,0.6,0.6,0\n"), std::string::npos)
      << csv;
  EXPECT_NE(csv.find("0.5,fake_b,down,encoded,2,0.2,0,0.2,0.2,0.2,0.2,0\n"), std::string::npos)
      << csv;
}

}  // namespace
}  // namespace turbid
