"""The paper's (eta1, eta2) maps as a 10,000-point sweep on a LocalCluster; wall time and overhead.

    python benchmarks/sweep_scaling.py [--points-per-axis 100] [--workers 2] [--out DIR]

Equivalent to (once `sweep` is wired into the CLI):

    granular-chain sweep scenarios/chain_eta_map.yaml \\
        --grid 'granules.friction.kinetic[0]=0:0.5:100' \\
        --grid 'granules.friction.kinetic[1]=0:0.8:100' --workers 2 \\
        --out outputs/sweeps/eta_map --quantity v1 --quantity v2 --quantity energy_ratio \\
        --quantity outcome --mask outcome=backscatter_and_propagation

Prints the sweep statistics (wall time, points per second, kernel time, the
per-point overhead = (wall x workers - stepping time) / points, and the part of it
spent inside each point on validation, model building and reduction), then draws
docs/figures/chains_eta_map_{v1,v2,energy,outcome}.png. A rerun of the same command
skips every point (resumable) and only redraws.
"""

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None):
    from granular_chain import sweep as sw

    p = argparse.ArgumentParser()
    p.add_argument("--points-per-axis", type=int, default=100)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--out", default=str(ROOT / "outputs" / "sweeps" / "eta_map"))
    p.add_argument("--batch-size", type=int, default=None)
    a = p.parse_args(argv)
    n = a.points_per_axis
    axes = [sw.parse_grid(f"granules.friction.kinetic[0]=0:0.5:{n}"),
            sw.parse_grid(f"granules.friction.kinetic[1]=0:0.8:{n}")]
    t0 = time.perf_counter()
    st = sw.run_sweep(ROOT / "scenarios" / "chain_eta_map.yaml", axes, out_dir=a.out,
                      workers=a.workers, batch_size=a.batch_size)
    total = time.perf_counter() - t0
    d = st.as_dict()
    d["total_including_cluster_start_s"] = total
    if st.computed:
        d["mean_eval_s"] = st.sum_eval / st.computed
        d["mean_kernel_s"] = st.sum_kernel / st.computed
        d["in_point_overhead_s"] = (st.sum_eval - st.sum_kernel) / st.computed
        d["scheduling_overhead_s"] = (st.wall * st.workers - st.sum_eval) / st.computed
    print(json.dumps(d, indent=1))
    cols = sw.read_results(st.results)
    outc = cols["outcome"]
    print("outcomes:", {k: int(np.sum(outc == k)) for k in sorted(set(outc.tolist()))})
    fig = ROOT / "docs" / "figures"
    x, y = axes[0].path, axes[1].path
    mask = {"outcome": "backscatter_and_propagation"}
    sw.plot_heatmap(cols, x, y, "v1", fig / "chains_eta_map_v1.png", mask=mask,
                    transform=np.negative, label=r"$-v_1$ (backscattering speed)",
                    title=r"$n = 5/2$: backscattering velocity $-v_1$ where both move (paper Fig. hertz, left)")
    sw.plot_heatmap(cols, x, y, "v2", fig / "chains_eta_map_v2.png", mask=mask,
                    label=r"$v_2$ (forward speed)",
                    title=r"$n = 5/2$: forward velocity $v_2$ where both move (paper Fig. hertz, middle)")
    sw.plot_heatmap(cols, x, y, "energy_ratio", fig / "chains_eta_map_energy.png", mask=mask,
                    label=r"$E/E_0$", title=r"$n = 5/2$: energy ratio $E/E_0$ where both move "
                    "(paper Fig. hertz, right)")
    sw.plot_heatmap(cols, x, y, "outcome", fig / "chains_eta_map_outcome.png",
                    title=r"$n = 5/2$: outcome of the collision over $(\eta_1, \eta_2)$")


if __name__ == "__main__":
    sys.exit(main())
