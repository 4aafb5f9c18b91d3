#!/usr/bin/env bash
# Quick start, command 1: install what is missing, build, run the main job on built-in scenes.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DTURBID_BUILD_TESTS=OFF >/dev/null
cmake --build build --target turbid -j"$(nproc)"
./build/turbid scene --builtin all --out out/scenes --force
