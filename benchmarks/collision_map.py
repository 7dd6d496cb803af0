"""collision_map throughput and collide() per-call cost (issue 5).

Goal: "event stepper, N = 2, n = 2: at most 20 us per collision, so a
million-point (eta1, eta2) map takes under a minute on 2 cores."

Measures
1. an M x M (eta1, eta2) map on [0, 1]^2, n = 2, on 1 and 2 workers (wall time,
   us per collision), once each (a million-point map takes minutes);
2. the same on a smaller grid, best of --repeats, and the cost per collision by
   how the run ends (separated, stuck, Zeno), which is the kernel's cost;
3. n = 5/2 at rtol 1e-10 on a smaller grid, 1 and 2 workers;
4. collide(stepper="event") per call (best of repeats of 200 calls) for the
   work-precision problems a1, a2, b (rtol 1e-4 and 1e-10), c, and, with
   --before DIR (an unpacked checkout of the code before collision_map, e.g.
   ``git archive 0ef0014 | tar -x -C /tmp/before``), the same in that code.

Adds the run to benchmarks/results/collision_map.json under ``--key`` (default: the
time; load average noted: the machine may be shared, and every time here is wall
time). benchmarks/results/collision_map.md is written by hand from those runs.

    python benchmarks/collision_map.py                       # about 10 minutes
    python benchmarks/collision_map.py --grid 300 --before /tmp/before
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
RESULTS = os.path.join(HERE, "results")

PER_CALL = {
    "a1": (2.0, (0.0, 0.3), (0.0, 0.0), {}),
    "a2": (2.0, (0.1, 0.0), (0.0, 0.0), {}),
    "b (rtol 1e-4)": (2.5, (0.0, 0.3), (0.0, 0.0), dict(rtol=1e-4, atol=1e-6)),
    "b (rtol 1e-10)": (2.5, (0.0, 0.3), (0.0, 0.0), dict(rtol=1e-10, atol=1e-12)),
    "c": (2.0, (0.0, 0.0), (1.0, 1.0), {}),
}


def per_call(repeats: int = 7, calls: int = 200) -> dict:
    """Best-of-repeats wall time of one collide() call and its kernel time (us)."""
    from granular_chain.two_granules import collide
    out = {}
    for name, (n, eta, gamma, kw) in PER_CALL.items():
        collide(n, eta, gamma, stepper="event", **kw)
        best = kern = float("inf")
        for _ in range(repeats):
            t = time.perf_counter()
            for _ in range(calls):
                c = collide(n, eta, gamma, stepper="event", **kw)
            best = min(best, (time.perf_counter() - t) / calls)
            kern = min(kern, c.result.wall_time)
        out[name] = {"call_us": best * 1e6, "kernel_us": kern * 1e6}
    return out


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def grid_map(m: int, n: float = 2.0, workers: int = 1, **kw):
    from granular_chain.two_granules import collision_map
    e = np.linspace(0.0, 1.0, m)
    return collision_map(e[None, :], e[:, None], n=n, workers=workers, **kw)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--grid", type=int, default=1000, help="points per axis of the big map")
    p.add_argument("--small", type=int, default=200, help="points per axis, repeated maps")
    p.add_argument("--hertz", type=int, default=100, help="points per axis, n = 5/2 map")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--key", default=None,
                   help="name of this run in results/collision_map.json (default: the time)")
    p.add_argument("--before", default=None, help="checkout of the code before collision_map")
    p.add_argument("--per-call-only", action="store_true", help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.per_call_only:
        print(json.dumps(per_call()))
        return

    from granular_chain.two_granules import OUTCOMES
    rows = {"load_start": load(), "cores": os.cpu_count()}
    print("load", rows["load_start"])
    # compile / load every specialisation first
    grid_map(20)
    grid_map(10, n=2.5, rtol=1e-10, atol=1e-12)

    big = {}
    for w in (1, 2):
        r = grid_map(a.grid, workers=w)
        big[w] = {"seconds": r.wall_time, "us_per_collision": r.wall_time / r.v1.size * 1e6,
                  "load": load()}
        print(f"{a.grid}^2 map, n = 2, {w} worker(s): {r.wall_time:.1f} s, "
              f"{big[w]['us_per_collision']:.1f} us/collision (load {big[w]['load']})")
    counts = {("failed" if k < 0 else OUTCOMES[k].name): int((r.outcome == k).sum())
              for k in np.unique(r.outcome)}
    rows["big"] = {"grid": a.grid, "points": int(r.v1.size), "runs": big, "outcomes": counts,
                   "statuses": {int(s): int((r.status == s).sum()) for s in np.unique(r.status)}}

    small = {}
    for w in (1, 2):
        best = min(grid_map(a.small, workers=w).wall_time for _ in range(a.repeats))
        small[w] = {"seconds": best, "us_per_collision": best / a.small ** 2 * 1e6}
        print(f"{a.small}^2 map, n = 2, {w} worker(s), best of {a.repeats}: {best:.2f} s, "
              f"{small[w]['us_per_collision']:.1f} us/collision")
    rows["small"] = {"grid": a.small, "runs": small}

    # cost by how the run ends: rerun each class of points of the small map alone
    from granular_chain.two_granules import collision_map
    r = grid_map(a.small)
    e = np.linspace(0.0, 1.0, a.small)
    E1, E2 = np.meshgrid(e, e)
    by = {}
    for name, sel in (("separated", r.status == 1), ("stuck (at rest)", r.status == 2),
                      ("zeno (failed)", r.status == -4),
                      ("one granule frictionless", (E1 == 0) | (E2 == 0))):
        if sel.sum() == 0:
            continue
        best = min(collision_map(E1[sel], E2[sel], workers=1).wall_time
                   for _ in range(a.repeats))
        by[name] = {"points": int(sel.sum()), "us_per_collision": best / sel.sum() * 1e6}
        print(f"  {name:26s} {sel.sum():7d} points {by[name]['us_per_collision']:8.1f} us each")
    rows["by_status"] = by

    hz = {}
    for w in (1, 2):
        best = min(grid_map(a.hertz, n=2.5, workers=w, rtol=1e-10, atol=1e-12).wall_time
                   for _ in range(a.repeats))
        hz[w] = {"seconds": best, "us_per_collision": best / a.hertz ** 2 * 1e6}
        print(f"{a.hertz}^2 map, n = 5/2, rtol 1e-10, {w} worker(s), best of {a.repeats}: "
              f"{best:.2f} s, {hz[w]['us_per_collision']:.1f} us/collision")
    rows["hertz"] = {"grid": a.hertz, "rtol": 1e-10, "runs": hz}

    rows["per_call_after"] = per_call()
    if a.before:
        env = dict(os.environ, PYTHONPATH=a.before,
                   NUMBA_CACHE_DIR=os.path.join("/tmp", "nbcache_before"),
                   PYTHONDONTWRITEBYTECODE="1")
        out = subprocess.run([sys.executable, os.path.abspath(__file__), "--per-call-only"],
                             env=env, capture_output=True, text=True, check=True, cwd="/tmp")
        rows["per_call_before"] = json.loads(out.stdout.strip().splitlines()[-1])
    for k, v in rows["per_call_after"].items():
        b = rows.get("per_call_before", {}).get(k)
        print(f"collide {k:15s} after {v['call_us']:7.1f} us (kernel {v['kernel_us']:.1f})"
              + (f", before {b['call_us']:7.1f} us (kernel {b['kernel_us']:.1f})" if b else ""))
    rows["load_end"] = load()
    os.makedirs(RESULTS, exist_ok=True)
    # Each run is added under its own key: the file keeps the earlier runs the
    # docs cite (run1 .. run5_third_session).
    path = os.path.join(RESULTS, "collision_map.json")
    runs = {}
    if os.path.exists(path):
        with open(path) as f:
            runs = json.load(f)
    runs[a.key or time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())] = rows
    with open(path, "w") as f:
        json.dump(runs, f, indent=1)
    print("load", rows["load_end"])


if __name__ == "__main__":
    main()
