"""turbid.torch against the C++ renderer (turbid.render): every term and their composition on the
built-in scenes, an array scene with missing depth (normals derived from depth) and a real
ICL-NUIM frame ($TURBID_DATA); batches with per-image parameters; gradients (gradcheck, float64).

Noise, snow and the PSF are off here (test_torch_psf.py, test_torch_noise.py, test_torch_snow.py);
the camera is bit depth 32 (clip only) on both sides. Tolerance: 1e-5 absolute in float32
(issue 35)."""

import importlib
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import turbid

# torch is imported by the fixture, not at collection: test_data.py checks that nothing the
# package does imports torch, and pytest collects every file before running any test.
torch = tt = None


def load():
    """Import torch and turbid.torch (skip without torch) into this module's globals."""
    global torch, tt
    torch = pytest.importorskip("torch")
    tt = importlib.import_module("turbid.torch")
    return torch, tt


@pytest.fixture(autouse=True, scope="module")
def _torch():
    load()

TOL = 1e-5
OFF = {"psf": {"enabled": False}, "snow": {"enabled": False}, "sensor": {"enabled": False},
       "camera": {"bit_depth": 32}}
MAPS = ["transmission", "light", "veil"]


def merged(*dicts):
    out = {}
    for d in dicts:
        for k, v in d.items():
            out[k] = merged(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) \
                else v
    return out


def own_normals(scene):
    """The scene's normals, or None when the renderer derives them from depth."""
    n = scene.normals
    return n if isinstance(n, np.ndarray) and n.dtype == np.float32 else None


def tensors(scene, own=True):
    """albedo 1 x C x H x W, depth 1 x 1 x H x W, K 3 x 3, normals (or None) from a Scene."""
    c = scene.camera
    image = torch.from_numpy(np.ascontiguousarray(scene.image))
    rho = image.permute(2, 0, 1)[None] if image.ndim == 3 else image[None, None]
    depth = torch.from_numpy(np.ascontiguousarray(scene.depth))[None, None]
    K = torch.tensor([[c["fx"], 0.0, c["cx"]], [0.0, c["fy"], c["cy"]], [0.0, 0.0, 1.0]],
                     dtype=torch.float64)
    normals = own_normals(scene) if own else None
    if normals is not None:
        normals = torch.from_numpy(np.ascontiguousarray(normals)).permute(2, 0, 1)[None]
    return rho, depth, K, normals


def chw(array):
    t = torch.from_numpy(np.ascontiguousarray(array))
    return t.permute(2, 0, 1)[None] if t.ndim == 3 else t[None, None]


def compare(scene, params, seed=None):
    """Max abs difference of the image and each map (torch - C++)."""
    ref = turbid.render(scene, params, seed=seed, maps=MAPS)
    rho, depth, K, normals = tensors(scene)
    image, maps = tt.render(rho, depth, K, params, seed=seed, normals=normals, maps=MAPS)
    assert image.dtype == torch.float32 and image.shape == rho.shape
    out = {"image": float((image - chw(ref.image)).abs().max())}
    for name in MAPS:
        out[name] = float((maps[name] - chw(ref.maps[name])).abs().max())
    return out, ref


WATERS = {
    "default": {},
    "backscatter": {"water": {"backscatter": True, "beta_rgb_per_m": [0.9, 0.35, 0.2],
                              "ambient_rgb": [0.1, 0.2, 0.3]}},
    "jerlov": {"water": {"type": "3C"}},
    "two_lights": {"light": {"lights": [
        {"position_in_camera_m": [0.2, 0.25, 0.0], "axis_in_camera": [-0.1, 0.0, 1.0],
         "power": 5.0, "half_power_angle_deg": 45.0, "color_rgb": [1.0, 0.8, 0.6]},
        {"position_in_camera_m": [-0.3, -0.1, 0.05], "power": 3.0, "half_power_angle_deg": 30.0}]}},
    "eq5": {"light": {"incidence": "paper_eq5", "min_cos_incidence": 0.1}},
    "no_light": {"light": {"lights": []}, "water": {"backscatter": True}},
    "clear": {"water": {"beta_rgb_per_m": [0.0, 0.0, 0.0]}},
}


@pytest.mark.parametrize("name", ["hull", "seafloor", "room"])
@pytest.mark.parametrize("water", sorted(WATERS))
def test_paper_model_equals_cpp_on_builtin_scenes(name, water):
    scene = turbid.Scene.builtin(name, 0.2)
    params = merged(OFF, WATERS[water])
    diff, ref = compare(scene, params)
    assert max(diff.values()) <= TOL, diff
    # Not vacuous: the water changes the image.
    assert np.abs(ref.image - np.clip(scene.image, 0, 1)).max() > 0.05


def array_scene(gray=False):
    """A scene from arrays with a hole in the depth (open water) and a depth edge; normals are
    derived from depth on both sides."""
    h, w = 36, 48
    y, x = np.mgrid[0:h, 0:w].astype(np.float32)
    depth = (1.5 + 0.02 * x + 0.01 * y).astype(np.float32)
    depth[10:20, 30:40] = 0.9  # a box in front: depth edges
    depth[:6, :10] = np.nan  # no surface
    depth[30:, 40:] = 0.0  # the TUM convention for unknown
    rng = np.random.default_rng(5)
    image = rng.uniform(0.05, 0.95, (h, w) if gray else (h, w, 3)).astype(np.float32)
    scene = turbid.Scene.from_arrays(image, depth, 40.0, 41.0, 23.5, 17.5)
    return scene, image, depth


@pytest.mark.parametrize("gray", [False, True])
@pytest.mark.parametrize("water", ["default", "backscatter", "two_lights", "eq5"])
def test_paper_model_equals_cpp_with_open_water_and_derived_normals(gray, water):
    scene, image, depth = array_scene(gray)
    assert own_normals(scene) is None
    params = merged(OFF, WATERS[water])
    ref = turbid.render(scene, params, maps=MAPS)
    rho = chw(image)
    d = torch.from_numpy(depth)[None, None]  # 0 and NaN: no surface, as from_arrays reads them
    K = torch.tensor([[40.0, 0, 23.5], [0, 41.0, 17.5], [0, 0, 1]])
    out, maps = tt.render(rho, d, K, params, maps=MAPS)
    assert float((out - chw(ref.image)).abs().max()) <= TOL
    for name in MAPS:
        assert float((maps[name] - chw(ref.maps[name])).abs().max()) <= TOL, name
    # The derived normals are those of the C++ estimator: compare with the scene's light map at
    # a tilted part, which depends on them (cos psi).
    assert float(maps["light"].abs().max()) > 0.1 or water == "no_light"


def test_normals_from_depth_match_the_renderer():
    """The Lambertian term with derived normals equals the C++ one only if the normals do; check
    them directly against the light map of a single head-on light: E = U0 cos psi / l^2 with
    cos psi = -n . v / l."""
    scene, image, depth = array_scene()
    K = torch.tensor([[40.0, 0, 23.5], [0, 41.0, 17.5], [0, 0, 1]])
    n = tt.normals_from_depth(torch.from_numpy(depth)[None, None], K)
    valid = np.isfinite(depth) & (depth > 0)
    assert torch.isfinite(n).all(dim=1)[0].numpy()[valid].mean() > 0.9
    length = torch.linalg.vector_norm(n, dim=1)[0].numpy()
    ok = np.isfinite(length)
    assert np.abs(length[ok] - 1).max() < 1e-6
    # The slope of the plane z = 1.5 + 0.02 x + 0.01 y: n ~ (-0.02 * 40 / z, -0.01 * 41 / z, ...).
    centre = n[0, :, 28, 12].numpy()
    z = depth[28, 12]
    X = np.array([(12 - 23.5) / 40 * z, (28 - 17.5) / 41 * z, z])
    dz = np.array([0.02, 0.01])
    tx = np.array([(13 - 23.5) / 40 * (z + dz[0]), (28 - 17.5) / 41 * (z + dz[0]), z + dz[0]]) - X
    ty = np.array([(12 - 23.5) / 40 * (z + dz[1]), (29 - 17.5) / 41 * (z + dz[1]), z + dz[1]]) - X
    want = np.cross(tx, ty)
    want /= np.linalg.norm(want)
    want = -want if want @ X > 0 else want
    assert np.abs(centre - want).max() < 1e-5


def test_real_icl_frame(tmp_path):
    root = os.environ.get("TURBID_DATA")
    base = os.path.join(root or "", "icl_nuim_lr_kt1")
    if not root or not os.path.isdir(base):
        pytest.skip("TURBID_DATA with icl_nuim_lr_kt1 is not available")
    spec = tmp_path / "icl.json"
    spec.write_text(json.dumps({"type": "rgbd", "image": os.path.join(base, "rgb/0.png"),
                                "depth": os.path.join(base, "depth/0.png")}))
    scene = turbid.Scene.load(str(spec))
    rho, depth, K, normals = tensors(scene)
    # The scene file's normals are NormalsFromDepth's: turbid.torch derives the same.
    derived = tt.normals_from_depth(depth, K)
    assert torch.equal(torch.isnan(derived), torch.isnan(normals))
    ok = ~torch.isnan(normals)
    assert ok.float().mean() > 0.9
    assert float((derived[ok] - normals[ok]).abs().max()) <= 1e-6
    for water in ("default", "backscatter", "two_lights"):
        ref = turbid.render(scene, merged(OFF, WATERS[water]), maps=MAPS)
        image, maps = tt.render(rho, depth, K, merged(OFF, WATERS[water]), maps=MAPS)
        assert float((image - chw(ref.image)).abs().max()) <= TOL, water
        for name in MAPS:
            assert float((maps[name] - chw(ref.maps[name])).abs().max()) <= TOL, (water, name)


REVISED = {
    "constant": {"model": "revised", "water": {"beta_rgb_per_m": [0.5, 0.3, 0.2],
                                               "backscatter_rgb": [0.05, 0.15, 0.2]},
                 "revised": {"beta_b_rgb_per_m": [0.9, 0.6, 0.4]}},
    "sea_thru": {"model": "revised", "revised": {
        "range_dependent": True, "a_rgb": [0.9, 0.5, 0.3], "b_rgb": [-0.3, -0.1, -0.05],
        "c_rgb": [0.2, 0.1, 0.05], "d_rgb": [-2.0, -1.0, -0.5],
        "beta_b_rgb_per_m": [0.8, 0.5, 0.3]}},
    "jerlov_no_light": {"model": "revised", "water": {"type": "II"}, "light": {"lights": []}},
}


@pytest.mark.parametrize("name", ["hull", "room"])
@pytest.mark.parametrize("water", sorted(REVISED))
def test_revised_model_equals_cpp(name, water):
    scene = turbid.Scene.builtin(name, 0.2)
    diff, _ = compare(scene, merged(OFF, REVISED[water]))
    assert max(diff.values()) <= TOL, diff


def test_revised_gray_with_open_water():
    scene, image, depth = array_scene(gray=True)
    params = merged(OFF, REVISED["sea_thru"])
    ref = turbid.render(scene, params)
    K = torch.tensor([[40.0, 0, 23.5], [0, 41.0, 17.5], [0, 0, 1]])
    out = tt.render(chw(image), torch.from_numpy(depth)[None, None], K, params)
    assert float((out - chw(ref.image)).abs().max()) <= TOL


def test_batch_with_per_image_parameters():
    """Each image of a batch with its own beta, B_inf, ambient, lamp power and position equals
    its own C++ render; channels-last layout too."""
    scene = turbid.Scene.builtin("seafloor", 0.15)
    rho, depth, K, normals = tensors(scene)
    n = 3
    beta = torch.tensor([[0.7, 0.7, 0.7], [1.2, 0.4, 0.1], [0.2, 0.3, 0.9]])
    bs = torch.tensor([[0.05, 0.2, 0.25], [0.1, 0.1, 0.1], [0.0, 0.3, 0.4]])
    power = torch.tensor([8.0, 2.0, 15.0])
    position = torch.tensor([[0.0, 0.25, 0.0], [0.3, -0.2, 0.1], [-0.1, 0.0, -0.2]])
    params = merged(OFF, {"water": {"beta_rgb_per_m": beta, "backscatter": True,
                                    "backscatter_rgb": bs, "ambient_rgb": [0.1, 0.12, 0.2]},
                          "light": {"lights": [{"power": power,
                                                "position_in_camera_m": position}]}})
    albedo = rho.expand(n, -1, -1, -1).permute(0, 2, 3, 1)
    out = tt.render(albedo, depth.expand(n, -1, -1, -1), K.expand(n, 3, 3), params,
                    normals=normals.permute(0, 2, 3, 1), channel_axis=-1)
    assert out.shape == albedo.shape
    for i in range(n):
        one = merged(OFF, {"water": {"beta_rgb_per_m": beta[i].tolist(), "backscatter": True,
                                     "backscatter_rgb": bs[i].tolist(),
                                     "ambient_rgb": [0.1, 0.12, 0.2]},
                           "light": {"lights": [{"power": float(power[i]),
                                                 "position_in_camera_m": position[i].tolist()}]}})
        ref = turbid.render(scene, one).image
        assert float((out[i] - torch.from_numpy(ref)).abs().max()) <= TOL, i
    # The images differ: the per-image values were used.
    assert float((out[0] - out[1]).abs().max()) > 0.05


def small_scene(h=5, w=6):
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    depth = torch.from_numpy(1.2 + 0.1 * x + 0.05 * y)[None, None]
    rho = torch.from_numpy(np.random.default_rng(1).uniform(0.1, 0.9, (1, 3, h, w)))
    K = torch.tensor([[6.0, 0, 2.5], [0, 6.0, 2.0], [0, 0, 1]], dtype=torch.float64)
    return rho, depth, K


def test_gradcheck_paper_model():
    """Gradients of beta per channel, B_inf, ambient, lamp power and position (float64)."""
    rho, depth, K = small_scene()
    normals = tt.normals_from_depth(depth, K)

    def f(beta, bs, ambient, power, position):
        params = {"psf": {"enabled": False}, "snow": {"enabled": False},
                  "sensor": {"enabled": False},
                  "water": {"beta_rgb_per_m": beta, "backscatter": True, "backscatter_rgb": bs,
                            "ambient_rgb": ambient},
                  "light": {"lights": [{"power": power, "position_in_camera_m": position,
                                        "half_power_angle_deg": 50.0}]}}
        return tt.render(rho, depth, K, params, normals=normals)

    args = (torch.tensor([0.7, 0.4, 0.2], dtype=torch.float64, requires_grad=True),
            torch.tensor([0.05, 0.2, 0.25], dtype=torch.float64, requires_grad=True),
            torch.tensor([0.15, 0.1, 0.2], dtype=torch.float64, requires_grad=True),
            torch.tensor([8.0], dtype=torch.float64, requires_grad=True),
            torch.tensor([0.05, 0.25, 0.02], dtype=torch.float64, requires_grad=True))
    assert torch.autograd.gradcheck(f, args, eps=1e-6, atol=1e-6)


def test_gradcheck_revised_model():
    rho, depth, K = small_scene()

    def f(beta_d, beta_b, bs, a, b):
        params = {"model": "revised", "psf": {"enabled": False}, "snow": {"enabled": False},
                  "sensor": {"enabled": False},
                  "water": {"beta_rgb_per_m": beta_d, "backscatter_rgb": bs},
                  "revised": {"beta_b_rgb_per_m": beta_b, "range_dependent": True,
                              "a_rgb": a, "b_rgb": b}}
        return tt.render(rho, depth, K, params)

    args = tuple(torch.tensor(v, dtype=torch.float64, requires_grad=True) for v in (
        [0.5, 0.3, 0.2], [0.9, 0.6, 0.4], [0.05, 0.15, 0.2], [0.6, 0.5, 0.4], [-0.2, -0.1, -0.3]))
    assert torch.autograd.gradcheck(f, args, eps=1e-6, atol=1e-6)


def test_gradients_are_finite_with_open_water():
    """NaN depth must not leak NaN into the gradients (t = 0 there, by a mask)."""
    scene, image, depth = array_scene()
    K = torch.tensor([[40.0, 0, 23.5], [0, 41.0, 17.5], [0, 0, 1]])
    beta = torch.tensor([0.7, 0.5, 0.3], requires_grad=True)
    power = torch.tensor(6.0, requires_grad=True)
    params = merged(OFF, {"water": {"beta_rgb_per_m": beta, "backscatter": True},
                          "light": {"lights": [{"power": power}]}})
    out = tt.render(chw(image), torch.from_numpy(depth)[None, None], K, params)
    out.sum().backward()
    assert torch.isfinite(beta.grad).all() and torch.isfinite(power.grad)
    assert float(beta.grad.abs().min()) > 0


def test_errors_name_the_problem():
    rho, depth, K = small_scene()
    with pytest.raises(ValueError, match="forward_scater"):
        tt.render(rho, depth, K, {"psf": {"forward_scater": 0.5}})
    with pytest.raises(ValueError, match="uwcnn"):
        tt.render(rho, depth, K, merged(OFF, {"model": "uwcnn"}))
    with pytest.raises(ValueError, match="leading dimension"):
        tt.render(rho, depth, K, merged(OFF, {"water": {"beta_rgb_per_m": torch.ones(2, 3)}}))
    # Options the C++ renderer has and the differentiable model does not: refused by name.
    for extra, name in [({"psf": {"model": "small_angle"}}, "small_angle"),
                        ({"snow": {"mode": "world"}}, "snow.mode")]:
        with pytest.raises(ValueError, match=name):
            tt.render(rho, depth, K, merged(OFF, extra))


def test_package_imports_without_torch():
    """import turbid does not import torch (turbid.torch only when asked)."""
    code = "import sys, turbid; turbid.render; assert 'torch' not in sys.modules, 'torch imported'"
    subprocess.run([sys.executable, "-c", code], check=True)
