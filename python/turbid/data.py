"""turbid.data: degraded training data on the fly, deterministic per item.

* :class:`DegradeTransform` degrades an (image, depth, intrinsics) sample with parameters drawn
  from a sampler written as ``turbid generate``'s ``random`` section
  (``{"params": {"water.type": {"choice": ["I", "II", "3C"]}, "psf.forward_scatter":
  {"uniform": [0.2, 0.8]}}, "seed": 7}``; Jerlov types are values of ``water.type``).
* :class:`RenderDataset` is a map-style dataset over a ``turbid generate`` config (scenes x grid x
  samples): item *i* is rendered on demand with exactly the parameters ``turbid generate`` gives
  item *i*.

Draws come from a counter-based generator keyed by (seed, index), so item *i* is the same bytes in
any worker process, for any ``num_workers`` and any order. Works with
``torch.utils.data.DataLoader``; this module does not import torch.
"""

import json as _json

import numpy as _np

from . import _turbid
from . import Scene, RenderResult, _dumps, _int, _seed

__all__ = ["DegradeTransform", "RenderDataset", "draw_params"]


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
        return tuple(a)
    raise ValueError("intrinsics: a dict fx, fy, cx, cy, a 3x3 matrix K or (fx, fy, cx, cy)")


class DegradeTransform:
    """Degrades an (image, depth_m, intrinsics) sample: ``t(image, depth_m, K, index)`` returns
    ``(degraded, clean, params)`` with ``degraded`` the rendered image (float32 RGB), ``clean``
    the clean image as the renderer saw it (float32 linear RGB; ``ground_truth="lit"`` gives
    J = (E_A + E_L) rho instead) and ``params`` the resolved parameters (a dict).

    ``random``: generate's ``random`` section; ``base``: fixed parameters under the draws;
    ``seed``: seeds the renders' noise. ``index`` selects the draw: pass the dataset index so
    every epoch, worker and order sees the same degradation for the same sample (or
    ``epoch * len(dataset) + index`` for fresh draws each epoch). ``encoding``: for integer
    images ("srgb" for ordinary 8-bit photos)."""

    def __init__(self, random=None, base=None, seed=0, encoding=None, ground_truth="clean"):
        if ground_truth not in ("clean", "lit"):
            raise ValueError("ground_truth: 'clean' or 'lit'")
        self.random = dict(random or {})
        self.base = dict(base or {})
        self.seed = _seed(seed)
        self.encoding = encoding
        self.ground_truth = ground_truth
        draw_params(self.random, 0, self.base, self.seed)  # fail early on a bad sampler

    def __call__(self, image, depth_m, intrinsics, index):
        fx, fy, cx, cy = _intrinsics(intrinsics)
        params = draw_params(self.random, index, self.base, self.seed)
        scene = Scene.from_arrays(image, depth_m, fx, fy, cx, cy, encoding=self.encoding)
        result = RenderResult(_turbid.render(scene._core, _json.dumps(params), None, ""), [])
        clean = result.lit if self.ground_truth == "lit" else scene.image
        return result.image, clean, params


class RenderDataset:
    """Map-style dataset over a ``turbid generate`` config (dict or JSON path): ``len`` is the
    number of items generate would write; ``ds[i]`` renders item ``i`` and returns
    ``(degraded, clean, params)`` (float32 RGB arrays, H x W x 3, and the resolved parameter
    dict, the sidecar's "options"). ``ground_truth="lit"`` returns J instead of rho;
    ``channels_first=True`` gives 3 x H x W arrays (torch layout); ``with_params=False`` returns
    only the two arrays (cheaper to collate). Picklable: worker processes rebuild the scenes."""

    def __init__(self, config, ground_truth="clean", channels_first=False, with_params=True):
        if ground_truth not in ("clean", "lit"):
            raise ValueError("ground_truth: 'clean' or 'lit'")
        self.config = config
        self.ground_truth = ground_truth
        self.channels_first = bool(channels_first)
        self.with_params = bool(with_params)
        self._plan = _turbid.GeneratePlan(config)

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_plan"] = None
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._plan = _turbid.GeneratePlan(self.config)

    def __len__(self):
        return len(self._plan)

    def item_id(self, index):
        """generate's id of item ``index`` ("<scene>_<index, 6 digits>")."""
        return self._plan.item(self._index(index))[0]

    def _index(self, index):
        n = _int(index, "RenderDataset index", None)
        if not -len(self) <= n < len(self):
            raise IndexError("RenderDataset index %d out of range (%d items)" % (n, len(self)))
        return n + len(self) if n < 0 else n

    def __getitem__(self, index):
        if isinstance(index, slice) or not isinstance(index, (int, _np.integer)):
            raise TypeError("RenderDataset index must be an int")
        _, scene_index, params_text = self._plan.item(self._index(index))
        scene = self._plan.scene(scene_index)
        params = _json.loads(params_text)
        render_params = params
        if self._plan.format == "exr":  # as generate: float output, not quantised
            render_params = dict(params, camera=dict(params["camera"], bit_depth=32))
        core = _turbid.render(scene, _json.dumps(render_params), None, "")
        result = RenderResult(core, [])
        degraded = result.image
        clean = result.lit if self.ground_truth == "lit" else scene.image
        if clean.ndim == 2:
            clean = clean[:, :, None]
            degraded = degraded[:, :, None] if degraded.ndim == 2 else degraded
        if self.channels_first:
            degraded = _np.ascontiguousarray(degraded.transpose(2, 0, 1))
            clean = _np.ascontiguousarray(clean.transpose(2, 0, 1))
        if self.with_params:
            return degraded, clean, params
        return degraded, clean
