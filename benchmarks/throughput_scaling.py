"""Verlet throughput against chain length N = 1e2 .. 1e7, against the bandwidth bound (issue 5).

For each N and feature set, runs :func:`throughput.measure` (the scene of
benchmarks/throughput.py: m = 1, radius 0.5, k = 1, n = 5/2, dt = 0.01, friction
eta = 1e-3, gamma = 1e-2 on every granule when asked) with S and 2 S steps,
S N about 1e8 grain-steps (fewer steps at large N, at least 20), and keeps the
best of ``--repeat`` runs. Two rates are reported: ``end_to_end`` (2 S steps over
Result.wall_time, which includes one output frame's checks: finiteness, overlaps,
energies, O(N) numpy work, about 0.05 us per granule) and ``marginal``
(S N grain-steps over the difference of the two times: the kernel alone).
Cases:

  frictionless            granule 0 struck at v = 1
  coulomb+viscous         granule 0 struck (most granules at rest: stuck)
  coulomb+viscous random  every granule starts at a velocity uniform in [-0.1, 0.1]:
                          granules collide, slide, stop, stick and reverse at random.
                          At most 1000 (S) steps, t = 10: friction brings the chain
                          to rest after t ~ 100, and a chain at rest is the cheap case.

The bounds are the single-thread DRAM bandwidth measured by benchmarks/bandwidth.py
(STREAM triad with its write-allocate traffic counted; read from
benchmarks/results/bandwidth.json, or measured now) divided by the DRAM bytes per
grain-step of the engine's three-pass kernel and of a single-sweep kernel (see
bandwidth.py).

    python benchmarks/throughput_scaling.py            # ~3 minutes
    python benchmarks/throughput_scaling.py --max-n 1e6 --repeat 2
    python benchmarks/throughput_scaling.py --csv results/x.csv --figure x.png   # elsewhere
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import throughput  # noqa: E402

CASES = [("frictionless", "struck"), ("viscous", "struck"), ("coulomb+viscous", "struck"),
         ("coulomb+viscous", "random")]


def bandwidth():
    path = os.path.join(HERE, "results", "bandwidth.json")
    if not os.path.exists(path):
        import bandwidth as bw
        res = bw.measure(int(2e7))
        res["triad_dram_GBs"] = res["triad_GBs"] * bw.WRITE_ALLOCATE
        res["kernel_bytes_per_grain_step"] = bw.KERNEL_BYTES
        with open(path, "w") as fh:
            json.dump(res, fh, indent=1)
    with open(path) as fh:
        return json.load(fh)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--max-n", type=float, default=1e7)
    p.add_argument("--grain-steps", type=float, default=1e8)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--plot-only", action="store_true", help="redraw from the stored CSV")
    p.add_argument("--csv", default=os.path.join(HERE, "results", "throughput_scaling.csv"))
    p.add_argument("--figure", default=os.path.join(HERE, "..", "docs", "figures",
                                                    "perf_throughput_scaling.png"))
    p.add_argument("--cases", nargs="*", default=None,
                   help="only these cases (e.g. 'coulomb+viscous random'); their rows replace "
                        "the stored ones in the CSV")
    a = p.parse_args()
    if a.plot_only:
        with open(a.csv) as fh:
            rows = [{k: (v if k in ("case", "features", "initial", "status") else float(v or "nan"))
                     for k, v in r.items()} for r in csv.DictReader(fh)]
        plot(rows, bandwidth(), a.figure)
        return
    Ns = [n for n in (100, 1000, 10_000, 100_000, 1_000_000, 10_000_000) if n <= a.max_n]
    rows = []
    cases = [c for c in CASES if a.cases is None or f"{c[0]} {c[1]}" in a.cases]
    for features, initial in cases:
        for N in Ns:
            steps = max(20, int(a.grain_steps // N))
            if initial == "random":
                steps = min(steps, 1000)
            best = {}
            loads = []
            for _ in range(a.repeat):
                for s in (steps, 2 * steps):
                    loads.append(os.getloadavg()[0])
                    out = throughput.measure(N, s, features, "verlet", initial)
                    if s not in best or out["seconds"] < best[s]["seconds"]:
                        best[s] = out
            row = dict(best[2 * steps])
            row["marginal_grain_steps_per_s"] = N * steps / max(
                best[2 * steps]["seconds"] - best[steps]["seconds"], 1e-12)
            row["load"] = min(loads)
            row["load_max"] = max(loads)
            row["case"] = f"{features} {initial}"
            rows.append(row)
            print(f"{features:16s} {initial:7s} N={N:>9d} steps={2 * steps:>8d} "
                  f"{row['grain_steps_per_s'] / 1e6:8.1f} M/s end-to-end, "
                  f"{row['marginal_grain_steps_per_s'] / 1e6:8.1f} M/s marginal, "
                  f"balance {row['energy_balance_error']:.1e} {row['status']} "
                  f"(load {row['load']:.2f}-{row['load_max']:.2f})", flush=True)
    os.makedirs(os.path.join(HERE, "results"), exist_ok=True)
    keys = ["case", "features", "initial", "grains", "steps", "seconds", "grain_steps_per_s", "marginal_grain_steps_per_s",
            "energy_balance_error", "status", "load"]
    path = a.csv
    if a.cases is not None and os.path.exists(path):
        with open(path) as fh:
            kept = [{k: (v if k in ("case", "features", "initial", "status") else float(v))
                     for k, v in r.items()} for r in csv.DictReader(fh) if r["case"] not in a.cases]
        rows = kept + rows
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    bw = bandwidth()
    plot(rows, bw, a.figure)


def plot(rows, bw, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(10.0, 4.8))
    for case, sty in (("frictionless struck", "o-"), ("viscous struck", "d-"),
                      ("coulomb+viscous struck", "s-"), ("coulomb+viscous random", "^-")):
        rr = [r for r in rows if r["case"] == case]
        if rr:
            ln, = ax.loglog([r["grains"] for r in rr], [r["marginal_grain_steps_per_s"] for r in rr],
                            sty, label=case + " (marginal)")
            ax.loglog([r["grains"] for r in rr], [r["grain_steps_per_s"] for r in rr], sty[0] + ":",
                      color=ln.get_color(), mfc="none", label=case + " (end-to-end)")
    B = bw.get("triad_dram_GBs", bw["triad_GBs"] * 32 / 24) * 1e9
    kb = bw["kernel_bytes_per_grain_step"]
    for k, col, ls in (("engine_3pass", "C0", "--"), ("engine_3pass_coulomb_viscous", "C1", "--"),
                       ("single_sweep", "k", ":"), ("single_sweep_uniform", "0.5", ":")):
        ax.axhline(B / kb[k], color=col, ls=ls, lw=1,
                   label=f"bandwidth bound, {k} ({kb[k]} B/grain-step)")
    ax.axhline(1e9, color="0.5", lw=0.8)
    ax.text(120, 1.05e9, "goal 1e9 (in cache)", fontsize=7, color="0.4")
    ax.axhspan(50e6, 65e6, color="0.85", zorder=0)
    ax.text(2e5, 52e6, "serial LAMMPS (issue's figure)", fontsize=7, color="0.3")
    ax.set_xlabel("granules N")
    ax.set_ylabel("grain-steps per second (one core)")
    ax.set_title(f"Verlet, one core; DRAM {B / 1e9:.0f} GB/s (triad + write-allocate)")
    ax.grid(True, which="both", alpha=0.25)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
