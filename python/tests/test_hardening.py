"""Issue 28 (Python): set_num_threads under load, TURBID_MAX_PIXELS for arrays, array-likes
(torch tensors, __array__, __dlpack__), dtypes and layouts, and messages that speak Python.

torch is imported inside the tests that use it (pytest.importorskip), never at collection:
test_data checks that turbid itself does not import it."""
import json
import os
import re
import resource
import subprocess
import sys
import textwrap
import threading

import numpy as np
import pytest

import turbid
from turbid import data

RNG = np.random.default_rng(7)
IMG = RNG.random((48, 64, 3), dtype=np.float32)
DEPTH = np.full((48, 64), 2.0, np.float32)
# A CLI flag in a message: what Python-facing messages must not contain.
FLAG = re.compile(r"(^|[\s(`'\"])--[a-z]")


def one_line(e):
    text = str(e.value)
    assert "\n" not in text and len(text) < 300, text
    assert "incompatible function arguments" not in text, text
    assert not FLAG.search(text), text
    return text


def run_script(code, timeout=300):
    """Runs `code` in a fresh interpreter (a crash there fails the test instead of pytest)."""
    env = dict(os.environ)
    p = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True,
                       text=True, env=env, timeout=timeout)
    assert p.returncode == 0, "exit %d\n%s\n%s" % (p.returncode, p.stdout, p.stderr[-3000:])
    return p.stdout


# ---- item 8: set_num_threads -----------------------------------------------------------------

def test_set_num_threads_refuses_counts_out_of_range():
    limit = 4 * (os.cpu_count() or 1)
    try:
        for n in (10**5, limit + 1, 10**30):
            with pytest.raises(ValueError, match="more than %d" % limit) as e:
                turbid.set_num_threads(n)
            one_line(e)
        for n in (-1, -10**30):
            with pytest.raises(ValueError, match="n must be >= 0") as e:
                turbid.set_num_threads(n)
            one_line(e)
        with pytest.raises(TypeError) as e:
            turbid.set_num_threads(2.5)
        one_line(e)
        turbid.set_num_threads(limit)
        assert turbid.get_num_threads() == limit
        turbid.set_num_threads(np.int64(1))
        assert turbid.get_num_threads() == 1
    finally:
        turbid.set_num_threads(0)


def test_set_num_threads_while_other_threads_render_enhance_and_score():
    # Three Python threads run turbid calls with the GIL released while the main thread changes
    # the count for 4 s (10^5 times): nothing crashes and every result is the single-thread one.
    out = run_script("""
        import threading
        import time
        import numpy as np
        import turbid
        scene = turbid.Scene.builtin("seafloor", scale=0.5)
        params = {"water": {"type": "5C"}, "psf": {"forward_scatter": 0.5}}
        turbid.set_num_threads(1)
        want = turbid.render(scene, params, seed=3).image
        want_enh = turbid.enhance(want, "dcp")
        want_score = turbid.score(want, ref=scene.image)
        turbid.set_num_threads(0)
        stop = threading.Event()
        errors = []
        def work(kind):
            try:
                while not stop.is_set():
                    if kind == 0:
                        assert np.array_equal(turbid.render(scene, params, seed=3).image, want)
                    elif kind == 1:
                        assert np.array_equal(turbid.enhance(want, "dcp"), want_enh)
                    else:
                        assert turbid.score(want, ref=scene.image) == want_score
            except BaseException as e:
                errors.append(repr(e))
        threads = [threading.Thread(target=work, args=(k,)) for k in range(3)]
        for t in threads:
            t.start()
        end, i = time.monotonic() + 4.0, 0
        while time.monotonic() < end:  # (the old binding crashed within a second here)
            turbid.set_num_threads(1 + i % 4)
            turbid.get_num_threads()
            i += 1
        turbid.set_num_threads(4)
        stop.set()
        for t in threads:
            t.join()
        assert not errors, errors
        assert turbid.get_num_threads() == 4  # the last change, applied once all calls returned
        print("ok")
    """)
    assert out.strip() == "ok"


def test_set_num_threads_from_a_sweep_method_is_applied_after_the_sweep(tmp_path):
    calls = []

    def method(image):
        turbid.set_num_threads(1)  # on a sweep worker, while the sweep runs: deferred
        calls.append(turbid.get_num_threads())
        turbid.enhance(image, "clahe")  # a nested turbid call
        return image

    exp = {"name": "t", "seed": 3, "scale": 0.1, "scenes": ["builtin:hull"],
           "grid": {"water.beta_gray_per_m": [0.2, 0.5, 1.0]}, "methods": ["mine"],
           "metrics": ["psnr"], "thumbnails": 0}
    try:
        turbid.set_num_threads(2)
        s = turbid.sweep(exp, tmp_path, threads=2, methods={"mine": method})
        assert s["ran"] == 3 and s["failed_rows"] == 0
        assert calls == [2, 2, 2]  # the pool was not resized under the running sweep...
        assert turbid.get_num_threads() == 1  # ...and is once it has returned
    finally:
        turbid.set_num_threads(0)


def test_set_num_threads_in_forked_workers():
    # DataLoader workers are forked processes: the parent's pool has run, the child sets 1.
    out = run_script("""
        import os
        import numpy as np
        import turbid
        scene = turbid.Scene.builtin("seafloor", scale=0.25)
        want = turbid.render(scene, seed=1).image
        pids = []
        for n in (1, 2, 0):
            pid = os.fork()
            if pid == 0:
                code = 1
                try:
                    turbid.set_num_threads(n)
                    code = 0 if np.array_equal(turbid.render(scene, seed=1).image, want) else 3
                finally:
                    os._exit(code)
            pids.append(pid)
        print([os.waitpid(p, 0)[1] for p in pids])
    """, timeout=120)
    assert out.strip() == "[0, 0, 0]"


def test_set_num_threads_in_dataloader_workers():
    pytest.importorskip("torch")
    out = run_script("""
        import numpy as np
        import torch
        import turbid
        from turbid import data
        config = {"scenes": ["builtin:room"], "scale": 0.1, "seed": 3,
                  "grid": {"psf.optical_thickness": [0.5, 1.0, 1.5, 2.0]}}
        ds = data.RenderDataset(config, channels_first=True, with_params=False)
        want = [ds[i]["degraded"] for i in range(len(ds))]  # the parent's pool has run
        loader = torch.utils.data.DataLoader(
            ds, batch_size=1, num_workers=2,
            worker_init_fn=lambda _: turbid.set_num_threads(1))
        got = [batch["degraded"][0].numpy() for batch in loader]
        assert all(np.array_equal(a, b) for a, b in zip(got, want)), "differs"
        print(len(got))
    """)
    assert out.strip() == "4"


def test_generate_threads_out_of_range_is_one_line(tmp_path):
    config = {"scenes": ["builtin:room"], "scale": 0.1}
    for n in (10**5, 10**30, -1):
        with pytest.raises(ValueError, match="threads") as e:
            turbid.generate(config, tmp_path / "out", threads=n)
        one_line(e)
    assert not (tmp_path / "out").exists()


# ---- item 10: TURBID_MAX_PIXELS for arrays ----------------------------------------------------

def ones(shape):
    """A float32 array of ones that holds no memory (a broadcast view)."""
    return np.broadcast_to(np.float32(1), shape)


def array_entry_points():
    """Every function that takes an image array, as (name, call(array)); the other arrays of a
    call are views of the same size holding no memory."""
    t = data.DegradeTransform()
    return [
        ("enhance", lambda a: turbid.enhance(a, "clahe")),
        ("score", lambda a: turbid.score(a, ref=a)),
        ("score ref", lambda a: turbid.score(np.zeros((2, 2), np.float32), ref=a)),
        ("score original", lambda a: turbid.score(np.zeros((2, 2), np.float32), original=a)),
        ("match_features", lambda a: turbid.match_features(a, a)),
        ("from_arrays", lambda a: turbid.Scene.from_arrays(a, ones(a.shape[:2]), 10, 10, 5, 5)),
        ("from_arrays depth", lambda a: turbid.Scene.from_arrays(
            ones(a.shape[:2]), a[..., 0], 10, 10, 5, 5)),
        ("from_arrays normals", lambda a: turbid.Scene.from_arrays(
            ones(a.shape[:2]), ones(a.shape[:2]), 10, 10, 5, 5, normals=a)),
        ("DegradeTransform", lambda a: t(a, ones(a.shape[:2]), (10, 10, 5, 5), 0)),
        ("write_image", lambda a: turbid.write_image(os.devnull + ".png", a)),
    ]


@pytest.mark.parametrize("name,call", array_entry_points())
def test_arrays_obey_turbid_max_pixels(monkeypatch, name, call):
    monkeypatch.setenv("TURBID_MAX_PIXELS", "1000")
    with pytest.raises(ValueError, match="TURBID_MAX_PIXELS") as e:
        call(np.zeros((40, 26, 3), np.float32))  # 1040 pixels
    assert "40" in one_line(e) or "26x40" in str(e.value)
    if name not in ("write_image", "score ref", "score original"):  # (sizes differ there)
        call(np.full((40, 25, 3), 0.5, np.float32))  # 1000 pixels: accepted


def test_a_20000_square_array_is_refused_before_any_allocation():
    # Views that hold no memory: 4.8 GB once converted to float32, as the issue's example.
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    for a in (np.broadcast_to(np.zeros(3, np.uint8), (20000, 20000, 3)),
              np.broadcast_to(np.zeros(3, np.float64), (20000, 20000, 3))):
        for name, call in array_entry_points():
            with pytest.raises(ValueError, match="20000x20000 exceeds the limit") as e:
                call(a)
            one_line(e)
    grown_kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before
    assert grown_kb < 100 * 1024, grown_kb


def test_a_sweep_method_returning_a_huge_array_fails_its_cell(tmp_path):
    def huge(image):
        return np.broadcast_to(np.zeros(1, np.float32), (20000, 20000))

    exp = {"name": "h", "seed": 3, "scale": 0.1, "scenes": ["builtin:hull"],
           "grid": {"water.beta_gray_per_m": [0.5]}, "methods": ["huge"], "metrics": ["psnr"],
           "thumbnails": 0}
    s = turbid.sweep(exp, tmp_path, threads=1, methods={"huge": huge})
    assert s["failed_rows"] == 1
    errors = [json.loads(l) for l in (tmp_path / "journal.jsonl").read_text().splitlines()] \
        if (tmp_path / "journal.jsonl").exists() else []
    text = (tmp_path / "items.csv").read_text()
    assert "TURBID_MAX_PIXELS" in text or any("TURBID_MAX_PIXELS" in json.dumps(x) for x in errors)


# ---- item 15: array-likes, dtypes, layouts ----------------------------------------------------

class ArrayOnly:
    """Only __array__ (as many array libraries)."""
    def __init__(self, a):
        self._a = a

    def __array__(self, dtype=None):
        return self._a if dtype is None else self._a.astype(dtype)


class DlpackOnly:
    """Only __dlpack__ / __dlpack_device__."""
    def __init__(self, a):
        self._a = a

    def __dlpack__(self, stream=None):
        return self._a.__dlpack__()

    def __dlpack_device__(self):
        return self._a.__dlpack_device__()


def test_array_likes_are_accepted_without_a_copy_where_possible():
    want_enh = turbid.enhance(IMG, "clahe")
    want_score = turbid.score(IMG, ref=IMG[::-1].copy())
    for wrap in (ArrayOnly, DlpackOnly, lambda a: memoryview(a), lambda a: a.tolist()):
        assert np.array_equal(turbid.enhance(wrap(IMG), "clahe"), want_enh)
        assert turbid.score(wrap(IMG), ref=wrap(IMG[::-1].copy())) == want_score
        s = turbid.Scene.from_arrays(wrap(IMG), wrap(DEPTH), 50, 50, 32, 24)
        assert np.array_equal(s.image, IMG)


def test_torch_cpu_tensors_are_accepted():
    torch = pytest.importorskip("torch")
    img, depth = torch.from_numpy(IMG), torch.from_numpy(DEPTH)
    assert np.array_equal(turbid.enhance(img, "clahe"), turbid.enhance(IMG, "clahe"))
    assert turbid.score(img, ref=img.flip(0)) == turbid.score(IMG, ref=IMG[::-1].copy())
    assert turbid.match_features(img, img) == turbid.match_features(IMG, IMG)
    s = turbid.Scene.from_arrays(img, depth, 50, 50, 32, 24)
    assert np.array_equal(s.image, IMG)
    # requires_grad (detached: turbid's results carry no gradient), a channels-first tensor
    # permuted to H x W x C (not contiguous), float64 and bfloat16 tensors, uint8 with encoding.
    chw = torch.from_numpy(IMG.transpose(2, 0, 1).copy())
    for t in (img.clone().requires_grad_(True), chw.permute(1, 2, 0), img.double()):
        assert np.array_equal(turbid.enhance(t, "clahe"), turbid.enhance(IMG, "clahe"))
    assert turbid.enhance(img.bfloat16(), "clahe").shape == IMG.shape
    u8 = (img * 255).round().to(torch.uint8)
    assert np.array_equal(turbid.enhance(u8, "clahe", encoding="srgb"),
                          turbid.enhance(u8.numpy(), "clahe", encoding="srgb"))
    t = data.DegradeTransform(seed=1)
    a = t(img, depth, torch.tensor([50.0, 50.0, 32.0, 24.0]), seed=3)
    b = t(IMG, DEPTH, (50, 50, 32, 24), 3)
    assert isinstance(a["degraded"], torch.Tensor) and isinstance(b["degraded"], np.ndarray)
    assert np.array_equal(a["degraded"].numpy(), b["degraded"]) and a["params"] == b["params"]


def test_torch_tensors_that_cannot_be_read_are_one_type_error():
    torch = pytest.importorskip("torch")
    meta = torch.empty((48, 64, 3), device="meta")
    with pytest.raises(TypeError, match=r"\.cpu\(\)") as e:
        turbid.enhance(meta, "clahe")
    assert "meta" in one_line(e)
    with pytest.raises(ValueError, match="channels first. pass channel_axis=-3") as e:
        turbid.enhance(torch.from_numpy(IMG.transpose(2, 0, 1).copy()), "clahe")
    one_line(e)
    for t in (torch.zeros((8, 8), dtype=torch.int64), torch.zeros((8, 8), dtype=torch.bool),
              torch.zeros((8, 8), dtype=torch.complex64)):
        with pytest.raises(TypeError, match="dtype") as e:
            turbid.score(t)
        one_line(e)


@pytest.mark.parametrize("bad", [None, "image.png", b"x", {"a": 1}, 3.0, object(),
                                 [[1, 2], [3]], np.array([object()] * 4).reshape(2, 2)])
def test_non_arrays_are_one_type_error(bad):
    for call in (lambda: turbid.enhance(bad, "clahe"), lambda: turbid.score(bad),
                 lambda: turbid.Scene.from_arrays(bad, DEPTH, 1, 1, 1, 1),
                 lambda: turbid.Scene.from_arrays(IMG, bad, 1, 1, 1, 1),
                 lambda: turbid.match_features(IMG, bad)):
        with pytest.raises(TypeError) as e:
            call()
        one_line(e)


def test_dtypes_and_layouts():
    want = turbid.enhance(IMG, "clahe")
    # Converted or copied to what the C++ half takes: float64 / float16, any strides, a
    # non-native byte order.
    for a in (IMG.astype(np.float64), IMG[::-1, ::-1][::-1, ::-1], IMG.astype(">f4"),
              np.asfortranarray(IMG)):
        assert np.array_equal(turbid.enhance(a, "clahe"), want)
    assert turbid.enhance(IMG.astype(np.float16), "clahe").shape == IMG.shape
    flipped = IMG[::-1]  # negative stride
    assert np.array_equal(turbid.enhance(flipped, "clahe"),
                          turbid.enhance(np.ascontiguousarray(flipped), "clahe"))
    strided = IMG[:, ::2]
    assert np.array_equal(turbid.enhance(strided, "clahe"),
                          turbid.enhance(np.ascontiguousarray(strided), "clahe"))
    assert turbid.score(np.ascontiguousarray(IMG[..., :1])) == turbid.score(IMG[..., 0])
    # Refused with one line: integer types other than uint8/uint16, bool, complex (TypeError);
    # shapes (ValueError); integer depth.
    for dtype in (np.int32, np.int64, np.uint32, np.bool_, np.complex64):
        with pytest.raises(TypeError, match="dtype") as e:
            turbid.enhance(IMG.astype(dtype), "clahe")
        one_line(e)
    for shape in ((48,), (2, 48, 64, 2), (48, 64, 2), (48, 64, 4), (0, 64, 3), (0, 48, 64, 3)):
        with pytest.raises(ValueError) as e:
            turbid.enhance(np.zeros(shape, np.float32), "clahe")
        one_line(e)
    with pytest.raises(TypeError, match="depth_m: dtype uint16") as e:
        turbid.Scene.from_arrays(IMG, (DEPTH * 1000).astype(np.uint16), 50, 50, 32, 24)
    one_line(e)


def test_integer_arguments_out_of_range_are_one_line(tmp_path):
    scene = turbid.Scene.builtin("room", scale=0.1)
    for call, error in [(lambda: turbid.render(scene, seed=2**64), ValueError),
                        (lambda: turbid.render(scene, seed=-1), ValueError),
                        (lambda: turbid.render(scene, seed="3"), TypeError),
                        (lambda: data.draw_params({}, -1), ValueError),
                        (lambda: data.draw_params({}, 2**70), ValueError),
                        (lambda: turbid.write_image(tmp_path / "a.png", IMG, bit_depth=2**40),
                         ValueError),
                        (lambda: turbid.sweep({}, tmp_path, threads=10**30), ValueError)]:
        with pytest.raises(error) as e:
            call()
        one_line(e)
    ds = data.RenderDataset({"scenes": ["builtin:room"], "scale": 0.1})
    for i in (len(ds), -len(ds) - 1, 2**70):
        with pytest.raises(IndexError):
            ds[i]
    assert np.array_equal(ds[-1]["degraded"], ds[len(ds) - 1]["degraded"])


# ---- item 15: messages speak Python ------------------------------------------------------------

EXP = {"name": "a", "seed": 3, "scale": 0.1, "scenes": ["builtin:room"],
       "grid": {"water.beta_gray_per_m": [0.5]}, "methods": ["clahe"], "metrics": ["psnr"],
       "thumbnails": 0}


def test_messages_name_keywords_not_cli_flags(tmp_path):
    scene = turbid.Scene.builtin("room", scale=0.1)
    img = turbid.render(scene, seed=1).image
    cases = [
        (lambda: turbid.enhance(img, "oracle"), ValueError, "sidecar="),
        (lambda: turbid.enhance(img, "oracle", sidecar={}), ValueError, "scene="),
        (lambda: turbid.score(img, metrics="ssim"), ValueError, "ref="),
        (lambda: turbid.render(scene, maps=["nope"]), ValueError, "maps="),
        (lambda: turbid.sweep(EXP, tmp_path / "s", shard="3/2"), ValueError, "shard='3/2'"),
        (lambda: turbid.sweep(EXP, tmp_path / "s", threads=5000), ValueError, "threads"),
    ]
    turbid.write_image(tmp_path / "a.png", img)
    cases.append((lambda: turbid.write_image(tmp_path / "a.png", img), OSError, "overwrite=True"))
    for call, error, keyword in cases:
        with pytest.raises(error) as e:
            call()
        text = one_line(e)
        assert keyword is None or keyword in text, text


def test_sweep_into_another_experiments_folder_names_force(tmp_path):
    turbid.sweep(EXP, tmp_path, threads=1)
    with pytest.raises((ValueError, OSError)) as e:
        turbid.sweep(dict(EXP, seed=4), tmp_path, threads=1)
    assert "force=True" in one_line(e)
