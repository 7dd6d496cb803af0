"""Old (three full passes) vs new (tiled) Verlet kernel, interleaved, against N (tiled-verlet).

Starts one persistent worker process per kernel (each with its own PYTHONPATH,
so both kernels run in the same driver without reloading), and for every case
and N runs, interleaved, old(S), new(S), old(2S), new(2S), ``--repeat`` times,
keeping the best time of each. Reports the marginal rate N S / (t(2S) - t(S))
(kernel alone) in M grain-steps/s, and the load average around each case. The
scene is benchmarks/throughput.py's (struck Hertz chain, or random velocities).

    python benchmarks/tiled_scaling.py --old /tmp/old_tree --new . --json out.json
    python benchmarks/tiled_scaling.py --new . --blocks 256 512 1024 2048 4096 --grains 1e4 1e7

With ``--blocks`` the new kernel is run once per block size (the module constant
``verlet.BLOCK`` set in the worker before compiling, with a private numba cache
directory per block size) instead of against the old kernel.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile

import throughput  # case_grid, emit (this script's directory is on sys.path)

WORKER = r"""
import json, os, sys
sys.path = [p for p in sys.path if p != ""]
sys.path.insert(0, os.path.join(sys.argv[1], "benchmarks"))
if os.environ.get("TILED_BLOCK"):
    import granular_chain.steppers.verlet as V
    V.BLOCK = int(os.environ["TILED_BLOCK"])
import throughput, granular_chain
print("worker kernel:", granular_chain.__file__, file=sys.stderr)
for line in sys.stdin:
    q = json.loads(line)
    out = throughput.measure(q["grains"], q["steps"], q["features"], "verlet", q["initial"])
    print(json.dumps(out), flush=True)
"""

CASES = [("frictionless", "struck"), ("coulomb+viscous", "struck"), ("coulomb+viscous", "random")]


class Worker:
    def __init__(self, root, block=None):
        env = dict(os.environ, PYTHONPATH=os.path.abspath(root))
        if block:
            env["TILED_BLOCK"] = str(block)
            env["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix=f"nbcache_B{block}_")
        self.p = subprocess.Popen([sys.executable, "-c", WORKER, os.path.abspath(root)], env=env,
                                  stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)

    def measure(self, **q):
        self.p.stdin.write(json.dumps(q) + "\n")
        self.p.stdin.flush()
        return json.loads(self.p.stdout.readline())

    def close(self):
        self.p.stdin.close()
        self.p.wait()


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--old", default=None, help="checkout with the old kernel")
    p.add_argument("--new", default=".", help="checkout with the new kernel")
    p.add_argument("--blocks", type=int, nargs="*", default=None)
    p.add_argument("--grains", type=float, nargs="*", default=[1e2, 1e3, 1e4, 1e5, 1e6, 1e7])
    p.add_argument("--grain-steps", type=float, default=1e8)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--cases", nargs="*", default=None, help="e.g. 'frictionless struck'")
    p.add_argument("--json", default=None, help="append result rows (JSON lines) to this file")
    a = p.parse_args()
    if a.blocks:
        workers = {f"B={b}": Worker(a.new, b) for b in a.blocks}
    else:
        workers = {"old": Worker(a.old), "new": Worker(a.new)}
    for features, initial, N, steps in throughput.case_grid(CASES, a.cases, a.grains,
                                                            a.grain_steps, 20):
        best = {}
        loads = [os.getloadavg()[0]]
        for _ in range(a.repeat):
            for s in (steps, 2 * steps):
                for name, w in workers.items():
                    out = w.measure(grains=N, steps=s, features=features, initial=initial)
                    key = (name, s)
                    if key not in best or out["seconds"] < best[key]["seconds"]:
                        best[key] = out
            loads.append(os.getloadavg()[0])
        row = {"case": f"{features} {initial}", "grains": N, "steps": steps,
               "load_min": min(loads), "load_max": max(loads)}
        for name in workers:
            t1, t2 = best[(name, steps)]["seconds"], best[(name, 2 * steps)]["seconds"]
            row[name] = N * steps / max(t2 - t1, 1e-12) / 1e6
            row[name + "_end_to_end"] = N * 2 * steps / t2 / 1e6
            row[name + "_balance"] = best[(name, 2 * steps)]["energy_balance_error"]
        throughput.emit(row, a.json)
    for w in workers.values():
        w.close()


if __name__ == "__main__":
    main()
