"""One frame, five ways in: `data.DegradeTransform`, `Scene.from_arrays` + `render`, `Scene.load` +
`render`, `data.RenderDataset` and `turbid generate` give bit-identical images for the same frame,
parameters and seed. The frame has no normals, so every path derives them from depth with the one
`NormalsFromDepth` (scenes/normals.h); the artificial light makes the image depend on them."""
import json
import os
import subprocess

import numpy as np
import pytest

import turbid
from turbid import data

SEED = 11
# Fixed parameters (no draws) with the default LED on; float output so that generate's EXR holds
# the render's float values exactly.
BASE = {"water": {"type": "3C"}, "psf": {"forward_scatter": 0.4},
        "snow": {"density_per_m3": 5.0}, "camera": {"bit_depth": 32}}


def synthetic_frame(tmp_path):
    """A 64 x 48 RGB-D frame: a tilted plane, a box in front of it (depth steps) and holes."""
    h, w = 48, 64
    fx, fy, cx, cy = 60.0, 60.0, 31.5, 23.5
    v, u = np.mgrid[0:h, 0:w].astype(np.float32)
    depth = 2.0 + 0.02 * u + 0.015 * v
    depth[14:30, 20:40] = 1.2 + 0.01 * u[14:30, 20:40]
    depth[5, 5] = np.nan
    depth[40:42, 50:53] = 0.0
    rng = np.random.default_rng(3)
    image = np.clip(0.4 + 0.2 * np.sin(u / 5.0)[..., None] * np.array([1.0, 0.7, 0.4])
                    + 0.05 * rng.standard_normal((h, w, 3)), 0.0, 1.0).astype(np.float32)
    turbid.write_image(tmp_path / "rgb.png", image, bit_depth=16, encoding="linear")
    np.save(tmp_path / "depth.npy", depth.astype(np.float32))
    spec = {"type": "depth", "image": "rgb.png", "depth": "depth.npy",
            "camera": {"fx": fx, "fy": fy, "cx": cx, "cy": cy}}
    path = tmp_path / "frame.json"
    path.write_text(json.dumps(spec))
    return path


def icl_frame(tmp_path):
    root = os.environ.get("TURBID_DATA")
    if not root or not os.path.isdir(os.path.join(root, "icl_nuim_lr_kt1")):
        pytest.skip("TURBID_DATA with icl_nuim_lr_kt1 is not available")
    spec = {"type": "rgbd", "image": os.path.join(root, "icl_nuim_lr_kt1/rgb/0.png"),
            "depth": os.path.join(root, "icl_nuim_lr_kt1/depth/0.png")}
    path = tmp_path / "icl.json"
    path.write_text(json.dumps(spec))
    return path


@pytest.mark.parametrize("make_frame", [synthetic_frame, icl_frame], ids=["synthetic", "icl"])
def test_five_ways_to_render_a_frame_agree(tmp_path, cli, make_frame):
    scene_path = make_frame(tmp_path)
    loaded = turbid.Scene.load(str(scene_path))
    image, depth, c = loaded.image, loaded.depth, loaded.camera
    K = np.array([[c["fx"], 0, c["cx"]], [0, c["fy"], c["cy"]], [0, 0, 1]])

    # generate's parameters for item 0 of a one-scene config with seed SEED.
    config = {"scenes": [str(scene_path)], "seed": SEED, "base": BASE, "format": "exr",
              "random": {"count": 1, "params": {}}}
    params = data.draw_params({"params": {}}, 0, BASE, SEED)

    from_load = turbid.render(loaded, params).image
    own = turbid.Scene.from_arrays(image, depth, c["fx"], c["fy"], c["cx"], c["cy"])
    from_arrays = turbid.render(own, params).image
    sample = data.DegradeTransform(base=BASE, seed=SEED)(image, depth, K, seed=0)
    degraded = sample["degraded"]
    assert sample["params"] == params
    sample = data.RenderDataset(config)[0]
    ds_image = sample["degraded"]
    assert sample["params"] == params

    config_path = tmp_path / "generate.json"
    config_path.write_text(json.dumps(config))
    out = tmp_path / "out"
    subprocess.run([cli, "generate", str(config_path), "--out", str(out)], check=True,
                   capture_output=True)
    rows = [json.loads(l) for l in (out / "manifest.jsonl").read_text().splitlines()]
    generated = turbid.read_image(out / rows[0]["image"])

    assert from_load.dtype == np.float32 and from_load.shape == image.shape
    for name, other in [("Scene.from_arrays", from_arrays), ("DegradeTransform", degraded),
                        ("RenderDataset", ds_image), ("turbid generate", generated)]:
        assert np.array_equal(from_load, other), name
    # The light depends on the normals: without the LED the image differs.
    dark = turbid.render(loaded, dict(params, light={"lights": []})).image
    assert not np.array_equal(dark, from_load)
