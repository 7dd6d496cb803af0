"""What writing while the run goes costs: throughput with frames streamed to disk
against the same run with no output.

A struck Hertz chain (m = 1, radius 0.5, k = 1, n = 5/2, dt = 0.01, scaled
units), Coulomb and viscous friction on every granule when asked, run through
``granular_chain.simulate`` as ``granular-chain run`` runs it (frames not kept
in memory, writers attached). Four ways, interleaved, best of --repeat each:

- ``none``: one frame at the end, no writers (the stepping alone);
- ``frames``: a frame every --every steps handed to no writer (the driver's work per frame);
- ``trajectory``: a frame every --every steps appended to trajectory.h5;
- ``all``: the same plus energy.csv and the thermo log (thermo.csv, 20 lines).

Prints one JSON line per way: seconds, grain-steps per second, frames, the rate
relative to ``none`` and the cost of one frame in microseconds. Opening and
closing the files are counted (a fixed cost: the shorter the run, the larger
its share); ``loop_relative`` is the rate of the stepping loop alone (the
Result's ``wall_time``, from the first frame to the last), without the time
spent outside it (``outside_loop_s``: setting the run up, then finishing the
files). ``round_relative_median`` is the median over the rounds of each round's
ratio to that round's ``none`` (the ways run in turn, so a drift of the machine's
speed between rounds cancels out); ``writing_relative`` the same median against
``frames``: what the writers cost beyond making the frames. ``cpu_s`` is the median over the rounds of the
process's CPU time (user + system, the writers' thread included): what a run
takes from a machine whose cores are all busy (a sweep). ``--out`` picks the folder
written to (a RAM disk such as /dev/shm leaves the disk's own speed out).

    python benchmarks/streaming_cost.py --grains 10000 --steps 100000 --every 100
"""

import argparse
import json
import resource
import statistics
import tempfile
import time
from pathlib import Path

import granular_chain as gc
from granular_chain.model import build_model
from granular_chain.writers.tables import EnergyTable
from granular_chain.writers.thermo import ThermoLog
from granular_chain.writers.trajectory import TrajectoryFrames

FRICTION = {"frictionless": {}, "coulomb+viscous": {"kinetic": 1e-3, "viscous": 1e-2}}


def scene(grains, steps, every, features):
    return gc.scene_from_dict({
        "name": "streaming",
        "granules": {"count": grains, "velocity": {0: 1.0}, "friction": FRICTION[features]},
        "contacts": {"exponent": 2.5},
        "run": {"dt": 0.01, "t_end": steps * 0.01},
        "output": {"every": every}})


def run(way, grains, steps, every, features, folder: Path):
    s = scene(grains, steps, steps if way == "none" else every, features)
    model = build_model(s)
    writers, thermo = [], None
    if way not in ("none", "frames"):
        writers.append(TrajectoryFrames(folder, s, grains, model=model))
    if way == "all":
        writers.append(EnergyTable(folder))
        thermo = ThermoLog(model, max(1, steps // 20), folder / "thermo.csv")
    cpu, start = _cpu(), time.perf_counter()
    r = gc.simulate(s, progress=False, writers=writers, keep_frames=False, thermo=thermo)
    seconds = time.perf_counter() - start
    if thermo is not None:
        thermo.close()
    return seconds, r.info["frames"], r.wall_time, _cpu() - cpu


def _cpu() -> float:
    use = resource.getrusage(resource.RUSAGE_SELF)
    return use.ru_utime + use.ru_stime


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--grains", type=int, default=10_000)
    p.add_argument("--steps", type=int, default=100_000)
    p.add_argument("--every", type=int, default=100)
    p.add_argument("--features", choices=list(FRICTION), default="frictionless")
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--out", type=Path, default=None, help="folder to write in (default: a "
                   "temporary folder)")
    a = p.parse_args()
    ways = ("none", "frames", "trajectory", "all")
    best = {w: (float("inf"), 0, float("inf")) for w in ways}
    loop = {w: float("inf") for w in ways}
    rounds = {w: [] for w in ways}  # each round's seconds: the ratio to that round's "none"
    cpu = {w: [] for w in ways}
    with tempfile.TemporaryDirectory(dir=a.out) as tmp:
        run("none", a.grains, 10, 5, a.features, Path(tmp))  # compile or load the kernel
        for _ in range(a.repeat):
            for w in ways:
                folder = Path(tmp) / f"{w}"
                folder.mkdir(exist_ok=True)
                seconds, frames, stepping, used = run(w, a.grains, a.steps, a.every, a.features,
                                                      folder)
                cpu[w].append(used)
                best[w] = min(best[w], (seconds, frames, stepping))
                rounds[w].append(seconds)
                loop[w] = min(loop[w], stepping)
    base = a.grains * a.steps / best["none"][0]
    for w in ways:
        seconds, frames, stepping = best[w]
        rate = a.grains * a.steps / seconds
        per_frame = (seconds - best["none"][0]) / max(frames - best["none"][1], 1)
        print(json.dumps({"way": w, "grains": a.grains, "steps": a.steps, "every": a.every,
                          "features": a.features, "frames": frames, "seconds": seconds,
                          "grain_steps_per_s": rate, "relative": rate / base,
                          "us_per_frame": per_frame * 1e6,
                          "loop_relative": loop["none"] / loop[w],
                          "round_relative_median": statistics.median(
                              n / t for n, t in zip(rounds["none"], rounds[w])),
                          "writing_relative": statistics.median(
                              n / t for n, t in zip(rounds["frames"], rounds[w])),
                          "outside_loop_s": seconds - stepping,
                          "cpu_s": statistics.median(cpu[w])}))


if __name__ == "__main__":
    main()
