#!/usr/bin/env python3
"""The "never collapses" check of docs/methods.md on the sweeps' own scenes and levels.

For demo.json and table1.json, every scene at every turbidity level is rendered (the experiment's
render options, seed 1) and enhanced by blind `full`; a tile of an 8x8 grid that is textured in the
degraded input (standard deviation >= 0.02) collapses when the output's standard deviation there is
below half the input's, or half its values are within 1/255 of 0 or 1 (as CollapsedTileShare in
tests/enhancer/full_blind_test.cc). Prints one line per image; exits 1 when any tile collapsed.

With --real, the real underwater frames of $TURBID_DATA instead (the evaluation split's frames
without a clean image: seathru_d1_d3, flsea, euvp_funiegan A and uieb_waternet; images only, so
`full` runs without a scene or sidecar: frontal plane, no LED, sRGB assumed for its CLAHE), each
read as sRGB and checked against itself as the degraded input.

Usage: PYTHONPATH=build/python TURBID_DATA=../shared/data python3 scripts/full_collapse_check.py
       [--method full] [--real] [EXPERIMENT.json ...]
"""
import argparse
import json
import os
import sys

import numpy as np
import turbid


def collapsed_tiles(output, degraded):
    height, width = degraded.shape[:2]
    textured = collapsed = 0
    for ty in range(8):
        for tx in range(8):
            tile = (slice(ty * height // 8, ty * height // 8 + height // 8),
                    slice(tx * width // 8, tx * width // 8 + width // 8))
            before, after = degraded[tile], output[tile]
            if before.std() < 0.02:
                continue
            textured += 1
            extreme = ((after <= 1 / 255) | (after >= 254 / 255)).mean()
            if after.std() < 0.5 * before.std() or extreme >= 0.5:
                collapsed += 1
    return collapsed, textured


def check(path, method):
    experiment = json.load(open(path))
    failures = 0
    for spec in experiment["scenes"]:
        if spec.startswith("builtin:"):
            scene = turbid.Scene.builtin(spec, scale=experiment.get("scale", 1.0))
        else:
            scene = turbid.Scene.load(os.path.join(os.path.dirname(path), spec))
        for level in experiment["grid"]["@turbidity"]:
            params = json.loads(json.dumps(experiment.get("render", {})))
            params.setdefault("water", {})
            for key, value in level.items():
                if key.startswith("water."):
                    params["water"][key[len("water."):]] = value
            render = turbid.render(scene, params, seed=1)
            degraded = np.asarray(render.image, dtype=np.float64)
            output = np.asarray(turbid.enhance(render.image, method, sidecar=render.sidecar,
                                               scene=scene), dtype=np.float64)
            bad, textured = collapsed_tiles(output, degraded)
            failures += bad
            print(f"{experiment['name']:8s} {scene.name:10s} level {level['label']:4s} "
                  f"{method}: {bad} of {textured} textured tiles collapsed")
    return failures


REAL_FRAMES = ("seathru_d1_d3/*_image.png", "flsea/*[0-9].tiff", "euvp_funiegan/A/*.jpg",
               "uieb_waternet/*.png")


def check_real(method):
    import glob
    data = os.environ.get("TURBID_DATA")
    if not data:
        sys.exit("TURBID_DATA is not set: the real frames are read from it")
    failures = 0
    for pattern in REAL_FRAMES:
        for path in sorted(glob.glob(os.path.join(data, pattern))):
            image = turbid.read_image(path)
            degraded = np.asarray(image, dtype=np.float64)
            output = np.asarray(turbid.enhance(image, method), dtype=np.float64)
            bad, textured = collapsed_tiles(output, degraded)
            failures += bad
            print(f"real     {os.path.relpath(path, data):50s} {method}: {bad} of {textured} "
                  f"textured tiles collapsed")
    return failures


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("experiments", nargs="*", default=["scenes/experiments/demo.json",
                                                             "scenes/experiments/table1.json"])
    parser.add_argument("--method", default="full")
    parser.add_argument("--real", action="store_true",
                        help="the real underwater frames of $TURBID_DATA instead of experiments")
    args = parser.parse_args()
    if args.real:
        failures = check_real(args.method)
    else:
        failures = sum(check(path, args.method) for path in args.experiments)
    print(f"{failures} collapsed tile(s)")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
