#!/usr/bin/env python3
"""Kill trials: SIGKILL `turbid sweep`, `turbid generate` and `turbid merge` at random moments, rerun
them, and check that nothing was lost, duplicated or corrupted (docs/reliability.md, "Crash safety").

Each trial runs one command into a fresh folder, killing it with SIGKILL after a random delay
(uniform in [0, the uninterrupted run's time]) up to --max-kills times, then lets it finish.
After every kill, every file under its final name must be byte-identical to the uninterrupted run's
(the journal: complete lines identical, at most one partial last line). After the final run the
folder must equal the uninterrupted run's folder file for file (timing fields of the journal
aside), with no temporary file (".NAME.tmpXXXX") and no external-method work folder left.

    python3 scripts/kill_trials.py --bin build/turbid --trials 50 --table kill_table.md

Exit status 0 when every trial held, 1 otherwise (the table says where).
"""

import argparse
import json
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

# The experiment and dataset the trials run: built-in scenes at scale 0.1 (seconds per run).
EXPERIMENT = {
    "name": "kill_trials",
    "description": "scripts/kill_trials.py: two small built-in scenes, eight turbidity levels",
    "seed": 11,
    "scale": 0.1,
    "scenes": ["builtin:hull", "builtin:seafloor"],
    "grid": {"water.type": ["I", "IA", "IB", "II", "III", "1C", "3C", "7C"]},
    "methods": ["clahe", "dcp"],
    "metrics": ["ssim", "psnr"],
    "thumbnails": 32,
}

GENERATE = {
    "scenes": ["builtin:hull", "builtin:seafloor"],
    "scale": 0.1,
    "seed": 3,
    "grid": {"water.type": ["I", "III", "5C", "9C"]},
    "random": {"count": 3, "seed": 9, "params": {"psf.forward_scatter": {"uniform": [0.5, 0.9]}}},
}

TIMING_KEYS = {"render_ms", "time_ms", "time_batch"}
TEMPORARY = re.compile(r"^\..+\.tmp[0-9a-f]+(\.[^.]+)?$")


def strip_timing(value):
    if isinstance(value, dict):
        return {k: strip_timing(v) for k, v in value.items() if k not in TIMING_KEYS}
    if isinstance(value, list):
        return [strip_timing(v) for v in value]
    return value


def list_files(root):
    """Relative paths of every file under root (the lock file aside)."""
    out = {}
    for folder, _, files in os.walk(root):
        for name in files:
            path = os.path.join(folder, name)
            rel = os.path.relpath(path, root)
            if rel == ".turbid.lock":
                continue
            out[rel] = path
    return out


def read(path):
    with open(path, "rb") as f:
        return f.read()


def temporaries(root):
    return [rel for rel in list_files(root) if TEMPORARY.match(os.path.basename(rel))]


def work_folders(root):
    found = []
    for folder, dirs, _ in os.walk(root):
        found += [os.path.join(folder, d) for d in dirs if d.startswith("work-")]
    return found


def journal_lines(path):
    """(complete entries by parse order, number of unparseable complete lines, partial tail?)."""
    if not os.path.exists(path):
        return [], 0, False
    text = read(path).decode("utf-8", "replace")
    lines = text.split("\n")
    partial = lines[-1] != ""
    entries, corrupt = [], 0
    for line in lines[:-1]:
        if not line:
            continue
        try:
            entries.append(json.loads(line))
        except ValueError:
            corrupt += 1
    return entries, corrupt, partial


class Counts:
    def __init__(self):
        self.lost = 0
        self.duplicated = 0
        self.corrupt = 0
        self.problems = []

    def add(self, kind, what):
        setattr(self, kind, getattr(self, kind) + 1)
        if len(self.problems) < 20:
            self.problems.append(f"{kind}: {what}")


def check_journal(path, reference, counts, final):
    """Rows of a sweep journal against the reference rows (by id, timing aside)."""
    entries, corrupt, partial = journal_lines(path)
    for _ in range(corrupt):
        counts.add("corrupt", f"{path}: an unparseable complete line")
    if final and partial:
        counts.add("corrupt", f"{path}: a partial last line after the final run")
    seen = {}
    for entry in entries:
        item = entry.get("id")
        seen[item] = seen.get(item, 0) + 1
        if item not in reference:
            counts.add("corrupt", f"{path}: unknown item {item}")
        elif strip_timing(entry) != reference[item]:
            counts.add("corrupt", f"{path}: row {item} differs from the uninterrupted run")
    for item, n in seen.items():
        for _ in range(n - 1):
            counts.add("duplicated", f"{path}: row {item} appears {n} times")
    if final:
        for item in reference:
            if item not in seen:
                counts.add("lost", f"{path}: row {item} missing")


def check_folder(out, ref, counts, final, journal_reference):
    """Every file under its final name equals the reference's; after the final run, the same set."""
    got, want = list_files(out), list_files(ref)
    for rel, path in got.items():
        name = os.path.basename(rel)
        if TEMPORARY.match(name):
            if final:
                counts.add("duplicated", f"{rel}: a temporary file left after the final run")
            continue
        if rel == "journal.jsonl":
            continue
        if rel not in want:
            # Tables of a killed run are not written before every item is; an extra file is one
            # the uninterrupted run does not have.
            counts.add("duplicated", f"{rel}: not in the uninterrupted run's folder")
        elif rel.startswith("timings."):
            continue  # wall-clock times
        elif read(path) != read(want[rel]):
            counts.add("corrupt", f"{rel}: differs from the uninterrupted run")
    if journal_reference is not None:
        check_journal(os.path.join(out, "journal.jsonl"), journal_reference, counts, final)
    if final:
        for rel in want:
            if rel not in got:
                counts.add("lost", f"{rel}: missing after the final run")
        for folder in work_folders(out):
            counts.add("duplicated", f"{folder}: an external work folder left")


def run(cmd, log):
    start = time.monotonic()
    proc = subprocess.run(cmd, stdout=log, stderr=log)
    if proc.returncode != 0:
        raise SystemExit(f"kill_trials: reference run failed ({proc.returncode}): {' '.join(cmd)}")
    return time.monotonic() - start


def trial(cmd, out, ref, journal_reference, duration, rng, max_kills, log):
    """Runs cmd into out, killing it up to max_kills times; returns (kills, kills that landed
    mid-run, temporaries left by the kills, Counts)."""
    counts = Counts()
    kills = 0
    mid_run = 0
    temps_left = 0
    ref_files = len(list_files(ref))
    while True:
        proc = subprocess.Popen(cmd, stdout=log, stderr=log)
        if kills < max_kills:
            delay = rng.uniform(0.0, duration)
            try:
                proc.wait(timeout=delay)
            except subprocess.TimeoutExpired:
                proc.send_signal(signal.SIGKILL)
                proc.wait()
                kills += 1
                if os.path.isdir(out):
                    temps_left += len(temporaries(out))
                    # Mid-run: some output written, not all of it.
                    written = len(list_files(out))
                    mid_run += 0 < written < ref_files
                    check_folder(out, ref, counts, False, journal_reference)
                continue
        code = proc.wait()
        if code != 0:
            counts.add("corrupt", f"{' '.join(cmd)} exited {code} after {kills} kills")
            return kills, mid_run, temps_left, counts
        break
    check_folder(out, ref, counts, True, journal_reference)
    return kills, mid_run, temps_left, counts


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bin", required=True, help="the turbid executable")
    parser.add_argument("--trials", type=int, default=3, help="trials per command")
    parser.add_argument("--max-kills", type=int, default=3, help="kills per trial at most")
    parser.add_argument("--seed", type=int, default=1, help="seeds the kill moments")
    parser.add_argument("--commands", default="sweep,generate,merge")
    parser.add_argument("--threads", default="2")
    parser.add_argument("--scale", type=float, default=0.3,
                        help="built-in scene scale (run time: about a second at 0.3)")
    parser.add_argument("--work", help="work folder (default: a temporary one, removed)")
    parser.add_argument("--table", help="also write the result table (Markdown) here")
    args = parser.parse_args()
    rng = random.Random(args.seed)
    commands = args.commands.split(",")
    work = args.work or tempfile.mkdtemp(prefix="turbid_kill_")
    os.makedirs(work, exist_ok=True)
    log = open(os.path.join(work, "runs.log"), "ab")
    t = args.threads
    try:
        exp = os.path.join(work, "experiment.json")
        with open(exp, "w") as f:
            json.dump(dict(EXPERIMENT, scale=args.scale), f)
        ref = lambda name: os.path.join(work, "ref_" + name)
        for name in ("sweep", "s0", "s1", "merged", "gen_png", "gen_exr"):
            shutil.rmtree(ref(name), ignore_errors=True)
        bin_ = os.path.abspath(args.bin)
        sweep_cmd = lambda out: [bin_, "sweep", exp, "--out", out, "--threads", t, "--quiet"]
        gen_cmd = {}
        for fmt in ("png", "exr"):
            path = os.path.join(work, f"generate_{fmt}.json")
            with open(path, "w") as f:
                json.dump(dict(GENERATE, format=fmt, scale=args.scale), f)
            gen_cmd[fmt] = lambda out, path=path: [bin_, "generate", path, "--out", out,
                                                   "--threads", t]
        merge_cmd = lambda out: [bin_, "merge", ref("s1"), ref("s0"), "--out", out]

        # The uninterrupted runs, timed (the kill moments are drawn within these times).
        duration = {"sweep": run(sweep_cmd(ref("sweep")), log)}
        run(sweep_cmd(ref("s0")) + ["--shard", "0/2"], log)
        run(sweep_cmd(ref("s1")) + ["--shard", "1/2"], log)
        duration["merge"] = run(merge_cmd(ref("merged")), log)
        duration["generate"] = max(run(gen_cmd["png"](ref("gen_png")), log),
                                   run(gen_cmd["exr"](ref("gen_exr")), log))
        # The shortest of three uninterrupted runs (a busy machine inflates single timings, and
        # kill moments beyond the real run time only let the run finish).
        scratch = os.path.join(work, "timing")
        for _ in range(2):
            for command, cmd in (("sweep", sweep_cmd(scratch)), ("merge", merge_cmd(scratch)),
                                 ("generate", gen_cmd["exr"](scratch))):
                shutil.rmtree(scratch, ignore_errors=True)
                duration[command] = min(duration[command], run(cmd, log))
        shutil.rmtree(scratch, ignore_errors=True)
        journal_reference = {}
        for entry in journal_lines(os.path.join(ref("sweep"), "journal.jsonl"))[0]:
            journal_reference[entry["id"]] = strip_timing(entry)
        # The merged shards equal the unsharded sweep (the harness's own promise).
        for name in ("experiment.json", "items.csv", "items.jsonl", "summary.md", "summary.csv"):
            if read(os.path.join(ref("merged"), name)) != read(os.path.join(ref("sweep"), name)):
                raise SystemExit(f"kill_trials: merged {name} differs from the unsharded sweep")

        rows = []
        failed = False
        for command in commands:
            total = {"trials": 0, "kills": 0, "mid": 0, "temps": 0, "lost": 0, "duplicated": 0,
                     "corrupt": 0}
            for k in range(args.trials):
                out = os.path.join(work, f"trial_{command}_{k:03d}")
                shutil.rmtree(out, ignore_errors=True)
                if command == "sweep":
                    cmd, reference, journal = sweep_cmd(out), ref("sweep"), journal_reference
                elif command == "merge":
                    cmd, reference, journal = merge_cmd(out), ref("merged"), journal_reference
                else:
                    fmt = "png" if k % 2 == 0 else "exr"
                    cmd, reference, journal = gen_cmd[fmt](out), ref("gen_" + fmt), None
                kills, mid, temps, counts = trial(cmd, out, reference, journal, duration[command], rng,
                                             args.max_kills, log)
                total["trials"] += 1
                total["kills"] += kills
                total["mid"] += mid
                total["temps"] += temps
                for kind in ("lost", "duplicated", "corrupt"):
                    total[kind] += getattr(counts, kind)
                if counts.problems:
                    failed = True
                    print(f"{command} trial {k}: " + "; ".join(counts.problems), file=sys.stderr)
                else:
                    shutil.rmtree(out, ignore_errors=True)
            total["seconds"] = duration[command]
            rows.append((command, total))
        table = ["| command | trials | kills | kills mid-run | temporaries left by kills "
                 "(removed by the rerun) | rows/files lost | duplicated | corrupt "
                 "| uninterrupted run |",
                 "|---|---|---|---|---|---|---|---|---|"]
        for command, r in rows:
            table.append(f"| {command} | {r['trials']} | {r['kills']} | {r['mid']} | {r['temps']} | "
                         f"{r['lost']} | {r['duplicated']} | {r['corrupt']} | "
                         f"{r['seconds']:.2f} s |")
        text = "\n".join(table) + "\n"
        print(text, end="")
        if args.table:
            with open(args.table, "w") as f:
                f.write(text)
        return 1 if failed else 0
    finally:
        log.close()
        if not args.work:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
