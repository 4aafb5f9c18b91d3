#!/usr/bin/env bash
# Quick start, command 2: install what is missing (test tools included), build, run every test.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh --test
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DTURBID_BUILD_TESTS=ON >/dev/null
cmake --build build -j"$(nproc)"
cd build
ctest --output-on-failure -j"$(nproc)" --timeout 600
