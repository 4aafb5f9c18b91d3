#!/usr/bin/env bash
# Runs one libFuzzer target of fuzz/ on its committed seeds (docs/reliability.md, "Fuzzing").
# Usage: fuzz/run_fuzzer.sh --fuzzer BIN --name NAME --work DIR (--replay | --seconds N) [-- ARGS]
#   --replay     run every seed (fuzz/corpus/NAME) and committed crash input
#                (fuzz/regressions/NAME) once; fails on any finding
#   --seconds N  fuzz for N seconds; new inputs go to DIR/corpus/NAME, a crash to
#                DIR/artifacts/NAME-*, never into the repository
#   ARGS         more libFuzzer flags (e.g. -jobs=1 for long runs)
# Memory: -rss_limit_mb=2560 (the process) and -malloc_limit_mb=4096 (one allocation). The single
# allocation limit sits above 2 GiB because OpenEXR allocates an attribute's claimed size (an int,
# up to 2 GiB) before reading it, and a short file then fails the read without touching that memory
# (docs/reliability.md, "Fuzzing"); the RSS limit still stops inputs that really use memory.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
fuzzer="" name="" work="" replay=0 seconds=0
while (($#)); do
  case "$1" in
    --fuzzer) fuzzer="$2"; shift 2 ;;
    --name) name="$2"; shift 2 ;;
    --work) work="$2"; shift 2 ;;
    --replay) replay=1; shift ;;
    --seconds) seconds="$2"; shift 2 ;;
    --) shift; break ;;
    *) echo "run_fuzzer.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done
[[ -x "$fuzzer" && -n "$name" && -n "$work" ]] || { echo "run_fuzzer.sh: need --fuzzer, --name, --work" >&2; exit 2; }
fuzzer="$(realpath "$fuzzer")"
mkdir -p "$work"
work="$(realpath "$work")"
seeds="$here/corpus/$name"
regressions="$here/regressions/$name"
[[ -d "$seeds" ]] || { echo "run_fuzzer.sh: no seeds in $seeds" >&2; exit 2; }
limits=(-rss_limit_mb=2560 -malloc_limit_mb=4096 -timeout=60)
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1}"
export LSAN_OPTIONS="suppressions=$here/lsan.supp:${LSAN_OPTIONS:-}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1}"
mkdir -p "$work/artifacts"
cd "$work"
if ((replay)); then
  inputs=("$seeds"/*)
  if [[ -d "$regressions" ]]; then
    shopt -s nullglob
    inputs+=("$regressions"/*)
  fi
  # Files given one by one are each run once; the exit status is non-zero on any finding.
  exec "$fuzzer" "${limits[@]}" "$@" "${inputs[@]}"
fi
mkdir -p "$work/corpus/$name"
exec "$fuzzer" "${limits[@]}" -max_total_time="$seconds" -print_final_stats=1 \
  -artifact_prefix="$work/artifacts/$name-" "$@" "$work/corpus/$name" "$seeds"
