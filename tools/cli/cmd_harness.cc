// `turbid sweep`, `turbid merge`, `turbid regress`, `turbid report`: the experiment harness.
// Reference: docs/cli/harness.md; experiment files: docs/experiments.md.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "core/error.h"
#include "core/input_file.h"
#include "tools/cli/cli.h"
#include "tools/harness/experiment.h"
#include "tools/harness/harness_runner.h"
#include "tools/harness/report.h"
#include "tools/harness/sweep.h"
#include "tools/harness/tables.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;

struct SweepArgs {
  std::string experiment;
  std::string out;
  int threads = 0;
  std::string shard = "0/1";
  bool quiet = false;
  bool force = false;
  bool dry_run = false;
  bool no_reuse = false;
  bool retry_failed = false;
  bool allow_commands = false;
};

void RunSweepCommand(const SweepArgs& args) {
  // Everything is validated before the output folder is touched.
  const Experiment experiment = LoadExperimentFile(args.experiment, RegistryCatalog());
  SweepOptions options;
  options.out_dir = args.out;
  options.threads = args.threads;
  options.shard = ParseShard(args.shard);
  options.force = args.force;
  options.retry_failed = args.retry_failed;
  options.progress = !args.quiet && ShouldShowProgress();
  ThrowIfInvalid(options, "sweep");
  // An experiment file is data: its external commands run only when the user says so.
  const std::vector<std::string> commands = DescribeCommands(experiment);
  if (args.dry_run && !commands.empty() && !args.allow_commands) {
    std::cout << experiment.name << ": the sweep would run these external commands (each needs "
              << "--allow-commands):\n";
    for (const std::string& line : commands) std::cout << "  " << line << "\n";
    std::cout << std::flush;
  }
  CheckCommandsAllowed(experiment, args.allow_commands, "--allow-commands");
  if (args.dry_run) {
    int in_shard = 0;
    for (const ItemSpec& item : ExpandItems(experiment))
      in_shard += options.shard.Contains(item.index);
    std::cout << experiment.name << ": valid; " << experiment.scenes.size() << " scenes x "
              << experiment.ConditionCount() << " conditions = " << experiment.ItemCount()
              << " items (" << in_shard << " in shard " << args.shard << "), "
              << experiment.methods.size() << " methods, " << experiment.metrics.size()
              << " metrics\n";
    if (!commands.empty()) {
      std::cout << "external commands it runs (allowed by --allow-commands):\n";
      for (const std::string& line : commands) std::cout << "  " << line << "\n";
    }
    return;
  }
  HarnessRunnerOptions runner_options;
  runner_options.reuse = !args.no_reuse;
  runner_options.allow_commands = args.allow_commands;
  HarnessRunner runner(experiment, args.out, runner_options);
  const SweepSummary summary = RunSweep(experiment, options, runner.Hooks());
  for (const std::string& note : summary.notes) std::cerr << "turbid: note: " << note << "\n";
  if (summary.ran == 0 && !summary.tables_written) {
    std::cout << "sweep: nothing to do: all " << summary.items_in_shard << " items of "
              << (options.shard.count > 1 ? "shard " + args.shard : std::string("the sweep"))
              << " are done in " << args.out << "\n";
  } else {
    std::cout << "sweep: " << summary.ran << " items run";
    if (summary.retried > 0) std::cout << " (" << summary.retried << " retried)";
    std::cout << ", " << summary.already_done << " already done (" << summary.items_in_shard
              << " in "
              << (options.shard.count > 1 ? "shard " + args.shard : std::string("the sweep"))
              << ", " << summary.items_total << " in the experiment)";
    if (summary.failed_rows > 0) {
      std::cout << "; " << summary.failed_rows
                << " method runs failed (see the error column; rerun with --retry-failed to "
                   "retry them)";
    }
    std::cout << "\n";
  }
  if (!args.quiet) {
    std::cout << "tables: " << args.out << "/summary.md, " << args.out << "/summary.csv, "
              << args.out << "/items.csv, " << args.out << "/timings.md\n";
    if (options.shard.count > 1) {
      std::cout << "combine the shards with: turbid merge DIR... --out MERGED\n";
    } else {
      std::cout << "report: turbid report " << args.out << "\n";
    }
  }
}

struct RegressArgs {
  std::string baseline;
  std::string results;
  std::vector<std::string> tolerances;  // METRIC=ABS[:REL]
  std::string tolerance_file;
  bool strict = false;
  bool within_interval = false;
};

void RunRegressCommand(const RegressArgs& args) {
  RegressOptions options;
  std::string tolerance_file = args.tolerance_file;
  // A baseline may carry its tolerances beside it: B.csv -> B.tolerances.json.
  if (tolerance_file.empty()) {
    const fs::path beside = fs::path(args.baseline).replace_extension(".tolerances.json");
    if (fs::exists(beside)) tolerance_file = beside.string();
  }
  if (!tolerance_file.empty()) LoadTolerances(tolerance_file, &options);
  for (const std::string& spec : args.tolerances) {
    const size_t eq = spec.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw Error("--tol '" + spec + "': expected METRIC=ABS or METRIC=ABS:REL");
    }
    Tolerance tolerance;
    tolerance.rel = 0.0;
    const std::string value = spec.substr(eq + 1);
    const size_t colon = value.find(':');
    // ParseValue reads '' and 'nan' as NaN (empty table cells); a tolerance must be a number.
    try {
      tolerance.abs = ParseValue(value.substr(0, colon));
      if (colon != std::string::npos) tolerance.rel = ParseValue(value.substr(colon + 1));
    } catch (const Error&) {
      tolerance.abs = std::nan("");
    }
    if (!(tolerance.abs >= 0.0) || !(tolerance.rel >= 0.0) || std::isinf(tolerance.abs) ||
        std::isinf(tolerance.rel)) {
      throw UsageError("--tol '" + spec + "': tolerances must be finite numbers >= 0");
    }
    options.tolerances[spec.substr(0, eq)] = tolerance;
  }
  options.fail_on_improvement = args.strict;
  options.within_interval = args.within_interval;
  // RESULTS: a sweep folder (its table of the baseline's kind) or a CSV file.
  std::string results = args.results;
  if (fs::is_directory(results)) {
    // The baseline's kind from its header (a summary.csv starts "level,method,metric"), else
    // from its name.
    std::string header;
    CheckInputFile(args.baseline);
    std::ifstream baseline_in(args.baseline);
    std::getline(baseline_in, header);
    const bool summary_baseline =
        header.rfind("level,method,metric", 0) == 0 ||
        (header.empty() &&
         fs::path(args.baseline).filename().string().find("summary") != std::string::npos);
    results += summary_baseline ? "/summary.csv" : "/items.csv";
    // Metric directions from the sweep's experiment.
    try {
      const SweepDir dir = LoadSweepDir(args.results);
      for (const HarnessMetricInfo& m : dir.experiment.metrics) {
        options.higher_is_better[m.name] = m.higher_is_better;
      }
    } catch (const Error&) {
      // Not a sweep folder with a journal: fall back to the registry below.
    }
  }
  const HarnessCatalog catalog = RegistryCatalog();
  const RegressReport probe = Regress(args.baseline, results, options);
  for (const RegressMove& move : probe.moves) {
    if (options.higher_is_better.count(move.metric)) continue;
    try {
      options.higher_is_better[move.metric] = catalog.find_metric(move.metric).higher_is_better;
    } catch (const Error&) {
      // Unknown direction: any move counts as a regression.
    }
  }
  const RegressReport report = Regress(args.baseline, results, options);
  std::cout << "regress: " << results << " against " << args.baseline << "\n" << report.Format();
  if (report.failed()) throw Error("regress: " + results + " regressed against " + args.baseline);
}

void AddSweepCommand(CLI::App& app) {
  auto sweep_args = std::make_shared<SweepArgs>();
  CLI::App* sweep = app.add_subcommand(
      "sweep", "run an experiment file: scenes x turbidity grid x methods x metrics");
  PathOption(sweep->add_option("experiment", sweep_args->experiment,
                               "experiment JSON (docs/experiments.md)"))
      ->required();
  PathOption(sweep->add_option("--out", sweep_args->out, "output folder (rerun to resume)"))
      ->required();
  InRange(sweep->add_option("--threads", sweep_args->threads, "worker threads (0 = all cores)"), 0,
          1024);
  sweep->add_option("--shard", sweep_args->shard, "run slice i of N (0 <= i < N), e.g. 2/8");
  sweep->add_flag("--quiet", sweep_args->quiet, "no progress bar and no hints");
  sweep->add_flag("--force", sweep_args->force,
                  "start over when --out holds a different experiment");
  sweep->add_flag("--dry-run", sweep_args->dry_run, "validate and count the items, run nothing");
  sweep->add_flag("--allow-commands", sweep_args->allow_commands,
                  "run the experiment's external \"command\" methods (programs it names, with "
                  "their env); without it a sweep that names one refuses to start");
  sweep->add_flag("--retry-failed", sweep_args->retry_failed,
                  "run again the method cells that failed in journaled items");
  sweep->add_flag("--no-reuse", sweep_args->no_reuse,
                  "recompute scene loading, renderer caches and ground-truth scores per item "
                  "(for benchmarks)");
  sweep->callback([sweep_args] { RunSweepCommand(*sweep_args); });
  sweep->footer("Example: turbid sweep scenes/experiments/demo.json --out demo");
}

void AddMergeCommand(CLI::App& app) {
  auto merge_dirs = std::make_shared<std::vector<std::string>>();
  auto merge_options = std::make_shared<MergeOptions>();
  CLI::App* merge = app.add_subcommand("merge", "combine shard outputs into the unsharded result");
  PathOption(merge->add_option("dirs", *merge_dirs, "shard output folders"))->required();
  PathOption(merge->add_option("--out", merge_options->out_dir, "merged output folder"))
      ->required();
  merge->add_flag("--allow-partial", merge_options->allow_partial,
                  "write tables even when some items are missing");
  merge->add_flag("--force", merge_options->force,
                  "replace an --out folder that holds a different experiment");
  merge->callback([merge_dirs, merge_options] {
    const int items = MergeSweeps(*merge_dirs, *merge_options);
    std::cout << "merge: " << items << " items from " << merge_dirs->size() << " folders into "
              << merge_options->out_dir << "\n";
  });
  merge->footer("Example: turbid merge demo_shard0 demo_shard1 --out demo_merged");
}

void AddRegressCommand(CLI::App& app) {
  auto regress_args = std::make_shared<RegressArgs>();
  CLI::App* regress = app.add_subcommand(
      "regress", "compare results with a baseline table; exit 1 when a metric regressed");
  PathOption(regress->add_option("--baseline", regress_args->baseline,
                                 "baseline items.csv or summary.csv"))
      ->required();
  PathOption(
      regress->add_option("results", regress_args->results, "sweep folder or CSV of the same kind"))
      ->required();
  regress
      ->add_option("--tol", regress_args->tolerances,
                   "per-metric tolerance METRIC=ABS[:REL] (repeatable)")
      ->type_name("METRIC=ABS[:REL]")
      ->allow_extra_args(false);
  PathOption(
      regress->add_option("--tolerances", regress_args->tolerance_file,
                          "tolerance JSON (default: BASELINE with .tolerances.json, if present)"));
  regress->add_flag("--strict", regress_args->strict, "improvements beyond tolerance fail too");
  regress->add_flag("--within-interval", regress_args->within_interval,
                    "summary tables: a mean inside the baseline's 95 % bootstrap interval (ci_lo, "
                    "ci_hi) is within the metric's noise over items and passes");
  regress->callback([regress_args] { RunRegressCommand(*regress_args); });
  regress->footer("Example: turbid regress --baseline demo/items.csv demo_merged");
}

void AddReportCommand(CLI::App& app) {
  auto report_dir = std::make_shared<std::string>();
  auto report_options = std::make_shared<ReportOptions>();
  CLI::App* report =
      app.add_subcommand("report", "a static HTML report of a sweep (tables, images, plots)");
  PathOption(report->add_option("dir", *report_dir, "sweep output folder"))->required();
  PathOption(report->add_option("--out", report_options->out_file,
                                "HTML file (default: DIR/report.html)"));
  PathOption(report->add_option("--gnuplot", report_options->gnuplot, "gnuplot executable"));
  report->callback([report_dir, report_options] {
    const ReportSummary summary = WriteReport(*report_dir, *report_options);
    if (!summary.warning.empty()) std::cerr << "turbid: warning: " << summary.warning << "\n";
    std::cout << "report: " << summary.html_path << " (" << summary.plots << " plots, "
              << summary.images << " images)\n";
  });
  report->footer("Example: turbid report demo");
}

}  // namespace

void AddHarnessCommands(CLI::App& app) {
  AddSweepCommand(app);
  AddMergeCommand(app);
  AddRegressCommand(app);
  AddReportCommand(app);
}

}  // namespace turbid
