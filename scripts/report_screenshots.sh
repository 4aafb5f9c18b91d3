#!/usr/bin/env bash
# Screenshots of a sweep's report for docs/experiments.md ("Report"): the page in headless Chromium
# at 1280 px (rendered at 0.6 scale), cropped with ImageMagick and quantised with pngquant.
#   bash scripts/report_screenshots.sh out/demo docs/images
# Needs chromium, convert (imagemagick) and pngquant; the crops' offsets fit the demo's report.
set -euo pipefail
dir=$(cd "$1" && pwd)
out=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
shot() {  # shot FILE HEIGHT HASH
  timeout 120 chromium --headless --no-sandbox --disable-gpu --hide-scrollbars --no-first-run \
    --user-data-dir="$tmp/profile" --force-device-scale-factor=0.6 --window-size=1280,"$2" \
    --virtual-time-budget=10000 --screenshot="$1" "file://$dir/report.html$3" >/dev/null 2>&1
}
shot "$tmp/tall.png" 9000 ""
convert "$tmp/tall.png" -crop 768x540+0+0 +repage "$tmp/report_tables.png"
convert "$tmp/tall.png" -crop 768x560+0+740 +repage "$tmp/report_plot.png"
convert "$tmp/tall.png" -crop 768x360+0+3920 +repage "$tmp/report_scatter.png"
shot "$tmp/report_viewer.png" 900 "#view=seafloor-c0003/5"
shot "$tmp/report_slider.png" 900 "#view=seafloor-c0003/5/slider"
mkdir -p "$out"
for name in report_tables report_plot report_scatter report_viewer report_slider; do
  pngquant --force --quality 60-85 --output "$out/$name.png" "$tmp/$name.png"
done
ls -l "$out"/report_*.png
