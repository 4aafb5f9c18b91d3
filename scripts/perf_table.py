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

# case: (bytes per pixel, flops per pixel, how they were counted). Pixels: the case's image
# (1360x1024 unless the case name says 640). Colour images have 3 samples per pixel.
MODEL = {
    "ssim/gray/8bit": (2, 260, "reads 2 x 1 B; 5 moment maps x 11-tap separable Gaussian "
                              "(2 passes x 11 FMA) + the SSIM formula"),
    "ssim/color/8bit": (6, 780, "3 channels of the gray case"),
    "ssim/gray/float": (8, 260, "reads 2 x 4 B; the gray case's arithmetic"),
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
}


def pixels(case, width, height):
    if "640" in case:
        return 640 * 480
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
            n = pixels(name, width, height)
            # Inputs and outputs that fit the last-level cache stay there between the bench's
            # iterations: their bound is the cache's bandwidth.
            rate = cache_bw if cache_bw > 0 and b * n <= cache_bytes else bandwidth
            t_mem = b * n / rate * 1e3
            t_flop = f * n / flops * 1e3
            bound = "%s / %s" % (fmt(t_mem, 2), fmt(t_flop, 2))
            at = "%.1f×" % (med / max(t_mem, t_flop))
        print("| `%s` | %s | %s | %s | %s | %s | %s | %s | %s |"
              % (name, cell, rows[0].get("peer") or "–",
                 fmt(statistics.median(peer)) if peer else "–", rcell, rows[0]["goal"],
                 " / ".join(status), bound, at))
    print()
    print("Work per pixel counted for the bound (bytes, flops):")
    for name, (b, f, why) in MODEL.items():
        if name in names:
            print("- `%s`: %d B, %d flop: %s" % (name, b, f, why))


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
