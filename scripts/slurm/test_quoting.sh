#!/bin/bash
# Quoting test of the Slurm scripts, without Slurm: paths with spaces, commas, '%', quotes,
# backslashes, '$(...)' and a newline must reach the jobs unchanged and never inside an sbatch
# option (a comma in --export=...,VAR=value starts a new variable); Slurm's --output names
# RESULTS_DIR/logs only when it holds no '%' or '\' (patterns there), else the jobs log themselves. A fake `sbatch` first on PATH records each call (arguments, working folder,
# environment); then sweep.sbatch and merge.sbatch run as Slurm would start them (array tasks
# 0 and 1 of 2, then the merge + report + regress) with the real turbid on a tiny experiment,
# and the merged tables must equal an unsharded run's.
#
# Usage: scripts/slurm/test_quoting.sh [--bin PATH/turbid] [--keep]
# Exit status: 0 passed, 1 failed.
set -uo pipefail

here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
bin="$root/build/turbid"
keep=0
while (($#)); do
  case "$1" in
    --bin) bin=$2; shift 2 ;;
    --keep) keep=1; shift ;;
    *) echo "usage: $0 [--bin PATH] [--keep]" >&2; exit 2 ;;
  esac
done
fail() { echo "FAIL: slurm quoting test: $*" >&2; exit 1; }
[[ -x "$bin" ]] || fail "no turbid binary at $bin (build first, or pass --bin)"
bin=$(realpath "$bin")

tmp=$(mktemp -d /tmp/turbid-slurm-quoting.XXXXXX) || fail "cannot create a temporary folder"
passed=0
cleanup() {
  if ((passed && !keep)); then rm -rf "$tmp"; else echo "slurm quoting test: files kept in $tmp" >&2; fi
}
trap cleanup EXIT

# Hostile folder names: each would break a naive script, and the payloads would create files in
# $tmp/pwned if a shell ran them.
mkdir -p "$tmp/pwned" "$tmp/bin"
export TURBID_PWNED="$tmp/pwned"
nasty="a b,LD_PRELOAD=/x,TURBID_SHARDS=9 100%j %A 'q' \"d\" \\ \$(cd \$TURBID_PWNED; touch d) \`cd \$TURBID_PWNED; touch b\`
line2"
work="$tmp/work/$nasty"
mkdir -p "$work/exp $nasty" || fail "cannot create the folders"
exp="$work/exp $nasty/tiny, 50%.json"
out="$work/results $nasty"
cat >"$exp" <<'JSON'
{"name": "slurm_quoting", "seed": 5, "scale": 0.1, "scenes": ["builtin:hull"],
 "grid": {"@turbidity": [{"label": "0.3", "x": 0.3, "water.beta_gray_per_m": 0.3},
                         {"label": "1.2", "x": 1.2, "water.beta_gray_per_m": 1.2}]},
 "methods": ["clahe"], "metrics": ["ssim", "psnr"], "thumbnails": 32}
JSON

# The fake sbatch: call k writes call-k/args (NUL-separated), call-k/pwd and call-k/env
# (NUL-separated), and answers job id 1000+k as `sbatch --parsable` does.
cat >"$tmp/bin/sbatch" <<'FAKE'
#!/bin/bash
k=$(($(ls -d "$FAKE_SBATCH_LOG"/call-* 2>/dev/null | wc -l) + 1))
d="$FAKE_SBATCH_LOG/call-$k"
mkdir -p "$d"
printf '%s\0' "$@" >"$d/args"
pwd >"$d/pwd"
env -0 >"$d/env"
echo "$((1000 + k));cluster"
FAKE
chmod +x "$tmp/bin/sbatch"
export FAKE_SBATCH_LOG="$tmp/sbatch-log"
mkdir -p "$FAKE_SBATCH_LOG"

# The unsharded reference (also the regress baseline, given by a relative path).
"$bin" sweep "$exp" --out "$work/whole" --quiet >"$tmp/whole.log" 2>&1 ||
  fail "the unsharded sweep failed: $(tail -n 1 "$tmp/whole.log")"

# Submit from a folder holding files that a glob in TURBID_MERGE_SBATCH_ARGS would match.
mkdir -p "$tmp/submit" && touch "$tmp/submit/glob-match-1" "$tmp/submit/glob-match-2"
ids=$(cd "$tmp/submit" && PATH="$tmp/bin:$PATH" TURBID_BIN="$bin" \
  TURBID_BASELINE="../work/$nasty/whole/summary.csv" TURBID_ARRAY_THROTTLE=2 \
  TURBID_MERGE_SBATCH_ARGS=$'--comment=glob-* \t--mem=1G\n' TURBID_SWEEP_ARGS=" --retry-failed " \
  bash "$here/submit.sh" "$exp" "$out" 2 --time=00:10:00 2>"$tmp/submit.err") ||
  fail "submit.sh failed: $(cat "$tmp/submit.err")"
[[ "$ids" == "1001 1002" ]] || fail "submit.sh printed '$ids', expected '1001 1002'"

args_of() { local -n list=$1; mapfile -d '' -t list <"$FAKE_SBATCH_LOG/$2/args"; }
env_of() {  # env_of CALL NAME: the value of NAME in that call's environment
  local line
  while IFS= read -r -d '' line; do
    [[ "$line" == "$2="* ]] && { printf '%s' "${line#*=}"; return 0; }
  done <"$FAKE_SBATCH_LOG/$1/env"
  return 1
}
[[ ! -d "$FAKE_SBATCH_LOG/call-3" ]] || fail "sbatch was called more than twice"
args_of array_args call-1
args_of merge_args call-2
# RESULTS_DIR holds '%' and '\': Slurm's --output cannot name it, the jobs log by themselves.
expected_array=(--parsable --array=0-1%2 --output=/dev/null --time=00:10:00 --export=ALL
  "$here/sweep.sbatch")
expected_merge=(--parsable --dependency=afterok:1001 --kill-on-invalid-dep=yes --output=/dev/null
  "--comment=glob-*" --mem=1G --export=ALL "$here/merge.sbatch")
[[ "${array_args[*]@Q}" == "${expected_array[*]@Q}" ]] ||
  fail "array sbatch arguments: ${array_args[*]@Q}; expected ${expected_array[*]@Q}"
[[ "${merge_args[*]@Q}" == "${expected_merge[*]@Q}" ]] ||
  fail "merge sbatch arguments: ${merge_args[*]@Q}; expected ${expected_merge[*]@Q}"
for call in call-1 call-2; do
  [[ "$(cat "$FAKE_SBATCH_LOG/$call/pwd")" == "$tmp/submit" ]] ||
    fail "sbatch ($call) ran in '$(cat "$FAKE_SBATCH_LOG/$call/pwd")', expected the submit folder"
  [[ "$(env_of $call TURBID_SELF_LOG)" == 1 ]] || fail "TURBID_SELF_LOG ($call) is not 1"
  [[ "$(env_of $call TURBID_ALLOW_COMMANDS)" == 0 ]] || fail "TURBID_ALLOW_COMMANDS ($call) is not 0"
  [[ "$(env_of $call TURBID_EXP)" == "$exp" ]] || fail "TURBID_EXP ($call) is '$(env_of $call TURBID_EXP)'"
  [[ "$(env_of $call TURBID_OUT)" == "$out" ]] || fail "TURBID_OUT ($call) is '$(env_of $call TURBID_OUT)'"
  [[ "$(env_of $call TURBID_SHARDS)" == 2 ]] || fail "TURBID_SHARDS ($call) is '$(env_of $call TURBID_SHARDS)'"
  [[ "$(env_of $call TURBID_BIN)" == "$bin" ]] || fail "TURBID_BIN ($call) is wrong"
  [[ "$(env_of $call TURBID_BASELINE)" == "$work/whole/summary.csv" ]] ||
    fail "TURBID_BASELINE ($call) is '$(env_of $call TURBID_BASELINE)', expected an absolute path"
  ! env_of $call LD_PRELOAD >/dev/null || fail "LD_PRELOAD reached the job environment ($call)"
done
[[ -d "$out/logs" ]] || fail "submit.sh did not create RESULTS_DIR/logs"

# The jobs, started as Slurm starts them: in the submit folder with the recorded environment.
run_job() {  # run_job CALL SCRIPT [VAR=value...]
  local call=$1 script=$2
  shift 2
  (cd "$tmp/submit" && env -i TURBID_SELF_LOG="$(env_of "$call" TURBID_SELF_LOG)" PATH="$PATH" HOME="${HOME:-/tmp}" \
    TURBID_EXP="$(env_of "$call" TURBID_EXP)" TURBID_OUT="$(env_of "$call" TURBID_OUT)" \
    TURBID_BIN="$(env_of "$call" TURBID_BIN)" TURBID_SHARDS="$(env_of "$call" TURBID_SHARDS)" \
    TURBID_BASELINE="$(env_of "$call" TURBID_BASELINE)" TURBID_SWEEP_ARGS="$(env_of "$call" TURBID_SWEEP_ARGS)" \
    TURBID_PWNED="$TURBID_PWNED" "$@" bash "$script")
}
for i in 0 1; do
  log="$out/logs/sweep-1001_$i.out"
  run_job call-1 "$here/sweep.sbatch" SLURM_ARRAY_JOB_ID=1001 SLURM_ARRAY_TASK_ID=$i \
    SLURM_ARRAY_TASK_COUNT=2 >"$tmp/sweep-$i.log" 2>&1 ||
    fail "sweep.sbatch task $i failed: $(tail -n 2 "$log" "$tmp/sweep-$i.log")"
  [[ -s "$out/shard-$i/journal.jsonl" ]] || fail "task $i wrote no journal in RESULTS_DIR/shard-$i"
  grep -q "shard $i/2" "$log" || fail "task $i did not log to RESULTS_DIR/logs/sweep-1001_$i.out"
done
log="$out/logs/merge-1002.out"
run_job call-2 "$here/merge.sbatch" SLURM_JOB_ID=1002 >"$tmp/merge.log" 2>&1 ||
  fail "merge.sbatch failed: $(tail -n 2 "$log" "$tmp/merge.log")"
grep -q "regress: OK" "$log" || fail "the merge job's regress did not pass: $(tail -n 2 "$log")"
[[ -s "$out/merged/report.html" ]] || fail "the merge job wrote no report"
for f in items.csv summary.csv summary.md; do
  cmp -s "$out/merged/$f" "$work/whole/$f" || fail "merged $f differs from the unsharded run's"
done
# A results folder with spaces, commas, quotes, $(...) and a newline but no '%' or '\': Slurm
# writes the logs there itself, named by one --output argument each.
safe="$tmp/work/r a,LD_PRELOAD=x 'q' \"d\" \$(cd \$TURBID_PWNED; touch s)
x"
rm -rf "$FAKE_SBATCH_LOG" && mkdir -p "$FAKE_SBATCH_LOG"
(cd "$tmp/submit" && PATH="$tmp/bin:$PATH" TURBID_BIN="$bin" bash "$here/submit.sh" "$exp" "$safe" 3 \
  >/dev/null 2>"$tmp/submit.err") || fail "submit.sh failed: $(cat "$tmp/submit.err")"
[[ ! -s "$tmp/submit.err" ]] || fail "submit.sh printed: $(cat "$tmp/submit.err")"
args_of array_args call-1
args_of merge_args call-2
expected_array=(--parsable --array=0-2 "--output=$safe/logs/sweep-%A_%a.out" --export=ALL
  "$here/sweep.sbatch")
expected_merge=(--parsable --dependency=afterok:1001 --kill-on-invalid-dep=yes
  "--output=$safe/logs/merge-%j.out" --export=ALL "$here/merge.sbatch")
[[ "${array_args[*]@Q}" == "${expected_array[*]@Q}" ]] ||
  fail "array sbatch arguments: ${array_args[*]@Q}; expected ${expected_array[*]@Q}"
[[ "${merge_args[*]@Q}" == "${expected_merge[*]@Q}" ]] ||
  fail "merge sbatch arguments: ${merge_args[*]@Q}; expected ${expected_merge[*]@Q}"
[[ "$(env_of call-1 TURBID_OUT)" == "$safe" ]] || fail "TURBID_OUT is '$(env_of call-1 TURBID_OUT)'"
! env_of call-1 TURBID_SELF_LOG >/dev/null || fail "TURBID_SELF_LOG set for a folder Slurm can name"
[[ -d "$safe/logs" ]] || fail "submit.sh did not create RESULTS_DIR/logs"

# Nothing else was created: no folder from a split path, no payload ran.
[[ -z "$(ls -A "$TURBID_PWNED")" ]] || fail "a payload ran: $(ls "$TURBID_PWNED")"
[[ "$(ls -A "$tmp/submit")" == $'glob-match-1\nglob-match-2' ]] || fail "files appeared in the submit folder"
passed=1
echo "PASS: submit.sh, sweep.sbatch and merge.sbatch with paths holding spaces, commas, %, quotes, a backslash, \$(...) and a newline"
