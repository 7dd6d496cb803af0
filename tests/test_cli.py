"""The command line: runs end to end; bad input gives one line, exit 2, nothing written."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from granular_chain.cli import main

ROOT = Path(__file__).resolve().parents[1]
TWO = ROOT / "scenarios" / "two_granules.yaml"


def test_run_writes_summary_and_trajectory(tmp_path):
    import h5py

    out = tmp_path / "run"
    assert main(["run", str(TWO), "--out", str(out), "--quiet"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    for key in ("status", "message", "t_final", "x_final", "v_final", "event_counts",
                "energy", "steps", "wall_time_s"):
        assert key in summary
    for key in ("kinetic", "potential", "friction_dissipated", "viscous_dissipated",
                "initial", "balance_error"):
        assert key in summary["energy"]
    assert summary["status"] == "separated"
    eta = 0.3
    import math
    assert summary["v_final"][1] == pytest.approx(math.sqrt(1 - eta ** 2) - eta * math.pi / (2 * math.sqrt(2)), abs=1e-8)
    with h5py.File(out / "trajectory.h5") as f:
        assert f["x"].shape == (len(f["time"]), 2) and f["x"].attrs["units"] == "1"
        assert "scaled" in f["x"].attrs["long_name"]
        assert yaml.safe_load(f.attrs["scene"])["name"] == "two_granules"
    assert [p.name for p in tmp_path.iterdir()] == ["run"]  # no temporary folder left


def test_set_overrides_change_the_run(tmp_path):
    out = tmp_path / "o"
    assert main(["run", str(TWO), "--out", str(out), "--quiet",
                 "--set", "granules.friction.kinetic=[0, 0]", "--set", "run.dt=1e-3"]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["dt"] == 1e-3 and s["energy"]["friction_dissipated"] == 0.0


BAD = {
    "yaml_error": ("granules: [\n", "invalid YAML"),
    "unknown_field": ("granules:\n  count: 2\n  masss: 1\n", "granules.masss: unknown field; did you mean 'mass'?"),
    "negative_mass": ("granules:\n  count: 2\n  mass: [1, -1]\n", "granules.mass[1]: Input should be greater than 0"),
    "wrong_length": ("granules:\n  count: 3\n  velocity: [1, 0]\n", "granules.velocity: has 2 values but granules.count is 3"),
    "zero_radius": ("granules:\n  count: 2\n  radius: 0\n", "granules.radius: Input should be greater than 0"),
    "nan": ("granules:\n  count: 2\n  velocity: [.nan, 0]\n", "granules.velocity[0]: must be a finite number"),
    "dt_negative": ("granules:\n  count: 2\nrun:\n  dt: -1\n", "run.dt: Input should be greater than 0"),
    "t_end_zero": ("granules:\n  count: 2\nrun:\n  t_end: 0\n", "run.t_end: Input should be greater than 0"),
    "stepper": ("granules:\n  count: 2\nrun:\n  stepper: rk4\n", "run.stepper: Input should be 'verlet' or 'event'"),
    "overlap": ("granules:\n  count: 2\n  gap: -0.6\n", "granules.gap: initial overlap 0.6"),
    "missing_count": ("granules:\n  mass: 1\n", "granules.count: is required but missing"),
    "dt_too_large": ("granules:\n  count: 2\n  velocity: [1, 0]\nrun:\n  dt: 5\n", "run.dt: 5 is too large for the stiffest contact"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_scene_one_line_exit_2_nothing_written(case, tmp_path, capsys):
    text, expected = BAD[case]
    scene = tmp_path / "bad.yaml"
    scene.write_text(text)
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert str(scene) in err and expected in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.yaml"]


def test_missing_file_and_bad_override_and_unwritable_out(tmp_path, capsys):
    assert main(["run", str(tmp_path / "nope.yaml")]) == 2
    assert "nope.yaml: no such file" in capsys.readouterr().err
    assert main(["run", str(TWO), "--set", "run.dtt=1", "--out", str(tmp_path / "o")]) == 2
    assert "run.dtt: unknown field; did you mean 'dt'?" in capsys.readouterr().err
    assert main(["run", str(TWO), "--set", "run", "--out", str(tmp_path / "o")]) == 2
    assert "dotted.path=value" in capsys.readouterr().err
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["run", str(TWO), "--out", str(blocker / "sub")]) == 2
    assert "--out" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


def test_validate_and_schema(capsys):
    assert main(["validate", str(TWO)]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["features"]["coulomb"] is True and info["features"]["viscous"] is False
    assert main(["schema"]) == 0
    schema = json.loads(capsys.readouterr().out)
    assert "granules" in schema["properties"]
    # bounds under JSON Schema's names, which other validators read
    text = json.dumps(schema)
    assert not any(f'"{key}":' in text for key in ("ge", "gt", "le", "lt"))
    count = schema["$defs"]["Granules"]["properties"]["count"]
    assert "minimum" in json.dumps(count) or "exclusiveMinimum" in json.dumps(count)


def test_console_script_exit_status(tmp_path):
    bad = tmp_path / "b.yaml"
    bad.write_text("granules:\n  count: -1\n")
    p = subprocess.run([sys.executable, "-m", "granular_chain.cli", "run", str(bad)],
                       capture_output=True, text=True, cwd=tmp_path)
    assert p.returncode == 2 and p.stdout == ""
    assert p.stderr.count("\n") == 1 and "granules.count" in p.stderr
    assert sorted(x.name for x in tmp_path.iterdir()) == ["b.yaml"]
