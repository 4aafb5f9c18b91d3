"""Synthesis throughput at 640 x 480: turbid against a straightforward NumPy implementation of the
same model, run in the same session (issue 18 item 4; docs/performance.md, "Whole sweeps").

The model both sides render (docs/model.md): the built-in seafloor scene, Jerlov 3C water, ambient
light 1, classic backscatter B_inf on, the paper's PSF (generalized Gaussian at T = 4, q = 0.9: a
Gaussian of sigma 0.527 px, radius 3, mirrored borders), Poisson-Gaussian sensor noise, 8-bit sRGB
camera; no LEDs and no marine snow (their geometry is long to write in NumPy, and a user rewriting
the model by hand rarely has them):

    I = [J * h](x) t(x) + (1 - t(x)) B_inf + n(x),   J = E_A rho,   t_c = exp(-beta_c r)

Before timing, the NumPy image without noise is compared with turbid's (sensor off): they must
agree to one 8-bit code, which shows that both compute the same thing.

Run: PYTHONPATH=build/python python3 scripts/generate_vs_numpy.py [--turbid build/turbid]
"""
import argparse
import json
import math
import os
import shutil
import subprocess
import tempfile
import time

import numpy as np

import turbid

PARAMS = {
    "light": {"lights": []},
    "snow": {"enabled": False},
    "water": {"type": "3C", "backscatter": True, "ambient_rgb": [1.0, 1.0, 1.0]},
}


def gaussian_kernel(sigma, radius):
    x = np.arange(-radius, radius + 1, dtype=np.float64)
    k = np.exp(-x * x / (2 * sigma * sigma))
    return (k / k.sum()).astype(np.float32)


def blur(image, kernel):
    """Separable convolution with mirrored borders (BORDER_REFLECT_101), one axis at a time."""
    r = len(kernel) // 2
    out = image
    for axis in (0, 1):
        pad = [(0, 0)] * out.ndim
        pad[axis] = (r, r)
        padded = np.pad(out, pad, mode="reflect")  # NumPy's "reflect" is REFLECT_101
        acc = np.zeros_like(out)
        n = out.shape[axis]
        for i, w in enumerate(kernel):
            acc += w * np.take(padded, np.arange(i, i + n), axis=axis)
        out = acc
    return out


def srgb_encode(v):
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * np.power(v, 1 / 2.4) - 0.055)


def srgb_decode(c):
    return np.where(c <= 0.04045, c / 12.92, np.power((c + 0.055) / 1.055, 2.4))


class NumpyRenderer:
    """The model above in NumPy, RGB order, float32 like turbid."""

    def __init__(self, scene, water):
        cam = scene.camera
        h, w = scene.depth.shape
        u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
        ray = np.sqrt(((u - cam["cx"]) / cam["fx"]) ** 2 + ((v - cam["cy"]) / cam["fy"]) ** 2 + 1)
        self.range_m = (scene.depth * ray).astype(np.float32)
        self.rho = scene.image
        self.beta = np.array(water["beta_rgb_per_m"], dtype=np.float32)
        self.ambient = np.array(water["ambient_rgb"], dtype=np.float32)
        self.b_inf = np.array(water["backscatter_rgb"], dtype=np.float32)
        sigma = 0.5 / math.sqrt(0.9)
        self.kernel = gaussian_kernel(sigma, 3)

    def render(self, rng, noise=True):
        t = np.exp(-self.range_m[..., None] * self.beta)
        j = self.rho * self.ambient
        i = blur(j, self.kernel) * t + (1 - t) * self.b_inf
        if noise:
            var = np.maximum(i, 0) / 4000.0 + 0.002 ** 2
            i = i + np.sqrt(var) * rng.standard_normal(i.shape, dtype=np.float32)
        codes = np.round(srgb_encode(np.clip(i, 0, 1)) * 255)
        return srgb_decode(codes / 255).astype(np.float32)


def rate(fn, count):
    fn()  # warm-up
    t0 = time.perf_counter()
    for k in range(count):
        fn(k)
    return count / (time.perf_counter() - t0)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--turbid", default="build/turbid", help="the turbid executable (generate)")
    ap.add_argument("--count", type=int, default=40, help="images per measurement")
    ap.add_argument("--runs", type=int, default=3)
    args = ap.parse_args()

    scene = turbid.Scene.builtin("seafloor")  # 640 x 480
    water = turbid.render(scene, PARAMS, seed=1).sidecar["options"]["water"]  # Jerlov 3C's beta
    ref = NumpyRenderer(scene, water)
    quiet = dict(PARAMS, sensor={"enabled": False})
    ours = turbid.render(scene, quiet, seed=1).image
    theirs = ref.render(None, noise=False)
    codes = np.abs(np.round(srgb_encode(ours) * 255) - np.round(srgb_encode(theirs) * 255))
    print("agreement without noise: max %d code(s), %.3f %% of values differ"
          % (codes.max(), 100.0 * np.count_nonzero(codes) / codes.size))
    if codes.max() > 1:
        raise SystemExit("the NumPy model does not match turbid's: not the same model")

    rng = np.random.default_rng(1)
    exp_dir = tempfile.mkdtemp(prefix="turbid-gen-")
    config = {"scenes": ["builtin:seafloor"], "seed": 1, "base": PARAMS,
              "random": {"count": args.count, "params": {"water.type": {"choice": ["3C"]}}}}
    with open(os.path.join(exp_dir, "gen.json"), "w") as f:
        json.dump(config, f)
    try:
        for run in range(args.runs):
            np_rate = rate(lambda k=0: ref.render(rng), args.count)
            turbid.set_num_threads(1)  # one core, as NumPy's element-wise code
            one_rate = rate(lambda k=0: turbid.render(scene, PARAMS, seed=k).image, args.count)
            turbid.set_num_threads(0)
            py_rate = rate(lambda k=0: turbid.render(scene, PARAMS, seed=k).image, args.count)
            out = os.path.join(exp_dir, "out%d" % run)
            t0 = time.perf_counter()
            subprocess.run([args.turbid, "generate", os.path.join(exp_dir, "gen.json"), "--out",
                            out, "--threads", "1"], check=True, stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL)
            gen_rate = args.count / (time.perf_counter() - t0)
            print("run %d: NumPy %.1f img/s | turbid.render in memory, 1 thread %.1f img/s = %.1fx,"
                  " all cores %.1f img/s = %.1fx | turbid generate (PNG files, whole process,"
                  " 1 thread) %.1f img/s = %.1fx NumPy"
                  % (run + 1, np_rate, one_rate, one_rate / np_rate, py_rate, py_rate / np_rate,
                     gen_rate, gen_rate / np_rate))
    finally:
        shutil.rmtree(exp_dir)


if __name__ == "__main__":
    main()
