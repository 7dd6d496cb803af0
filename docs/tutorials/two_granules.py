"""Two granules: one collision against the paper's closed form, then the outcome map.

Granule 1 strikes granule 2 at v0 = 1 (scaled units). With kinetic friction eta2
on granule 2 only and n = 2 the paper (Sec. II A) gives the separation velocities
in closed form:  v1 = -eta pi / (2 sqrt 2),  v2 = sqrt(1 - eta^2) + v1.
"""

import math

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import ListedColormap

from granular_chain.two_granules import OUTCOMES, collide, collision_map

eta = 0.3
v1_exact = -eta * math.pi / (2 * math.sqrt(2))
v2_exact = math.sqrt(1 - eta**2) + v1_exact

# One collision, both steppers: the event stepper is exact to roundoff at n = 2,
# velocity-Verlet converges as dt^2.
print(f"closed form         v1 = {v1_exact:+.15f}  v2 = {v2_exact:+.15f}")
for stepper, dt in (("event", None), ("verlet", 1e-3), ("verlet", 1e-4)):
    c = collide(n=2, eta=(0.0, eta), stepper=stepper, dt=dt)
    label = stepper if dt is None else f"{stepper} dt={dt:g}"
    print(f"{label:<19s} v1 = {c.v1:+.15f}  v2 = {c.v2:+.15f}  "
          f"error {max(abs(c.v1 - v1_exact), abs(c.v2 - v2_exact)):.1e}  "
          f"E/E0 = {c.energy_ratio:.6f}  t_sep = {c.t_separation:.6f}  {c.outcome.name}")

# The outcome over the (eta1, eta2) plane, n = 2: one compiled event-stepper run
# per point.
grid = np.linspace(0.0, 0.8, 33)
eta1, eta2 = np.meshgrid(grid, grid, indexing="xy")
m = collision_map(eta1, eta2, n=2.0)
print(f"\n{eta1.size} collisions in {m.wall_time:.2f} s; failed runs: {int(m.failed.sum())}")
for code, outcome in enumerate(OUTCOMES):
    print(f"  {outcome.name:<28s} {np.count_nonzero(m.outcome == code):5d} points")

colours = ["#4477aa", "#66ccee", "#228833", "#ccbb44", "#ee6677", "#aa3377"]
fig, ax = plt.subplots(figsize=(7.0, 4.0), layout="constrained")
ax.pcolormesh(grid, grid, m.outcome, cmap=ListedColormap(colours), vmin=-0.5, vmax=5.5,
              shading="nearest")
for code, outcome in enumerate(OUTCOMES):
    if np.any(m.outcome == code):
        ax.plot([], [], "s", color=colours[code], label=outcome.name.replace("_", " "))
ax.set(xlabel=r"$\eta_1$", ylabel=r"$\eta_2$", title=r"Outcome of the collision, $n = 2$")
fig.legend(loc="outside right upper", fontsize=8)
fig.savefig("outcomes.png", dpi=110)
