"""turbid.water.fit gives the numbers `turbid water fit` writes for the same frame, its params render
as they are, and the dataset takes "water_from" fits (docs/cli/water.md)."""
import json
import os
import subprocess

import numpy as np
import pytest

import turbid
import turbid.data

# A known `revised` water without lights, PSF, snow or noise (the closed loop's coastal water).
WATER = {"model": "revised", "light": {"lights": []}, "psf": {"enabled": False},
         "snow": {"enabled": False}, "sensor": {"enabled": False},
         "water": {"type": "custom", "beta_rgb_per_m": [0.6, 0.25, 0.3],
                   "ambient_rgb": [0.9, 0.9, 0.9], "backscatter_rgb": [0.06, 0.28, 0.3]},
         "revised": {"beta_b_rgb_per_m": [0.55, 0.4, 0.45]}}


def dark_seafloor(scale):
    """The built-in seafloor with every 37th pixel black: Sea-thru needs dark pixels at every
    range (as the closed-loop tests, tests/enhancer/seathru_closed_loop_test.cc)."""
    scene = turbid.Scene.builtin("seafloor", scale)
    image = scene.image.copy()
    flat = image.reshape(-1, 3)
    flat[::37] = 0
    c = scene.camera
    return turbid.Scene.from_arrays(image, scene.depth, c["fx"], c["fy"], c["cx"], c["cy"])


def murky_frame(tmp_path, name, scale, camera):
    """The seafloor rendered in WATER, written as a scene file (16-bit linear PNG + EXR depth);
    returns (scene path, image as the file holds it, depth, K)."""
    scene = dark_seafloor(scale)
    image = turbid.render(scene, WATER, seed=1).image
    png, exr = tmp_path / (name + ".png"), tmp_path / (name + "_depth.exr")
    turbid.write_image(png, image, bit_depth=16, encoding="linear")
    turbid.write_image(exr, scene.depth, encoding="linear")  # EXR: float, unclipped
    c = scene.camera
    k = (c["fx"], c["fy"], c["cx"], c["cy"])
    doc = {"type": "depth", "name": name, "image": png.name, "depth": exr.name, "color": "linear",
           "camera": "unknown" if camera is None else dict(zip(("fx", "fy", "cx", "cy"), k))}
    path = tmp_path / (name + ".json")
    path.write_text(json.dumps(doc))
    return path, turbid.read_image(png, encoding="linear"), scene.depth, k


def cli_fit(cli, tmp_path, scenes, options=None):
    out = tmp_path / "cli_fit.json"
    args = [cli, "water", "fit"] + [str(s) for s in scenes] + ["--out", str(out), "--force"]
    if options is not None:
        (tmp_path / "options.json").write_text(json.dumps(options))
        args += ["--options", str(tmp_path / "options.json")]
    run = subprocess.run(args, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    return (json.loads(out.read_text()),
            json.loads((tmp_path / "cli_fit.diagnostics.json").read_text()))


def assert_same(a, b):
    """Equal JSON values, numbers to 1e-9 relative (the same code: in practice bit-equal)."""
    if isinstance(a, dict):
        assert sorted(a) == sorted(b)
        for k in a:
            assert_same(a[k], b[k])
    elif isinstance(a, list):
        assert len(a) == len(b)
        for x, y in zip(a, b):
            assert_same(x, y)
    elif isinstance(a, float) or isinstance(b, float):
        assert a == pytest.approx(b, rel=1e-9, abs=1e-12)
    else:
        assert a == b


def test_fit_matches_the_cli_on_the_same_frame(cli, tmp_path):
    path, image, depth, k = murky_frame(tmp_path, "f", 0.5, camera="known")
    params, diagnostics = cli_fit(cli, tmp_path, [path])
    fit = turbid.water.fit(image, depth, K=k)
    assert_same(fit.params, params)
    assert_same(fit.diagnostics, diagnostics)
    assert fit.plot.shape == (420, 1000, 3) and fit.plot.dtype == np.float32
    # A 3 x 3 K is the same camera; integer data with its encoding the same image.
    kmat = np.array([[k[0], 0, k[2]], [0, k[1], k[3]], [0, 0, 1]])
    assert_same(turbid.water.fit(image, depth, K=kmat).params, params)
    raw = np.round(image * 65535).astype(np.uint16)
    assert_same(turbid.water.fit(raw, depth, K=k, encoding="linear").params, params)
    # The fit is close to the water it was rendered in (the closed-loop tests hold the bounds).
    assert fit.params["revised"]["beta_b_rgb_per_m"] == pytest.approx([0.55, 0.4, 0.45], rel=0.1)


def test_unknown_camera_options_and_several_frames_match_the_cli(cli, tmp_path):
    a, image_a, depth_a, k = murky_frame(tmp_path, "a", 0.4, camera=None)
    b, image_b, depth_b, _ = murky_frame(tmp_path, "b", 0.3, camera=None)
    options = {"range_bins": 8, "dark_percent": 2.0, "fit_illuminant_scale": False}
    params, diagnostics = cli_fit(cli, tmp_path, [a, b], options)
    fit = turbid.water.fit([image_a, image_b], [depth_a, depth_b], options=options)
    assert_same(fit.params, params)
    assert_same(fit.diagnostics, diagnostics)
    assert fit.diagnostics["frames"] == 2
    # Range given as range: K is not applied.
    assert_same(turbid.water.fit([image_a, image_b], [depth_a, depth_b], K=[k, k],
                                 depth_kind="range", options=options).params, params)


def test_params_render_as_they_are_and_errors_are_plain(tmp_path):
    scene = dark_seafloor(0.3)
    image = turbid.render(scene, WATER, seed=2).image
    c = scene.camera
    k = (c["fx"], c["fy"], c["cx"], c["cy"])
    fit = turbid.water.fit(image, scene.depth, K=k)
    assert turbid.render(scene, fit.params, seed=2).image.shape == image.shape
    # Its veil is the true one: a black scene (backscatter alone) renders within 10 % in both
    # (B∞ within 5 %, β^B within 10 %: the closed-loop tests' bounds).
    black = turbid.Scene.from_arrays(np.zeros_like(scene.image), scene.depth, *k)
    extras = {key: WATER[key] for key in ("psf", "snow", "sensor")}
    truth = turbid.render(black, WATER).image
    refit = turbid.render(black, dict(fit.params, **extras)).image
    assert float(np.abs(refit - truth).max()) < 0.1 * float(truth.max())
    with pytest.raises(ValueError, match="range_binz"):
        turbid.water.fit(image, scene.depth, K=k, options={"range_binz": 3})
    with pytest.raises(ValueError, match="range_bins"):
        turbid.water.fit(image, scene.depth, K=k, options={"range_bins": 0})
    with pytest.raises(ValueError, match="RGB"):
        turbid.water.fit(image[:, :, 0], scene.depth, K=k)
    with pytest.raises(ValueError, match="same grid"):
        turbid.water.fit(image, scene.depth[:-1], K=k)
    with pytest.raises(ValueError, match="integer arrays need encoding"):
        turbid.water.fit((image * 255).astype(np.uint8), scene.depth, K=k)
    with pytest.raises(ValueError, match="both one array or both lists"):
        turbid.water.fit([image], scene.depth, K=k)
    with pytest.raises(ValueError, match="depth_kind"):
        turbid.water.fit(image, scene.depth, K=k, depth_kind="Z")
    with pytest.raises(ValueError, match="K"):
        turbid.water.fit(image, scene.depth, K=(1.0, 2.0))
    with pytest.raises(ValueError, match="needs K"):
        turbid.water.fit(image, scene.depth, depth_kind="z")
    with pytest.raises(ValueError):  # one range only: no bins to fit
        turbid.water.fit(image, np.full_like(scene.depth, 2.0))


def test_dataset_draws_water_from_fits_as_generate(cli, tmp_path):
    waters = []
    for i, beta in enumerate((0.2, 0.5, 0.9)):
        path = tmp_path / ("w%d.json" % i)
        path.write_text(json.dumps({"model": "revised", "water": {
            "type": "custom", "beta_rgb_per_m": [beta] * 3, "beta_gray_per_m": beta}}))
        waters.append(str(path))
    config = {"scenes": ["builtin:seafloor"], "scale": 0.05, "seed": 3,
              "random": {"count": 8, "seed": 4}, "water_from": waters}
    ds = turbid.data.RenderDataset(config, threads=None)
    betas = [ds[i]["params"]["water"]["beta_gray_per_m"] for i in range(len(ds))]
    assert set(betas) <= {0.2, 0.5, 0.9} and len(set(betas)) > 1
    # Epoch 0 is generate's items (the manifest names each item's fit).
    cfg = tmp_path / "g.json"
    cfg.write_text(json.dumps(config))
    run = subprocess.run([cli, "generate", str(cfg), "--out", str(tmp_path / "g")],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    rows = [json.loads(line) for line in (tmp_path / "g" / "manifest.jsonl").read_text().split("\n")
            if line]
    assert [r["options"]["water"]["beta_gray_per_m"] for r in rows] == betas
    assert [json.loads(open(r["water_from"]).read())["water"]["beta_gray_per_m"]
            for r in rows] == betas
    # Later epochs draw again, reproducibly.
    ds.set_epoch(1)
    again = turbid.data.RenderDataset(config, threads=None, epoch=1)
    epoch1 = [ds[i]["params"]["water"]["beta_gray_per_m"] for i in range(len(ds))]
    assert epoch1 == [again[i]["params"]["water"]["beta_gray_per_m"] for i in range(len(ds))]
    assert epoch1 != betas and set(epoch1) <= {0.2, 0.5, 0.9}
    with pytest.raises(OSError, match="no_such.json"):
        turbid.data.RenderDataset(dict(config, water_from=str(tmp_path / "no_such.json")))


def load_script():
    import importlib.util
    path = os.path.join(os.path.dirname(__file__), "..", "..", "scripts", "against_real_water.py")
    spec = importlib.util.spec_from_file_location("against_real_water", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_against_real_water_fits_and_measures_what_it_says():
    """scripts/against_real_water.py (docs/model.md "Against real water"): its paper fit recovers a
    known backscatter curve, the revised fit adds J' where the data has it, its paper restoration
    inverts the paper model, and the colour spread is 0 for a range-independent colour."""
    s = load_script()
    r = np.linspace(1.0, 9.0, 10)
    dark = 0.3 * (1 - np.exp(-0.4 * r))
    b_inf, beta = s.fit_paper_backscatter(r, dark)
    assert b_inf == pytest.approx(0.3, rel=1e-3) and beta == pytest.approx(0.4, abs=0.005)
    with_j = dark + 0.1 * np.exp(-1.5 * r)
    curve = s.fit_revised_backscatter(r, with_j)
    assert np.abs(curve - with_j).max() < 2e-3
    # The paper model rendered in closed form and restored: the reflectance comes back up to the
    # grey-world scale per channel.
    rng = np.random.default_rng(0)
    rho = rng.uniform(0.1, 0.9, (160, 200, 3)).astype(np.float32)
    depth = np.linspace(1.0, 6.0, 160 * 200).reshape(160, 200).astype(np.float32)
    b, be = np.array([0.2, 0.3, 0.4]), np.array([0.5, 0.3, 0.2])
    t = np.exp(-be * depth[..., None])
    image = (rho * t + b * (1 - t)).astype(np.float32)
    j = s.restore_paper(image, depth, b, be)
    for c in range(3):
        assert np.corrcoef(j[..., c].ravel(), rho[..., c].ravel())[0, 1] > 0.999
    _, logs = s.colour_by_range(rho, depth)
    assert s.spread(logs) < 0.02
    _, logs = s.colour_by_range(image, depth)
    assert s.spread(logs) > 0.08  # the unrestored image's colour depends on range (0.10)
