// Sweep journals as a resume, `turbid merge` and `turbid report` read them: the input is
// DIR/journal.jsonl beside a fixed DIR/experiment.json (journal_experiment.h: seafloor, 3
// turbidity levels, clahe, psnr). Journal::Load with the repair a resume does, every entry through
// ItemResultFromJson, and LoadSweepDir (which checks entries against the experiment's items and
// refuses an incomplete entry: method rows or metrics missing, another item's fields).
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

#include "fuzz/fuzz_support.h"
#include "fuzz/journal_experiment.h"
#include "tools/harness/experiment.h"
#include "tools/harness/harness_runner.h"
#include "tools/harness/sweep.h"
#include "tools/harness/tables.h"

namespace {
using namespace turbid;

std::string SweepFolder() {
  static const std::string dir = [] {
    const std::string d = fuzz::ScratchPath("sweep");
    std::filesystem::create_directories(d);
    const nlohmann::json file = nlohmann::json::parse(fuzz::kJournalExperiment);
    const Experiment e = ParseExperiment(file, d + "/source.json", RegistryCatalog());
    fuzz::WriteFile(d + "/experiment.json", e.ToJson().dump(2) + "\n");
    return d;
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string dir = SweepFolder();
  const std::string path = dir + "/journal.jsonl";
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  fuzz::WriteFile(path, bytes);
  fuzz::ExpectOnlyErrors([&] {
    for (const auto& id_entry : Journal(path).Load(/*repair=*/true))
      fuzz::ExpectOnlyErrors([&] { ItemResultFromJson(id_entry.second); });
  });
  fuzz::WriteFile(path, bytes);  // the repair may have cut a partial last line
  fuzz::ExpectOnlyErrors([&] { LoadSweepDir(dir); });
  return 0;
}
