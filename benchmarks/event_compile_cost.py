"""Cold compile time of the event stepper's kernel, one feature set at a time.

Each feature set is measured in a fresh Python process whose ``NUMBA_CACHE_DIR``
is a new, empty temporary folder (set before numba is imported), so nothing is
loaded from disk: the process imports granular_chain and then times its first
``simulate`` of a tiny scene (10 granules, t_end = 0.1) with ``stepper: event``.
That call is almost all compilation: ``run_events`` specialised for the scene's
feature codes (contact law, Coulomb, viscous, dissipation) and every compiled
function it calls, plus the event driver's small helpers. Wall and CPU seconds
of the call are printed per feature set with their sums; on a shared machine the
CPU seconds are the steadier figure.

``--shared`` adds one more process that compiles the chosen feature sets one after
the other on a single empty cache, as a test suite does: functions the kernels
share are compiled once there, so its sum can be below the sum of the rows. Each
kernel's compile there is also split by compiled function (numba's
"numba:compile" events: CPU seconds of each function compiled, callees indented
under their caller and included in its time; inlined functions are part of their
caller's), which shows what a further feature set costs once the first is cached.

    PYTHONPATH=<checkout> python benchmarks/event_compile_cost.py [--repeats 1] [--only coulomb] [--shared]

Writes benchmarks/results/event_compile_cost.json (``--out`` to change).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

#: Feature set -> (friction mapping, contacts mapping) of the tiny scene.
FEATURES = {
    "frictionless n=5/2": ({}, {"exponent": 2.5, "stiffness": 1.0}),
    "coulomb n=5/2": ({"kinetic": 1e-3, "static": 2e-3}, {"exponent": 2.5, "stiffness": 1.0}),
    "viscous n=5/2": ({"viscous": 1e-2}, {"exponent": 2.5, "stiffness": 1.0}),
    "dashpot n=5/2": ({}, {"exponent": 2.5, "stiffness": 1.0,
                           "damping": {"model": "viscoelastic", "coefficient": 0.05}}),
    "coulomb+viscous n=5/2": ({"kinetic": 1e-3, "static": 2e-3, "viscous": 1e-2},
                              {"exponent": 2.5, "stiffness": 1.0}),
    "frictionless n=2": ({}, {"exponent": 2.0, "stiffness": 1.0}),
}

CHILD = r"""
import json, sys, time
from numba.core import event
import granular_chain as gc


class Compiles(event.Listener):
    # (depth, function, CPU s) of every function numba compiles, callees after callers
    def __init__(self):
        self.open, self.rows = [], []

    def on_start(self, ev):
        self.rows.append([len(self.open), ev.data["dispatcher"].py_func.__qualname__, 0.0])
        self.open.append((len(self.rows) - 1, time.process_time()))

    def on_end(self, ev):
        row, c0 = self.open.pop()
        self.rows[row][2] = time.process_time() - c0


out = []
for friction, contacts in json.loads(sys.argv[1]):
    scene = gc.scene_from_dict({"name": "c", "granules": {"count": 10, "mass": 1.0,
        "radius": 0.5, "gap": 0.0, "velocity": {0: 1.0}, "friction": friction},
        "contacts": contacts, "run": {"stepper": "event", "t_end": 0.1},
        "output": {"trajectory": False}})
    w0, c0 = time.perf_counter(), time.process_time()
    watch = Compiles()
    with event.install_listener("numba:compile", watch):
        gc.simulate(scene, progress=False)
    out.append({"wall": time.perf_counter() - w0, "cpu": time.process_time() - c0,
                "functions": watch.rows})
print(json.dumps(out))
"""


def measure(feature_sets):
    """Wall and CPU seconds of the first event-stepper run of each (friction, contacts)
    pair, one after the other in one process on an empty numba cache."""
    with tempfile.TemporaryDirectory(prefix="event_compile_") as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        p = subprocess.run([sys.executable, "-c", CHILD, json.dumps(feature_sets)],
                           env=env, capture_output=True, text=True, check=True)
    return json.loads(p.stdout.strip().splitlines()[-1])


def _commit(root: Path) -> str:
    """The checkout's commit (short hash), not a machine path; "unknown" outside git."""
    p = subprocess.run(["git", "-C", str(root), "rev-parse", "--short", "HEAD"],
                       capture_output=True, text=True)
    return p.stdout.strip() or "unknown"


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeats", type=int, default=1, help="cold runs per feature set (min kept)")
    p.add_argument("--only", nargs="*", help="only the feature sets whose names contain these")
    p.add_argument("--shared", action="store_true",
                   help="also compile them all in one process on one empty cache")
    p.add_argument("--out", default=str(Path(__file__).with_name("results")
                                        / "event_compile_cost.json"))
    args = p.parse_args()
    import granular_chain
    rows = {}
    chosen = {name: fc for name, fc in FEATURES.items()
              if not args.only or any(s in name for s in args.only)}
    for name, feature_set in chosen.items():
        runs = [measure([feature_set])[0] for _ in range(args.repeats)]
        rows[name] = {"wall": min(r["wall"] for r in runs), "cpu": min(r["cpu"] for r in runs),
                      "runs": runs}
        print(f"{name:22s} wall {rows[name]['wall']:7.1f} s   cpu {rows[name]['cpu']:7.1f} s",
              flush=True)
    total = {k: sum(r[k] for r in rows.values()) for k in ("wall", "cpu")}
    print(f"{'sum':22s} wall {total['wall']:7.1f} s   cpu {total['cpu']:7.1f} s")
    out = {"checkout": _commit(Path(granular_chain.__file__).resolve().parents[1]),
           "python": sys.version.split()[0], "repeats": args.repeats,
           "features": rows, "sum": total}
    if args.shared:
        runs = measure(list(chosen.values()))
        out["shared"] = {name: r for name, r in zip(chosen, runs)}
        out["shared_sum"] = {k: sum(r[k] for r in runs) for k in ("wall", "cpu")}
        print(f"{'one cache, in turn':22s} wall {out['shared_sum']['wall']:7.1f} s   "
              f"cpu {out['shared_sum']['cpu']:7.1f} s")
        for name, r in out["shared"].items():
            print(f"\n{name}: cpu {r['cpu']:.1f} s, by compiled function (>= 0.5 s):")
            for depth, function, cpu in r["functions"]:
                if cpu >= 0.5:
                    print(f"  {'  ' * depth}{function:{40 - 2 * depth}s} {cpu:6.1f}")
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(args.out).with_suffix(".json.tmp")
    tmp.write_text(json.dumps(out, indent=1) + "\n")
    tmp.replace(args.out)


if __name__ == "__main__":
    main()
