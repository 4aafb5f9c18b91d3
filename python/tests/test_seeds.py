"""Seeds outside [0, 2**64 - 1] are one ValueError naming the argument (issue 28, item 13): -1 was
refused by a message without the range, 2**63 and more were a pybind11 TypeError wall of text."""
import numpy as np
import pytest

import turbid
from turbid import data

RANGE = r"must be an integer in \[0, 18446744073709551615\]"
SAMPLER = {"params": {"water.beta_gray_per_m": {"uniform": [0.2, 0.8]}}}


@pytest.fixture(scope="module")
def scene():
    return turbid.Scene.builtin("hull", scale=0.05)


@pytest.mark.parametrize("bad, error", [(-1, ValueError), (2**64, ValueError), (1.5, TypeError),
                                        ("7", TypeError), (True, TypeError)])
def test_render_seed_out_of_range_is_one_value_error(scene, bad, error):
    # Out of range: ValueError; not an integer: TypeError; the same one line either way.
    with pytest.raises(error, match="^seed: " + RANGE):
        turbid.render(scene, {}, seed=bad)


def test_render_takes_the_whole_seed_range(scene):
    for seed in (0, 2**63, 2**64 - 1):
        r = turbid.render(scene, {}, seed=seed)
        assert r.sidecar["options"]["seed"] == seed
    assert np.array_equal(turbid.render(scene, {}, seed=np.uint64(2**64 - 1)).image,
                          turbid.render(scene, {}, seed=2**64 - 1).image)


@pytest.mark.parametrize("bad, error", [(-1, ValueError), (2**64, ValueError), (0.5, TypeError)])
def test_data_seeds_out_of_range_name_the_argument(bad, error):
    with pytest.raises(error, match="^seed: " + RANGE):
        data.draw_params(SAMPLER, 0, seed=bad)
    with pytest.raises(error, match="^random.seed: " + RANGE):
        data.draw_params(dict(SAMPLER, seed=bad), 0)
    with pytest.raises(error, match="^seed: " + RANGE):
        data.DegradeTransform(SAMPLER, seed=bad)
    assert data.draw_params(dict(SAMPLER, seed=2**64 - 1), 3, seed=2**63)["seed"] >= 0
