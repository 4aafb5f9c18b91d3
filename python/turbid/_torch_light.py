"""turbid.torch's lamp irradiance E_L (light.cc's IrradianceAt, paper eq. 3-5) as one autograd
Function with a hand-written backward: the geometry of each lamp (distance, emission and incidence
angles) lives on N x 1 x H x W tensors and the attenuation on N x C x H x W; autograd's op-by-op
graph of the same formula allocated about 30 full-size tensors in forward + backward (0.93 s of
the 64 x 3 x 256 x 256 batch's 3.0 s CPU), this one about 12. Checked by gradcheck
(python/tests/test_torch_model.py, test_torch_speed.py). Used by turbid.torch.irradiance."""

import torch


def _dot(x, y):
    """sum over H, W of x * y (N x K x H x W and N x 1 x H x W, or K x ... broadcast by bmm):
    N x K, without a full-size temporary (a batched matrix product)."""
    n = x.shape[0]
    return torch.bmm(x.reshape(n, x.shape[1], -1), y.reshape(n, -1, 1))[..., 0]


def _to(grad, shape):
    """A per-image gradient (N x ...) summed to a parameter's shape (B x ..., B = 1 or N)."""
    return grad.sum(0, keepdim=True).reshape(shape) if shape[0] == 1 and grad.shape[0] > 1 \
        else grad.reshape(shape)


class Lamp(torch.autograd.Function):
    """E_c = colour_c g exp(-beta_c l), g = U0 inc(cos psi) cos^m(phi) / l^2 for one lamp.

    Inputs: position (B x 3), unit axis (B x 3), power (B), beta (B x C x 1 x 1), colour
    (B x C x 1 x 1, or None: white), and ``geo``: a dict of constant tensors px, py, pz (surface
    points), nx, ny, nz (unit normals) N x 1 x H x W, valid (bool, or None: all) and the numbers
    order, eq5, min_cos, min_l."""

    @staticmethod
    def forward(ctx, pos, axis, power, beta, color, geo):
        n = geo["px"].shape[0]
        ctx.shapes = [None if t is None else t.shape for t in (pos, axis, power, beta, color)]
        pos, axis = pos.reshape(-1, 3, 1, 1), axis.reshape(-1, 3, 1, 1)
        vx, vy, vz = geo["px"] - pos[:, 0:1], geo["py"] - pos[:, 1:2], geo["pz"] - pos[:, 2:3]
        # In the order of operations of turbid.torch's earlier op-by-op E_L (no fused
        # multiply-adds: the renderer's rounding to ~1e-7).
        l_true = (vx * vx).add_(vy * vy).add_(vz * vz).sqrt_()
        along = (axis[:, 0:1] * vx).add_(axis[:, 1:2] * vy).add_(axis[:, 2:3] * vz)
        facing = (geo["nx"] * vx).add_(geo["ny"] * vy).add_(geo["nz"] * vz).neg_()
        apart = l_true > 1e-12
        all_apart = bool(apart.all())
        if all_apart:
            inv = 1.0 / l_true
            cphi, cpsi = along.mul_(inv), facing.mul_(inv)
        else:  # a lamp at a surface point: head-on there (cos phi = cos psi = 1)
            inv = 1.0 / torch.where(apart, l_true, torch.ones_like(l_true))
            one = torch.ones_like(l_true)
            cphi = torch.where(apart, along.mul_(inv), one)
            cpsi = torch.where(apart, facing.mul_(inv), one)
        l = torch.clamp(l_true, min=geo["min_l"])
        if geo["eq5"]:
            incidence = torch.where(cpsi > 0, 1.0 / torch.clamp(cpsi, min=geo["min_cos"]),
                                    torch.zeros_like(cpsi))
        else:
            incidence = torch.clamp(cpsi, min=0.0)
        cphi_c = torch.clamp(cphi, 0.0, 1.0)
        if geo["cos_cutoff"] > 0:  # spot cut-off: cos phi below it counts as 0 (light.cc)
            cphi_c = torch.where(cphi_c >= geo["cos_cutoff"], cphi_c, torch.zeros_like(cphi_c))
        order = geo["order"]
        if geo["whole"]:
            beam = cphi_c if order == 1 else cphi_c ** int(order)
        else:
            beam = torch.exp(order * torch.log(torch.clamp(cphi_c, min=1e-30)))
        # g in the order of operations of light.cc (the rounding of E_L is the renderer's).
        g = power.reshape(-1, 1, 1, 1) * incidence / (l * l) * beam
        valid = geo["valid"]
        if valid is not None:
            g = torch.where(valid, g, torch.zeros_like(g))
            l = torch.where(valid, l, torch.zeros_like(l))
        ex = (l * beta).neg_().exp_()
        e = ex * g
        if color is not None:
            e = e.mul_(color)
        ctx.save_for_backward(pos, axis, power, beta, color, vx, vy, vz, inv, cphi, cpsi, l_true,
                              l, incidence, beam, g, ex)
        ctx.geo = geo
        ctx.all_apart = all_apart
        return e

    @staticmethod
    def backward(ctx, grad):
        (pos, axis, power, beta, color, vx, vy, vz, inv, cphi, cpsi, l_true, l, incidence, beam,
         g, ex) = ctx.saved_tensors
        geo = ctx.geo
        n, c = grad.shape[:2]
        need = ctx.needs_input_grad
        grads = [None] * 6
        gx = grad * ex  # dL/d(colour g) per channel
        if color is not None and need[4]:
            grads[4] = _to(_dot(gx, g), ctx.shapes[4])
        if color is not None:
            gx = gx.mul_(color)
        d_g = gx.sum(1, keepdim=True)  # dL/dg
        if need[2]:  # g / power, 0 where invalid (l = 0 there)
            g0 = incidence / torch.where(l > 0, l * l, torch.ones_like(l)) * beam * (l > 0)
            grads[2] = _to(_dot(d_g, g0)[:, 0], ctx.shapes[2])
        if need[3]:
            grads[3] = _to(-_dot(gx, g * l), ctx.shapes[3])
        if not (need[0] or need[1]):
            return tuple(grads)
        # Through l (exp(-beta l) and 1 / l^2), the incidence and the beam profile.
        b = beta.reshape(-1, 1, c).expand(n, 1, c)
        beta_gx = torch.bmm(b, gx.reshape(n, c, -1)).reshape(l.shape)  # sum_c beta_c gx_c
        d_l = (beta_gx.addcmul_(d_g, 2.0 / torch.where(l > 0, l, torch.ones_like(l)))).mul_(g)
        d_l = d_l.neg_().mul_(l_true > geo["min_l"])  # the clamp at min_distance_m
        scaled = d_g.mul_(power.reshape(-1, 1, 1, 1)).div_(l * l if geo["valid"] is None else
                                                           torch.where(l > 0, l * l, torch.ones_like(l)))
        if geo["valid"] is not None:
            scaled = scaled.mul_(geo["valid"])
        d_inc = scaled * beam
        d_beam = scaled.mul_(incidence)
        order = geo["order"]
        inside = (cphi >= 0) & (cphi <= 1)
        if geo["cos_cutoff"] > 0:
            inside = inside & (torch.clamp(cphi, 0.0, 1.0) >= geo["cos_cutoff"])
        if geo["whole"]:
            k = int(order)
            slope = torch.zeros_like(cphi) if k == 0 else (
                inside.to(cphi.dtype) if k == 1 else k * torch.clamp(cphi, 0.0, 1.0) ** (k - 1)
                * inside)
        else:
            cl = torch.clamp(cphi, 0.0, 1.0)
            slope = order * beam / torch.clamp(cl, min=1e-30) * (inside & (cl >= 1e-30))
        d_cphi = d_beam.mul_(slope)
        if geo["eq5"]:
            d_cpsi = d_inc.mul_(-(incidence * incidence)).mul_((cpsi > 0) & (cpsi >= geo["min_cos"]))
        else:
            d_cpsi = d_inc.mul_(cpsi >= 0)
        if not ctx.all_apart:
            apart = l_true > 1e-12
            d_cphi, d_cpsi = d_cphi.mul_(apart), d_cpsi.mul_(apart)
        a1 = d_cphi.mul_(inv)  # dL/dv = a1 axis - a2 normal + bc v
        a2 = d_cpsi.mul_(inv)
        bc = (d_l - a1 * cphi).sub_(a2 * cpsi).mul_(inv)
        if need[1]:
            vs = torch.cat([vx, vy, vz], dim=1)
            grads[1] = _to(_dot(vs, a1), ctx.shapes[1])
        if need[0]:
            ns = torch.cat([geo["nx"].expand_as(vx), geo["ny"].expand_as(vx),
                            geo["nz"].expand_as(vx)], dim=1)
            vs = torch.cat([vx, vy, vz], dim=1)
            sum_a1 = a1.sum((1, 2, 3)).reshape(n, 1)
            dv = axis.reshape(-1, 3) * sum_a1 - _dot(ns, a2) + _dot(vs, bc)
            grads[0] = _to(-dv, ctx.shapes[0])
        return tuple(grads)


class Veiled(torch.autograd.Function):
    """I = J_b t + (1 - t)(E_L + B_inf), t = exp(-beta r) (0 where ``valid`` is False): eq. 2
    composed when t_B = t (the paper model), in the renderer's order of operations (ComposeVeil
    of render.cc), with three full-size tensors in forward and two or three in backward
    (autograd's graph of the same: five and six). e (N x C x H x W) or None, bs (B x C x 1 x 1)
    or None, beta (B x C x 1 x 1); r (N x 1 x H x W, 0 where invalid) and valid (bool or None)
    are constants."""

    @staticmethod
    def forward(ctx, jb, e, beta, bs, r, valid):
        t = (r * beta).neg_().exp_()
        if valid is not None:
            t = t.mul_(valid)
        v = e if bs is None else (bs if e is None else e + bs)
        if v is None:
            out = jb * t
        else:
            out = torch.rsub(t, 1.0).mul_(v).addcmul_(jb, t)
        ctx.save_for_backward(jb, v, beta, r, t)
        ctx.shapes = [None if x is None else x.shape for x in (beta, bs)]
        return out

    @staticmethod
    def backward(ctx, grad):
        jb, v, beta, r, t = ctx.saved_tensors
        need = ctx.needs_input_grad
        g_jb = grad * t
        g_e = g_beta = g_bs = None
        if need[1]:
            g_e = grad - g_jb
        if need[3]:
            g_bs = _to((grad.sum((2, 3)) - g_jb.sum((2, 3)))[..., None, None], ctx.shapes[1])
        if need[2]:
            d = jb.clone() if v is None else jb - v
            g_beta = _to(-_dot(d.mul_(g_jb), r)[..., None, None], ctx.shapes[0])
        return g_jb if need[0] else None, g_e, g_beta, g_bs, None, None


class Noisy(torch.autograd.Function):
    """I + z sqrt(max(I, 0) shot + read^2) for read > 0 (the sensor noise by reparameterisation,
    noise.cc): two full-size tensors in forward, three in backward. shot = 1 / photons (0: no shot
    noise) and read are B x 1 x 1 x 1; z the standard normals (constant)."""

    @staticmethod
    def forward(ctx, image, shot, read, z):
        sd = torch.clamp(image, min=0.0).mul_(shot).add_(read * read).sqrt_()
        ctx.save_for_backward(image, shot, read, z, sd)
        ctx.shapes = (shot.shape, read.shape)
        return torch.addcmul(image, z, sd)

    @staticmethod
    def backward(ctx, grad):
        image, shot, read, z, sd = ctx.saved_tensors
        need = ctx.needs_input_grad
        q = (grad * z).div_(sd)  # dL/d sd
        g_shot = g_read = None
        if need[1]:
            n = q.shape[0]
            relu = torch.clamp(image, min=0.0).reshape(n, -1, 1)
            g_shot = _to(0.5 * torch.bmm(q.reshape(n, 1, -1), relu).reshape(n), ctx.shapes[0])
        if need[2]:
            g_read = _to(q.sum((1, 2, 3)) * read.reshape(-1), ctx.shapes[1])
        g_image = None
        if need[0]:
            g_image = q.mul_(0.5 * shot).mul_(image >= 0).add_(grad)
        return g_image, g_shot, g_read, None
