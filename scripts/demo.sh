#!/usr/bin/env bash
# Quick start, command 1: install what is missing, build, run the main job on built-in scenes:
# write the scenes' clean ground truth, sweep turbidity over every enhancement method, score,
# and write the report. Rerunning resumes the sweep (finished items are not recomputed).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build --target turbid -j"$(nproc)"
./build/turbid scene --builtin all --out out/scenes --force
# --force: a changed demo experiment starts over instead of refusing the old folder.
./build/turbid sweep scenes/experiments/demo.json --out out/demo --force
./build/turbid report out/demo
echo
echo "demo done:"
echo "  clean ground truth   out/scenes/"
echo "  results table        out/demo/summary.md (and summary.csv, items.csv)"
echo "  report with plots    out/demo/report.html"
