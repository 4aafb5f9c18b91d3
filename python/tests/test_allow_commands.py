"""An experiment's external "command" methods run only with turbid.sweep(..., allow_commands=True)."""
import os

import pytest

import turbid


def command_experiment(marker):
    # `touch MARKER {input} {output}` runs once per image: the marker says whether anything ran
    # (the empty output fails the cells, which is fine here).
    return {
        "name": "commands",
        "seed": 3,
        "scale": 0.1,
        "scenes": ["builtin:hull"],
        "grid": {"water.beta_gray_per_m": [0.4]},
        "methods": ["clahe", {"name": "toucher", "command": ["touch", str(marker), "{input}",
                                                             "{output}"],
                              "env": {"LD_PRELOAD": ""}, "timeout_s": 30}],
        "metrics": ["psnr"],
        "thumbnails": 0,
    }


def test_command_method_refused_before_any_work_without_allow_commands(tmp_path):
    marker = tmp_path / "ran"
    out = tmp_path / "out"
    with pytest.raises(ValueError) as error:
        turbid.sweep(command_experiment(marker), out)
    message = str(error.value)
    assert "method 'toucher'" in message
    assert "allow_commands=True" in message
    assert "--allow-commands" not in message  # Python-facing messages speak Python
    assert "\n" not in message
    assert not marker.exists()
    assert not out.exists()  # refused before the output folder was created


def test_experiment_file_cannot_allow_its_own_commands(tmp_path):
    marker = tmp_path / "ran"
    exp = command_experiment(marker)
    exp["allow_commands"] = True
    with pytest.raises(ValueError):
        turbid.sweep(exp, tmp_path / "out")
    assert not marker.exists()


def test_allow_commands_runs_them(tmp_path):
    marker = tmp_path / "ran"
    s = turbid.sweep(command_experiment(marker), tmp_path / "out", allow_commands=True)
    assert s["ran"] == 1
    assert marker.exists()
    assert os.path.exists(tmp_path / "out" / "items.csv")
