"""The hand-written backward passes that make turbid.torch fast (python/turbid/_torch_light.py,
the fused composition in torch.py): gradcheck in float64 over every option they branch on, and
their forward equal to the op-by-op formula they replace."""

import importlib
import math

import numpy as np
import pytest

torch = tt = None


@pytest.fixture(autouse=True, scope="module")
def _torch():
    global torch, tt
    torch = pytest.importorskip("torch")
    tt = importlib.import_module("turbid.torch")


def scene(n=2, h=5, w=6, holes=False):
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    depth = torch.from_numpy(1.2 + 0.1 * x + 0.05 * y)[None, None].repeat(n, 1, 1, 1)
    if holes:
        depth[0, 0, 1, 2] = float("nan")
        depth[-1, 0, 3, 4] = float("nan")
    rho = torch.from_numpy(np.random.default_rng(1).uniform(0.1, 0.9, (n, 3, h, w)))
    K = torch.tensor([[6.0, 0, 2.5], [0, 6.0, 2.0], [0, 0, 1]], dtype=torch.float64)
    return rho, depth, K


def reference_lamp(pos, axis, power, beta, color, depth, K, normals, light, incidence, min_cos,
                   min_l):
    """E of one lamp by plain autograd ops (the formula of light.cc, as turbid.torch had it)."""
    n, _, h, w = depth.shape
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    xs = torch.arange(w, dtype=torch.float64)
    ys = torch.arange(h, dtype=torch.float64)
    rx = ((xs - cx) / fx).reshape(1, 1, 1, w)
    ry = ((ys - cy) / fy).reshape(1, 1, h, 1)
    valid = torch.isfinite(depth)
    z = torch.where(valid, depth, torch.ones_like(depth))
    p = [rx * z, ry * z, z]
    pos = pos.reshape(-1, 3, 1, 1)
    axis = axis.reshape(-1, 3, 1, 1)
    axis = axis / torch.linalg.vector_norm(axis, dim=1, keepdim=True)
    v = [p[k] - pos[:, k:k + 1] for k in range(3)]
    l_true = torch.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2)
    cphi = sum(axis[:, k:k + 1] * v[k] for k in range(3)) / l_true
    cpsi = -sum(normals[:, k:k + 1] * v[k] for k in range(3)) / l_true
    l = torch.clamp(l_true, min=min_l)
    if incidence == "paper_eq5":
        inc = torch.where(cpsi > 0, 1.0 / torch.clamp(cpsi, min=min_cos), torch.zeros_like(cpsi))
    else:
        inc = torch.clamp(cpsi, min=0.0)
    order = -math.log(2.0) / math.log(math.cos(light * math.pi / 180.0))
    beam = torch.clamp(cphi, 0.0, 1.0) ** order
    g = power.reshape(-1, 1, 1, 1) * inc / (l * l) * beam
    g = torch.where(valid, g, torch.zeros_like(g))
    l = torch.where(valid, l, torch.zeros_like(l))
    return color.reshape(-1, 3, 1, 1) * g * torch.exp(-beta.reshape(-1, 3, 1, 1) * l)


def tilted_normals(depth):
    """Unit normals facing the camera, tilted differently at every pixel."""
    n, _, h, w = depth.shape
    y, x = torch.meshgrid(torch.arange(h, dtype=torch.float64),
                          torch.arange(w, dtype=torch.float64), indexing="ij")
    v = torch.stack([0.1 * x - 0.3, 0.15 * y - 0.2, -torch.ones_like(x)])[None].repeat(n, 1, 1, 1)
    return v / torch.linalg.vector_norm(v, dim=1, keepdim=True)


CASES = [  # half-power angle, incidence, min_cos, min_distance_m, holes
    (60.0, "lambertian", 0.05, 0.01, False),   # order 1
    (45.0, "lambertian", 0.05, 0.01, True),    # order 2, open water
    (50.0, "paper_eq5", 0.3, 0.01, False),  # order 1.43, the paper's 1 / cos psi
    (35.0, "paper_eq5", 0.05, 1.0, True),   # the distance clamp bites
]


@pytest.mark.parametrize("case", CASES)
def test_lamp_forward_and_gradcheck(case):
    """E_L of the fused lamp equals the op-by-op formula, and its gradients in position, axis,
    power, beta and colour (per image) pass gradcheck."""
    angle, incidence, min_cos, min_l, holes = case
    rho, depth, K = scene(holes=holes)
    normals = tilted_normals(depth)
    args = (torch.tensor([[0.05, 0.25, 0.02], [-0.2, 0.1, 0.3]], dtype=torch.float64),
            torch.tensor([[0.1, -0.05, 1.0], [0.0, 0.2, 0.9]], dtype=torch.float64),
            torch.tensor([8.0, 3.0], dtype=torch.float64),
            torch.tensor([[0.7, 0.4, 0.2], [0.3, 0.5, 0.9]], dtype=torch.float64),
            torch.tensor([[1.0, 0.8, 0.6], [0.9, 1.0, 0.7]], dtype=torch.float64))
    args = tuple(a.requires_grad_() for a in args)
    light = {"half_power_angle_deg": angle}

    def fused(pos, axis, power, beta, color):
        params = {"light": {"incidence": incidence, "min_cos_incidence": min_cos,
                            "min_distance_m": min_l,
                            "lights": [dict(light, position_in_camera_m=pos,
                                            axis_in_camera=axis, power=power,
                                            color_rgb=color)]}}
        P = tt.resolve(params)
        return tt.irradiance(P, depth, K, normals, beta.reshape(-1, 3, 1, 1), 2, 3, rho)

    ref = reference_lamp(*args, depth, K, normals, angle, incidence, min_cos, min_l)
    assert float((fused(*args) - ref).abs().max()) <= 1e-12
    assert torch.autograd.gradcheck(fused, args, eps=1e-6, atol=1e-7)
    # One light shared by the batch (B = 1) sums its gradients over the images.
    shared = tuple(a[:1].detach().clone().requires_grad_() for a in args)
    assert torch.autograd.gradcheck(fused, shared, eps=1e-6, atol=1e-7)


def test_gray_and_two_lights_gradcheck():
    rho, depth, K = scene(n=1)
    gray = rho.mean(dim=1, keepdim=True)
    normals = tilted_normals(depth)

    def f(p0, p1, power, beta):
        params = {"psf": {"enabled": False}, "snow": {"enabled": False},
                  "sensor": {"enabled": False},
                  "water": {"beta_gray_per_m": beta, "backscatter": True},
                  "light": {"lights": [{"position_in_camera_m": p0, "power": power},
                                       {"position_in_camera_m": p1, "power": 4.0,
                                        "half_power_angle_deg": 40.0}]}}
        return tt.render(gray, depth, K, params, normals=normals)

    args = tuple(torch.tensor(v, dtype=torch.float64, requires_grad=True) for v in (
        [0.05, 0.25, 0.02], [-0.3, -0.1, 0.1], [6.0], [0.6]))
    assert torch.autograd.gradcheck(f, args, eps=1e-6, atol=1e-7)


@pytest.mark.parametrize("lights,backscatter", [(True, True), (False, True), (True, False)])
def test_fused_composition_gradcheck(lights, backscatter):
    """The paper model's fused eq. 2 (t_B = t), open water included: gradients in the albedo, beta
    (per image), B_inf and the lamp's power; and its output equals the unfused composition (the
    path taken when maps are asked for)."""
    rho, depth, K = scene(n=2, holes=True)
    normals = tilted_normals(depth)

    def f(albedo, beta, bs, power):
        params = {"psf": {"enabled": False}, "snow": {"enabled": False},
                  "sensor": {"enabled": False},
                  "water": {"beta_rgb_per_m": beta, "backscatter": backscatter,
                            "backscatter_rgb": bs},
                  "light": {"lights": [{"power": power}] if lights else []}}
        return tt.render(albedo, depth, K, params, normals=normals)

    args = (rho.clone(), torch.tensor([[0.7, 0.4, 0.2], [0.3, 0.5, 0.9]], dtype=torch.float64),
            torch.tensor([0.05, 0.2, 0.25], dtype=torch.float64),
            torch.tensor([6.0, 2.0], dtype=torch.float64))
    args = tuple(a.requires_grad_() for a in args)
    assert torch.autograd.gradcheck(f, args, eps=1e-6, atol=1e-7)
    params = {"psf": {"enabled": False}, "snow": {"enabled": False}, "sensor": {"enabled": False},
              "water": {"beta_rgb_per_m": args[1], "backscatter": backscatter,
                        "backscatter_rgb": args[2]},
              "light": {"lights": [{"power": args[3]}] if lights else []}}
    fused = tt.render(rho, depth, K, params, normals=normals)
    plain, _ = tt.render(rho, depth, K, params, normals=normals, maps=["veil"])
    assert float((fused - plain).abs().max()) <= 1e-12


def test_fused_noise_gradcheck():
    """Sensor noise with read noise (the fused path): gradients in the image (negative values
    included: no shot noise there), photons_at_white and read_noise per image."""
    from turbid._torch_noise import sensor_noise
    image = torch.from_numpy(np.random.default_rng(3).uniform(-0.2, 1.0, (2, 3, 4, 5)))
    image.requires_grad_()

    def f(img, photons, read):
        P = tt.resolve({"sensor": {"photons_at_white": photons, "read_noise": read}})
        return sensor_noise(img, P, [1, 2])

    args = (image, torch.tensor([300.0, 80.0], dtype=torch.float64, requires_grad=True),
            torch.tensor([0.01, 0.03], dtype=torch.float64, requires_grad=True))
    assert torch.autograd.gradcheck(f, args, eps=1e-6, atol=1e-7)


def test_cache_host_memory_reuses_freed_blocks():
    """After cache_host_memory(), the freed 64 MB tensors of a training-like loop are reused: once
    the loop has run a few times its steps fault in (almost) no fresh page, where glibc's default
    faults in every page of every temporary again. In a child process: the setting is
    process-wide."""
    import subprocess
    import sys
    code = """
import resource, sys, torch, turbid.torch as tt
if sys.argv[1] == "cached":
    assert tt.cache_host_memory()
def step():  # three 64 MB tensors, two freed at once, one at the end
    a = torch.ones(16 << 20); b = a * 2.0; c = b + a; del a, b; return float(c[0])
for _ in range(3): step()
r0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(3): step()
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - r0)
"""
    out = {mode: int(subprocess.run([sys.executable, "-c", code, mode], check=True,
                                    capture_output=True, text=True).stdout.split()[-1])
           for mode in ("default", "cached")}
    pages = (64 << 20) // 4096
    assert out["default"] > 3 * 3 * pages // 2, out
    assert out["cached"] < pages // 20, out


def test_native_normals_equal_the_transcription():
    """The renderer's RandomNormals (turbid._turbid._standard_normals, what the noise uses) and
    the NumPy transcription of noise.cc give the same bits."""
    import turbid._turbid as native
    from turbid._torch_noise import standard_normals
    for seed, count in ((0, 1), (7, 1001), (2 ** 40 + 3, 4096)):
        assert np.array_equal(native._standard_normals(seed, count), standard_normals(seed, count))
