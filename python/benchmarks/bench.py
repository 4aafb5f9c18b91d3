"""Binding overhead, thread scaling and loader throughput of the turbid package.

Run: PYTHONPATH=build/python python3 python/benchmarks/bench.py   (docs/performance.md)
"""
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


def loader():
    try:
        from torch.utils.data import DataLoader
    except ImportError:
        DataLoader = None
    config = {"scenes": ["builtin:seafloor"], "seed": 1,
              "random": {"count": 64, "params": {
                  "water.type": {"choice": ["I", "II", "3C", "5C"]},
                  "psf.forward_scatter": {"uniform": [0.2, 0.8]}}}}
    ds = data.RenderDataset(config, channels_first=True, with_params=False)
    scene = turbid.Scene.builtin("seafloor")
    crop_img = np.ascontiguousarray(scene.image[100:356, 100:356])
    crop_depth = np.ascontiguousarray(scene.depth[100:356, 100:356])
    c = scene.camera
    K = (c["fx"], c["fy"], c["cx"] - 100, c["cy"] - 100)
    t = data.DegradeTransform(config["random"], seed=1)

    class Crops:
        def __len__(self):
            return 64

        def __getitem__(self, i):
            return t(crop_img, crop_depth, K, i)[:2]

    for name, dataset in (("640x480 RenderDataset", ds), ("256x256 DegradeTransform", Crops())):
        t0 = time.perf_counter()
        for i in range(len(dataset)):
            dataset[i]
        print("%s, in-process: %.1f images/s" % (name, len(dataset) / (time.perf_counter() - t0)))
        if DataLoader is None:
            continue
        for workers in (1, 2):
            loader = DataLoader(dataset, batch_size=8, num_workers=workers)
            t0 = time.perf_counter()
            count = sum(b[0].shape[0] for b in loader)
            print("%s, DataLoader num_workers=%d: %.1f images/s"
                  % (name, workers, count / (time.perf_counter() - t0)))


if __name__ == "__main__":
    print("turbid", turbid.__version__)
    overhead()
    scaling()
    loader()
