// turbid sequence: a built-in scene flown along a trajectory, or an RGB-D sequence with ground
// truth, summarised and written as a TUM RGB-D folder (docs/cli/sequence.md).
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/json_io.h"
#include "scenes/sequence.h"
#include "tools/cli/cli.h"

namespace turbid {
namespace {

struct SequenceArgs {
  std::string spec;
  std::string trajectory;  // JSON object text or a file holding one
  std::string kind;
  int frames = 0;
  double scale = 1.0;
  std::string out_dir;
  bool force = false;
};

TrajectoryOptions TrajectoryFromArgs(const SequenceArgs& args) {
  TrajectoryOptions options;
  if (!args.trajectory.empty()) {
    const bool inline_json = args.trajectory.find('{') != std::string::npos;
    const nlohmann::json j =
        inline_json ? ParseJson(args.trajectory, "--trajectory") : ReadJsonFile(args.trajectory);
    TrajectoryFields().Read(j, &options, inline_json ? "--trajectory" : args.trajectory,
                            "trajectory");
  }
  if (!args.kind.empty()) options.kind = args.kind;
  if (args.frames > 0) options.frames = args.frames;
  std::string why;
  if (!options.Check(&why)) throw Error("--trajectory: " + why);
  return options;
}

std::unique_ptr<Sequence> OpenSequence(const SequenceArgs& args) {
  const std::string prefix = "builtin:";
  if (args.spec.rfind(prefix, 0) == 0) {
    BuiltinSceneOptions options;
    options.scale = args.scale;
    return MakeBuiltinSequence(args.spec.substr(prefix.size()), options, TrajectoryFromArgs(args));
  }
  if (!args.trajectory.empty() || !args.kind.empty() || args.frames > 0)
    throw Error(args.spec + ": --trajectory, --kind and --frames are for built-in scenes");
  return LoadRgbdSequence(args.spec);
}

void PrintSummary(const Sequence& s) {
  double path_m = 0, turn_deg = 0;
  for (int i = 1; i < s.size(); ++i) {
    const Pose step = Relative(s.pose(i - 1), s.pose(i));
    path_m += cv::norm(step.position_m);
    turn_deg += RotationAngleDeg(step.rotation);
  }
  std::printf("%s: %d frames over %.3f s; path %.3f m, rotation %.2f deg in all\n",
              s.name().c_str(), s.size(), s.timestamp_s(s.size() - 1) - s.timestamp_s(0), path_m,
              turn_deg);
  for (int i : {0, s.size() - 1}) {
    const Pose& p = s.pose(i);
    std::printf("  frame %d at t = %.3f s: camera at (%.3f, %.3f, %.3f) m\n", i, s.timestamp_s(i),
                p.position_m[0], p.position_m[1], p.position_m[2]);
    if (s.size() == 1) break;
  }
}

void RunSequence(const SequenceArgs& args) {
  const std::unique_ptr<Sequence> sequence = OpenSequence(args);
  PrintSummary(*sequence);
  if (args.out_dir.empty()) return;
  WriteTumSequence(*sequence, args.out_dir, args.force);
  std::printf("wrote %s: rgb/, depth/, associations.txt, groundtruth.txt, sequence.json\n",
              args.out_dir.c_str());
}

}  // namespace

void AddSequenceCommand(CLI::App& app) {
  auto args = std::make_shared<SequenceArgs>();
  CLI::App* cmd = app.add_subcommand(
      "sequence", "fly a built-in scene along a trajectory, or load an RGB-D sequence with poses");
  PathOption(cmd->add_option("spec", args->spec,
                             "builtin:NAME (hull, seafloor, room) or an rgbd_sequence JSON file")
                 ->required());
  cmd->add_option("--trajectory", args->trajectory,
                  "trajectory options: a JSON object or a file (docs/formats.md \"Sequences\")");
  cmd->add_option("--kind", args->kind, "trajectory kind: survey, pass or hover")
      ->check(CLI::IsMember({"survey", "pass", "hover"}));
  cmd->add_option("--frames", args->frames, "number of frames (overrides the trajectory's)")
      ->check(CLI::Range(1, 100000));
  cmd->add_option("--scale", args->scale, "size scale for built-in scenes, in (0, 1]")
      ->capture_default_str();
  PathOption(cmd->add_option("--out", args->out_dir,
                             "write a TUM RGB-D folder (rgb/, depth/, associations.txt, "
                             "groundtruth.txt, sequence.json)"));
  cmd->add_flag("--force", args->force, "overwrite existing outputs");
  cmd->callback([args]() { RunSequence(*args); });
  cmd->footer(
      "Example: turbid sequence builtin:seafloor --kind survey --frames 10 --scale 0.5 --out "
      "survey");
}

}  // namespace turbid
