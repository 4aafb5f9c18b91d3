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
# Paths are made absolute, so the jobs may start in any folder.
set -euo pipefail
if (($# < 3)); then
  echo "usage: $0 EXP.json RESULTS_DIR N [sbatch options for the array...]" >&2
  exit 2
fi
here=$(cd "$(dirname "$0")" && pwd)
exp=$(realpath "$1")
out=$(realpath -m "$2")
n=$3
shift 3
if ! [[ "$n" =~ ^[1-9][0-9]*$ ]]; then
  echo "submit.sh: N must be a positive integer, got '$n'" >&2
  exit 2
fi
[[ -f "$exp" ]] || { echo "submit.sh: no experiment file $exp" >&2; exit 2; }
bin=$(realpath "${TURBID_BIN:-./build/turbid}")
[[ -x "$bin" ]] || { echo "submit.sh: $bin is not executable (set TURBID_BIN)" >&2; exit 2; }
# Validate before queueing anything: a bad experiment fails here, not in N tasks.
allow=()
[[ "${TURBID_ALLOW_COMMANDS:-}" == 1 ]] && allow=(--allow-commands)
"$bin" sweep "$exp" --out "$out/shard-0" --shard "0/$n" --dry-run ${allow[@]+"${allow[@]}"} >/dev/null || {
  echo "submit.sh: the experiment does not validate (see above); if it names external commands" \
    "you trust, set TURBID_ALLOW_COMMANDS=1" >&2
  exit 2
}
mkdir -p "$out/logs"
range="0-$((n - 1))${TURBID_ARRAY_THROTTLE:+%$TURBID_ARRAY_THROTTLE}"
vars="ALL,TURBID_EXP=$exp,TURBID_OUT=$out,TURBID_BIN=$bin,TURBID_SHARDS=$n,TURBID_ALLOW_COMMANDS=${TURBID_ALLOW_COMMANDS:-0}"
array=$(sbatch --parsable --array="$range" --export="$vars" \
  --output="$out/logs/sweep-%A_%a.out" "$@" "$here/sweep.sbatch")
array=${array%%;*}
# shellcheck disable=SC2086  # TURBID_MERGE_SBATCH_ARGS is a list of options
merge=$(sbatch --parsable --dependency="afterok:$array" --kill-on-invalid-dep=yes \
  --export="$vars" --output="$out/logs/merge-%j.out" ${TURBID_MERGE_SBATCH_ARGS:-} \
  "$here/merge.sbatch")
merge=${merge%%;*}
echo "$array $merge"
