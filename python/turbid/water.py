"""The water of real underwater RGB-D, from NumPy: Sea-thru's fit (Akkaynak & Treibitz, CVPR 2019).

:func:`fit` runs the same C++ as ``turbid water fit`` (docs/cli/water.md: the procedure, its
options and where it departs from the paper) on arrays instead of scene files, so a frame gives
the numbers the CLI writes. Its ``params`` are a render-parameter dict (model ``revised``) that
:func:`turbid.render` takes as it is, and that a ``turbid generate`` config's ``"water_from"``
takes when saved as JSON.
"""

import collections as _collections
import json as _json
import numbers as _numbers

import numpy as _np

from . import _turbid
from . import _arrays

__all__ = ["fit", "WaterFit"]

WaterFit = _collections.namedtuple("WaterFit", ["params", "diagnostics", "plot"])
WaterFit.__doc__ = """The result of :func:`fit`.

``params``: the render-parameter dict ``turbid water fit`` writes to FIT.json (``model``
``revised``, ``water``, ``revised``, ``light``); ``diagnostics``: the dict of FIT.diagnostics.json
(every fitted value, residuals, per-bin values, the options); ``plot``: FIT.plot.png's figure,
float32 RGB H x W x 3 (dark pixels against range with B_c(r); beta^D per bin with beta^D_c(r))."""


def _intrinsics(k, what):
    """(fx, fy, cx, cy) from a 3 x 3 matrix or four numbers; None stays None."""
    if k is None:
        return None
    a = _np.asarray(k, dtype=_np.float64)
    if a.shape == (3, 3):
        return (float(a[0, 0]), float(a[1, 1]), float(a[0, 2]), float(a[1, 2]))
    if a.shape == (4,):
        return tuple(float(x) for x in a)
    raise ValueError("%s: a 3 x 3 matrix or (fx, fy, cx, cy), not shape %s" % (what, a.shape))


def _is_one_k(k):
    """True when ``k`` is one camera (3 x 3 or four numbers), not a list of them."""
    if k is None or isinstance(k, _np.ndarray):
        return True
    seq = list(k)
    return len(seq) == 4 and all(isinstance(x, _numbers.Real) for x in seq) or (
        len(seq) == 3 and all(not isinstance(x, _numbers.Real) and len(x) == 3 for x in seq)
        and all(isinstance(y, _numbers.Real) for x in seq for y in x))


def fit(image, depth, K=None, depth_kind=None, encoding=None, options=None, channel_axis=-1):
    """Fit Sea-thru's water to one frame, or to several frames of the same water at once.

    ``image``: H x W x 3 RGB, float32 linear light in [0, 1], or uint8 / uint16 with
    ``encoding`` ("linear": Sea-thru's PNGs; "srgb": camera JPEG/TIFF output); a list for several
    frames. ``depth``: H x W metres on the image's grid (0, negative or NaN where unknown); a list
    with one per image. ``K``: the pinhole intrinsics (3 x 3 or (fx, fy, cx, cy), pixels), one for
    all frames or a list with one per frame (None entries allowed); ``depth_kind``: "z" (depth
    along the optical axis, the default with ``K``: converted to range along the ray) or "range"
    (used as it is). Without ``K`` the depth is taken as range (a scene file's ``"camera":
    "unknown"``). ``options``: dict of the fit options of ``turbid water fit --options``
    (range_bins, dark_percent, illuminant_layers, illuminant_extent, attenuation_bins,
    fit_illuminant_scale; strict). Returns :class:`WaterFit` (params, diagnostics, plot).
    Raises ValueError for bad arrays or options and when the frames hold too few valid ranges."""
    if depth_kind not in (None, "z", "range"):
        raise ValueError("depth_kind: 'z' or 'range', not %r" % (depth_kind,))
    several = isinstance(image, (list, tuple))
    images = list(image) if several else [image]
    if several != isinstance(depth, (list, tuple)):
        raise ValueError("image and depth: both one array or both lists of the same length")
    depths = list(depth) if several else [depth]
    if len(depths) != len(images):
        raise ValueError("depth: %d maps for %d images" % (len(depths), len(images)))
    if not images:
        raise ValueError("image: no frames")
    if _is_one_k(K):
        ks = [K] * len(images)
    else:
        ks = list(K)
        if len(ks) != len(images):
            raise ValueError("K: %d cameras for %d images" % (len(ks), len(images)))
    names = ["image"] if not several else ["image[%d]" % i for i in range(len(images))]
    arrays, depth_arrays, cams = [], [], []
    for i, name in enumerate(names):
        a, _ = _arrays.single(images[i], name, channel_axis)
        if a.ndim != 3 or a.shape[2] != 3:
            raise ValueError("%s: water fit needs an RGB image (H x W x 3)" % name)
        d, _ = _arrays.single(depths[i], name.replace("image", "depth"), color=False,
                              float_only=True)
        if d.ndim == 3:
            d = _np.ascontiguousarray(d[:, :, 0])
        arrays.append(a)
        depth_arrays.append(d)
        k = _intrinsics(ks[i], "K" if not several else "K[%d]" % i)
        if k is None and depth_kind == "z":
            raise ValueError("depth_kind='z' needs K (the intrinsics) to turn z-depth into range")
        # The depth is converted to range with K unless it is range already.
        cams.append(None if depth_kind == "range" else k)
    if options is None:
        options = {}
    if not isinstance(options, dict):
        raise TypeError("options: a dict, not %s" % type(options).__name__)
    params, diagnostics, plot = _turbid.water_fit(arrays, depth_arrays, cams, encoding,
                                                  _json.dumps(options))
    return WaterFit(_json.loads(params), _json.loads(diagnostics), plot)
