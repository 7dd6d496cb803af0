"""The hard-case matrix and the bad-input matrix, as markdown tables.

Hard cases: each row is case, stepper, expected outcome, what happened (status,
message excerpt, numbers), wall time. The same cases are asserted in
tests/test_robustness.py (Verlet) and tests/test_events.py (event stepper).

    python benchmarks/robustness_matrix.py verlet event

Bad input: every case of tests/test_bad_input.py (CASES), run in-process through
``granular_chain.cli.main`` in a fresh temporary folder with 4 GiB of memory to
plan with; each row is case, command, expected (exit 2, one line naming the
field), what happened (exit status, number of stderr lines, the line with the
folder replaced by DIR, whether the folder changed) and the time. A summary per
category comes first.

    python benchmarks/robustness_matrix.py bad-input > benchmarks/results/bad_input_matrix.md
"""

import math
import time

import numpy as np

import granular_chain as gc
from granular_chain.simulate import SimulationError
from granular_chain.two_granules import collide


def scene(stepper, **parts):
    base = {"name": "hard", "granules": {"count": 2, "velocity": [1.0, 0.0]}}
    base.update(parts)
    base.setdefault("run", {})
    base["run"] = {**base["run"], "stepper": stepper}
    return gc.scene_from_dict(base)


def run_scene(s):
    try:
        r = gc.simulate(s, progress=False)
    except SimulationError as exc:
        return f"refused: {exc}"
    return (f"{r.status.name.lower()}: v_final = {np.array2string(r.v_final, precision=6)}, "
            f"ledger error {r.energy.balance_error:.1e}, steps {r.steps}")


def cases(stepper):
    yield ("mass ratio 1e-6", "elastic: v = ((m1-m2)/(m1+m2), 2 m1/(m1+m2))",
           lambda: run_scene(scene(stepper, granules={"count": 2, "mass": [1.0, 1e-6], "velocity": [1.0, 0.0], "radius": 1.0},
                                   run={"stop": "separation", "t_end": 1e4})))
    yield ("mass ratio 1e6", "elastic: v = ((m1-m2)/(m1+m2), 2 m1/(m1+m2))",
           lambda: run_scene(scene(stepper, granules={"count": 2, "mass": [1.0, 1e6], "velocity": [1.0, 0.0], "radius": 1.0},
                                   run={"stop": "separation", "t_end": 1e4})))
    yield ("stiffness ratio 1e6 (3 granules)", "success, ledger closes",
           lambda: run_scene(scene(stepper, granules={"count": 3, "velocity": {0: 1.0}},
                                   contacts={"stiffness": [1.0, 1e6]}, run={"t_end": 20.0})))
    for eta, exp in ((0.0, "propagation_only"), (1e-12, "backscatter_and_propagation (v1 ~ -1e-12)"),
                     (1e6, "stuck")):
        yield (f"kinetic friction {eta:g} on both", exp,
               lambda eta=eta: _collide(stepper, eta=(eta, eta)))
    yield ("gamma dt = 10 (gamma = 1e4)", "stable, no_separation", lambda: _collide(stepper, gamma=(1e4, 1e4), t_max=10.0))
    for g in (math.sqrt(8.0), 3.0):
        yield (f"gamma = {g:.4g} (gamma^2 >= 8), n = 2", "no_separation in bounded time",
               lambda g=g: _collide(stepper, gamma=(g, g), t_max=200.0))
    if stepper == "verlet":
        yield ("dt = 2 on a contact of period 4.44", "refused, limit named",
               lambda: run_scene(scene(stepper, run={"dt": 2.0})))
        yield ("dt = 3 with run.check_dt off", "stops with a status, no NaN",
               lambda: run_scene(scene(stepper, granules={"count": 5, "velocity": {0: 1.0}},
                                       run={"dt": 3.0, "t_end": 1000.0, "check_dt": False})))
    yield ("precompressed chain, overlaps 0.2 (radius 0.5)", "success, ledger closes",
           lambda: run_scene(scene(stepper, granules={"count": 10, "gap": -0.2, "velocity": {0: 0.1}},
                                   contacts={"exponent": 2.5},
                                   walls={"left": {"gap": -0.2, "exponent": 2.5}, "right": {"gap": -0.2, "exponent": 2.5}},
                                   run={"t_end": 50.0})))
    for v0, radius in ((1e-8, 0.5), (1e3, 500.0)):
        yield (f"impact speed {v0:g}, Hertz, radius {radius:g}", "exchange, t_c ~ v^(-1/5)",
               lambda v0=v0, radius=radius: run_scene(scene(
                   stepper, granules={"count": 2, "velocity": [v0, 0.0], "radius": radius},
                   contacts={"exponent": 2.5}, run={"stop": "separation", "t_end": 1e6})))
    yield ("impact speed 1000, Hertz, radius 0.5 (overlap would reach 208)",
           "status overlap, clear message",
           lambda: run_scene(scene(stepper, granules={"count": 2, "velocity": [1e3, 0.0]},
                                   contacts={"exponent": 2.5},
                                   run={"stop": "separation", "t_end": 1e6})))
    yield ("soft contact pushed through", "status overlap, clear message",
           lambda: run_scene(scene(stepper, granules={"count": 2, "mass": 2.0, "radius": [0.5, 0.375],
                                                      "velocity": [2.0, 0.0]}, run={"t_end": 8.0})))
    yield ("N = 1", "ballistic", lambda: run_scene(gc.scene_from_dict(
        {"granules": {"count": 1, "velocity": 2.0}, "run": {
            "t_end": 1.0, "stepper": stepper, **({"dt": 0.1} if stepper == "verlet" else {})}})))
    if stepper == "verlet":
        yield ("N = 1e6, 50 steps", "success", lambda: run_scene(gc.scene_from_dict(
            {"granules": {"count": 1_000_000, "velocity": {0: 1.0}}, "contacts": {"exponent": 2.5},
             "run": {"dt": 1e-2, "t_end": 0.5}})))
        yield ("1e8 steps, 2 granules between stiff walls", "bounded ledger error",
               lambda: run_scene(scene(stepper, granules={"count": 2, "velocity": [1.0, -0.5], "gap": 0.3},
                                       contacts={"exponent": 2.5, "stiffness": 100.0},
                                       walls={"left": {"gap": 0.2, "exponent": 2.5, "stiffness": 100.0},
                                              "right": {"gap": 0.2, "exponent": 2.5, "stiffness": 100.0}},
                                       run={"dt": 1e-3, "t_end": 1e5}, output={"every": 1_000_000})))


def _collide(stepper, **kw):
    kw.setdefault("t_max", 1000.0)
    try:
        c = collide(2, stepper=stepper, dt=1e-3 if stepper == "verlet" else None, **kw)
    except Exception as exc:  # report, do not hide: the table shows it
        return f"error: {type(exc).__name__}: {exc}"
    return (f"{c.outcome.name}: v1 = {c.v1:.6g}, v2 = {c.v2:.6g}, t_sep = {c.t_separation:.6g}")


def main(steppers=("verlet", "event")):
    print("| case | stepper | expected | what happened | time (s) |")
    print("|---|---|---|---|---|")
    for stepper in steppers:
        for name, expected, fn in cases(stepper):
            t0 = time.perf_counter()
            try:
                what = fn()
            except Exception as exc:
                what = f"error: {type(exc).__name__}: {exc}"
            dt = time.perf_counter() - t0
            print(f"| {name} | {stepper} | {expected} | {what.replace('|', '/')} | {dt:.3g} |", flush=True)


def bad_input_rows():
    """Run every bad-input case; yield (case, exit status, stderr lines, folder changed, seconds)."""
    import contextlib
    import io
    import os
    import sys
    import tempfile
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    import test_bad_input as T

    from granular_chain import budget
    from granular_chain.cli import main as cli

    budget.available_memory = lambda: T.MEMORY
    home = os.getcwd()
    with tempfile.TemporaryDirectory() as top:
        run_dir = Path(top) / "finished" / "run"
        run_dir.parent.mkdir()
        (run_dir.parent / "s.yaml").write_text(T.dump(T.scene(**{"output.trajectory": True,
                                                                   "walls": {}})))
        with contextlib.redirect_stderr(io.StringIO()):
            cli(["run", str(run_dir.parent / "s.yaml"), "--out", str(run_dir), "--quiet"])
        for i, case in enumerate(T.CASES):
            folder = Path(top) / f"case{i}"
            folder.mkdir()
            T._write(folder, case.files)
            before = T.snapshot(folder)
            argv = [a.replace("{dir}", str(folder)).replace("{run}", str(run_dir))
                    for a in case.argv]
            err = io.StringIO()
            os.chdir(folder)
            t0 = time.perf_counter()
            try:
                with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                    try:
                        code = cli(argv)
                    except SystemExit as exc:
                        code = exc.code
            finally:
                os.chdir(home)
            seconds = time.perf_counter() - t0
            lines = err.getvalue().strip().replace(str(folder), "DIR").replace(
                str(run_dir), "RUN").splitlines()
            changed = sorted(set(T.snapshot(folder)) ^ set(before)) or (
                ["(contents)"] if T.snapshot(folder) != before else [])
            yield case, code, lines, changed, seconds


def bad_input_main():
    rows = list(bad_input_rows())
    cats = {}
    for case, code, lines, changed, _ in rows:
        ok = code == 2 and len(lines) == 1 and lines[0].startswith("granular-chain: ") and all(
            f in lines[0] for f in case.expect)
        c = cats.setdefault(case.category, [0, 0, 0])
        c[0] += 1
        c[1] += ok
        c[2] += bool(changed)
    print(f"{len(rows)} cases; exit 2 with one line naming the field: "
          f"{sum(c[1] for c in cats.values())}; folder changed: {sum(c[2] for c in cats.values())}\n")
    print("| category | cases | exit 2, one line, field named | folder changed |")
    print("|---|---|---|---|")
    for name, (n, ok, ch) in cats.items():
        print(f"| {name} | {n} | {ok} | {ch} |")
    print("\n| case | command | expected | what happened | changed | time (s) |")
    print("|---|---|---|---|---|---|")
    for case, code, lines, changed, seconds in rows:
        what = f"exit {code}, {len(lines)} line(s): " + " / ".join(lines)[-300:]
        print(f"| {case.id} | {case.argv[0]} | exit 2 naming {', '.join(case.expect)} | "
              f"{what.replace('|', '/')} | {' '.join(changed) or '-'} | {seconds:.3f} |")


if __name__ == "__main__":
    import sys
    if sys.argv[1:] == ["bad-input"]:
        bad_input_main()
    else:
        main(tuple(sys.argv[1:]) or ("verlet", "event"))
