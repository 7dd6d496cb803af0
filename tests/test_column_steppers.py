"""The column under gravity (scenarios/column.yaml) with both steppers.

Ten Hertz spheres on a wall, gravity towards it, viscoelastic dashpots: the
column comes to rest at the static overlaps delta_i = (i m g / k)^(2/3), grain i
counted from the top. The Verlet run stops at rest; the event stepper (which
sees the velocities decay without ever reaching zero) runs to t_end. Both must
give the static overlaps to 1e-10 relative, and so agree with each other.
"""

from pathlib import Path

import numpy as np
import pytest

import granular_chain as gc
from granular_chain.restitution import column_overlaps

SCENE = Path(__file__).resolve().parents[1] / "scenarios" / "column.yaml"


def overlaps_from_top(x):
    """Overlaps (wall contact last) of touching spheres of radius 1, from the top."""
    return np.concatenate([[1.0 - x[0]], 2.0 - np.diff(x)])[::-1]


@pytest.fixture(scope="module")
def runs():
    out = {}
    for stepper in ("verlet", "event"):
        overrides = [f"run.stepper={stepper}"] + (["run.dt=null"] if stepper == "event" else [])
        scene = gc.load_scene(SCENE, overrides + ["output.trajectory=false"])
        out[stepper] = gc.simulate(scene, progress=False)
    return out


def test_both_steppers_settle_to_the_static_overlaps(runs):
    expected = column_overlaps(10, 1.0, 0.01, 1.0, 2.5)
    assert runs["verlet"].status.name == "AT_REST"
    assert runs["event"].status.name == "T_END"
    for stepper, r in runs.items():
        error = np.max(np.abs(overlaps_from_top(r.x_final) / expected - 1.0))
        assert error < 1e-10, (stepper, error)
        # gravity's work went into the springs and the dashpots
        led = r.energy
        assert led.body_work[-1] > 0 and led.contact_dissipated[-1] > 0
        assert led.balance_error < (1e-5 if stepper == "verlet" else 1e-12), stepper


def test_the_steppers_agree(runs):
    a, b = (overlaps_from_top(runs[s].x_final) for s in ("verlet", "event"))
    assert np.max(np.abs(a / b - 1.0)) < 1e-10
