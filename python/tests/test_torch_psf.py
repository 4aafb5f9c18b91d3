"""turbid.torch's PSF (paper eq. 7, Metari & Deschenes' generalized Gaussian) against the C++
renderer: the Gaussian (separable) default, 2-D kernels, kernels wider than the image (mirrored
borders reflected again), per-image T and q in a batch; gradcheck for T and q (float64)."""

import numpy as np
import pytest

import turbid

import test_torch_model as base  # noqa: E402

torch = tt = None  # imported by the fixture (not at collection; see test_torch_model.py)


@pytest.fixture(autouse=True, scope="module")
def _torch():
    global torch, tt
    torch, tt = base.load()

from test_torch_model import OFF, TOL, chw, merged, tensors  # noqa: E402

ON = merged(OFF, {"psf": {"enabled": True}})
PSFS = {
    "paper": {},  # T = 4, q = 0.9: the separable Gaussian, R = 3
    "thin": {"optical_thickness": 1.5, "forward_scatter": 0.4},  # p < 2: heavy tail, 2-D
    "thick": {"optical_thickness": 9.0, "forward_scatter": 0.2},  # p = 3, 2-D
    "wide": {"optical_thickness": 4.0, "forward_scatter": 0.05, "pixels_per_unit": 3.0},
    "delta": {"forward_scatter": 1.0, "pixels_per_unit": 0.2},  # skipped: a delta
}


@pytest.mark.parametrize("name", sorted(PSFS))
@pytest.mark.parametrize("scene_name", ["hull", "room"])
def test_psf_equals_cpp(name, scene_name):
    scene = turbid.Scene.builtin(scene_name, 0.15)
    params = merged(ON, {"psf": PSFS[name], "water": {"backscatter": True}})
    ref = turbid.render(scene, params)
    rho, depth, K, normals = tensors(scene)
    out = tt.render(rho, depth, K, params, normals=normals)
    assert float((out - chw(ref.image)).abs().max()) <= TOL
    # Not vacuous: the blur changes the image (but for the delta).
    flat = turbid.render(scene, merged(params, {"psf": {"enabled": False}})).image
    moved = np.abs(ref.image - flat).max()
    assert (moved == 0.0) if name == "delta" else (moved > 1e-3)


def test_kernel_wider_than_the_image():
    """A 7 x 5 image under a kernel of radius > 7: rows and columns are mirrored again and again,
    as cv::borderInterpolate does."""
    rng = np.random.default_rng(3)
    image = rng.uniform(0.1, 0.9, (5, 7, 3)).astype(np.float32)
    depth = np.full((5, 7), 1.5, np.float32)
    scene = turbid.Scene.from_arrays(image, depth, 10.0, 10.0, 3.0, 2.0)
    params = merged(ON, {"psf": {"forward_scatter": 0.01, "optical_thickness": 2.0},
                          "light": {"lights": []}, "water": {"beta_rgb_per_m": [0.0, 0.0, 0.0]}})
    ref = turbid.render(scene, params)
    assert ref.sidecar["derived"]["psf"]["radius_px"] > 7
    K = torch.tensor([[10.0, 0, 3.0], [0, 10.0, 2.0], [0, 0, 1]])
    out = tt.render(chw(image), torch.from_numpy(depth)[None, None], K, params)
    assert float((out - chw(ref.image)).abs().max()) <= TOL


def test_kernel_matches_the_sidecar():
    """The radius and shape the renderer reports (p, sigma, A, R) are the kernel's."""
    for psf in PSFS.values():
        params = merged(ON, {"psf": psf})
        P = tt.resolve(params)
        kernel = tt.psf_kernel(P, torch.zeros(1), 1)
        derived = turbid.render(turbid.Scene.builtin("room", 0.05), params).sidecar["derived"]
        if derived["psf"]["is_delta"]:
            assert kernel is None and psf is PSFS["delta"]
            continue
        k, separable = kernel
        assert separable == derived["psf"]["separable"]
        assert (k.shape[-1] - 1) // 2 == derived["psf"]["radius_px"]
        assert abs(float(k.sum()) - 1.0) < 1e-12


def test_per_image_psf_parameters_in_a_batch():
    scene = turbid.Scene.builtin("seafloor", 0.15)
    rho, depth, K, normals = tensors(scene)
    T = torch.tensor([4.0, 1.5, 9.0])
    q = torch.tensor([0.9, 0.4, 0.2])
    params = merged(ON, {"psf": {"optical_thickness": T, "forward_scatter": q}})
    out = tt.render(rho.expand(3, -1, -1, -1), depth.expand(3, -1, -1, -1), K, params,
                    normals=normals.expand(3, -1, -1, -1))
    for i in range(3):
        one = merged(ON, {"psf": {"optical_thickness": float(T[i]),
                                   "forward_scatter": float(q[i])}})
        ref = turbid.render(scene, one).image
        assert float((out[i] - chw(ref)[0]).abs().max()) <= TOL, i


def test_gradcheck_psf_parameters():
    """d/dT and d/dq through the kernel (lgamma, the profile, the normalisation), with the
    radius held (it is a discrete choice)."""
    h, w = 7, 8
    rng = np.random.default_rng(4)
    rho = torch.from_numpy(rng.uniform(0.1, 0.9, (1, 3, h, w)))
    depth = torch.full((1, 1, h, w), 1.5, dtype=torch.float64)
    K = torch.tensor([[8.0, 0, 3.5], [0, 8.0, 3.0], [0, 0, 1]], dtype=torch.float64)

    def f(T, q):
        params = {"snow": {"enabled": False}, "sensor": {"enabled": False},
                  "psf": {"optical_thickness": T, "forward_scatter": q}}
        return tt.render(rho, depth, K, params)

    for T0, q0 in ((3.0, 0.5), (4.0, 0.9), (1.2, 0.3)):
        T = torch.tensor(T0, dtype=torch.float64, requires_grad=True)
        q = torch.tensor(q0, dtype=torch.float64, requires_grad=True)
        assert torch.autograd.gradcheck(f, (T, q), eps=1e-6, atol=1e-6)
        g = torch.autograd.grad(f(T, q).pow(2).sum(), (T, q))  # not vacuous: non-zero
        assert all(float(x.abs()) > 1e-6 for x in g), g


TURBIDITY = merged(ON, {"psf": {"turbidity_dependent": True}})


@pytest.mark.parametrize("scene_name", ["hull", "seafloor", "room"])
@pytest.mark.parametrize("water", [{}, {"water": {"type": "9C"}, "psf": {"forward_scatter": 0.3}},
                                   {"model": "revised", "revised": {
                                       "range_dependent": True, "a_rgb": [1.5, 1.0, 0.5],
                                       "b_rgb": [-0.2, -0.1, -0.1]}}])
def test_turbidity_dependent_psf_equals_cpp(scene_name, water):
    """Levels evenly spaced in sqrt(T) (the interpolated case), paper and Sea-thru thickness."""
    scene = turbid.Scene.builtin(scene_name, 0.15)
    params = merged(TURBIDITY, water)
    ref = turbid.render(scene, params)
    assert ref.sidecar["derived"]["psf"]["turbidity"]["exact"] is False
    rho, depth, K, normals = tensors(scene)
    out = tt.render(rho, depth, K, params, normals=normals)
    assert float((out - chw(ref.image)).abs().max()) <= TOL
    flat = turbid.render(scene, merged(params, {"psf": {"enabled": False}})).image
    assert np.abs(ref.image - flat).max() > 5e-3


def test_turbidity_dependent_psf_exact_levels_and_open_water():
    """Few distinct T (exact levels) and NaN depth (open water takes the largest T)."""
    rng = np.random.default_rng(8)
    image = rng.uniform(0.1, 0.9, (5, 6)).astype(np.float32)
    depth = np.full((5, 6), 2.0, np.float32)
    depth[0, :2] = np.nan
    scene = turbid.Scene.from_arrays(image, depth, 6.0, 6.0, 2.5, 2.0)
    K = torch.tensor([[6.0, 0, 2.5], [0, 6.0, 2.0], [0, 0, 1]])
    for water in ({}, {"water": {"type": "9C", "backscatter": True}}):
        params = merged(TURBIDITY, water)
        ref = turbid.render(scene, params)
        assert ref.sidecar["derived"]["psf"]["turbidity"]["exact"] is True
        out = tt.render(chw(image), torch.from_numpy(depth)[None, None], K, params)
        assert float((out - chw(ref.image)).abs().max()) <= TOL


@pytest.mark.parametrize("shape", [(4, 5), (7, 8)])  # exact levels, interpolated levels
def test_gradcheck_turbidity_dependent_psf(shape):
    """d/dbeta through e^{-T}, the levels' kernels and the interpolation weight; d/dq through
    the kernels' width (float64)."""
    h, w = shape
    rng = np.random.default_rng(5)
    rho = torch.from_numpy(rng.uniform(0.1, 0.9, (1, 1, h, w)))
    y, x = np.mgrid[0:h, 0:w]
    depth = torch.from_numpy(1.0 + 0.3 * x + 0.2 * y)[None, None]
    K = torch.tensor([[6.0, 0, 2.0], [0, 6.0, 1.5], [0, 0, 1]], dtype=torch.float64)

    def f(beta, q):
        params = {"snow": {"enabled": False}, "sensor": {"enabled": False},
                  "light": {"lights": []}, "water": {"beta_gray_per_m": beta},
                  "psf": {"turbidity_dependent": True, "forward_scatter": q,
                          "thickness_levels": 32 if h == 4 else 6}}
        return tt.render(rho, depth, K, params)

    args = (torch.tensor(0.8, dtype=torch.float64, requires_grad=True),
            torch.tensor(0.3, dtype=torch.float64, requires_grad=True))
    assert torch.autograd.gradcheck(f, args, eps=1e-6, atol=1e-6)
