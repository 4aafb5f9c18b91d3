#!/bin/bash
# A real single-node Slurm run of the job scripts in this folder: starts munged, slurmctld and
# slurmd on localhost (private config, ports, state and sockets in a temporary folder), submits
# scripts/slurm/submit.sh with N shards of test_experiment.json, requeues one array task while it
# runs (it must resume from its journal), waits for the dependent merge + report + regress job
# (baseline: the same experiment run unsharded beforehand), and checks that the merged
# deterministic files equal the unsharded ones byte for byte. Stops every daemon it started,
# whatever happens.
#
# Usage: scripts/slurm/test_local.sh [--bin PATH/turbid] [--shards N] [--keep] [--limit SECONDS]
#                                   [--pattern-results]
# Exit status: 0 passed, 1 failed, 77 skipped (Slurm cannot start here; the reason is printed).
# Needs: root (slurmd starts job steps as the submitting user), Debian's slurm-wlm and munge
# (scripts/install_deps.sh --slurm), python3.
set -uo pipefail

here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
bin="$root/build/turbid"
shards=3
keep=0
limit=300
pattern_results=0
while (($#)); do
  case "$1" in
    --bin) bin=$2; shift 2 ;;
    --shards) shards=$2; shift 2 ;;
    --keep) keep=1; shift ;;
    --limit) limit=$2; shift 2 ;;
    --pattern-results) pattern_results=1; shift ;;
    *) echo "usage: $0 [--bin PATH] [--shards N] [--keep] [--limit SECONDS] [--pattern-results]" >&2; exit 2 ;;
  esac
done
start_s=$SECONDS
skip() { echo "SKIP: slurm test: $*" >&2; exit 77; }
fail() { echo "FAIL: slurm test: $*" >&2; exit 1; }
note() { printf '[%3ds] %s\n' $((SECONDS - start_s)) "$*"; }
left() { echo $((limit - (SECONDS - start_s))); }

((shards >= 3)) || fail "--shards must be at least 3 (one task is requeued mid-run)"
[[ -x "$bin" ]] || fail "no turbid binary at $bin (build first, or pass --bin)"
bin=$(realpath "$bin")
export PATH="$PATH:/usr/sbin:/sbin"
for tool in munged munge slurmctld slurmd sbatch squeue scontrol sinfo sacct python3; do
  if ! command -v "$tool" >/dev/null; then
    [[ "$tool" == sacct ]] && continue
    skip "'$tool' is not installed (Debian: scripts/install_deps.sh --slurm installs slurm-wlm and munge)"
  fi
done
[[ "$(id -u)" == 0 ]] || skip "needs root to start slurmd (it starts jobs as their user); run as root"

tmp=$(mktemp -d /tmp/turbid-slurm.XXXXXX) || fail "cannot create a temporary folder"
chmod 711 "$tmp"
mkdir -p "$tmp"/{munge,state,spool,log,work}
chmod 711 "$tmp/munge"
export SLURM_CONF="$tmp/slurm.conf"
passed=0

cleanup() {
  # Stop what this script started, by pid file: never by name.
  if [[ -f "$tmp/slurmctld.pid" || -f "$tmp/slurmd.pid" ]]; then
    timeout 20 scontrol shutdown >/dev/null 2>&1
  fi
  for pidfile in "$tmp/slurmd.pid" "$tmp/slurmctld.pid" "$tmp/munge/munged.pid"; do
    [[ -f "$pidfile" ]] || continue
    pid=$(cat "$pidfile" 2>/dev/null)
    [[ -n "$pid" ]] || continue
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; kill "$pid" 2>/dev/null; sleep 0.2; done
    kill -9 "$pid" 2>/dev/null
  done
  if ((passed && !keep)); then
    rm -rf "$tmp"
  else
    echo "slurm test: files and daemon logs kept in $tmp" >&2
  fi
}
trap cleanup EXIT
trap 'exit 1' INT TERM HUP  # so that the EXIT trap stops the daemons

# A free TCP port on localhost, from a random start (several test runs may share a machine).
free_port() {
  local port=$((20000 + RANDOM % 20000))
  for _ in $(seq 200); do
    if ! (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null && [[ "$port" != "${1:-}" ]]; then
      echo "$port"
      return
    fi
    port=$((port + 1))
  done
  return 1
}

# munge: a fresh key and a private socket.
dd if=/dev/urandom of="$tmp/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$tmp/munge/munge.key"
munged --key-file="$tmp/munge/munge.key" --socket="$tmp/munge/munge.socket" \
  --pid-file="$tmp/munge/munged.pid" --log-file="$tmp/munge/munged.log" \
  --seed-file="$tmp/munge/munged.seed" --force ||
  skip "munged does not start: $(tail -n 1 "$tmp/munge/munged.log" 2>/dev/null)"
munge -S "$tmp/munge/munge.socket" -n | unmunge -S "$tmp/munge/munge.socket" >/dev/null 2>&1 ||
  skip "munge cannot encode and decode a credential: $(tail -n 1 "$tmp/munge/munged.log")"

host=$(hostname -s)
cpus=$(nproc)
ctld_port=$(free_port) || skip "no free TCP port on localhost"
slurmd_port=$(free_port "$ctld_port") || skip "no free TCP port on localhost"
cat >"$SLURM_CONF" <<EOF
ClusterName=turbidtest
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
AuthType=auth/munge
CredType=cred/munge
# cred_expire also delays a requeued job (default 120 s); 10 s keeps the test short.
AuthInfo=socket=$tmp/munge/munge.socket,cred_expire=10
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldLogFile=$tmp/log/slurmctld.log
SlurmdLogFile=$tmp/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
MpiDefault=none
ReturnToService=2
SchedulerParameters=sched_interval=1
JobRequeue=1
MinJobAge=600
KillWait=5
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=turbid Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
slurmctld -f "$SLURM_CONF" -i ||
  skip "slurmctld does not start: $(tail -n 1 "$tmp/log/slurmctld.log" 2>/dev/null)"
slurmd -f "$SLURM_CONF" -N "$host" ||
  skip "slurmd does not start: $(tail -n 1 "$tmp/log/slurmd.log" 2>/dev/null)"
state=""
for _ in $(seq 60); do
  state=$(sinfo -h -N -o %T 2>/dev/null | head -n 1)
  [[ "$state" == idle* ]] && break
  sleep 0.5
done
[[ "$state" == idle* ]] ||
  skip "the node did not come up (state '$state'): $(grep -h error "$tmp"/log/*.log | grep -v -i pmix | tail -n 1)"
note "slurm is up: slurmctld :$ctld_port, slurmd :$slurmd_port, node $host with $cpus CPUs"

# The experiment and its external method, copied so that the run writes nothing into the
# repository. The experiment's and the results' folders hold a space, commas (a naive
# --export=...,TURBID_OUT=... would start a new variable at each) and quotes, the experiment's
# also '%' and a backslash: the jobs must find them unchanged.
wdir="$tmp/work/exp a b,LD_PRELOAD=x,TURBID_SHARDS=9 100%j 'q' \"d\" \\"
mkdir -p "$wdir" || fail "cannot create $wdir"
cp "$here/test_experiment.json" "$here/slow_copy.py" "$wdir/"
exp="$wdir/test_experiment.json"
out="$tmp/work/results, a b,LD_PRELOAD=x 'q' \"d\""
# With --pattern-results the results folder holds '%' and '\' too: Slurm's --output cannot name
# it, and the jobs write their logs there themselves (submit.sh sets TURBID_SELF_LOG).
((pattern_results)) && out="$out 100%A_%a \\ x"
# Its external method runs only with --allow-commands (TURBID_ALLOW_COMMANDS=1 for the scripts).
"$bin" sweep "$exp" --out "$tmp/work/none" --dry-run >/dev/null 2>&1 &&
  fail "turbid sweep --dry-run accepted an external command without --allow-commands"
total=$("$bin" sweep "$exp" --out "$tmp/work/none" --dry-run --allow-commands | grep -o '= [0-9]* items' | cut -d' ' -f2)
[[ -n "$total" ]] || fail "turbid sweep --dry-run does not print the item count"
# The unsharded reference, outside Slurm, first: its summary is the merge job's regress baseline.
timeout "$(left)" "$bin" sweep "$exp" --out "$tmp/work/whole" --quiet --allow-commands >"$tmp/log/whole.out" 2>&1 ||
  fail "the unsharded sweep failed: $(tail -n 1 "$tmp/log/whole.out")"
note "unsharded sweep done"
ids=$(cd "$tmp/work" && TURBID_BIN="$bin" TURBID_BASELINE="$tmp/work/whole/summary.csv" \
  TURBID_ALLOW_COMMANDS=1 bash "$here/submit.sh" "$exp" "$out" "$shards") ||
  fail "submit.sh failed"
read -r array merge <<<"$ids"
note "submitted array job $array (shards 0-$((shards - 1)) of $total items) and merge job $merge"

# Requeue task 1 once it has journaled an item but is not finished.
victim=1
victim_journal="$out/shard-$victim/journal.jsonl"
requeued=0
gone=0
while (($(left) > 0)); do
  task_state=$(squeue -h -j "${array}_$victim" -o %T 2>/dev/null)
  lines=0
  [[ -f "$victim_journal" ]] && lines=$(wc -l <"$victim_journal")
  if [[ "$task_state" == RUNNING ]] && ((lines >= 1)); then
    scontrol requeue "${array}_$victim" || fail "scontrol requeue ${array}_$victim failed"
    requeued=$lines
    note "requeued task ${array}_$victim while running, after $lines journaled items"
    break
  fi
  # Gone from the queue (several polls in a row, not one slow answer) or completed: too late.
  if [[ -z "$task_state" || "$task_state" == COMPLETED ]]; then gone=$((gone + 1)); else gone=0; fi
  ((gone < 10)) || fail "task ${array}_$victim finished before it could be requeued (make the items slower)"
  sleep 0.2
done
((requeued)) || fail "timed out waiting for task ${array}_$victim to start"

# Wait for the merge job (it starts after every array task succeeded).
merge_state=""
while (($(left) > 0)); do
  merge_state=$(scontrol show job "$merge" 2>/dev/null | grep -o 'JobState=[A-Z_]*' | cut -d= -f2)
  case "$merge_state" in
    COMPLETED | FAILED | CANCELLED | TIMEOUT | NODE_FAIL | OUT_OF_MEMORY) break ;;
  esac
  sleep 1
done
note "merge job $merge: ${merge_state:-unknown}"
if [[ "$merge_state" != COMPLETED ]]; then
  tail -n 5 "$out"/logs/*.out >&2
  squeue >&2
  fail "the merge job ended as '${merge_state:-still running after ${limit}s}'"
fi
restarts=$(scontrol show job "${array}_$victim" | grep -o 'Restarts=[0-9]*' | cut -d= -f2)
((restarts >= 1)) || fail "task ${array}_$victim shows Restarts=${restarts:-?}, expected >= 1"
grep -q "restart 1" "$out/logs/sweep-${array}_$victim.out" ||
  fail "the requeued task's log does not show its second start"
grep -q "already done" "$out/logs/sweep-${array}_$victim.out" ||
  fail "the requeued task did not resume from its journal: $(tail -n 1 "$out/logs/sweep-${array}_$victim.out")"
for ((i = 0; i < shards; ++i)); do
  want=$(((total - i + shards - 1) / shards))
  got=$(grep -c . "$out/shard-$i/journal.jsonl")
  ((got == want)) || fail "shard $i journaled $got items, expected $want (an item ran twice or was lost)"
done
note "task $victim restarted $restarts time(s); every shard journaled each of its items once"
[[ -s "$out/merged/report.html" ]] || fail "the merge job wrote no report"
grep -q "regress: OK" "$out"/logs/merge-*.out || fail "the merge job's regress did not pass"

for f in experiment.json items.csv items.jsonl summary.md summary.csv; do
  cmp -s "$out/merged/$f" "$tmp/work/whole/$f" || fail "merged $f differs from the unsharded run's"
done
diff -r -q "$out/merged/thumbs" "$tmp/work/whole/thumbs" >/dev/null ||
  fail "merged thumbnails differ from the unsharded run's"
[[ ! -e "$tmp/work/results" && ! -e "$tmp/work/exp a b" ]] || fail "a path was split: $(ls "$tmp/work")"
passed=1
note "PASS: $shards shards (task $victim requeued mid-run), experiment and results paths with spaces, commas, quotes (and %, a backslash), merged equal the unsharded run byte for byte (experiment.json, items.csv, items.jsonl, summary.md, summary.csv, thumbs/)"
