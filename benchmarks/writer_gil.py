"""What a writer that holds the GIL costs the stepping thread, with no file at all.

A struck Hertz chain (the chain of ``streaming_cost.py``: m = 1, radius 0.5,
k = 1, n = 5/2, dt = 0.01) runs through ``granular_chain.simulate`` with a frame
every --every steps handed to one writer on the writers' thread. The writer does
nothing but hold the GIL for a fixed time per frame (a busy loop in Python), so
the run shows what the writers' Python costs the driver, apart from copying and
writing the frames:

- ``none``: one frame at the end, no writer (the stepping alone);
- ``frames``: a frame every --every steps, no writer (the driver's own work);
- ``hold_U``: the same, with a writer that holds the GIL U microseconds a frame.

The ways run in turn, --repeat rounds. Prints one JSON line per way: the best
time, the rate relative to ``none`` from the best runs, the median over the
rounds of each round's ratio to that round's ``none``, and the calling (stepping)
thread's own CPU time in the median run (``thread_cpu_s``, from
``time.thread_time``) with the median of the wall time it spent off the CPU
(``waiting_s``: waiting for the GIL, or descheduled).

    python benchmarks/writer_gil.py --grains 10000 --steps 100000 --every 100 --hold 0,10,30,100
"""

import argparse
import json
import statistics
import time

import granular_chain as gc


class HoldingWriter:
    """A frame writer that only holds the GIL ``seconds`` per frame."""

    def __init__(self, seconds: float):
        self.seconds = seconds

    def write_frame(self, frame) -> None:
        end = time.perf_counter() + self.seconds
        while time.perf_counter() < end:  # Python bytecode: the GIL is held throughout
            pass

    def close(self, result=None) -> None:
        pass


def run(way: str, grains: int, steps: int, every: int) -> tuple[float, float]:
    """Wall and calling-thread CPU seconds of one run of ``way`` (``none``,
    ``frames`` or ``hold_U``)."""
    s = gc.scene_from_dict({
        "name": "writer_gil",
        "granules": {"count": grains, "velocity": {0: 1.0}},
        "contacts": {"exponent": 2.5},
        "run": {"dt": 0.01, "t_end": steps * 0.01},
        "output": {"every": steps if way == "none" else every}})
    writers = []
    if way.startswith("hold_"):
        writers.append(HoldingWriter(float(way[5:]) * 1e-6))
    start, cpu = time.perf_counter(), time.thread_time()
    gc.simulate(s, progress=False, writers=writers, keep_frames=False)
    return time.perf_counter() - start, time.thread_time() - cpu


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--grains", type=int, default=10_000)
    p.add_argument("--steps", type=int, default=100_000)
    p.add_argument("--every", type=int, default=100)
    p.add_argument("--hold", default="0,10,30,100", help="microseconds held per frame, "
                   "comma-separated")
    p.add_argument("--repeat", type=int, default=8)
    a = p.parse_args()
    ways = ["none", "frames"] + [f"hold_{h}" for h in a.hold.split(",")]
    for way in ways:  # compile and warm up
        run(way, a.grains, max(a.every, a.steps // 10), a.every)
    times = {way: [] for way in ways}
    for _ in range(a.repeat):
        for way in ways:
            times[way].append(run(way, a.grains, a.steps, a.every))
    base = [wall for wall, _ in times["none"]]
    for way in ways:
        wall = [w for w, _ in times[way]]
        print(json.dumps({
            "way": way, "grains": a.grains, "steps": a.steps, "every": a.every,
            "seconds": min(wall), "relative": min(base) / min(wall),
            "round_relative_median": statistics.median(b / t for b, t in zip(base, wall)),
            "thread_cpu_s": statistics.median(c for _, c in times[way]),
            "waiting_s": statistics.median(w - c for w, c in times[way])}))


if __name__ == "__main__":
    main()
