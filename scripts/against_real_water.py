#!/usr/bin/env python3
"""How well do turbid's image-formation models explain real underwater RGB-D? (issue 31 item 6)

Fits the `paper` model (one beta per channel for the direct signal and the backscatter) and the
`revised` model (Sea-thru's fit: B_inf, beta^B, J', beta' and a range-dependent beta^D(r);
`turbid water fit`) to the real frames of $TURBID_DATA (seathru_d1_d3, flsea; their SOURCE.md
gives the grids, encodings and intrinsics used below) and reports per frame and model:

* the backscatter residual over the range bins: both models' backscatter fitted by least squares
  to the medians of the dark pixels in `turbid water fit`'s range bins (paper: B_inf (1 - e^{-beta
  r}), 2 parameters; revised: + J' e^{-beta' r}, 4), then the RMS over the bins of (median - model)
  per channel, as a fraction of the channel's mean dark level;
* the range-dependence of the restored colour: the restored image's median per channel in 8
  equal-count range bins; the standard deviation over the bins of ln(median), averaged over the
  channels (0 = the same colour at every range), and the same for the unrestored image;
* the restored images side by side (input | paper | revised), written to OUT (not to the
  repository: the frames' licences do not allow redistributing them or derivatives).

Writes OUT/table.md (the table of docs/model.md, "Against real water"), OUT/against_real_water.png
(the figure; docs/images/against_real_water.png is a copy) and OUT/restored_<frame>.png.

Run: PYTHONPATH=build/python python3 scripts/against_real_water.py --out /tmp/real_water
"""
import argparse
import json
import os
import sys

import numpy as np

import turbid

FLSEA_CANYONS = {"fx": 1175.39, "fy": 1174.28, "cx": 466.26, "cy": 271.21}
FLSEA_RED_SEA = {"fx": 1296.67, "fy": 1300.83, "cx": 501.50, "cy": 276.16}


def frames(data):
    """(name, scene-file dict) per real frame, as docs/formats.md describes them."""
    st = "%s/seathru_d1_d3/" % data
    out = [("D3", {"type": "depth", "image": st + "D3_T_S04856_image_wbNeutral.png",
                   "depth": st + "D3_T_S04856_depth.exr", "color": "linear", "camera": "unknown",
                   "depth_resize": "stretch_nearest", "depth_erode_px": 1}),
           ("D1", {"type": "depth", "image": st + "D1_T_S03047_image.png",
                   "depth": st + "D1_T_S03047_depth.exr", "color": "linear", "camera": "unknown",
                   "depth_resize": "stretch_nearest", "depth_erode_px": 1})]
    for ts in ("16233045486672034", "16233045634681115", "16233052210817852",
               "16315113063217030", "16315129396993518", "16315955823536320"):
        camera = FLSEA_CANYONS if ts.startswith("16233") else FLSEA_RED_SEA
        where = "canyons" if ts.startswith("16233") else "red_sea"
        out.append(("%s_%s" % (where, ts[-4:]),
                    {"type": "depth", "image": "%s/flsea/%s.tiff" % (data, ts),
                     "depth": "%s/flsea/%s_SeaErra_abs_depth.tif" % (data, ts), "color": "srgb",
                     "camera": camera}))
    return out


def fit_paper_backscatter(r, dark):
    """B(r) = B_inf (1 - exp(-beta r)) to the bins' dark medians (one channel): beta on a 0.005
    grid over [0, 5] 1/m, B_inf in [0, 1] by least squares for each."""
    best = (np.inf, 0.0, 0.0)
    for beta in np.arange(0.0, 5.0001, 0.005):
        g = 1.0 - np.exp(-beta * r)
        gg = float(g @ g)
        b_inf = 0.0 if gg == 0 else min(max(float(g @ dark) / gg, 0.0), 1.0)
        err = float(np.sum((b_inf * g - dark) ** 2))
        if err < best[0]:
            best = (err, b_inf, beta)
    return best[1], best[2]


def fit_revised_backscatter(r, dark):
    """Sea-thru's B(r) = B_inf (1 - e^{-beta^B r}) + J' e^{-beta' r} to the same bin medians (one
    channel): (beta^B, beta') on a 0.05 grid over [0, 5]^2, (B_inf, J') >= 0 by least squares
    (the unconstrained solution, else the better single-term fit). Returns the curve at r."""
    best = (np.inf, None)
    betas = np.arange(0.0, 5.0001, 0.05)
    for bb in betas:
        g1 = 1.0 - np.exp(-bb * r)
        for bp in betas:
            g2 = np.exp(-bp * r)
            a = np.stack([g1, g2], axis=1)
            coef, *_ = np.linalg.lstsq(a, dark, rcond=None)
            if coef.min() < 0:
                cands = []
                for g in (g1, g2):
                    gg = float(g @ g)
                    k = 0.0 if gg == 0 else max(float(g @ dark) / gg, 0.0)
                    cands.append(k * g)
                curve = min(cands, key=lambda c: float(np.sum((c - dark) ** 2)))
            else:
                curve = a @ coef
            err = float(np.sum((curve - dark) ** 2))
            if err < best[0]:
                best = (err, curve)
    return best[1]


def restore_paper(image, rng, b_inf, beta):
    """J = (I - B_inf (1 - e^{-beta r})) e^{beta r}, grey world per channel (mean 0.5)."""
    valid = np.isfinite(rng) & (rng > 0)
    r = np.where(valid, rng, 0.0)[..., None]
    j = np.maximum(image - b_inf * (1.0 - np.exp(-beta * r)), 0.0) * np.exp(beta * r)
    for c in range(3):
        m = float(j[..., c][valid].mean())
        if m > 0:
            j[..., c] *= 0.5 / m
    j[~valid] = image[~valid]
    return np.clip(j, 0.0, 1.0).astype(np.float32)


def colour_by_range(image, rng, bins=8):
    """Bin centres and ln(median) per channel in `bins` equal-count range bins."""
    valid = np.isfinite(rng) & (rng > 0)
    r = rng[valid]
    pix = image[valid]
    edges = np.quantile(r, np.linspace(0, 1, bins + 1))
    centres, logs = [], []
    for i in range(bins):
        sel = (r >= edges[i]) & (r <= edges[i + 1])
        med = np.median(pix[sel], axis=0)
        centres.append(float(np.median(r[sel])))
        logs.append(np.log(np.maximum(med, 1e-4)))
    return np.array(centres), np.array(logs)


def spread(logs):
    return float(np.mean(np.std(logs, axis=0)))


def analyse(name, spec, out):
    path = os.path.join(out, "scenes", name + ".json")
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        json.dump(spec, f)
    scene = turbid.Scene.load(path)
    image, rng = scene.image, scene.range
    fit = turbid.water.fit(image, rng)  # the range as it is (docs/cli/water.md)
    bins = fit.diagnostics["backscatter"]["bins"]
    r = np.array([b["range_m"] for b in bins])
    dark = np.array([b["dark_median_rgb"] for b in bins])
    paper = [fit_paper_backscatter(r, dark[:, c]) for c in range(3)]
    paper_curve = np.stack([p[0] * (1 - np.exp(-p[1] * r)) for p in paper], axis=1)
    # Both models fitted to the same bin medians (the revised one has two more parameters).
    revised_curve = np.stack([fit_revised_backscatter(r, dark[:, c]) for c in range(3)], axis=1)
    # The paper's curve is the revised one with J' = 0 (on a finer beta grid): keep the better.
    for c in range(3):
        if np.sum((paper_curve[:, c] - dark[:, c]) ** 2) < np.sum(
                (revised_curve[:, c] - dark[:, c]) ** 2):
            revised_curve[:, c] = paper_curve[:, c]
    level = np.maximum(dark.mean(axis=0), 1e-6)
    res_paper = np.sqrt(np.mean((paper_curve - dark) ** 2, axis=0)) / level
    res_revised = np.sqrt(np.mean((revised_curve - dark) ** 2, axis=0)) / level
    restored_revised = turbid.enhance(image, "seathru", scene=scene)
    restored_paper = restore_paper(image, rng, np.array([p[0] for p in paper]),
                                   np.array([p[1] for p in paper]))
    centres, logs_in = colour_by_range(image, rng)
    _, logs_paper = colour_by_range(restored_paper, rng)
    _, logs_revised = colour_by_range(restored_revised, rng)
    side = np.concatenate([image, restored_paper, restored_revised], axis=1)
    turbid.write_image(os.path.join(out, "restored_%s.png" % name), side, overwrite=True)
    d = fit.diagnostics
    return {
        "name": name, "range": d["range_m"], "r": r, "dark": dark, "paper_curve": paper_curve,
        "revised_curve": revised_curve, "centres": centres, "logs": (logs_in, logs_paper,
                                                                     logs_revised),
        "res_paper": res_paper, "res_revised": res_revised,
        "spread": (spread(logs_in), spread(logs_paper), spread(logs_revised)),
        "paper_beta": [p[1] for p in paper], "paper_b_inf": [p[0] for p in paper],
        "b_inf": d["backscatter"]["b_inf_rgb"], "beta_b": d["backscatter"]["beta_b_rgb_per_m"],
    }


def table(rows):
    lines = ["| frame | range (m) | backscatter residual R, G, B: paper | revised | "
             "colour spread over range: input | paper | revised | paper β (1/m) | revised β^B "
             "(1/m) |", "|---|---|---|---|---|---|---|---|---|"]
    for x in rows:
        f3 = lambda v: ", ".join("%.2f" % a for a in v)  # noqa: E731
        lines.append("| %s | %.1f–%.1f | %s | %s | %.2f | %.2f | %.2f | %s | %s |" % (
            x["name"], x["range"][0], x["range"][1], f3(x["res_paper"]), f3(x["res_revised"]),
            x["spread"][0], x["spread"][1], x["spread"][2], f3(x["paper_beta"]), f3(x["beta_b"])))
    return "\n".join(lines) + "\n"


# ---- the figure: a plain raster (no plotting library), one row per frame -----------------------
COLOURS = np.array([[0.85, 0.1, 0.1], [0.1, 0.6, 0.1], [0.1, 0.2, 0.9]], np.float32)


def draw_line(canvas, xs, ys, colour, dash=False, dot=False):
    for i in range(len(xs) - 1):
        n = int(max(abs(xs[i + 1] - xs[i]), abs(ys[i + 1] - ys[i]))) + 1
        for t in range(n + 1):
            if dash and (t // 5) % 2:
                continue
            x = int(round(xs[i] + (xs[i + 1] - xs[i]) * t / n))
            y = int(round(ys[i] + (ys[i + 1] - ys[i]) * t / n))
            if 0 <= y < canvas.shape[0] and 0 <= x < canvas.shape[1]:
                canvas[y, x] = colour
    if dot:
        for x, y in zip(xs, ys):
            canvas[max(int(y) - 2, 0):int(y) + 3, max(int(x) - 2, 0):int(x) + 3] = colour


def panel(canvas, box, xs, series):
    """series: list of (ys per channel (n x 3), style); axes scaled to the data."""
    x0, y0, w, h = box
    canvas[y0:y0 + h, x0] = 0.3
    canvas[y0 + h - 1, x0:x0 + w] = 0.3
    lo = min(float(np.min(s)) for s, _ in series)
    hi = max(float(np.max(s)) for s, _ in series)
    if hi - lo < 1e-9:
        hi = lo + 1
    xmin, xmax = float(np.min(xs)), float(np.max(xs))
    px = x0 + 4 + (np.asarray(xs) - xmin) / max(xmax - xmin, 1e-9) * (w - 8)
    for ys, style in series:
        for c in range(3):
            py = y0 + h - 4 - (ys[:, c] - lo) / (hi - lo) * (h - 8)
            colour = COLOURS[c] * (0.5 if style == "thin" else 1.0) + (0.5 if style == "thin"
                                                                      else 0.0)
            draw_line(canvas, px, py, colour, dash=style == "dash", dot=style == "dot")


def figure(rows, path):
    h, w = 150, 330
    canvas = np.ones((len(rows) * (h + 10) + 10, 2 * w + 30, 3), np.float32)
    for i, x in enumerate(rows):
        y0 = 10 + i * (h + 10)
        panel(canvas, (10, y0, w, h), x["r"], [(x["dark"], "dot"), (x["paper_curve"], "dash"),
                                                (x["revised_curve"], "solid")])
        logs = [lg - lg.mean(axis=0) for lg in x["logs"]]
        panel(canvas, (w + 20, y0, w, h), x["centres"],
              [(logs[0], "thin"), (logs[1], "dash"), (logs[2], "solid")])
    turbid.write_image(path, canvas, overwrite=True)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--data", default=os.environ.get("TURBID_DATA", ""))
    p.add_argument("--out", required=True)
    args = p.parse_args()
    if not args.data or not os.path.isdir(args.data):
        sys.exit("against_real_water: set TURBID_DATA or --data to the real-data folder")
    os.makedirs(args.out, exist_ok=True)
    rows = [analyse(name, spec, args.out) for name, spec in frames(args.data)]
    text = table(rows)
    with open(os.path.join(args.out, "table.md"), "w") as f:
        f.write(text)
    figure(rows, os.path.join(args.out, "against_real_water.png"))
    print(text)


if __name__ == "__main__":
    main()
