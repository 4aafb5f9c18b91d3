"""docs/performance.md's goal table from `turbid bench --json` runs: for every case the median and
range of ours, the peer, the ratio, the goal and its status over the runs, and how close ours is to
the machine's limit (issue 18 item 5).

The limit: each case's minimal work per pixel (bytes that must cross memory, floating-point
operations the algorithm needs; the MODEL table below, counted by hand from the algorithm and
stated with it) divided by the machine's measured rates: the `machine/memory/triad` row
(bytes/s; `machine/cache/triad` when a call's bytes fit the last-level cache, where the bench's
repeated inputs stay) and the `machine/fma/*` rows (flop/s, the widest SIMD width measured),
taken from the same JSON runs. Integer kernels (8-bit SSIM, CLAHE's bins) are counted in flops
as if they were float: an approximation that the table's note repeats. "at limit" = our time / the larger of the two bounds: 1 is the hardware limit,
10 means ten times slower than the bound.

Usage:
  ./build/turbid bench --repetitions 3 --json run1.json     # three times (or --warm-allocator)
  python3 scripts/perf_table.py run1.json run2.json run3.json
"""
import json
import re
import statistics
import sys

# case: (bytes per pixel, flops per pixel or None, how they were counted). Pixels: the bench's
# inputs, 1360x1024 (the hull), or 640x480 (the seafloor) for the names in SEAFLOOR. Colour images
# have 3 samples per pixel. None: comparisons or table look-ups, not floating-point arithmetic
# (the bound is then the memory one alone, a loose one).
MODEL = {
    "ssim/gray/8bit": (2, 210, "reads 2 x 1 B; 4 moment maps (x, y, xy, (x - y)^2) x 11-tap "
                              "separable Gaussian (2 passes x 11 FMA) + the SSIM formula"),
    "ssim/color/8bit": (6, 630, "3 channels of the gray case"),
    "ssim/gray/float": (8, 210, "reads 2 x 4 B; the gray case's arithmetic (in float64 here)"),
    "psnr/color/8bit": (6, 9, "reads 2 x 3 B; a difference and a square-add per sample"),
    "guided_filter/gray/r2": (8, 60, "reads 4 B, writes 4 B; 4 box sums (2 passes each) + "
                                     "coefficients"),
    "guided_filter/gray/r8": (8, 60, "as r2: box sums cost the same at any radius"),
    "clahe/uniform": (8, 12, "reads 4 B, writes 4 B; a bin and a bilinear blend of 4 maps"),
    "clahe/rayleigh": (8, 12, "as uniform"),
    "psf/color/paper": (24, 84, "reads and writes 3 x 4 B; 7-tap separable, 3 channels"),
    "render/color/full": (28, 150, "reads depth 4 B + rho 12 B, writes 12 B; exp, light, PSF, "
                                   "noise per channel"),
    "render/gray/full": (12, 60, "reads depth + rho, writes 4 B"),
    "enhance/full": (8, 200, "reads 4 B, writes 4 B; guided filter, light, eq. 6, Wiener 7x7, "
                             "CLAHE"),
    "enhance/simplified": (8, 140, "reads 4 B, writes 4 B; two guided filters, boost, CLAHE"),
    "enhance/full/color": (24, 600, "3 channels of enhance/full"),
    "enhance/full/color640": (24, 600, "3 channels of enhance/full"),
    "enhance/simplified/color": (24, 420, "3 channels of enhance/simplified"),
    "enhance/simplified/color640": (24, 420, "3 channels of enhance/simplified"),
    "metrics/visible_edges/pair/paper": (6, None, "reads 2 x 3 B; window searches are table "
                                                  "look-ups and integer sums"),
    "metrics/visible_edges/pair/ifsttar": (6, None, "as paper"),
    "metrics/uiqm/color/8bit": (3, 40, "reads 3 B; Sobel, block extremes, colour moments"),
    "metrics/uciqe/color/8bit": (3, 40, "reads 3 B; Lab conversion, chroma, saturation"),
    "baseline/tarel/gray": (8, None, "reads 4 B, writes 4 B; two exact 11x11 medians "
                                     "(min/max networks)"),
    "baseline/tarel/color": (24, None, "as gray, colour white balance"),
    "baseline/tarel/median11/gray": (8, None, "one exact 11x11 median"),
    "baseline/fusion/gray": (8, 300, "reads 4 B, writes 4 B; weights and 5-level pyramids"),
    "baseline/fusion/color": (24, 900, "3 channels"),
    "baseline/dcp/gray": (8, 100, "reads 4 B, writes 4 B; min filter, guided filter r 60, "
                                  "recovery"),
    "baseline/udcp/gray": (8, 100, "as dcp"),
    "baseline/cap/gray": (8, 100, "as dcp"),
    "baseline/oracle/gray": (16, 300, "reads image, range and light 12 B, writes 4 B; "
                                      "MMSE box sums, Wiener deblur"),
    "baseline/dcp/dark_channel/gray": (8, None, "reads 4 B, writes 4 B; minima"),
    "baseline/dcp/color": (24, 300, "3 channels of the gray case"),
    "baseline/udcp/color": (24, 300, "as dcp"),
    "baseline/cap/color": (24, 300, "as dcp"),
    "baseline/oracle/color": (48, 900, "3 channels of the gray case"),
    "baseline/dcp/dark_channel/color": (16, None, "reads 12 B, writes 4 B; minima"),
    "baseline/dcp/refine/color": (16, 200, "reads a colour guide 12 B, writes 4 B; 3x3 solve "
                                           "per pixel"),
}
SEAFLOOR = {"enhance/full/color640", "enhance/simplified/color640", "baseline/tarel/color",
            "baseline/fusion/color", "baseline/dcp/color", "baseline/udcp/color",
            "baseline/cap/color", "baseline/oracle/color", "baseline/dcp/dark_channel/color",
            "baseline/dcp/refine/color"}


def pixels(case, width, height):
    if case in SEAFLOOR:
        return round(640 * width / 1360) * round(480 * height / 1024)
    return width * height


def limits(runs):
    """Machine rates: memory and last-level-cache bandwidth (bytes/s), the cache's size (bytes) and
    peak flop/s: the best over the runs of the machine rows."""
    bandwidth, cache_bw, cache_bytes, flops = 0.0, 0.0, 0, 0.0
    for run in runs:
        for c in run["cases"]:
            text = c.get("agreement", "")
            if c["name"] == "machine/cache/triad":
                m = re.match(r"([\d.]+) GB/s.*last-level cache (\d+) MiB", text)
                if m:
                    cache_bw = max(cache_bw, float(m.group(1)) * 1e9)
                    cache_bytes = int(m.group(2)) << 20
            if c["name"] == "machine/memory/triad":
                m = re.match(r"([\d.]+) GB/s", text)
                if m:
                    bandwidth = max(bandwidth, float(m.group(1)) * 1e9)
            elif c["name"].startswith("machine/fma/"):
                m = re.match(r"([\d.]+) GFLOP/s", text)
                if m:
                    flops = max(flops, float(m.group(1)) * 1e9)
    return bandwidth, cache_bw, cache_bytes, flops


def fmt(v, digits=3):
    return "–" if v is None else ("%.*g" % (digits, v))


def main(paths):
    runs = [json.load(open(p)) for p in paths]
    bandwidth, cache_bw, cache_bytes, flops = limits(runs)
    width, height = runs[0]["width"], runs[0]["height"]
    names = []
    for run in runs:
        for c in run["cases"]:
            if c["name"] not in names and not c["name"].startswith("machine/"):
                names.append(c["name"])
    print("machine: memory %.1f GB/s, last-level cache %.1f GB/s (%d MiB) (triad), %.1f GFLOP/s f32"
          " (FMA, one core); %d run(s)" % (bandwidth / 1e9, cache_bw / 1e9, cache_bytes >> 20,
                                           flops / 1e9, len(runs)))
    print()
    print("| case | ours ms: median (range) | peer | peer ms | ratio: median (range) | goal | "
          "status | bound ms (memory / flops) | at limit |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name in names:
        rows = [c for run in runs for c in run["cases"] if c["name"] == name]
        ours = [c["ours_ms"] for c in rows if c.get("ours_ms", -1) > 0]
        peer = [c["peer_ms"] for c in rows if c.get("peer_ms")]
        ratio = [c["ratio"] for c in rows if c.get("ratio")]
        status = sorted(set(c["status"] for c in rows))
        med = statistics.median(ours) if ours else None
        cell = "%s (%s–%s)" % (fmt(med), fmt(min(ours)), fmt(max(ours))) if ours else "–"
        rcell = ("%.1f× (%.1f–%.1f)" % (statistics.median(ratio), min(ratio), max(ratio))
                 if ratio else "–")
        bound, at = "–", "–"
        if name in MODEL and bandwidth > 0 and flops > 0 and med:
            b, f, _ = MODEL[name]
            f = f or 0
            n = pixels(name, width, height)
            # Inputs and outputs that fit the last-level cache stay there between the bench's
            # iterations: their bound is the cache's bandwidth.
            rate = cache_bw if cache_bw > 0 and b * n <= cache_bytes else bandwidth
            t_mem = b * n / rate * 1e3
            t_flop = f * n / flops * 1e3
            bound = "%s / %s" % (fmt(t_mem, 2), fmt(t_flop, 2) if f else "–")
            # Without a flop model the memory bound alone says little: no ratio.
            at = "%.1f×" % (med / max(t_mem, t_flop)) if f else "–"
        print("| `%s` | %s | %s | %s | %s | %s | %s | %s | %s |"
              % (name, cell, rows[0].get("peer") or "–",
                 fmt(statistics.median(peer)) if peer else "–", rcell, rows[0]["goal"],
                 " / ".join(status), bound, at))
    print()
    print("Work per pixel counted for the bound (bytes, flops):")
    for name, (b, f, why) in MODEL.items():
        if name in names:
            print("- `%s`: %d B, %s flop: %s" % (name, b, "–" if f is None else f, why))


if __name__ == "__main__":
    if len(sys.argv) < 2 or sys.argv[1] in ("-h", "--help"):
        print(__doc__)
        sys.exit(0 if len(sys.argv) >= 2 else 2)
    try:
        main(sys.argv[1:])
    except (OSError, ValueError, KeyError) as e:
        sys.exit("perf_table: %s" % e)
