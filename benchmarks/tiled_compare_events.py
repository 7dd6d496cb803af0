"""tiled_compare.py's Verlet scenes with ``output.events: true``: the event log changes
nothing (the Verlet stepper's event log; event-stepper scenes run as they are).

Dumps the same .npz as ``tiled_compare.py --dump`` but with every scene logging its
events, so that ``tiled_compare.py --compare`` against a dump without the log (or of
the tree before the log existed) shows the run bit-identical; and checks, per scene,
that the logged events of each kind add up to the counts (the wall contacts, which
the counts leave out, excluded). Prints ``LOGCHECK`` lines and the number of mismatches.

    PYTHONPATH=<checkout> python benchmarks/tiled_compare_events.py out.npz
    python benchmarks/tiled_compare.py --compare before.npz out.npz
"""

import importlib
import runpy
import sys
from collections import Counter
from pathlib import Path

import granular_chain as gc

_scene_from_dict = gc.scene_from_dict
_sim = importlib.import_module("granular_chain.simulate")
_simulate_verlet = _sim._simulate_verlet
MISMATCHES = []


def with_log(d):
    d = dict(d)
    if d.get("run", {}).get("stepper", "verlet") == "verlet":  # (the event stepper has no
        d["output"] = {**d.get("output", {}), "events": True}  # output.events: it refuses it)
    return _scene_from_dict(d)


def checked(scene, model, progress):
    r = _simulate_verlet(scene, model, progress)
    walls = (-1, model.count - 1)
    logged = Counter(e.kind for e in r.events
                     if not (e.kind.startswith("contact") and e.index in walls))
    counted = {k: n for k, n in r.event_counts.items() if n}
    ok = dict(logged) == counted
    print("LOGCHECK", ok, len(r.events), dict(logged), counted, flush=True)
    if not ok:
        MISMATCHES.append(counted)
    return r


if __name__ == "__main__":
    gc.scene_from_dict = with_log
    _sim._simulate_verlet = checked
    out = sys.argv[1]
    sys.argv = ["tiled_compare.py", "--dump", out]
    runpy.run_path(str(Path(__file__).with_name("tiled_compare.py")), run_name="__main__")
    print("LOGCHECK mismatches:", len(MISMATCHES))
