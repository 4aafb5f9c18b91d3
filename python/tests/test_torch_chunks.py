"""turbid.torch.render in chunks of images (``chunk_images``): the same image, maps and gradients
as one pass over the batch, with every per-image input (parameters with a leading N, K, seeds,
normals, snow draws, noise streams) sliced rather than redrawn."""

import numpy as np
import pytest

import turbid

import test_torch_model as base  # noqa: E402

torch = tt = None  # imported by the fixture (not at collection; see test_torch_model.py)


@pytest.fixture(autouse=True, scope="module")
def _torch():
    global torch, tt
    torch, tt = base.load()


def batch(n, gray=False, holes=False, scale=0.1):
    """n crops of the seafloor scene (shifted per image so no two are alike), its normals, and
    per-image intrinsics (N x 3 x 3, fx varying)."""
    scene = turbid.Scene.builtin("seafloor", scale)
    rho, depth, K, normals = base.tensors(scene)
    rho = torch.cat([torch.roll(rho, i, dims=-1) for i in range(n)])
    depth = torch.cat([torch.roll(depth, i, dims=-1) * (1 + 0.05 * i) for i in range(n)])
    normals = normals.expand(n, -1, -1, -1)
    if gray:
        rho = rho.mean(dim=1, keepdim=True)
    if holes:  # open water in some images only (the batch-wide "all valid" branches)
        depth[1, 0, :3, :5] = float("nan")
        depth[n - 1, 0, -2:, -4:] = float("nan")
    Ks = K.expand(n, 3, 3).clone()
    Ks[:, 0, 0] *= torch.linspace(0.9, 1.1, n, dtype=Ks.dtype)
    return rho, depth, Ks, normals


def leaves(n, c=3):
    g = torch.Generator().manual_seed(5)
    return {
        "beta": (0.3 + torch.rand(n, c, generator=g)).requires_grad_(),      # per image
        "binf": (0.3 * torch.rand(c, generator=g)).requires_grad_(),         # shared
        "ambient": (0.1 + 0.1 * torch.rand(n, c, generator=g)).requires_grad_(),
        "power": (4.0 + 4.0 * torch.rand(n, generator=g)).requires_grad_(),
        "position": (torch.tensor([0.0, 0.25, 0.0]) + 0.1 * torch.rand(n, 3, generator=g))
        .requires_grad_(),
        "q": (0.8 + 0.1 * torch.rand(n, generator=g)).requires_grad_(),       # per image PSF
        "photons": torch.tensor(300.0, requires_grad=True),                  # shared noise scale
    }


def params_of(v, c=3, extra=None):
    rgb = c == 3
    p = {"water": {("beta_rgb_per_m" if rgb else "beta_gray_per_m"): v["beta"],
                   "backscatter": True,
                   ("backscatter_rgb" if rgb else "backscatter_gray"): v["binf"],
                   ("ambient_rgb" if rgb else "ambient_gray"): v["ambient"]},
         "light": {"lights": [{"power": v["power"], "position_in_camera_m": v["position"]}]},
         "psf": {"optical_thickness": 2.0, "forward_scatter": v["q"]},
         "snow": {"enabled": True, "density_per_m3": 400.0},
         "sensor": {"enabled": True, "photons_at_white": v["photons"], "read_noise": 0.01}}
    return base.merged(p, extra or {})


def run(rho, depth, K, normals, v, chunk, c=3, maps=None, **kw):
    """Image (and maps) and each leaf's gradient of a fixed random loss, chunk_images=chunk."""
    for leaf in v.values():
        leaf.grad = None
    extra = kw.pop("extra", {})
    out = tt.render(rho, depth, K, params_of(v, c, extra), seed=[3 + 7 * i for i in
                                                                     range(rho.shape[0])],
                    normals=normals, maps=maps, chunk_images=chunk, **kw)
    image, m = out if maps is not None else (out, {})
    weights = torch.rand(image.shape, generator=torch.Generator().manual_seed(1))
    (image * weights).sum().backward()
    grads = {k: None if leaf.grad is None else leaf.grad.clone() for k, leaf in v.items()}
    return image.detach(), {k: t.detach() for k, t in m.items()}, grads


# Gradients of per-image leaves are each image's own reductions: the same bits in chunks. A
# shared leaf's gradient sums every image's share: in chunks autograd adds the chunks' partial
# sums, another summation order (float rounding, nothing else).
PER_IMAGE = ("beta", "ambient", "power", "position", "q")
SHARED = ("binf", "photons")


def assert_same(one, chunked, unused=(), shared_rtol=1e-5):
    image, maps, grads = one
    image_c, maps_c, grads_c = chunked
    assert torch.equal(image, image_c)
    assert maps.keys() == maps_c.keys()
    for k in maps:
        assert torch.equal(maps[k], maps_c[k]), k
    for k in PER_IMAGE:
        if k in unused:
            assert grads[k] is None and grads_c[k] is None
            continue
        assert grads[k] is not None and float(grads[k].abs().max()) > 0, k
        assert torch.equal(grads[k], grads_c[k]), k
    for k in SHARED:
        if k in unused:
            assert grads[k] is None and grads_c[k] is None
            continue
        assert grads[k] is not None and float(grads[k].abs().max()) > 0, k
        torch.testing.assert_close(grads_c[k], grads[k], rtol=shared_rtol, atol=0)


@pytest.mark.parametrize("noise", ["turbid", "torch"])
def test_chunks_equal_one_pass_with_noise_snow_and_per_image_values(noise):
    n = 7
    rho, depth, K, normals = batch(n)
    v = leaves(n)
    one = run(rho, depth, K, normals, v, 0, maps=["transmission", "light", "veil"], noise=noise)
    for chunk in (1, 3, 6):
        assert_same(one, run(rho, depth, K, normals, v, chunk,
                             maps=["transmission", "light", "veil"], noise=noise))
    # Not vacuous: the images differ from each other, the snow and the noise show.
    image = one[0]
    assert float((image[0] - image[1]).abs().max()) > 0.05
    clean = tt.render(rho, depth, K, params_of(v, extra={"snow": {"enabled": False},
                                                         "sensor": {"enabled": False}}),
                      normals=normals, chunk_images=0)
    assert float((image - clean).abs().max()) > 0.05


def test_chunks_equal_one_pass_gray_channels_last_open_water_derived_normals():
    n = 5
    rho, depth, K, _ = batch(n, gray=True, holes=True)
    v = leaves(n, c=1)
    last = rho.permute(0, 2, 3, 1)
    one = run(last, depth, K, None, v, 0, c=1, maps=["transmission", "lit"], channel_axis=-1)
    assert one[0].shape == last.shape
    assert torch.isnan(depth).any()
    assert_same(one, run(last, depth, K, None, v, 2, c=1, maps=["transmission", "lit"],
                         channel_axis=-1))


@pytest.mark.parametrize("extra", [
    {"model": "revised", "revised": {"range_dependent": True}},
    {"veil": "single_scatter"},
    {"psf": {"turbidity_dependent": True}},
    {"ambient": "derived"},
])
def test_chunks_equal_one_pass_in_every_model_branch(extra):
    n = 4
    rho, depth, K, normals = batch(n, holes=True)
    v = leaves(n)
    one = run(rho, depth, K, normals, v, 0, extra=extra)
    unused = ("binf",) if extra.get("ambient") == "derived" else ()  # B_inf = omega E_A H
    assert_same(one, run(rho, depth, K, normals, v, 3, extra=extra), unused)


@pytest.mark.parametrize("thin", [1e-4, 0.5])
def test_psf_kernel_is_the_batchs_in_every_chunk(thin):
    """Per-image T: alone, the chunk of the thin images would get a delta (T = 1e-4) or a 15 x 15
    kernel (T = 0.5, conv2d) and that of the thick ones a 7 x 7 one (sums of taps); the batch's
    kernels (the largest radius) serve every chunk, as in one pass."""
    n = 4
    rho, depth, K, normals = batch(n)
    T = torch.tensor([thin, thin, 3.0, 3.0], dtype=torch.float64)
    p = base.merged(base.OFF, {"psf": {"enabled": True, "optical_thickness": T}})
    assert tt.psf_kernel(tt.resolve(p), rho, n)[0].shape[-1] > 7
    one = tt.render(rho, depth, K, p, normals=normals, chunk_images=0)
    assert torch.equal(one, tt.render(rho, depth, K, p, normals=normals, chunk_images=2))
    assert torch.equal(one, tt.render(rho, depth, K, p, normals=normals, chunk_images=1))


def test_gradcheck_through_chunks():
    rho, depth, K = base.small_scene()
    rho = torch.cat([rho, rho.flip(-1), rho.flip(-2)])
    depth = depth.expand(3, -1, -1, -1)
    normals = tt.normals_from_depth(depth, K)

    def f(beta, bs, power, position):
        params = {"psf": {"enabled": False}, "snow": {"enabled": False},
                  "sensor": {"enabled": False},
                  "water": {"beta_rgb_per_m": beta, "backscatter": True, "backscatter_rgb": bs},
                  "light": {"lights": [{"power": power, "position_in_camera_m": position,
                                        "half_power_angle_deg": 50.0}]}}
        return tt.render(rho, depth, K, params, normals=normals, chunk_images=2)

    f64 = dict(dtype=torch.float64, requires_grad=True)
    args = (torch.tensor([[0.7, 0.4, 0.2], [0.5, 0.5, 0.5], [0.2, 0.3, 0.9]], **f64),
            torch.tensor([0.05, 0.2, 0.25], **f64),
            torch.tensor([8.0, 4.0, 6.0], **f64),
            torch.tensor([0.05, 0.25, 0.02], **f64))
    assert torch.autograd.gradcheck(f, args, eps=1e-6, atol=1e-6)


def test_automatic_chunks_on_a_batch_larger_than_one():
    """CPU, float, 3 x 256 x 256: 10 images a chunk (8 MB a tensor); 12 images take two chunks
    and equal one pass."""
    from turbid.torch import _chunk_size
    rho = torch.zeros(12, 3, 256, 256)
    assert _chunk_size(None, rho) == 10
    assert _chunk_size(None, rho.double()) == 5
    assert _chunk_size(0, rho) == 12 and _chunk_size(4, rho) == 4
    assert _chunk_size(None, torch.zeros(2, 3, 4096, 4096)) == 1
    g = torch.Generator().manual_seed(2)
    rho = torch.rand(12, 3, 256, 256, generator=g)
    depth = 1.0 + torch.rand(12, 1, 256, 256, generator=g)
    K = torch.tensor([[200.0, 0, 127.5], [0, 200.0, 127.5], [0, 0, 1]])
    beta = (0.2 + torch.rand(12, 3, generator=g)).requires_grad_()
    p = {"water": {"beta_rgb_per_m": beta, "backscatter": True}, "light": {"lights": []},
         "snow": {"enabled": False}, "sensor": {"enabled": True}}
    auto = tt.render(rho, depth, K, p, seed=11)
    auto.sum().backward()
    grad, beta.grad = beta.grad.clone(), None
    one = tt.render(rho, depth, K, p, seed=11, chunk_images=0)
    one.sum().backward()
    assert torch.equal(auto, one)
    assert torch.equal(grad, beta.grad)


@pytest.mark.parametrize("bad", [-1, 1.5, True, "4"])
def test_chunk_images_errors(bad):
    rho, depth, K = base.small_scene()
    with pytest.raises(ValueError, match="chunk_images"):
        tt.render(rho, depth, K, base.OFF, chunk_images=bad)
