#!/usr/bin/env python3
# Usage: python3 scripts/trust_name_trials.py build/turbid  (docs/reliability.md figures, issue 28 item 3)
# Bad scene names through `turbid scene` and `turbid generate`: every one refused with one line,
# nothing written outside --out (the sandbox is listed before and after).
import json, os, random, subprocess, sys, tempfile
B = sys.argv[1]
random.seed(28)
base = ["../X", "../../X", "a/../../X", "/tmp/h28t-abs-X", "..", ".", "", ".hidden", "a/b", "a\\b",
        "x\ny", "x\x00y", "x\ty", "\x7f", "x" * 201, "./X", "X/", "/", "//", "a/./b"]
seps = ["/", "\\", "\n", "\r", "\x00", "\x01", "\x1b", ".."]
names = list(base)
while len(names) < 120:
    n = "".join(random.choice(["a", "Z", "_", "-", ".", random.choice(seps)]) for _ in range(random.randint(1, 12)))
    ok = n and "/" not in n and "\\" not in n and not n.startswith(".") and all(ord(c) >= 32 and ord(c) != 127 for c in n)
    if not ok: names.append(n)
tried = clear = crashes = hangs = escaped = 0
with tempfile.TemporaryDirectory() as root:
    sand = os.path.join(root, "s"); os.makedirs(os.path.join(sand, "a", "b"))
    def snapshot():
        return sorted(os.path.relpath(os.path.join(d, f), root) for d, _, fs in os.walk(root) for f in fs + _)
    for name in names:
        scene = os.path.join(sand, "a", "b", "scene.json")
        with open(scene, "w") as f:
            json.dump({"type": "builtin", "builtin": "room", "scale": 0.1, "name": name}, f)
        gen = os.path.join(sand, "a", "b", "gen.json")
        with open(gen, "w") as f:
            json.dump({"scenes": [scene], "scale": 0.1, "grid": {"water.beta_gray_per_m": [0.5]}}, f)
        for args in (["scene", scene, "--out", os.path.join(sand, "a", "b", "out")],
                     ["generate", gen, "--out", os.path.join(sand, "a", "b", "gen")]):
            before = snapshot()
            tried += 1
            try:
                r = subprocess.run([B] + args, capture_output=True, text=True, timeout=60, errors="replace")
            except subprocess.TimeoutExpired:
                hangs += 1; continue
            if r.returncode < 0 or r.returncode > 1: crashes += 1
            lines = r.stderr.strip("\n").split("\n")
            if r.returncode == 1 and len(lines) == 1 and "scene name" in lines[0]: clear += 1
            else: print("UNCLEAR", repr(name), args[0], r.returncode, r.stderr[:200])
            if snapshot() != before: escaped += 1; print("WROTE", repr(name), set(snapshot()) ^ set(before))
print(f"names {len(names)}, runs {tried}, clear one-line errors {clear}, crashes {crashes}, hangs {hangs}, runs that wrote anything {escaped}")
