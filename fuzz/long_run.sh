#!/usr/bin/env bash
# The long fuzzing run of docs/reliability.md ("Fuzzing"): each named fuzzer in turn for SECONDS,
# nice'd, from its committed seeds, one process at a time; a summary line per fuzzer. libFuzzer's
# fork mode with one worker (-fork=1) keeps fuzzing after a crash, out-of-memory or timeout and
# keeps every such input under WORK_DIR/artifacts.
# Usage: [NICE=N] fuzz/long_run.sh BUILD_DIR WORK_DIR SECONDS NAME...
#   e.g. fuzz/long_run.sh build-san /tmp/turbid-fuzz 420 image scene render_params
# Writes WORK_DIR/NAME.log (libFuzzer's output), WORK_DIR/corpus/NAME (inputs found),
# WORK_DIR/artifacts/NAME-* (crashes) and appends to WORK_DIR/summary.tsv:
#   name  seconds  cpu_s  executions  exec_per_s  cov  ft  corpus  peak_rss_mb  findings
# NICE (default 10) is the fuzzers' niceness; on a machine busy with builds, nice 10 gets a small
# share of a core, so pass NICE=0 when the CPU time matters more than the other work.
set -uo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
build="$(cd "$1" && pwd)" work="$2" seconds="$3"
shift 3
mkdir -p "$work"
work="$(cd "$work" && pwd)"
for name in "$@"; do
  log="$work/$name.log"
  /usr/bin/time -f "%U %S" -o "$work/$name.time" nice -n "${NICE:-10}" bash "$here/run_fuzzer.sh" \
    --fuzzer "$build/fuzz/${name}_fuzzer" --name "$name" --work "$work" --seconds "$seconds" \
    -- -fork=1 -ignore_crashes=1 -ignore_ooms=1 -ignore_timeouts=1 >"$log" 2>&1
  cpu=$(awk '{printf "%.0f", $1 + $2}' "$work/$name.time" 2>/dev/null || echo "?")
  # Fork mode's status lines: "#EXECS: cov: C ft: F corp: N exec/s: R oom/timeout/crash: ..."
  execs=$(grep -o '^#[0-9]*: cov' "$log" | tail -1 | tr -dc '0-9')
  rate=$(grep -o 'exec/s:\? [0-9]*' "$log" | tail -1 | awk '{print $2}')
  rss=$(sed -n 's/^stat::peak_rss_mb: *//p' "$log" | sort -n | tail -1)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
  ft=$(grep -o 'ft: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
  corpus=$(find "$work/corpus/$name" -type f | wc -l)
  findings=$(find "$work/artifacts" -name "$name-*" -type f | wc -l)
  printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$name" "$seconds" "$cpu" "${execs:-?}" \
    "${rate:-?}" "${cov:-?}" "${ft:-?}" "$corpus" "${rss:-?}" "$findings" >>"$work/summary.tsv"
done
