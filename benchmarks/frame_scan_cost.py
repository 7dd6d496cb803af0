"""What the Verlet driver's frame scan costs: microseconds a call at N = 10^4.

At every output frame the driver reads the state off in one compiled call
(``steppers/verlet/frame_scan.py``): it fills the frame's x, v, f, checks the
state and sums the kinetic and elastic energies. This times that call alone, as
the driver makes it (``VerletRun.scan``, the Python around the call included),
on two states of a Hertz chain (m = 1, radius 0.5, k = 1, n = 5/2, dt = 0.01):

- ``pulse``: a chain at rest struck at one end, stepped to t = 300, so a few
  hundred of its contacts are closed (the solitary wave and the striker's wake);
- ``compressed``: the same chain precompressed by an overlap of 0.01 at every
  contact and struck, so every contact is closed.

``reach`` 0 is the scan after a kernel call that paused on the frame cadence (the
kernel has checked every step), 1 after a call that ended early (the scan also
looks for centres that met). Prints one JSON line per case: the median over
--repeat batches of the microseconds per call.

``--against CHECKOUT`` also times that checkout's ``frame_scan.py`` in the same
process, on the same arrays (so CHECKOUT's ``scan_frame`` must take this tree's
records: ``Chain`` with the contact table's columns and the table's ``d0``, from
commit f444f6a on), in turn with this one (``against_us`` and the median
of the batch-by-batch ratio ``ratio``, this one over that one). Between two
processes the same call moves by up to 30 % on a 2-core virtual machine (where
the arrays land in memory), which hides a change of a few microseconds::

    python benchmarks/frame_scan_cost.py --against ../old-checkout
"""

import argparse
import importlib.util
import json
import statistics
import time
from pathlib import Path

import granular_chain as gc
from granular_chain._compile import specialised
from granular_chain.frames import FrameLog
from granular_chain.model import build_model
from granular_chain.steppers.verlet import frame_scan
from granular_chain.steppers.verlet.driver import VerletRun, _Chunk

STATES = {"pulse": 0.0, "compressed": -0.01}


def prepared(grains: int, gap: float) -> VerletRun:
    """A Verlet run of the struck chain stepped to t = 300 (no frames written)."""
    scene = gc.scene_from_dict({
        "name": "scan", "granules": {"count": grains, "velocity": {0: 1.0}, "gap": gap},
        "contacts": {"exponent": 2.5}, "run": {"dt": 0.01, "t_end": 1000.0}})
    run = VerletRun(scene, build_model(scene), False, log=FrameLog(keep=False))
    chunk = _Chunk(grains)
    while run.steps < 30_000:
        run._advance(chunk, 30_000 - run.steps)
    return run


def per_call_us(run: VerletRun, reach: bool, calls: int) -> float:
    begin = time.perf_counter()
    for _ in range(calls):
        run.scan(reach)
    return (time.perf_counter() - begin) / calls * 1e6


def other_scan(checkout: Path):
    """Another checkout's frame_scan module, loaded inside this package (its relative
    imports resolve here: the scan's own code is the other checkout's)."""
    path = checkout / "granular_chain" / "steppers" / "verlet" / "frame_scan.py"
    spec = importlib.util.spec_from_file_location(
        "granular_chain.steppers.verlet._frame_scan_against", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def use_scan(run: VerletRun, module) -> None:
    """Make ``run.scan`` call ``module.scan_frame`` (compiled for this run's records)."""
    x = run._v2.copy()
    run._scanner = specialised(module.scan_frame, (
        run._scan_codes, run.chain, run.chain.d0, run.u, run.vs, run.f, run.model.x0,
        module.FrameArrays(x, x, x, run._v2), 1), (0,))


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--grains", type=int, default=10_000)
    p.add_argument("--calls", type=int, default=2_000, help="calls per batch")
    p.add_argument("--repeat", type=int, default=7, help="batches (the median is printed)")
    p.add_argument("--against", type=Path, default=None,
                   help="another checkout whose frame scan to time in turn")
    a = p.parse_args()
    scans = {"this": frame_scan}
    if a.against is not None:
        scans["against"] = other_scan(a.against)
    for state, gap in STATES.items():
        run = prepared(a.grains, gap)
        for reach in (0, 1):
            times = {name: [] for name in scans}
            for name, module in scans.items():  # compile or load, warm the caches
                use_scan(run, module)
                per_call_us(run, bool(reach), 100)
            for _ in range(a.repeat):
                for name, module in scans.items():
                    use_scan(run, module)
                    times[name].append(per_call_us(run, bool(reach), a.calls))
            this = times["this"]
            line = {"state": state, "reach": reach, "grains": a.grains,
                    "us_per_call": statistics.median(this), "min_us": min(this),
                    "max_us": max(this)}
            if a.against is not None:
                line["against_us"] = statistics.median(times["against"])
                line["ratio"] = statistics.median(
                    t / o for t, o in zip(this, times["against"]))
            print(json.dumps(line))


if __name__ == "__main__":
    main()
