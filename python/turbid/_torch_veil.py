"""turbid.torch's single-scatter veil (render option ``veil: "single_scatter"``): a transcription
of simulator/veil.cc's fast path in torch operations, differentiable in the water (beta = c, the
scattering albedo through b = omega c) and the lamps (power, position, axis, colour).

    V_c(x) = pi integral_0^R b_c p(theta(s)) E_c(s) exp(-c_c s) ds,
    E_c(s) = sum_k colour_k,c U0_k cos^m(phi_k(s)) exp(-c_c l_k(s)) / l_k(s)^2

with the renderer's quadrature: s = a u / (1 - u) (a = the nearest lamp's distance from the
camera, clamped to [0.05, 10] m), Simpson's rule on 48 segments in u on a coarse grid of view rays
(every 5 degrees of field, and the last row and column), the phase function tabulated at 8192
values uniform in cos theta (the table is the renderer's own, turbid._turbid._phase_table: it is a
constant, not differentiated), each pixel bilinear between the four tables around it and cubic
Hermite in u at its own range. Sums along a ray are kept in float64 and the tables rounded to the
image's precision, as the C++ does. Public entry: :func:`single_scatter_veil`."""

import json as _json
import math as _math

import torch

_SEGMENTS = 48
_PHASE_N = 8192
_PHASE = {}


def _phase_table(water, device):
    """The renderer's phase-function table for the water's ``phase`` section (float32 values used
    in double arithmetic, as Context::Phase)."""
    key = (_json.dumps(water["phase"], sort_keys=True), str(device))
    if key not in _PHASE:
        import turbid._turbid as native
        text = _json.dumps({"water": {"phase": water["phase"]}})
        table = torch.from_numpy(native._phase_table(text, _PHASE_N)).double().to(device)
        if len(_PHASE) > 8:
            _PHASE.clear()
        _PHASE[key] = table
    return _PHASE[key]


def _axis_nodes(n, step):
    """Axis of veil.cc: the nodes (every ``step`` pixels and the last), for each pixel the node
    before it and the weight of the node after it (float32, as the C++)."""
    nodes = list(range(0, n - 1, step)) + [n - 1]
    before, offset, span = [], [], []
    k = 0
    for i in range(n):
        while k + 2 < len(nodes) and nodes[k + 1] <= i:
            k += 1
        before.append(k)
        offset.append(i - nodes[k] if len(nodes) > 1 else 0)
        span.append(nodes[k + 1] - nodes[k] if len(nodes) > 1 else 1)
    if len(nodes) == 1:
        nodes.append(nodes[0])
    # static_cast<float>(i - node) / span: a float division.
    weight = torch.tensor(offset, dtype=torch.float32) / torch.tensor(span, dtype=torch.float32)
    return nodes, before, weight


def _grid_step(fx, fy):
    focal = min(abs(fx), abs(fy))
    x = 0.0874886635 * focal
    step = int(_math.floor(x + 0.5)) if x >= 0 else -int(_math.floor(-x + 0.5))  # lround
    return min(max(step, 1), 64)


def _phase(table, cos_theta):
    """Context::Phase: linear in the table by (1 - cos theta) (float64)."""
    scale = 0.5 * (table.numel() - 1)
    x = torch.clamp((1.0 - cos_theta) * scale, 0.0, scale * 2.0)
    i = torch.clamp(x.detach().floor().long(), max=table.numel() - 2)
    f = x - i.to(x.dtype)
    lo, hi = table[i], table[i + 1]
    return lo + f * (hi - lo)


def _integrand(lamps, c, min_l, table, d, s):
    """Context::Integrand at P = s d for every ray and sample: d (B, R, 1, 3), s (B, 1, U) ->
    (B, R, U, C), float64."""
    total = 0.0
    for lamp in lamps:
        pos = lamp["position"][:, None, None, :]  # B x 1 x 1 x 3
        v = s[..., None] * d - pos                # B x R x U x 3
        l_true = torch.linalg.vector_norm(v, dim=-1)
        safe = torch.where(l_true > 0, l_true, torch.ones_like(l_true))
        cos_phi = (v * lamp["axis"][:, None, None, :]).sum(-1) / safe
        lit = (l_true > 0) & (cos_phi > 0) & (cos_phi >= lamp["cos_cutoff"])
        l = torch.clamp(l_true, min=min_l)
        cp = torch.clamp(cos_phi, min=0.0)
        order = lamp["order"]
        if order == 1.0:
            profile = cp
        elif order == 2.0:
            profile = cp * cp
        else:
            profile = torch.exp(order * torch.log(torch.clamp(cp, min=1e-300)))
        cos_theta = -(v * d).sum(-1) / safe
        geometry = profile * _phase(table, cos_theta) / (l * l)
        geometry = torch.where(lit, geometry, torch.zeros_like(geometry))
        att = torch.exp(-c[:, None, None, :] * (s[..., None] + l[..., None]))  # B x R x U x C
        total = total + lamp["weight"][:, None, None, :] * geometry[..., None] * att
    return total


def _tables(lamps, c, min_l, table, a, rays):
    """F (cumulative) and G = dF/du at u_j = j / M for every ray, Simpson's rule per segment:
    rays (B, R, 3) unit, a (B,) -> F, G (B, R, M + 1, C), float64."""
    m = _SEGMENTS
    du = 1.0 / m
    # Breakpoints j du (j < M; u = 1 at the end: s = infinity, no light) and midpoints (j + 1/2) du.
    ends = torch.tensor([j * du for j in range(m)], dtype=torch.float64, device=rays.device)
    mids = torch.tensor([(j + 0.5) * du for j in range(m)], dtype=torch.float64,
                        device=rays.device)
    u = torch.cat([ends, mids])
    s = a[:, None, None] * u / (1.0 - u)                          # B x 1 x 2M
    ds = (a[:, None] / ((1.0 - u) * (1.0 - u)))[:, None, :, None]  # B x 1 x 2M x 1
    g = _integrand(lamps, c, min_l, table, rays[:, :, None, :], s) * ds
    b, r, _, ch = g.shape
    g_end = torch.cat([g[:, :, :m], torch.zeros(b, r, 1, ch, dtype=g.dtype, device=g.device)], 2)
    g_mid = g[:, :, m:]
    seg = du / 6.0 * (g_end[:, :, :-1] + 4.0 * g_mid + g_end[:, :, 1:])
    f = torch.cat([torch.zeros(b, r, 1, ch, dtype=g.dtype, device=g.device),
                   torch.cumsum(seg, dim=2)], 2)
    return f, g_end


def _veil_of(lamps, c, min_l, table, fx, fy, cx, cy, r, a, dtype):
    """V (B x C x H x W) for one camera: r (B x 1 x H x W, NaN: open water)."""
    b, _, h, w = r.shape
    step = _grid_step(fx, fy)
    nodes_x, before_x, weight_x = _axis_nodes(w, step)
    nodes_y, before_y, weight_y = _axis_nodes(h, step)
    nx, ny = len(nodes_x), len(nodes_y)
    dev = r.device
    gx = (torch.tensor(nodes_x, dtype=torch.float64, device=dev) - cx) / fx
    gy = (torch.tensor(nodes_y, dtype=torch.float64, device=dev) - cy) / fy
    ray = torch.stack([gx[None, :].expand(ny, nx), gy[:, None].expand(ny, nx),
                       torch.ones(ny, nx, dtype=torch.float64, device=dev)], -1)
    ray = (ray / torch.linalg.vector_norm(ray, dim=-1, keepdim=True)).reshape(1, ny * nx, 3)
    bt = max(a.shape[0], c.shape[0], *(lamp["weight"].shape[0] for lamp in lamps))
    f, g = _tables(lamps, c, min_l, table, a.expand(bt), ray.expand(bt, -1, -1))
    f, g = f.to(dtype), g.to(dtype)  # the renderer's float tables
    m = _SEGMENTS
    ch = f.shape[-1]
    # Per pixel: u at its range, the segment, the Hermite weights (in the image's precision).
    af = a.to(dtype).reshape(-1, 1, 1, 1)
    finite = torch.isfinite(r) & (r < 3e38)
    rr = torch.where(finite, r, torch.zeros_like(r)).to(dtype)
    u = torch.where(finite, rr / (rr + af), torch.ones_like(rr))   # B x 1 x H x W
    xs = u * m
    seg = torch.clamp(xs.detach().floor().long(), max=m - 1)
    t = xs - seg.to(dtype)
    t2 = t * t
    t3 = t2 * t
    h00, h01 = 2 * t3 - 3 * t2 + 1, -2 * t3 + 3 * t2
    h10, h11 = (t3 - 2 * t2 + t) * (1.0 / m), (t3 - t2) * (1.0 / m)
    # The four tables around each pixel (node row j or j + 1, column k or k + 1), bilinear as the
    # renderer (to float rounding), for the four numbers Hermite needs at the pixel's segment: F
    # and G at the segment's two ends. One grid_sample over a volume of (segment, node row, node
    # column) with the segment coordinate on its integer: one fused kernel forward and backward
    # (sixteen gathers and their arithmetic cost 4-8x more).
    bn = max(bt, r.shape[0])
    ends = torch.stack([f[:, :, :-1], f[:, :, 1:], g[:, :, :-1], g[:, :, 1:]], 1)  # B4RMC
    ends = ends.permute(0, 1, 4, 3, 2).reshape(bt, 4 * ch, m, ny, nx).expand(bn, -1, -1, -1, -1)
    f64 = torch.float64
    by = torch.tensor(before_y, dtype=f64, device=dev) + weight_y.to(device=dev, dtype=f64)
    bx = torch.tensor(before_x, dtype=f64, device=dev) + weight_x.to(device=dev, dtype=f64)
    gy = (2.0 * by / (ny - 1) - 1.0).reshape(1, 1, h, 1).expand(bn, 1, h, w)
    gx = (2.0 * bx / (nx - 1) - 1.0).reshape(1, 1, 1, w).expand(bn, 1, h, w)
    gz = (2.0 * seg.to(f64) / (m - 1) - 1.0).expand(bn, 1, h, w)
    grid = torch.stack([gx, gy, gz], -1).to(dtype)  # B x 1 x H x W x 3 (x, y, z)
    v = torch.nn.functional.grid_sample(ends, grid, mode="bilinear", padding_mode="border",
                                        align_corners=True).reshape(bn, 4, ch, h, w)
    value = h00 * v[:, 0] + h01 * v[:, 1] + h10 * v[:, 2] + h11 * v[:, 3]
    return torch.clamp(value, min=0.0)


def single_scatter_veil(P, K_parts, r, beta, like, n, c, lamp_values):
    """V (N x C x H x W) of veil "single_scatter" (simulator/veil.h) for the batch: r the range
    (N x 1 x H x W, NaN where there is no surface: integrated to infinity), beta (B x C x 1 x 1)
    the beam attenuation c. K_parts: fx, fy, cx, cy (lists of N floats); lamp_values: per lamp
    a dict of position (B x 3), axis (B x 3, unit), power (B), colour (B x C), order, cos_cutoff.
    None when no lamp shines (every power a number <= 0)."""
    lamps = [dict(lamp) for lamp in lamp_values if lamp["on"]]
    if not lamps:
        return None
    f64 = torch.float64
    omega = P.get("water." + ("scattering_albedo_rgb" if c == 3 else "scattering_albedo_gray"),
                  like, n).reshape(-1, c).to(f64)
    cc = beta.reshape(-1, c).to(f64)
    b = omega * cc
    for lamp in lamps:
        lamp["position"] = lamp["position"].to(f64)
        lamp["axis"] = lamp["axis"].to(f64)
        lamp["weight"] = (_math.pi * lamp["power"].to(f64).reshape(-1, 1)
                          * lamp["colour"].to(f64).reshape(-1, c) * b)
    norms = torch.broadcast_tensors(*[torch.linalg.vector_norm(lamp["position"], dim=1)
                                      for lamp in lamps])
    nearest = torch.stack(norms).min(0).values
    a = torch.clamp(nearest, 0.05, 10.0)
    table = _phase_table(P.raw("water"), like.device)
    min_l = P.raw("light.min_distance_m")
    fx, fy, cx, cy = K_parts
    if len(set(zip(fx, fy, cx, cy))) == 1:
        return _veil_of(lamps, cc, min_l, table, fx[0], fy[0], cx[0], cy[0], r, a,
                        like.dtype).expand(n, c, *r.shape[-2:])
    out = []  # one camera per image: one grid each
    for i in range(n):
        pick = lambda t: t[i:i + 1] if t.shape[0] > 1 else t  # noqa: E731
        mine = [dict(lamp, position=pick(lamp["position"]), axis=pick(lamp["axis"]),
                     weight=pick(lamp["weight"])) for lamp in lamps]
        out.append(_veil_of(mine, pick(cc), min_l, table, fx[i], fy[i], cx[i], cy[i],
                            r[i:i + 1], pick(a), like.dtype))
    return torch.cat(out)
