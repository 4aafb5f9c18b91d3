#!/usr/bin/env python3
"""A tiny external enhancement method for `turbid sweep` (docs/experiments.md, "External methods").

Gray-world white balance, then a percentile contrast stretch, on float32 PFM images; numpy only.

  python3 grayworld_stretch.py INPUT_DIR OUTPUT_DIR   # batch: every INPUT_DIR/<id>.pfm
  python3 grayworld_stretch.py INPUT.pfm OUTPUT.pfm   # one image

turbid writes the degraded images as linear float PFM ("input": {"format": "pfm"}) and reads
OUTPUT_DIR/<id>.pfm back, matched by item id.
"""
import os
import sys

import numpy as np


def read_pfm(path):
    with open(path, "rb") as f:
        kind = f.readline().strip()
        width, height = (int(v) for v in f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4")
    channels = 3 if kind == b"PF" else 1
    return data.reshape(height, width, channels)[::-1].astype(np.float64)  # rows bottom-to-top


def write_pfm(path, image):
    height, width, channels = image.shape
    with open(path, "wb") as f:
        f.write(b"PF\n" if channels == 3 else b"Pf\n")
        f.write(b"%d %d\n-1.0\n" % (width, height))
        f.write(np.ascontiguousarray(image[::-1], dtype="<f4").tobytes())


def enhance(image, low_pct=0.5, high_pct=99.5):
    # Gray world: scale each channel so that its mean equals the mean over all channels.
    means = image.reshape(-1, image.shape[2]).mean(axis=0)
    balanced = image * (means.mean() / np.maximum(means, 1e-6))
    # Contrast stretch: the low/high percentiles of all values map to 0 and 1.
    low, high = np.percentile(balanced, [low_pct, high_pct])
    return np.clip((balanced - low) / max(high - low, 1e-6), 0.0, 1.0)


def main(source, target):
    if os.path.isdir(source):
        for name in sorted(os.listdir(source)):
            if name.endswith(".pfm"):
                write_pfm(os.path.join(target, name), enhance(read_pfm(os.path.join(source, name))))
    else:
        write_pfm(target, enhance(read_pfm(source)))


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
