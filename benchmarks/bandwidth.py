"""Memory bandwidth of this machine (numba STREAM kernels) and the bound it puts on Verlet (issue 5).

Measures, on arrays far larger than the last-level cache (default 2e7 float64 =
160 MB per array), the STREAM kernels written in numba, one thread and all
threads (prange):

    copy   a[i] = b[i]                 16 B/element counted (read b, write a)
    scale  a[i] = s * b[i]             16 B
    triad  a[i] = b[i] + s * c[i]      24 B
    sum    s += a[i]                    8 B (read-only)

Bytes are counted the STREAM way (no write-allocate); the minimum over repeats
is kept. The DRAM traffic of the triad is really 32 B per element (a store to a
line not read first costs a read for ownership too), so the memory system moves
``triad x 32/24`` bytes per second: that is the bandwidth used for the bounds.

The grain-step bound is that bandwidth over the DRAM bytes per grain-step
(write-allocate included, counted below):

* ``engine_3pass``: the arrays the blocked passes stream
  (granular_chain/steppers/verlet/kernel.py, passes_chunk), frictionless;
* ``engine_3pass_coulomb_viscous``: the same with the kick and drift parameters;
* ``single_sweep``: what one sweep per step must move with per-granule
  parameters: u, v, f read and written (48 B) and inv_m, d0, k read (24 B);
* ``single_sweep_uniform``: the same with uniform parameters (48 B).

    python benchmarks/bandwidth.py --json
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numba
import numpy as np
from numba import prange

# DRAM bytes per grain-step (float64 = 8 B, active = uint8; an array written
# without being read in the same pass costs 16 B: read for ownership + write-back):
#   engine, frictionless: pass 1 (kick + drift) reads v f u inv_m, writes v u    = 48
#                 pass 2 (contacts) reads u d0 k, writes c (not read: 16)        = 40
#                 pass 3 (net force + kick + events) reads c v inv_m active,
#                 writes f (not read: 16) v active                               = 50
#   engine, coulomb+viscous: pass 1 also reads eta eta_s m E P1, pass 3 eta eta_s = 138 + 56
KERNEL_BYTES = {"engine_3pass": 138, "engine_3pass_coulomb_viscous": 194,
                "single_sweep": 72, "single_sweep_uniform": 48}
WRITE_ALLOCATE = 32.0 / 24.0


@numba.njit(cache=True)
def copy(a, b):
    for i in range(a.size):
        a[i] = b[i]


@numba.njit(cache=True)
def scale(a, b, s):
    for i in range(a.size):
        a[i] = s * b[i]


@numba.njit(cache=True)
def triad(a, b, c, s):
    for i in range(a.size):
        a[i] = b[i] + s * c[i]


@numba.njit(cache=True)
def total(a):
    s = 0.0
    for i in range(a.size):
        s += a[i]
    return s


@numba.njit(cache=True, parallel=True)
def triad_par(a, b, c, s):
    for i in prange(a.size):
        a[i] = b[i] + s * c[i]


@numba.njit(cache=True, parallel=True)
def copy_par(a, b):
    for i in prange(a.size):
        a[i] = b[i]


def best(fn, *args, repeat=7):
    fn(*args)
    t = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn(*args)
        t.append(time.perf_counter() - t0)
    return min(t)


def measure(n, repeat=7):
    a = np.zeros(n)
    b = np.random.default_rng(0).random(n)
    c = np.random.default_rng(1).random(n)
    out = {"elements": n, "array_MB": n * 8 / 1e6, "load": os.getloadavg()[0],
           "threads": numba.get_num_threads()}
    out["copy_GBs"] = 16 * n / best(copy, a, b, repeat=repeat) / 1e9
    out["scale_GBs"] = 16 * n / best(scale, a, b, 3.0, repeat=repeat) / 1e9
    out["triad_GBs"] = 24 * n / best(triad, a, b, c, 3.0, repeat=repeat) / 1e9
    out["sum_GBs"] = 8 * n / best(total, b, repeat=repeat) / 1e9
    out["triad_par_GBs"] = 24 * n / best(triad_par, a, b, c, 3.0, repeat=repeat) / 1e9
    out["copy_par_GBs"] = 16 * n / best(copy_par, a, b, repeat=repeat) / 1e9
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--elements", type=float, default=2e7)
    p.add_argument("--repeat", type=int, default=7)
    p.add_argument("--json", action="store_true")
    a = p.parse_args()
    res = measure(int(a.elements), a.repeat)
    # in-cache reference (256 KB per array: L2)
    small = measure(32768, repeat=2000)
    res["in_cache_triad_GBs"] = small["triad_GBs"]
    res["triad_dram_GBs"] = res["triad_GBs"] * WRITE_ALLOCATE
    bw = res["triad_dram_GBs"] * 1e9
    res["kernel_bytes_per_grain_step"] = KERNEL_BYTES
    res["bound_grain_steps_per_s"] = {k: bw / v for k, v in KERNEL_BYTES.items()}
    os.makedirs(os.path.join(os.path.dirname(__file__), "results"), exist_ok=True)
    with open(os.path.join(os.path.dirname(__file__), "results", "bandwidth.json"), "w") as fh:
        json.dump(res, fh, indent=1)
    if a.json:
        print(json.dumps(res))
    else:
        for k, v in res.items():
            print(f"{k:32s} {v}")


if __name__ == "__main__":
    main()
