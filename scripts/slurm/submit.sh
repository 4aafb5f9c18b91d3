#!/bin/bash
# Submits a turbid sweep to Slurm: a job array of N shards and a merge + report job that starts
# after every array task succeeded. Prints the two job ids ("ARRAY_ID MERGE_ID").
#
# Usage: scripts/slurm/submit.sh EXP.json RESULTS_DIR N [sbatch options for the array...]
#   e.g. scripts/slurm/submit.sh scenes/experiments/table1.json results/table1 32 \
#          --cpus-per-task=8 --time=02:00:00 --partition=cpu
# Environment: TURBID_BIN (default ./build/turbid), TURBID_SWEEP_ARGS, TURBID_ALLOW_COMMANDS=1
# (run the experiment's external commands: --allow-commands), TURBID_BASELINE (see the
# .sbatch files), TURBID_ARRAY_THROTTLE (k: at most k tasks at once), TURBID_MERGE_SBATCH_ARGS.
# TURBID_SWEEP_ARGS and TURBID_MERGE_SBATCH_ARGS are split at whitespace (spaces, tabs, newlines)
# and nothing else: no quotes, no globbing, no expansion, so one argument cannot hold a space.
#
# Paths may hold any character (spaces, commas, '%', quotes, backslashes, newlines): they reach
# the jobs as environment variables of this process (sbatch --export=ALL), never in --export's
# comma-separated list. Logs go to RESULTS_DIR/logs; Slurm's --output names that folder only when
# it holds no '%' and no '\' (Slurm reads both as patterns); otherwise the jobs write their logs
# there themselves (TURBID_SELF_LOG=1) and Slurm's own output goes to /dev/null. Paths are made
# absolute, so the jobs may start on any node.
set -euo pipefail
if (($# < 3)); then
  echo "usage: $0 EXP.json RESULTS_DIR N [sbatch options for the array...]" >&2
  exit 2
fi
here=$(cd "$(dirname "$0")" && pwd)
exp=$(realpath -- "$1")
out=$(realpath -m -- "$2")
n=$3
shift 3
if ! [[ "$n" =~ ^[1-9][0-9]*$ ]]; then
  echo "submit.sh: N must be a positive integer, got '$n'" >&2
  exit 2
fi
if [[ -n "${TURBID_ARRAY_THROTTLE:-}" && ! "$TURBID_ARRAY_THROTTLE" =~ ^[1-9][0-9]*$ ]]; then
  echo "submit.sh: TURBID_ARRAY_THROTTLE must be a positive integer, got '$TURBID_ARRAY_THROTTLE'" >&2
  exit 2
fi
[[ -f "$exp" ]] || { echo "submit.sh: no experiment file $exp" >&2; exit 2; }
bin=$(realpath -- "${TURBID_BIN:-./build/turbid}")
[[ -x "$bin" ]] || { echo "submit.sh: $bin is not executable (set TURBID_BIN)" >&2; exit 2; }
# Whitespace-separated lists of arguments, without glob or any other expansion.
split_words() {  # split_words ARRAY_NAME TEXT
  local -n words=$1
  words=()
  [[ -n "$2" ]] || return 0
  read -r -d '' -a words <<<"$2" || true
}
split_words sweep_args "${TURBID_SWEEP_ARGS:-}"
split_words merge_args "${TURBID_MERGE_SBATCH_ARGS:-}"
# Validate before queueing anything: a bad experiment fails here, not in N tasks.
allow=()
[[ "${TURBID_ALLOW_COMMANDS:-}" == 1 ]] && allow=(--allow-commands)
"$bin" sweep "$exp" --out "$out/shard-0" --shard "0/$n" --dry-run "${allow[@]}" "${sweep_args[@]}" \
  >/dev/null || {
  echo "submit.sh: the experiment does not validate (see above); if it names external commands" \
    "you trust, set TURBID_ALLOW_COMMANDS=1" >&2
  exit 2
}
mkdir -p "$out/logs"
range="0-$((n - 1))${TURBID_ARRAY_THROTTLE:+%$TURBID_ARRAY_THROTTLE}"
# What the jobs read (sweep.sbatch, merge.sbatch): exported here, passed on by --export=ALL.
export TURBID_EXP="$exp" TURBID_OUT="$out" TURBID_BIN="$bin" TURBID_SHARDS="$n"
export TURBID_ALLOW_COMMANDS="${TURBID_ALLOW_COMMANDS:-0}"
if [[ -n "${TURBID_BASELINE:-}" ]]; then
  TURBID_BASELINE=$(realpath -- "$TURBID_BASELINE")
  export TURBID_BASELINE
fi
# Slurm's --output is a pattern: '%' starts a field and any '\' turns the fields off. A folder
# free of both is named as it is; otherwise the jobs write their logs themselves.
if [[ "$out" == *[%\\]* ]]; then
  export TURBID_SELF_LOG=1
  sweep_log=/dev/null merge_log=/dev/null
  echo "submit.sh: RESULTS_DIR holds '%' or '\\', which Slurm's --output cannot name: the jobs" \
    "write their logs to RESULTS_DIR/logs themselves (Slurm's own messages are not kept)" >&2
else
  unset TURBID_SELF_LOG
  sweep_log="$out/logs/sweep-%A_%a.out" merge_log="$out/logs/merge-%j.out"
fi
# --export=ALL comes after the user's options so that it is the one in effect.
array=$(sbatch --parsable --array="$range" --output="$sweep_log" "$@" --export=ALL \
  "$here/sweep.sbatch")
array=${array%%;*}
[[ "$array" =~ ^[0-9]+$ ]] || { echo "submit.sh: sbatch returned no job id ('$array')" >&2; exit 1; }
merge=$(sbatch --parsable --dependency="afterok:$array" --kill-on-invalid-dep=yes \
  --output="$merge_log" "${merge_args[@]}" --export=ALL "$here/merge.sbatch")
merge=${merge%%;*}
echo "$array $merge"
