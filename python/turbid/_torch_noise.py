"""turbid.torch's sensor noise (the renderer's normals, bit for bit, or torch's), the camera's
encoding and the renderer's marine-snow particle draw: transcriptions of simulator/noise.cc and
scenes/camera_encoding.cc. Public names are re-exported by turbid.torch."""

import math as _math
import numbers as _numbers

import numpy as _np
import torch

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


def _normals_of_seed(seed, count):
    """standard_normals(seed, count) from the renderer itself (RandomNormals, about 20x faster than
    the NumPy transcription) when the extension has it, else the transcription."""
    import turbid._turbid as native
    fn = getattr(native, "_standard_normals", None)
    if fn is None or not 0 <= int(seed) < 1 << 64:
        return standard_normals(seed, count)
    return fn(int(seed), int(count))


def _seeds(seed, P, n):
    if seed is None:
        seed = P.raw("seed")
    if isinstance(seed, _numbers.Integral):
        return [int(seed) + i for i in range(n)]
    seeds = [int(s) for s in (seed.tolist() if isinstance(seed, torch.Tensor) else seed)]
    if len(seeds) != n:
        raise ValueError("seed: one integer or %d (one per image), got %d" % (n, len(seeds)))
    return seeds


def _normals_like(image, seeds):
    """Per image the renderer's sensor normals for its seed, laid out as the image (N x C x H x W,
    channels R, G, B: the C++ image holds B, G, R)."""
    n, c, h, w = image.shape
    out = _np.empty((n, c, h, w), dtype=_np.float32)
    for i, s in enumerate(seeds):
        z = _normals_of_seed(s, h * w * c).reshape(h, w, c)
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
    if bool((read > 0).all()):
        from ._torch_light import Noisy
        return Noisy.apply(image, shot, read, z)
    variance = torch.addcmul(read * read, torch.clamp(image, min=0.0), shot)
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


# ---- marine snow: the particle draw ---------------------------------------------------------------


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
