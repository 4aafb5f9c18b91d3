"""The Python package against the CLI: same bytes, same scores, same messages."""
import json
import subprocess
import threading
import time

import numpy as np
import pytest

import turbid

PARAMS = {"water": {"type": "II"}, "psf": {"forward_scatter": 0.4},
          "snow": {"density_per_m3": 2.0}, "sensor": {"read_noise": 0.01}}


def run(cli, *args, ok=True):
    p = subprocess.run([cli, *map(str, args)], capture_output=True, text=True)
    if ok and p.returncode != 0:
        raise AssertionError("turbid %s failed: %s" % (" ".join(map(str, args)), p.stderr))
    return p


def cli_error(cli, *args):
    p = run(cli, *args, ok=False)
    assert p.returncode != 0
    line = p.stderr.strip().splitlines()[-1]
    assert line.startswith("turbid: error: ")
    return line[len("turbid: error: "):]


def test_version_matches_cli(cli):
    assert run(cli, "--version").stdout.strip() == "turbid " + turbid.__version__


@pytest.mark.parametrize("bits", [8, 16])
def test_render_is_byte_identical_to_cli(cli, tmp_path, bits):
    params = dict(PARAMS, camera={"bit_depth": bits})
    (tmp_path / "p.json").write_text(json.dumps(params))
    out = tmp_path / "cli.png"
    run(cli, "render", "--scene", "builtin:seafloor", "--scale", "0.25", "--params",
        tmp_path / "p.json", "--seed", 11, "--out", out)
    scene = turbid.Scene.builtin("seafloor", scale=0.25)
    r = turbid.render(scene, params, seed=11)
    assert r.image.dtype == np.float32 and r.image.shape == (scene.height, scene.width, 3)
    # The in-memory image holds the CLI's PNG codes, decoded (sRGB, camera.encoding's default; RGB
    # both sides; image_io decodes in float, the camera's table in double: < 2e-6 apart)...
    assert np.abs(turbid.read_image(out, encoding="srgb") - r.image).max() < 2e-6
    assert r.sidecar["encoding"] == "srgb"
    # ...and writing it with that encoding gives the same file bytes.
    turbid.write_image(tmp_path / "py.png", r.image, bit_depth=bits, encoding="srgb")
    assert (tmp_path / "py.png").read_bytes() == out.read_bytes()
    sidecar = json.loads((tmp_path / "cli.json").read_text())
    sidecar.pop("outputs")
    assert r.sidecar == sidecar


def test_rgb_order_at_the_boundary():
    scene = turbid.Scene.builtin("seafloor", scale=0.25)
    # Jerlov II attenuates red most: the red channel (index 0 in RGB) loses the most.
    r = turbid.render(scene, {"water": {"type": "II"}, "sensor": {"enabled": False},
                              "camera": {"bit_depth": 32}}, maps=["transmission"])
    t = r.maps["transmission"]
    assert t.shape[2] == 3
    assert np.nanmean(t[..., 0]) < np.nanmean(t[..., 1])
    assert np.nanmean(t[..., 0]) < np.nanmean(t[..., 2])


def test_write_image_leaves_the_array_alone(tmp_path):
    # RGB in, RGB back; the BGR conversion for OpenCV must not swap the caller's array in place.
    a = np.zeros((2, 3, 3), np.float32)
    a[..., 0] = 1.0
    a[..., 1] = 0.5
    kept = a.copy()
    turbid.write_image(tmp_path / "a.png", a, bit_depth=16, encoding="linear")
    assert np.array_equal(a, kept)
    assert np.array_equal(turbid.read_image(tmp_path / "a.png", encoding="linear"),
                          np.rint(kept * 65535) / 65535)


def test_integer_decoding_matches_the_png_reader(cli, tmp_path):
    out = tmp_path / "a.png"
    run(cli, "render", "--scene", "builtin:room", "--scale", "0.2", "--out", out)
    raw = np.rint(turbid.read_image(out, encoding="linear") * 255).astype(np.uint8)
    for enc in ("srgb", "linear"):
        scene = turbid.Scene.from_arrays(raw, np.full(raw.shape[:2], 2.0, np.float32),
                                         100, 100, raw.shape[1] / 2, raw.shape[0] / 2, encoding=enc)
        assert np.array_equal(scene.image, turbid.read_image(out, encoding=enc))


def test_score_equals_cli(cli, tmp_path):
    ref, img = tmp_path / "ref.png", tmp_path / "img.png"
    run(cli, "render", "--scene", "builtin:seafloor", "--scale", "0.25", "--out", ref,
        "--set", "water.type=custom", "--set", "water.beta_rgb_per_m=[0.01,0.01,0.01]",
        "--set", "sensor.enabled=false")
    (tmp_path / "p.json").write_text(json.dumps(PARAMS))
    run(cli, "render", "--scene", "builtin:seafloor", "--scale", "0.25", "--out", img,
        "--params", tmp_path / "p.json")
    doc = json.loads(run(cli, "score", img, "--ref", ref, "--original", img, "--metrics", "all",
                         "--json").stdout)
    expected = doc["results"][0]
    u8 = lambda p: np.rint(turbid.read_image(p, encoding="linear") * 255).astype(np.uint8)
    got = turbid.score(u8(img), ref=u8(ref), original=u8(img), metrics="all", domain="as_given")
    assert set(got) == set(doc["metrics"])
    for name, value in got.items():
        want = expected[name]
        want = float(want) if isinstance(want, str) else want
        assert value == want or (np.isnan(value) and np.isnan(want)), name


def test_enhance_equals_cli(cli, tmp_path):
    img = tmp_path / "in.png"
    run(cli, "render", "--scene", "builtin:seafloor", "--scale", "0.25", "--out", img)
    for method in ("clahe", "dcp"):
        out = tmp_path / (method + ".exr")
        run(cli, "enhance", "--method", method, img, out)
        # The CLI decodes the sRGB PNG per the render's sidecar beside it (img.json).
        got = turbid.enhance(turbid.read_image(img, encoding="srgb"), method)
        assert got.dtype == np.float32
        assert np.array_equal(got, turbid.read_image(out)), method


def test_match_features_equals_cli(cli, tmp_path):
    a, b = tmp_path / "a.png", tmp_path / "b.png"
    run(cli, "render", "--scene", "builtin:hull", "--scale", "0.5", "--out", a, "--seed", 1)
    run(cli, "render", "--scene", "builtin:hull", "--scale", "0.5", "--out", b, "--seed", 2)
    (tmp_path / "pairs.txt").write_text("%s,%s\n" % (a, b))
    doc = json.loads(run(cli, "score", "--pairs", tmp_path / "pairs.txt", "--json").stdout)
    want = doc["detectors"][0]["pairs_detail"][0]
    u8 = lambda p: np.rint(turbid.read_image(p, encoding="linear") * 255).astype(np.uint8)
    got = turbid.match_features(u8(a), u8(b), "orb")
    for key in ("keypoints_a", "keypoints_b", "correspondences", "inliers"):
        assert got[key] == want[key], key


def test_errors_carry_the_cli_message(cli):
    scene = turbid.Scene.builtin("hull", scale=0.1)
    for bad, sets in [({"psf": {"forward_scater": 0.5}}, "psf.forward_scater=0.5"),
                      ({"psf": {"forward_scatter": 2.0}}, "psf.forward_scatter=2.0"),
                      ({"water": {"type": "IX"}}, "water.type=IX")]:
        with pytest.raises(ValueError) as e:
            turbid.render(scene, bad)
        assert str(e.value) == cli_error(cli, "render", "--scene", "builtin:hull", "--scale",
                                         "0.1", "--set", sets, "--explain")
    with pytest.raises(ValueError) as e:
        turbid.enhance(scene.image, "no_such_method")
    assert str(e.value) == cli_error(cli, "enhance", "--method", "no_such_method", "a.png",
                                     "b.png")
    with pytest.raises(OSError):
        turbid.Scene.load("/nonexistent/scene.json")
    with pytest.raises(OSError):
        turbid.read_image("/nonexistent/image.png")


def test_bad_arrays_raise_value_error():
    # (Strided and float64 arrays are accepted: test_hardening.py::test_dtypes_and_layouts.)
    img = np.random.default_rng(0).random((48, 64, 3), dtype=np.float32)
    with pytest.raises(TypeError, match="dtype"):
        turbid.enhance(img.astype(np.int32), "clahe")
    with pytest.raises(ValueError, match="shape"):
        turbid.enhance(img[None, :, :, :2], "clahe")
    with pytest.raises(ValueError, match="shape"):
        turbid.enhance(np.zeros((8, 8, 2), np.float32), "clahe")
    with pytest.raises(ValueError, match="encoding"):
        turbid.enhance((img * 255).astype(np.uint8), "clahe")
    nan = img.copy()
    nan[3, 4, 1] = np.nan
    with pytest.raises(ValueError):
        turbid.enhance(nan, "clahe")
    with pytest.raises(ValueError):
        turbid.score(nan, ref=img)
    with pytest.raises(ValueError):
        turbid.Scene.from_arrays(nan, np.ones((48, 64), np.float32), 50, 50, 32, 24)
    with pytest.raises(ValueError, match="depth_m"):
        turbid.Scene.from_arrays(img, np.ones((48, 63), np.float32), 50, 50, 32, 24)


def test_scene_attributes():
    s = turbid.Scene.builtin("room", scale=0.25)
    assert s.image.shape == (s.height, s.width, 3)
    assert s.depth.shape == s.range.shape == (s.height, s.width)
    assert s.normals.shape == (s.height, s.width, 3)
    assert np.all(s.range[np.isfinite(s.depth)] >= s.depth[np.isfinite(s.depth)])
    c = s.camera
    again = turbid.Scene.from_arrays(s.image, s.depth, c["fx"], c["fy"], c["cx"], c["cy"],
                                     normals=s.normals, name="copy")
    p = {"water": {"type": "3C"}}
    assert np.array_equal(turbid.render(again, p, seed=3).image, turbid.render(s, p, seed=3).image)


def test_num_threads_do_not_change_results():
    scene = turbid.Scene.builtin("seafloor", scale=0.25)
    default = turbid.get_num_threads()
    try:
        turbid.set_num_threads(1)
        assert turbid.get_num_threads() == 1
        one = turbid.render(scene, {"water": {"type": "5C"}}, seed=3).image
        one_enh = turbid.enhance(one, "dcp")
        turbid.set_num_threads(2)
        assert turbid.get_num_threads() == 2
        two = turbid.render(scene, {"water": {"type": "5C"}}, seed=3).image
        assert np.array_equal(one, two)
        assert np.array_equal(one_enh, turbid.enhance(two, "dcp"))
        with pytest.raises(ValueError, match="n must be >= 0"):
            turbid.set_num_threads(-1)
    finally:
        turbid.set_num_threads(0)
    assert turbid.get_num_threads() == default


def test_gil_is_released_while_rendering():
    scene = turbid.Scene.builtin("hull")  # 1360 x 1024: long enough to observe
    params = {"psf": {"forward_scatter": 0.5, "optical_thickness": 1.0}}
    turbid.render(scene, params)
    done = threading.Event()
    ticks = 0

    def work():
        for _ in range(3):
            turbid.render(scene, params)
        done.set()

    t = threading.Thread(target=work)
    start = time.perf_counter()
    t.start()
    while not done.is_set():
        ticks += 1  # runs only while the render thread does not hold the GIL
    t.join()
    elapsed = time.perf_counter() - start
    # Holding the GIL for the whole render would leave a handful of switch-interval ticks.
    assert ticks > 1000, (ticks, elapsed)


def test_no_leak_over_10000_calls():
    def rss_kb():
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1])
    scene = turbid.Scene.builtin("seafloor", scale=0.1)
    img = turbid.render(scene).image

    def calls(n):
        for i in range(n):
            r = turbid.render(scene, {"water": {"type": "IB"}}, seed=i)
            _ = r.image, r.lit, r.sidecar
            turbid.enhance(img, "clahe")  # R, G, B read natively, the result wrapped
            turbid.enhance(img, "dcp")    # reordered by the library, the result wrapped
    calls(1000)
    before = rss_kb()
    calls(10000)
    grown = rss_kb() - before
    assert grown < 8 * 1024, "RSS grew by %d kB over 10,000 calls" % grown


def test_lists():
    names = [m["name"] for m in turbid.methods()]
    assert "clahe" in names and "full" in names
    assert {"ssim", "psnr", "uciqe"} <= {m["name"] for m in turbid.metrics()}
    d = turbid.default_params()
    assert turbid.resolve_params({}) == d
    assert turbid.render.__doc__ and "docs/model.md" in turbid.render.__doc__
