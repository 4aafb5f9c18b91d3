"""turbid.torch's single-scatter veil (veil: "single_scatter", python/turbid/_torch_veil.py)
against the C++ renderer (simulator/veil.cc's fast path: the same quadrature, tables and
interpolation), on the built-in scenes, an array scene with open water, gray images, per-image
water and lamps, per-image cameras and an ICL-NUIM frame; gradcheck in float64 for beta, the
scattering albedo, B_inf, lamp power, position and axis. Tolerance 1e-5 absolute (issue 35)."""

import importlib
import json
import os

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
SS = {"veil": "single_scatter"}
VEIL_WATERS = {
    "default": {},
    "backscatter": {"water": {"backscatter": True, "beta_rgb_per_m": [0.9, 0.35, 0.2],
                              "scattering_albedo_rgb": [0.7, 0.8, 0.9]}},
    "two_lights": {"light": {"lights": [
        {"position_in_camera_m": [0.2, 0.25, 0.0], "axis_in_camera": [-0.1, 0.0, 1.0],
         "power": 5.0, "half_power_angle_deg": 45.0, "color_rgb": [1.0, 0.8, 0.6]},
        {"position_in_camera_m": [-0.3, -0.1, 0.05], "power": 3.0,
         "half_power_angle_deg": 30.0}]}},
    "henyey_greenstein": {"water": {"type": "3C", "phase": {"model": "henyey_greenstein",
                                                            "g": 0.8}}},
    "revised": {"model": "revised", "revised": {"beta_b_rgb_per_m": [0.9, 0.6, 0.4]}},
    "lamp_at_the_camera": {"light": {"lights": [{"position_in_camera_m": [0.0, 0.0, 0.0]}]}},
}


def check(scene, params, own=True):
    ref = turbid.render(scene, params, maps=["veil", "light"])
    rho, depth, K, normals = M.tensors(scene, own)
    image, maps = tt.render(rho, depth, K, params, normals=normals, maps=["veil", "light"])
    diff = {"image": float((image - M.chw(ref.image)).abs().max())}
    for name in ("veil", "light"):
        diff[name] = float((maps[name] - M.chw(ref.maps[name])).abs().max())
    assert max(diff.values()) <= TOL, diff
    # Not vacuous: a veil there is, and it is not eq. 2's.
    paper = turbid.render(scene, dict(params, veil="paper"), maps=["veil"]).maps["veil"]
    assert ref.maps["veil"].max() > 0.01
    assert np.abs(ref.maps["veil"] - paper).max() > 0.01
    return image


@pytest.mark.parametrize("name", ["hull", "seafloor", "room"])
@pytest.mark.parametrize("water", sorted(VEIL_WATERS))
def test_single_scatter_veil_equals_cpp_on_builtin_scenes(name, water):
    scene = turbid.Scene.builtin(name, 0.2)
    check(scene, M.merged(M.OFF, SS, VEIL_WATERS[water]))


@pytest.mark.parametrize("gray", [False, True])
def test_open_water_and_gray(gray):
    """Open-water pixels (NaN and 0 depth) are integrated to infinity, as the renderer does."""
    scene, image, depth = M.array_scene(gray)
    out = check(scene, M.merged(M.OFF, SS, VEIL_WATERS["backscatter"] if not gray else
                                {"water": {"backscatter": True, "beta_gray_per_m": 0.6}}),
                own=False)
    assert float(out[..., :6, :10].min()) > 0  # the veil of open water is not 0


def test_per_image_water_lamps_and_cameras():
    """Each image of a batch with its own beta, lamp power and position (one camera), and then a
    batch with a camera per image (one ray grid each) equals its own C++ render."""
    scene = turbid.Scene.builtin("seafloor", 0.15)
    rho, depth, K, normals = M.tensors(scene)
    beta = torch.tensor([[0.7, 0.7, 0.7], [1.2, 0.4, 0.1], [0.2, 0.3, 0.9]])
    power = torch.tensor([8.0, 2.0, 15.0])
    position = torch.tensor([[0.0, 0.25, 0.0], [0.3, -0.2, 0.1], [-0.1, 0.0, 0.5]])
    params = M.merged(M.OFF, SS, {"water": {"beta_rgb_per_m": beta},
                                  "light": {"lights": [{"power": power,
                                                        "position_in_camera_m": position}]}})
    n = 3
    Ks = K.expand(n, 3, 3).clone()
    for Kb in (K, Ks):
        if Kb is Ks:
            Ks[1, 0, 0] *= 1.3  # image 1 sees through a longer lens (another ray grid)
            Ks[2, 1, 2] += 3.0
        out = tt.render(rho.expand(n, -1, -1, -1), depth.expand(n, -1, -1, -1), Kb, params,
                        normals=normals.expand(n, -1, -1, -1))
        for i in range(n):
            c = scene.camera
            k = Kb[i] if Kb.ndim == 3 else Kb
            one = turbid.Scene.from_arrays(scene.image, scene.depth, float(k[0, 0]),
                                           float(k[1, 1]), float(k[0, 2]), float(k[1, 2]),
                                           normals=scene.normals)
            assert c["fx"] == float(K[0, 0])
            p = M.merged(M.OFF, SS, {"water": {"beta_rgb_per_m": beta[i].tolist()},
                                     "light": {"lights": [{"power": float(power[i]),
                                               "position_in_camera_m": position[i].tolist()}]}})
            ref = turbid.render(one, p).image
            assert float((out[i] - torch.from_numpy(ref).permute(2, 0, 1)).abs().max()) <= TOL
    assert float((out[0] - out[1]).abs().max()) > 0.05


def test_real_icl_frame(tmp_path):
    root = os.environ.get("TURBID_DATA")
    base = os.path.join(root or "", "icl_nuim_lr_kt1")
    if not root or not os.path.isdir(base):
        pytest.skip("TURBID_DATA with icl_nuim_lr_kt1 is not available")
    spec = tmp_path / "icl.json"
    spec.write_text(json.dumps({"type": "rgbd", "image": os.path.join(base, "rgb/0.png"),
                                "depth": os.path.join(base, "depth/0.png")}))
    scene = turbid.Scene.load(str(spec))
    for water in ("default", "two_lights"):
        check(scene, M.merged(M.OFF, SS, VEIL_WATERS[water]))


def test_gradcheck_single_scatter_veil():
    """Gradients of beta per channel, the scattering albedo, B_inf, lamp power, position and axis
    through V (float64; the phase table is a constant)."""
    y, x = np.mgrid[0:5, 0:6].astype(np.float64)
    depth = torch.from_numpy(1.2 + 0.1 * x + 0.05 * y)[None, None]
    depth[0, 0, 0, 0] = float("nan")  # open water: integrated to infinity
    rho = torch.from_numpy(np.random.default_rng(1).uniform(0.1, 0.9, (1, 3, 5, 6)))
    K = torch.tensor([[6.0, 0, 2.5], [0, 6.0, 2.0], [0, 0, 1]], dtype=torch.float64)

    def f(beta, omega, bs, power, position, axis):
        params = {"psf": {"enabled": False}, "snow": {"enabled": False},
                  "sensor": {"enabled": False}, "veil": "single_scatter",
                  "water": {"beta_rgb_per_m": beta, "scattering_albedo_rgb": omega,
                            "backscatter": True, "backscatter_rgb": bs},
                  "light": {"lights": [{"power": power, "position_in_camera_m": position,
                                        "axis_in_camera": axis,
                                        "half_power_angle_deg": 50.0}]}}
        return tt.render(rho, depth, K, params, maps=["veil"])[1]["veil"]

    args = tuple(torch.tensor(v, dtype=torch.float64, requires_grad=True) for v in (
        [0.7, 0.4, 0.2], [0.8, 0.7, 0.9], [0.05, 0.2, 0.25], [8.0], [0.05, 0.25, 0.02],
        [0.1, -0.2, 1.0]))
    assert torch.autograd.gradcheck(f, args, eps=1e-6, atol=1e-7)
