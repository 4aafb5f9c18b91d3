"""turbid: underwater image degradation, enhancement and scoring from NumPy.

The same C++ libraries as the ``turbid`` command line, so the same scene, parameters and seed give
byte-identical images, and ``score`` gives the numbers ``turbid score`` prints.

Arrays: H x W or H x W x 3, **RGB order**, dtype float32 (linear light in [0, 1]), uint8 or uint16
(integer arrays need ``encoding="srgb"`` or ``encoding="linear"``). Outputs are float32 RGB in
[0, 1]. Parameters are the CLI's JSON schema (docs/model.md) as Python dicts. Errors raise
``ValueError`` (bad parameters or data), ``OSError`` (files) or ``RuntimeError`` with the CLI's
one-line message. The GIL is released while C++ runs. Reference: docs/python.md.
"""

import json as _json
import numbers as _numbers
import operator as _operator
import os as _os

import numpy as _np

from . import _turbid

__version__ = _turbid.__version__

__all__ = ["Scene", "RenderResult", "render", "enhance", "methods", "score", "metrics",
           "match_features", "generate", "sweep", "default_params", "resolve_params",
           "read_image", "write_image", "set_num_threads", "get_num_threads", "__version__"]


class Scene:
    """A scene: clean image rho (linear RGB), z-depth in metres, normals and pinhole intrinsics.

    Make one with :meth:`builtin`, :meth:`load` or :meth:`from_arrays`. Attributes (NumPy, read
    only): ``image`` (H x W x 3 RGB or H x W float32), ``depth`` (H x W metres, NaN = invalid),
    ``normals`` (H x W x 3, camera-frame x, y, z), ``range`` (metres along the viewing ray),
    ``camera`` (dict fx, fy, cx, cy, width, height), ``name``, ``width``, ``height``.
    """

    def __init__(self, core):
        self._core = core

    @staticmethod
    def builtin(name, scale=1.0):
        """A procedural built-in scene: "hull", "seafloor" or "room" (``builtin:NAME`` works too).

        ``scale`` in (0, 1] shrinks it (hull is 1360 x 1024, seafloor and room 640 x 480)."""
        return Scene(_turbid.Scene.builtin(str(name), float(scale)))

    @staticmethod
    def load(path):
        """A scene JSON file (docs/formats.md, "Scene files"), read as ``turbid render --scene``;
        ``"FILE.json#KEY"`` picks one frame of a multi-frame (``nyu_v2``, ``folder``) file."""
        return Scene(_turbid.Scene.load(_os.fspath(path)))

    @staticmethod
    def frames(path):
        """The single-frame specs a scene file stands for: ``"FILE.json#KEY"`` for every frame a
        ``nyu_v2`` or ``folder`` file selects (pass each to :meth:`load`); ``[path]`` otherwise."""
        return list(_turbid.expand_scene_spec(_os.fspath(path)))

    @staticmethod
    def from_arrays(image, depth_m, fx, fy, cx, cy, normals=None, name="arrays", encoding=None):
        """A scene from arrays: ``image`` RGB (float32 linear, or uint8/uint16 with ``encoding``),
        ``depth_m`` float32 H x W z-depth in metres (NaN where unknown), pinhole intrinsics in
        pixels; ``normals`` (optional, float32 H x W x 3, camera frame) else derived from depth."""
        return Scene(_turbid.Scene.from_arrays(
            _array(image, "image"), _array(depth_m, "depth_m", color=False, float_only=True),
            float(fx), float(fy), float(cx), float(cy),
            _optional_array(normals, "normals", float_only=True), str(name), encoding))

    name = property(lambda self: self._core.name)
    spec = property(lambda self: self._core.spec)
    width = property(lambda self: self._core.width)
    height = property(lambda self: self._core.height)
    image = property(lambda self: self._core.image)
    depth = property(lambda self: self._core.depth)
    normals = property(lambda self: self._core.normals)
    range = property(lambda self: self._core.range)
    camera = property(lambda self: self._core.camera)

    def __repr__(self):
        return "turbid.Scene(%r, %dx%d)" % (self.name, self.width, self.height)


class RenderResult:
    """What :func:`render` returns. ``image``: the degraded image I (float32 RGB [0, 1], quantised
    as the camera's bit depth says); ``lit``: J = (E_A + E_L) rho, the lit ground truth; ``maps``:
    dict of the requested maps (transmission, light, veil, psf, noise); ``sidecar``: the dict the
    CLI writes as OUT.json; ``plan``: what was computed and skipped. Arrays are converted on first
    access."""

    def __init__(self, core, maps):
        self._core = core
        self._names = maps
        self._cache = {}

    def _get(self, key, make):
        if key not in self._cache:
            self._cache[key] = make()
        return self._cache[key]

    image = property(lambda self: self._get("image", self._core.image))
    lit = property(lambda self: self._get("lit", self._core.lit))
    maps = property(lambda self: self._get(
        "maps", lambda: {n: self._core.map(n) for n in self._names}))
    sidecar = property(lambda self: self._get("sidecar", lambda: _json.loads(self._core.sidecar())))
    plan = property(lambda self: self._core.plan())


def _first_line(error):
    text = str(error).strip().splitlines()
    text = text[0] if text else type(error).__name__
    return text if len(text) <= 160 else text[:157] + "..."


def _to_numpy(value, what):
    """``value`` as a NumPy array, sharing its memory where it can, or one short TypeError."""
    if isinstance(value, _np.ndarray):
        return value
    kind = type(value).__name__
    if value is None or isinstance(value, (str, bytes, dict, set, int, float, complex)):
        raise TypeError("%s: an array (numpy.ndarray, a CPU torch tensor or anything "
                        "numpy.asarray takes), not %s" % (what, kind))
    if type(value).__module__.split(".")[0] == "torch":  # without importing torch
        device = getattr(value, "device", None)
        if device is not None and getattr(device, "type", "cpu") != "cpu":
            raise TypeError("%s: a torch tensor on %s; move it to the CPU first (tensor.cpu())"
                            % (what, device))
        if getattr(value, "requires_grad", False):
            value = value.detach()  # turbid's results carry no gradient
        if str(getattr(value, "dtype", "")) == "torch.bfloat16":
            value = value.float()   # NumPy has no bfloat16
    try:
        if any(hasattr(value, a) for a in ("__array__", "__array_interface__",
                                           "__array_struct__")):
            array = _np.asarray(value)
        elif hasattr(value, "__dlpack__"):
            array = _np.from_dlpack(value)
        else:
            array = _np.asarray(value)  # the buffer protocol, nested sequences
    except Exception as e:  # noqa: BLE001 (any failure of a foreign type becomes one line)
        raise TypeError("%s: a %s cannot be read as an array (%s)"
                        % (what, kind, _first_line(e))) from None
    if not isinstance(array, _np.ndarray) or array.dtype.kind in "OUSV":
        raise TypeError("%s: a %s is not an array of numbers" % (what, kind))
    return array


def _array(value, what, color=True, float_only=False):
    """``value`` (an ndarray, a CPU torch tensor, anything with ``__array__``, ``__dlpack__`` or
    the buffer protocol) as the array the C++ half takes: H x W (x 3 with ``color``; x 1 too),
    within TURBID_MAX_PIXELS, C-contiguous, native byte order, dtype uint8, uint16 or float32
    (other float types converted; ``float_only``: float32). Shares the memory when nothing needs
    converting. Raises one short TypeError (not an array, wrong dtype) or ValueError (shape,
    size)."""
    a = _to_numpy(value, what)
    dtype = a.dtype
    if dtype.kind == "f":
        pass
    elif dtype.kind == "u" and dtype.itemsize in (1, 2) and not float_only:
        pass
    else:
        accepted = ("float32; float16 and float64 are converted" if float_only else
                    "uint8, uint16 or float32; float16 and float64 are converted")
        raise TypeError("%s: dtype %s is not supported (%s)" % (what, dtype.name, accepted))
    channels = (1, 3) if color else (1,)
    if not (a.ndim == 2 or (a.ndim == 3 and a.shape[2] in channels)):
        hint = ""
        if a.ndim == 3 and a.shape[0] in channels:
            hint = " (channels first? use .transpose(1, 2, 0), or .permute(1, 2, 0) for torch)"
        raise ValueError("%s: shape %s is not H x W%s%s"
                         % (what, tuple(a.shape), " or H x W x 3" if color else "", hint))
    if a.shape[0] < 1 or a.shape[1] < 1:
        raise ValueError("%s: array is empty" % what)
    _turbid._check_image_size(what, int(a.shape[1]), int(a.shape[0]))  # before any copy
    if dtype.kind == "f" and dtype.itemsize != 4:
        a = a.astype(_np.float32)
    elif not dtype.isnative:
        a = a.astype(dtype.newbyteorder("="))
    return _np.require(a, requirements=["C_CONTIGUOUS", "ALIGNED"])


def _optional_array(value, what, **kw):
    return None if value is None else _array(value, what, **kw)


def _int(value, what, low=-2**63, high=2**63 - 1):
    """An integer argument (anything with ``__index__``), in [low, high] unless low is None."""
    try:
        n = _operator.index(value)
    except TypeError:
        raise TypeError("%s: an integer, not %s" % (what, type(value).__name__)) from None
    if low is not None and not low <= n <= high:
        raise ValueError("%s: %d is out of range [%d, %d]" % (what, n, low, high))
    return n


def _dumps(value, what):
    if value is None:
        return "{}"
    if isinstance(value, (str, bytes, _os.PathLike)):
        raise ValueError("%s: a dict of parameters, not a %s" % (what, type(value).__name__))
    try:
        return _json.dumps(value, allow_nan=False)
    except (TypeError, ValueError) as e:
        raise ValueError("%s: not JSON-serialisable: %s" % (what, e)) from None


def _map_list(maps):
    if maps is None:
        return []
    if isinstance(maps, str):
        maps = [m for m in maps.split(",") if m]
    return [str(m) for m in maps]


_SEED_MAX = 2**64 - 1


def _seed(value, what="seed"):
    """``value`` as a seed: an integer in [0, 2**64 - 1], the CLI's range (TypeError for a value
    that is not an integer, ValueError outside the range)."""
    message = "%s: must be an integer in [0, %d], not %r" % (what, _SEED_MAX, value)
    if isinstance(value, bool) or not isinstance(value, _numbers.Integral):
        raise TypeError(message)
    if not 0 <= int(value) <= _SEED_MAX:
        raise ValueError(message)
    return int(value)


def render(scene, params=None, seed=None, maps=None):
    """Degrade ``scene`` with the forward model (paper eq. 2), as ``turbid render``.

    ``params``: dict in the CLI's JSON schema (docs/model.md), e.g.
    ``{"water": {"type": "II"}, "psf": {"forward_scatter": 0.5}}``; unknown keys and bad values
    raise ValueError with the CLI's message. ``seed`` overrides ``params["seed"]`` (noise, snow).
    ``maps``: any of "transmission", "light", "veil", "psf", "noise". Returns a RenderResult."""
    if not isinstance(scene, Scene):
        raise ValueError("scene: a turbid.Scene, not a %s" % type(scene).__name__)
    names = _map_list(maps)
    core = _turbid.render(scene._core, _dumps(params, "params"),
                          None if seed is None else _seed(seed), ",".join(names))
    return RenderResult(core, names)


def enhance(image, method, params=None, sidecar=None, scene=None, encoding=None):
    """Enhance ``image`` (RGB or gray) with a registered method (see :func:`methods`), as
    ``turbid enhance``. ``params``: the method's parameters (dict); ``sidecar``: a render's sidecar
    dict (the oracle needs it; ``full`` reads the lights from it); ``scene``: a Scene giving the
    geometry (else the one the sidecar names, for methods that need geometry). Returns float32."""
    if scene is not None and not isinstance(scene, Scene):
        raise ValueError("scene: a turbid.Scene, not a %s" % type(scene).__name__)
    return _turbid.enhance(_array(image, "image"), str(method), _dumps(params, "params"),
                           None if sidecar is None else _dumps(sidecar, "sidecar"),
                           None if scene is None else scene._core, encoding)


def methods():
    """The enhancement methods: list of dicts (name, summary, source, needs_geometry,
    needs_sidecar, privileged, params {name: default}, param_docs)."""
    return _json.loads(_turbid.methods())


def score(image, ref=None, original=None, metrics=None):
    """Metrics of ``image`` against ``ref`` (full-reference) and/or ``original`` (the degraded
    input, for visible-edge metrics), as ``turbid score`` computes them for files holding these
    values: uint8 / uint16 arrays are scored on their raw values (data range 255 / 65535), float32
    on [0, 1]. ``metrics``: list of names or "all" (default: ssim, psnr with ``ref``, else cnr).
    Returns {name: float}."""
    if metrics is None:
        text = ""
    elif isinstance(metrics, str):
        text = metrics
    else:
        text = ",".join(str(m) for m in metrics)
    return dict(_turbid.score(_array(image, "image"), _optional_array(ref, "ref"),
                              _optional_array(original, "original"), text))


def metrics():
    """The metrics: list of dicts (name, summary, needs_reference, needs_original,
    higher_is_better)."""
    return _json.loads(_turbid.metrics())


def match_features(a, b, detector="orb"):
    """Feature matching between two images (the paper's criterion, as ``turbid score --pairs``):
    detector "orb", "akaze" or "sift". Returns dict keypoints_a, keypoints_b, correspondences,
    inliers, active."""
    return _json.loads(_turbid.match_features(_array(a, "a"), _array(b, "b"), str(detector)))


def set_num_threads(n):
    """Threads one call (render, enhance, score) may use inside C++; 0 restores the default (all
    cores), at most 4 per core (more raises ValueError). Results do not depend on it. Set 1 in
    DataLoader workers or when running several Python threads, so that the processes or threads
    do not oversubscribe the cores. Safe while other threads run turbid calls: the change takes
    effect when none is running (at once when none is)."""
    _turbid.set_num_threads(_int(n, "set_num_threads: n", None))  # any size: checked in C++


def get_num_threads():
    """Threads one call may use inside C++ now (see :func:`set_num_threads`)."""
    return _turbid.get_num_threads()


def generate(config, out, threads=None):
    """``turbid generate``: render a dataset (config dict or JSON path; docs/cli/render.md) into
    folder ``out`` (resumable). ``threads``: 1 to 256, None or 0 for all cores (the default);
    the bytes do not depend on it."""
    threads = 0 if threads is None else _int(threads, "generate: threads", 0, 256)
    if threads == 0:
        threads = min(_os.cpu_count() or 1, 256)
    _turbid.generate(config, _os.fspath(out), threads)


def sweep(experiment, out, threads=0, shard="0/1", force=False, reuse=True, methods=None,
          retry_failed=False, allow_commands=False):
    """``turbid sweep``: run an experiment (dict or JSON path; docs/experiments.md) into ``out``
    (rerun to resume). Returns the summary dict (items_total, ran, already_done, retried,
    failed_rows, ...).

    ``methods``: your own enhancement methods as Python callables, scored beside the built-in
    ones on the same degraded images, with the same metrics and tables, e.g.
    ``methods={"mine": f}`` with ``"mine"`` (or ``{"name": "mine", "label": ...}``) listed in the
    experiment's ``methods``. ``f(image) -> image`` receives the degraded image as float32 RGB
    (H x W x 3, or H x W for gray) in [0, 1], linear light; it returns an array of the same size
    and channels (float32/float64 in [0, 1], or uint8/uint16; anything ``numpy.asarray`` takes,
    a CPU torch tensor too). Options go in the experiment's method object:
    ``{"name": "mine", "batch": true, "batch_size": 16}`` calls ``f(list_of_images)`` once per
    batch and expects a list back (a network loaded once, batched inference);
    ``"encoding": "srgb"`` hands it sRGB-encoded values (what a network trained on PNGs expects)
    and reads its result the same way. A call that raises, or returns the wrong size, shape or
    non-finite values, fails those cells (the reason is in the journal and the tables' failed
    count); the sweep goes on. ``retry_failed=True`` runs the failed cells again on a resume.
    The callable runs on the sweep's worker threads holding the GIL (one call at a time); its
    wall time per image is recorded (a batch's time divided by its items, flagged). The
    experiment.json records the method's key, not the callable: resuming with another function
    under the same key mixes results, so change the key (or the output folder) when the method
    changes. ``turbid sweep`` (the CLI) refuses an experiment with Python methods.

    ``allow_commands=True`` lets the experiment's ``"command"`` methods run (external programs,
    with their ``env``); without it a sweep that names one raises before any work. An experiment
    file is data: nothing in it can allow its commands."""
    threads = _int(threads, "threads", -2**31, 2**31 - 1)  # the range is checked by the sweep
    return _json.loads(_turbid.sweep(experiment, _os.fspath(out), int(threads), str(shard),
                                     bool(force), bool(reuse), bool(retry_failed),
                                     dict(methods or {}), allow_commands=bool(allow_commands)))


def default_params():
    """Every render parameter with its default (the sidecar's "options" object)."""
    return _json.loads(_turbid.default_params())


def resolve_params(params):
    """``params`` with every default filled in and checked (raises ValueError as render does)."""
    return _json.loads(_turbid.resolve_params(_dumps(params, "params")))


def read_image(path, encoding="linear"):
    """Read an image file as turbid does (float32, RGB, integer files scaled to [0, 1] and decoded
    with the sRGB curve when ``encoding="srgb"``)."""
    return _turbid.read_image(_os.fspath(path), str(encoding))


def write_image(path, image, bit_depth=8, encoding="linear", overwrite=False):
    """Write a float32 RGB/gray image: .png (8/16-bit), .exr or .pfm, as the CLI writes them."""
    bits = _int(bit_depth, "bit_depth", 0, 64)  # which depths a format takes: checked in C++
    _turbid.write_image(_os.fspath(path), _array(image, "image"), bits, str(encoding),
                        bool(overwrite))


from . import data  # noqa: E402,F401  (turbid.data: on-the-fly training data)
