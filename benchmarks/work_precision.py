"""Work-precision: error against wall time, the engine's steppers against solve_ivp (issue 5).

Problems (scaled units, masses 1, force coefficient 1, granule 1 arriving at v = 1):

a1, a2  two granules, n = 2, kinetic friction eta = (0, 0.3) and (0.1, 0); error
        max(|v1 - v1*|, |v2 - v2*|) at separation against the exact piecewise-linear
        solution :func:`granular_chain.paper.reference_collision_n2` (mpmath, 30 digits).
b       the same as a1 with n = 5/2. No closed form: the reference is the event
        stepper at rtol = 1e-13, accepted only if it agrees with Verlet at dt = 1e-5
        Richardson-extrapolated (dt, dt/2: second order) and with DOP853 at
        rtol = 1e-13; the three-way spread is printed and stored as ``ref_spread``.
c       two granules, n = 2, hydrodynamic friction gamma = (1, 1): exact closed form
        (t0 = pi/omega, reference_collision_n2(0, 0, 1, 1)).
d       struck frictionless Hertz chain (n = 5/2) of 1000 touching granules, state at
        t = 100; error max over granules of |x - x*| and |v - v*|. Reference:
        the event stepper at rtol = 1e-13 (it locates every contact opening, so
        the force kink does not cap its order), cross-checked with Verlet
        Richardson-extrapolated from dt = 5e-4, 2.5e-4, and DOP853 at rtol 1e-13 (stored).

Methods:

verlet   the engine's velocity-Verlet, dt sweep;
event    the engine's event stepper, tolerance sweep (n = 2 problems: the stepper
         ignores rtol and uses its fixed exact-order series, so one point);
RK45, DOP853, LSODA  scipy.integrate.solve_ivp. Two granules with Coulomb friction
         are integrated as piecewise-smooth *modes*: each granule either slides in
         a fixed direction s (m a = F - eta s - gamma v) or sticks (v = 0, a = 0);
         terminal events end a mode (a sliding granule's velocity reaching 0, a stuck
         granule's |spring force| exceeding eta, the contact opening) and the
         driver restarts solve_ivp in the next mode. Within a mode the right-hand
         side is smooth (delta > 0 during the contact), so the methods keep their
         order; the collision ends at the contact-opening event. The chain (d) has
         no terminal event: contacts open and close behind the pulse at the kink of
         max(delta, 0)^(3/2), which no method here locates.

Times: the minimum over repeats of the wall time of one solve. For the engine two
times are stored: ``kernel`` (Result.wall_time, the compiled stepping alone) and
``call`` (scene -> Result through the public API: collide() / simulate(), including
scene validation and model building). solve_ivp's time is the whole call.

    python benchmarks/work_precision.py            # all problems, a few minutes
    python benchmarks/work_precision.py --problems a1 c --quick
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import time
import warnings

import numpy as np
from scipy.integrate import solve_ivp

import granular_chain as gc
from granular_chain.paper import reference_collision_n2
from granular_chain.two_granules import collide

HERE = os.path.dirname(os.path.abspath(__file__))
RESULTS = os.path.join(HERE, "results")
FIGURES = os.path.join(HERE, "..", "docs", "figures")

PROBLEMS = {
    "a1": dict(n=2.0, eta=(0.0, 0.3), gamma=(0.0, 0.0), title="(a) n = 2, eta = (0, 0.3)"),
    "a2": dict(n=2.0, eta=(0.1, 0.0), gamma=(0.0, 0.0), title="(a) n = 2, eta = (0.1, 0)"),
    "b": dict(n=2.5, eta=(0.0, 0.3), gamma=(0.0, 0.0), title="(b) n = 5/2, eta = (0, 0.3)"),
    "c": dict(n=2.0, eta=(0.0, 0.0), gamma=(1.0, 1.0), title="(c) n = 2, gamma = (1, 1)"),
    "d": dict(n=2.5, N=1000, t_end=100.0, title="(d) Hertz chain N = 1000, t = 100"),
}


def best_time(fn, min_total=0.3, max_rep=31):
    """Run ``fn`` (returns (value, kernel_seconds or None)) repeatedly; min wall time.

    Up to ``max_rep`` calls, stopping once they took ``min_total`` seconds: a call of
    ~50 us gets 31 tries (7 left the first problem of a process 1.4x slow, measured).
    """
    best, bestk, out = math.inf, math.inf, None
    total = 0.0
    for rep in range(max_rep):
        t0 = time.perf_counter()
        out, kt = fn()
        w = time.perf_counter() - t0
        total += w
        best = min(best, w)
        if kt is not None:
            bestk = min(bestk, kt)
        if total > min_total and rep >= 1:
            break
    return out, best, (bestk if bestk < math.inf else None)


# ---------------------------------------------------------------------------
# solve_ivp: two granules as piecewise-smooth modes with terminal events
# ---------------------------------------------------------------------------

def two_granules_ivp(n, eta, gamma, method, rtol, atol, t_max=200.0):
    """Velocities (v1, v2) and time at the first contact opening.

    State y = (x1, x2, v1, v2). ``mode[i]`` is +1/-1 (sliding that way, or free if
    eta_i = 0) or 0 (stuck). Returns (v1, v2, t_sep, nfev).
    """
    eta = np.asarray(eta, float)
    gam = np.asarray(gamma, float)
    p = n - 1.0

    def force(y):
        d = y[0] - y[1]
        return d ** p if d > 0.0 else 0.0

    y = np.array([0.0, 0.0, 1.0, 0.0])
    # granule 1 slides forward; granule 2 at rest: stuck if it has friction
    mode = [1, 0 if eta[1] > 0 else 1]
    t = 0.0
    nfev = 0
    for _ in range(100):
        md = list(mode)

        def rhs(_t, z, md=md):
            F = force(z)
            a1 = (-F - eta[0] * md[0] - gam[0] * z[2]) if md[0] != 0 else 0.0
            a2 = (F - eta[1] * md[1] - gam[1] * z[3]) if md[1] != 0 else 0.0
            return np.array([z[2], z[3], a1, a2])

        def opening(_t, z):
            return z[0] - z[1]
        opening.terminal, opening.direction = True, -1
        events = [opening]
        kinds = ["open"]
        for i in range(2):
            if eta[i] == 0.0:
                continue
            if md[i] != 0:
                def stop(_t, z, i=i, s=md[i]):
                    return s * z[2 + i]
                stop.terminal, stop.direction = True, -1
                events.append(stop)
                kinds.append(("stop", i))
            else:
                def slip(_t, z, i=i):
                    return abs(force(z)) - eta[i]
                slip.terminal, slip.direction = True, 1
                events.append(slip)
                kinds.append(("slip", i))
        sol = solve_ivp(rhs, (t, t_max), y, method=method, rtol=rtol, atol=atol, events=events)
        nfev += sol.nfev
        hit = [(sol.t_events[j][0], j) for j in range(len(events)) if len(sol.t_events[j])]
        if not hit:
            raise RuntimeError("no event before t_max")
        t, j = min(hit)
        y = sol.y_events[j][0].copy()
        kind = kinds[j]
        if kind == "open":
            return y[2], y[3], t, nfev
        what, i = kind
        F = force(y) * (1.0 if i == 1 else -1.0)  # spring force on granule i
        if what == "stop":
            y[2 + i] = 0.0
            mode[i] = int(np.sign(F)) if abs(F) > eta[i] else 0
        else:
            mode[i] = int(np.sign(F))
    raise RuntimeError("too many mode switches")


# ---------------------------------------------------------------------------
# the struck chain
# ---------------------------------------------------------------------------

def chain_rhs(N, p=1.5):
    def rhs(_t, z):
        x = z[:N]
        d = x[:-1] - x[1:]
        c = np.where(d > 0.0, np.maximum(d, 0.0) ** p, 0.0)
        a = np.zeros(N)
        a[:-1] -= c
        a[1:] += c
        return np.concatenate((z[N:], a))
    return rhs


def chain_ivp(N, t_end, method, rtol, atol):
    z0 = np.zeros(2 * N)
    z0[N] = 1.0
    sol = solve_ivp(chain_rhs(N), (0.0, t_end), z0, method=method, rtol=rtol, atol=atol,
                    t_eval=[t_end])
    return sol.y[:N, -1], sol.y[N:, -1], sol.nfev


def chain_scene(N, t_end, stepper, dt=None, rtol=None, atol=None):
    run = {"stepper": stepper, "t_end": t_end}
    # Both steppers asked for the final state only (as solve_ivp is): Verlet one
    # frame per t_end / dt steps, the event stepper one frame per t_end (without
    # output.dt it records a frame at every event batch: 150 frames of 3 N values).
    if dt is not None:
        run["dt"] = dt
        output = {"every": int(round(t_end / dt)), "trajectory": False}
    else:
        output = {"dt": t_end, "trajectory": False}
    if rtol is not None:
        run["rtol"], run["atol"] = rtol, atol
    return gc.scene_from_dict({
        "name": "wp_chain",
        "granules": {"count": N, "mass": 1.0, "radius": 0.5, "gap": 0.0, "velocity": {0: 1.0}},
        "contacts": {"exponent": 2.5, "stiffness": 1.0},
        "run": run,
        "output": output,
    })


def chain_engine(N, t_end, stepper, dt=None, rtol=None, atol=None):
    r = gc.simulate(chain_scene(N, t_end, stepper, dt, rtol, atol), progress=False)
    if not r.success or abs(r.t_final - t_end) > 1e-9:
        raise RuntimeError(f"{stepper}: {r.status.name} {r.message} t={r.t_final}")
    return (np.asarray(r.x_final) - np.asarray(r.x[0]), np.asarray(r.v_final)), r.wall_time


# ---------------------------------------------------------------------------

def two_granule_error(val, ref):
    return max(abs(val[0] - ref[0]), abs(val[1] - ref[1]))


def reference(key, spec, log):
    if key in ("a1", "a2", "c"):
        r = reference_collision_n2(*spec["eta"], *spec["gamma"])
        return (float(r["v1"]), float(r["v2"])), {"kind": "exact (reference_collision_n2, mpmath 30 digits)",
                                                  "spread": 0.0}
    if key == "b":
        ce = collide(spec["n"], spec["eta"], spec["gamma"], stepper="event", rtol=1e-13, atol=1e-15)
        ev = (ce.v1, ce.v2)
        c1 = collide(spec["n"], spec["eta"], spec["gamma"], stepper="verlet", dt=1e-5)
        c2 = collide(spec["n"], spec["eta"], spec["gamma"], stepper="verlet", dt=5e-6)
        rich = ((4 * c2.v1 - c1.v1) / 3, (4 * c2.v2 - c1.v2) / 3)
        dop = two_granules_ivp(spec["n"], spec["eta"], spec["gamma"], "DOP853", 1e-13, 1e-15)[:2]
        spread = max(two_granule_error(rich, ev), two_granule_error(dop, ev))
        log(f"  b reference: event {ev}, Verlet-Richardson {rich}, DOP853 {dop}; spread {spread:.2e}")
        return ev, {"kind": "event stepper rtol=1e-13 (checked: Verlet dt=1e-5/5e-6 Richardson, DOP853 1e-13)",
                    "spread": spread, "event": ev, "verlet_richardson": rich, "dop853": dop}
    if key == "d":
        N, T = spec["N"], spec["t_end"]
        # The event stepper locates every contact opening/closing, so the kink of
        # max(delta, 0)^(3/2) does not cap its order: it is the reference. Checks:
        # Verlet Richardson-extrapolated (dt = 5e-4, 2.5e-4, second order) and DOP853
        # at rtol 1e-13 (which does not locate the kinks).
        (x, v), _ = chain_engine(N, T, "event", rtol=1e-13, atol=1e-15)
        info = {"kind": "event stepper rtol=1e-13 atol=1e-15"}
        (xv, vv), _ = chain_engine(N, T, "verlet", dt=5e-4)
        (xv2, vv2), _ = chain_engine(N, T, "verlet", dt=2.5e-4)
        xr, vr = (4 * xv2 - xv) / 3, (4 * vv2 - vv) / 3
        info["verlet_richardson_vs_ref"] = float(max(np.max(abs(xr - x)), np.max(abs(vr - v))))
        info["verlet_2.5e-4_vs_ref"] = float(max(np.max(abs(xv2 - x)), np.max(abs(vv2 - v))))
        (xe, ve), _ = chain_engine(N, T, "event", rtol=1e-11, atol=1e-13)
        info["event_1e-11_vs_ref"] = float(max(np.max(abs(xe - x)), np.max(abs(ve - v))))
        xd, vd, _ = chain_ivp(N, T, "DOP853", 1e-13, 1e-15)
        info["dop853_1e-13_vs_ref"] = float(max(np.max(abs(xd - x)), np.max(abs(vd - v))))
        info["spread"] = info["verlet_richardson_vs_ref"]
        log(f"  d reference: {info}")
        return (x, v), info
    raise KeyError(key)


def run_problem(key, quick, log, timeout=20.0):
    spec = PROBLEMS[key]
    ref, refinfo = reference(key, spec, log)
    rows = []

    def add(method, param, err, wall, kernel=None, extra=""):
        rows.append(dict(problem=key, method=method, param=param, error=err, seconds=wall,
                         kernel_seconds=kernel, note=extra))
        log(f"  {key} {method:8s} {param:>9.1e} err {err:.3e} time {wall:.3e}"
            + (f" kernel {kernel:.3e}" if kernel is not None else ""))

    if key != "d":
        n, eta, gam = spec["n"], spec["eta"], spec["gamma"]
        # Verlet dt sweep
        dts = [1e-1, 3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6]
        if quick:
            dts = dts[::2]
        for dt in dts:
            def f(dt=dt):
                c = collide(n, eta, gam, stepper="verlet", dt=dt)
                return (c.v1, c.v2), c.result.wall_time
            val, wall, kern = best_time(f)
            add("verlet", dt, two_granule_error(val, ref), wall, kern)
        # event stepper tolerance sweep
        tols = [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12] if n != 2 else [1e-10]
        for tol in tols:
            def f(tol=tol):
                c = collide(n, eta, gam, stepper="event", rtol=tol, atol=tol * 1e-2)
                return (c.v1, c.v2), c.result.wall_time
            val, wall, kern = best_time(f)
            add("event", tol, two_granule_error(val, ref), wall, kern,
                "n=2: fixed exact-order series, rtol ignored" if n == 2 else "")
        # solve_ivp
        for method in ("RK45", "DOP853", "LSODA"):
            tols = [10.0 ** -k for k in range(3, 14)]
            if quick:
                tols = tols[::2]
            for tol in tols:
                def f(tol=tol, method=method):
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        r = two_granules_ivp(n, eta, gam, method, tol, tol * 1e-2)
                    return r[:2], None
                val, wall, _ = best_time(f)
                add(method, tol, two_granule_error(val, ref), wall)
                if wall > timeout:
                    break
    else:
        N, T = spec["N"], spec["t_end"]
        xr, vr = ref

        def cerr(x, v):
            return max(np.max(abs(x - xr)), np.max(abs(v - vr)))
        dts = [1e-1, 5e-2, 2e-2, 1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2.5e-4]
        if quick:
            dts = dts[::2]
        for dt in dts:
            def f(dt=dt):
                return chain_engine(N, T, "verlet", dt=dt)
            (x, v), wall, kern = best_time(f, min_total=0.5)
            add("verlet", dt, cerr(x, v), wall, kern)
        for tol in ([1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12] if not quick else [1e-4, 1e-8]):
            def f(tol=tol):
                return chain_engine(N, T, "event", rtol=tol, atol=tol * 1e-2)
            try:
                (x, v), wall, kern = best_time(f, min_total=0.5, max_rep=3)
            except Exception as e:
                log(f"  d event {tol}: failed: {e}")
                continue
            add("event", tol, cerr(x, v), wall, kern)
            if wall > timeout:
                break
        for method in ("RK45", "DOP853", "LSODA"):
            tols = [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12]
            if quick:
                tols = tols[::3]
            for tol in tols:
                def f(tol=tol, method=method):
                    x, v, _ = chain_ivp(N, T, method, tol, tol * 1e-2)
                    return (x, v), None
                (x, v), wall, _ = best_time(f, min_total=0.0, max_rep=2 if tol > 1e-7 else 1)
                add(method, tol, cerr(x, v), wall)
                if wall > timeout:
                    break
    return rows, refinfo


def speedup_table(rows, levels=(1e-4, 1e-6, 1e-8, 1e-10)):
    """At each error level: the cheapest time (log-log interpolated front) of each method."""
    def front(pts):
        pts = sorted(pts, key=lambda r: r[0])  # by error
        return pts

    def time_at(pts, e):
        # the least time among points with error <= e
        ok = [w for err, w in pts if err <= e]
        return min(ok) if ok else math.nan
    out = {}
    by = {}
    for r in rows:
        by.setdefault(r["method"], []).append((r["error"], r["seconds"]))
        if r["kernel_seconds"] is not None:
            by.setdefault(r["method"] + " kernel", []).append((r["error"], r["kernel_seconds"]))
    for e in levels:
        out[e] = {m: time_at(front(p), e) for m, p in by.items()}
    return out


def plot(key, rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    styles = {"verlet": "o-", "event": "s-", "RK45": "^--", "DOP853": "v--", "LSODA": "d--"}
    for m in ("verlet", "event", "RK45", "DOP853", "LSODA"):
        rr = [r for r in rows if r["method"] == m]
        if not rr:
            continue
        e = np.array([max(r["error"], 1e-17) for r in rr])
        w = np.array([r["seconds"] for r in rr])
        ax.loglog(w, e, styles[m], label=m + (" (call)" if m in ("verlet", "event") else ""), ms=4)
        if rr[0]["kernel_seconds"] is not None:
            k = np.array([r["kernel_seconds"] for r in rr])
            ax.loglog(k, e, styles[m][0] + ":", mfc="none", ms=4, color=ax.lines[-1].get_color(),
                      label=m + " (kernel)")
    ax.axhspan(1e-10, 1e-4, color="0.93", zorder=0)
    ax.set_xlabel("wall time per solve (s)")
    ax.set_ylabel("max error" + (" in (v1, v2) at separation" if key != "d" else " in (x, v) at t = 100"))
    ax.set_title(PROBLEMS[key]["title"])
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def goal_table(levels=(1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)):
    """Markdown: at each error level, the cheapest engine run against the cheapest solve_ivp run.

    Cheapest run = least wall time among the sweep's points whose error is at most
    the level (no interpolation: conservative for every method alike).
    """
    lines = ["| problem | error | best engine (call) | best engine (kernel) | best solve_ivp | "
             "speed-up call | speed-up kernel |", "|---|---|---|---|---|---|---|"]
    for key in PROBLEMS:
        path = os.path.join(RESULTS, f"work_precision_{key}.csv")
        if not os.path.exists(path):
            continue
        with open(path) as fh:
            rows = list(csv.DictReader(fh))
        for e in levels:
            def best(methods, col="seconds"):
                c = [(float(r[col]), r["method"], float(r["param"])) for r in rows
                     if r["method"] in methods and float(r["error"]) <= e and r[col] not in ("", "None")]
                return min(c) if c else None
            eng = best(("verlet", "event"))
            engk = best(("verlet", "event"), "kernel_seconds")
            ivp = best(("RK45", "DOP853", "LSODA"))

            def fmt(b):
                return f"{b[0]:.2e} s ({b[1]} {b[2]:.0e})" if b else "none reached"

            def ratio(a, b):
                return f"{b[0] / a[0]:.1f}x" if a and b else "-"
            lines.append(f"| {key} | {e:.0e} | {fmt(eng)} | {fmt(engk)} | {fmt(ivp)} | "
                         f"{ratio(eng, ivp)} | {ratio(engk, ivp)} |")
    return "\n".join(lines)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--problems", nargs="*", default=list(PROBLEMS))
    p.add_argument("--table", action="store_true",
                   help="only print the goal table from the stored CSVs")
    p.add_argument("--quick", action="store_true", help="half the sweep points")
    a = p.parse_args()
    if a.table:
        print(goal_table())
        return
    os.makedirs(RESULTS, exist_ok=True)
    os.makedirs(FIGURES, exist_ok=True)
    load = os.getloadavg()

    def log(s):
        print(s, flush=True)
    # compile everything once
    collide(2.0, (0.0, 0.3), stepper="event")
    collide(2.5, (0.0, 0.3), stepper="event", rtol=1e-8, atol=1e-10)
    collide(2.0, (0.0, 0.3), stepper="verlet", dt=1e-2)
    summary = {}
    for key in a.problems:
        log(f"problem {key}: {PROBLEMS[key]['title']}  (load {os.getloadavg()[0]:.2f})")
        rows, refinfo = run_problem(key, a.quick, log)
        with open(os.path.join(RESULTS, f"work_precision_{key}.csv"), "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        plot(key, rows, os.path.join(FIGURES, f"perf_work_precision_{key}.png"))
        tab = speedup_table(rows)
        summary[key] = {"reference": {k: (v if not isinstance(v, tuple) else list(v))
                                      for k, v in refinfo.items()},
                        "time_at_error": {f"{e:.0e}": t for e, t in tab.items()},
                        "load_start": load[0], "load_end": os.getloadavg()[0]}
        for e, t in tab.items():
            log(f"  at error {e:.0e}: " + ", ".join(f"{m} {v:.2e}" for m, v in t.items()))
    path = os.path.join(RESULTS, "work_precision_summary.json")
    old = {}
    if os.path.exists(path):
        with open(path) as fh:
            old = json.load(fh)
    old.update(summary)
    table = goal_table()
    old["goal_table_markdown"] = table
    with open(path, "w") as fh:
        json.dump(old, fh, indent=1, default=float)
    print(table)


if __name__ == "__main__":
    main()
