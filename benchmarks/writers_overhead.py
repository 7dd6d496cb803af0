"""Cost of the writers: time and disk for 1000 frames of a 10,000-granule chain, and the
run's overhead with writers on against off.

    python benchmarks/writers_overhead.py            # 10,000 granules, 1000 frames
    python benchmarks/writers_overhead.py --granules 1000 --frames 200

The run is the shipped friction chain (scenarios/chain_friction.yaml) made longer,
stepped to t_end = 1000 with a frame every t_end/frames. It reports:

* the stepping time (simulate(), writers off; the kernel is compiled and cached first);
* each writer on that Result: seconds and bytes on disk (VTK with zlib, lz4 and no
  compression);
* end-to-end ``granular-chain run`` wall time (a fresh process, as a user runs it) with no
  writer (only summary.json) against trajectory + csv + vtk, and the overhead ratio.

Numbers go to stdout as a table and, with --json, to a file. Speed is a benchmark,
never a test.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CHAIN = ROOT / "scenarios" / "chain_friction.yaml"


def _du(path: Path) -> int:
    if path.is_file():
        return path.stat().st_size
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def _timed(fn, *args, **kwargs):
    t0 = time.perf_counter()
    out = fn(*args, **kwargs)
    return time.perf_counter() - t0, out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--granules", type=int, default=10_000)
    ap.add_argument("--frames", type=int, default=1000)
    ap.add_argument("--t-end", type=float, default=1000.0)
    ap.add_argument("--workdir", default=None, help="scratch folder (default: a temp dir)")
    ap.add_argument("--json", default=None, help="also write the numbers to this file")
    args = ap.parse_args(argv)

    from granular_chain import load_scene, simulate
    from granular_chain.writers.summary import write_summary
    from granular_chain.writers.tables import write_tables
    from granular_chain.writers.trajectory import write_trajectory
    from granular_chain.writers.vtk import write_vtk

    overrides = [f"granules.count={args.granules}", f"run.t_end={args.t_end}",
                 "output.dt=null", "output.every=1"]
    scene = load_scene(CHAIN, overrides)
    from granular_chain.simulate import default_dt
    from granular_chain.model import build_model
    dt = default_dt(build_model(scene))
    steps = int(args.t_end / dt)
    every = max(1, steps // args.frames)
    overrides[-1] = f"output.every={every}"
    scene = load_scene(CHAIN, overrides)

    simulate(load_scene(CHAIN, ["run.t_end=1"]), progress=False)  # compile / load cache
    t_sim, result = _timed(simulate, scene, progress=False)
    F, N = result.x.shape
    rows = [("simulate (stepping, writers off)", t_sim, None)]

    work = Path(args.workdir) if args.workdir else Path(tempfile.mkdtemp(prefix="gc-bench-"))
    work.mkdir(parents=True, exist_ok=True)
    try:
        d = work / "summary"
        d.mkdir()
        t, p = _timed(write_summary, result, d, scene)
        rows.append(("summary.json", t, _du(p)))
        d = work / "traj"
        d.mkdir()
        t, p = _timed(write_trajectory, result, d, scene)
        rows.append(("trajectory.h5 (t, x, v, f, ledger)", t, _du(p)))
        d = work / "csv"
        d.mkdir()
        t, ps = _timed(write_tables, result, d, scene)
        rows.append(("energy.csv", t, sum(_du(q) for q in ps)))
        for comp in ("zlib", "lz4", None):
            d = work / f"vtk-{comp}"
            t, _ = _timed(write_vtk, result, d, scene, compression=comp)
            rows.append((f"VTK series, {comp or 'uncompressed'} ({F} .vtp + .pvd)", t, _du(d)))
            shutil.rmtree(d)

        # End to end, fresh processes, as a user runs them.
        cli = [sys.executable, "-m", "granular_chain.cli", "run", str(CHAIN), "--quiet"]
        sets = [a for o in overrides for a in ("--set", o)]
        e2e = {}
        for label, flags in (("no writers (summary.json only)", ["--no-trajectory"]),
                             ("trajectory + csv + vtk", ["--trajectory", "--csv", "--vtk"])):
            out = work / f"e2e-{len(e2e)}"
            t0 = time.perf_counter()
            subprocess.run(cli + sets + flags + ["--out", str(out)], check=True)
            e2e[label] = (time.perf_counter() - t0, _du(out))
            shutil.rmtree(out)
    finally:
        if not args.workdir:
            shutil.rmtree(work, ignore_errors=True)

    print(f"chain_friction, N = {N} granules, F = {F} frames, {result.steps} steps "
          f"(dt = {result.dt:.4g}, a frame every {every} steps)")
    print(f"{'what':50s} {'seconds':>9s} {'disk':>10s}  per frame")
    for name, secs, size in rows:
        disk = "" if size is None else f"{size / 1e6:8.1f} MB"
        per = "" if size is None else f"{secs / F * 1e3:6.2f} ms, {size / F / 1e3:7.1f} kB"
        print(f"{name:50s} {secs:9.2f} {disk:>10s}  {per}")
    print("end to end (granular-chain run, fresh process):")
    for label, (secs, size) in e2e.items():
        print(f"  {label:48s} {secs:9.2f} {size / 1e6:8.1f} MB")
    (t_off, _), (t_on, _) = e2e.values()
    print(f"  overhead of the writers: +{t_on - t_off:.2f} s ({t_on / t_off:.2f}x)")
    if args.json:
        Path(args.json).write_text(json.dumps({
            "granules": N, "frames": F, "steps": result.steps,
            "rows": [{"what": a, "seconds": b, "bytes": c} for a, b, c in rows],
            "end_to_end": {k: {"seconds": a, "bytes": b} for k, (a, b) in e2e.items()},
        }, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
