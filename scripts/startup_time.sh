#!/usr/bin/env bash
# Whole-process start-up times (issue 18 item 0): `turbid --version` and `turbid score --ref A B`
# on a 640x480 colour pair, beside the floor of an empty program (/bin/true: a C program linked
# with libc only) measured the same way in the same run. Each process is started with
# posix_spawn and reaped with wait4 by a small Python timer; per run it records the wall time
# (spawn to exit: exec, dynamic loading, work, exit) and the CPU time (user + system, from the
# kernel's rusage of that child). Printed: median, min and max over N runs, in rounds that
# interleave the three commands so that load on the machine hits them alike. On a shared,
# loaded machine the wall time includes waiting for a core; the CPU time does not.
# Usage: scripts/startup_time.sh [BUILD_DIR] [N]     (defaults: build 30)
set -euo pipefail

build=${1:-build}
n=${2:-30}
turbid="$build/turbid"
[[ -x "$turbid" ]] || { echo "startup_time: $turbid not found (build the turbid target)" >&2; exit 1; }
command -v python3 >/dev/null || { echo "startup_time: python3 is needed for the timer" >&2; exit 1; }

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# The pair: the built-in seafloor scene (640x480 colour) and a render of it in coastal water.
"$turbid" scene seafloor --out "$work/scene" >/dev/null
"$turbid" render --scene seafloor --water 3C --seed 1 --out "$work/degraded.png" >/dev/null
ref="$work/scene/seafloor/image.png"
img="$work/degraded.png"

echo "libraries loaded by $turbid: $(LD_TRACE_LOADED_OBJECTS=1 "$turbid" | wc -l)"
echo "machine: $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg)"
python3 - "$n" "$turbid" "$ref" "$img" <<'EOF'
import os, statistics, sys, time

n, turbid, ref, img = int(sys.argv[1]), sys.argv[2], sys.argv[3], sys.argv[4]
commands = [
    ("empty program (/bin/true)", ["/bin/true"]),
    ("turbid --version", [turbid, "--version"]),
    ("turbid score --ref A B (640x480)", [turbid, "score", "--ref", ref, img]),
]
devnull = os.open(os.devnull, os.O_WRONLY)
actions = [(os.POSIX_SPAWN_DUP2, devnull, 1)]

def run_once(argv):
    start = time.perf_counter()
    pid = os.posix_spawn(argv[0], argv, os.environ, file_actions=actions)
    _, status, usage = os.wait4(pid, 0)
    wall = time.perf_counter() - start
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit(f"startup_time: {' '.join(argv)} failed")
    return wall * 1e3, (usage.ru_utime + usage.ru_stime) * 1e3

for _, argv in commands:  # warm the page cache
    run_once(argv)
samples = {name: ([], []) for name, _ in commands}
for _ in range(n):
    for name, argv in commands:
        wall, cpu = run_once(argv)
        samples[name][0].append(wall)
        samples[name][1].append(cpu)

print(f"per process, ms, over {n} runs: median [min, max]")
print(f"{'command':<34} {'wall':>24} {'CPU (user+sys)':>24}")
def fmt(v):
    return f"{statistics.median(v):7.1f} [{min(v):6.1f}, {max(v):6.1f}]"
for name, _ in commands:
    wall, cpu = samples[name]
    print(f"{name:<34} {fmt(wall):>24} {fmt(cpu):>24}")
EOF
