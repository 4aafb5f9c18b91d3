"""The array boundary of the package: what callers hand in (NumPy arrays, CPU torch tensors,
anything with ``__array__``, ``__dlpack__`` or the buffer protocol; any strides; float16/32/64,
uint8, uint16; the channel axis anywhere; leading batch dimensions) becomes the N x H x W x C or
H x W x C C-contiguous array the C++ half takes, and results go back in the caller's kind and
layout (a tensor for a tensor, the channel axis where it was)."""

import operator as _operator
import sys as _sys

import numpy as _np

from . import _turbid


def _first_line(error):
    text = str(error).strip().splitlines()
    text = text[0] if text else type(error).__name__
    return text if len(text) <= 160 else text[:157] + "..."


def _is_torch(value):
    return type(value).__module__.split(".")[0] == "torch"  # without importing torch


def to_numpy(value, what):
    """``value`` as a NumPy array, sharing its memory where it can, or one short TypeError."""
    if isinstance(value, _np.ndarray):
        return value
    kind = type(value).__name__
    if value is None or isinstance(value, (str, bytes, dict, set, int, float, complex)):
        raise TypeError("%s: an array (numpy.ndarray, a CPU torch tensor or anything "
                        "numpy.asarray takes), not %s" % (what, kind))
    if _is_torch(value):
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


class Layout:
    """How the caller holds its images: ``torch`` (a tensor came in), ``axis`` (where the channel
    axis is, as a non-negative index; None for a single H x W image), ``batch`` (the leading
    dimensions)."""

    def __init__(self, torch, axis, batch):
        self.torch, self.axis, self.batch = torch, axis, batch

    def restore(self, out):
        """A result (H x W x C or N x H x W x C NumPy, float) in the caller's kind and layout."""
        if self.axis is None:
            if out.ndim == 3 and out.shape[2] == 1:
                out = out[:, :, 0]
        else:
            if out.ndim == 2 + (1 if self.batch else 0):
                out = out[..., None]  # a gray result of an H x W x 1 input keeps its axis
            out = out.reshape(self.batch + out.shape[-3:])
            if self.axis != out.ndim - 1:
                out = _np.ascontiguousarray(_np.moveaxis(out, -1, self.axis))
        return self.tensor(out)

    def tensor(self, out):
        if self.torch and isinstance(out, _np.ndarray):
            return _sys.modules["torch"].from_numpy(out)
        return out


def _axis(channel_axis, ndim, what):
    try:
        axis = _operator.index(channel_axis)
    except TypeError:
        raise TypeError("%s: channel_axis must be an integer, not %s"
                        % (what, type(channel_axis).__name__)) from None
    if not -ndim <= axis < ndim:
        raise ValueError("%s: channel_axis=%d is out of range for %d dimensions"
                         % (what, axis, ndim))
    return axis % ndim


def images(value, what, channel_axis=-1, color=True, float_only=False, batch=True):
    """``value`` as the array the C++ half takes and the caller's :class:`Layout`.

    H x W is one gray image; with 3 or more dimensions the ``channel_axis`` (default last; -3 for
    C x H x W, N x C x H x W) holds 1 or 3 channels (1 only unless ``color``), and dimensions
    before the image's are batch dimensions (``batch``). Returns an H x W, H x W x C or (with a
    batch) N x H x W x C C-contiguous array in native byte order, dtype uint8, uint16 or float32
    (other float types converted; ``float_only``: float32), sharing the memory when nothing needs
    converting; raises one short TypeError (not an array, dtype) or ValueError (shape, size)."""
    torch = _is_torch(value)
    a = to_numpy(value, what)
    dtype = a.dtype
    if not (dtype.kind == "f" or (dtype.kind == "u" and dtype.itemsize in (1, 2)
                                  and not float_only)):
        accepted = ("float32; float16 and float64 are converted" if float_only else
                    "uint8, uint16 or float32; float16 and float64 are converted")
        raise TypeError("%s: dtype %s is not supported (%s)" % (what, dtype.name, accepted))
    channels = (1, 3) if color else (1,)
    wanted = "H x W%s" % (" or H x W x 3" if color else "")
    if a.ndim == 2:
        layout = Layout(torch, None, ())
    elif a.ndim >= 3 and (batch or a.ndim == 3):
        axis = _axis(channel_axis, a.ndim, what)
        if a.shape[axis] not in channels or axis < a.ndim - 3:
            hint = ""
            if a.shape[-1] in channels and axis != a.ndim - 1:
                hint = " (channels last? pass channel_axis=-1)"
            elif a.shape[-3] in channels and axis != a.ndim - 3:
                hint = " (channels first? pass channel_axis=-3)"
            raise ValueError("%s: shape %s has no channel axis of %s at channel_axis=%s%s"
                             % (what, tuple(a.shape), " or ".join(map(str, channels)),
                                channel_axis, hint))
        a = _np.moveaxis(a, axis, -1)
        layout = Layout(torch, axis, tuple(a.shape[:-3]))
    else:
        raise ValueError("%s: shape %s is not %s%s" % (
            what, tuple(a.shape), wanted, "" if batch else " (one image, no batch)"))
    if a.size == 0:
        raise ValueError("%s: array is empty" % what)
    height, width = (a.shape[0], a.shape[1]) if a.ndim == 2 else (a.shape[-3], a.shape[-2])
    _turbid._check_image_size(what, int(width), int(height))  # before any copy
    if dtype.kind == "f" and dtype.itemsize != 4:
        a = _np.ascontiguousarray(a, dtype=_np.float32)
    elif not dtype.isnative:
        a = a.astype(dtype.newbyteorder("="))
    a = _np.require(a, requirements=["C_CONTIGUOUS", "ALIGNED"])
    if a.ndim > 3:
        a = a.reshape((-1,) + a.shape[-3:])
    elif a.ndim == 3 and layout.batch:  # cannot happen: a batch has 4+ dimensions
        raise AssertionError
    return a, layout


def single(value, what, channel_axis=-1, **kw):
    """One image (no batch dimensions) as the C++ half takes it: H x W or H x W x C."""
    a, layout = images(value, what, channel_axis, batch=False, **kw)
    return a, layout
