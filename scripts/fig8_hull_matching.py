#!/usr/bin/env python3
"""The paper's Fig. 8 feature-matching table, from the harness experiment scenes/experiments/fig8.json.

The views, the degradation, the methods and the per-pair figures are the experiment's (issue 34
item 4): a straight pass along the built-in hull plate (10 frames, 3 cm apart, 1.06 m from the
plate), ray-cast per pose, degraded with table1's settings at beta 0.4 / 0.7 / 1.0, enhanced, and
matched by the sweep's front-end metrics (ORB and SIFT, 1000 keypoints, ratio 0.8, RANSAC
homography 3 px) as the camera writes the frames (sRGB 8-bit). This script runs the sweep (or
reads one already run, --sweep DIR) and adds what the harness tables do not: the paper's pooled
figures over the pairs (i, i+1) and (i, i+2) together -- active sets (pairs with more than 10
correspondences) as a count, mean correspondences and mean homography inliers over the active
sets -- and the inliers against CLAHE's at the same level (the paper's claim: more than twice).

Until 2026-11-30 this script made its own views (homographies of the reference image with yaw,
pitch and heave drift) and matched them with turbid.match_features; the experiment replaces that
(docs/experiments.md, Fig. 8, has both sets of figures).

Usage: python3 scripts/fig8_hull_matching.py [--turbid build/turbid] [--out out/fig8]
       [--sweep DIR] [--threads 2] [--detector orb|sift|both] [--csv FILE]
Deterministic: the sweep's tables are the same bytes for any thread count.
"""
import argparse
import csv
import json
import math
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
EXPERIMENT = os.path.join(HERE, "..", "scenes", "experiments", "fig8.json")


def load_items(sweep_dir):
    path = os.path.join(sweep_dir, "items.jsonl")
    if not os.path.exists(path):
        sys.exit(f"{path}: no such file (run the sweep first, or drop --sweep)")
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def number(value):
    return float(value) if value not in (None, "nan") else math.nan


def pooled_rows(items, detector):
    """One row per (level, method): the pairs k = 1 and k = 2 pooled, as the paper counts them."""
    prefix = "" if detector == "orb" else "sift_"
    sums = {}  # (level, method) -> [pairs, active, correspondences, inliers]
    order = []
    for item in items:
        rows = [("clean", item["reference_metrics"])]
        rows += [(m["method"], m["metrics"]) for m in item["methods"] if "error" not in m]
        for method, metrics in rows:
            key = (item["level"], method)
            if key not in sums:
                sums[key] = [0, 0, 0.0, 0.0]
                order.append(key)
            for suffix in ("", "_k2"):
                active = number(metrics.get(f"{prefix}active{suffix}"))
                if math.isnan(active):
                    continue  # the first frame(s): no pair
                s = sums[key]
                s[0] += 1
                if active > 0:
                    s[1] += 1
                    s[2] += number(metrics[f"{prefix}correspondences{suffix}"])
                    s[3] += number(metrics[f"{prefix}homography_inliers{suffix}"])
    out = []
    for level, method in order:
        pairs, active, corr, inl = sums[(level, method)]
        out.append({"detector": detector, "beta": level, "method": method, "pairs": pairs,
                    "active": active,
                    "correspondences": round(corr / active, 1) if active else 0.0,
                    "inliers": round(inl / active, 1) if active else 0.0})
    by_clahe = {r["beta"]: r["inliers"] for r in out if r["method"] == "clahe"}
    for r in out:
        base = by_clahe.get(r["beta"], 0.0)
        r["inliers_vs_clahe"] = round(r["inliers"] / base, 2) if base > 0 else float("nan")
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--turbid", default=os.path.join(HERE, "..", "build", "turbid"))
    ap.add_argument("--out", default="out/fig8", help="sweep output folder (resumed if present)")
    ap.add_argument("--sweep", default="", help="read this finished sweep instead of running one")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--detector", choices=["orb", "sift", "both"], default="both")
    ap.add_argument("--csv", default="")
    args = ap.parse_args()

    sweep_dir = args.sweep
    if not sweep_dir:
        sweep_dir = args.out
        cmd = [args.turbid, "sweep", EXPERIMENT, "--out", sweep_dir, "--threads", str(args.threads)]
        print("running:", " ".join(cmd), file=sys.stderr)
        if subprocess.call(cmd) != 0:
            sys.exit("fig8: the sweep failed")
    items = load_items(sweep_dir)
    detectors = ["orb", "sift"] if args.detector == "both" else [args.detector]
    rows = []
    for detector in detectors:
        table = pooled_rows(items, detector)
        rows += table
        print(f"\n{detector}, pairs (i, i+1) and (i, i+2) pooled, from {sweep_dir}")
        print("| beta | method | active sets | mean correspondences | mean inliers | inliers / CLAHE |")
        print("|---|---|---|---|---|---|")
        for r in table:
            print(f"| {r['beta']} | {r['method']} | {r['active']}/{r['pairs']} "
                  f"| {r['correspondences']} | {r['inliers']} | {r['inliers_vs_clahe']} |")
    if args.csv and rows:
        with open(args.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
            w.writeheader()
            w.writerows(rows)


if __name__ == "__main__":
    main()
