#!/usr/bin/env bash
# Quick start, command 2: install what is missing (test tools included), build, run every test.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh --test
# Real-data tests read $TURBID_DATA (CI: ../shared/data, relative to the repository root) and the
# reference values beside it; CTest runs each suite from its own build folder, so pass absolute paths.
if [[ -n "${TURBID_DATA:-}" ]]; then
  if [[ -d "$TURBID_DATA" ]]; then
    TURBID_DATA="$(realpath "$TURBID_DATA")"
    export TURBID_DATA
    if [[ -z "${TURBID_REFERENCE:-}" && -d "$TURBID_DATA/../reference" ]]; then
      TURBID_REFERENCE="$(realpath "$TURBID_DATA/../reference")"
      export TURBID_REFERENCE
    fi
  else
    echo "note: TURBID_DATA=$TURBID_DATA is not a folder; real-data tests will skip" >&2
  fi
fi
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DTURBID_BUILD_TESTS=ON >/dev/null
cmake --build build -j"$(nproc)"
cd build
ctest --output-on-failure -j"$(nproc)" --timeout 600
