"""Python speaks Python (issue 33 items 3 and 4): pickling, docstrings, stubs, report / merge /
regress, dotted parameters and NumPy numbers."""
import ast
import inspect
import json
import os
import pickle

import numpy as np
import pytest

import turbid
from turbid import data

EXP = {"name": "a", "seed": 3, "scale": 0.1, "scenes": ["builtin:room", "builtin:seafloor"],
       "grid": {"water.beta_gray_per_m": [0.5, 1.0]}, "methods": ["clahe"], "metrics": ["psnr"],
       "thumbnails": 0}
HERE = os.path.dirname(turbid.__file__)


def test_scenes_results_and_datasets_pickle(tmp_path):
    room = turbid.Scene.builtin("room", 0.1)
    arrays = turbid.Scene.from_arrays(room.image, room.depth, 50, 50, 32, 24, name="mine")
    for scene in (room, arrays):
        back = pickle.loads(pickle.dumps(scene))
        assert back.name == scene.name and back.camera == scene.camera
        assert np.array_equal(back.image, scene.image)
        assert np.array_equal(turbid.render(back, seed=1).image, turbid.render(scene, seed=1).image)
    r = turbid.render(room, {"water": {"type": "3C"}}, seed=2, maps="transmission")
    back = pickle.loads(pickle.dumps(r))
    assert np.array_equal(back.image, r.image) and np.array_equal(back.lit, r.lit)
    assert np.array_equal(back.maps["transmission"], r.maps["transmission"])
    assert back.sidecar == r.sidecar and back.plan == r.plan
    ds = data.RenderDataset({"scenes": ["builtin:room"], "scale": 0.1, "seed": 1}, crop=32)
    ds.set_epoch(3)
    again = pickle.loads(pickle.dumps(ds))
    assert again.epoch == 3 and np.array_equal(again[0]["degraded"], ds[0]["degraded"])
    t = data.DegradeTransform({"params": {"water.type": {"choice": ["I", "3C"]}}}, crop=16)
    t2 = pickle.loads(pickle.dumps(t))
    k = (50, 50, 32, 24)
    assert np.array_equal(t2(room.image, room.depth, k, seed=4)["degraded"],
                          t(room.image, room.depth, k, seed=4)["degraded"])


def public_names():
    for module in (turbid, data):
        for name in module.__all__:
            obj = getattr(module, name)
            if name.startswith("__"):
                continue
            yield "%s.%s" % (module.__name__, name), obj
            if inspect.isclass(obj):
                for attr, value in vars(obj).items():
                    if not attr.startswith("_"):
                        yield "%s.%s.%s" % (module.__name__, name, attr), value


def test_every_public_name_has_a_docstring():
    missing = []
    for qualified, obj in public_names():
        if isinstance(obj, (str, tuple, int)):
            continue  # constants: documented where they are used
        doc = obj.__doc__ if not isinstance(obj, staticmethod) else obj.__func__.__doc__
        if not doc or not doc.strip():
            missing.append(qualified)
    assert not missing, missing
    assert len(list(public_names())) > 40


def test_stubs_ship_and_cover_the_public_names():
    assert os.path.exists(os.path.join(HERE, "py.typed"))
    for module, stub in ((turbid, "__init__.pyi"), (data, "data.pyi")):
        tree = ast.parse(open(os.path.join(HERE, stub)).read())
        stubbed = {n.name for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
        stubbed |= {t.id for n in tree.body if isinstance(n, ast.AnnAssign) for t in [n.target]}
        for name in module.__all__:
            assert name in stubbed, (stub, name)
            obj = getattr(module, name)
            if inspect.isfunction(obj):  # the stub's parameters are the function's
                node = next(n for n in tree.body if getattr(n, "name", None) == name)
                assert [a.arg for a in node.args.args] == \
                    list(inspect.signature(obj).parameters), name


def test_report_merge_and_regress(tmp_path):
    for i in range(2):
        turbid.sweep(EXP, tmp_path / ("s%d" % i), shard="%d/2" % i, threads=1)
    with pytest.raises(ValueError, match="allow_partial=True"):
        turbid.merge([tmp_path / "s0"], tmp_path / "partial")
    assert turbid.merge([tmp_path / "s0", tmp_path / "s1"], tmp_path / "m") == 4
    whole = tmp_path / "whole"
    turbid.sweep(EXP, whole, threads=1)
    assert (tmp_path / "m" / "items.csv").read_text() == (whole / "items.csv").read_text()
    same = turbid.regress(whole / "items.csv", tmp_path / "m")
    assert not same["failed"] and same["compared"] >= 4 and same["moves"] == []
    # A worse baseline-relative result is a regression.
    worse = (whole / "items.csv").read_text().splitlines()
    header = worse[0].split(",")
    col = header.index("psnr")
    rows = [line.split(",") for line in worse[1:]]
    for row in rows:
        if row[col] not in ("", "nan"):
            row[col] = str(float(row[col]) + 1.0)  # the baseline was 1 dB better
    (tmp_path / "base.csv").write_text("\n".join([worse[0]] + [",".join(r) for r in rows]) + "\n")
    bad = turbid.regress(tmp_path / "base.csv", tmp_path / "m")
    assert bad["failed"] and all(m["metric"] == "psnr" and m["regression"] for m in bad["moves"])
    assert not turbid.regress(tmp_path / "base.csv", tmp_path / "m",
                              tolerances={"psnr": 1.5})["failed"]
    out = turbid.report(whole, gnuplot="/nonexistent/gnuplot")
    assert os.path.exists(out["html"]) and out["plots"] == 0 and out["warning"]
    with pytest.raises(ValueError, match="force=True"):  # Python's words, not --force
        turbid.sweep(dict(EXP, name="b"), whole, threads=1)


def test_dotted_paths_and_numpy_numbers():
    scene = turbid.Scene.builtin("room", 0.1)
    nested = {"water": {"type": "3C"}, "psf": {"forward_scatter": 0.5}}
    want = turbid.render(scene, nested, seed=3).image
    for params in ({"water.type": "3C", "psf.forward_scatter": 0.5},
                   {"water": {"type": "3C"}, "psf.forward_scatter": np.float32(0.5)},
                   {"water.type": np.str_("3C"), "psf": {"forward_scatter": np.float64(0.5)}}):
        assert np.array_equal(turbid.render(scene, params, seed=np.int64(3)).image, want)
    assert turbid.resolve_params({"water.type": "3C"}) == turbid.resolve_params(
        {"water": {"type": "3C"}})
    # Arrays where lists go; a light's field by index.
    lights = turbid.resolve_params({"light.lights.0.power": np.float32(2.0)})
    assert lights["light"]["lights"][0]["power"] == 2.0
    beta = turbid.resolve_params({"water": {"type": "custom",
                                            "beta_rgb_per_m": np.array([0.1, 0.2, 0.3])}})
    assert beta["water"]["beta_rgb_per_m"] == pytest.approx([0.1, 0.2, 0.3])
    assert data.draw_params({}, 0, base={"water.type": "II"})["water"]["type"] == "II"
    with pytest.raises(ValueError, match="water.tpye"):
        turbid.render(scene, {"water.tpye": "3C"})


def test_nested_samplers_equal_dotted_everywhere(tmp_path):
    """One configuration language: nested objects and dotted paths are the same samplers in
    generate's random / DegradeTransform, a sweep's samples and render, and --set."""
    dotted = {"water.type": {"choice": ["I", "3C", "5C"]},
              "psf.forward_scatter": {"uniform": [0.2, 0.8]},
              "snow.density_per_m3": {"log_uniform": [0.5, 20.0]},
              "light.lights.0.power": {"int_uniform": [1, 9]}}
    nested = {"water": {"type": {"choice": ["I", "3C", "5C"]}},
              "psf": {"forward_scatter": {"uniform": [0.2, 0.8]}},
              "snow.density_per_m3": {"log_uniform": [0.5, 20.0]},
              "light": {"lights": {"0": {"power": {"int_uniform": [1, 9]}}}}}
    config = {"scenes": ["builtin:room"], "scale": 0.1, "seed": 2, "base": {"snow.enabled": True}}
    a = data.RenderDataset(dict(config, random={"count": 6, "params": dotted}))
    b = data.RenderDataset(dict(config, random={"count": 6, "params": nested},
                                base={"snow": {"enabled": True}}))
    assert [a.params(i) for i in range(6)] == [b.params(i) for i in range(6)]
    assert len({a.params(i)["water"]["type"] for i in range(6)}) > 1
    assert all(a.params(i)["light"]["lights"][0]["power"] in range(1, 10) for i in range(6))
    assert np.array_equal(a[3]["degraded"], b[3]["degraded"])
    for i in range(4):
        assert data.draw_params({"params": dotted}, i) == data.draw_params({"params": nested}, i)
    with pytest.raises(ValueError, match="random.params.water.type must be a distribution"):
        data.DegradeTransform({"params": {"water": {"type": "3C"}}})
    with pytest.raises(ValueError, match="given twice"):
        data.draw_params({"params": dict(nested, **{"water.type": {"choice": ["I"]}})}, 0)
    with pytest.raises(ValueError, match="tpye"):
        data.RenderDataset(dict(config, random={"params": {"water": {"tpye": {"choice": ["I"]}}}}))
    # A sweep's samples and render.
    exp = dict(EXP, grid={"water.beta_gray_per_m": [0.5]},
               samples={"count": 2, "seed": 4, "params": {"psf.forward_scatter": {
                   "uniform": [0.2, 0.8]}}}, render={"sensor.enabled": False})
    nested_exp = dict(exp, samples={"count": 2, "seed": 4, "params": {"psf": {"forward_scatter": {
        "uniform": [0.2, 0.8]}}}}, render={"sensor": {"enabled": False}})
    rows = []
    for name, e in (("d", exp), ("n", nested_exp)):
        turbid.sweep(dict(e, name=name), tmp_path / name, threads=1)
        with open(tmp_path / name / "experiment.json") as f:
            rows.append(json.load(f))
    assert rows[0]["samples"] == rows[1]["samples"]
    assert rows[0]["render_resolved"] == rows[1]["render_resolved"]
    assert rows[0]["render_resolved"]["sensor"]["enabled"] is False


def test_numpy_numbers_in_configs(tmp_path):
    config = {"scenes": ["builtin:room"], "scale": np.float64(0.1), "seed": np.int64(3),
              "random": {"count": np.int32(2), "params": {
                  "psf.forward_scatter": {"uniform": np.array([0.2, 0.8])}}}}
    plain = {"scenes": ["builtin:room"], "scale": 0.1, "seed": 3,
             "random": {"count": 2, "params": {"psf.forward_scatter": {"uniform": [0.2, 0.8]}}}}
    a, b = data.RenderDataset(config), data.RenderDataset(plain)
    assert len(a) == 2 and a[1]["params"] == b[1]["params"]
    assert pickle.loads(pickle.dumps(a))[1]["params"] == b[1]["params"]
    turbid.generate(config, tmp_path / "g", threads=1)
    assert len((tmp_path / "g" / "manifest.jsonl").read_text().splitlines()) == 2
    exp = dict(EXP, scale=np.float32(0.1), grid={"water.beta_gray_per_m": np.array([0.5])})
    assert turbid.sweep(exp, tmp_path / "s", threads=1)["items_total"] == 2
