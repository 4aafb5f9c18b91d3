#!/usr/bin/env python3
# Usage: python3 scripts/trust_link_trials.py build/turbid  (docs/reliability.md figures, issue 28 item 4)
# Symlinks planted in a sweep / generate / merge folder, pointing at a "victim" folder holding what
# turbid's clean-up removes in its own folders (work-* folders, .NAME.tmpHEX files, journal).
# Each run: refused with one line, or runs; the victim must be intact either way.
import os, shutil, subprocess, sys, tempfile
B = sys.argv[1]
exp = """{"name": "l", "seed": 1, "scale": 0.1, "scenes": ["builtin:hull"], "grid": {"water.beta_gray_per_m": [0.4]},
 "methods": ["clahe"], "metrics": ["psnr"], "thumbnails": 32}"""
trials = refused = refused_other = ran = damaged = unclear = 0
def victim_setup(v):
    shutil.rmtree(v, ignore_errors=True)
    os.makedirs(os.path.join(v, "work-keep")); open(os.path.join(v, "work-keep", "f"), "w").write("k")
    open(os.path.join(v, ".a.png.tmp12ab.png"), "w").write("k")
    open(os.path.join(v, "journal.jsonl"), "w").write("k\n")
    os.makedirs(os.path.join(v, "sub", "work-deep")); open(os.path.join(v, "sub", "work-deep", "f"), "w").write("k")
def intact(v):
    return all(os.path.exists(os.path.join(v, p)) for p in ["work-keep/f", ".a.png.tmp12ab.png", "journal.jsonl", "sub/work-deep/f"]) and open(os.path.join(v, "journal.jsonl")).read() == "k\n"
with tempfile.TemporaryDirectory() as root:
    e = os.path.join(root, "e.json"); open(e, "w").write(exp)
    v = os.path.join(root, "victim")
    base = os.path.join(root, "base")
    assert subprocess.run([B, "sweep", e, "--out", base], capture_output=True).returncode == 0
    places = ["thumbs", "thumbs/hull-c0000", "thumbs/hull", "thumbs/new", "thumbs/hull-c0000/x", "external",
              "external/lbl", "external/lbl/work-hull-c0000", "journal.jsonl", "report", "thumbs/hull-c0000/clahe.png"]
    for place in places:
        for cmd in ("sweep", "sweep-force", "merge"):
            victim_setup(v)
            out = os.path.join(root, "o"); shutil.rmtree(out, ignore_errors=True); shutil.copytree(base, out, symlinks=True)
            p = os.path.join(out, place)
            os.makedirs(os.path.dirname(p), exist_ok=True)
            if os.path.isdir(p) and not os.path.islink(p): shutil.rmtree(p)
            elif os.path.lexists(p): os.remove(p)
            target = os.path.join(v, "journal.jsonl") if place.endswith((".jsonl", ".png")) else v
            os.symlink(target, p)
            if cmd == "sweep": args = ["sweep", e, "--out", out]
            elif cmd == "sweep-force": args = ["sweep", e, "--out", out, "--force"]
            else: args = ["merge", out, "--out", os.path.join(root, "m")]; shutil.rmtree(os.path.join(root, "m"), ignore_errors=True)
            trials += 1
            r = subprocess.run([B] + args, capture_output=True, text=True, timeout=120)
            if r.returncode == 0: ran += 1
            elif r.returncode == 1 and r.stderr.count("\n") == 1 and "symbolic link" in r.stderr: refused += 1
            elif r.returncode == 1 and r.stderr.count("\n") == 1: refused_other += 1; print("REFUSED", place, cmd, r.stderr.strip())
            else: unclear += 1; print("UNCLEAR", place, cmd, r.returncode, r.stderr[:200])
            if not intact(v): damaged += 1; print("DAMAGED", place, cmd)
    for place in ["images", "ground_truth", "lit", "sidecars"]:
        victim_setup(v)
        g = os.path.join(root, "g"); shutil.rmtree(g, ignore_errors=True); os.makedirs(g)
        os.symlink(v, os.path.join(g, place))
        gj = os.path.join(root, "g.json"); open(gj, "w").write('{"scenes": ["builtin:seafloor"], "scale": 0.1, "grid": {"water.beta_gray_per_m": [0.5]}}')
        trials += 1
        r = subprocess.run([B, "generate", gj, "--out", g], capture_output=True, text=True, timeout=120)
        if r.returncode == 0: ran += 1
        elif r.returncode == 1 and "symbolic link" in r.stderr: refused += 1
        else: unclear += 1; print("UNCLEAR", place, r.stderr[:200])
        if not intact(v): damaged += 1; print("DAMAGED generate", place)
print(f"link trials {trials}: refused with one line naming the link {refused}, other one-line refusals {refused_other}, ran (link never followed) {ran}, unclear {unclear}, victim damaged {damaged}")
