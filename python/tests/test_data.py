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


# ---- the data path (issue 33 item 2) -------------------------------------------------------------

DARK = {"light": {"lights": []}}  # no artificial light: the image does not depend on normals


def crop_reference(scene, sample, params):
    """The sample's window rendered independently: the scene's arrays cut out by hand, the
    principal point shifted by the window's origin, through Scene.from_arrays + render."""
    fx, fy, cx, cy = sample["K"]
    c = scene.camera
    x0, y0 = c["cx"] - cx, c["cy"] - cy
    assert (fx, fy) == (c["fx"], c["fy"]) and x0 == int(x0) and y0 == int(y0)
    h, w = sample["depth"].shape
    box = (slice(int(y0), int(y0) + h), slice(int(x0), int(x0) + w))
    own = turbid.Scene.from_arrays(scene.image[box], scene.depth[box], fx, fy, cx, cy)
    return turbid.render(own, params).image, scene.image[box], scene.depth[box]


def test_crops_are_rendered_after_cropping_with_k_shifted():
    config = {"scenes": ["builtin:seafloor"], "seed": 2, "base": DARK,
              "random": dict(SAMPLER, count=6)}
    scene = turbid.Scene.builtin("seafloor")
    for mode in ("random", "center"):
        ds = data.RenderDataset(config, crop=(96, 128), crop_mode=mode)
        origins = set()
        for i in range(len(ds)):
            s = ds[i]
            assert s["degraded"].shape == (96, 128, 3) and s["depth"].shape == (96, 128)
            want, clean, depth = crop_reference(scene, s, s["params"])
            assert np.array_equal(s["degraded"], want), (mode, i)
            assert np.array_equal(s["clean"], clean)
            assert np.array_equal(s["depth"], depth, equal_nan=True)
            origins.add(tuple(s["K"][2:]))
            again = data.RenderDataset(config, crop=(96, 128), crop_mode=mode)[i]
            assert np.array_equal(again["degraded"], s["degraded"])  # reproducible
        if mode == "center":
            assert origins == {(scene.camera["cx"] - 256, scene.camera["cy"] - 192)}
        else:
            assert len(origins) > 3  # windows drawn per item
    with pytest.raises(ValueError, match="crop 512x700 .* larger than the frame, 480x640"):
        data.RenderDataset(config, crop=(512, 700))


def test_size_and_scale_resize_before_rendering():
    config = {"scenes": ["builtin:room"], "seed": 2, "random": dict(SAMPLER, count=2)}
    s = data.RenderDataset(config, crop=240, crop_mode="center", size=(60, 80))[0]
    assert s["degraded"].shape == (60, 80, 3) and s["valid"].shape == (60, 80)
    c = turbid.Scene.builtin("room").camera
    fx, fy, cx, cy = s["K"]
    # The 240 x 240 window at (200, 120), scaled by 1/3 x 1/4 about pixel centres.
    assert abs(fx - c["fx"] * 80 / 240) < 1e-9 and abs(fy - c["fy"] * 60 / 240) < 1e-9
    assert abs(cx - ((c["cx"] - 200 + 0.5) * 80 / 240 - 0.5)) < 1e-9
    assert abs(cy - ((c["cy"] - 120 + 0.5) * 60 / 240 - 0.5)) < 1e-9


def test_scale_applies_to_file_scenes(tmp_path):
    h, w = 48, 64
    rgb = np.random.default_rng(1).random((h, w, 3), dtype=np.float32)
    turbid.write_image(tmp_path / "rgb.png", rgb, bit_depth=16)
    depth = np.full((h, w), 2.0, np.float32)
    depth[:4] = 0.0
    np.save(tmp_path / "depth.npy", depth)
    (tmp_path / "f.json").write_text(json.dumps({
        "type": "depth", "image": "rgb.png", "depth": "depth.npy",
        "camera": {"fx": 60, "fy": 60, "cx": 31.5, "cy": 23.5}}))
    s = data.RenderDataset({"scenes": [str(tmp_path / "f.json")], "scale": 0.5})[0]
    assert s["degraded"].shape == (24, 32, 3)
    assert s["K"] == (30.0, 30.0, 15.5, 11.5)  # (c + 0.5) * s - 0.5
    # valid: depth known (0 is unknown); the first two rows of the half-size frame.
    assert not s["valid"][:2].any() and s["valid"][2:].all()
    assert np.isnan(s["depth"][:2]).all()


def test_epochs_draw_anew_reproducibly():
    ds = data.RenderDataset(CONFIG)
    first = [ds[i]["params"] for i in range(len(ds))]
    ds.set_epoch(1)
    second = [ds[i]["params"] for i in range(len(ds))]
    assert all(a != b for a, b in zip(first, second))
    assert [ds.params(i, 0) for i in range(len(ds))] == first
    again = data.RenderDataset(CONFIG, epoch=1)
    assert np.array_equal(again[3]["degraded"], ds[3]["degraded"])
    ds.set_epoch(0)
    assert ds[5]["params"] == first[5]
    # The grid point stays; the sampler's values change.
    assert [p["psf"]["optical_thickness"] for p in second] == \
        [p["psf"]["optical_thickness"] for p in first]


def test_samples_have_masks_maps_and_channels():
    config = {"scenes": ["builtin:hull"], "scale": 0.125, "seed": 1}
    s = data.RenderDataset(config, maps=["transmission"], channel_axis=-3)[0]
    assert s["degraded"].shape[0] == 3 and s["clean"].shape[0] == 3  # gray hull made RGB
    assert s["transmission"].shape == s["degraded"].shape
    assert s["valid"].dtype == np.bool_
    assert np.array_equal(s["valid"], np.isfinite(s["depth"]) & (s["depth"] > 0))
    gray = data.RenderDataset(config, channels=1)[0]
    assert gray["degraded"].shape[2] == 1
    with pytest.raises(ValueError, match="maps"):
        data.RenderDataset(config, maps=["transmision"])


def test_collate_names_sizes_and_buckets_group_them():
    config = {"scenes": ["builtin:seafloor", "builtin:hull"], "scale": 0.125, "seed": 1,
              "random": dict(SAMPLER, count=3)}
    ds = data.RenderDataset(config, channels=None)
    with pytest.raises(ValueError, match=r"different sizes in one batch: 60x80x3 \(items 0\); "
                                         r"128x170x1 \(items 3\)"):
        data.collate([ds[0], ds[3]])
    sampler = data.BucketBatchSampler(ds, batch_size=2, seed=4)
    batches = list(sampler)
    assert sorted(i for b in batches for i in b) == list(range(len(ds)))
    for b in batches:
        batch = data.collate([ds[i] for i in b])  # never mixed
        assert batch["degraded"].shape[0] == len(b) and batch["index"] is not None
    sampler.set_epoch(1)
    assert list(sampler) != batches or len(batches) < 3


def assert_same_batch(got, want):
    assert set(got) == set(want)
    for key, value in want.items():
        if hasattr(value, "shape"):
            assert got[key].dtype == value.dtype and tuple(got[key].shape) == tuple(value.shape)
            assert np.array_equal(np.asarray(got[key]), np.asarray(value), equal_nan=True), key
        elif key == "psf":  # kernels of their own sizes: a list
            assert all(np.array_equal(a, b) for a, b in zip(got[key], value, strict=True))
        else:
            assert got[key] == value, key


def test_batches_are_rendered_into_one_batch():
    # ds.batch / ds[[...]] / __getitems__: the bytes collate gives over the single samples.
    for kw in ({}, {"channel_axis": -3, "maps": ("transmission", "psf")}, {"crop": 40}):
        ds = data.RenderDataset(CONFIG, **kw)
        order = [6, 1, 3, 3]
        want = data.collate([ds[i] for i in order])
        assert_same_batch(ds.batch(order), want)
        assert_same_batch(ds[np.array(order)], want)
        got = ds.__getitems__(order)
        assert data.collate(got) is got.batch  # no copy
        assert_same_batch(data.collate(list(got)), want)  # the per-sample views
        assert all(np.shares_memory(s["degraded"], got.batch["degraded"]) for s in got)
    mixed = data.RenderDataset({"scenes": ["builtin:seafloor", "builtin:hull"], "scale": 0.125,
                                "seed": 1, "random": dict(SAMPLER, count=1)}, channels=None)
    with pytest.raises(ValueError, match="different sizes in one batch"):
        mixed.batch([0, 1])
    with pytest.raises(ValueError, match="render_sample: the array for degraded"):
        ds._render(0, {"degraded": np.zeros((2, 2, 3), np.float32)})


def test_dataloader_batches_come_in_shared_memory():
    torch = pytest.importorskip("torch", reason="python3-torch is not installed")
    from torch.utils.data import BatchSampler, DataLoader, SequentialSampler
    ds = data.RenderDataset(CONFIG, channel_axis=-3, with_params=False)
    want = [data.collate([ds[i] for i in range(k, min(k + 3, len(ds)))])
            for k in range(0, len(ds), 3)]
    loaders = [DataLoader(ds, batch_size=3, num_workers=2, collate_fn=data.collate),
               DataLoader(ds, batch_size=3, num_workers=2),  # torch's default_collate
               DataLoader(ds, batch_size=None, num_workers=2,
                          sampler=BatchSampler(SequentialSampler(ds), 3, drop_last=False))]
    for loader in loaders:
        got = list(loader)
        assert len(got) == len(want)
        for g, w in zip(got, want):
            for key in ("degraded", "clean", "depth", "valid", "index"):
                assert g[key].is_shared() and torch.equal(g[key], w[key]), key
            assert g["id"] == w["id"]


def test_worker_threads_are_set_automatically():
    torch = pytest.importorskip("torch")
    from torch.utils.data import DataLoader

    class Probe(data.RenderDataset):
        def __getitem__(self, i):
            s = super().__getitem__(i)
            s["threads"] = turbid.get_num_threads()
            return s

    import os as _os
    ds = Probe({"scenes": ["builtin:room"], "scale": 0.1, "seed": 1,
                "random": dict(SAMPLER, count=4)}, with_params=False)
    threads = [int(t) for b in DataLoader(ds, batch_size=1, num_workers=2,
                                          collate_fn=data.collate) for t in b["threads"]]
    assert threads == [max(1, (_os.cpu_count() or 1) // 2)] * 4


def test_transform_crops_like_the_dataset():
    scene = turbid.Scene.builtin("seafloor", scale=0.5)
    c = scene.camera
    K = (c["fx"], c["fy"], c["cx"], c["cy"])
    t = data.DegradeTransform(SAMPLER, base=DARK, seed=3, crop=64)
    s = t(scene.image, scene.depth, K, seed=7)
    assert s["degraded"].shape == (64, 64, 3)
    want, clean, _ = crop_reference(scene, s, s["params"])
    assert np.array_equal(s["degraded"], want) and np.array_equal(s["clean"], clean)
    assert np.array_equal(t(scene.image, scene.depth, K, seed=7)["degraded"], s["degraded"])
    with pytest.raises(TypeError, match="seed="):
        t(scene.image, scene.depth, K)
