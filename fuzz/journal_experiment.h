// The experiment behind the journal fuzzer's sweep folder, shared with make_seeds.cc, which runs
// it for real to write the seed journals (so the seeds' item ids are this experiment's).
#pragma once

namespace turbid::fuzz {

inline constexpr const char* kJournalExperiment = R"({
  "name": "fuzz",
  "scenes": ["builtin:seafloor"],
  "scale": 0.05,
  "seed": 3,
  "grid": {"water.beta_gray_per_m": [0.1, 0.5, 1.0]},
  "methods": ["clahe"],
  "metrics": ["psnr"],
  "thumbnails": 0
})";

}  // namespace turbid::fuzz
