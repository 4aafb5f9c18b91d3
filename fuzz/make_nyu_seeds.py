#!/usr/bin/env python3
"""Writes the NYU Depth v2 fuzzer's seeds (fuzz/corpus/nyu/): tiny files with the labelled file's
layout, written independently of our reader with h5py. Run with Debian's python3 (python3-h5py):
    /usr/bin/python3 fuzz/make_nyu_seeds.py fuzz/corpus/nyu
Datasets are gzip-compressed constant arrays, so a 640x480 frame costs a few kilobytes."""
import os
import sys

import h5py
import numpy as np


def write(path, frames, depth_dtype, userblock, raw_depths):
    with h5py.File(path, "w", userblock_size=userblock) as f:
        shape = (frames, 3, 640, 480) if frames > 1 else (3, 640, 480)
        images = np.full(shape, 90, dtype=np.uint8)
        f.create_dataset("images", data=images, compression="gzip", compression_opts=9,
                         chunks=(1,) * (images.ndim - 3) + images.shape[-3:])
        dshape = (frames, 640, 480) if frames > 1 else (640, 480)
        depths = np.full(dshape, 2.5, dtype=depth_dtype)
        f.create_dataset("depths", data=depths, compression="gzip", compression_opts=9,
                         chunks=(1,) * (depths.ndim - 2) + depths.shape[-2:])
        if raw_depths:
            raw = np.zeros(dshape, dtype=depth_dtype)
            raw[..., 100:200, 100:200] = 3.0
            f.create_dataset("rawDepths", data=raw, compression="gzip", compression_opts=9,
                         chunks=(1,) * (raw.ndim - 2) + raw.shape[-2:])


def main():
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    write(os.path.join(out, "two_frames_f32.mat"), 2, np.float32, 512, True)
    write(os.path.join(out, "one_frame_f64.mat"), 1, np.float64, 0, False)


if __name__ == "__main__":
    main()
