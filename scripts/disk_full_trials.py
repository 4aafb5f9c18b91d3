#!/usr/bin/env python3
"""Disk-full trials: run `turbid sweep`, `turbid generate` and `turbid merge` into a tmpfs that
fills up at a random point, free the space, rerun, and check that nothing was lost
(docs/reliability.md, "Nothing lost on a full disk").

Each trial mounts a tmpfs of one of --sizes MiB (root only), fills it with a ballast file so that
a random fraction (uniform in [0.02, 0.98]) of what the command writes still fits, and runs the
command into it. The run must fail with exit status 1 and exactly one stderr line
"turbid: error: <file>: ... No space left on device ..." naming a file under the output folder;
what it left must be sound: no temporary file, every file under its final name identical to the
uninterrupted run's, every complete journal line one of the uninterrupted run's (timings aside:
in particular no method failure), at most one of each item. Then the ballast is removed and the
same command is run again: it must succeed, and the folder must equal the uninterrupted run's
file for file (journal order and timing tables aside), with no temporary left.

    sudo python3 scripts/disk_full_trials.py --bin build/turbid --trials 30 --table disk_table.md

Exit status 0 when every trial held, 1 otherwise, 77 when tmpfs cannot be mounted (not root, no
mount permission): the ctest registration skips then.
"""

import argparse
import json
import os
import random
import re
import shutil
import subprocess
import sys
import tempfile

EXPERIMENT = {
    "name": "disk_full_trials",
    "description": "scripts/disk_full_trials.py: two small built-in scenes, eight turbidity levels",
    "seed": 11,
    "scale": 0.1,
    "scenes": ["builtin:hull", "builtin:seafloor"],
    "grid": {"water.type": ["I", "IA", "IB", "II", "III", "1C", "3C", "7C"]},
    "methods": ["clahe", "dcp"],
    "metrics": ["ssim", "psnr"],
    "thumbnails": 48,
}

GENERATE = {
    "scenes": ["builtin:hull", "builtin:seafloor"],
    "scale": 0.1,
    "seed": 3,
    "grid": {"water.type": ["I", "III", "5C", "9C"]},
}

TIMING_KEYS = {"render_ms", "time_ms", "time_batch"}
TEMPORARY = re.compile(r"^\..+\.tmp[0-9a-f]+(\.[^.]+)?$")
ENOSPC = os.strerror(28)  # "No space left on device"
SKIP = 77


def strip_timing(value):
    if isinstance(value, dict):
        return {k: strip_timing(v) for k, v in value.items() if k not in TIMING_KEYS}
    if isinstance(value, list):
        return [strip_timing(v) for v in value]
    return value


def list_files(root):
    out = {}
    for folder, _, files in os.walk(root):
        for name in files:
            path = os.path.join(folder, name)
            rel = os.path.relpath(path, root)
            if rel != ".turbid.lock":
                out[rel] = path
    return out


def read(path):
    with open(path, "rb") as f:
        return f.read()


def mount_tmpfs(path, mib):
    os.makedirs(path, exist_ok=True)
    proc = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={mib}m", "tmpfs", path],
                          capture_output=True, text=True)
    return proc.returncode == 0, proc.stderr.strip()


def umount(path):
    subprocess.run(["umount", path], capture_output=True)


def free_bytes(path):
    st = os.statvfs(path)
    return st.f_bavail * st.f_frsize


def write_ballast(path, size):
    """Writes `size` bytes (tmpfs stores zero pages too), unbuffered; stops quietly when the disk
    is full (the last page may not fit)."""
    chunk = bytes(1 << 20)
    with open(path, "wb", buffering=0) as f:
        left = size
        while left > 0:
            try:
                n = f.write(chunk[:min(left, len(chunk))])
            except OSError:
                break
            left -= n


def run(cmd, log):
    proc = subprocess.run(cmd, capture_output=True, text=True)
    log.write(f"$ {' '.join(cmd)}\n[{proc.returncode}]\n{proc.stdout}{proc.stderr}\n")
    return proc


class Trial:
    def __init__(self):
        self.problems = []

    def fail(self, what):
        self.problems.append(what)


def check_partial(out, ref, journal_ref, trial):
    """What a stopped run leaves: no temporary, final-named files equal to the reference's,
    complete journal lines from the reference, no item twice."""
    for rel, path in list_files(out).items():
        name = os.path.basename(rel)
        if TEMPORARY.match(name):
            trial.fail(f"temporary left by the stopped run: {rel}")
            continue
        if rel == "journal.jsonl" or rel.startswith("timings."):
            continue
        want = os.path.join(ref, rel)
        if not os.path.exists(want):
            trial.fail(f"{rel}: not in the uninterrupted run's folder")
        elif read(path) != read(want):
            trial.fail(f"{rel}: differs from the uninterrupted run's (a partial file?)")
    journal = os.path.join(out, "journal.jsonl")
    if journal_ref is None or not os.path.exists(journal):
        return 0
    text = read(journal).decode("utf-8", "replace")
    if text and not text.endswith("\n"):
        trial.fail("journal.jsonl: a partial last line")
    seen = set()
    for line in text.split("\n"):
        if not line:
            continue
        try:
            entry = json.loads(line)
        except ValueError:
            trial.fail("journal.jsonl: an unparseable line")
            continue
        item = entry.get("id")
        if item in seen:
            trial.fail(f"journal.jsonl: {item} twice")
        seen.add(item)
        if strip_timing(entry) != journal_ref.get(item):
            trial.fail(f"journal.jsonl: {item} differs from the uninterrupted run's "
                       "(a method failure recorded?)")
    return len(seen)


def check_final(out, ref, trial):
    got, want = list_files(out), list_files(ref)
    for rel in sorted(set(got) | set(want)):
        if TEMPORARY.match(os.path.basename(rel)):
            trial.fail(f"temporary left after the rerun: {rel}")
        elif rel == "journal.jsonl" or rel.startswith("timings."):
            continue
        elif rel not in got:
            trial.fail(f"{rel}: missing after the rerun")
        elif rel not in want:
            trial.fail(f"{rel}: not in the uninterrupted run's folder")
        elif read(got[rel]) != read(want[rel]):
            trial.fail(f"{rel}: differs from the uninterrupted run's")
    if "journal.jsonl" in want:
        ids = lambda p: sorted(strip_timing(json.loads(l))["id"] for l in read(p).decode().split(
            "\n") if l)
        if "journal.jsonl" not in got or ids(got["journal.jsonl"]) != ids(want["journal.jsonl"]):
            trial.fail("journal.jsonl: not the uninterrupted run's items")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bin", required=True, help="the turbid executable")
    parser.add_argument("--trials", type=int, default=12, help="trials in all (commands in turn)")
    parser.add_argument("--sizes", default="2,4,8", help="tmpfs sizes in MiB, drawn per trial")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--commands", default="sweep,generate,merge")
    parser.add_argument("--threads", default="2")
    parser.add_argument("--scale", type=float, default=0.1, help="built-in scene scale")
    parser.add_argument("--work", help="work folder (default: a temporary one, removed)")
    parser.add_argument("--table", help="also write the result table (Markdown) here")
    args = parser.parse_args()
    rng = random.Random(args.seed)
    sizes = [int(s) for s in args.sizes.split(",")]
    work = args.work or tempfile.mkdtemp(prefix="turbid_disk_")
    os.makedirs(work, exist_ok=True)
    mnt = os.path.join(work, "mnt")
    if os.geteuid() != 0:
        print("disk_full_trials: skipped: mounting a tmpfs needs root")
        return SKIP
    ok, why = mount_tmpfs(mnt, 1)
    if not ok:
        print(f"disk_full_trials: skipped: cannot mount a tmpfs ({why})")
        return SKIP
    umount(mnt)
    log = open(os.path.join(work, "runs.log"), "a")
    bin_ = os.path.abspath(args.bin)
    t = args.threads
    try:
        exp = os.path.join(work, "experiment.json")
        with open(exp, "w") as f:
            json.dump(dict(EXPERIMENT, scale=args.scale), f)
        gen = os.path.join(work, "generate.json")
        with open(gen, "w") as f:
            json.dump(dict(GENERATE, scale=args.scale), f)
        ref = lambda name: os.path.join(work, "ref_" + name)
        for name in ("sweep", "s0", "s1", "merge", "generate"):
            shutil.rmtree(ref(name), ignore_errors=True)
        cmds = {
            "sweep": lambda out: [bin_, "sweep", exp, "--out", out, "--threads", t, "--quiet"],
            "generate": lambda out: [bin_, "generate", gen, "--out", out, "--threads", t],
            "merge": lambda out: [bin_, "merge", ref("s0"), ref("s1"), "--out", out],
        }
        for name, cmd in (("sweep", cmds["sweep"](ref("sweep"))),
                          ("s0", cmds["sweep"](ref("s0")) + ["--shard", "0/2"]),
                          ("s1", cmds["sweep"](ref("s1")) + ["--shard", "1/2"]),
                          ("merge", cmds["merge"](ref("merge"))),
                          ("generate", cmds["generate"](ref("generate")))):
            if run(cmd, log).returncode != 0:
                raise SystemExit(f"disk_full_trials: reference run failed: {' '.join(cmd)}")
        journal_ref = {}
        for line in read(os.path.join(ref("sweep"), "journal.jsonl")).decode().split("\n"):
            if line:
                entry = json.loads(line)
                journal_ref[entry["id"]] = strip_timing(entry)
        # What each command writes (tmpfs stores every file in whole 4 KiB pages).
        need = {c: sum(-(-os.path.getsize(p) // 4096) * 4096 for p in list_files(ref(c)).values())
                for c in cmds}

        commands = args.commands.split(",")
        rows = {c: {"trials": 0, "sizes": set(), "one_line": 0, "journaled": 0, "items": 0,
                    "sound": 0, "identical": 0, "failed": 0} for c in commands}
        failed = False
        for k in range(args.trials):
            command = commands[k % len(commands)]
            size = rng.choice(sizes)
            trial = Trial()
            row = rows[command]
            ok, why = mount_tmpfs(mnt, size)
            if not ok:
                raise SystemExit(f"disk_full_trials: cannot mount a {size} MiB tmpfs: {why}")
            try:
                fraction = rng.uniform(0.02, 0.98)
                ballast = os.path.join(mnt, "ballast")
                room = int(need[command] * fraction)
                if free_bytes(mnt) < need[command] + 65536:
                    raise SystemExit(f"disk_full_trials: {size} MiB is too small for {command} "
                                     f"({need[command]} bytes): raise --sizes")
                write_ballast(ballast, free_bytes(mnt) - room)
                out = os.path.join(mnt, "out")
                cmd = cmds[command](out)
                first = run(cmd, log)
                # generate's progress ("generate: 10/16 items\r") is not an error line.
                err_lines = [l for l in first.stderr.splitlines()
                             if l and not re.match(r"^generate: \d+/\d+ items$", l)]
                if first.returncode != 1:
                    trial.fail(f"the run on a full disk exited {first.returncode} "
                               f"({fraction:.2f} of the output fitted)")
                elif (len(err_lines) == 1 and err_lines[0].startswith("turbid: error: " + out + "/")
                      and ENOSPC in err_lines[0]):
                    row["one_line"] += 1
                else:
                    trial.fail(f"not one clear line naming a file under the output: {first.stderr!r}")
                reference = ref(command)
                items = check_partial(out, reference, journal_ref if command == "sweep" else None,
                                      trial)
                row["journaled"] += items
                row["items"] += len(journal_ref) if command == "sweep" else 0
                sound = not trial.problems
                os.remove(ballast)
                second = run(cmd, log)
                if second.returncode != 0:
                    trial.fail(f"the rerun exited {second.returncode}: {second.stderr.strip()}")
                else:
                    check_final(out, reference, trial)
                row["trials"] += 1
                row["sizes"].add(size)
                row["sound"] += sound
                row["identical"] += not trial.problems
                if trial.problems:
                    row["failed"] += 1
                    failed = True
                    print(f"{command} trial {k} ({size} MiB, {fraction:.2f} fitted): " +
                          "; ".join(trial.problems[:10]), file=sys.stderr)
            finally:
                umount(mnt)
        table = ["| command | trials | tmpfs sizes (MiB) | stopped with one line naming the file "
                 "(ENOSPC) | left nothing partial, no method failure journaled | items journaled "
                 "before the disk filled | identical after a plain rerun |",
                 "|---|---|---|---|---|---|---|"]
        for command in commands:
            r = rows[command]
            journaled = f"{r['journaled']} of {r['items']}" if command == "sweep" else "–"
            table.append(f"| {command} | {r['trials']} | {', '.join(map(str, sorted(r['sizes'])))}"
                         f" | {r['one_line']} | {r['sound']} | {journaled} | {r['identical']} |")
        text = "\n".join(table) + "\n"
        print(text, end="")
        if args.table:
            with open(args.table, "w") as f:
                f.write(text)
        return 1 if failed else 0
    finally:
        log.close()
        umount(mnt)
        if not args.work:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
