"""Python callables as enhancement methods in a sweep (turbid.sweep(..., methods={...}))."""
import csv
import json
import os
import subprocess
import threading

import numpy as np
import pytest

import turbid


def experiment(methods, levels=(0.4, 1.0), scenes=("builtin:hull",), metrics=("ssim", "psnr")):
    return {
        "name": "callables",
        "seed": 3,
        "scale": 0.1,
        "scenes": list(scenes),
        "grid": {"water.beta_gray_per_m": list(levels)},
        "methods": methods,
        "metrics": list(metrics),
        "thumbnails": 0,
    }


def rows(out):
    with open(os.path.join(out, "items.csv"), newline="") as f:
        return list(csv.DictReader(f))


def by_method(out, method):
    return {r["id"]: r for r in rows(out) if r["method"] == method}


def test_identity_callable_scores_exactly_as_the_degraded_input(tmp_path):
    seen = []

    def identity(image):
        seen.append((image.dtype, image.shape, float(image.min()), float(image.max())))
        return image

    s = turbid.sweep(experiment(["mine"]), tmp_path, threads=2, methods={"mine": identity})
    assert s["ran"] == 2 and s["failed_rows"] == 0
    assert len(seen) == 2
    for dtype, shape, lo, hi in seen:
        assert dtype == np.float32 and len(shape) == 2 and 0.0 <= lo <= hi <= 1.0
    mine, none = by_method(tmp_path, "mine"), by_method(tmp_path, "none")
    assert set(mine) == set(none) and len(mine) == 2
    for item in mine:
        assert mine[item]["error"] == ""
        assert mine[item]["ssim"] == none[item]["ssim"]
        assert mine[item]["psnr"] == none[item]["psnr"]
    recorded = json.load(open(tmp_path / "experiment.json"))
    spec = [m for m in recorded["methods"] if m.get("label", m.get("name")) == "mine"][0]
    assert spec["external"]["kind"] == "python" and spec["external"]["python"] == "mine"
    assert "mine" in (tmp_path / "summary.md").read_text()


def test_callable_equals_the_builtin_method_it_wraps(tmp_path):
    # A callable that runs turbid's own CLAHE through turbid.enhance scores exactly like the
    # built-in row: the images reach Python and come back without loss.
    def wrapped(image):
        return turbid.enhance(image, "clahe")

    turbid.sweep(experiment([{"name": "py_clahe"}, "clahe"]), tmp_path, methods={"py_clahe": wrapped})
    mine, builtin = by_method(tmp_path, "py_clahe"), by_method(tmp_path, "clahe")
    for item in builtin:
        assert mine[item]["ssim"] == builtin[item]["ssim"]
        assert mine[item]["psnr"] == builtin[item]["psnr"]


def test_colour_srgb_and_integer_results(tmp_path):
    seen = []

    def to_uint8(image):  # sRGB values in, 8-bit sRGB out
        seen.append(image.shape)
        return np.round(np.clip(image, 0, 1) * 255).astype(np.uint8)

    exp = experiment([{"name": "u8", "encoding": "srgb"}], levels=(0.7,),
                     scenes=("builtin:seafloor",))
    s = turbid.sweep(exp, tmp_path, methods={"u8": to_uint8})
    assert s["failed_rows"] == 0
    assert len(seen) == 1 and seen[0][2] == 3
    mine, none = by_method(tmp_path, "u8"), by_method(tmp_path, "none")
    item = next(iter(none))
    # 8-bit sRGB quantisation of the input: close to, not equal to, the input's scores.
    assert abs(float(mine[item]["psnr"]) - float(none[item]["psnr"])) < 0.2


def test_batch_callable_gets_lists_once_per_batch(tmp_path):
    calls = []

    def batch(images):
        calls.append(len(images))
        return [np.clip(im * 1.5, 0, 1) for im in images]

    exp = experiment([{"name": "net", "batch": True, "batch_size": 2}], levels=(0.2, 0.5, 0.9))
    s = turbid.sweep(exp, tmp_path, threads=2, methods={"net": batch})
    assert s["ran"] == 3 and s["failed_rows"] == 0
    assert sorted(calls) == [1, 2]
    assert all(r["error"] == "" for r in rows(tmp_path))


def test_failures_mark_cells_and_the_sweep_goes_on(tmp_path):
    def flaky(image):
        if image.mean() > 0.0:
            raise RuntimeError("out of GPU memory\nsecond line")
        return image

    def wrong_size(image):
        return image[:-1]

    def not_finite(image):
        out = image.copy()
        out[0, 0] = np.nan
        return out

    exp = experiment(["flaky", "small", "nan", "clahe"])
    s = turbid.sweep(exp, tmp_path,
                     methods={"flaky": flaky, "small": wrong_size, "nan": not_finite})
    assert s["failed_rows"] == 6
    errors = {(r["method"], r["id"]): r["error"] for r in rows(tmp_path)}
    for (method, _), error in errors.items():
        if method == "flaky":
            assert error == "RuntimeError: out of GPU memory"
        elif method == "small":
            assert "wrong size" in error
        elif method == "nan":
            assert "non-finite" in error
        else:
            assert error == ""
    assert "failed" in (tmp_path / "summary.md").read_text()

    # Resume retries only when asked; a fixed callable under the same key then succeeds.
    again = turbid.sweep(exp, tmp_path,
                         methods={"flaky": flaky, "small": wrong_size, "nan": not_finite})
    assert again["ran"] == 0
    fixed = turbid.sweep(exp, tmp_path, retry_failed=True,
                         methods={"flaky": lambda im: im, "small": lambda im: im,
                                  "nan": lambda im: im})
    assert fixed["failed_rows"] == 0
    assert all(r["error"] == "" for r in rows(tmp_path))


def test_bad_batch_results_fail_the_batch(tmp_path):
    exp = experiment([{"name": "short", "batch": True}, {"name": "scalar", "batch": True}])
    s = turbid.sweep(exp, tmp_path, methods={"short": lambda ims: ims[:1],
                                             "scalar": lambda ims: 3})
    assert s["failed_rows"] == 4
    errors = {(r["method"], r["id"]): r["error"] for r in rows(tmp_path) if r["method"] != "none"}
    assert all("returned 1 images for 2 inputs" in e for (m, _), e in errors.items() if m == "short")
    assert all("must return a list" in e for (m, _), e in errors.items() if m == "scalar")


def test_bad_methods_argument_raises_before_any_work(tmp_path):
    with pytest.raises(ValueError, match="'other' is not a method of the experiment"):
        turbid.sweep(experiment(["mine"]), tmp_path, methods={"mine": abs, "other": abs})
    with pytest.raises(ValueError, match="built-in method"):
        turbid.sweep(experiment(["clahe"]), tmp_path, methods={"clahe": abs})
    with pytest.raises(ValueError, match="not callable"):
        turbid.sweep(experiment(["mine"]), tmp_path, methods={"mine": 3})
    with pytest.raises(ValueError, match="Python callable"):
        turbid.sweep(experiment([{"name": "mine", "python": "mine"}]), tmp_path)
    assert not (tmp_path / "items.csv").exists()


def test_cli_refuses_python_methods(cli, tmp_path):
    path = tmp_path / "exp.json"
    path.write_text(json.dumps(experiment([{"name": "mine", "python": "mine"}])))
    run = subprocess.run([cli, "sweep", str(path), "--out", str(tmp_path / "out")],
                         capture_output=True, text=True)
    assert run.returncode != 0
    assert "is a Python callable" in run.stderr and "turbid.sweep" in run.stderr


def test_callable_runs_while_other_threads_hold_the_gil(tmp_path):
    # Worker threads take the GIL for the call: a Python thread running meanwhile is not blocked
    # for the whole sweep, and the sweep is not deadlocked by it.
    stop = threading.Event()
    ticks = []

    def spin():
        while not stop.is_set():
            ticks.append(1)

    t = threading.Thread(target=spin)
    t.start()
    try:
        s = turbid.sweep(experiment(["mine"], levels=(0.2, 0.4, 0.6, 0.8)), tmp_path, threads=2,
                         methods={"mine": lambda im: im})
    finally:
        stop.set()
        t.join()
    assert s["ran"] == 4 and s["failed_rows"] == 0
    assert len(ticks) > 0
