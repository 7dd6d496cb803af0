"""Writers attached to a run write while it goes: the same numbers as writing a
finished Result, without keeping the frames in memory."""

import csv

import numpy as np
import pytest

import granular_chain as gc
from granular_chain.cli import main
from granular_chain.frames import FrameLog
from granular_chain.model import build_model
from granular_chain.writers.tables import EnergyTable, write_energy_csv
from granular_chain.writers.thermo import COLUMNS, ThermoLog


def chain(stepper="verlet", **run):
    return gc.scene_from_dict({
        "name": "stream",
        "granules": {"count": 30, "velocity": {0: 0.1},
                     "friction": {"kinetic": [0.0] * 15 + [2e-5] * 15, "viscous": 1e-4}},
        "contacts": {"exponent": 2.5},
        "walls": {"right": {"gap": 0.0, "exponent": 2.5}},
        "run": {"stepper": stepper, "t_end": 60.0,
                **({"dt": 0.02} if stepper == "verlet" else {}), **run},
        "output": {"every": 25}})


class Collect:
    def __init__(self):
        self.frames, self.closed = [], None

    def write_frame(self, frame):
        self.frames.append((frame.step, frame.t, frame.x.copy(), frame.v.copy()))

    def close(self, result):
        self.closed = result


def test_streamed_frames_equal_kept_frames_and_memory_keeps_two():
    kept = gc.simulate(chain(), progress=False)
    sink = Collect()
    streamed = gc.simulate(chain(), progress=False, writers=[sink], keep_frames=False)
    assert sink.closed is streamed and len(sink.frames) == kept.t.size == 121
    for q, (step, t, x, v) in enumerate(sink.frames):
        assert step == 25 * q and t == kept.t[q]
        assert np.array_equal(x, kept.x[q]) and np.array_equal(v, kept.v[q])
    assert streamed.t.size == 2 and streamed.x.shape == (2, 30)
    assert np.array_equal(streamed.x_final, kept.x_final)
    assert streamed.info["frames"] == 121
    # the ledger error over every frame, though only two are kept
    assert streamed.energy.balance_error == kept.energy.balance_error > 0


def test_energy_table_streamed_is_the_table_of_the_result(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir(), b.mkdir()
    table = EnergyTable(a)
    result = gc.simulate(chain(), progress=False, writers=[table])
    write_energy_csv(result, b)
    assert (a / "energy.csv").read_bytes() == (b / "energy.csv").read_bytes()


def test_thermo_lines_on_their_own_cadence(tmp_path):
    scene = chain()
    model = build_model(scene)
    thermo = ThermoLog(model, every=40, path=tmp_path / "thermo.csv")
    result = gc.simulate(scene, progress=False, thermo=thermo)
    thermo.close()
    rows = list(csv.DictReader((tmp_path / "thermo.csv").open()))
    assert tuple(rows[0]) == COLUMNS
    steps = [int(r["step"]) for r in rows]
    assert steps == list(range(0, 3001, 40)) + [3000] * (3000 % 40 != 0)
    # the lines at frame steps (multiples of 200 = lcm(25, 40)) agree with the frames
    for r in rows:
        s = int(r["step"])
        if s % 25 == 0:
            q = s // 25
            e = result.energy
            assert float(r["kinetic"]) == e.kinetic[q] and float(r["t"]) == result.t[q]
            assert float(r["dissipated"]) == e.coulomb[q] + e.viscous[q]
            x = result.x[q]
            closed = np.count_nonzero(2 * 0.5 - np.diff(x) > 0) + int(
                x[-1] - model.x0[-1] + model.walls[3] > 0)
            assert int(r["contacts_closed"]) == closed
            assert int(r["sliding"]) == np.count_nonzero(result.v[q][15:] != 0)
    assert max(int(r["sliding"]) for r in rows) > 0 and max(
        int(r["contacts_closed"]) for r in rows) > 1


def test_cli_run_writes_thermo_and_prints_it(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.yaml").write_text(
        "granules: {count: 5, velocity: {0: 1.0}}\nrun: {t_end: 20}\noutput: {thermo: 100}\n")
    assert main(["run", "s.yaml", "--out", "r", "--csv"]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert printed[0].split() == ["step", "t", "kinetic", "potential", "dissipated", "ledger",
                                  "closed", "sliding"]
    rows = list(csv.DictReader((tmp_path / "r" / "thermo.csv").open()))
    assert len(rows) == len(printed[1:1 + len(rows)]) and int(rows[1]["step"]) == 100
    assert (tmp_path / "r" / "energy.csv").exists()
    assert max(len(line) for line in printed[:1 + len(rows)]) <= 79


def test_thermo_lines_fit_an_80_column_terminal(capsys):
    """The widest values a line can hold (a step count near run.max_steps, energies
    with 5 digits and an exponent) keep the printed line within 79 characters, each
    value apart from the next."""
    from granular_chain.writers.thermo import _Echo

    echo = _Echo()
    echo.line((1_999_999_999, 123456.78, 1.2345678e-05, 9.8765432e+10, 1.2345678e-300,
               1.5e-09, 9_999_999, 9_999_999))
    echo.line((0, 0.0, -1.2345678e-05, 0.5, -1.2345678e-300, 0.0, 0, 0))  # roundoff below 0
    header, *lines = capsys.readouterr().out.splitlines()
    assert len(header) <= 79 and all(len(line) <= 79 for line in lines)
    assert all(len(line.split()) == 8 for line in lines)


MEMORY_CHILD = """
import sys
from granular_chain.cli import main
sys.exit(main(sys.argv[1:]))
"""


def _peak_rss_mib(args, cwd) -> float:
    import os
    import subprocess
    import sys
    proc = subprocess.Popen([sys.executable, "-c", MEMORY_CHILD, *args], cwd=cwd,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0, proc.stderr.read()
    return usage.ru_maxrss / 1024  # kB on Linux


def test_memory_does_not_grow_with_the_number_of_frames(tmp_path):
    """A 2000-grain run writing 200 frames and one writing 5000 (240 MB of frames,
    streamed to trajectory.h5 and energy.csv) peak within 10 % of each other."""
    scene = tmp_path / "s.yaml"
    scene.write_text("name: mem\ngranules: {count: 2000, velocity: {0: 1.0}}\n"
                     "contacts: {exponent: 2.5}\nrun: {t_end: 50, dt: 0.01}\n")
    peaks = {}
    for frames in (200, 5000):
        every = 5000 // frames
        peaks[frames] = _peak_rss_mib(
            ["run", str(scene), "--out", f"r{frames}", "--quiet", "--csv",
             "--set", f"output.every={every}"], tmp_path)
        assert gc.read_run(tmp_path / f"r{frames}").t.size == frames + 1
    # kept in memory, the 5000 frames alone would add 3 x 5001 x 2000 x 8 B = 229 MiB
    assert abs(peaks[5000] - peaks[200]) < 0.10 * peaks[200], peaks


@pytest.mark.parametrize("stepper", ["verlet", "event"])
def test_energy_tolerance_sets_the_status(stepper):
    """A run whose ledger misses run.energy_tolerance is not a success, and says why."""
    base = chain(stepper)
    error = gc.simulate(base, progress=False).energy.balance_error
    assert error > 0
    for tolerance, status in ((error * 0.5, gc.Status.INACCURATE), (error * 2, gc.Status.T_END)):
        scene = chain(stepper, energy_tolerance=tolerance)
        r = gc.simulate(scene, progress=False, writers=[Collect()], keep_frames=False)
        assert r.status == status and r.success == (status == gc.Status.T_END)
        if status == gc.Status.INACCURATE:
            assert "run.energy_tolerance" in r.message and f"{error:.3g}" in r.message
