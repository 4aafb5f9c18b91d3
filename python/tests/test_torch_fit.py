"""Fitting water through turbid.torch: from wrong water parameters, Adam (at most 500 steps)
recovers the ones the C++ renderer used to within 1 %, on a built-in scene and on a real ICL-NUIM
frame ($TURBID_DATA)."""

import json
import os

import numpy as np
import pytest

import turbid

import test_torch_model as base  # noqa: E402

torch = tt = None  # imported by the fixture (not at collection; see test_torch_model.py)


@pytest.fixture(autouse=True, scope="module")
def _torch():
    global torch, tt
    torch, tt = base.load()

from test_torch_model import OFF, chw, merged, tensors  # noqa: E402


def fit(scene, truth, start, make_params, steps=500, lr=0.05, normals=None):
    """Adam on the logs of the parameters (positive) against turbid.render's image of ``truth``.
    Returns the fitted values and the steps taken."""
    target = chw(turbid.render(scene, make_params(truth)).image)
    rho, depth, K, own = tensors(scene)
    normals = own if normals is None else normals
    logs = {k: torch.log(torch.as_tensor(v, dtype=torch.float32)).requires_grad_()
            for k, v in start.items()}
    opt = torch.optim.Adam(list(logs.values()), lr=lr)
    for step in range(steps):
        opt.zero_grad()
        image = tt.render(rho, depth, K, make_params({k: v.exp() for k, v in logs.items()}),
                          normals=normals)
        loss = (image - target).pow(2).mean()
        loss.backward()
        opt.step()
        if float(loss) < 1e-13:
            break
    return {k: v.detach().exp() for k, v in logs.items()}, step + 1


def relative_error(fitted, truth):
    return max(float((fitted[k] / torch.as_tensor(truth[k]) - 1).abs().max()) for k in truth)


def test_fit_water_on_a_builtin_scene():
    scene = turbid.Scene.builtin("seafloor", 0.15)

    def params(v):
        return merged(OFF, {"water": {"beta_rgb_per_m": v["beta"], "backscatter": True,
                                      "backscatter_rgb": v["binf"]}})

    truth = {"beta": [0.9, 0.35, 0.2], "binf": [0.05, 0.2, 0.3]}
    start = {"beta": [0.5, 0.5, 0.5], "binf": [0.1, 0.1, 0.1]}
    fitted, steps = fit(scene, truth, start, params)
    assert relative_error(fitted, truth) <= 0.01, (fitted, steps)
    assert relative_error({k: torch.tensor(v) for k, v in start.items()}, truth) > 0.4


def icl_scene(tmp_path, step=8):
    """ICL-NUIM frame 0 at an eighth of its size (every 8th pixel, intrinsics scaled)."""
    root = os.environ.get("TURBID_DATA")
    base = os.path.join(root or "", "icl_nuim_lr_kt1")
    if not root or not os.path.isdir(base):
        pytest.skip("TURBID_DATA with icl_nuim_lr_kt1 is not available")
    spec = tmp_path / "icl.json"
    spec.write_text(json.dumps({"type": "rgbd", "image": os.path.join(base, "rgb/0.png"),
                                "depth": os.path.join(base, "depth/0.png")}))
    full = turbid.Scene.load(str(spec))
    c = full.camera
    image = np.ascontiguousarray(full.image[::step, ::step])
    depth = np.ascontiguousarray(full.depth[::step, ::step])
    return turbid.Scene.from_arrays(image, depth, c["fx"] / step, c["fy"] / step,
                                    c["cx"] / step, c["cy"] / step, name="icl")


def test_fit_revised_water_on_a_real_frame(tmp_path):
    """The revised model's beta^D, beta^B and B_inf from an ICL-NUIM frame lit by a lamp."""
    scene = icl_scene(tmp_path)

    def params(v):
        return merged(OFF, {"model": "revised",
                            "water": {"beta_rgb_per_m": v["beta_d"], "backscatter_rgb": v["binf"]},
                            "revised": {"beta_b_rgb_per_m": v["beta_b"]},
                            "light": {"lights": [{"power": 4.0,
                                                  "position_in_camera_m": [0.0, -0.25, 0.0]}]}})

    truth = {"beta_d": [0.6, 0.25, 0.15], "beta_b": [0.8, 0.5, 0.4], "binf": [0.05, 0.15, 0.2]}
    start = {"beta_d": [0.4, 0.4, 0.4], "beta_b": [0.5, 0.5, 0.5], "binf": [0.1, 0.1, 0.1]}
    fitted, steps = fit(scene, truth, start, params)
    assert relative_error(fitted, truth) <= 0.01, (fitted, steps)
