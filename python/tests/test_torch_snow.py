"""turbid.torch's marine snow against the C++ renderer: the same particles for the same seed
(positions, sizes, albedos, which are hidden behind the scene), the same overlay to 1e-5; the
overlay differentiable in the water and the lamps (gradcheck, float64)."""

import numpy as np
import pytest

import turbid

import test_torch_model as base  # noqa: E402

torch = tt = None  # imported by the fixture (not at collection; see test_torch_model.py)


@pytest.fixture(autouse=True, scope="module")
def _torch():
    global torch, tt
    torch, tt = base.load()

from test_torch_model import OFF, TOL, array_scene, chw, merged, tensors  # noqa: E402

SNOW = merged(OFF, {"snow": {"enabled": True, "density_per_m3": 200.0}})


@pytest.mark.parametrize("name", ["hull", "seafloor", "room"])
def test_snow_equals_cpp_for_the_same_seed(name):
    scene = turbid.Scene.builtin(name, 0.2)
    rho, depth, K, normals = tensors(scene)
    for seed in (0, 9):
        for extra in ({}, {"water": {"type": "5C"}, "snow": {"blur_px": 2.5, "size_max_m": 0.02}}):
            params = merged(SNOW, extra)
            ref = turbid.render(scene, params, seed=seed)
            out = tt.render(rho, depth, K, params, seed=seed, normals=normals)
            assert float((out - chw(ref.image)).abs().max()) <= TOL, (seed, extra)
    flat = turbid.render(scene, OFF).image
    assert np.abs(ref.image - flat).max() > 0.1  # not vacuous: the snow shows


def test_particles_are_the_renderers():
    """Drawn and visible counts equal the sidecar's."""
    scene = turbid.Scene.builtin("room", 0.2)
    c = scene.camera
    for seed in (1, 2):
        derived = turbid.render(scene, SNOW, seed=seed).sidecar["derived"]["snow"]
        part, count = tt.snow_particles(tt.resolve(SNOW).raw("snow"), c["fx"], c["fy"], c["cx"],
                                        c["cy"], c["height"], c["width"], scene.range, seed)
        assert count == derived["particles"]
        assert len(part["u"]) == derived["visible"]


def test_snow_in_open_water_and_gray_and_batches():
    scene, image, depth = array_scene(gray=True)
    K = torch.tensor([[40.0, 0, 23.5], [0, 41.0, 17.5], [0, 0, 1]])
    params = merged(SNOW, {"snow": {"density_per_m3": 3000.0}})
    out = tt.render(chw(image).expand(2, -1, -1, -1), torch.from_numpy(depth)[None, None], K,
                    params, seed=[4, 8])
    for i, seed in enumerate((4, 8)):
        ref = turbid.render(scene, params, seed=seed).image
        assert float((out[i, 0] - torch.from_numpy(ref)).abs().max()) <= TOL


def test_gradcheck_through_the_snow():
    h, w = 8, 9
    rng = np.random.default_rng(6)
    rho = torch.from_numpy(rng.uniform(0.1, 0.9, (1, 3, h, w)))
    depth = torch.full((1, 1, h, w), 3.0, dtype=torch.float64)
    K = torch.tensor([[5.0, 0, 4.0], [0, 5.0, 3.5], [0, 0, 1]], dtype=torch.float64)
    snow = {"enabled": True, "density_per_m3": 20.0, "size_max_m": 0.05, "size_min_m": 0.02}

    def f(beta, power, position, snow=snow):
        params = {"psf": {"enabled": False}, "sensor": {"enabled": False}, "snow": snow,
                  "water": {"beta_rgb_per_m": beta},
                  "light": {"lights": [{"power": power, "position_in_camera_m": position}]}}
        return tt.render(rho, depth, K, params, seed=3)

    args = (torch.tensor([0.7, 0.4, 0.2], dtype=torch.float64, requires_grad=True),
            torch.tensor(8.0, dtype=torch.float64, requires_grad=True),
            torch.tensor([0.05, 0.25, 0.02], dtype=torch.float64, requires_grad=True))
    assert torch.autograd.gradcheck(f, args, eps=1e-6, atol=1e-6)
    # Not vacuous: there is snow in this image.
    with torch.no_grad():
        assert float((f(*args) - f(*args, snow={"enabled": False})).abs().max()) > 1e-3
