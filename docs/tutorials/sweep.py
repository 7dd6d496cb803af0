"""A parameter sweep: backscattered energy against Coulomb friction and chain length.

Each point is one run of a struck Hertz chain with kinetic friction eta on every
granule; the quantity is the largest backward kinetic energy of the first three
granules over the run, as a fraction of E0. The points are independent tasks:
with dask installed they run as dask.delayed tasks (here on a thread pool; pass a
dask.distributed Client to spread them over machines), else one after another.
For sweeps of scene files from the command line, with resumable results.csv,
see ``granular-chain sweep`` in the CLI reference.
"""

import itertools

import matplotlib.pyplot as plt
import numpy as np

import granular_chain as gc
from granular_chain import diagnostics


def backscattered_fraction(count: int, eta: float) -> float:
    """Largest backward kinetic energy of granules 0-2, over E0, for one chain."""
    scene = gc.scene_from_dict({
        "granules": {"count": count, "radius": 1.0, "velocity": {0: 1.0},
                     "friction": {"kinetic": eta}},
        "contacts": {"exponent": 2.5},
        "run": {"dt": 0.01, "t_end": 25.0, "stop": "rest"},
        "output": {"every": 2, "trajectory": False},
    })
    return diagnostics.backscatter(gc.simulate(scene, progress=False), first=3)["fraction_max"]


etas = np.round(np.linspace(0.0, 0.3, 13), 3)
counts = (2, 3, 10)
points = list(itertools.product(counts, etas))
try:
    import dask
except ImportError:
    dask = None
if dask is not None:
    tasks = [dask.delayed(backscattered_fraction)(n, e) for n, e in points]
    values = dask.compute(*tasks, scheduler="threads", num_workers=2)
    how = "dask (threads, 2 workers)"
else:
    values = [backscattered_fraction(n, e) for n, e in points]
    how = "serially"
table = np.array(values).reshape(len(counts), len(etas))
print(f"{len(points)} runs, {how}\n")
print("eta    " + "".join(f"  N = {n:<5d}" for n in counts))
for j, eta in enumerate(etas):
    print(f"{eta:<6.3f} " + "".join(f"  {table[i, j]:.5f} " for i in range(len(counts))))
best = etas[np.argmax(table[-1])]
print(f"\nlargest backscatter for N = {counts[-1]}: {table[-1].max():.4f} E0 at eta = {best}")

fig, ax = plt.subplots(figsize=(5, 3.5), layout="constrained")
for i, n in enumerate(counts):
    ax.plot(etas, table[i], "o-", ms=3, label=f"$N = {n}$")
ax.set(xlabel=r"kinetic friction $\eta$", ylabel=r"$E_\mathrm{back} / E_0$",
       title="Backscattered energy, first three granules")
ax.legend()
fig.savefig("backscatter.png", dpi=110)
