"""granules.state: a scene starts from positions and velocities in a file."""

import numpy as np
import pytest

import granular_chain as gc
from granular_chain.cli import main
from granular_chain.scene import SceneError

CHAIN = """\
name: {name}
granules:
  count: 20
  radius: 2.0
  {start}
contacts: {{exponent: 2.5}}
run: {{t_end: {t_end}, dt: 0.01}}
output: {{every: 50}}
"""


def scene_file(tmp_path, name, start, t_end):
    path = tmp_path / f"{name}.yaml"
    path.write_text(CHAIN.format(name=name, start=start, t_end=t_end))
    return path


def test_continuing_from_a_run_matches_the_longer_run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    striker = "velocity: {0: 1.0}"
    assert main(["run", str(scene_file(tmp_path, "first", striker, 5)), "--out", "a",
                 "--quiet"]) == 0
    first = gc.read_run(tmp_path / "a")
    # a relative file is taken from the scene file's folder
    then = scene_file(tmp_path, "then", "state: {file: a/trajectory.h5, frame: -1}", 5)
    cont = gc.simulate(gc.load_scene(then), progress=False)
    assert np.array_equal(cont.x[0], first.x_final) and np.array_equal(cont.v[0],
                                                                        first.v_final)
    whole = gc.simulate(gc.load_scene(scene_file(tmp_path, "whole", striker, 10)),
                        progress=False)
    # velocity Verlet restarts from (x, v): the same run up to the rounding of the
    # overlaps, formed from positions instead of from displacements
    assert np.max(np.abs(cont.x_final - whole.x_final)) < 1e-12
    assert np.max(np.abs(cont.v_final - whole.v_final)) < 1e-12
    assert np.max(np.abs(cont.v_final)) > 0.1


@pytest.mark.parametrize("kind", ["npz", "npz-frames", "csv"])
def test_tables_give_the_state(tmp_path, kind):
    x = 2.0 + np.arange(20) * 4.001
    v = np.linspace(-0.1, 0.1, 20)
    if kind == "npz":
        np.savez(tmp_path / "s.npz", x=x, v=v)
        spec = "{file: s.npz}"
    elif kind == "npz-frames":
        np.savez(tmp_path / "s.npz", x=np.stack([x - 1, x]), v=np.stack([v * 0, v]))
        spec = "{file: s.npz, frame: 1}"
    else:
        rows = ["id,x,v"] + [f"{i},{float(a)!r},{float(b)!r}" for i, (a, b) in enumerate(zip(x, v))]
        (tmp_path / "s.csv").write_text("\n".join(rows) + "\n")
        spec = "{file: s.csv}"
    scene = gc.load_scene(scene_file(tmp_path, "t", f"state: {spec}", 1))
    r = gc.simulate(scene, progress=False)
    assert np.array_equal(r.x[0], x) and np.array_equal(r.v[0], v)


@pytest.mark.parametrize("content, start, words", [
    ("id,x\n0,1.0\n", "state: {file: s.csv}", ["granules.state.file", "s.csv", "no column 'v'"]),
    ("x,v\n" + "1.0,0\n" * 3, "state: {file: s.csv}", ["has 3 values", "granules.count is 20"]),
    (None, "state: {file: s.npz, frame: 5}", ["frame 5 is out of range", "2 frames"]),
    (None, "state: {file: nowhere.h5}", ["granules.state.file", "no such file"]),
    (None, "state: {file: s.npz, frame: 0}\n  gap: 0.1", ["granules.state", "leave out granules.gap"]),
    ("x,v\n" + "".join(f"{20 - i},0\n" for i in range(20)), "state: {file: s.csv}",
     ["must increase"]),
])
def test_bad_state_files_are_refused_naming_file_and_column(tmp_path, content, start, words):
    if content is not None:
        (tmp_path / "s.csv").write_text(content)
    x = 2.0 + np.arange(20) * 4.0
    np.savez(tmp_path / "s.npz", x=np.stack([x, x]), v=np.zeros((2, 20)))
    with pytest.raises(SceneError) as err:
        gc.load_scene(scene_file(tmp_path, "bad", start, 1))
    message = str(err.value)
    assert "\n" not in message and all(w in message for w in words), message


def test_a_run_from_a_state_file_reads_back_after_the_file_is_gone(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    x = 2.0 + np.arange(20) * 4.001
    np.savez(tmp_path / "s.npz", x=x, v=np.full(20, 0.01))
    assert main(["run", str(scene_file(tmp_path, "t", "state: {file: s.npz}", 1)), "--out",
                 "r", "--quiet"]) == 0
    (tmp_path / "s.npz").unlink()
    back = gc.read_run(tmp_path / "r")
    assert back.scene.granules.state.file == str(tmp_path / "s.npz")
    assert np.array_equal(back.x[0], x)
