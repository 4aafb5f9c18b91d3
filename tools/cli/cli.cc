#include "tools/cli/cli.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <new>

#include "core/error.h"
#include "tools/harness/file_context.h"
#include "turbid_version.h"

namespace turbid {
namespace {

// The name an option has in messages: "--beta", or "IN" for a positional.
std::string OptionName(const CLI::Option* option) { return option->get_name(); }

bool IsDecimalInteger(const std::string& text) {
  size_t start = text.empty() || (text[0] != '-' && text[0] != '+') ? 0 : 1;
  if (start == text.size()) return false;
  return text.find_first_not_of("0123456789", start) == std::string::npos;
}

// A plain decimal number: digits with an optional sign, point and exponent. Not '', ' 1', '0x10',
// 'nan', 'inf' or '1e999' (all of which strtod takes).
bool IsDecimalNumber(const std::string& text, double* value) {
  if (text.empty() || text.find_first_not_of("0123456789+-.eE") != std::string::npos) return false;
  errno = 0;
  char* end = nullptr;
  *value = std::strtod(text.c_str(), &end);
  return end == text.c_str() + text.size() && std::isfinite(*value) && errno != ERANGE;
}

// The check every numeric option gets: CLI11 itself reads '' as 0, saturates integers beyond
// int64 (strtoll), wraps '-1' into an unsigned option, and takes octal ('010' is 8), hex, 'nan',
// 'inf' and leading blanks.
void CheckNumberText(const std::string& name, const std::string& type, const std::string& text) {
  if (text.empty()) throw UsageError("empty value given for " + name + " (expected a number)");
  if (type.rfind("FLOAT", 0) == 0) {
    double value = 0.0;
    if (!IsDecimalNumber(text, &value))
      throw UsageError(name + ": '" + text + "' is not a finite decimal number");
    return;
  }
  const bool is_unsigned = type.rfind("UINT", 0) == 0;
  const std::string problem = name + ": '" + text + "' is not an integer" +
                              (is_unsigned ? " in [0, 18446744073709551615]" : "");
  if (!IsDecimalInteger(text) || (is_unsigned && text[0] == '-')) throw UsageError(problem);
  errno = 0;
  if (is_unsigned) {
    std::strtoull(text.c_str(), nullptr, 10);
  } else {
    std::strtoll(text.c_str(), nullptr, 10);
  }
  if (errno == ERANGE) throw UsageError(problem);
}

// Gives every option of `app` and its subcommands the checks above: numbers must be plain
// decimal numbers in their type's range, and no value may be empty.
void CheckEveryOption(CLI::App& app) {
  for (CLI::Option* option : app.get_options()) {
    if (option->get_items_expected_max() == 0) continue;  // a flag
    const std::string type = option->get_type_name();
    const std::string name = OptionName(option);
    const bool number =
        type.rfind("INT", 0) == 0 || type.rfind("UINT", 0) == 0 || type.rfind("FLOAT", 0) == 0;
    option->check(CLI::Validator(
        [name, type, number](std::string& text) {
          if (number) {
            CheckNumberText(name, type, text);
          } else if (text.empty()) {
            throw UsageError("empty value given for " + name);
          }
          return std::string();
        },
        ""));
  }
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) CheckEveryOption(*sub);
}

// An option that takes one value each time it is given (repeatable, allow_extra_args(false)) is
// shown as "--set KEY=VALUE", not CLI11's "--set TEXT ...", which reads as several values.
void ShowOneValuePerFlag(CLI::App& app) {
  for (CLI::Option* option : app.get_options()) {
    if (!option->nonpositional() || option->get_allow_extra_args() ||
        option->get_expected_max() < CLI::detail::expected_max_vector_size ||
        !option->get_option_text().empty())
      continue;
    option->option_text(option->get_type_name() + (option->get_required() ? " REQUIRED" : ""));
  }
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; }))
    ShowOneValuePerFlag(*sub);
}

// "turbid score" for messages about the command that was running.
std::string RunningCommand(CLI::App& app) {
  std::string command = "turbid";
  for (CLI::App* sub = &app; sub != nullptr;) {
    const std::vector<CLI::App*> chosen = sub->get_subcommands();
    sub = chosen.empty() ? nullptr : chosen.front();
    if (sub != nullptr) command += " " + sub->get_name();
  }
  return command;
}

std::string OutOfMemoryLine(CLI::App& app) {
  return "turbid: error: out of memory while running '" + RunningCommand(app) +
         "' (try smaller inputs, a smaller --scale or fewer --threads)\n";
}

// One line: messages that hold newlines (OpenCV's, some of CLI11's) are joined.
std::string OneLine(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  for (char& c : text)
    if (c == '\n' || c == '\r') c = ' ';
  return text;
}

}  // namespace

CLI::Option* PathOption(CLI::Option* option) {
  const std::string name = OptionName(option);
  return option->check(CLI::Validator(
      [name](std::string& text) {
        if (text.empty()) throw UsageError("empty path given for " + name);
        return std::string();
      },
      ""));
}

double ParseDecimalOption(const std::string& name, const std::string& text) {
  CheckNumberText(name, "FLOAT", text);
  return std::strtod(text.c_str(), nullptr);
}

CLI::Option* InRange(CLI::Option* option, double lo, double hi) {
  const std::string name = OptionName(option);
  const std::string type = option->get_type_name();
  const auto format = [](double v) {
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%.10g", v);
    return std::string(buffer);
  };
  return option->check(CLI::Validator(
      [name, type, lo, hi, format](std::string& text) {
        CheckNumberText(name, type, text);
        const double value = std::strtod(text.c_str(), nullptr);
        if (value < lo || value > hi)
          throw UsageError(name + ": " + text + " is not in [" + format(lo) + ", " + format(hi) +
                           "]");
        return std::string();
      },
      "in [" + format(lo) + " - " + format(hi) + "]"));
}

int RunCli(int argc, const char* const* argv) {
  CLI::App app{"turbid: underwater image degradation simulator, enhancers, metrics and sweeps"};
  app.set_version_flag("--version", std::string("turbid ") + TURBID_VERSION);
  app.require_subcommand(1);
  // `turbid --help` lists the subcommands in this order: the order a newcomer uses them.
  AddSceneCommand(app);
  AddSequenceCommand(app);
  AddRenderCommand(app);
  AddWaterCommand(app);
  AddEnhanceCommand(app);
  AddScoreCommand(app);
  AddHarnessCommands(app);
  AddGenerateCommand(app);
  AddBenchLauncher(app);
  return RunApp(app, argc, argv);
}

int RunApp(CLI::App& app, int argc, const char* const* argv) {
  CheckEveryOption(app);
  ShowOneValuePerFlag(app);
  // Usage errors are one line too (CLI11 adds a second, "Run with --help ...").
  app.failure_message([](const CLI::App*, const CLI::Error& e) {
    return "turbid: error: " + OneLine(e.what()) + " (see --help)\n";
  });
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version are "successes"; every real usage error exits 2 (docs/cli.md),
    // not CLI11's own numbering.
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  } catch (const ExitStatus& e) {
    return e.code;
  } catch (const UsageError& e) {
    std::cerr << "turbid: error: " << OneLine(e.what()) << "\n";
    return 2;
  } catch (const Error& e) {
    std::cerr << "turbid: error: " << OneLine(e.what()) << "\n";
    return 1;
  } catch (const std::bad_alloc&) {
    std::cerr << OutOfMemoryLine(app);
    return 1;
  } catch (const cv::Exception& e) {
    if (IsOpenCvOutOfMemory(e)) {
      std::cerr << OutOfMemoryLine(app);
    } else {
      std::cerr << "turbid: error: " << RunningCommand(app) << ": " << OpenCvProblem(e) << "\n";
    }
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "turbid: error: " << OneLine(e.what()) << "\n";
    return 1;
  }
  return 0;
}

int RunCli(const std::vector<std::string>& args) {
  std::vector<const char*> argv;
  argv.reserve(args.size());
  for (const std::string& arg : args) argv.push_back(arg.c_str());
  return RunCli(static_cast<int>(argv.size()), argv.data());
}

}  // namespace turbid
