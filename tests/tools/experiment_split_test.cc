// The experiment key "split" (issue 32 item 2, docs/methods.md "Tuning and evaluation splits"):
// "tuning" | "evaluation", kept through the resolved experiment.json and written into
// protocol.json and its Markdown section; anything else is a one-line error.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "core/error.h"
#include "tests/tools/harness_fakes.h"
#include "tools/harness/experiment.h"
#include "tools/harness/protocol.h"

namespace turbid {
namespace {

using testing::FakeCatalog;
using testing::FakeExperimentJson;

TEST(ExperimentSplit, RoleIsReadKeptAndWrittenIntoTheProtocol) {
  for (const char* role : {"tuning", "evaluation"}) {
    nlohmann::json in = FakeExperimentJson();
    in["split"] = role;
    const Experiment e = ParseExperiment(in, "x.json", FakeCatalog());
    EXPECT_EQ(e.split, role);
    EXPECT_EQ(e.ToJson()["split"], role);
    EXPECT_EQ(ExperimentFromResolvedJson(e.ToJson(), "e.json").split, role);
    EXPECT_EQ(ProtocolJson(e)["split"]["role"], role);
    EXPECT_NE(ProtocolMarkdown(e).find(std::string("- split (") + role + "): "), std::string::npos)
        << ProtocolMarkdown(e);
  }
  // Not said: no key in the resolved file, null in the protocol, no role in the Markdown.
  const Experiment none = ParseExperiment(FakeExperimentJson(), "x.json", FakeCatalog());
  EXPECT_TRUE(none.split.empty());
  EXPECT_FALSE(none.ToJson().contains("split"));
  EXPECT_TRUE(ProtocolJson(none)["split"]["role"].is_null());
  EXPECT_NE(ProtocolMarkdown(none).find("- split: "), std::string::npos);
}

TEST(ExperimentSplit, OtherValuesAreOneLineErrors) {
  for (const nlohmann::json& bad : {nlohmann::json("test"), nlohmann::json(1)}) {
    nlohmann::json in = FakeExperimentJson();
    in["split"] = bad;
    try {
      ParseExperiment(in, "x.json", FakeCatalog());
      ADD_FAILURE() << "accepted split " << bad.dump();
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("x.json"), std::string::npos) << what;
      EXPECT_NE(what.find("'split'"), std::string::npos) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    }
  }
}

}  // namespace
}  // namespace turbid
