"""Cost of a boundary point: collisions and seconds to refine one outcome boundary
to 1e-12 relative (granular_chain.boundaries), n = 2 and n = 5/2.

Also writes the thresholds table of docs/boundaries.md (paper value, exact value,
engine value, digits) to benchmarks/results/boundaries_thresholds.json.

Usage::

    PYTHONPATH=. python benchmarks/boundary_cost.py [--repeat 20] \
        [--out benchmarks/results/boundaries.json]

Per case: the 1-D search from a range (scan of 128 points + refinement), repeated;
reported per boundary: collisions and median seconds of the refinement alone, with
the secant indicator and with bisection only, and the scan's cost per point. For
the 2-D tracer: collisions and seconds per traced curve point in (eta1, eta2).
The kernels are compiled (and the batches built) before timing.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import statistics
import subprocess
import time
from pathlib import Path

from granular_chain.boundaries import find_boundaries, trace_curves

CASES = [  # name, param, lo, hi, fixed, by
    ("n2 eta2 0.669", "eta2", 0.0, 1.0, {}, "outcome"),
    ("n2 eta1 0.2196", "eta1", 0.1, 1.0, {}, "outcome"),
    ("n2 eta1 0.4440 (events)", "eta1", 0.3, 1.0, {}, "events"),
    ("n2 eta2 eta1=0.3 (2 boundaries)", "eta2", 0.0, 1.0, {"eta1": 0.3}, "outcome"),
    ("n2 gamma sqrt8 edge", "gamma", 2.0, 4.0, {}, "outcome"),
    ("n5/2 eta2 0.6418", "eta2", 0.3, 1.0, {"n": 2.5}, "outcome"),
    ("n5/2 gamma 1.4884", "gamma", 1.0, 2.0, {"n": 2.5}, "outcome"),
]


def _case(param, lo, hi, fixed, by, secant, repeat):
    runs = [find_boundaries(param, lo, hi, fixed, by=by, secant=secant, error=False)
            for _ in range(repeat)]
    first = runs[0]
    out = []
    for i, b in enumerate(first):
        secs = [r[i].seconds for r in runs]
        out.append({"value": b.value, "below": b.below, "above": b.above, "method": b.method,
                    "collisions": b.collisions, "seconds_median": statistics.median(secs),
                    "ms_per_collision": 1e3 * statistics.median(secs) / b.collisions})
    scan = statistics.median(r.scan_seconds for r in runs) / first.scan_collisions
    return out, scan


def _pick(bs, below, above, lo=-1.0, hi=1e9):
    return [b for b in bs if (b.below, b.above) == (below, above) and lo < b.value < hi][0]


def _digits(v, exact):
    d = abs(v - exact) / abs(exact)
    return 17.0 if d == 0 else -math.log10(d)


def thresholds(out):
    """The paper's thresholds from parameter ranges (the table of docs/boundaries.md)."""
    from granular_chain import paper as P
    from granular_chain.boundaries import separation_limit
    pick, digits = _pick, _digits
    rows = []

    def row(name, paper, exact, b, extra=None):
        r = {"threshold": name, "paper": paper, "exact": exact, "engine": b.value,
             "bracket": list(b.bracket), "collisions": b.collisions, "ms": 1e3 * b.seconds,
             "method": b.method, "error": b.error,
             "digits_vs_exact": None if exact is None else round(digits(b.value, exact), 1)}
        if extra: r.update(extra)
        rows.append(r)
        print(json.dumps(r))

    bs = find_boundaries("eta2", 0, 1)
    row("both move iff eta2 < eta_max (n=2, eta1=0)", "(1+pi^2/8)^(-1/2) = 0.669...",
        float(P.iia_eta_max(exact=True)),
        pick(bs, "backscatter_and_propagation", "backscatter_only"))
    bs = find_boundaries("eta1", 0, 1, by="events")
    row("backscattering ends (n=2, eta2=0)", "~0.22",
        float(P.iib_backscatter_threshold_eta_exact(dps=25)),
        pick(bs, "backscatter_and_propagation", "propagation_only", 0.1))
    row("granule 1 stops sliding back (n=2, eta2=0; by events)",
        "0.439 (printed; 0.4388612 root of the approximate condition)",
        float(P.iib_slip_critical_eta_exact(dps=25)),
        pick(bs, "propagation_only", "propagation_only", 0.3))
    bs = find_boundaries("gamma", 2, 4)
    s8 = math.sqrt(8)
    for b in bs:
        row(f"never separate, equal gamma (n=2): engine edge {b.below}|{b.above}",
            "sqrt(8) = 2.8284...", s8, b)
    t = time.perf_counter()
    v, err, n = separation_limit("gamma", bs[0].bracket[0], bs[-1].bracket[1])
    rows.append({"threshold": "never separate, equal gamma (n=2): 1/t_sep^2 -> 0 extrapolation",
                 "paper": "sqrt(8)", "exact": s8, "engine": v, "error": err, "collisions": n,
                 "ms": 1e3 * (time.perf_counter() - t), "digits_vs_exact": round(digits(v, s8), 1)})
    print(rows[-1])
    bs = find_boundaries("gamma", 1, 2, {"n": 2.5})
    row("never separate, equal gamma (n=5/2)", "(not given)", None,
        pick(bs, "backscatter_and_propagation", "no_separation"),
        {"reference": "scipy DOP853 bisection: [1.4883892680765718, 1.4883892680772992]"})
    bs = find_boundaries("eta2", 0.3, 1, {"n": 2.5})
    row("both move iff eta2 < eta_max (n=5/2)", "shrinks as n grows", None,
        pick(bs, "backscatter_and_propagation", "backscatter_only"))
    bs = find_boundaries("eta1", 0.05, 1, {"n": 2.5})
    row("backscattering ends (n=5/2, eta2=0)", "(Fig. hertz)", None,
        pick(bs, "backscatter_and_propagation", "propagation_only"))
    bs = find_boundaries("eta2", 0.3, 1, {"n": 3.0})
    row("both move iff eta2 < eta_max (n=3)", "shrinks as n grows", None,
        pick(bs, "backscatter_and_propagation", "backscatter_only"))
    Path(out).write_text(json.dumps({"thresholds": rows}, indent=2) + "\n")
    print(f"wrote {out}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=20)
    ap.add_argument("--out", default="benchmarks/results/boundaries.json")
    ap.add_argument("--thresholds", default="benchmarks/results/boundaries_thresholds.json",
                    help="where the thresholds table goes")
    args = ap.parse_args()
    thresholds(args.thresholds)
    for c in CASES:  # warm: compile kernels, build batches
        find_boundaries(*c[1:5], by=c[5], grid=8, error=False)
    results = {"machine": platform.processor() or platform.machine(),
               "commit": subprocess.run(["git", "rev-parse", "--short", "HEAD"],
                                        capture_output=True, text=True).stdout.strip(),
               "repeat": args.repeat, "tol": 1e-12, "grid": 128, "cases": []}
    for name, param, lo, hi, fixed, by in CASES:
        sec, scan = _case(param, lo, hi, fixed, by, True, args.repeat)
        bis, _ = _case(param, lo, hi, fixed, by, False, max(3, args.repeat // 4))
        results["cases"].append({"name": name, "param": param, "range": [lo, hi],
                                 "fixed": fixed, "by": by, "scan_ms_per_point": 1e3 * scan,
                                 "secant": sec, "bisection": bis})
        for s, b in zip(sec, bis):
            print(f"{name:34s} {s['value']:.15g} {s['method']:16s} {s['collisions']:3d} coll "
                  f"{1e3 * s['seconds_median']:6.2f} ms | bisection {b['collisions']:3d} coll "
                  f"{1e3 * b['seconds_median']:6.2f} ms | scan {1e3 * scan:.3f} ms/point")
    trace_curves(seeds=1, step=0.05)  # warm
    t0 = time.perf_counter()
    curves = trace_curves(seeds=2, step=0.02)
    wall = time.perf_counter() - t0
    pts = sum(len(c.points) for c in curves)
    coll = sum(c.collisions for c in curves)
    results["trace_eta_plane"] = {"curves": len(curves), "points": pts, "collisions": coll,
                                  "seconds": wall, "ms_per_point": 1e3 * wall / pts,
                                  "collisions_per_point": coll / pts}
    print(f"trace (eta1, eta2) [0,1]^2: {len(curves)} curves, {pts} points, {coll} collisions, "
          f"{wall:.2f} s = {1e3 * wall / pts:.2f} ms/point")
    Path(args.out).write_text(json.dumps(results, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
