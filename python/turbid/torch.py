"""turbid.torch: the forward model as differentiable PyTorch operations (docs/python.md,
"Differentiable model").

A transcription of the C++ renderer's equations (simulator/render.cc, light.cc, psf.cc, noise.cc,
water.cc; docs/model.md) in torch operations on batches N x C x H x W, on any device torch
supports. The C++ renderer is the reference (python/tests/test_torch*.py compare the two) and the
fast path for data generation; this module is for learning through the model.

    import turbid.torch as tt
    image = tt.render(albedo, depth, K, {"water": {"beta_rgb_per_m": beta}})

``params`` is the dict :func:`turbid.render` takes; any number (or list of numbers) in it may be a
tensor, with a leading N for one value per image (``beta`` N x 3, a light's ``power`` N, its
``position_in_camera_m`` N x 3). Importing this module needs torch; ``import turbid`` does not.
"""

import json as _json
import math as _math
import numbers as _numbers

import numpy as _np
import torch

import turbid as _turbid
# The PSF (psf.cc) and the noise, camera and snow draw (noise.cc, camera_encoding.cc) live in their
# own files; their public names are this module's.
from ._torch_noise import _seeds, camera, sensor_noise, snow_particles, standard_normals
from ._torch_light import Lamp as _Lamp, Veiled as _Veiled
from ._torch_psf import apply_psf, psf_kernel, turbidity_psf
from ._torch_veil import single_scatter_veil

__all__ = ["render", "resolve", "Params", "range_from_depth", "normals_from_depth", "single_scatter_veil",
           "irradiance", "psf_kernel", "apply_psf", "turbidity_psf", "sensor_noise",
           "standard_normals", "camera", "snow_particles", "snow_layer", "cache_host_memory"]

# ---- parameters ---------------------------------------------------------------------------------


def _is_tensor(value):
    return isinstance(value, torch.Tensor)


def _default_at(defaults, path):
    """The default value at ``path`` (a light index reads the default light)."""
    node = defaults
    for key in path:
        if isinstance(node, list):
            node = node[0] if node else None
        elif isinstance(node, dict):
            node = node.get(key)
        else:
            return None
    return node


def _split(value, defaults, path, tensors):
    """``value`` with every tensor replaced by the numbers of its first batch element (for the C++
    checks and defaults); the tensors go to ``tensors`` keyed by path."""
    if _is_tensor(value) or isinstance(value, _np.ndarray):
        t = torch.as_tensor(value)
        default = _default_at(defaults, path)
        width = len(default) if isinstance(default, list) else 0
        if width:
            if t.numel() % width:
                raise ValueError("params: %s: expected %d values (or N x %d), got shape %s"
                                 % (".".join(map(str, path)), width, width, tuple(t.shape)))
            tensors[path] = t.reshape(-1, width)
            return [float(v) for v in t.detach().reshape(-1, width)[0].cpu()]
        tensors[path] = t.reshape(-1)
        return float(t.detach().reshape(-1)[0].cpu())
    if isinstance(value, dict):
        return {k: _split(v, defaults, path + (k,), tensors) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        if any(_is_tensor(v) for v in value):  # [tensor, tensor, tensor]: one per channel
            stacked = torch.stack([torch.as_tensor(v).reshape(-1) for v in value], dim=-1)
            return _split(stacked, defaults, path, tensors)
        return [_split(v, defaults, path + (i,), tensors) for i, v in enumerate(value)]
    return value


_DEFAULTS = []


def _defaults():
    """Every key's default, the model sections included (for the widths of tensor values)."""
    if not _DEFAULTS:
        d = _turbid.resolve_params({"model": "revised"})
        d["uwcnn"] = _turbid.resolve_params({"model": "uwcnn"})["uwcnn"]
        _DEFAULTS.append(d)
    return _DEFAULTS[0]


class Params:
    """Resolved render parameters: every default filled in and checked by the C++ reader
    (:func:`turbid.resolve_params`, on the first batch element of tensor values), with the tensors
    given kept as they are. ``get(path)`` returns a tensor of shape (B,) or (B, width), B = 1 or N.
    """

    def __init__(self, params):
        if params is None:
            params = {}
        if not isinstance(params, dict):
            raise ValueError("params: a dict, not a %s" % type(params).__name__)
        self.given = params
        self.tensors = {}
        plain = _split(params, _defaults(), (), self.tensors)
        self.plain = _turbid.resolve_params(plain)

    def raw(self, path):
        node = self.plain
        for key in path.split(".") if isinstance(path, str) else path:
            node = node[int(key)] if isinstance(node, list) else node[key]
        return node

    def get(self, path, like, n):
        key = tuple(int(k) if k.isdigit() else k for k in path.split(".")) \
            if isinstance(path, str) else tuple(path)
        value = self.tensors.get(key)
        if value is None:
            value = torch.as_tensor(self.raw(key), dtype=torch.float64)
            value = value.reshape(1, -1) if value.ndim == 1 else value.reshape(1)
        value = value.to(dtype=like.dtype, device=like.device)
        if value.shape[0] not in (1, n):
            raise ValueError("params: %s: a leading dimension of %d for a batch of %d"
                             % (".".join(map(str, key)), value.shape[0], n))
        return value

    def channels(self, section, rgb_key, gray_key, like, n, c):
        """Per-channel values (B, C, 1, 1): R, G, B for colour images, the gray key for gray."""
        v = self.get(section + "." + (rgb_key if c == 3 else gray_key), like, n)
        return v.reshape(v.shape[0], c, 1, 1)

    def scalar(self, path, like, n):
        """(B, 1, 1, 1)."""
        return self.get(path, like, n).reshape(-1, 1, 1, 1)


def resolve(params):
    """:class:`Params` of ``params`` (the dict :func:`turbid.render` takes, tensors allowed)."""
    return params if isinstance(params, Params) else Params(params)


def cache_host_memory(enabled=True):
    """Keep freed host memory in the process for reuse (glibc's malloc; opt-in, process-wide).

    glibc serves blocks above 32 MB (a 64 x 3 x 256 x 256 float batch is 50 MB) by mmap and
    returns them to the kernel on free, so every large temporary tensor is faulted in, page by
    page, anew: in the 64-image benchmark a third to a half of the forward + backward CPU time
    (python/benchmarks/bench_torch.py prints the system time and the page faults). This sets
    M_MMAP_MAX = 0, a 2 GB M_TRIM_THRESHOLD and one arena, so freed blocks stay in the heap and
    are reused once a loop has run a step or two
    (what a caching allocator, or jemalloc / tcmalloc by LD_PRELOAD, does; PyTorch's CUDA
    allocator caches device memory the same way). The cost: the process keeps its peak memory.
    ``enabled=False`` restores glibc's defaults. Returns False where there is no glibc mallopt
    (nothing changed)."""
    import ctypes
    import ctypes.util
    try:
        mallopt = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").mallopt
    except (OSError, AttributeError):
        return False
    m_trim_threshold, m_mmap_max, m_arena_max = -1, -4, -8
    if enabled:  # one arena: a thread on another arena would mmap blocks above its 64 MB heaps
        return (bool(mallopt(m_arena_max, 1)) and bool(mallopt(m_mmap_max, 0))
                and bool(mallopt(m_trim_threshold, 2 ** 31 - 1)))
    return bool(mallopt(m_mmap_max, 65536)) and bool(mallopt(m_trim_threshold, 128 * 1024))


# ---- geometry -----------------------------------------------------------------------------------


def _intrinsics(K, n, device):
    """fx, fy, cx, cy as float64 tensors of shape (B,), B = 1 or n."""
    K = torch.as_tensor(K, dtype=torch.float64, device=device)
    if K.shape[-1] == 4 and K.ndim in (1, 2):  # (fx, fy, cx, cy), or N of them
        K = K.reshape(-1, 4)
        if K.shape[0] not in (1, n):
            raise ValueError("K: %d intrinsics for a batch of %d" % (K.shape[0], n))
        return tuple(K[:, i] for i in range(4))
    if K.ndim == 2:
        K = K.reshape(1, 3, 3)
    if K.ndim != 3 or K.shape[1:] != (3, 3) or K.shape[0] not in (1, n):
        raise ValueError("K: 3 x 3 or N x 3 x 3 intrinsics, got shape %s" % (tuple(K.shape),))
    return K[:, 0, 0], K[:, 1, 1], K[:, 0, 2], K[:, 1, 2]


def _rays(K, n, h, w, device):
    """Column and row ray slopes (x - cx) / fx (B, 1, 1, W) and (y - cy) / fy (B, 1, H, 1), float64."""
    fx, fy, cx, cy = _intrinsics(K, n, device)
    xs = torch.arange(w, dtype=torch.float64, device=device)
    ys = torch.arange(h, dtype=torch.float64, device=device)
    rx = ((xs[None, :] - cx[:, None]) / fx[:, None]).reshape(-1, 1, 1, w)
    ry = ((ys[None, :] - cy[:, None]) / fy[:, None]).reshape(-1, 1, h, 1)
    return rx, ry


def _valid(depth):
    return torch.isfinite(depth) & (depth > 0)


def range_from_depth(depth, K):
    """Range along the viewing ray r = z ||K^-1 [u v 1]|| (N x 1 x H x W metres; NaN where the
    depth is NaN, 0 or negative), as RangeFromDepth (the norm in double)."""
    depth = _depth4(depth)
    n, _, h, w = depth.shape
    rx, ry = _rays(K, n, h, w, depth.device)
    factor = torch.sqrt(rx * rx + ry * ry + 1.0)
    valid = _valid(depth)
    if bool(valid.all()):
        return (depth.double() * factor).to(depth.dtype)
    r = (torch.where(valid, depth, torch.ones_like(depth)).double() * factor).to(depth.dtype)
    return torch.where(valid, r, torch.full_like(r, float("nan")))


@torch.no_grad()
def normals_from_depth(depth, K, max_relative_jump=0.05):
    """Unit normals N x 3 x H x W (camera frame, facing the camera; NaN where undefined) as the
    renderer derives them for scenes without normals (scenes/normals.cc: one-sided differences
    towards the neighbour with the smaller depth jump, jumps above max_relative_jump * z
    rejected), computed in double. No gradient flows through them."""
    depth = _depth4(depth)
    dtype = depth.dtype
    z = depth.double()
    n, _, h, w = z.shape
    rx, ry = _rays(K, n, h, w, z.device)
    valid = _valid(z)
    nan = float("nan")
    z = torch.where(valid, z, torch.full_like(z, nan))
    p = torch.cat([(rx * z).expand(n, 1, h, w), (ry * z).expand(n, 1, h, w), z], dim=1)

    def shifted(t, dy, dx):  # t at (y + dy, x + dx), NaN outside
        out = torch.full_like(t, nan)
        ys = slice(max(dy, 0), h + min(dy, 0))
        xs = slice(max(dx, 0), w + min(dx, 0))
        yd = slice(max(-dy, 0), h + min(-dy, 0))
        xd = slice(max(-dx, 0), w + min(-dx, 0))
        out[..., yd, xd] = t[..., ys, xs]
        return out

    limit = max_relative_jump * z

    def tangent(dy, dx):
        z_prev, z_next = shifted(z, -dy, -dx), shifted(z, dy, dx)
        inf = torch.full_like(z, float("inf"))
        jump_prev = torch.where(torch.isfinite(z_prev), (z_prev - z).abs(), inf)
        jump_next = torch.where(torch.isfinite(z_next), (z_next - z).abs(), inf)
        use_next = (jump_next <= jump_prev) & (jump_next <= limit)
        use_prev = ~use_next & (jump_prev <= limit)
        t = torch.where(use_next, shifted(p, dy, dx) - p, p - shifted(p, -dy, -dx))
        return t, use_next | use_prev

    tx, ok_x = tangent(0, 1)
    ty, ok_y = tangent(1, 0)
    normal = torch.cross(tx, ty, dim=1)
    length = torch.linalg.vector_norm(normal, dim=1, keepdim=True)
    ok = valid & ok_x & ok_y & (length > 0)
    normal = normal / length
    flip = (normal * p).sum(dim=1, keepdim=True) > 0
    normal = torch.where(flip, -normal, normal)
    normal = torch.where(ok, normal, torch.full_like(normal, nan))
    return normal.to(dtype)


def _depth4(depth):
    depth = torch.as_tensor(depth)
    if depth.ndim == 2:
        depth = depth[None, None]
    elif depth.ndim == 3:
        depth = depth[:, None]
    if depth.ndim != 4 or depth.shape[1] != 1:
        raise ValueError("depth: N x 1 x H x W (or N x H x W) metres, got shape %s"
                         % (tuple(depth.shape),))
    return depth


# ---- light --------------------------------------------------------------------------------------


def _cos_cutoff(light):
    """CosCutoff of light.cc: cos of the spot cut-off, 0 for none (90 degrees)."""
    cutoff = light.get("cutoff_angle_deg", 90.0)
    return 0.0 if cutoff >= 90.0 else _math.cos(cutoff * _math.pi / 180.0)


def _lambertian_order(half_power_angle_deg):
    return -_math.log(2.0) / _math.log(_math.cos(half_power_angle_deg * _math.pi / 180.0))


def irradiance(P, depth, K, normals, beta, n, c, like):
    """E_L (N x C x H x W) of the lights of ``P`` (:class:`Params`) at the surface points, with
    attenuation coefficients ``beta`` (B x C x 1 x 1); 0 where the depth is invalid. None when
    there is no light (or every power is 0 and none is a tensor)."""
    lights = P.raw("light.lights")
    if not lights:
        return None
    if all(light["power"] <= 0 and ("light", "lights", i, "power") not in P.tensors
           for i, light in enumerate(lights)):
        return None
    h, w = depth.shape[-2:]
    dtype = like.dtype
    rx64, ry64 = _rays(K, n, h, w, like.device)
    rx, ry = rx64.to(dtype), ry64.to(dtype)
    valid = _valid(depth)
    all_valid = bool(valid.all())
    z = (depth if all_valid else torch.where(valid, depth, torch.ones_like(depth))).to(dtype)
    px, py, pz = rx * z, ry * z, z
    # A NaN normal faces the camera along the viewing ray.
    nn = normals.to(dtype)
    bad = torch.isnan(nn).any(dim=1, keepdim=True)
    if bad.any():
        rl = 1.0 / torch.sqrt(rx * rx + ry * ry + 1.0)
        facing = torch.cat([(-rx * rl).expand_as(z), (-ry * rl).expand_as(z),
                            (-rl).expand_as(z)], dim=1)
        nn = torch.where(bad, facing, nn)
    nx, ny, nz = nn[:, 0:1], nn[:, 1:2], nn[:, 2:3]
    geo = {"px": px, "py": py, "pz": pz, "nx": nx, "ny": ny, "nz": nz,
           "valid": None if all_valid else valid, "eq5": P.raw("light.incidence") == "paper_eq5",
           "min_cos": P.raw("light.min_cos_incidence"), "min_l": P.raw("light.min_distance_m")}
    total = None
    for i, light in enumerate(lights):
        base = "light.lights.%d." % i
        pos = P.get(base + "position_in_camera_m", like, n)
        axis = P.get(base + "axis_in_camera", like, n)
        axis = axis / torch.linalg.vector_norm(axis, dim=1, keepdim=True)
        power = P.get(base + "power", like, n)
        color = P.get(base + "color_rgb", like, n)
        if c == 1:
            color = color.mean(dim=1, keepdim=True)
        color = color.reshape(-1, c, 1, 1)
        if ("light", "lights", i, "color_rgb") not in P.tensors and bool((color == 1).all()):
            color = None  # white light (the default): one product fewer
        order = _lambertian_order(light["half_power_angle_deg"])
        rounded = round(order)
        whole = abs(order - rounded) < 1e-9 and 0 <= rounded <= 8
        e = _Lamp.apply(pos, axis, power, beta, color,
                        dict(geo, order=float(rounded) if whole else order, whole=whole,
                             cos_cutoff=_cos_cutoff(light)))
        total = e if total is None else total + e
    return total


# ---- marine snow --------------------------------------------------------------------------------


def _light_at_points(P, points, beta, like, i, n, c):
    """E_L at particle points (M x 3, facing every light: cos psi = 1) per channel, M x C,
    IrradianceAtPoint of light.cc; differentiable in the lights' and water's tensors."""
    total = torch.zeros(points.shape[0], c, dtype=like.dtype, device=like.device)
    lights = P.raw("light.lights")
    min_l = P.raw("light.min_distance_m")
    for k, light in enumerate(lights):
        base = "light.lights.%d." % k
        pick = lambda t: t[i] if t.shape[0] > 1 else t[0]  # noqa: E731
        pos = pick(P.get(base + "position_in_camera_m", like, n))
        axis = pick(P.get(base + "axis_in_camera", like, n))
        axis = axis / torch.linalg.vector_norm(axis)
        power = pick(P.get(base + "power", like, n))
        color = pick(P.get(base + "color_rgb", like, n))
        color = color.mean().reshape(1) if c == 1 else color
        vec = points - pos
        l_true = torch.linalg.vector_norm(vec, dim=1)
        apart = l_true > 1e-12
        cphi = torch.where(apart, torch.clamp((vec @ axis) / torch.where(
            apart, l_true, torch.ones_like(l_true)), 0.0, 1.0), torch.ones_like(l_true))
        cos_cutoff = _cos_cutoff(light)
        if cos_cutoff > 0:  # beyond the spot cut-off (IrradianceAtPoint)
            cphi = torch.where(cphi < cos_cutoff, torch.zeros_like(cphi), cphi)
        order = _lambertian_order(light["half_power_angle_deg"])
        l = torch.clamp(l_true, min=min_l)
        g = power * torch.pow(cphi, order) / (l * l)
        total = total + color[None, :] * g[:, None] * torch.exp(-beta[None, :] * l[:, None])
    return total


def snow_layer(P, K, r, beta, ambient, like, seeds):
    """The marine-snow layer (N x C x H x W) added before the sensor noise: the renderer's
    particles for each image's seed (same positions, sizes, albedos and visibility), each a
    flux-preserving Gaussian of peak albedo (E_A + E_L) exp(-beta r) R^2 / (2 sigma^2).
    Differentiable in the peaks (water, lights); the draw itself is fixed by the seed."""
    n, c, h, w = like.shape
    snow = P.raw("snow")
    fxs, fys, cxs, cys = (t.expand(n).tolist() for t in _intrinsics(K, n, like.device))
    range_np = r.detach().double().cpu().numpy()
    layers = []
    lights_on = P.raw("model") in ("paper", "revised") and bool(P.raw("light.lights"))
    for i in range(n):
        part, _ = snow_particles(snow, fxs[i], fys[i], cxs[i], cys[i], h, w, range_np[i, 0],
                                 seeds[i])
        layer = torch.zeros(c, h * w, dtype=like.dtype, device=like.device)
        m = part["u"].shape[0]
        if m == 0:
            layers.append(layer.reshape(c, h, w))
            continue
        b_i = beta[i if beta.shape[0] > 1 else 0].reshape(c)
        a_i = ambient[i if ambient.shape[0] > 1 else 0].reshape(c)
        dev = like.device
        points = torch.tensor(_np.stack([part["x"], part["y"], part["z"]], 1), dtype=like.dtype,
                              device=dev)
        lit = _light_at_points(P, points, b_i, like, i, n, c) if lights_on else 0.0
        rng = torch.tensor(part["range"], dtype=like.dtype, device=dev)
        albedo = torch.tensor(part["albedo"] * part["peak_scale"], dtype=like.dtype, device=dev)
        peak = albedo[:, None] * (a_i[None, :] + lit) * torch.exp(-b_i[None, :] * rng[:, None])
        # Footprints: the square of half-width reach around floor(u) .. ceil(u), clipped.
        size = int(2 * part["reach"].max() + 2)
        offs = _np.arange(size)
        u, v, reach = part["u"], part["v"], part["reach"]
        xs = (_np.floor(u) - reach)[:, None] + offs[None, :]
        ys = (_np.floor(v) - reach)[:, None] + offs[None, :]
        okx = (xs >= 0) & (xs <= w - 1) & (xs <= _np.ceil(u)[:, None] + reach[:, None])
        oky = (ys >= 0) & (ys <= h - 1) & (ys <= _np.ceil(v)[:, None] + reach[:, None])
        inv = -0.5 / part["sigma2"]
        gx = _np.exp((xs - u[:, None]) ** 2 * inv[:, None]).astype(_np.float32)
        gy = _np.exp((ys - v[:, None]) ** 2 * inv[:, None]).astype(_np.float32)
        weight = (gy[:, :, None] * gx[:, None, :]) * (oky[:, :, None] & okx[:, None, :])
        index = ys[:, :, None] * w + xs[:, None, :]
        keep = (oky[:, :, None] & okx[:, None, :]).reshape(-1)
        index = torch.from_numpy(index.reshape(-1)[keep].astype(_np.int64)).to(dev)
        weight = torch.from_numpy(weight.reshape(m, -1)).to(device=dev, dtype=like.dtype)
        source = (peak.t()[:, :, None] * weight[None]).reshape(c, -1)[:, torch.from_numpy(
            keep).to(dev)]
        layers.append(layer.index_add(1, index, source).reshape(c, h, w))
    return torch.stack(layers)


# ---- the model ----------------------------------------------------------------------------------


def _images(albedo, channel_axis):
    albedo = torch.as_tensor(albedo)
    if not albedo.is_floating_point():
        raise ValueError("albedo: a float tensor (linear light), got %s" % albedo.dtype)
    if albedo.ndim == 3:
        albedo = albedo[None]
    if albedo.ndim != 4:
        raise ValueError("albedo: N x C x H x W, got shape %s" % (tuple(albedo.shape),))
    if channel_axis in (-1, 3):
        albedo = albedo.permute(0, 3, 1, 2)
    elif channel_axis not in (-3, 1):
        raise ValueError("channel_axis: -3 (N x C x H x W) or -1 (N x H x W x C)")
    if albedo.shape[1] not in (1, 3):
        raise ValueError("albedo: 1 or 3 channels, got %d" % albedo.shape[1])
    return albedo


def _check_supported(P):
    """The model's name; ValueError for what the differentiable model does not have."""
    model = P.raw("model")
    if model not in ("paper", "revised"):
        raise ValueError("turbid.torch: model %r is not in the differentiable model (paper, "
                         "revised)" % model)
    if model == "revised" and P.raw("water.iop") and P.raw("revised.from_iop"):
        raise ValueError("turbid.torch: revised with water.iop (tabulated beta^D(r)) is not in the "
                         "differentiable model; set revised.from_iop false")
    # Options newer than the differentiable model: refused by name, never rendered another way.
    if P.raw("psf.model") != "paper":
        raise ValueError("turbid.torch: psf.model %r is not in the differentiable model (paper)"
                         % P.raw("psf.model"))
    if P.raw("snow.mode") != "per_frame":
        raise ValueError("turbid.torch: snow.mode %r is not in the differentiable model "
                         "(per_frame)" % P.raw("snow.mode"))
    if any(k[0] == "snow" for k in P.tensors):
        raise ValueError("turbid.torch: snow parameters are fixed numbers (the draw is not "
                         "differentiable)")
    return model


_SHARES = {}


def _derived_backscatter(P, beta, ambient, like, n, c):
    """B_inf of ambient "derived" (DerivedBackscatter of water.cc): omega E_A H per channel, 0
    where beta is 0 (B x C x 1 x 1; differentiable in omega and E_A, H from the renderer: it
    depends only on the phase function and the view elevation); None for ambient "typed"."""
    if P.raw("ambient") != "derived":
        return None
    water = P.raw("water")
    key = (_json.dumps(water["phase"], sort_keys=True), water["ambient_view_elevation_deg"])
    if key not in _SHARES:
        text = _json.dumps({"water": {"phase": water["phase"],
                                      "ambient_view_elevation_deg": key[1]}})
        import turbid._turbid as native
        _SHARES[key] = native._ambient_share(text)
    omega = P.channels("water", "scattering_albedo_rgb", "scattering_albedo_gray", like, n, c)
    value = omega * ambient * _SHARES[key]
    return torch.where(beta > 0, value, torch.zeros_like(value))


def _single_scatter(P, K, r, beta, like, n, c):
    """V of veil "single_scatter" (python/turbid/_torch_veil.py) for the batch, or None."""
    lamps = []
    for i, light in enumerate(P.raw("light.lights")):
        base = "light.lights.%d." % i
        axis = P.get(base + "axis_in_camera", like, n)
        colour = P.get(base + "color_rgb", like, n)
        order = _lambertian_order(light["half_power_angle_deg"])
        if abs(order - round(order)) < 1e-9:  # whole orders as such (veil.cc)
            order = float(round(order))
        lamps.append({
            "on": light["power"] > 0 or ("light", "lights", i, "power") in P.tensors,
            "position": P.get(base + "position_in_camera_m", like, n),
            "axis": axis / torch.linalg.vector_norm(axis, dim=1, keepdim=True),
            "power": P.get(base + "power", like, n),
            "colour": colour.mean(dim=1, keepdim=True) if c == 1 else colour,
            "order": order,
            "cos_cutoff": _cos_cutoff(light)})
    parts = [t.expand(n).tolist() for t in _intrinsics(K, n, like.device)]
    return single_scatter_veil(P, parts, r, beta, like, n, c, lamps)


def _map_outputs(maps, t, e, veil, lit, rho, channels_last):
    """{name: tensor} of the maps asked for."""
    out = {}
    for name in maps:
        if name == "transmission":
            value = t.expand_as(rho)
        elif name == "light":
            value = e if e is not None else torch.zeros_like(rho)
        elif name == "veil":
            value = veil if veil is not None else torch.zeros_like(rho)
        elif name == "lit":
            value = lit
        else:
            raise ValueError("maps: unknown map %r (transmission, light, veil, lit)" % name)
        out[name] = value.permute(0, 2, 3, 1) if channels_last else value
    return out


def render(albedo, depth, K, params=None, seed=None, *, normals=None, channel_axis=-3,
           maps=None, noise="turbid", chunk_images=None):
    """Degrade a batch with the forward model, differentiably (docs/model.md; the C++ renderer's
    equations).

    ``albedo`` N x C x H x W (C = 3, R, G, B, or 1; ``channel_axis=-1``: N x H x W x C), linear;
    ``depth`` N x 1 x H x W (or N x H x W) z-depth in metres, NaN (or <= 0) = no surface; ``K``
    N x 3 x 3 or 3 x 3 (for all), or (fx, fy, cx, cy) (N x 4 or 4, as turbid.data's samples); ``params`` the dict of :func:`turbid.render`, whose numbers may
    be tensors (``requires_grad`` for gradients; a leading N gives each image its own value).
    ``seed``: the sensor noise's seed (default ``params["seed"]``); an integer s gives image i
    the seed s + i (so image i of a batch equals ``turbid.render(..., seed=s + i)``), a sequence
    gives one per image. ``noise``: where the sensor noise's standard normals come from:
    ``"turbid"`` (the renderer's, bit for bit) or ``"torch"`` (torch's generator seeded per image:
    faster, on the device). ``normals``: N x 3 x H x W camera-frame unit normals (the scene's own);
    None derives them from depth as the renderer does for scenes without normals.

    Returns I, N x C x H x W (the layout of ``albedo``), linear light. The camera (clip and the
    quantiser of ``camera.bit_depth`` / ``camera.encoding``, straight-through gradients) is applied
    only when ``params`` has a ``"camera"`` section; otherwise I is returned unclipped. Marine
    snow is the renderer's particles for each image's seed, added as a differentiable overlay
    (the draw itself is fixed). ``maps``: a list of "transmission", "light", "veil", "lit"
    returns (I, {name: tensor}) as well.

    ``chunk_images``: how many images go through the model at a time; the chunks' outputs are
    concatenated (torch.cat: its backward only slices), with every result, value and gradient,
    the same as in one pass (the per-image parameters, K, seeds, normals and snow draws are
    sliced, never redrawn; the PSF kernels are made once for the batch). None (the default):
    on CPU as many as keep each per-image tensor of the chunk within 8 MB (10 float images of
    3 x 256 x 256), none on other devices; 0: the whole batch at once. Small chunks keep the
    temporaries below glibc's 32 MB mmap threshold, so the heap reuses them chunk after chunk
    instead of the kernel faulting in fresh pages for each (docs/python.md, "Differentiable
    model": about half the CPU time of a 64-image forward + backward). On a machine whose cores
    other jobs share, run with OMP_WAIT_POLICY=passive: the chunks' more numerous OpenMP regions
    otherwise spin while a thread waits for a core.
    """
    rho = _images(albedo, channel_axis)
    P = resolve(params)
    n, c, h, w = rho.shape
    depth = _depth4(depth).to(device=rho.device)
    if depth.shape[0] not in (1, n) or depth.shape[-2:] != (h, w):
        raise ValueError("depth: shape %s for albedo %s" % (tuple(depth.shape), tuple(rho.shape)))
    depth = depth.expand(n, 1, h, w)
    model = _check_supported(P)
    if normals is not None:
        normals = torch.as_tensor(normals, device=rho.device)
        if normals.ndim == 3:
            normals = normals[None]
        if channel_axis in (-1, 3):
            normals = normals.permute(0, 3, 1, 2)
        normals = normals.expand(n, 3, h, w)
    seeds = _seeds(seed, P, n)
    kernel = None
    if P.raw("psf.enabled") and not P.raw("psf.turbidity_dependent"):
        kernel = psf_kernel(P, rho, n)  # once for the batch (its radius is the batch's largest)
    size = _chunk_size(chunk_images, rho)
    if size >= n:
        image, out = _render(rho, depth, K, P, model, seeds, normals, maps, noise, kernel)
    else:
        K = torch.as_tensor(K, dtype=torch.float64)  # as _intrinsics reads it
        _intrinsics(K, n, rho.device)  # its errors for the whole batch
        parts = []
        for first in range(0, n, size):
            part = slice(first, min(first + size, n))
            parts.append(_render(
                rho[part], depth[part], _batch_slice(K, part, n, True), _params_slice(P, part, n),
                model, seeds[part], None if normals is None else normals[part], maps, noise,
                None if kernel is None else (_batch_slice(kernel[0], part, n), kernel[1])))
        image = torch.cat([p[0] for p in parts])
        out = None if maps is None else {k: torch.cat([p[1][k] for p in parts]) for k in maps}
    if channel_axis in (-1, 3):
        image = image.permute(0, 2, 3, 1)
        out = None if out is None else {k: v.permute(0, 2, 3, 1) for k, v in out.items()}
    return image if maps is None else (image, out)


_CHUNK_BYTES = 8 << 20


def _chunk_size(chunk_images, rho):
    """Images per chunk of :func:`render` (``chunk_images`` as documented there)."""
    if chunk_images is None:
        if rho.device.type != "cpu":
            return rho.shape[0]
        per_image = rho[0].numel() * rho.element_size()
        return max(1, _CHUNK_BYTES // max(per_image, 1))
    if isinstance(chunk_images, bool) or not isinstance(chunk_images, _numbers.Integral) \
            or chunk_images < 0:
        raise ValueError("chunk_images: None (automatic), 0 (off) or a positive integer, got %r"
                         % (chunk_images,))
    return rho.shape[0] if chunk_images == 0 else int(chunk_images)


def _batch_slice(t, part, n, intrinsics=False):
    """t[part] where t has one row per image (a leading n; for ``intrinsics``, only an
    N x 3 x 3 or N x 4 K), else t (shared by the batch)."""
    if t.ndim == 0 or t.shape[0] != n or n == 1:
        return t
    if intrinsics and not (t.ndim == 3 or (t.ndim == 2 and t.shape[-1] == 4)):
        return t
    return t[part]


def _params_slice(P, part, n):
    """P with its per-image tensors (a leading n) cut to ``part``; shared values as they are."""
    sliced = object.__new__(Params)
    sliced.given, sliced.plain = P.given, P.plain
    sliced.tensors = {k: _batch_slice(v, part, n) for k, v in P.tensors.items()}
    return sliced


def _render(rho, depth, K, P, model, seeds, normals, maps, noise, kernel):
    """The model on rho (N x C x H x W), depth (N x 1 x H x W), normals (N x 3 x H x W or None):
    (image, {name: map} or None), N x C x H x W; ``kernel`` the PSF's (psf_kernel) or None."""
    n, c, h, w = rho.shape
    snow = P.raw("snow")
    valid = _valid(depth)
    r = range_from_depth(depth, K).to(rho.dtype)
    if bool(valid.all()):
        r0, keep = r, (lambda t: t)  # noqa: E731
    else:  # open water: t = 0 (and no NaN in the gradients)
        r0 = torch.where(valid, r, torch.zeros_like(r))
        keep = (lambda t: t * valid)  # noqa: E731
    beta = P.channels("water", "beta_rgb_per_m", "beta_gray_per_m", rho, n, c)
    ambient = P.channels("water", "ambient_rgb", "ambient_gray", rho, n, c)
    if normals is None and P.raw("light.lights"):
        normals = normals_from_depth(depth, K)
    e = irradiance(P, depth, K, normals, beta, n, c, rho)
    lit = (ambient + e) * rho if e is not None else ambient * rho
    if model == "revised":
        if P.raw("revised.range_dependent"):
            co = [P.channels("revised", k + "_rgb", k + "_gray", rho, n, c) for k in "abcd"]
            beta_d = co[0] * torch.exp(co[1] * r0) + co[2] * torch.exp(co[3] * r0)
        else:
            beta_d = beta
    if P.raw("psf.enabled") and P.raw("psf.turbidity_dependent"):
        thickness = (beta_d if model == "revised" else beta) * r0
        if not bool(valid.all()):  # NaN: open water (a where: no NaN in the gradients)
            thickness = torch.where(valid, thickness, torch.full_like(thickness, float("nan")))
        jb = turbidity_psf(lit, thickness.expand(n, c, h, w), P)
    else:
        jb = apply_psf(lit, kernel)
    single = P.raw("veil") == "single_scatter"
    derived = _derived_backscatter(P, beta, ambient, rho, n, c)
    if model == "paper" and maps is None and not single:  # eq. 2 fused (t_B = t): _torch_light.py
        bs = derived if derived is not None else (
            P.channels("water", "backscatter_rgb", "backscatter_gray", rho, n, c)
            if P.raw("water.backscatter") else None)
        image = _Veiled.apply(jb, e, beta, bs, r0, None if bool(valid.all()) else valid)
    else:
        if model == "revised":
            beta_b = P.channels("revised", "beta_b_rgb_per_m", "beta_b_gray_per_m", rho, n, c)
            t = keep(torch.exp(-beta_d * r0))
            t_b = keep(torch.exp(-beta_b * r0))
            bs = P.channels("water", "backscatter_rgb", "backscatter_gray", rho, n, c)
        else:
            t = t_b = keep(torch.exp(-beta * r0))
            bs = (P.channels("water", "backscatter_rgb", "backscatter_gray", rho, n, c)
                  if P.raw("water.backscatter") else None)
        bs = derived if derived is not None else bs
        if single:  # I = J_b t + ((1 - t_B) B_inf + V): ComposeSingleScatter of render.cc
            v = _single_scatter(P, K, r, beta, rho, n, c)
            veil = (1.0 - t_b) * bs if bs is not None else None
            veil = v if veil is None else (veil if v is None else veil + v)
            image = jb * t if veil is None else torch.addcmul(veil, jb, t)
        else:
            veil_light = e if bs is None else (bs if e is None else e + bs)
            if veil_light is None:
                image, veil = jb * t, None
            elif t_b is t and maps is None:  # jb t + (1 - t) v = v + t (jb - v)
                image, veil = torch.addcmul(veil_light, t, jb - veil_light), None
            else:
                veil = (1.0 - t_b) * veil_light
                image = torch.addcmul(veil, jb, t)
    if snow["enabled"] and snow["density_per_m3"] > 0:
        image = image + snow_layer(P, K, r, beta, ambient, rho, seeds)
    sensor = P.raw("sensor")
    if sensor["enabled"] and (sensor["photons_at_white"] > 0 or sensor["read_noise"] > 0 or any(
            k[0] == "sensor" for k in P.tensors)):
        image = sensor_noise(image, P, seeds, source=noise)
    if "camera" in P.given:
        image = camera(image, P)
    if maps is None:
        return image, None
    return image, _map_outputs(maps, t, e, veil, lit, rho, False)
