"""RenderDataset(dtype="uint8"): 8-bit camera codes instead of float32, the same renders."""
import pickle

import numpy as np
import pytest

import turbid
from turbid import data

CONFIG = {"scenes": ["builtin:seafloor", "builtin:room"], "scale": 0.2, "seed": 3,
          "random": {"count": 3, "seed": 5, "params": {
              "water.type": {"choice": ["I", "3C", "5C"]},
              "psf.forward_scatter": {"uniform": [0.2, 0.8]},
              "snow.density_per_m3": {"log_uniform": [0.5, 20.0]}}}}


def srgb_codes(linear):
    """The 8-bit sRGB codes of linear values (IEC 61966-2-1 in double, rounded), and where a
    value lies within double rounding of a decision threshold (either code is right there)."""
    v = np.clip(np.nan_to_num(np.asarray(linear, np.float64), nan=0.0), 0.0, 1.0)
    e = np.where(v <= 0.0031308, 12.92 * v, 1.055 * v ** (1 / 2.4) - 0.055) * 255
    return np.round(e), np.abs(e - np.floor(e) - 0.5) < 1e-6


@pytest.mark.parametrize("kw", [dict(channel_axis=-1), dict(channel_axis=-3, crop=40),
                                dict(channel_axis=-3, ground_truth="lit")])
def test_codes_are_the_float_paths_codes(kw):
    f = data.RenderDataset(CONFIG, with_params=False, **kw)
    u = data.RenderDataset(CONFIG, with_params=False, dtype="uint8", **kw)
    for i in range(len(f)):
        a, b = f[i], u[i]
        for key in ("degraded", "clean"):
            assert b[key].dtype == np.uint8 and b[key].shape == a[key].shape, key
        # degraded: the float path's values are the decoded codes, bit for bit.
        assert np.array_equal(data.decode_codes(b["degraded"]), a["degraded"])
        # clean: the codes of the float path's (unquantised) clean image.
        want, tie = srgb_codes(a["clean"])
        assert np.all((b["clean"] == want) | tie)
        assert np.array_equal(a["depth"], b["depth"], equal_nan=True)
        assert np.array_equal(a["valid"], b["valid"]) and a["K"] == b["K"]


def test_codes_gray_linear_and_generate(tmp_path):
    config = {"scenes": ["builtin:hull"], "scale": 0.25, "seed": 2,
              "base": {"camera": {"encoding": "linear"}}, "random": {"count": 2}}
    f = data.RenderDataset(config, channels=None, with_params=False)
    u = data.RenderDataset(config, channels=None, with_params=False, dtype=np.uint8)
    for i in range(len(f)):
        a, b = f[i], u[i]
        assert b["degraded"].shape[-1] == 1
        assert np.array_equal(data.decode_codes(b["degraded"], "linear"), a["degraded"])
        clean = np.clip(a["clean"].astype(np.float64), 0, 1) * 255
        assert np.all(np.abs(b["clean"] - np.round(clean)) <= (np.abs(clean % 1 - 0.5) < 1e-5))
    # sRGB items: the bytes of generate's PNGs (read back as codes).
    config = dict(CONFIG, scenes=["builtin:seafloor"])
    turbid.generate(config, tmp_path, threads=1)
    u = data.RenderDataset(config, channels=None, with_params=False, dtype="uint8")
    for i in range(len(u)):
        s = u[i]
        for key, folder in (("degraded", "images"), ("clean", "ground_truth")):
            png = turbid.read_image(tmp_path / folder / (s["id"] + ".png"), encoding="linear")
            assert np.array_equal(s[key], np.round(png * 255).astype(np.uint8)), key


def test_dtype_spellings_errors_and_pickle():
    for spelling in ("uint8", np.uint8, np.dtype("uint8")):
        assert data.RenderDataset(CONFIG, dtype=spelling).dtype == "uint8"
    assert data.RenderDataset(CONFIG).dtype == "float32"
    with pytest.raises(ValueError, match="dtype: 'float32' .* or 'uint8'"):
        data.RenderDataset(CONFIG, dtype="float16")
    with pytest.raises(ValueError, match="format is exr"):
        data.RenderDataset(dict(CONFIG, format="exr"), dtype="uint8")
    deep = dict(CONFIG, base={"camera": {"bit_depth": 16}})
    with pytest.raises(Exception, match="dtype='uint8': 8-bit camera codes only.*16-bit"):
        data.RenderDataset(deep, dtype="uint8")[0]
    ds = pickle.loads(pickle.dumps(data.RenderDataset(CONFIG, crop=32, dtype="uint8")))
    assert ds.dtype == "uint8" and ds[1]["degraded"].dtype == np.uint8
    with pytest.raises(TypeError, match="uint8 codes"):
        data.decode_codes(np.zeros(3, np.float32))
    with pytest.raises(ValueError, match="encoding"):
        data.decode_codes(np.zeros(3, np.uint8), "gamma")


def test_codes_through_dataloader_workers():
    torch = pytest.importorskip("torch", reason="python3-torch is not installed")
    from torch.utils.data import DataLoader
    assert data.RenderDataset(CONFIG, dtype=torch.uint8).dtype == "uint8"
    ds = data.RenderDataset(CONFIG, channel_axis=-3, with_params=False, crop=48, dtype="uint8")
    expected = [ds[i] for i in range(len(ds))]
    for workers in (0, 1, 2):
        for collate in (data.collate, None):  # the batch path and torch's default collate
            kw = {"collate_fn": collate} if collate else {}
            seen = 0
            for batch in DataLoader(ds, batch_size=4, num_workers=workers, **kw):
                assert batch["degraded"].dtype == torch.uint8
                assert batch["clean"].dtype == torch.uint8
                assert workers == 0 or batch["degraded"].is_shared()
                for j in range(batch["degraded"].shape[0]):
                    for key in ("degraded", "clean", "depth", "valid"):
                        assert np.array_equal(batch[key][j].numpy(), expected[seen][key],
                                              equal_nan=True), key
                    seen += 1
            assert seen == len(ds)
    b = next(iter(DataLoader(ds, batch_size=4, collate_fn=data.collate)))
    decoded = data.decode_codes(b["degraded"])
    f = data.RenderDataset(CONFIG, channel_axis=-3, with_params=False, crop=48)
    assert isinstance(decoded, torch.Tensor) and decoded.dtype == torch.float32
    assert torch.equal(decoded, data.collate([f[i] for i in range(4)])["degraded"])
