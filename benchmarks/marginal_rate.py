"""Marginal Verlet rate through simulate(): N S / (t(2S) - t(S)), best of --repeat (issue 5).

Runs benchmarks/throughput.py's scene (struck Hertz chain) with S and 2 S steps
through the public ``simulate()`` and prints one JSON line per feature set with
the marginal rate (the kernel alone: the output frame's cost cancels) and the
end-to-end rate of the 2 S run. Which checkout is measured is set by PYTHONPATH;
the line names it.

    PYTHONPATH=. python benchmarks/marginal_rate.py --grains 1e7 --steps 20 --features frictionless viscous
"""

import argparse
import json
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import throughput  # noqa: E402

import granular_chain  # noqa: E402


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--grains", type=float, default=1e7)
    p.add_argument("--steps", type=int, default=20)
    p.add_argument("--features", nargs="*", default=["frictionless", "viscous"])
    p.add_argument("--repeat", type=int, default=3)
    a = p.parse_args()
    N = int(a.grains)
    S = a.steps
    for feat in a.features:
        best = {}
        loads = []
        for _ in range(a.repeat):
            for s in (S, 2 * S):
                loads.append(os.getloadavg()[0])
                out = throughput.measure(N, s, feat)
                best[s] = min(best.get(s, float("inf")), out["seconds"])
        print(json.dumps({"tree": os.path.dirname(os.path.dirname(granular_chain.__file__)),
                          "features": feat, "grains": N, "steps": [S, 2 * S],
                          "marginal_Mps": N * S / (best[2 * S] - best[S]) / 1e6,
                          "end_to_end_Mps": N * 2 * S / best[2 * S] / 1e6,
                          "load_min": min(loads), "load_max": max(loads)}), flush=True)


if __name__ == "__main__":
    main()
