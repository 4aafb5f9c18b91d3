"""Dataset adapters from Python: an NYU Depth v2 labelled file written by h5py (the layout MATLAB
v7.3 writes, independently of turbid's HDF5 reader) and an RGB-D folder whose depth maps NumPy
writes with np.save (independently of turbid's .npy reader). Expected values come from the arrays
written, never from the readers."""
import json

import numpy as np
import pytest

import turbid

W, H = 640, 480
# Kinect RGB intrinsics of the NYU Depth v2 toolbox (camera_params.m), as published.
NYU_K = (518.85790117450188, 519.46961112127485, 325.58244941119034, 253.73616633400465)


def srgb_decode(v):  # IEC 61966-2-1
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def nyu_frames(n):
    """Frames as a user sees them: RGB uint8 (H, W, 3) and depth float32 (H, W) metres."""
    y, x = np.mgrid[0:H, 0:W]
    rgb = np.stack([(x // 3) % 256, (y // 2) % 256, np.full_like(x, 40 * n + 7)], axis=-1)
    depth = 1.0 + x / 640.0 + 2.0 * y / 480.0 + n
    return rgb.astype(np.uint8), depth.astype(np.float32)


def write_nyu(path, count=2, depths=True, transform=None, compress=False):
    """A MATLAB v7.3-style file: 512-byte user block, `images` (N, 3, 640, 480) uint8 and `depths`
    (N, 640, 480) float32 -- MATLAB's column-major 480x640x3xN seen slowest-axis first.
    `compress`: chunked and deflate-compressed, as MATLAB's save -v7.3 writes by default."""
    h5py = pytest.importorskip("h5py")
    frames = [nyu_frames(n) for n in range(count)]
    images = np.stack([rgb.transpose(2, 1, 0) for rgb, _ in frames])
    depth = np.stack([d.T for _, d in frames])
    if transform:
        images, depth = transform(images, depth)
    kw = {"chunks": True, "compression": "gzip", "compression_opts": 3} if compress else {}
    with h5py.File(path, "w", userblock_size=512) as f:
        f.create_dataset("images", data=images, **kw)
        f["images"].attrs["MATLAB_class"] = np.bytes_("uint8")
        if depths:
            f.create_dataset("depths", data=depth, **kw)
            f["depths"].attrs["MATLAB_class"] = np.bytes_("single")
    return frames


def write_json(path, obj):
    path.write_text(json.dumps(obj))
    return str(path)


def test_nyu_v2_file_written_by_h5py(tmp_path):
    frames = write_nyu(tmp_path / "nyu.mat", compress=True)
    spec = write_json(tmp_path / "nyu.json", {"type": "nyu_v2", "file": "nyu.mat", "color": "linear"})
    assert turbid.Scene.frames(spec) == [spec + "#0", spec + "#1"]
    for n, (rgb, depth) in enumerate(frames):
        scene = turbid.Scene.load(spec + "#%d" % n)
        assert scene.name == "nyu_%d" % n
        assert (scene.width, scene.height) == (W, H)
        assert np.array_equal(scene.image, rgb.astype(np.float32) / 255)
        assert np.array_equal(scene.depth, depth)
        c = scene.camera
        assert (c["fx"], c["fy"], c["cx"], c["cy"]) == NYU_K

    # sRGB decoding (the default) and the toolbox's border crop: rows 44..470, columns 40..600.
    crop = write_json(tmp_path / "crop.json",
                      {"type": "nyu_v2", "file": "nyu.mat", "frames": 1, "crop_border": True})
    scene = turbid.Scene.load(crop)
    rgb, depth = frames[1]
    assert (scene.width, scene.height) == (561, 427)
    np.testing.assert_allclose(scene.image, srgb_decode(rgb[44:471, 40:601] / 255.0), atol=1e-6)
    assert np.array_equal(scene.depth, depth[44:471, 40:601])
    assert scene.camera["cx"] == pytest.approx(NYU_K[2] - 40, abs=1e-12)
    assert scene.camera["cy"] == pytest.approx(NYU_K[3] - 44, abs=1e-12)


def test_nyu_v2_bad_files_raise_one_line(tmp_path):
    spec = write_json(tmp_path / "s.json", {"type": "nyu_v2", "file": "x.mat", "frames": 0})
    mat = str(tmp_path / "x.mat")

    def expect(message):
        with pytest.raises(ValueError) as e:
            turbid.Scene.load(spec)
        text = str(e.value)
        assert "\n" not in text and text.startswith(mat + ": ") and message in text, text

    write_nyu(tmp_path / "x.mat", count=1, depths=False)
    expect("has no dataset 'depths'")
    # A NumPy (N, 3, H, W) array stored without MATLAB's axis reversal.
    write_nyu(tmp_path / "x.mat", count=1,
              transform=lambda im, d: (np.ascontiguousarray(im.transpose(0, 1, 3, 2)), d))
    expect("it looks transposed")

    def hole(im, d):
        d = d.copy()
        d[0, 17, 3] = np.nan  # column 17, row 3
        return im, d
    write_nyu(tmp_path / "x.mat", count=1, transform=hole)
    expect("'depths' frame 0 has depth nan at pixel (17, 3)")
    write_nyu(tmp_path / "x.mat", count=1,
              transform=lambda im, d: (im, np.where(d > 3.5, -1.0, d).astype(np.float32)))
    expect("has depth -1")
    (tmp_path / "x.mat").write_bytes(b"MATLAB 5.0 MAT-file, not HDF5")
    expect("not an HDF5 file")


def write_folder(root, depth_of, stems=("f10", "f2", "f1")):
    """rgb/STEM.png beside depth/STEM.npy (np.save); frame i gets red code 50 i + 5."""
    (root / "rgb").mkdir(parents=True)
    (root / "depth").mkdir()
    h, w = 6, 8
    y, x = np.mgrid[0:h, 0:w]
    out = {}
    for i, stem in enumerate(stems):
        rgb = np.stack([np.full_like(x, 50 * i + 5), 30 * y, 20 * x], axis=-1).astype(np.float32) / 255
        turbid.write_image(root / "rgb" / (stem + ".png"), rgb, encoding="linear")
        depth = depth_of(i, x, y)
        np.save(root / "depth" / (stem + ".npy"), depth)
        out[stem] = (rgb, depth)
    return out


def folder_json(tmp_path, name, **keys):
    obj = {"type": "folder", "folder": "data", "color": "linear",
           "camera": {"fx": 10, "fy": 11, "cx": 3.5, "cy": 2.5}}
    obj.update(keys)
    return write_json(tmp_path / name, obj)


def test_folder_dataset_with_numpy_depth(tmp_path):
    def depth_of(i, x, y):
        d = (1.5 + 0.1 * x + 0.25 * y + i).astype(np.float64)
        d[0, 0] = np.nan  # a Hypersim-style hole
        return d
    frames = write_folder(tmp_path / "data", depth_of)
    spec = folder_json(tmp_path, "all.json")
    assert turbid.Scene.frames(spec) == [spec + "#f1", spec + "#f2", spec + "#f10"]  # natural order
    for stem, (rgb, depth) in frames.items():
        scene = turbid.Scene.load(spec + "#" + stem)
        assert scene.name == "all_" + stem
        # code / 255 in float32, up to the last bit of the division (1 code = 3.9e-3).
        np.testing.assert_allclose(scene.image, rgb, rtol=0, atol=1e-7)
        assert np.isnan(scene.depth[0, 0])
        assert np.array_equal(scene.depth[1:], depth[1:].astype(np.float32))

    # uint16 millimetres need depth_scale; ray distances become z = r / |K^-1 (x, y, 1)|.
    mm = write_folder(tmp_path / "mm" / "data",
                      lambda i, x, y: (1000 + 100 * x + 250 * y + 1000 * i).astype(np.uint16),
                      stems=("a",))
    spec = folder_json(tmp_path / "mm", "mm.json", frames=["a"], depth_scale=1000)
    assert np.array_equal(turbid.Scene.load(spec).depth, mm["a"][1].astype(np.float32) / 1000)
    spec = folder_json(tmp_path / "mm", "ray.json", frames=0, depth_scale=1000, depth_kind="ray")
    y, x = np.mgrid[0:6, 0:8]
    norm = np.sqrt(((x - 3.5) / 10) ** 2 + ((y - 2.5) / 11) ** 2 + 1)
    np.testing.assert_allclose(turbid.Scene.load(spec).depth, mm["a"][1] / 1000 / norm, rtol=1e-6)
    with pytest.raises(ValueError, match="'depth_scale' is required for integer depth files"):
        turbid.Scene.load(folder_json(tmp_path / "mm", "noscale.json", frames=0))


def test_folder_dataset_bad_npy_raise_one_line(tmp_path):
    write_folder(tmp_path / "data", lambda i, x, y: np.asfortranarray(1.0 + 0 * x, dtype=np.float32),
                 stems=("a",))
    spec = folder_json(tmp_path, "s.json")
    npy = str(tmp_path / "data" / "depth" / "a.npy")
    with pytest.raises(ValueError) as e:
        turbid.Scene.load(spec)
    assert str(e.value).startswith(npy + ": ") and "Fortran-order" in str(e.value)
    np.save(npy, np.full((6, 8), -0.5, np.float32))
    with pytest.raises(ValueError, match="negative depth value -0.5 at pixel"):
        turbid.Scene.load(spec)
    np.save(npy, np.ones((6, 8, 1), np.float32))
    with pytest.raises(ValueError, match="a depth map must be 2-D"):
        turbid.Scene.load(spec)
    (tmp_path / "data" / "depth" / "a.npy").unlink()
    with pytest.raises(ValueError, match="without a depth file of the same stem"):
        turbid.Scene.frames(spec)


def test_generate_and_render_dataset_expand_frames(tmp_path):
    write_folder(tmp_path / "data", lambda i, x, y: (2.0 + 0.1 * x + i).astype(np.float32))
    spec = folder_json(tmp_path, "set.json", frames="1:3")  # f2, f10
    # scale 1: generate scales built-ins only, RenderDataset file scenes too (test_data.py).
    config = {"scenes": [spec, "builtin:room"], "scale": 1.0, "seed": 4,
              "grid": {"psf.optical_thickness": [0.5, 1.5]}}
    ds = turbid.data.RenderDataset(config, channels=None)
    assert len(ds) == 3 * 2
    turbid.generate(config, tmp_path / "out", threads=2)
    rows = [json.loads(line) for line in (tmp_path / "out" / "manifest.jsonl").read_text().splitlines()]
    assert [r["scene"] for r in rows] == [spec + "#f2"] * 2 + [spec + "#f10"] * 2 + ["builtin:room"] * 2
    assert [r["id"][:-7] for r in rows[:4]] == ["set_f2", "set_f2", "set_f10", "set_f10"]
    for i in (0, 3):
        degraded, clean, params = (ds[i][k] for k in ("degraded", "clean", "params"))
        if clean.shape[2] == 1:
            degraded, clean = degraded[:, :, 0], clean[:, :, 0]
        assert ds.item_id(i) == rows[i]["id"] and params == rows[i]["options"]
        assert np.array_equal(clean, turbid.Scene.load(rows[i]["scene"]).image)
        png = turbid.read_image(tmp_path / "out" / rows[i]["image"], encoding="srgb")
        assert rows[i]["encoding"] == "srgb"  # the same 8-bit codes, decoded in float vs double
        assert np.abs(degraded - png).max() < 2e-6
