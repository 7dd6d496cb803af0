"""Throughput of two checkouts, interleaved: OLD against NEW, stepping only.

Runs ``benchmarks/throughput.py`` (a struck Hertz chain, kernel compiled or loaded by a
warm-up first) with each checkout on PYTHONPATH in turn, 7 times per case, and prints a
JSON line per case: the median rates (million grain-steps per second) and the median,
min and max of the pair-by-pair ratio NEW/OLD (pairs run back to back, so a drift of the
machine's speed cancels).

    python benchmarks/driver_ab.py OLD_CHECKOUT NEW_CHECKOUT > results.jsonl
"""

import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

THROUGHPUT = Path(__file__).with_name("throughput.py")
CASES = [(100, 200_000), (10_000, 20_000), (1_000_000, 300)]
FEATURES = ["frictionless", "coulomb+viscous"]
REPEAT = 7


def rate(checkout: str, grains: int, steps: int, features: str) -> float:
    env = {**os.environ, "PYTHONPATH": checkout}
    out = subprocess.run([sys.executable, str(THROUGHPUT), "--grains", str(grains), "--steps",
                          str(steps), "--features", features, "--json"], env=env,
                         capture_output=True, text=True, check=True).stdout
    return json.loads(out)["grain_steps_per_s"]


def main():
    old, new = sys.argv[1], sys.argv[2]
    for grains, steps in CASES:
        for features in FEATURES:
            rates = {"old": [], "new": []}
            for _ in range(REPEAT):
                rates["old"].append(rate(old, grains, steps, features))
                rates["new"].append(rate(new, grains, steps, features))
            pairs = sorted(n / o for n, o in zip(rates["new"], rates["old"]))
            print(json.dumps({
                "N": grains, "steps": steps, "features": features,
                "old_M": statistics.median(rates["old"]) / 1e6,
                "new_M": statistics.median(rates["new"]) / 1e6,
                "pair_ratio_median": statistics.median(pairs), "pair_min": pairs[0],
                "pair_max": pairs[-1]}), flush=True)


if __name__ == "__main__":
    main()
