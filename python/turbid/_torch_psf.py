"""turbid.torch's PSF (paper eq. 7, Metari & Deschenes' generalized Gaussian, and the
turbidity-dependent PSF by levels): transcriptions of simulator/psf.cc in torch operations.
Public names are re-exported by turbid.torch."""

import math as _math

import numpy as _np
import torch

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
