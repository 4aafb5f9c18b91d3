#!/usr/bin/env python3
"""The paper's Fig. 8 feature-matching comparison, on a built-in hull image sequence.

The built-in hull is one plane, so every other view of it is an exact homography of the clean
reference image. This script flies a camera along the plate (known poses R, t), makes each view's
clean image by sampling the reference through the plane-induced homography
H = K (R - t n^T / d) K^-1 and its depth from the plane equation, degrades every view with turbid's
renderer (table1's settings: PSF T = 4, q = 0.9, one LED of power 2; beta from the command line),
enhances it with each method and counts, over the image pairs (i, i + 1) and (i, i + 2),
the paper's three figures: active sets (pairs with more than 10 correspondences), the mean number
of correspondences and the mean number of RANSAC homography inliers in the active sets. A fourth
column, the inlier ratio against CLAHE, is the paper's claim (>= 2x for the proposed method).

Domain (issue 32): by default every image is matched as the camera writes it, sRGB 8-bit codes
(``--domain coded``: turbid.srgb_encode(..., dtype=uint8) / 255, the way the field's matchers see
frames); ``--domain linear`` matches the linear float images as before (the matcher scales [0, 1]
to 8 bits linearly).

Usage: PYTHONPATH=build/python python3 scripts/fig8_hull_matching.py [--betas 0.4,0.7,1.0]
       [--frames 10] [--detector orb] [--methods none,clahe,tarel,simplified,full] [--csv FILE]
       [--domain coded|linear]
Deterministic: the same arguments print the same table.
"""
import argparse
import csv
import sys

import numpy as np

import turbid


def plane_of(scene):
    """Unit normal n and distance d > 0 of the scene's plane (n . X = d, camera frame, metres),
    fitted to the ray-cast depth (exact for the hull: residual ~1e-7 m)."""
    c = scene.camera
    z = scene.depth.astype(np.float64)
    v, u = np.mgrid[0:z.shape[0], 0:z.shape[1]]
    pts = np.stack([(u - c["cx"]) / c["fx"] * z, (v - c["cy"]) / c["fy"] * z, z], -1).reshape(-1, 3)
    pts = pts[np.isfinite(pts).all(1)][::7]
    a = np.c_[pts, np.ones(len(pts))]
    p = np.linalg.svd(a, full_matrices=False)[2][-1]
    n, d = p[:3], -p[3]
    scale = np.linalg.norm(n)
    n, d = n / scale, d / scale
    if d < 0:
        n, d = -n, -d
    residual = np.abs(pts @ n - d).max()
    if residual > 1e-4:
        sys.exit(f"fig8: the scene is not a plane (residual {residual:.2e} m)")
    return n, d


def rot(yaw_rad, pitch_rad):
    cy, sy, cp, sp = np.cos(yaw_rad), np.sin(yaw_rad), np.cos(pitch_rad), np.sin(pitch_rad)
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rx = np.array([[1, 0, 0], [0, cp, -sp], [0, sp, cp]])
    return ry @ rx


def bilinear(img, x, y):
    h, w = img.shape
    x0 = np.clip(np.floor(x).astype(np.int64), 0, w - 2)
    y0 = np.clip(np.floor(y).astype(np.int64), 0, h - 2)
    fx, fy = x - x0, y - y0
    a = img[y0, x0] * (1 - fx) + img[y0, x0 + 1] * fx
    b = img[y0 + 1, x0] * (1 - fx) + img[y0 + 1, x0 + 1] * fx
    return (a * (1 - fy) + b * fy).astype(np.float32)


def make_view(ref, n, d, r, t):
    """Clean image and z-depth of the plane seen from the camera X_new = R X_ref + t."""
    c = ref.camera
    k = np.array([[c["fx"], 0, c["cx"]], [0, c["fy"], c["cy"]], [0, 0, 1.0]])
    h, w = ref.height, ref.width
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    rays = np.stack([(u - c["cx"]) / c["fx"], (v - c["cy"]) / c["fy"], np.ones_like(u)], -1)
    # Plane in the new frame: n' = R n, d' = d + n'.t; the ray's point lambda * ray meets it at
    # lambda = d' / (n' . ray) (rays have z = 1, so lambda is the z-depth).
    n_new = r @ n
    d_new = d + n_new @ t
    depth = d_new / (rays @ n_new)
    x_new = rays * depth[..., None]
    x_ref = (x_new - t) @ r  # R^T (X - t), row vectors
    p = x_ref @ k.T
    xs, ys = p[..., 0] / p[..., 2], p[..., 1] / p[..., 2]
    inside = (xs >= 0) & (xs <= w - 1) & (ys >= 0) & (ys <= h - 1)
    if not inside.all():
        sys.exit(f"fig8: a view leaves the reference image ({(~inside).mean():.1%} outside)")
    image = bilinear(ref.image, xs, ys)
    return turbid.Scene.from_arrays(image, depth.astype(np.float32), c["fx"], c["fy"], c["cx"],
                                    c["cy"], name="hull_view")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--betas", default="0.4,0.7,1.0")
    ap.add_argument("--frames", type=int, default=10)
    ap.add_argument("--detector", default="orb")
    ap.add_argument("--methods", default="none,clahe,tarel,simplified,full,full_literal")
    ap.add_argument("--csv", default="")
    ap.add_argument("--domain", choices=["coded", "linear"], default="coded")
    args = ap.parse_args()

    def as_matched(image):
        if args.domain == "linear":
            return image
        return turbid.srgb_encode(image, dtype="uint8").astype(np.float32) / 255.0

    ref = turbid.Scene.builtin("hull")
    n, d = plane_of(ref)
    # A lawn-mower leg along the plate: 40% closer than the reference along its optical axis (so
    # every view lies inside it), sliding 3 cm per frame across the plate with a little yaw, pitch
    # and heave drift.
    centre = np.array([0.0, 0.0, d / n[2]])  # where the reference's optical axis meets the plate
    axis_u = np.cross(n, [0.0, 1.0, 0.0])
    axis_u /= np.linalg.norm(axis_u)
    views = []
    for i in range(args.frames):
        s = (i - (args.frames - 1) / 2) / max(args.frames - 1, 1)
        r = rot(0.02 * s, 0.015 * np.sin(3.0 * s))
        t = -0.4 * centre + axis_u * (0.03 * (i - (args.frames - 1) / 2))
        t = t + np.array([0.0, 0.02 * np.cos(2.0 * s), 0.0])
        views.append(make_view(ref, n, d, r, t))
    pairs = [(i, i + 1) for i in range(args.frames - 1)] + [(i, i + 2) for i in range(args.frames - 2)]
    methods = [m for m in args.methods.split(",") if m]
    rows = []
    for beta in [float(b) for b in args.betas.split(",")]:
        params = {"water": {"beta_gray_per_m": beta, "beta_rgb_per_m": [beta] * 3},
                  "psf": {"optical_thickness": 4.0, "forward_scatter": 0.9},
                  "light": {"lights": [{"power": 2.0}]}}
        degraded = [turbid.render(v, params, seed=100 + i).image for i, v in enumerate(views)]
        for method in ["clean"] + methods:
            if method == "clean":
                images = [v.image for v in views]
            elif method == "none":
                images = degraded
            else:
                images = [turbid.enhance(img, method) for img in degraded]
            images = [as_matched(img) for img in images]
            res = [turbid.match_features(images[a], images[b], args.detector) for a, b in pairs]
            active = [x for x in res if x["active"]]
            corr = float(np.mean([x["correspondences"] for x in active])) if active else 0.0
            inl = float(np.mean([x["inliers"] for x in active])) if active else 0.0
            rows.append({"beta": beta, "method": method, "pairs": len(pairs), "active": len(active),
                         "correspondences": round(corr, 1), "inliers": round(inl, 1)})
    by_clahe = {r["beta"]: r["inliers"] for r in rows if r["method"] == "clahe"}
    for r in rows:
        base = by_clahe.get(r["beta"], 0.0)
        r["inliers_vs_clahe"] = round(r["inliers"] / base, 2) if base > 0 else float("nan")
    print(f"detector {args.detector}, {args.frames} frames, {len(pairs)} pairs per level, "
          f"matched {args.domain}")
    print("| beta | method | active sets | mean correspondences | mean inliers | inliers / CLAHE |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['beta']} | {r['method']} | {r['active']}/{r['pairs']} | {r['correspondences']} "
              f"| {r['inliers']} | {r['inliers_vs_clahe']} |")
    if args.csv:
        with open(args.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
            w.writeheader()
            w.writerows(rows)


if __name__ == "__main__":
    main()
