"""Damped contacts, gravity and a driven wall.

1. The restitution of two viscoelastic Hertz spheres over six decades of impact
   speed, against an independent high-precision integration and the small-speed
   series 1 - e = C1 G - C2 G^2.
2. The linear dashpot chosen for a target restitution (n = 2): e comes out exact.
3. A column settling on a wall under gravity, against delta_i = (i m g / k)^(2/3).
4. A chain driven by an oscillating wall: where the wall's work goes.
5. A target restitution for any exponent: e = 0.9 at impact speed 1 for n = 5/2
   and n = 3, the curves e(v) from scaled_restitution and the engine's points.
"""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import granular_chain as gc
from granular_chain.restitution import (column_overlaps, damping_group, restitution_reference,
                                        scaled_restitution, solve_damping, viscoelastic_series)

STEPPER = "event"
SCENES = Path(__file__).resolve().parents[2] / "scenarios"


def two_granules(v, damping, n, tensile=False, stepper=STEPPER):
    """Granule 0 at speed v hits granule 1 at rest (m = 1, k = 1); returns e."""
    run = {"stepper": stepper, "t_end": 1e6, "stop": "separation"}
    scene = gc.scene_from_dict({
        "name": "pair", "granules": {"count": 2, "radius": 1.0, "velocity": {0: float(v)}},
        "contacts": {"exponent": n, "damping": damping, "tensile": tensile},
        "run": run, "output": {"trajectory": False}})
    r = gc.simulate(scene, progress=False)
    assert r.success, r.message
    return (r.v_final[1] - r.v_final[0]) / v


# 1. viscoelastic Hertz spheres: e(v)
A, m_eff = 0.1, 0.5
speeds = np.logspace(-6, 0, 13)
visco = {"model": "viscoelastic", "coefficient": A}
engine = np.array([two_granules(v, visco, 2.5) for v in speeds])
reference = np.array([restitution_reference(v, 1.0, m_eff, 2.5, "viscoelastic", A,
                                            tensile=False, dps=30).e for v in speeds])
print("viscoelastic Hertz, A = 0.1: e(v), engine against the reference integration")
print("        v          e (engine)        e (reference)      difference")
for v, e, ref in zip(speeds, engine, reference):
    print(f"  {v:9.1e}  {e:.15f}  {ref:.15f}  {e - ref:+.1e}")
print(f"largest |difference|: {np.max(np.abs(engine - reference)):.1e}")

fine = np.logspace(-6, 0, 200)
fig, ax = plt.subplots(figsize=(6.4, 4.2), constrained_layout=True)
ax.loglog(fine, 1 - viscoelastic_series(fine, 1.0, A, m_eff, terms=1), "C1--",
          label=r"series $C_1 G$")
ax.loglog(fine, 1 - viscoelastic_series(fine, 1.0, A, m_eff, terms=2), "C2-.",
          label=r"series $C_1 G - C_2 G^2$")
ax.loglog(speeds, 1 - reference, "k-", lw=0.8, label="reference integration")
ax.loglog(speeds, 1 - engine, "o", mfc="none", color="C0", label=f"engine ({STEPPER} stepper)")
ax.set_xlabel(r"impact speed $v$ (scaled: $k = m = 1$)")
ax.set_ylabel(r"$1 - e$")
ax.set_title(r"viscoelastic Hertz spheres, $A = 0.1$")
ax.legend(fontsize=8)
fig.savefig("restitution_viscoelastic.png", dpi=120)

# 2. a target restitution with the linear dashpot (n = 2): independent of v
for tensile in (False, True):
    e = [two_granules(v, {"model": "restitution", "value": 0.8}, 2.0, tensile)
         for v in (1e-3, 1.0)]
    print(f"\nrestitution 0.8 asked, tensile = {tensile}: e = {e[0]:.15f} (v = 1e-3), "
          f"{e[1]:.15f} (v = 1)")

# 3. the column: static overlaps under gravity
column = gc.simulate(gc.load_scene(SCENES / "column.yaml"), progress=False)
x = column.x_final
overlaps = np.concatenate([[1.0 - x[0]], 2.0 - np.diff(x)])[::-1]  # from the top
expected = column_overlaps(10, 1.0, 0.01, 1.0, 2.5)
print(f"\ncolumn: {column.status} at t = {column.t_final:.1f}; largest relative "
      f"error of the static overlaps {np.max(np.abs(overlaps / expected - 1)):.1e}")

# 4. the driven chain: the wall's work, dissipated and stored
driven = gc.simulate(gc.load_scene(SCENES / "driven_chain.yaml"), progress=False)
led = driven.energy
fig, ax = plt.subplots(figsize=(6.4, 3.8), constrained_layout=True)
ax.plot(driven.t, led.wall_work, "k-", label="work done by the wall")
ax.plot(driven.t, led.kinetic + led.potential, label="kinetic + elastic")
ax.plot(driven.t, led.contact_dissipated, label="dissipated in the contacts")
ax.set_xlabel(r"$t$ (scaled)")
ax.set_ylabel("energy (scaled)")
ax.legend(fontsize=8)
fig.savefig("driven_ledger.png", dpi=120)
print(f"\ndriven chain: the wall did {led.wall_work[-1]:.4g}; the contacts dissipated "
      f"{led.contact_dissipated[-1]:.4g}; ledger error {led.balance_error:.1e}")

# 5. a target restitution for any exponent: e = 0.9 at impact speed 1
target = {"model": "restitution", "value": 0.9, "speed": 1.0}
curve_speeds = np.logspace(-4, 1, 61)
fig, ax = plt.subplots(figsize=(6.4, 4.2), constrained_layout=True)
print("\nrestitution 0.9 at speed 1: e(v) of the engine and of scaled_restitution")
for colour, n in (("C0", 2.5), ("C3", 3.0)):
    A_n = solve_damping(0.9, 1.0, n, 1.0, m_eff)
    curve = [scaled_restitution(damping_group(A_n, v, n, 1.0, m_eff), n) for v in curve_speeds]
    ax.semilogx(curve_speeds, curve, "-", color=colour, label=f"n = {n:g}: scaled_restitution")
    points = np.array([1e-3, 1e-2, 1e-1, 1.0])
    measured = [two_granules(v, target, n) for v in points]
    ax.semilogx(points, measured, "o", mfc="none", color=colour,
                label=f"n = {n:g}: engine ({STEPPER} stepper)")
    for v, e in zip(points, measured):
        expected = scaled_restitution(damping_group(A_n, v, n, 1.0, m_eff), n)
        print(f"  n = {n:g}, v = {v:7.0e}: e = {e:.12f}, scaled_restitution {expected:.12f}, "
              f"difference {e - expected:+.1e}")
ax.axhline(0.9, color="0.6", lw=0.6)
ax.axvline(1.0, color="0.6", lw=0.6)
ax.set_xlabel(r"impact speed $v$ (scaled: $k = 1$, $m^* = 1/2$)")
ax.set_ylabel(r"restitution $e$")
ax.set_title(r"model: restitution, value: 0.9, speed: 1")
ax.legend(fontsize=8)
fig.savefig("restitution_any_exponent.png", dpi=120)
