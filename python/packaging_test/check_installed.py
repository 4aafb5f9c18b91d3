"""Run by scripts/test_wheel.sh inside a fresh venv where only the built wheel is installed: the
package imports from the venv (not the build tree), its plugins load from beside the extension,
and it renders, enhances and scores."""
import os
import struct
import sys

import numpy as np

venv = sys.argv[1]
import turbid  # noqa: E402

where = os.path.realpath(turbid.__file__)
assert where.startswith(os.path.realpath(venv)), f"turbid imported from {where}, not from {venv}"
print("imported from", where)
# The type information ships in the wheel (PEP 561).
for typed in ("py.typed", "__init__.pyi", "data.pyi"):
    assert os.path.exists(os.path.join(os.path.dirname(where), typed)), typed + " not installed"


def write_gray_tiff(path, pixels):
    """A baseline uncompressed 8-bit gray TIFF (TIFF 6.0), written by hand: no imaging library."""
    h, w = pixels.shape
    data = pixels.astype(np.uint8).tobytes()
    entries = [  # tag, type (3 = SHORT, 4 = LONG), value
        (256, 4, w), (257, 4, h), (258, 3, 8), (259, 3, 1), (262, 3, 1), (273, 4, 8),
        (277, 3, 1), (278, 4, h), (279, 4, len(data)),
    ]
    ifd_offset = 8 + len(data)
    out = b"II*\x00" + struct.pack("<I", ifd_offset) + data
    out += struct.pack("<H", len(entries))
    for tag, kind, value in entries:
        if kind == 3:
            out += struct.pack("<HHIHH", tag, kind, 1, value, 0)
        else:
            out += struct.pack("<HHII", tag, kind, 1, value)
    out += struct.pack("<I", 0)
    with open(path, "wb") as f:
        f.write(out)


# A TIFF is read through the OpenImageIO plugin (turbid_oiio.so), dlopen'ed from beside the
# extension module: the one in the venv.
gray = (np.arange(48, dtype=np.uint8).reshape(6, 8) * 5)
write_gray_tiff("gray.tif", gray)
image = turbid.read_image("gray.tif", encoding="linear")
assert image.shape[:2] == (6, 8), image.shape
np.testing.assert_allclose(np.asarray(image).reshape(6, 8), gray / 255.0, atol=1e-6)
with open("/proc/self/maps") as f:
    plugins = {line.split()[-1] for line in f if "turbid_oiio" in line}
assert plugins, "the OpenImageIO plugin was not loaded"
for path in plugins:
    assert os.path.realpath(path).startswith(os.path.realpath(venv)), f"plugin loaded from {path}"
print("plugin loaded from", sorted(plugins)[0])

scene = turbid.Scene.builtin("seafloor", scale=0.1)
degraded = turbid.render(scene, {"water": {"type": "3C"}}, seed=1).image
restored = turbid.enhance(degraded, "clahe")
scores = turbid.score(restored, ref=scene.image, metrics=["psnr"])
assert np.isfinite(scores["psnr"]), scores
print("render, enhance, score: psnr", round(float(scores["psnr"]), 3))
