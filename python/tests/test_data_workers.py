"""turbid.data in DataLoader workers started by spawn (the dataset pickled, its scene table
rebuilt in each worker): the same bytes as in the main process, for crops and mixed scenes."""
import pickle

import numpy as np
import pytest

from turbid import data

CONFIG = {"scenes": ["builtin:seafloor", "builtin:room"], "scale": 0.2, "seed": 7,
          "random": {"count": 3, "seed": 2, "params": {
              "water.type": {"choice": ["I", "3C", "5C"]},
              "psf.forward_scatter": {"uniform": [0.2, 0.8]}}}}


def _equal(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def test_unpickled_dataset_renders_the_same_bytes():
    ds = data.RenderDataset(CONFIG, crop=48, channel_axis=-3)
    ds.set_epoch(2)
    again = pickle.loads(pickle.dumps(ds))
    assert len(again) == len(ds) == 6
    for i in (0, 3, 5):  # both scenes
        a, b = ds[i], again[i]
        assert a["id"] == b["id"] and a["K"] == b["K"] and a["params"] == b["params"]
        for key in ("degraded", "clean", "depth", "valid"):
            assert _equal(a[key], b[key]), key
        assert again.sample_size(i) == ds.sample_size(i) == (48, 48)
    # The batch path after unpickling gives the per-sample bytes.
    batch = again.batch([5, 0, 3])
    for j, i in enumerate((5, 0, 3)):
        assert _equal(batch["degraded"][j], ds[i]["degraded"])


def test_spawned_workers_give_the_main_process_bytes():
    torch = pytest.importorskip("torch", reason="python3-torch is not installed")
    from torch.utils.data import DataLoader
    ds = data.RenderDataset(CONFIG, crop=(40, 56), channel_axis=-3, with_params=False)
    ds.set_epoch(1)
    loader = DataLoader(ds, batch_size=3, num_workers=2, collate_fn=data.collate,
                        multiprocessing_context="spawn")
    got = list(loader)
    assert [b["degraded"].shape[0] for b in got] == [3, 3]
    for k, b in enumerate(got):
        want = data.collate([ds[i] for i in range(3 * k, 3 * k + 3)])
        assert b["id"] == want["id"]
        for key in ("degraded", "clean", "depth", "valid", "index"):
            assert torch.equal(b[key], want[key]), key
