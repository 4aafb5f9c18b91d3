"""turbid.data: deterministic on-the-fly synthesis, equal to `turbid generate`."""
import json
import os
import sys

import numpy as np
import pytest

import turbid
from turbid import data

SAMPLER = {"params": {"water.type": {"choice": ["I", "IB", "II", "3C", "5C"]},
                      "psf.forward_scatter": {"uniform": [0.2, 0.8]},
                      "snow.density_per_m3": {"log_uniform": [0.5, 20.0]}},
           "seed": 5}
CONFIG = {"scenes": ["builtin:seafloor", "builtin:room"], "scale": 0.2, "seed": 3,
          "grid": {"psf.optical_thickness": [0.5, 1.5]},
          "random": dict(SAMPLER, count=2)}


def test_module_does_not_import_torch():
    assert "torch" not in sys.modules or "torch" in sys.argv  # nothing here imports it
    import subprocess
    out = subprocess.run([sys.executable, "-c",
                          "import sys, turbid, turbid.data; print('torch' in sys.modules)"],
                         capture_output=True, text=True, env=os.environ)
    assert out.stdout.strip() == "False", out.stderr


def test_dataset_items_equal_generate(tmp_path):
    ds = data.RenderDataset(CONFIG)
    assert len(ds) == 2 * 2 * 2
    turbid.generate(CONFIG, tmp_path, threads=2)
    rows = [json.loads(l) for l in (tmp_path / "manifest.jsonl").read_text().splitlines()]
    assert len(rows) == len(ds)
    for i in (0, 3, 5, 7):
        sample = ds[i]
        degraded, clean, params = sample["degraded"], sample["clean"], sample["params"]
        assert ds.item_id(i) == rows[i]["id"] == sample["id"] and sample["index"] == i
        assert params == rows[i]["options"]
        # The same 8-bit codes, sRGB-coded as the manifest records (decoded in float vs double).
        assert rows[i]["encoding"] == "srgb"
        png = turbid.read_image(tmp_path / rows[i]["image"], encoding="srgb")
        assert np.abs(degraded - png).max() < 2e-6
        assert np.array_equal(clean, turbid.Scene.builtin(rows[i]["scene"], 0.2).image)


def test_dataset_is_deterministic_in_any_order():
    ds = data.RenderDataset(CONFIG, with_params=False)
    forward = [ds[i]["degraded"] for i in range(len(ds))]
    again = data.RenderDataset(CONFIG, with_params=False)
    for i in reversed(range(len(ds))):
        assert np.array_equal(again[i]["degraded"], forward[i])
    assert not np.array_equal(forward[0], forward[1])


def test_transform_draws_like_generate():
    scene = turbid.Scene.builtin("seafloor", scale=0.2)
    t = data.DegradeTransform(SAMPLER, seed=3)
    c = scene.camera
    K = np.array([[c["fx"], 0, c["cx"]], [0, c["fy"], c["cy"]], [0, 0, 1]])
    # A single-scene generate config without grid: item i uses draw i and generate's seed i.
    ds = data.RenderDataset({"scenes": ["builtin:seafloor"], "scale": 0.2, "seed": 3,
                             "random": dict(SAMPLER, count=4)})
    types = set()
    for i in range(4):
        sample = t(scene.image, scene.depth, K, seed=i)
        degraded, clean, params = sample["degraded"], sample["clean"], sample["params"]
        assert params == ds[i]["params"]  # generate's parameters for item i
        # Rendered as from_arrays + render with those parameters (normals derived from depth).
        own = turbid.Scene.from_arrays(scene.image, scene.depth, c["fx"], c["fy"], c["cx"], c["cy"])
        assert np.array_equal(degraded, turbid.render(own, params).image)
        assert np.array_equal(clean, scene.image)
        types.add(params["water"]["type"])
        again = t(scene.image, scene.depth, (c["fx"], c["fy"], c["cx"], c["cy"]), i)
        assert np.array_equal(again["degraded"], degraded)
    assert types <= {"I", "IB", "II", "3C", "5C"}


def test_transform_rejects_bad_samplers():
    with pytest.raises(ValueError, match="random.params.psf.forward_scatter"):
        data.DegradeTransform({"params": {"psf.forward_scatter": {"normal": [0, 1]}}})
    with pytest.raises(ValueError, match="psf.forward_scatter"):
        data.DegradeTransform({"params": {"psf.forward_scatter": {"uniform": [2, 3]}}})


def test_torch_dataloader_two_workers():
    torch = pytest.importorskip("torch", reason="python3-torch is not installed")
    from torch.utils.data import DataLoader
    ds = data.RenderDataset(CONFIG, channel_axis=-3, with_params=False)
    expected = [ds[i] for i in range(len(ds))]
    for workers in (0, 2):
        loader = DataLoader(ds, batch_size=3, num_workers=workers, shuffle=False,
                            collate_fn=data.collate)
        seen = 0
        for batch in loader:
            degraded, clean = batch["degraded"], batch["clean"]
            assert degraded.shape[1:] == (3, 96, 128) and batch["valid"].dtype == torch.bool
            for j in range(degraded.shape[0]):
                assert np.array_equal(degraded[j].numpy(), expected[seen]["degraded"])
                assert np.array_equal(clean[j].numpy(), expected[seen]["clean"])
                seen += 1
        assert seen == len(ds)
    # Another order, items still the same bytes.
    order = [5, 2, 7, 0, 3, 6, 1, 4]
    loader = DataLoader(ds, batch_size=1, num_workers=2, sampler=order)  # default collate
    for k, batch in enumerate(loader):
        assert np.array_equal(batch["degraded"][0].numpy(), expected[order[k]]["degraded"])
