"""How RenderDataset's batches reach the main process: the same bytes every way, both dtypes."""
import pytest

from turbid import data

CONFIG = {"scenes": ["builtin:seafloor", "builtin:room"], "scale": 0.2, "seed": 3,
          "random": {"count": 4, "params": {"water.type": {"choice": ["I", "3C"]}}}}


def _replacing_collate(samples):
    """collate, then one entry replaced and one added (as a user's wrapper might)."""
    import torch
    b = data.collate(samples)
    b["depth"] = b["depth"] * 2
    b["extra"] = torch.ones(2)
    return b


@pytest.mark.parametrize("dtype", ["float32", "uint8"])
def test_batches_are_bit_identical_through_workers(dtype):
    torch = pytest.importorskip("torch", reason="python3-torch is not installed")
    from torch.utils.data import DataLoader
    ds = data.RenderDataset(CONFIG, channel_axis=-3, crop=40, maps=("transmission",),
                            dtype=dtype)
    want = [data.collate([ds[i] for i in range(k, min(k + 3, len(ds)))])
            for k in range(0, len(ds), 3)]
    runs = {"0 workers": DataLoader(ds, batch_size=3, collate_fn=data.collate),
            "1 worker": DataLoader(ds, batch_size=3, num_workers=1, collate_fn=data.collate),
            "2 workers": DataLoader(ds, batch_size=3, num_workers=2, collate_fn=data.collate),
            "pin_memory": DataLoader(ds, batch_size=3, num_workers=2, collate_fn=data.collate,
                                     pin_memory=True),
            "persistent": DataLoader(ds, batch_size=3, num_workers=2, collate_fn=data.collate,
                                     persistent_workers=True)}
    for name, loader in runs.items():
        for epoch in range(2 if name == "persistent" else 1):
            got = list(loader)
            assert len(got) == len(want), name
            for g, w in zip(got, want):
                assert type(g) is dict and list(g) == list(w), name
                tensors = [k for k in w if isinstance(w[k], torch.Tensor)]
                assert set(tensors) == {"degraded", "clean", "depth", "valid", "transmission",
                                        "index"}
                for k in w:
                    if k in tensors:
                        assert g[k].dtype == w[k].dtype and torch.equal(g[k], w[k]), (name, k)
                    else:
                        assert g[k] == w[k], (name, k)
                if name in ("1 worker", "2 workers", "persistent"):
                    assert all(g[k].is_shared() for k in tensors), name
    # Batches kept while later ones arrive keep their values (no shared memory is reused).
    kept = list(DataLoader(ds, batch_size=3, num_workers=2, collate_fn=data.collate))
    for g, w in zip(kept, want):
        assert torch.equal(g["degraded"], w["degraded"])
    # A collate wrapper that replaces an entry: the replacement arrives, not the rendered array.
    got = list(DataLoader(ds, batch_size=3, num_workers=2, collate_fn=_replacing_collate))
    for g, w in zip(got, want):
        assert torch.equal(g["depth"], w["depth"] * 2)
        assert torch.equal(g["extra"], torch.ones(2))
        assert torch.equal(g["degraded"], w["degraded"])
