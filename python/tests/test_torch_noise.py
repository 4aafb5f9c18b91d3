"""turbid.torch's sensor noise (Poisson-Gaussian by reparameterisation: the renderer's own normals
for the same seed, times the differentiable scale) and the camera's encoding, against the C++
renderer; gradcheck for the noise scale (photons_at_white, read_noise)."""

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

NOISE = merged(OFF, {"sensor": {"enabled": True, "photons_at_white": 500.0, "read_noise": 0.01}})


@pytest.mark.parametrize("name", ["hull", "room"])
def test_noise_equals_cpp_for_the_same_seed(name):
    scene = turbid.Scene.builtin(name, 0.15)
    rho, depth, K, normals = tensors(scene)
    for seed in (0, 7, 2**40 + 3):
        ref = turbid.render(scene, NOISE, seed=seed)
        out = tt.render(rho, depth, K, NOISE, seed=seed, normals=normals)
        assert float((out - chw(ref.image)).abs().max()) <= TOL, seed
    clean = turbid.render(scene, merged(NOISE, {"sensor": {"enabled": False}})).image
    assert np.abs(ref.image - clean).std() > 0.005  # not vacuous


def test_gray_noise_and_params_seed():
    """Gray images (one channel) and the seed taken from params["seed"]."""
    rng = np.random.default_rng(9)
    image = rng.uniform(0.1, 0.9, (9, 11)).astype(np.float32)
    depth = np.full((9, 11), 2.0, np.float32)
    scene = turbid.Scene.from_arrays(image, depth, 12.0, 12.0, 5.0, 4.0)
    params = merged(NOISE, {"seed": 12345})
    ref = turbid.render(scene, params)
    K = torch.tensor([[12.0, 0, 5.0], [0, 12.0, 4.0], [0, 0, 1]])
    out = tt.render(chw(image), torch.from_numpy(depth)[None, None], K, params)
    assert float((out - chw(ref.image)).abs().max()) <= TOL


def test_standard_normals_are_standard():
    z = tt.standard_normals(3, 200001)
    assert z.shape == (200001,) and z.dtype == np.float32
    assert abs(z.mean()) < 0.01 and abs(z.std() - 1) < 0.01
    assert np.array_equal(z[:1001], tt.standard_normals(3, 1001))  # a prefix of the stream


def test_batch_seeds():
    """An integer seed s gives image i the seed s + i; a list gives one per image."""
    scene = turbid.Scene.builtin("seafloor", 0.1)
    rho, depth, K, normals = tensors(scene)
    n = 3
    batch = (rho.expand(n, -1, -1, -1), depth.expand(n, -1, -1, -1), K)
    out = tt.render(*batch, NOISE, seed=10, normals=normals.expand(n, -1, -1, -1))
    listed = tt.render(*batch, NOISE, seed=[10, 11, 12], normals=normals.expand(n, -1, -1, -1))
    assert torch.equal(out, listed)
    for i in range(n):
        ref = turbid.render(scene, NOISE, seed=10 + i).image
        assert float((out[i] - chw(ref)[0]).abs().max()) <= TOL
    assert float((out[0] - out[1]).abs().max()) > 0.01


def test_gradcheck_noise_scale():
    h, w = 5, 6
    rng = np.random.default_rng(2)
    rho = torch.from_numpy(rng.uniform(0.1, 0.9, (1, 3, h, w)))
    depth = torch.full((1, 1, h, w), 1.5, dtype=torch.float64)
    K = torch.tensor([[6.0, 0, 2.5], [0, 6.0, 2.0], [0, 0, 1]], dtype=torch.float64)

    def f(photons, read, beta):
        params = merged(OFF, {"sensor": {"enabled": True, "photons_at_white": photons,
                                         "read_noise": read}, "water": {"beta_rgb_per_m": beta}})
        params.pop("camera")
        return tt.render(rho, depth, K, params, seed=4)

    args = (torch.tensor(300.0, dtype=torch.float64, requires_grad=True),
            torch.tensor(0.02, dtype=torch.float64, requires_grad=True),
            torch.tensor([0.7, 0.5, 0.3], dtype=torch.float64, requires_grad=True))
    assert torch.autograd.gradcheck(f, args, eps=1e-6, atol=1e-6)
    g = torch.autograd.grad(f(*args).pow(2).sum(), args[:2])
    assert all(float(x.abs()) > 0 for x in g)


@pytest.mark.parametrize("camera", [{"bit_depth": 8, "encoding": "srgb"},
                                    {"bit_depth": 16, "encoding": "srgb"},
                                    {"bit_depth": 8, "encoding": "linear"},
                                    {"bit_depth": 16, "encoding": "linear"}])
def test_camera_encoding_equals_cpp(camera):
    scene = turbid.Scene.builtin("hull", 0.15)
    rho, depth, K, normals = tensors(scene)
    params = merged(NOISE, {"camera": camera, "water": {"backscatter": True}})
    ref = chw(turbid.render(scene, params, seed=1).image)
    out = tt.render(rho, depth, K, params, seed=1, normals=normals)
    # The same codes but where a value lies within float rounding of a decision threshold.
    levels = 255.0 if camera["bit_depth"] == 8 else 65535.0
    differ = (out != ref)
    assert differ.float().mean() <= 1e-3
    if differ.any():
        enc = (lambda v: turbid.srgb_encode(v.numpy())) if camera["encoding"] == "srgb" \
            else (lambda v: v.numpy())
        steps = np.abs(enc(out[differ]) - enc(ref[differ])) * levels
        assert steps.max() <= 1.01  # one code (float32 encoding error at 16 bits: 0.004)
    assert len(torch.unique(out)) <= levels + 1


def test_camera_passes_gradients_straight_through():
    leaf = torch.tensor([[-0.2, 0.3], [0.5, 1.4]], requires_grad=True)
    P = tt.resolve({"camera": {"bit_depth": 8}})
    y = tt.camera(leaf.reshape(1, 1, 2, 2), P)
    y.sum().backward()
    # Inside [0, 1] the quantiser is the identity for gradients; the clip stops them outside.
    assert leaf.grad.flatten().tolist() == [0.0, 1.0, 1.0, 0.0]
    assert float(y.flatten()[1]) == pytest.approx(0.3, abs=0.005) and float(y.flatten()[1]) != 0.3
