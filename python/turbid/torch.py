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

import math as _math
import numbers as _numbers

import numpy as _np
import torch

import turbid as _turbid

__all__ = ["render", "resolve", "range_from_depth", "normals_from_depth", "irradiance",
           "psf_kernel", "apply_psf", "sensor_noise", "standard_normals", "camera"]

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
    eq5 = P.raw("light.incidence") == "paper_eq5"
    min_cos = P.raw("light.min_cos_incidence")
    min_l = P.raw("light.min_distance_m")
    total = None
    for i, light in enumerate(lights):
        base = "light.lights.%d." % i
        pos = P.get(base + "position_in_camera_m", like, n).reshape(-1, 3, 1, 1)
        axis = P.get(base + "axis_in_camera", like, n).reshape(-1, 3, 1, 1)
        axis = axis / torch.linalg.vector_norm(axis, dim=1, keepdim=True)
        power = P.scalar(base + "power", like, n)
        color = P.get(base + "color_rgb", like, n)
        if c == 1:
            color = color.mean(dim=1, keepdim=True)
        color = color.reshape(-1, c, 1, 1)
        vx, vy, vz = px - pos[:, 0:1], py - pos[:, 1:2], pz - pos[:, 2:3]
        l_true = torch.sqrt(vx * vx + vy * vy + vz * vz)
        along = axis[:, 0:1] * vx + axis[:, 1:2] * vy + axis[:, 2:3] * vz
        facing = -(nx * vx + ny * vy + nz * vz)
        apart = l_true > 1e-12
        if bool(apart.all()):
            inv = 1.0 / l_true
            cphi, cpsi = along * inv, facing * inv
        else:  # a light at a surface point: head-on there (cos phi = cos psi = 1)
            inv = 1.0 / torch.where(apart, l_true, torch.ones_like(l_true))
            one = torch.ones_like(l_true)
            cphi = torch.where(apart, along * inv, one)
            cpsi = torch.where(apart, facing * inv, one)
        l = torch.clamp(l_true, min=min_l)
        if eq5:
            incidence = torch.where(cpsi > 0, 1.0 / torch.clamp(cpsi, min=min_cos),
                                    torch.zeros_like(cpsi))
        else:
            incidence = torch.clamp(cpsi, min=0.0)
        cphi = torch.clamp(cphi, 0.0, 1.0)
        order = _lambertian_order(light["half_power_angle_deg"])
        rounded = round(order)
        if abs(order - rounded) < 1e-9 and 0 <= rounded <= 8:
            beam = cphi ** int(rounded) if rounded != 1 else cphi
        else:
            beam = torch.exp(order * torch.log(torch.clamp(cphi, min=1e-30)))
        # g is finite (l >= min_distance_m, incidence <= 1 / min_cos_incidence).
        g = power * incidence / (l * l) * beam
        if not all_valid:
            g = torch.where(valid, g, torch.zeros_like(g))
            l = torch.where(valid, l, torch.zeros_like(l))
        if ("light", "lights", i, "color_rgb") not in P.tensors and bool((color == 1).all()):
            e = g * torch.exp(-beta * l)  # white light (the default): one product fewer
        else:
            e = color * g * torch.exp(-beta * l)
        total = e if total is None else total + e
    return total


# ---- PSF (paper eq. 7) --------------------------------------------------------------------------


def _gamma_q(a, x):
    """Regularized upper incomplete gamma Q(a, x), as psf.cc computes it (series / Lentz)."""
    if x <= 0.0:
        return 1.0
    if not _math.isfinite(x):
        return 0.0
    if x < a + 1.0:
        term = 1.0 / a
        total = term
        for k in range(1, 100000):
            term *= x / (a + k)
            total += term
            if abs(term) < abs(total) * 1e-16:
                break
        return 1.0 - total * _math.exp(-x + a * _math.log(x) - _math.lgamma(a))
    tiny = 1e-300
    b = x + 1.0 - a
    cc, d = 1.0 / tiny, 1.0 / b
    hh = d
    for i in range(1, 100000):
        an = -i * (i - a)
        b += 2.0
        d = an * d + b
        if abs(d) < tiny:
            d = tiny
        cc = b + an / cc
        if abs(cc) < tiny:
            cc = tiny
        d = 1.0 / d
        delta = d * cc
        hh *= delta
        if abs(delta - 1.0) < 1e-16:
            break
    return _math.exp(-x + a * _math.log(x) - _math.lgamma(a)) * hh


def _psf_radius(p, sigma, tail_mass, max_radius):
    """The truncation radius of PsfKernel (plain floats)."""
    log_a = _math.log(sigma) + 0.5 * (_math.lgamma(1.0 / p) - _math.lgamma(3.0 / p))
    shape = 2.0 / p

    def outside(radius):
        return _gamma_q(shape, _math.exp(p * (_math.log(radius) - log_a)))

    radius = 1
    while radius < max_radius and outside(radius) > tail_mass:
        radius += 1
    return radius


def _profile(p, log_a, r2):
    """exp(-(r/A)^p) from r^2 (float64 tensors broadcasting), as ProfileFromSquare."""
    safe = torch.where(r2 > 0, r2, torch.ones_like(r2))
    exponent = torch.clamp(p * (0.5 * torch.log(safe) - log_a), max=700.0)
    return torch.where(r2 > 0, torch.exp(-torch.exp(exponent)), torch.ones_like(r2))


def psf_kernel(P, like, n):
    """Eq. 7's discrete kernels for the batch: a tuple (kernel, separable) where kernel is
    B x (2R + 1) x (2R + 1) (or B x (2R + 1) 1-D factors when separable), float64, each image's
    kernel normalised on its own square of radius R_i and zero outside; None when every image's
    kernel is a delta (or the PSF is disabled)."""
    if not P.raw("psf.enabled"):
        return None
    if P.raw("psf.depth_dependent"):
        raise ValueError("turbid.torch: psf.depth_dependent is not in the differentiable model yet")
    f64 = torch.empty(0, dtype=torch.float64, device=like.device)
    T = P.get("psf.optical_thickness", f64, n)
    q = P.get("psf.forward_scatter", f64, n)
    ppu = P.get("psf.pixels_per_unit", f64, n)
    b = max(T.shape[0], q.shape[0], ppu.shape[0])
    T, q, ppu = T.expand(b), q.expand(b), ppu.expand(b)
    p = torch.sqrt(T)
    sigma = 0.5 / torch.sqrt(q) * ppu
    tail, max_r = P.raw("psf.tail_mass"), P.raw("psf.max_radius_px")
    radii = [_psf_radius(float(pi), float(si), tail, max_r)
             for pi, si in zip(p.detach().cpu().tolist(), sigma.detach().cpu().tolist())]
    log_a = torch.log(sigma) + 0.5 * (torch.lgamma(1.0 / p) - torch.lgamma(3.0 / p))
    R = max(radii)
    offsets = torch.arange(-R, R + 1, dtype=torch.float64, device=like.device)
    r2 = offsets[:, None] ** 2 + offsets[None, :] ** 2
    inside = torch.stack([((offsets.abs() <= ri)[:, None] & (offsets.abs() <= ri)[None, :])
                          for ri in radii])
    k = _profile(p[:, None, None], log_a[:, None, None], r2[None]) * inside
    k = k / k.sum(dim=(1, 2), keepdim=True)
    centre = k[:, R, R]
    delta = (1.0 - centre.detach()) < P.raw("psf.delta_tolerance")
    if bool(delta.all()):
        return None
    if bool(delta.any()):
        identity = torch.zeros_like(k)
        identity[:, R, R] = 1.0
        k = torch.where(delta[:, None, None], identity, k)
    separable = (bool((p.detach() == 2.0).all()) and not T.requires_grad and not q.requires_grad
                 and not ppu.requires_grad and not bool(delta.any()))
    if separable:  # the renderer's two 1-D passes (Gaussian)
        k1 = _profile(p[:, None], log_a[:, None], offsets[None] ** 2) * inside[:, R, :]
        return k1 / k1.sum(dim=1, keepdim=True), True
    return k, False


def _glow_kernel(P, thickness, sigma):
    """g_T of the turbidity-dependent PSF (GlowKernel of psf.cc): eq. 7 at p = sqrt(T), its tail
    judged by the share 1 - e^{-T} it carries, cut to its disc and renormalised; None for the
    identity. thickness, sigma: 0-d float64 tensors; the kernel is differentiable in both (the
    radius is not)."""
    p = torch.sqrt(thickness)
    scattered = -float(torch.expm1(-thickness))
    tail = min(0.1, P.raw("psf.tail_mass") / scattered)
    R = _psf_radius(float(p), float(sigma), tail, P.raw("psf.max_radius_px"))
    log_a = torch.log(sigma) + 0.5 * (torch.lgamma(1.0 / p) - torch.lgamma(3.0 / p))
    o = torch.arange(-R, R + 1, dtype=torch.float64, device=sigma.device)
    r2 = o[:, None] ** 2 + o[None, :] ** 2
    k = _profile(p, log_a, r2)
    k = k / k.sum()
    tolerance = P.raw("psf.delta_tolerance")
    if 1.0 - float(k[R, R]) < tolerance:
        return None
    k = k * (r2 <= R * R)
    k = k / k.sum()
    if scattered * (1.0 - float(k[R, R])) < tolerance:
        return None
    return k


def _thickness_levels(t, max_levels, default):
    """The levels of PlanTurbidityPsf for one image's thickness values t (any shape, NaN
    skipped), as float64 tensors differentiable in t: (levels, exact, p_lo, p_scale)."""
    lo_t, hi_t = 1e-4, 100.0
    flat = t.reshape(-1)
    flat = flat[~torch.isnan(flat)]
    if flat.numel() == 0:
        flat = torch.tensor([min(max(default, lo_t), hi_t)], dtype=t.dtype, device=t.device)
    clamped = torch.clamp(flat, lo_t, hi_t)
    values, first = _np.unique(clamped.detach().cpu().numpy(), return_index=True)
    if values.size <= max_levels:  # exact: each level is the T of the pixels that have it
        first = torch.from_numpy(first).to(t.device)
        return clamped[first].double(), True, None, None
    lo, hi = clamped.min().double(), clamped.max().double()
    p_lo, p_hi = torch.sqrt(lo), torch.sqrt(hi)
    k = torch.arange(max_levels, dtype=torch.float64, device=t.device)
    levels = (p_lo + (p_hi - p_lo) * k / (max_levels - 1)) ** 2
    levels = torch.cat([lo.reshape(1), levels[1:-1], hi.reshape(1)])
    # In the image's precision (float: as the renderer's float p_lo and p_scale).
    p_lo_t, p_hi_t = torch.sqrt(lo.to(t.dtype)), torch.sqrt(hi.to(t.dtype))
    return levels, False, p_lo_t, (max_levels - 1) / (p_hi_t - p_lo_t)


def turbidity_psf(lit, thickness, P):
    """J blurred per pixel and channel with h_T = e^{-T} delta + (1 - e^{-T}) g_T at the pixel's
    own optical thickness T (N x C x H x W, NaN: open water), by levels as PlanTurbidityPsf /
    ApplyTurbidityPsf do (exact when T takes at most psf.thickness_levels values, else g
    interpolated linearly in sqrt(T) between levels evenly spaced in sqrt(T)). Differentiable in
    J, in T (e^{-T}, the interpolation weight and the levels' kernels) and in q (their width)."""
    n, c, h, w = lit.shape
    f64 = torch.empty(0, dtype=torch.float64, device=lit.device)
    q = P.get("psf.forward_scatter", f64, n)
    ppu = P.get("psf.pixels_per_unit", f64, n)
    sigma = 0.5 / torch.sqrt(q) * ppu
    out = []
    for i in range(n):
        t_i = thickness[i]
        levels, exact, p_lo, p_scale = _thickness_levels(t_i, P.raw("psf.thickness_levels"),
                                                         P.raw("psf.optical_thickness"))
        s_i = sigma[i if sigma.shape[0] > 1 else 0]
        j_i = lit[i:i + 1]
        blurred = []
        for level in levels:
            g = _glow_kernel(P, level, s_i)
            blurred.append(j_i[0] if g is None else apply_psf(j_i, (g[None], False))[0])
        blurred = torch.stack(blurred)  # L x C x H x W
        top = levels.numel() - 1
        last = levels[-1].to(t_i.dtype)
        v = torch.where(torch.isnan(t_i), last.expand_as(t_i), torch.clamp(t_i, 1e-4, 100.0))
        direct = torch.exp(-v)
        if exact:
            table = levels.detach().float()
            lower = (v.detach().float()[None] >= table[1:, None, None, None]).sum(0)
            weight = torch.zeros_like(v)
        else:
            f = torch.clamp((torch.sqrt(v) - p_lo.to(v.dtype)) * p_scale.to(v.dtype), 0.0,
                            float(top))
            lower = torch.clamp(f.detach().long(), max=max(top - 1, 0))
            weight = f - lower.to(f.dtype)
        a = torch.gather(blurred, 0, lower[None])[0]
        b = torch.gather(blurred, 0, torch.clamp(lower + 1, max=top)[None])[0]
        out.append(direct * lit[i] + (1.0 - direct) * ((1.0 - weight) * a + weight * b))
    return torch.stack(out)


def _reflect101(i, size):
    """cv::borderInterpolate(i, size, BORDER_REFLECT_101), reflecting as often as needed."""
    if size == 1:
        return 0
    while i < 0 or i >= size:
        i = -i if i < 0 else 2 * size - 2 - i
    return i


class _Taps(torch.autograd.Function):
    """out = sum_t w[:, t] x[..., dy_t : dy_t + h, dx_t : dx_t + w] for a padded x and per-image
    (or shared) tap weights w (B x T): a convolution as shifted multiply-adds, whose backward
    adds the output gradient into the taps' windows in place (slicing's own backward would
    allocate a padded zero image per tap)."""

    @staticmethod
    def forward(ctx, x, weights, offsets, h, w):
        ctx.save_for_backward(x, weights)
        ctx.offsets, ctx.size = offsets, (h, w)
        wt = weights.reshape(weights.shape[0], 1, 1, 1, -1)
        out = None
        for t, (dy, dx) in enumerate(offsets):
            part = x[:, :, dy:dy + h, dx:dx + w]
            out = part * wt[..., t] if out is None else torch.addcmul(out, part, wt[..., t])
        return out

    @staticmethod
    def backward(ctx, grad):
        x, weights = ctx.saved_tensors
        h, w = ctx.size
        wt = weights.reshape(weights.shape[0], 1, 1, 1, -1)
        grad_x = grad_w = None
        if ctx.needs_input_grad[0]:
            grad_x = torch.zeros_like(x)
            for t, (dy, dx) in enumerate(ctx.offsets):
                grad_x[:, :, dy:dy + h, dx:dx + w].addcmul_(grad, wt[..., t])
        if ctx.needs_input_grad[1]:
            dims = (1, 2, 3) if weights.shape[0] > 1 else (0, 1, 2, 3)
            grad_w = torch.stack([(grad * x[:, :, dy:dy + h, dx:dx + w]).sum(dim=dims)
                                  for dy, dx in ctx.offsets], dim=-1).reshape(weights.shape)
        return grad_x, grad_w, None, None, None


def apply_psf(image, kernel):
    """image (N x C x H x W) convolved with :func:`psf_kernel`'s kernels, mirrored borders
    (BORDER_REFLECT_101 at any kernel size). Small kernels run as sums of shifted images (one
    multiply-add per tap: depthwise convolution is slow on CPU), large ones as conv2d."""
    if kernel is None:
        return image
    k, separable = kernel
    n, c, h, w = image.shape
    R = (k.shape[-1] - 1) // 2
    b = k.shape[0]
    if b not in (1, n):
        raise ValueError("psf: per-image parameters for %d images in a batch of %d" % (b, n))
    def pad(x, dim):  # mirrored border of R along dim (2: rows, 3: columns)
        size = x.shape[dim]
        if R < size:  # torch's "reflect" is BORDER_REFLECT_101 (fast)
            return torch.nn.functional.pad(x, (R, R, 0, 0) if dim == 3 else (0, 0, R, R),
                                           mode="reflect")
        index = torch.tensor([_reflect101(i, size) for i in range(-R, size + R)],
                             device=x.device)
        return x.index_select(dim, index)

    k = k.to(image.dtype)
    span = range(2 * R + 1)
    if separable and R <= 16:
        x = _Taps.apply(pad(image, 2), k, [(j, 0) for j in span], h, w)
        return _Taps.apply(pad(x, 3), k, [(0, j) for j in span], h, w)
    x = pad(pad(image, 2), 3)
    if separable:
        k = k[:, :, None] * k[:, None, :]
    if (2 * R + 1) ** 2 <= 121:
        return _Taps.apply(x, k.reshape(b, -1), [(dy, dx) for dy in span for dx in span], h, w)
    groups = n * c if b > 1 else c
    weights = (k.repeat_interleave(c, dim=0) if b > 1 else k.expand(c, *k.shape[1:]))
    x = x.reshape(1, n * c, h + 2 * R, w + 2 * R) if b > 1 else x
    out = torch.nn.functional.conv2d(x, weights.reshape(groups, 1, 2 * R + 1, 2 * R + 1),
                                     groups=groups)
    return out.reshape(n, c, h, w)


# ---- noise and camera ---------------------------------------------------------------------------

_M64 = (1 << 64) - 1


def _mix64(z):
    z = ((z ^ (z >> 30)) * 0xbf58476d1ce4e5b9) & _M64
    z = ((z ^ (z >> 27)) * 0x94d049bb133111eb) & _M64
    return z ^ (z >> 31)


def _random_key(seed, stream):
    return _mix64(_mix64(seed) ^ ((stream * 0x9e3779b97f4a7c15 + 1) & _M64))


def _hash32(x):
    x = x ^ (x >> _np.uint32(16))
    x = x * _np.uint32(0x7feb352d)
    x = x ^ (x >> _np.uint32(15))
    x = x * _np.uint32(0x846ca68b)
    return x ^ (x >> _np.uint32(16))


def _fast_log(x):
    """noise.cc's FastLog in float32 (the same operations)."""
    f = _np.float32
    bits = x.view(_np.uint32)
    e = (bits >> _np.uint32(23)).astype(_np.int32) - 127
    m = ((bits & _np.uint32(0x007fffff)) | _np.uint32(0x3f800000)).view(_np.float32)
    big = (m > f(1.41421356)).astype(_np.int32)
    m = m * (f(1.0) - f(0.5) * big.astype(_np.float32))
    e = e + big
    s = (m - f(1.0)) / (m + f(1.0))
    s2 = s * s
    series = s * (f(2.0) + s2 * (f(0.6666666667) + s2 * (f(0.4) + s2 * (
        f(0.2857142857) + s2 * f(0.2222222222)))))
    return series + e.astype(_np.float32) * f(0.69314718056)


def _fast_sincos(u):
    f = _np.float32
    quarters = u * f(4.0)
    q = (quarters + f(0.5)).astype(_np.int32)
    theta = (quarters - q.astype(_np.float32)) * f(1.5707963268)
    t2 = theta * theta
    s = theta * (f(1.0) + t2 * (f(-1.0 / 6) + t2 * (f(1.0 / 120) + t2 * (
        f(-1.0 / 5040) + t2 * f(1.0 / 362880)))))
    c = f(1.0) + t2 * (f(-0.5) + t2 * (f(1.0 / 24) + t2 * (f(-1.0 / 720) + t2 * f(1.0 / 40320))))
    swap = (q & 1).astype(_np.float32)
    sin_sign = f(1.0) - f(2.0) * ((q >> 1) & 1).astype(_np.float32)
    cos_sign = f(1.0) - f(2.0) * (((q + 1) >> 1) & 1).astype(_np.float32)
    return sin_sign * (s + swap * (c - s)), cos_sign * (c + swap * (s - c))


def standard_normals(seed, count):
    """The renderer's standard normals of its sensor stream for ``seed``: samples 0 .. count - 1
    (RandomNormals of noise.cc, bit for bit), float32 NumPy. Sample y * W * C + x * C + c is
    the noise of pixel (x, y), channel c in the C++ image's order (B, G, R for colour)."""
    key = _random_key(int(seed), 2)
    k1, k2 = _np.uint32(key & 0xffffffff), _np.uint32(key >> 32)
    pairs = (count + 1) // 2
    if pairs >= 1 << 32:
        raise ValueError("standard_normals: too many samples")
    j = _np.arange(pairs, dtype=_np.uint32)
    with _np.errstate(over="ignore"):
        a = _hash32(j ^ k1)  # the high word of the pair counter is 0 below 2^32 pairs
        b1 = _hash32(a ^ k2)
        b2 = _hash32((a + _np.uint32(0x9e3779b9)) ^ k2)
    f = _np.float32
    u1 = ((b1 >> _np.uint32(8)).astype(_np.int32).astype(_np.float32) + f(1.0)) * f(1.0 / 16777216.0)
    u2 = (b2 >> _np.uint32(8)).astype(_np.int32).astype(_np.float32) * f(1.0 / 16777216.0)
    radius = _np.sqrt(f(-2.0) * _fast_log(u1))
    s, c = _fast_sincos(u2)
    out = _np.empty(2 * pairs, dtype=_np.float32)
    out[0::2] = radius * c
    out[1::2] = radius * s
    return out[:count]


def _seeds(seed, P, n):
    if seed is None:
        seed = P.raw("seed")
    if isinstance(seed, _numbers.Integral):
        return [int(seed) + i for i in range(n)]
    seeds = [int(s) for s in (seed.tolist() if _is_tensor(seed) else seed)]
    if len(seeds) != n:
        raise ValueError("seed: one integer or %d (one per image), got %d" % (n, len(seeds)))
    return seeds


def _normals_like(image, seeds):
    """Per image the renderer's sensor normals for its seed, laid out as the image (N x C x H x W,
    channels R, G, B: the C++ image holds B, G, R)."""
    n, c, h, w = image.shape
    out = _np.empty((n, c, h, w), dtype=_np.float32)
    for i, s in enumerate(seeds):
        z = standard_normals(s, h * w * c).reshape(h, w, c)
        if c == 3:
            z = z[:, :, ::-1]
        out[i] = z.transpose(2, 0, 1)
    return torch.from_numpy(out).to(device=image.device, dtype=image.dtype)


def _torch_normals(image, seeds):
    """Standard normals from torch's generator, one stream per image seeded by its seed (fast,
    on the image's device; not the renderer's stream)."""
    out = torch.empty_like(image)
    for i, s in enumerate(seeds):
        g = torch.Generator(device=image.device)
        g.manual_seed(int(s) & ((1 << 63) - 1))
        out[i] = torch.randn(image.shape[1:], generator=g, device=image.device,
                             dtype=image.dtype)
    return out


def sensor_noise(image, P, seeds, normals=None, source="turbid"):
    """Poisson-Gaussian noise by reparameterisation: image + z sqrt(max(image, 0) / photons +
    read^2) with z standard normals, so gradients flow to the image, ``sensor.photons_at_white``
    and ``sensor.read_noise``. z: ``normals`` if given, else per image from its seed: the
    renderer's own normals (``source="turbid"``: the same noise as turbid.render) or torch's
    generator (``"torch"``: about 7x faster on CPU, generated on the device)."""
    n = image.shape[0]
    photons = P.scalar("sensor.photons_at_white", image, n)
    read = P.scalar("sensor.read_noise", image, n)
    if normals is not None:
        z = normals
    elif source == "turbid":
        z = _normals_like(image, seeds)
    elif source == "torch":
        z = _torch_normals(image, seeds)
    else:
        raise ValueError("noise: 'turbid' (the renderer's normals) or 'torch', not %r" % source)
    shot = torch.where(photons > 0, 1.0 / torch.where(photons > 0, photons,
                                                       torch.ones_like(photons)),
                       torch.zeros_like(photons))
    variance = torch.addcmul(read * read, torch.clamp(image, min=0.0), shot)
    if bool((read > 0).all()):
        return torch.addcmul(image, z, torch.sqrt(variance))
    # d sqrt(v) at v = 0 is infinite: keep the gradient finite where there is no noise at all.
    safe = torch.where(variance > 0, variance, torch.ones_like(variance))
    return image + z * torch.where(variance > 0, torch.sqrt(safe), torch.zeros_like(variance))


def _srgb_decode(c):
    return _np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


_TABLES = {}


def _srgb_tables(bits, device):
    key = (bits, str(device))
    if key not in _TABLES:
        levels = (1 << bits) - 1
        k = _np.arange(levels, dtype=_np.float64)
        threshold = _srgb_decode((k + 0.5) / levels)
        decoded = _srgb_decode(_np.arange(levels + 1, dtype=_np.float64) / levels).astype(
            _np.float32)
        _TABLES[key] = (torch.from_numpy(threshold).to(device),
                        torch.from_numpy(decoded).to(device))
    return _TABLES[key]


def camera(image, P):
    """The camera (docs/model.md "Camera"): clip to [0, 1]; for bit depth 8 / 16 the value of its
    integer code (sRGB or linear encoding), i.e. what the renderer keeps in memory. The
    quantisation passes gradients straight through (the clip does not)."""
    clipped = torch.clamp(torch.nan_to_num(image, nan=0.0), 0.0, 1.0)
    bits = P.raw("camera.bit_depth")
    if bits == 32:
        return clipped
    with torch.no_grad():
        if P.raw("camera.encoding") == "srgb":
            threshold, decoded = _srgb_tables(bits, image.device)
            v = clipped.float().double()
            code = torch.searchsorted(threshold, v.reshape(-1), right=True).reshape(v.shape)
            q = decoded[code].to(image.dtype)
        else:
            levels = 255.0 if bits == 8 else 65535.0
            v = clipped.float()
            q = (torch.floor(v * levels + 0.5) / levels).to(image.dtype)
    return clipped + (q - clipped).detach()


# ---- marine snow --------------------------------------------------------------------------------


def _uniforms(key, index):
    """RandomUniform(key, index) of noise.cc for a uint64 array of indices (float64)."""
    with _np.errstate(over="ignore"):
        z = _np.uint64(key) + (index + _np.uint64(1)) * _np.uint64(0x9e3779b97f4a7c15)
        z = (z ^ (z >> _np.uint64(30))) * _np.uint64(0xbf58476d1ce4e5b9)
        z = (z ^ (z >> _np.uint64(27))) * _np.uint64(0x94d049bb133111eb)
        z = z ^ (z >> _np.uint64(31))
    return ((z >> _np.uint64(11)).astype(_np.float64) + 0.5) * (1.0 / 9007199254740992.0)


def _lround(x):
    """std::lround: halves away from zero."""
    return _np.where(x >= 0, _np.floor(x + 0.5), -_np.floor(-x + 0.5)).astype(_np.int64)


def snow_particles(snow, fx, fy, cx, cy, h, w, range_m, seed):
    """The renderer's draw of marine-snow particles for one image (DrawMarineSnow of noise.cc):
    dict of NumPy arrays for the particles in front of the scene (u, v, range, point x y z,
    peak_scale, sigma2, reach) and the count drawn. range_m: H x W NumPy (NaN: open water)."""
    near3, far3 = snow["near_m"] ** 3, snow["far_m"] ** 3
    expected = snow["density_per_m3"] * (w / abs(fx)) * (h / abs(fy)) * (far3 - near3) / 3.0
    if not expected <= 1e6:
        raise ValueError("snow: density_per_m3 x frustum volume gives %g particles (at most 1e6)"
                         % expected)
    count = int(_math.floor(expected + 0.5))
    key = _random_key(int(seed), 1)
    base = _np.arange(count, dtype=_np.uint64) * _np.uint64(8)
    draw = [_uniforms(key, base + _np.uint64(k)) for k in range(5)]
    u = draw[0] * w - 0.5
    v = draw[1] * h - 0.5
    z = _np.cbrt(near3 + draw[2] * (far3 - near3))
    lo, hi = _math.log(snow["size_min_m"]), _math.log(snow["size_max_m"])
    diameter = _np.exp(lo + draw[3] * (hi - lo))
    albedo = snow["albedo_min"] + draw[4] * (snow["albedo_max"] - snow["albedo_min"])
    x3 = (u - cx) / fx * z
    y3 = (v - cy) / fy * z
    rng = _np.sqrt(x3 * x3 + y3 * y3 + z * z)
    px = _np.clip(_lround(u), 0, w - 1)
    py = _np.clip(_lround(v), 0, h - 1)
    surface = range_m[py, px].astype(_np.float64)
    keep = _np.isnan(surface) | (surface > rng)
    radius = 0.5 * diameter * _math.sqrt(abs(fx * fy)) / z
    sigma2 = 0.5 * radius * radius + snow["blur_px"] ** 2
    reach = _np.minimum(_np.ceil(3.0 * _np.sqrt(sigma2)), 200).astype(_np.int64)
    out = {"u": u, "v": v, "range": rng, "x": x3, "y": y3, "z": z, "albedo": albedo,
           "peak_scale": radius * radius / (2.0 * sigma2), "sigma2": sigma2, "reach": reach}
    return {k: a[keep] for k, a in out.items()}, count


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


def render(albedo, depth, K, params=None, seed=None, *, normals=None, channel_axis=-3,
           maps=None, noise="turbid"):
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
    """
    rho = _images(albedo, channel_axis)
    P = resolve(params)
    n, c, h, w = rho.shape
    depth = _depth4(depth).to(device=rho.device)
    if depth.shape[0] not in (1, n) or depth.shape[-2:] != (h, w):
        raise ValueError("depth: shape %s for albedo %s" % (tuple(depth.shape), tuple(rho.shape)))
    depth = depth.expand(n, 1, h, w)
    model = P.raw("model")
    if model not in ("paper", "revised"):
        raise ValueError("turbid.torch: model %r is not in the differentiable model (paper, "
                         "revised)" % model)
    if P.raw("veil") != "paper":
        raise ValueError("turbid.torch: veil %r is not in the differentiable model (paper)"
                         % P.raw("veil"))
    if model == "revised" and P.raw("water.iop") and P.raw("revised.from_iop"):
        raise ValueError("turbid.torch: revised with water.iop (tabulated beta^D(r)) is not in the "
                         "differentiable model; set revised.from_iop false")
    snow = P.raw("snow")
    if any(k[0] == "snow" for k in P.tensors):
        raise ValueError("turbid.torch: snow parameters are fixed numbers (the draw is not "
                         "differentiable)")
    valid = _valid(depth)
    r = range_from_depth(depth, K).to(rho.dtype)
    if bool(valid.all()):
        r0, keep = r, (lambda t: t)  # noqa: E731
    else:  # open water: t = 0 (and no NaN in the gradients)
        r0 = torch.where(valid, r, torch.zeros_like(r))
        keep = (lambda t: t * valid)  # noqa: E731
    beta = P.channels("water", "beta_rgb_per_m", "beta_gray_per_m", rho, n, c)
    ambient = P.channels("water", "ambient_rgb", "ambient_gray", rho, n, c)
    if normals is None:
        if P.raw("light.lights"):
            normals = normals_from_depth(depth, K)
    else:
        normals = torch.as_tensor(normals, device=rho.device)
        if normals.ndim == 3:
            normals = normals[None]
        if channel_axis in (-1, 3):
            normals = normals.permute(0, 3, 1, 2)
        normals = normals.expand(n, 3, h, w)
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
        jb = apply_psf(lit, psf_kernel(P, rho, n))
    if model == "revised":
        beta_b = P.channels("revised", "beta_b_rgb_per_m", "beta_b_gray_per_m", rho, n, c)
        t = keep(torch.exp(-beta_d * r0))
        t_b = keep(torch.exp(-beta_b * r0))
        bs = P.channels("water", "backscatter_rgb", "backscatter_gray", rho, n, c)
    else:
        t = t_b = keep(torch.exp(-beta * r0))
        bs = (P.channels("water", "backscatter_rgb", "backscatter_gray", rho, n, c)
              if P.raw("water.backscatter") else None)
    veil_light = e if bs is None else (bs if e is None else e + bs)
    if veil_light is None:
        image, veil = jb * t, None
    elif t_b is t and maps is None:  # jb t + (1 - t) v = v + t (jb - v): two passes fewer
        image, veil = torch.addcmul(veil_light, t, jb - veil_light), None
    else:
        veil = (1.0 - t_b) * veil_light
        image = torch.addcmul(veil, jb, t)
    if snow["enabled"] and snow["density_per_m3"] > 0:
        image = image + snow_layer(P, K, r, beta, ambient, rho, _seeds(seed, P, n))
    sensor = P.raw("sensor")
    if sensor["enabled"] and (sensor["photons_at_white"] > 0 or sensor["read_noise"] > 0 or any(
            k[0] == "sensor" for k in P.tensors)):
        image = sensor_noise(image, P, _seeds(seed, P, n), source=noise)
    if "camera" in P.given:
        image = camera(image, P)
    if channel_axis in (-1, 3):
        image = image.permute(0, 2, 3, 1)
    if maps is None:
        return image
    out = {}
    for name in maps:
        if name == "transmission":
            value = t.expand(n, c, h, w)
        elif name == "light":
            value = e if e is not None else torch.zeros_like(rho)
        elif name == "veil":
            value = veil if veil is not None else torch.zeros_like(rho)
        elif name == "lit":
            value = lit
        else:
            raise ValueError("maps: unknown map %r (transmission, light, veil, lit)" % name)
        out[name] = value.permute(0, 2, 3, 1) if channel_axis in (-1, 3) else value
    return image, out
