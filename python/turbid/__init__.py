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
from . import _arrays

__version__ = _turbid.__version__

__all__ = ["Scene", "RenderResult", "render", "enhance", "methods", "score", "metrics",
           "srgb_encode", "srgb_decode", "report", "merge", "regress",
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
    def from_arrays(image, depth_m, fx, fy, cx, cy, normals=None, name="arrays", encoding=None,
                    channel_axis=-1):
        """A scene from arrays: ``image`` RGB or gray (float linear, or uint8/uint16 with
        ``encoding``; ``channel_axis=-3`` for C x H x W), ``depth_m`` float H x W z-depth in
        metres (NaN, 0 or negative where unknown: the TUM / ICL-NUIM convention is 0), pinhole
        intrinsics in pixels; ``normals`` (optional, float32 H x W x 3, camera frame) else
        derived from depth."""
        return Scene(_turbid.Scene.from_arrays(
            _array(image, "image", channel_axis=channel_axis),
            _zero_is_invalid(_array(depth_m, "depth_m", color=False, float_only=True)),
            float(fx), float(fy), float(cx), float(cy),
            _optional_array(normals, "normals", float_only=True), str(name), encoding))

    name = property(lambda self: self._core.name, doc="The scene's short name (str).")
    spec = property(lambda self: self._core.spec,
                    doc='How it was loaded ("builtin:NAME", a scene file path; "" for arrays).')
    width = property(lambda self: self._core.width, doc="Width in pixels.")
    height = property(lambda self: self._core.height, doc="Height in pixels.")
    image = property(lambda self: self._core.image,
                     doc="The clean image rho: float32 linear RGB H x W x 3 (or H x W gray).")
    depth = property(lambda self: self._core.depth,
                     doc="z-depth in metres, float32 H x W, NaN where unknown.")
    normals = property(lambda self: self._core.normals,
                       doc="Unit normals (camera frame x, y, z), H x W x 3; None if derived.")
    range = property(lambda self: self._core.range,
                     doc="Distance along the viewing ray in metres, H x W, NaN where unknown.")
    camera = property(lambda self: self._core.camera,
                      doc="Pinhole intrinsics: dict fx, fy, cx, cy, width, height (pixels).")

    def __repr__(self):
        return "turbid.Scene(%r, %dx%d)" % (self.name, self.width, self.height)

    def __reduce__(self):
        # Loaded scenes travel as their spec (and scale); array scenes as their arrays.
        if self.spec:
            return (_scene_from_spec, (self.spec, self._core.scale))
        c = self.camera
        normals = self.normals
        if not isinstance(normals, _np.ndarray) or normals.dtype != _np.float32:
            normals = None  # derived from depth again, as the first time
        return (_scene_from_arrays, (self.image, self.depth, c["fx"], c["fy"], c["cx"], c["cy"],
                                     normals, self.name))


def _scene_from_spec(spec, scale):
    return Scene(_turbid.Scene.builtin(spec, scale) if spec.startswith("builtin:")
                 else _turbid.Scene.load(spec))


def _scene_from_arrays(image, depth, fx, fy, cx, cy, normals, name):
    return Scene.from_arrays(image, depth, fx, fy, cx, cy, normals=normals, name=name)


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

    image = property(lambda self: self._get("image", lambda: self._core.image()),
                     doc="The degraded image I: float32 RGB (or gray) in [0, 1].")
    lit = property(lambda self: self._get("lit", lambda: self._core.lit()),
                   doc="J = (E_A + E_L) rho, the lit ground truth (float32).")
    maps = property(lambda self: self._get(
        "maps", lambda: {n: self._core.map(n) for n in self._names}),
        doc="Dict of the maps asked for with render(maps=...).")
    sidecar = property(lambda self: self._get("sidecar", lambda: _json.loads(self._core.sidecar())),
                       doc="The dict the CLI writes as OUT.json (parameters, scene, versions).")
    # Python holds R, G, B: the plan says so (the libraries' B, G, R is never visible).
    plan = property(lambda self: self._get("plan", lambda: self._core.plan().replace(
        "channels (BGR)", "channels (RGB)")),
                    doc="What the render computed and skipped (text).")

    def __getstate__(self):  # the arrays, not the C++ result
        return {"names": self._names, "cache": {
            "image": self.image, "lit": self.lit, "maps": self.maps, "sidecar": self.sidecar,
            "plan": self.plan}}

    def __setstate__(self, state):
        self._core, self._names, self._cache = None, state["names"], dict(state["cache"])

    def __repr__(self):
        shape = "x".join(map(str, self.image.shape))
        return "turbid.RenderResult(image %s, maps %s)" % (shape, list(self._names))


def _array(value, what, color=True, float_only=False, channel_axis=-1):
    """One image (``_arrays.images`` without a batch) as the C++ half takes it."""
    return _arrays.single(value, what, channel_axis, color=color, float_only=float_only)[0]


def _zero_is_invalid(depth):
    """Depth with 0 and negative values (invalid in TUM / ICL-NUIM / Kinect files) as NaN."""
    if depth.ndim == 3:
        depth = depth[:, :, 0]
    if (depth <= 0).any():
        depth = _np.where(depth > 0, depth, _np.float32(_np.nan)).astype(_np.float32)
    return depth


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


def _json_value(value):
    """NumPy scalars and arrays (and CPU tensors) where JSON takes numbers and lists."""
    if isinstance(value, _np.generic):
        return value.item()
    if isinstance(value, _np.ndarray) or _arrays._is_torch(value):
        return _np.asarray(value).tolist()
    if isinstance(value, _os.PathLike):
        return _os.fspath(value)
    raise TypeError("Object of type %s is not JSON serializable" % type(value).__name__)


def _dumps(value, what):
    if value is None:
        return "{}"
    if isinstance(value, (str, bytes, _os.PathLike)):
        raise ValueError("%s: a dict of parameters, not a %s" % (what, type(value).__name__))
    try:
        return _json.dumps(value, allow_nan=False, default=_json_value)
    except (TypeError, ValueError) as e:
        raise ValueError("%s: not JSON-serialisable: %s" % (what, e)) from None


def _config(value, what):
    """A config / experiment argument: a path as it is, a dict as plain JSON values (NumPy
    scalars and arrays become numbers and lists)."""
    if isinstance(value, (str, _os.PathLike)):
        return value
    return _json.loads(_dumps(value, what))


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


def enhance(image, method, params=None, sidecar=None, scene=None, encoding=None,
            channel_axis=-1):
    """Enhance ``image`` with a registered method (see :func:`methods`), as ``turbid enhance``.

    ``image``: H x W, H x W x C or a batch N x ... x H x W x C of RGB or gray images (a NumPy
    array, a CPU torch tensor, anything with ``__array__`` / ``__dlpack__``), float (linear
    light, [0, 1]) or uint8 / uint16 with ``encoding``; ``channel_axis``: where the channels are
    (-1 default, -3 for C x H x W and N x C x H x W). A batch runs its images in parallel in C++
    with the GIL released. ``params``: the method's parameters (dict); ``sidecar``: a render's
    sidecar dict (the oracle needs it; ``full`` reads the lights from it), for a batch one dict or
    a list with one per image; ``scene``: a Scene giving the geometry (else the one the sidecar
    names, for methods that need geometry). Returns float32 in the caller's kind and layout (a
    tensor for a tensor, the channel axis where it was)."""
    if scene is not None and not isinstance(scene, Scene):
        raise ValueError("scene: a turbid.Scene, not a %s" % type(scene).__name__)
    a, layout = _arrays.images(image, "image", channel_axis)
    params_text = _dumps(params, "params")
    if not layout.batch:
        out = _turbid.enhance(a, str(method), params_text,
                              None if sidecar is None else _dumps(sidecar, "sidecar"),
                              None if scene is None else scene._core, encoding)
        return layout.restore(out)
    if sidecar is None:
        sidecars = []
    elif isinstance(sidecar, dict):
        sidecars = [_dumps(sidecar, "sidecar")]
    else:
        sidecars = [_dumps(x, "sidecar[%d]" % i) for i, x in enumerate(sidecar)]
    out = _turbid.enhance_batch(a, str(method), params_text, sidecars,
                                None if scene is None else scene._core, encoding)
    return layout.restore(out)


def methods():
    """The enhancement methods: list of dicts (name, summary, source, needs_geometry,
    needs_sidecar, privileged, params {name: default}, param_docs)."""
    return _json.loads(_turbid.methods())


SCORE_DOMAINS = ("srgb8", "linear", "as_given")


def score(image, ref=None, original=None, metrics=None, domain="srgb8", encoding=None,
          channel_axis=-1):
    """Metrics of ``image`` against ``ref`` (full-reference) and/or ``original`` (the degraded
    input, for visible-edge metrics). ``metrics``: list of names or "all" (default: ssim, psnr
    with ``ref``, else cnr).

    ``domain`` says what the full-reference metrics (ssim, psnr, mse) compare:

    * ``"srgb8"`` (the default, as the paper and the field score): both images as an 8-bit sRGB
      camera writes them -- float arrays (linear light) clipped to [0, 1], sRGB-encoded and
      rounded to codes 0..255; uint8 arrays are taken as those codes, uint16 as 16-bit sRGB codes
      rounded to 8 bits -- scored with data range 255, as ``turbid score`` and scikit-image score
      the PNG files.
    * ``"linear"``: linear light in [0, 1] (integer arrays decoded with ``encoding``, sRGB unless
      told ``"linear"``), data range 1: what sweeps did before issue 32.
    * ``"as_given"``: the values as they are (floats on [0, 1], uint8 / uint16 raw with data range
      255 / 65535), exactly as ``turbid score`` reads files holding these values.

    No-reference metrics (cnr, hautiere_*, uiqm, uciqe) read linear light in every domain but
    ``as_given``. Arrays as for :func:`enhance` (``channel_axis``, batches): for a batch the
    result is ``{name: array of the batch's shape}`` (a float64 tensor for tensors), computed in
    parallel; else ``{name: float}``."""
    if metrics is None:
        text = ""
    elif isinstance(metrics, str):
        text = metrics
    else:
        text = ",".join(str(m) for m in metrics)
    if domain not in SCORE_DOMAINS:
        raise ValueError("domain must be 'srgb8', 'linear' or 'as_given', not %r" % (domain,))
    a, layout = _arrays.images(image, "image", channel_axis)
    others = []
    for name, value in (("ref", ref), ("original", original)):
        if value is None:
            others.append(None)
            continue
        b, other = _arrays.images(value, name, channel_axis)
        if other.batch != layout.batch:
            raise ValueError("%s: batch shape %s differs from the image's %s"
                             % (name, other.batch, layout.batch))
        others.append(b)
    if not layout.batch:
        return dict(_turbid.score(a, others[0], others[1], text, domain, encoding))
    rows = _turbid.score_batch(a, others[0], others[1], text, domain, encoding)
    return {k: layout.tensor(_np.array([r[k] for r in rows]).reshape(layout.batch))
            for k in rows[0]}


def srgb_encode(linear, dtype=None):
    """Linear light -> sRGB values (IEC 61966-2-1, the curve turbid's files use), element by
    element, any shape. ``dtype``: None keeps float32 (values outside [0, 1] follow the curve's
    formula), ``numpy.uint8`` / ``numpy.uint16`` (or ``"uint8"``, ``"uint16"``) clip to [0, 1] and
    round to 8 / 16-bit codes as ``write_image`` writes them. Takes anything :func:`enhance`
    takes (float); returns the caller's kind (a tensor for a tensor)."""
    bits = {None: 0, "float32": 0, "uint8": 8, "uint16": 16}.get(
        None if dtype is None else _np.dtype(dtype).name, -1)
    if bits < 0:
        raise ValueError("dtype: None (float32), uint8 or uint16, not %r" % (dtype,))
    return _curve(linear, True, bits, "srgb_encode")


def srgb_decode(encoded):
    """sRGB values -> linear light (IEC 61966-2-1), element by element, any shape: float arrays
    as they are, uint8 / uint16 codes scaled to [0, 1] first (as ``read_image`` decodes PNGs).
    Returns float32 in the caller's kind (a tensor for a tensor)."""
    return _curve(encoded, False, 0, "srgb_decode")


def _curve(value, encode, bits, what):
    torch = _arrays._is_torch(value)
    a = _arrays.to_numpy(value, what)
    if a.dtype.kind == "f" and a.dtype != _np.float32:
        a = a.astype(_np.float32)
    elif not a.dtype.isnative:
        a = a.astype(a.dtype.newbyteorder("="))
    a = _np.ascontiguousarray(a)
    return _arrays.Layout(torch, None, ()).tensor(_turbid.srgb_curve(a, encode, bits))


def metrics():
    """The metrics: list of dicts (name, summary, needs_reference, needs_original,
    higher_is_better)."""
    return _json.loads(_turbid.metrics())


def match_features(a, b, detector="orb", channel_axis=-1):
    """Feature matching between two images (the paper's criterion, as ``turbid score --pairs``):
    detector "orb", "akaze" or "sift". Returns dict keypoints_a, keypoints_b, correspondences,
    inliers, active."""
    return _json.loads(_turbid.match_features(_array(a, "a", channel_axis=channel_axis),
                                              _array(b, "b", channel_axis=channel_axis),
                                              str(detector)))


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
    _turbid.generate(_config(config, "config"), _os.fspath(out), threads)


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
    return _json.loads(_turbid.sweep(_config(experiment, "experiment"), _os.fspath(out),
                                     int(threads), str(shard),
                                     bool(force), bool(reuse), bool(retry_failed),
                                     dict(methods or {}), allow_commands=bool(allow_commands)))


def report(dir, out=None, gnuplot="gnuplot"):
    """``turbid report``: a static HTML report of a sweep folder (tables, images, plots).
    ``out``: the HTML file (default ``DIR/report.html``). Returns dict html (its path), plots,
    images, warning (non-empty when something was skipped, e.g. gnuplot missing)."""
    return _json.loads(_turbid.report(_os.fspath(dir), "" if out is None else _os.fspath(out),
                                      str(gnuplot)))


def merge(dirs, out, allow_partial=False, force=False):
    """``turbid merge``: combine shard folders (``sweep(..., shard="i/N")``) into the unsharded
    result in ``out``. ``allow_partial=True`` writes tables even when items are missing;
    ``force=True`` replaces an ``out`` holding another experiment. Returns the items merged."""
    if isinstance(dirs, (str, bytes, _os.PathLike)):
        raise TypeError("merge: dirs is a list of shard folders")
    return _turbid.merge([_os.fspath(d) for d in dirs], _os.fspath(out), bool(allow_partial),
                         bool(force))


def regress(baseline, results, tolerances=None, tolerance_file=None, strict=False):
    """``turbid regress``: compare ``results`` (a sweep folder or a CSV) with a ``baseline``
    items.csv / summary.csv. ``tolerances``: {metric: abs or (abs, rel)} (default: the file
    ``BASELINE.tolerances.json`` beside the baseline if present, else abs 1e-6, rel 1e-4);
    ``strict=True``: improvements beyond tolerance fail too. Returns dict failed (bool),
    compared, moves (list of key, metric, baseline, result, regression), missing, extra and text
    (what the CLI prints); it does not raise for a regression -- check ``["failed"]``."""
    tol = {}
    for metric, value in dict(tolerances or {}).items():
        pair = value if isinstance(value, (tuple, list)) else (value, 0.0)
        if len(pair) != 2:
            raise ValueError("tolerances: %r is abs or (abs, rel)" % (metric,))
        tol[str(metric)] = (float(pair[0]), float(pair[1]))
    return _json.loads(_turbid.regress(
        _os.fspath(baseline), _os.fspath(results), tol,
        "" if tolerance_file is None else _os.fspath(tolerance_file), bool(strict)))


def default_params():
    """Every render parameter with its default (the sidecar's "options" object)."""
    return _json.loads(_turbid.default_params())


def resolve_params(params):
    """``params`` with every default filled in and checked (raises ValueError as render does)."""
    return _json.loads(_turbid.resolve_params(_dumps(params, "params")))


ENCODINGS = ("srgb", "linear")


def read_image(path, encoding="srgb", channel_axis=-1):
    """Read an image file as turbid does: float32 linear light, RGB (or H x W gray), in [0, 1].

    ``encoding`` says how integer files (PNG, JPEG, 8/16-bit TIFF) are coded: ``"srgb"`` (the
    default: ordinary photos and the PNGs ``render`` / ``generate`` write) decodes them with the
    sRGB curve, ``"linear"`` only scales them to [0, 1]. Float files (EXR, PFM) are linear
    already. ``channel_axis=-3`` returns C x H x W."""
    if encoding not in ENCODINGS:
        raise ValueError("encoding must be 'srgb' or 'linear', not %r" % (encoding,))
    out = _turbid.read_image(_os.fspath(path), str(encoding))
    if out.ndim == 3 and _operator.index(channel_axis) % 3 != 2:
        out = _np.ascontiguousarray(_np.moveaxis(out, -1, channel_axis))
    return out


def write_image(path, image, bit_depth=8, encoding="srgb", overwrite=False, channel_axis=-1):
    """Write an RGB or gray image: .png (8/16-bit), .exr or .pfm (float), as the CLI writes them.

    ``image``: float (linear light, [0, 1]: clipped, coded with ``encoding`` -- ``"srgb"`` by
    default, what viewers expect -- and rounded to ``bit_depth`` for PNG) or uint8 / uint16 codes
    (written as they are into a PNG of their own bit depth; ``bit_depth`` must match or be left
    at 8 for uint8). Anything :func:`enhance` takes (one image, ``channel_axis``).
    ``overwrite=True`` replaces an existing file."""
    a = _array(image, "image", channel_axis=channel_axis)
    bits = _int(bit_depth, "bit_depth", 0, 64)  # which depths a format takes: checked in C++
    if encoding not in ENCODINGS:
        raise ValueError("encoding must be 'srgb' or 'linear', not %r" % (encoding,))
    if a.dtype.kind == "u":
        code_bits = 8 * a.dtype.itemsize
        if bits not in (8, code_bits):
            raise ValueError("bit_depth=%d: a %s image is written as it is, %d-bit"
                             % (bits, a.dtype.name, code_bits))
        bits = code_bits
    _turbid.write_image(_os.fspath(path), a, bits, str(encoding), bool(overwrite))


from . import data  # noqa: E402,F401  (turbid.data: on-the-fly training data)
from . import water  # noqa: E402,F401  (turbid.water: Sea-thru water fit)
