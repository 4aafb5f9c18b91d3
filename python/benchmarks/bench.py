"""Binding overhead, thread scaling and loader throughput of the turbid package.

Run: PYTHONPATH=build/python python3 python/benchmarks/bench.py [--loader]   (docs/performance.md)
"""
import os
import resource
import sys
import threading
import time

import numpy as np

import turbid
from turbid import _turbid, data

PARAMS = {"water": {"type": "3C"}, "psf": {"forward_scatter": 0.5}}


def per_call(fn, n):
    t0 = time.process_time()  # process CPU time, as _cpp_*_seconds: waiting for a core not counted
    for _ in range(n):
        fn()
    return (time.process_time() - t0) / n


def compare(label, cpp_fn, py_fn, n, rounds=9):
    """C++ alone and the Python call, in process CPU time, interleaved round by round so that
    load from other processes hits both alike; reports the minimum of each and the range of the
    per-round overheads."""
    cpp, py, ratios = [], [], []
    for _ in range(rounds):
        c = cpp_fn(n)
        p = per_call(py_fn, n)
        cpp.append(c)
        py.append(p)
        ratios.append(100 * (p - c) / c)
    ratios.sort()
    print("%s: C++ %.2f ms, Python %.2f ms CPU (minimum of %d rounds of %d), overhead %+.1f %% "
          "(min over min; per-round median %+.1f %%, range %+.1f .. %+.1f %%)"
          % (label, min(cpp) * 1e3, min(py) * 1e3, rounds, n,
             100 * (min(py) - min(cpp)) / min(cpp), ratios[len(ratios) // 2], ratios[0],
             ratios[-1]))


def overhead():
    scene = turbid.Scene.builtin("seafloor")  # 640 x 480
    import json
    text = json.dumps(PARAMS)
    compare("render 640x480 (render + .image)",
            lambda n: _turbid._cpp_render_seconds(scene._core, text, n),
            lambda: turbid.render(scene, PARAMS).image, 20)
    img = turbid.render(scene, PARAMS).image
    for method in ("clahe", "simplified"):
        compare("enhance %s 640x480" % method,
                lambda n: _turbid._cpp_enhance_seconds(img, method, n),
                lambda: turbid.enhance(img, method), 10)


def scaling(n=40):
    """Python threads rendering at once, each render on one C++ thread (set_num_threads(1)):
    the scaling shows the GIL released while C++ runs."""
    scene = turbid.Scene.builtin("seafloor")
    turbid.set_num_threads(1)

    def work(count):
        for _ in range(count):
            turbid.render(scene, PARAMS).image

    work(3)
    rates = {}
    for threads in (1, 2):
        ts = [threading.Thread(target=work, args=(n // threads,)) for _ in range(threads)]
        t0 = time.perf_counter()
        for t in ts:
            t.start()
        for t in ts:
            t.join()
        rates[threads] = n / (time.perf_counter() - t0)
    turbid.set_num_threads(0)
    print("render 640x480, one C++ thread per call, Python threads: 1 -> %.1f /s, 2 -> %.1f /s"
          " (x%.2f)" % (rates[1], rates[2], rates[2] / rates[1]))


def usage():
    """(main user, main system, workers user, workers system) seconds and (main, workers) minor
    page faults."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (own.ru_utime, own.ru_stime, kids.ru_utime, kids.ru_stime, own.ru_minflt,
            kids.ru_minflt)


class _PerSample:
    """The dataset without its batch fetch: DataLoader renders each sample into its own arrays
    and collate stacks them (the path before RenderDataset.__getitems__)."""

    def __init__(self, ds):
        self.ds = ds

    def __len__(self):
        return len(self.ds)

    def __getitem__(self, i):
        return self.ds[i]


def loader(images=512, rounds=2):
    """turbid.data through a torch DataLoader with 2 workers, batch 32: 256 x 256 random crops
    and full 640 x 480 frames of the seafloor / room scenes with a random sampler; the batch path
    (RenderDataset.__getitems__: rendered into one shared-memory batch) and the per-sample path
    (each sample its own arrays, stacked by collate), alternated round by round. images/s (wall)
    and CPU milliseconds per image, all processes (the figure that matters on a shared machine)."""
    try:
        import torch
        from torch.utils.data import DataLoader
    except ImportError:
        print("loader: python3-torch is not installed")
        return
    config = {"scenes": ["builtin:seafloor", "builtin:room"], "seed": 1,
              "random": {"count": images // 2, "params": {
                  "water.type": {"choice": ["I", "II", "3C", "5C"]},
                  "psf.forward_scatter": {"uniform": [0.2, 0.8]},
                  "snow.density_per_m3": {"log_uniform": [0.5, 20]}}}}
    workers = 2
    for name, kw in (("256x256 crops", {"crop": 256}), ("640x480 frames", {})):
        ds = data.RenderDataset(config, channel_axis=-3, with_params=False, **kw)
        for r in range(rounds):
            for path, dataset in (("batch", ds), ("per-sample", _PerSample(ds))):
                dl = DataLoader(dataset, batch_size=32, num_workers=workers, shuffle=True,
                                collate_fn=data.collate)
                it = iter(dl)
                next(it)  # start-up (fork, first scene load) not counted
                u0, t0 = usage(), time.perf_counter()
                count = sum(b["degraded"].shape[0] for b in it)
                wall = time.perf_counter() - t0
                d = [b - a for a, b in zip(u0, usage())]
                print("RenderDataset %s, %s path, num_workers=%d, batch 32: %.0f images/s, "
                      "%.2f ms CPU per image (%d images, %d cores); per image: workers %.2f ms "
                      "user + %.2f ms system, %.0f page faults; main process %.2f ms"
                      % (name, path, workers, count / wall, 1e3 * sum(d[:4]) / count, count,
                         os.cpu_count(), 1e3 * d[2] / count, 1e3 * d[3] / count, d[5] / count,
                         1e3 * (d[0] + d[1]) / count))
                del it, dl


if __name__ == "__main__":
    print("turbid", turbid.__version__)
    if "--loader" in sys.argv:
        loader()
        sys.exit(0)
    overhead()
    scaling()
    loader()
