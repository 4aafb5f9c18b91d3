"""Binding overhead, thread scaling and loader throughput of the turbid package.

Run: PYTHONPATH=build/python python3 python/benchmarks/bench.py [--loader [--rounds N] [--no-touch]
     [--dtype uint8] [--path batch]]   (docs/python.md)
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


class _Timed(data.RenderDataset):
    """RenderDataset whose batch fetch counts, in the worker, the CPU its thread spends in
    __getitems__ (the renders, written into the batch's shared-memory rows) and the page faults."""

    fetch_cpu = 0.0
    fetch_faults = 0

    def __getitems__(self, indices):
        t0, f0 = time.thread_time(), resource.getrusage(resource.RUSAGE_SELF).ru_minflt
        out = super().__getitems__(indices)
        _Timed.fetch_cpu += time.thread_time() - t0
        _Timed.fetch_faults += resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0
        return out


class _PerSample:
    """The dataset without its batch fetch: DataLoader renders each sample into its own arrays
    and collate stacks them (the path before RenderDataset.__getitems__)."""

    def __init__(self, ds):
        self.ds = ds

    def __len__(self):
        return len(self.ds)

    def __getitem__(self, i):
        t0, f0 = time.thread_time(), resource.getrusage(resource.RUSAGE_SELF).ru_minflt
        out = self.ds[i]
        _Timed.fetch_cpu += time.thread_time() - t0
        _Timed.fetch_faults += resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0
        return out


def _tagged_collate(samples):
    """turbid.data.collate, plus the worker's own counters (read in the worker: process CPU of
    all its threads, the fetch's CPU, page faults), so that each process is counted alone."""
    import torch
    batch = data.collate(samples)
    ru = resource.getrusage(resource.RUSAGE_SELF)
    batch["_worker"] = (torch.utils.data.get_worker_info().id, time.process_time(),
                        _Timed.fetch_cpu, ru.ru_minflt, _Timed.fetch_faults)
    return batch


def loader(images=512, rounds=2, touch=True, dtype="float32", paths=("batch", "per-sample")):
    """turbid.data through a torch DataLoader with 2 workers, batch 32: 256 x 256 random crops
    and full 640 x 480 frames of the seafloor / room scenes with a random sampler; the batch path
    (RenderDataset.__getitems__: rendered into one shared-memory batch) and the per-sample path
    (each sample its own arrays, stacked by collate), alternated round by round. images/s (wall)
    and CPU milliseconds per image, each process counted alone (the workers read their own
    counters, from the first batch each delivered to its last; the main process its own), split
    into: the fetch (renders into the batch, incl. the page faults of its fresh shared-memory
    pages), the worker's rest (collate, pickling, handing the file descriptors over) and the main
    process (receiving, mapping, and with ``touch`` reading every page of the batch, as training
    does). ``dtype``: RenderDataset's (float32 or the opt-in uint8 camera codes); ``paths``:
    which of the two paths to run."""
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
        if dtype != "float32":
            kw["dtype"] = dtype
        ds = _Timed(config, channel_axis=-3, with_params=False, **kw)
        for r in range(rounds):
            for path, dataset in (("batch", ds), ("per-sample", _PerSample(ds))):
                if path not in paths:
                    continue
                dl = DataLoader(dataset, batch_size=32, num_workers=workers, shuffle=True,
                                collate_fn=_tagged_collate)
                first, last, count = {}, {}, 0
                it = iter(dl)
                b = next(it)  # start-up (fork, first batches) not counted
                first[b["_worker"][0]] = b["_worker"][1:]
                m0 = time.process_time()
                f0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
                t0 = time.perf_counter()
                for b in it:
                    w = b["_worker"][0]
                    if w not in first:  # each worker counted from its own first batch on
                        first[w] = b["_worker"][1:]
                        continue
                    last[w] = b["_worker"][1:]
                    count += b["degraded"].shape[0]
                    if touch:
                        for key in ("degraded", "clean", "depth", "valid"):
                            v = b[key].view(-1)
                            v[::4096 // v.element_size()].max()  # one value per 4 KiB page
                wall = time.perf_counter() - t0
                main = time.process_time() - m0
                main_faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0
                d = [sum(last[w][k] - first[w][k] for w in last) for k in range(4)]
                ms = 1e3 / count
                print("RenderDataset %s %s, %s path, num_workers=%d, batch 32: %.0f images/s, "
                      "%.2f ms CPU per image (%d images, %d cores): workers %.2f ms (fetch %.2f "
                      "with %.0f page faults, rest %.2f), main process %.2f ms (%.0f faults)"
                      % (name, dtype, path, workers, count / wall, (d[0] + main) * ms, count,
                         os.cpu_count(), d[0] * ms, d[1] * ms, d[3] / count, (d[0] - d[1]) * ms,
                         main * ms, main_faults / count))
                del it, dl


if __name__ == "__main__":
    print("turbid", turbid.__version__)
    if "--loader" in sys.argv:
        rounds = int(sys.argv[sys.argv.index("--rounds") + 1]) if "--rounds" in sys.argv else 2
        dtype = sys.argv[sys.argv.index("--dtype") + 1] if "--dtype" in sys.argv else "float32"
        paths = ((sys.argv[sys.argv.index("--path") + 1],) if "--path" in sys.argv
                 else ("batch", "per-sample"))
        loader(rounds=rounds, touch="--no-touch" not in sys.argv, dtype=dtype, paths=paths)
        sys.exit(0)
    overhead()
    scaling()
    loader()
