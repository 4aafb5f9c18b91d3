"""Render options the differentiable model took on after its first version: ambient "derived"
(B_inf = omega E_A H, simulator/water.cc DerivedBackscatter) and a lamp's spot cut-off
(light.lights[k].cutoff_angle_deg, light.cc) in E_L, the single-scatter veil and the snow's
lighting. Each against turbid.render (1e-5, float32) and by gradcheck (float64)."""

import importlib

import numpy as np
import pytest

import turbid

torch = tt = M = None


@pytest.fixture(autouse=True, scope="module")
def _torch():
    global torch, tt, M
    torch = pytest.importorskip("torch")
    tt = importlib.import_module("turbid.torch")
    M = importlib.import_module("test_torch_model")
    M.load()


TOL = 1e-5
DERIVED = {
    "paper": {"ambient": "derived"},
    "paper_down": {"ambient": "derived", "water": {"ambient_view_elevation_deg": -60.0,
                                                   "ambient_rgb": [0.1, 0.2, 0.3],
                                                   "scattering_albedo_rgb": [0.6, 0.8, 0.9]}},
    "revised_hg": {"ambient": "derived", "model": "revised",
                   "water": {"phase": {"model": "henyey_greenstein", "g": 0.7},
                             "beta_rgb_per_m": [0.5, 0.0, 0.3]}},
    "single_scatter": {"ambient": "derived", "veil": "single_scatter"},
}
CUTOFF = {
    "paper": {"light": {"lights": [{"cutoff_angle_deg": 20.0}]}},
    "two_lamps": {"light": {"lights": [
        {"position_in_camera_m": [0.2, 0.25, 0.0], "axis_in_camera": [-0.1, 0.0, 1.0],
         "half_power_angle_deg": 45.0, "cutoff_angle_deg": 15.0},
        {"position_in_camera_m": [-0.3, -0.1, 0.05], "power": 3.0, "half_power_angle_deg": 30.0,
         "cutoff_angle_deg": 25.0}]}},
    "single_scatter": {"veil": "single_scatter",
                       "light": {"lights": [{"cutoff_angle_deg": 20.0}]}},
}


def compare(scene, params):
    ref = turbid.render(scene, params, maps=["veil", "light"])
    rho, depth, K, normals = M.tensors(scene)
    image, maps = tt.render(rho, depth, K, params, normals=normals, maps=["veil", "light"])
    diff = {"image": float((image - M.chw(ref.image)).abs().max())}
    for name in ("veil", "light"):
        diff[name] = float((maps[name] - M.chw(ref.maps[name])).abs().max())
    assert max(diff.values()) <= TOL, diff
    return ref


@pytest.mark.parametrize("name", ["hull", "seafloor", "room"])
@pytest.mark.parametrize("case", sorted(DERIVED))
def test_derived_ambient_equals_cpp(name, case):
    scene = turbid.Scene.builtin(name, 0.15)
    params = M.merged(M.OFF, DERIVED[case])
    ref = compare(scene, params)
    typed = turbid.render(scene, dict(params, ambient="typed")).image
    assert np.abs(ref.image - typed).max() > 1e-3  # B_inf changed


@pytest.mark.parametrize("name", ["hull", "seafloor", "room"])
@pytest.mark.parametrize("case", sorted(CUTOFF))
def test_spot_cutoff_equals_cpp(name, case):
    scene = turbid.Scene.builtin(name, 0.15)
    params = M.merged(M.OFF, CUTOFF[case])
    ref = compare(scene, params)
    lights = [{k: v for k, v in light.items() if k != "cutoff_angle_deg"}
              for light in params["light"]["lights"]]
    wide = turbid.render(scene, M.merged(params, {"light": {"lights": lights}}),
                         maps=["light"]).maps["light"]
    # The cut-off darkens part of the image and leaves the rest as it was.
    assert (ref.maps["light"] < wide - 1e-4).mean() > 0.05
    assert (np.abs(ref.maps["light"] - wide) <= 1e-6).mean() > 0.01


def test_spot_cutoff_lights_the_snow_as_the_renderer():
    scene = turbid.Scene.builtin("seafloor", 0.15)
    params = M.merged(M.OFF, {"snow": {"enabled": True, "density_per_m3": 400.0}},
                      CUTOFF["paper"])
    ref = turbid.render(scene, params, seed=3).image
    rho, depth, K, normals = M.tensors(scene)
    out = tt.render(rho, depth, K, params, seed=3, normals=normals)
    assert float((out - M.chw(ref)).abs().max()) <= TOL
    no_snow = turbid.render(scene, M.merged(params, {"snow": {"enabled": False}})).image
    assert np.abs(ref - no_snow).max() > 0.01


def small():
    y, x = np.mgrid[0:5, 0:6].astype(np.float64)
    depth = torch.from_numpy(1.2 + 0.1 * x + 0.05 * y)[None, None]
    rho = torch.from_numpy(np.random.default_rng(1).uniform(0.1, 0.9, (1, 3, 5, 6)))
    K = torch.tensor([[6.0, 0, 2.5], [0, 6.0, 2.0], [0, 0, 1]], dtype=torch.float64)
    return rho, depth, K


def test_gradcheck_derived_ambient():
    """Gradients of omega, E_A and beta through B_inf = omega E_A H and the rest of the model."""
    rho, depth, K = small()

    def f(omega, ambient, beta):
        params = {"psf": {"enabled": False}, "snow": {"enabled": False},
                  "sensor": {"enabled": False}, "ambient": "derived",
                  "water": {"scattering_albedo_rgb": omega, "ambient_rgb": ambient,
                            "beta_rgb_per_m": beta}}
        return tt.render(rho, depth, K, params)

    args = tuple(torch.tensor(v, dtype=torch.float64, requires_grad=True) for v in (
        [0.8, 0.7, 0.9], [0.15, 0.2, 0.1], [0.7, 0.4, 0.2]))
    assert torch.autograd.gradcheck(f, args, eps=1e-6, atol=1e-7)


def test_gradcheck_with_a_spot_cutoff():
    """Lamp position, axis and power with a cut-off that crosses the image (no pixel on its edge
    within eps: the cut-off is a step)."""
    rho, depth, K = small()
    normals = torch.tensor([0.1, -0.2, -1.0], dtype=torch.float64).reshape(1, 3, 1, 1)
    normals = (normals / normals.norm()).expand(1, 3, 5, 6)

    def f(position, axis, power):
        params = {"psf": {"enabled": False}, "snow": {"enabled": False},
                  "sensor": {"enabled": False},
                  "light": {"lights": [{"position_in_camera_m": position, "axis_in_camera": axis,
                                        "power": power, "cutoff_angle_deg": 12.0,
                                        "half_power_angle_deg": 50.0}]}}
        return tt.render(rho, depth, K, params, normals=normals)

    args = tuple(torch.tensor(v, dtype=torch.float64, requires_grad=True) for v in (
        [0.05, 0.25, 0.02], [0.0, -0.1, 1.0], [8.0]))
    out = f(*args)
    lit = tt.render(rho, depth, K, {"psf": {"enabled": False}, "snow": {"enabled": False},
                                    "sensor": {"enabled": False}, "light": {"lights": []}},
                    normals=normals)
    dark = ((out - lit).abs() < 1e-12).all(dim=1)
    assert 0 < int(dark.sum()) < dark.numel()  # the cut-off crosses the image
    assert torch.autograd.gradcheck(f, args, eps=1e-6, atol=1e-7)
