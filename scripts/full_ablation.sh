#!/usr/bin/env bash
# The `full` step ablation of docs/methods.md: the built-in hull (half size, default render:
# noise, marine snow, PSF) at beta 0.4, 0.7 and 1.0 /m, enhanced by the blind `full` and by the
# paper read literally (`full_literal`) with --dump-steps; prints Hautiere's e of every step
# against the degraded input and, when ImageMagick is installed, writes a picture of the steps.
# Usage: scripts/full_ablation.sh [OUT_DIR] (default out/ablation); needs ./build/turbid.
set -euo pipefail
cd "$(dirname "$0")/.."
B="${TURBID:-./build/turbid}"
OUT="${1:-out/ablation}"
mkdir -p "$OUT"
for beta in 0.4 0.7 1.0; do
  "$B" render --scene builtin:hull --scale 0.5 --beta "$beta" --seed 1 --out "$OUT/hull_$beta.png" \
    --force >/dev/null
  for m in full full_literal; do
    "$B" enhance -m "$m" "$OUT/hull_$beta.png" "$OUT/${m}_$beta.png" --sidecar "$OUT/hull_$beta.json" \
      --dump-steps "$OUT/steps_${m}_$beta" --force >/dev/null
  done
done
python3 - "$OUT" <<'PY'
import json, sys
out = sys.argv[1]
print("| beta | method | " + " | ".join(["denoised", "veil removed", "dehazed", "deblurred", "output"]) + " |")
print("|---|---|---|---|---|---|---|")
for beta in ["0.4", "0.7", "1.0"]:
    for m in ["full", "full_literal"]:
        steps = json.load(open(f"{out}/steps_{m}_{beta}/steps.json"))
        e = {s["step"]: s["hautiere_e"] for s in steps["visible_edges"]}
        cells = [e.get(k) for k in ["01_denoised", "02_veil_removed", "04_dehazed", "05_deblurred", "99_output"]]
        print(f"| {beta} | {m} | " + " | ".join("–" if c is None else f"{c:.2f}" for c in cells) + " |")
PY
if command -v montage >/dev/null && montage -version 2>/dev/null | grep -q ImageMagick; then
  rows=()
  for beta in 0.4 0.7 1.0; do
    for m in full full_literal; do
      d="$OUT/steps_${m}_$beta"
      for f in 00_input 01_denoised 02_veil_removed 04_dehazed 05_deblurred 99_output; do
        rows+=("$d/$f.exr")
      done
    done
  done
  montage "${rows[@]}" -resize 220x -tile 6x -geometry +2+2 -background white \
    -quality 85 "$OUT/full_steps_hull.jpg"
  echo "picture: $OUT/full_steps_hull.jpg (rows: beta 0.4 full, full_literal, 0.7 ..., columns:"\
    "input, denoised, veil removed, dehazed, deblurred, output)"
fi
