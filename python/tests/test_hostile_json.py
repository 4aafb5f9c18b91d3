"""Issue 28 items 6, 7 and 9 through Python: wide PSF kernels on tiny scenes, JSON nested past the
limit (core/json_io.h: 64 levels), config paths that are not regular files."""
import os

import numpy as np
import pytest

import turbid


def _nested(levels):
    value = 1
    for _ in range(levels):
        value = {"a": value}
    return value


def test_psf_wider_than_the_image_renders_finite():
    for scale in (0.002, 0.01, 0.05):
        scene = turbid.Scene.builtin("room", scale=scale)
        for psf in ({"forward_scatter": 0.01}, {"forward_scatter": 1e-4, "max_radius_px": 96},
                    {"forward_scatter": 0.001, "turbidity_dependent": True}):
            image = turbid.render(scene, params={"psf": psf}).image
            assert np.isfinite(image).all()


def test_params_nested_past_the_limit_are_one_value_error():
    scene = turbid.Scene.builtin("room", scale=0.05)
    with pytest.raises(ValueError, match="nested deeper than 64 levels") as info:
        turbid.render(scene, params={"psf": _nested(200)})
    assert "\n" not in str(info.value)


def test_generate_config_nested_past_the_limit(tmp_path):
    config = {"scenes": ["builtin:room"], "scale": 0.05, "base": _nested(100)}
    with pytest.raises(ValueError, match="nested deeper than 64 levels"):
        turbid.generate(config, str(tmp_path / "out"))
    path = tmp_path / "deep.json"
    path.write_text('{"scenes": ["builtin:room"], "base": ' + "[" * 100000 + "]" * 100000 + "}")
    with pytest.raises(ValueError, match="deep.json: invalid JSON: nested deeper"):
        turbid.generate(str(path), str(tmp_path / "out2"))
    dup = tmp_path / "dup.json"
    dup.write_text('{"scenes": ["builtin:room"], "scale": 0.05, "scale": 0.1}')
    with pytest.raises(ValueError, match="duplicate key 'scale'"):
        turbid.generate(str(dup), str(tmp_path / "out3"))


def test_config_that_is_not_a_regular_file_is_an_os_error(tmp_path):
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    for path in (str(fifo), "/dev/zero", str(tmp_path)):
        with pytest.raises(OSError, match="not a regular file"):
            turbid.generate(path, str(tmp_path / "out"))
