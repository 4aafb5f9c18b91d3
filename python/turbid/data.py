"""turbid.data: degraded training data on the fly, deterministic per item and epoch.

* :class:`RenderDataset` is a map-style dataset over a ``turbid generate`` config (scenes x grid x
  samples). ``ds[i]`` is a dict sample (``degraded``, ``clean``, ``depth``, ``valid``, ``K``,
  ``params``, ``index``, ``id`` and the maps asked for, e.g. ``transmission``), rendered on demand
  after cropping / resizing the scene with its intrinsics adjusted (``crop=256``, ``size=``):
  a 256 x 256 crop costs a 256 x 256 render. Epoch 0 is exactly what ``turbid generate`` writes;
  :meth:`RenderDataset.set_epoch` gives new draws per epoch, still reproducible.
* :class:`DegradeTransform` degrades your own (image, depth, intrinsics) frames inside your own
  Dataset: ``t(rgb, depth_m, K, seed=i)`` returns the same dict sample.
* :func:`collate` stacks samples into a batch (torch tensors when torch is imported) and names the
  sizes when they differ; :class:`BucketBatchSampler` batches items of one size together.

Draws come from a counter-based generator keyed by (seed, epoch, index), so a sample is the same
bytes in any worker process, for any ``num_workers`` and any order. Inside DataLoader workers each
worker uses ``cores // num_workers`` threads (set on its first item; ``threads=`` overrides) and
keeps freed memory in its heap for the next sample (no fresh pages per sample).
This module does not import torch.
"""

import json as _json
import os as _os
import sys as _sys

import numpy as _np

from . import _turbid, _arrays
from . import Scene, _config, _dumps, _int, _seed, set_num_threads

__all__ = ["RenderDataset", "DegradeTransform", "collate", "BucketBatchSampler", "draw_params",
           "decode_codes"]

_MAPS = ("transmission", "light", "veil", "psf", "noise")
_LISTED = ("psf",)  # per-sample kernels of their own sizes: batched as lists


def draw_params(random, index, base=None, seed=0):
    """The resolved render parameters for draw ``index`` of sampler ``random`` (generate's
    ``random`` section: {"params": {path: distribution}, "seed": s}) over ``base``; the render seed
    is generate's for item ``index`` of a config with this ``seed`` unless ``base`` names one."""
    random = dict(random or {})
    unknown = set(random) - {"params", "seed", "count"}
    if unknown:
        raise ValueError("random: unknown key %s (params, seed)" % sorted(unknown)[0])
    params = random.get("params", {})
    random_seed = _seed(random.get("seed", seed), "random.seed" if "seed" in random else "seed")
    return _json.loads(_turbid.draw_params(_dumps(base, "base"), _dumps(params, "random.params"),
                                           random_seed, _seed(seed),
                                           _int(index, "index", 0, 2**64 - 1)))


def _intrinsics(k):
    if isinstance(k, dict):
        return float(k["fx"]), float(k["fy"]), float(k["cx"]), float(k["cy"])
    a = _np.asarray(k, dtype=float)
    if a.shape == (3, 3):
        return a[0, 0], a[1, 1], a[0, 2], a[1, 2]
    if a.shape == (4,):
        return tuple(float(x) for x in a)
    raise ValueError("intrinsics: a dict fx, fy, cx, cy, a 3x3 matrix K or (fx, fy, cx, cy)")


def _hw(value, what):
    """``256`` or ``(h, w)`` -> (h, w); None -> (0, 0)."""
    if value is None:
        return 0, 0
    if isinstance(value, (tuple, list)):
        if len(value) != 2:
            raise ValueError("%s: an integer or (height, width), not %r" % (what, value))
        h, w = (_int(v, what, 1, 1 << 20) for v in value)
    else:
        h = w = _int(value, what, 1, 1 << 20)
    return h, w


def _maps(maps):
    names = [m for m in (maps.split(",") if isinstance(maps, str) else list(maps or ())) if m]
    for m in names:
        if m not in _MAPS:
            raise ValueError("maps: unknown map %r (%s)" % (m, ", ".join(_MAPS)))
    return names


class _SampleOptions:
    """What RenderDataset and DegradeTransform share: crop, size, channels, maps, layout."""

    def __init__(self, crop, crop_mode, size, channels, maps, ground_truth, channel_axis):
        if ground_truth not in ("clean", "lit"):
            raise ValueError("ground_truth: 'clean' or 'lit', not %r" % (ground_truth,))
        if crop_mode not in ("random", "center"):
            raise ValueError("crop_mode: 'random' or 'center', not %r" % (crop_mode,))
        if channels not in (None, 1, 3):
            raise ValueError("channels: 1 (gray), 3 (RGB) or None (as the scene), not %r"
                             % (channels,))
        if channel_axis not in (-1, -3, 0, 2):
            raise ValueError("channel_axis: -1 (H x W x C) or -3 (C x H x W), not %r"
                             % (channel_axis,))
        self.crop = _hw(crop, "crop")
        self.crop_mode = crop_mode
        self.size = _hw(size, "size")
        self.channels = channels
        self.maps = _maps(maps)
        self.lit = ground_truth == "lit"
        self.channels_first = channel_axis in (-3, 0)

    def window(self, seed, epoch, index, height, width):
        ch, cw = self.crop
        if ch == 0:
            return 0, 0, 0, 0
        y0, x0 = _turbid.crop_origin(seed, epoch, index, height, width, ch, cw,
                                     self.crop_mode == "random")
        return ch, cw, y0, x0

    def render(self, core, params_text, window, float_output, into=None, codes8=False):
        ch, cw, y0, x0 = window
        return _turbid.render_sample(core, params_text, ch, cw, y0, x0, self.size[0],
                                     self.size[1], self.channels or 0, ",".join(self.maps),
                                     self.lit, float_output, self.channels_first, into, codes8)


_CODE_TABLES = {}


def decode_codes(codes, encoding="srgb"):
    """8-bit camera codes (uint8, e.g. a ``dtype="uint8"`` batch's ``degraded`` / ``clean``) ->
    float32 linear values, by a 256-entry table on the codes' device (a CUDA tensor stays on the
    GPU): the same float32 values the ``dtype="float32"`` path gives for ``degraded``, bit for bit
    (tested). ``encoding``: "srgb" (default) or "linear" (the camera's ``encoding``). NumPy
    arrays give NumPy arrays."""
    if encoding not in ("srgb", "linear"):
        raise ValueError("encoding: 'srgb' or 'linear', not %r" % (encoding,))
    table = _CODE_TABLES.get(encoding)
    if table is None:
        c = _np.arange(256, dtype=_np.float64) / 255.0
        if encoding == "srgb":  # IEC 61966-2-1 in double, rounded once (as the renderer's table)
            c = _np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
        else:
            c = (_np.arange(256, dtype=_np.float32) / _np.float32(255)).astype(_np.float64)
        table = _CODE_TABLES[encoding] = c.astype(_np.float32)
    torch = _sys.modules.get("torch")
    if torch is not None and isinstance(codes, torch.Tensor):
        if codes.dtype != torch.uint8:
            raise TypeError("decode_codes: uint8 codes, not %s" % (codes.dtype,))
        return torch.from_numpy(table).to(codes.device)[codes.long()]
    codes = _np.asarray(codes)
    if codes.dtype != _np.uint8:
        raise TypeError("decode_codes: uint8 codes, not %s" % (codes.dtype,))
    return table[codes]


def _image_dtype(dtype):
    """RenderDataset's ``dtype``: "float32" or "uint8" from a name, a NumPy or a torch dtype."""
    name = str(dtype).replace("torch.", "") if dtype is not None else "None"
    if not isinstance(dtype, str) and not name.startswith(("float32", "uint8")):
        try:
            name = _np.dtype(dtype).name
        except TypeError:
            pass
    if name not in ("float32", "uint8"):
        raise ValueError("dtype: 'float32' (default) or 'uint8' (8-bit camera codes), not %r"
                         % (dtype,))
    return name


def _worker_threads(threads):
    """In a torch DataLoader worker: cores // num_workers threads per worker (or ``threads``),
    and freed memory kept in the worker's heap (warm pages for the next sample's arrays)."""
    torch = _sys.modules.get("torch")
    info = torch.utils.data.get_worker_info() if torch is not None else None
    if info is not None:
        _turbid.keep_freed_memory()
    if threads is None:
        return
    if threads == "auto":
        if info is None:
            return
        threads = max(1, (_os.cpu_count() or 1) // max(1, info.num_workers))
    set_num_threads(threads)


class RenderDataset:
    """Map-style dataset over a ``turbid generate`` config (dict or JSON path; docs/cli/render.md).

    ``len(ds)`` is the number of items generate would write; ``ds[i]`` renders item ``i`` and
    returns a dict:

    * ``degraded``: the rendered image I, float32 (H x W x C, or C x H x W with
      ``channel_axis=-3``), quantised as the camera's bit depth says (float with
      ``"format": "exr"``);
    * ``clean``: the clean image rho the renderer saw (``ground_truth="lit"``: J = (E_A + E_L)
      rho), float32 linear, same layout;
    * with ``dtype="uint8"`` (or ``torch.uint8``), ``degraded`` and ``clean`` are instead the 8-bit
      camera codes (uint8, 0 .. 255: the bytes of generate's 8-bit PNGs, sRGB-coded unless the
      camera says ``"encoding": "linear"``), as torchvision's ``decode_image`` gives a PNG: 11
      instead of 29 bytes per pixel through a DataLoader. :func:`decode_codes` turns them into
      the float path's values on the batch's device (``decode_codes(b["degraded"].cuda())``:
      the same float32 bits as ``dtype="float32"`` gives for ``degraded``; for ``clean`` the
      8-bit rounding of the float path's). Needs 8-bit camera items (not ``"format": "exr"``);
    * ``depth`` (H x W metres, NaN where unknown) and ``valid`` (H x W bool: depth known; pixels
      without depth render near-black, so mask the loss with it);
    * ``K``: (fx, fy, cx, cy) of the sample (after crop / resize); ``params``: the resolved render
      parameters (the sidecar's "options"; ``with_params=False`` leaves them out); ``index``,
      ``id`` (generate's "<scene>_<index>"); and each map of ``maps`` ("transmission", "light",
      "veil", "psf", "noise").

    ``crop``: 256 or (h, w): a window of the (scaled) frame cut out *before* rendering, the
    intrinsics shifted; ``crop_mode`` "random" (drawn per (seed, epoch, index)) or "center".
    ``size``: (h, w) or an integer: the (cropped) frame resized before rendering, intrinsics
    scaled. ``"scale"`` of the config applies to file scenes too (generate: built-ins only).
    ``channels``: 3 (default: gray scenes become RGB before rendering, so any scene list
    collates), 1 (RGB scenes become gray) or None (as the scene). Epoch 0 without crop, size or
    channel change is exactly what ``turbid generate`` writes (tested). ``threads``: per worker
    ("auto": cores // num_workers inside DataLoader workers; an integer; None: leave it).
    Picklable: worker processes rebuild the scenes."""

    def __init__(self, config, crop=None, crop_mode="random", size=None, channels=3, maps=(),
                 ground_truth="clean", channel_axis=-1, with_params=True, epoch=0,
                 threads="auto", channels_first=None, dtype="float32"):
        if channels_first is not None:  # the 0.x spelling
            channel_axis = -3 if channels_first else -1
        self.config = config
        self._options = _SampleOptions(crop, crop_mode, size, channels, maps, ground_truth,
                                       channel_axis)
        self._args = dict(crop=crop, crop_mode=crop_mode, size=size, channels=channels,
                          maps=tuple(self._options.maps), ground_truth=ground_truth,
                          channel_axis=channel_axis)
        self.dtype = _image_dtype(dtype)
        self._args["dtype"] = self.dtype if self.dtype != "float32" else None
        self.with_params = bool(with_params)
        self.epoch = _seed(epoch, "epoch")
        if threads not in ("auto", None):
            threads = _int(threads, "threads", 1, 4096)
        self.threads = threads
        self._pid = None
        self._load_plan()  # crops larger than a scene fail now, not in a worker

    def _load_plan(self):
        self._plan = _turbid.GeneratePlan(_config(self.config, "config"))
        # Per scene, looked up per sample: (scene, frame height, frame width, sample size).
        self._scenes = []
        for s in range(self._plan.scene_count):
            scene = self._plan.scene(s)
            self._scenes.append((scene, scene.height, scene.width, self._sample_size(s)))
        self._exr = self._plan.format == "exr"
        if self._exr and self.dtype == "uint8":
            raise ValueError("dtype='uint8' needs 8-bit camera codes: the config's format is "
                             "exr (float); use dtype='float32'")

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_plan"] = None
        state["_scenes"] = None
        state["_pid"] = None
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._load_plan()

    def __len__(self):
        return len(self._plan)

    def __repr__(self):
        return "turbid.data.RenderDataset(%d items, epoch %d, %r)" % (
            len(self), self.epoch, {k: v for k, v in self._args.items() if v})

    def set_epoch(self, epoch):
        """Use the draws of ``epoch`` (0: generate's). Call it before iterating a DataLoader
        (its workers copy the dataset when an epoch's iteration starts; with
        ``persistent_workers=True`` they keep the epoch they started with)."""
        self.epoch = _seed(epoch, "epoch")

    def item_id(self, index):
        """generate's id of item ``index`` ("<scene>_<index, 6 digits>")."""
        return self._plan.item(self._index(index))[0]

    def _index(self, index):
        n = _int(index, "RenderDataset index", None)
        if not -len(self) <= n < len(self):
            raise IndexError("RenderDataset index %d out of range (%d items)" % (n, len(self)))
        return n + len(self) if n < 0 else n

    def _sample_size(self, scene_index):
        scene = self._plan.scene(scene_index)
        h, w = scene.height, scene.width
        ch, cw = self._options.crop
        if ch:
            _turbid.crop_origin(0, 0, 0, h, w, ch, cw, False)  # checks the crop fits
            h, w = ch, cw
        if self._options.size[0]:
            h, w = self._options.size
        return h, w

    def sample_size(self, index):
        """(height, width) of sample ``index`` without rendering it (for bucketing)."""
        return self._scenes[self._plan.item(self._index(index))[1]][3]

    def params(self, index, epoch=None):
        """The resolved render parameters of item ``index`` in ``epoch`` (default: the current)."""
        epoch = self.epoch if epoch is None else _seed(epoch, "epoch")
        return _json.loads(self._plan.params(self._index(index), epoch))

    def __getitem__(self, index):
        if isinstance(index, (list, tuple)) or (isinstance(index, _np.ndarray) and index.ndim == 1):
            return self.batch(index)
        if isinstance(index, slice) or not isinstance(index, (int, _np.integer)):
            raise TypeError("RenderDataset index must be an int (or a list of ints: a batch)")
        return self._render(index)

    def _render(self, index, into=None):
        if self._pid != _os.getpid():
            self._pid = _os.getpid()
            _worker_threads(self.threads)
        i = self._index(index)
        item_id, scene_index = self._plan.item(i)
        scene, height, width, _ = self._scenes[scene_index]
        params_text = self._plan.params(i, self.epoch)
        window = self._options.window(self._plan.seed, self.epoch, i, height, width)
        sample = self._options.render(scene, params_text, window, self._exr, into,
                                      self.dtype == "uint8")
        sample["index"] = i
        sample["id"] = item_id
        if self.with_params:
            sample["params"] = _json.loads(params_text)
        return sample

    def batch(self, indices):
        """The samples ``indices`` rendered straight into one batch: the dict :func:`collate`
        would return for ``[ds[i] for i in indices]`` (the same bytes), without per-sample
        arrays or the stacking copy. Inside a DataLoader worker its tensors are allocated once in
        shared memory, so they reach the main process without another copy. ``ds[[i, j, ...]]``
        is the same (for ``DataLoader(ds, batch_size=None, sampler=BatchSampler(...))``).
        Samples of different sizes raise collate's error naming them."""
        samples = self.__getitems__(indices)
        return collate(samples)

    def __getitems__(self, indices):
        """DataLoader's batch fetch (``batch_size=N``, torch >= 1.13): the samples rendered into
        one batch (see :meth:`batch`); :func:`collate` returns that batch as is, any other
        collate_fn sees the per-sample views."""
        if type(self).__getitem__ is not RenderDataset.__getitem__:
            return [self[i] for i in indices]  # a subclass's own samples
        indices = [self._index(i) for i in indices]
        sizes = {self.sample_size(i) for i in indices}
        if len(indices) < 2 or len(sizes) > 1:
            return [self._render(i) for i in indices]  # collate names the sizes
        first = self._render(indices[0])
        n = len(indices)
        torch = _sys.modules.get("torch")
        shared = torch is not None and torch.utils.data.get_worker_info() is not None
        arrays, batch = {}, {}
        for key, value in first.items():
            if isinstance(value, _np.ndarray) and key not in _LISTED:
                batch[key], arrays[key] = _batch_array(torch, shared, (n,) + value.shape,
                                                       value.dtype)
                arrays[key][0] = value
        for j in range(1, n):
            into = {key: a[j] for key, a in arrays.items()}
            rest = self._render(indices[j], into)
            for key in first:
                if key not in arrays:
                    batch.setdefault(key, [first[key]]).append(rest[key])
        for key in first:
            if key not in arrays:
                batch.setdefault(key, [first[key]])
        if torch is not None:
            batch["index"] = torch.tensor(batch["index"])
        return _Batch(batch, n)


class DegradeTransform:
    """Degrades your own (image, depth_m, intrinsics) frames, e.g. inside your own Dataset:
    ``t(rgb, depth_m, K, seed=i)`` returns the dict sample :class:`RenderDataset` returns
    (``degraded``, ``clean``, ``depth``, ``valid``, ``K``, ``params`` and the maps asked for), as
    NumPy arrays, or tensors when ``rgb`` is a tensor.

    ``random``: generate's ``random`` section (``{"params": {path: distribution}, "seed": s}``);
    ``base``: fixed parameters under the draws; ``seed``: seeds the renders' noise as generate's
    config seed does. The call's ``seed`` (or positional ``index``) selects the draw: pass the
    dataset index for the same degradation every epoch, ``epoch * len(dataset) + index`` for new
    ones. ``rgb``: RGB or gray, float (linear) or uint8 / uint16 with ``encoding`` ("srgb" for
    ordinary photos), ``channel_axis`` -1 or -3 (C x H x W, also the layout of the results);
    ``depth_m``: metres, NaN / 0 / negative = unknown; ``K``: a 3 x 3 matrix, (fx, fy, cx, cy) or
    a dict. ``crop``, ``crop_mode``, ``size``, ``channels``, ``maps``, ``ground_truth`` as for
    :class:`RenderDataset` (cropped before rendering, K adjusted; the frame's pixels are copied
    once, the window only)."""

    def __init__(self, random=None, base=None, seed=0, encoding=None, ground_truth="clean",
                 crop=None, crop_mode="random", size=None, channels=None, maps=(),
                 channel_axis=-1):
        self.random = dict(random or {})
        self.base = dict(base or {})
        self.seed = _seed(seed)
        self.encoding = encoding
        self.channel_axis = channel_axis
        self._options = _SampleOptions(crop, crop_mode, size, channels, maps, ground_truth,
                                       channel_axis)
        draw_params(self.random, 0, self.base, self.seed)  # fail early on a bad sampler

    def __call__(self, image, depth_m, intrinsics, index=None, seed=None):
        if (index is None) == (seed is None):
            raise TypeError("DegradeTransform: pass the draw as seed= (or index), exactly once")
        draw = _int(index if seed is None else seed, "seed", 0, 2**64 - 1)
        fx, fy, cx, cy = _intrinsics(intrinsics)
        torch = _arrays._is_torch(image)
        rgb, _ = _arrays.single(image, "image", self.channel_axis)
        depth, _ = _arrays.single(depth_m, "depth_m", color=False, float_only=True)
        if depth.ndim == 3:
            depth = depth[:, :, 0]
        if depth.shape != rgb.shape[:2]:
            raise ValueError("depth_m: size %s differs from the image's %s"
                             % (depth.shape, rgb.shape[:2]))
        window = self._options.window(self.seed, 0, draw, rgb.shape[0], rgb.shape[1])
        ch, cw, y0, x0 = window
        if ch:  # only the window is copied into the scene
            rgb, depth = rgb[y0:y0 + ch, x0:x0 + cw], depth[y0:y0 + ch, x0:x0 + cw]
            cx, cy = cx - x0, cy - y0
        params = draw_params(self.random, draw, self.base, self.seed)
        scene = Scene.from_arrays(rgb, depth, fx, fy, cx, cy, encoding=self.encoding)
        sample = self._options.render(scene._core, _json.dumps(params), (0, 0, 0, 0), False)
        sample["params"] = params
        if torch:
            t = _sys.modules["torch"]
            sample = {k: t.from_numpy(v) if isinstance(v, _np.ndarray) else v
                      for k, v in sample.items()}
        return sample


def _batch_array(torch, shared, shape, dtype):
    """An uninitialised batch array: a torch tensor (in shared memory in a DataLoader worker)
    when torch is imported, else NumPy; and its NumPy view."""
    if torch is None:
        a = _np.empty(shape, dtype)
        return a, a
    kind = {_np.dtype(_np.float32): torch.float32, _np.dtype(bool): torch.bool,
            _np.dtype(_np.uint8): torch.uint8}[_np.dtype(dtype)]
    if shared:  # as torch's default_collate allocates its output in workers
        elem = torch.empty(0, dtype=kind)
        numel = int(_np.prod(shape))
        t = elem.new(elem.storage()._new_shared(numel)).resize_(shape)
        a = t.numpy()
    else:
        t = torch.empty(shape, dtype=kind)
        a = t.numpy()
    return t, a


class _Batch(list):
    """What RenderDataset.__getitems__ returns: the per-sample views of one rendered batch (what
    any collate_fn expects) and ``.batch``, the collated dict, which :func:`collate` returns
    without copying."""

    def __init__(self, batch, n):
        super().__init__(
            {k: v[j] for k, v in batch.items()}
            for j in range(n))
        self.batch = batch


def _shape_text(shape):
    return "x".join(str(n) for n in shape)


def collate(samples):
    """Stacks a list of dict samples into a batch: arrays become one array per key (torch
    tensors when torch is imported, as DataLoader's default collate gives), ``params``, ``id``,
    ``K`` and the ``psf`` kernels (one size per sample) stay lists. Samples of different sizes raise one ValueError naming the sizes and
    their items (use ``crop=`` / ``size=``, or :class:`BucketBatchSampler`)."""
    if isinstance(samples, _Batch):
        return samples.batch  # rendered straight into the batch (RenderDataset.__getitems__)
    if not samples:
        raise ValueError("collate: an empty batch")
    torch = _sys.modules.get("torch")
    out = {}
    for key in samples[0]:
        values = [s[key] for s in samples]
        first = values[0]
        if key in _LISTED:
            out[key] = values
            continue
        if torch is not None and isinstance(first, torch.Tensor):
            values = [v.numpy() for v in values]
            first = values[0]
        if isinstance(first, _np.ndarray):
            shapes = {}
            for s, v in zip(samples, values):
                shapes.setdefault(v.shape, []).append(s.get("index", len(shapes)))
            if len(shapes) > 1:
                sizes = "; ".join("%s (items %s)" % (_shape_text(k), ", ".join(map(str, v[:4])))
                                  for k, v in shapes.items())
                raise ValueError("collate: '%s' has different sizes in one batch: %s; pass crop= "
                                 "or size= to the dataset, or batch with "
                                 "turbid.data.BucketBatchSampler" % (key, sizes))
            if torch is not None:  # in a worker: stacked into shared memory, as torch does
                out[key] = torch.utils.data.default_collate(values)
            else:
                out[key] = _np.stack(values)
        elif key == "index" and torch is not None:
            out[key] = torch.tensor(values)
        else:
            out[key] = values
    return out


class BucketBatchSampler:
    """Batches of indices whose samples have one size (``dataset.sample_size``), so that
    :func:`collate` never sees mixed sizes: pass it as a DataLoader's ``batch_sampler``.
    ``shuffle`` with ``seed``: the order is drawn per epoch (:meth:`set_epoch`);
    ``drop_last`` drops each size's incomplete batch."""

    def __init__(self, dataset, batch_size, shuffle=True, drop_last=False, seed=0):
        self.batch_size = _int(batch_size, "batch_size", 1, 1 << 30)
        self.shuffle, self.drop_last = bool(shuffle), bool(drop_last)
        self.seed, self.epoch = _seed(seed), 0
        self.buckets = {}
        for i in range(len(dataset)):
            self.buckets.setdefault(tuple(dataset.sample_size(i)), []).append(i)

    def set_epoch(self, epoch):
        """The shuffle of ``epoch``."""
        self.epoch = _seed(epoch, "epoch")

    def _batches(self):
        rng = _np.random.default_rng([self.seed, self.epoch])
        batches = []
        for size in sorted(self.buckets):
            idx = list(self.buckets[size])
            if self.shuffle:
                rng.shuffle(idx)
            for k in range(0, len(idx), self.batch_size):
                b = idx[k:k + self.batch_size]
                if len(b) == self.batch_size or not self.drop_last:
                    batches.append(b)
        if self.shuffle:
            rng.shuffle(batches)
        return batches

    def __iter__(self):
        return iter(self._batches())

    def __len__(self):
        return len(self._batches())
