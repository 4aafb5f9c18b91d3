// What an experiment or scene file may make turbid do (docs/reliability.md, threat model): its
// external commands run only with --allow-commands; names from data never steer a write outside
// --out or make two outputs one file; clean-up never follows a symbolic link.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/atomic_file.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;
using testing::CliRun;
using testing::ReadFileText;
using testing::RunTurbid;
using testing::TempDir;

bool OneLine(const std::string& text) {
  return !text.empty() && text.find('\n') == text.size() - 1;
}

// One tiny item (hull at scale 0.1, one turbidity), clahe plus `methods`.
std::string TinyExperiment(const std::string& methods, const std::string& extra = "") {
  return R"({
  "name": "trust",
  "seed": 3,
  "scale": 0.1,
  "scenes": ["builtin:hull"],
  "grid": {"water.beta_gray_per_m": [0.4]},
  "methods": ["clahe")" +
         (methods.empty() ? "" : ", " + methods) + R"(],
  "metrics": ["psnr"],)" +
         extra +
         R"(
  "thumbnails": 32
})";
}

// A command method that leaves `marker` when it runs, with an environment to show.
std::string Toucher(const std::string& marker) {
  return R"({"name": "toucher", "command": ["touch", ")" + marker +
         R"(", "{input}", "{output}"], "env": {"LD_PRELOAD": "/nonexistent/evil.so"}})";
}

// ---- item 2: external commands need --allow-commands ------------------------------------------

TEST(TrustCli, CommandMethodsRefusedUpFrontWithoutAllowCommands) {
  TempDir dir;
  const std::string marker = dir.File("ran");
  const std::string exp = dir.Write("exp.json", TinyExperiment(Toucher(marker)));
  const std::string out = dir.File("out");
  const CliRun run = RunTurbid({"sweep", exp, "--out", out});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_TRUE(OneLine(run.err)) << run.err;
  EXPECT_NE(run.err.find("method 'toucher'"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("--allow-commands"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(marker));
  EXPECT_FALSE(fs::exists(out)) << "the output folder was created before the refusal";
  // bench --sweep runs sweeps too.
  const CliRun bench = RunTurbid({"bench", "--sweep", exp, "--out", dir.File("bench")});
  EXPECT_EQ(bench.exit_code, 1);
  EXPECT_NE(bench.err.find("--allow-commands"), std::string::npos) << bench.err;
  EXPECT_FALSE(fs::exists(marker));
  EXPECT_FALSE(fs::exists(dir.File("bench")));
}

TEST(TrustCli, ExperimentFileCannotAllowItsOwnCommands) {
  TempDir dir;
  const std::string marker = dir.File("ran");
  for (const std::string& extra : {std::string("\n  \"allow_commands\": true,"),
                                   std::string("\n  \"allow-commands\": true,")}) {
    const std::string exp = dir.Write("exp.json", TinyExperiment(Toucher(marker), extra));
    const CliRun run = RunTurbid({"sweep", exp, "--out", dir.File("out")});
    EXPECT_EQ(run.exit_code, 1) << extra;
    EXPECT_FALSE(fs::exists(marker)) << extra;
    EXPECT_FALSE(fs::exists(dir.File("out"))) << extra;
  }
}

TEST(TrustCli, DryRunListsEveryCommandAndItsEnvironment) {
  TempDir dir;
  const std::string marker = dir.File("ran");
  const std::string exp = dir.Write(
      "exp.json",
      TinyExperiment(Toucher(marker) +
                     R"(, {"name": "batcher", "command": ["python3", "-c", "x\ny", "{input_dir}",
                        "{output_dir}"], "batch": true, "batch_size": 4, "cwd": "/tmp"})"));
  // Without the flag: the commands are listed and the dry run fails as the sweep would.
  const CliRun refused = RunTurbid({"sweep", exp, "--out", dir.File("out"), "--dry-run"});
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_NE(refused.out.find("needs --allow-commands"), std::string::npos) << refused.out;
  EXPECT_NE(refused.err.find("--allow-commands"), std::string::npos) << refused.err;
  for (const CliRun& run : {refused, RunTurbid({"sweep", exp, "--out", dir.File("out"), "--dry-run",
                                                "--allow-commands"})}) {
    EXPECT_NE(run.out.find("method 'toucher' (one process per image): command [\"touch\",\"" +
                           marker + "\",\"{input}\",\"{output}\"]"),
              std::string::npos)
        << run.out;
    EXPECT_NE(run.out.find("env {\"LD_PRELOAD\":\"/nonexistent/evil.so\"}"), std::string::npos)
        << run.out;
    // A newline in an argument is shown escaped: one line per method.
    EXPECT_NE(run.out.find("method 'batcher' (one process per batch of up to 4 items): command "
                           "[\"python3\",\"-c\",\"x\\ny\""),
              std::string::npos)
        << run.out;
    EXPECT_NE(run.out.find("cwd \"/tmp\""), std::string::npos) << run.out;
  }
  const CliRun allowed =
      RunTurbid({"sweep", exp, "--out", dir.File("out"), "--dry-run", "--allow-commands"});
  EXPECT_EQ(allowed.exit_code, 0) << allowed.err;
  EXPECT_NE(allowed.out.find("trust: valid;"), std::string::npos) << allowed.out;
  EXPECT_FALSE(fs::exists(marker));
  EXPECT_FALSE(fs::exists(dir.File("out")));
}

TEST(TrustCli, AllowCommandsRunsThem) {
  TempDir dir;
  const std::string marker = dir.File("ran");
  const std::string exp = dir.Write("exp.json", TinyExperiment(Toucher(marker)));
  const CliRun run = RunTurbid({"sweep", exp, "--out", dir.File("out"), "--allow-commands"});
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(fs::exists(marker));
  // Results methods run nothing: no flag needed.
  const std::string results =
      dir.Write("results.json", TinyExperiment(R"({"name": "theirs", "results": "r/{id}.png"})"));
  EXPECT_EQ(RunTurbid({"sweep", results, "--out", dir.File("out2")}).exit_code, 0);
}

// ---- item 3: names from data stay one file name inside --out ---------------------------------

std::string SceneFile(const std::string& name) {
  return R"({"type": "builtin", "builtin": "room", "scale": 0.1, "name": )" + name + "}";
}

TEST(TrustCli, SceneNamesThatAreNotOneFileNameAreRefused) {
  TempDir dir;
  fs::create_directories(dir.File("a/b"));
  const std::vector<std::string> bad = {R"("../../escaped")",
                                        R"("a/../../escaped")",
                                        "\"" + dir.File("escaped") + "\"",
                                        R"("..")",
                                        R"(".")",
                                        R"(".hidden")",
                                        R"("")",
                                        R"("tab\there")",
                                        R"("nul\u0000x")",
                                        R"("back\\slash")"};
  for (const std::string& name : bad) {
    const std::string scene = dir.Write("a/b/scene.json", SceneFile(name));
    const CliRun run = RunTurbid({"scene", scene, "--out", dir.File("a/b/out")});
    EXPECT_EQ(run.exit_code, 1) << name;
    EXPECT_TRUE(OneLine(run.err)) << name << " -> " << run.err;
    EXPECT_NE(run.err.find("scene name"), std::string::npos) << name << " -> " << run.err;
    EXPECT_FALSE(fs::exists(dir.File("a/b/out"))) << name;
    EXPECT_FALSE(fs::exists(dir.File("escaped"))) << name;
    EXPECT_FALSE(fs::exists(dir.File("a/escaped"))) << name;
    // generate: the degraded image and its ground truth must never be one file.
    const std::string config =
        dir.Write("a/b/gen.json", R"({"scenes": [")" + dir.File("a/b/scene.json") +
                                      R"("], "grid": {"water.beta_gray_per_m": [0.5]}})");
    const CliRun gen = RunTurbid({"generate", config, "--out", dir.File("a/b/gen")});
    EXPECT_EQ(gen.exit_code, 1) << name;
    EXPECT_NE(gen.err.find("scene name"), std::string::npos) << name << " -> " << gen.err;
    EXPECT_FALSE(fs::exists(dir.File("a/b/gen"))) << name;
    EXPECT_FALSE(fs::exists(dir.File("escaped_000000.png"))) << name;
    EXPECT_FALSE(fs::exists(dir.File("a/escaped_000000.png"))) << name;
  }
  // A plain name with a dot is fine.
  const std::string scene = dir.Write("a/b/scene.json", SceneFile(R"("room.v2")"));
  const CliRun run = RunTurbid({"scene", scene, "--out", dir.File("a/b/out")});
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(fs::exists(dir.File("a/b/out/room.v2/image.png")));
}

TEST(TrustCli, NamesDifferingOnlyInCaseAreRefused) {
  TempDir dir;
  const std::string upper = dir.Write("upper.json", SceneFile(R"("Reef")"));
  const std::string lower = dir.Write("lower.json", SceneFile(R"("reef")"));
  const CliRun scene = RunTurbid({"scene", upper, lower, "--out", dir.File("out")});
  EXPECT_EQ(scene.exit_code, 1);
  EXPECT_NE(scene.err.find("differ only in case"), std::string::npos) << scene.err;
  EXPECT_FALSE(fs::exists(dir.File("out")));
  const std::string exp = dir.Write("exp.json", R"({"name": "case", "scale": 0.1,
    "scenes": [{"spec": "builtin:hull", "name": "Reef"}, {"spec": "builtin:hull", "name": "reef"}],
    "grid": {"water.beta_gray_per_m": [0.4]}, "methods": ["clahe"], "metrics": ["psnr"]})");
  const CliRun sweep = RunTurbid({"sweep", exp, "--out", dir.File("out"), "--dry-run"});
  EXPECT_EQ(sweep.exit_code, 1);
  EXPECT_NE(sweep.err.find("differ only in case"), std::string::npos) << sweep.err;
  const std::string labels =
      dir.Write("labels.json", TinyExperiment(R"({"name": "clahe", "label": "CLAHE"})"));
  const CliRun label = RunTurbid({"sweep", labels, "--out", dir.File("out"), "--dry-run"});
  EXPECT_EQ(label.exit_code, 1);
  EXPECT_NE(label.err.find("differ only in case"), std::string::npos) << label.err;
}

TEST(TrustCli, MethodLabelsCannotTakeTheItemsOwnThumbnailNames) {
  TempDir dir;
  for (const std::string& label :
       {std::string("degraded"), std::string("Lit"), std::string("clean")}) {
    const std::string exp =
        dir.Write("exp.json", TinyExperiment(R"({"name": "clahe", "label": ")" + label + R"("})"));
    const CliRun run = RunTurbid({"sweep", exp, "--out", dir.File("out"), "--dry-run"});
    EXPECT_EQ(run.exit_code, 1) << label;
    EXPECT_NE(run.err.find("method label '" + label + "' is reserved"), std::string::npos)
        << run.err;
  }
}

TEST(TrustCli, TamperedResolvedExperimentCannotNameFilesOutsideTheFolder) {
  TempDir dir;
  const std::string exp = dir.Write("exp.json", TinyExperiment(""));
  const std::string out = dir.File("out");
  ASSERT_EQ(RunTurbid({"sweep", exp, "--out", out}).exit_code, 0);
  std::string text = ReadFileText(out + "/experiment.json");
  const size_t at = text.find("\"label\": \"clahe\"");
  ASSERT_NE(at, std::string::npos) << text;
  text.replace(at, 16, "\"label\": \"../../clahe\"");
  std::ofstream(out + "/experiment.json", std::ios::binary) << text;
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"report", out},
        std::vector<std::string>{"merge", out, "--out", dir.File("merged")}}) {
    const CliRun run = RunTurbid(args);
    EXPECT_EQ(run.exit_code, 1) << args[0];
    EXPECT_NE(run.err.find("method label '../../clahe'"), std::string::npos) << run.err;
  }
  EXPECT_FALSE(fs::exists(dir.File("merged")));
}

// ---- item 4: clean-up never follows a symbolic link ------------------------------------------

TEST(TrustCli, SweepCleanUpNeverFollowsLinks) {
  TempDir dir;
  const std::string exp = dir.Write("exp.json", TinyExperiment(""));
  const std::string out = dir.File("out");
  ASSERT_EQ(RunTurbid({"sweep", exp, "--out", out}).exit_code, 0);
  // Someone else's folder, with what the sweep's clean-up removes in its own folders.
  const std::string victim = dir.File("victim");
  fs::create_directories(victim + "/work-precious");
  std::ofstream(victim + "/work-precious/data.txt") << "keep";
  const std::string temporary = ".a.png.tmp1234abcd.png";
  ASSERT_TRUE(IsTemporaryName(temporary));
  std::ofstream(victim + "/" + temporary) << "keep";
  const auto victim_intact = [&] {
    return fs::exists(victim + "/work-precious/data.txt") && fs::exists(victim + "/" + temporary);
  };
  // Links where the sweep keeps its own folders: refused with one line, nothing removed.
  fs::create_directories(out + "/external");
  for (const std::string& link :
       {out + "/external/evil", out + "/thumbs/planted", out + "/external"}) {
    if (link == out + "/external") fs::remove_all(link);
    fs::create_directory_symlink(victim, link);
    const CliRun run = RunTurbid({"sweep", exp, "--out", out});
    EXPECT_EQ(run.exit_code, 1) << link;
    EXPECT_TRUE(OneLine(run.err)) << run.err;
    EXPECT_NE(run.err.find(link + ": is a symbolic link"), std::string::npos) << run.err;
    EXPECT_TRUE(victim_intact()) << link;
    fs::remove(link);
  }
  // Deeper than the sweep's own folders: never followed, and the sweep goes on.
  fs::create_directory_symlink(victim, out + "/thumbs/hull-c0000/x");
  const CliRun deeper = RunTurbid({"sweep", exp, "--out", out});
  EXPECT_EQ(deeper.exit_code, 0) << deeper.err;
  EXPECT_TRUE(victim_intact());
  fs::remove(out + "/thumbs/hull-c0000/x");
  // The thumbs folder itself.
  fs::rename(out + "/thumbs", dir.File("thumbs-real"));
  fs::create_directory_symlink(victim, out + "/thumbs");
  const CliRun run = RunTurbid({"sweep", exp, "--out", out});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("is a symbolic link"), std::string::npos) << run.err;
  EXPECT_TRUE(victim_intact());
}

TEST(TrustCli, MergeNeverCopiesThroughLinks) {
  TempDir dir;
  const std::string exp = dir.Write("exp.json", TinyExperiment(""));
  const std::string out = dir.File("out");
  ASSERT_EQ(RunTurbid({"sweep", exp, "--out", out}).exit_code, 0);
  std::ofstream(dir.File("secret.txt")) << "private";
  fs::create_symlink(dir.File("secret.txt"), out + "/thumbs/hull-c0000/secret.png");
  const CliRun merge = RunTurbid({"merge", out, "--out", dir.File("merged")});
  ASSERT_EQ(merge.exit_code, 0) << merge.err;
  EXPECT_TRUE(fs::exists(dir.File("merged/thumbs/hull-c0000/degraded.png")));
  EXPECT_FALSE(fs::exists(fs::symlink_status(dir.File("merged/thumbs/hull-c0000/secret.png"))));
  // A shard whose thumbs/ is a link is refused before anything is written.
  fs::rename(out + "/thumbs", dir.File("thumbs-real"));
  fs::create_directory_symlink(dir.File("thumbs-real"), out + "/thumbs");
  const CliRun linked = RunTurbid({"merge", out, "--out", dir.File("merged2")});
  EXPECT_EQ(linked.exit_code, 1);
  EXPECT_NE(linked.err.find("thumbs: is a symbolic link"), std::string::npos) << linked.err;
  EXPECT_FALSE(fs::exists(dir.File("merged2")));
}

TEST(TrustCli, GenerateCleanUpNeverFollowsLinks) {
  TempDir dir;
  const std::string config = dir.Write("gen.json", R"({"scenes": ["builtin:seafloor"], "scale": 0.1,
                      "grid": {"water.beta_gray_per_m": [0.5]}})");
  const std::string victim = dir.File("victim");
  fs::create_directories(victim);
  const std::string temporary = ".a.png.tmp1234abcd.png";
  std::ofstream(victim + "/" + temporary) << "keep";
  fs::create_directories(dir.File("gen"));
  fs::create_directory_symlink(victim, dir.File("gen/images"));
  const CliRun run = RunTurbid({"generate", config, "--out", dir.File("gen")});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("gen/images: is a symbolic link"), std::string::npos) << run.err;
  EXPECT_TRUE(fs::exists(victim + "/" + temporary));
}

TEST(TrustCli, StaleTemporaryCleanUpLeavesLinksAlone) {
  TempDir dir;
  const std::string target = dir.File("target.txt");
  std::ofstream(target) << "keep";
  fs::create_directories(dir.File("folder"));
  const std::string link = dir.File("folder/.a.png.tmp1234abcd.png");
  fs::create_symlink(target, link);
  std::ofstream(dir.File("folder/.b.png.tmp99.png")) << "stale";
  EXPECT_EQ(RemoveStaleTemporaries(dir.File("folder"), /*recursive=*/true), 1);
  EXPECT_TRUE(fs::is_symlink(fs::symlink_status(link)));
  EXPECT_TRUE(fs::exists(target));
  EXPECT_FALSE(fs::exists(dir.File("folder/.b.png.tmp99.png")));
}

}  // namespace
}  // namespace turbid
