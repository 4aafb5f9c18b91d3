"""model "uwcnn" against an independent NumPy transcription of the published synthesis recipe
(C. Li, S. Anwar, F. Porikli, "Underwater scene prior inspired deep underwater image and video
enhancement", Pattern Recognition 98 (2020) 107038; the NYU-v2 scripts): on 8-bit sRGB codes x / 255,
d = depth / max(depth) * U(0.5, 15) m, t_c = N_c^d, A_c = 1.5 N_c^b with b ~ U(3, 5), and
I = A x t + A (1 - t), clipped and written as 8-bit codes. Real frames (ICL-NUIM, $TURBID_DATA),
fixed random draws, every Jerlov type; turbid must give the same codes to one 8-bit level.
turbid's d is the range along the viewing ray (its scenes' geometry); the transcription is handed
the same range. Pixels without depth are open water in turbid (t = 0) and are not compared."""
import json
import os

import numpy as np
import pytest

import turbid

# N_lambda per metre, [R, G, B], as the authors' scripts list them (type_I = [0.85, 0.961, 0.982]
# ... type_9 = [0.55, 0.46, 0.29]); written out here, not read from turbid.
N = {"I": [0.85, 0.961, 0.982], "IA": [0.84, 0.955, 0.975], "IB": [0.83, 0.95, 0.968],
     "II": [0.80, 0.925, 0.94], "III": [0.75, 0.885, 0.89], "1C": [0.75, 0.885, 0.875],
     "3C": [0.71, 0.82, 0.80], "5C": [0.67, 0.73, 0.67], "7C": [0.62, 0.61, 0.50],
     "9C": [0.55, 0.46, 0.29]}


def srgb_encode(v):
    v = np.clip(v.astype(np.float64), 0.0, 1.0)
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * np.power(v, 1.0 / 2.4) - 0.055)


def recipe(codes, range_m, n_rgb, b, max_distance):
    """The scripts' image: codes H x W x 3 in [0, 1] (8-bit / 255), range in metres."""
    valid = np.isfinite(range_m)
    d = range_m / np.max(range_m[valid]) * max_distance
    n = np.asarray(n_rgb, dtype=np.float64)
    t = np.power(n[None, None, :], d[..., None])
    a = 1.5 * np.power(n, b)
    out = a * codes * t + a * (1.0 - t)
    return np.round(np.clip(out, 0.0, 1.0) * 255.0)


def frames():
    root = os.environ.get("TURBID_DATA")
    base = os.path.join(root or "", "icl_nuim_lr_kt1")
    if not root or not os.path.isdir(base):
        pytest.skip("TURBID_DATA with icl_nuim_lr_kt1 is not available")
    return [(os.path.join(base, "rgb/%d.png" % i), os.path.join(base, "depth/%d.png" % i))
            for i in (0, 2)]


def test_uwcnn_matches_numpy_transcription(tmp_path):
    rng = np.random.default_rng(2020)
    worst = 0.0
    for k, (rgb, depth) in enumerate(frames()):
        spec = tmp_path / ("frame%d.json" % k)
        spec.write_text(json.dumps({"type": "rgbd", "image": rgb, "depth": depth}))
        scene = turbid.Scene.load(str(spec))
        # The file's own 8-bit codes / 255 (read without decoding), as the scripts read them.
        codes = np.asarray(turbid.read_image(rgb, "linear"), dtype=np.float64)
        range_m = np.asarray(scene.range, dtype=np.float64)
        valid = np.isfinite(range_m)
        assert valid.mean() > 0.5
        for water, n_rgb in N.items():
            b = rng.uniform(3.0, 5.0)  # the scripts' exponent draw
            max_distance = rng.uniform(0.5, 15.0)  # and their per-image distance
            params = {"model": "uwcnn", "psf": {"enabled": False}, "snow": {"enabled": False},
                      "sensor": {"enabled": False}, "camera": {"bit_depth": 8, "encoding": "srgb"},
                      "uwcnn": {"type": water, "backlight_exponent": b,
                                "max_distance_m": max_distance, "domain": "encoded"}}
            image = np.asarray(turbid.render(scene, params).image, dtype=np.float64)
            got = np.round(srgb_encode(image) * 255.0)
            want = recipe(codes, range_m, n_rgb, b, max_distance)
            diff = np.abs(got - want)[valid]
            worst = max(worst, float(diff.max()))
            assert diff.max() <= 1.0, (rgb, water, b, max_distance, float(diff.max()))
            # Not a vacuous comparison: the water changes the image by much more than a level.
            assert np.abs(want - np.round(codes * 255.0))[valid].mean() > 5.0
    assert worst <= 1.0


def test_uwcnn_linear_domain_is_labelled_and_differs():
    scene = turbid.Scene.builtin("seafloor", 0.25)
    base = {"model": "uwcnn", "uwcnn": {"type": "3C"}, "camera": {"bit_depth": 32}}
    encoded = turbid.render(scene, base)
    linear = turbid.render(scene, {**base, "uwcnn": {"type": "3C", "domain": "linear"}})
    assert encoded.sidecar["options"]["uwcnn"]["domain"] == "encoded"
    assert linear.sidecar["options"]["uwcnn"]["domain"] == "linear"
    assert "linear light" in str(linear.plan)
    assert np.abs(np.asarray(encoded.image) - np.asarray(linear.image)).max() > 0.01
