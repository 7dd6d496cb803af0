"""Merged kicks: Coulomb scenes that do not stop at rest step the leapfrog form
(one kick of dt per step instead of two of dt/2; granular_chain/steppers/verlet.py).

A kick is the exact flow of m dv/dt = F - eta sign(v) (with stick) under a frozen
force, so two half kicks and one whole kick are the same map up to roundoff. The
checks: the merged run agrees with the same scene run with two half kicks per
step (forced by a 'rest' stop that does not trigger) to roundoff, with the same
stop, slip and contact counts and the same friction work; the output cadence
does not change a merged trajectory at all (bitwise); and the synchronised
velocities handed to the frames close the energy ledger.
"""

import numpy as np
import pytest

import granular_chain as gc
from granular_chain.steppers import verlet


def _chain(N, viscous, stop, every, seed=7, t_end=8.0):
    rng = np.random.default_rng(seed)
    friction = {"kinetic": rng.uniform(0.0, 4e-3, N).tolist(),
                "static": rng.uniform(4e-3, 6e-3, N).tolist()}
    if viscous:
        friction["viscous"] = rng.uniform(0.0, 0.05, N).tolist()
    granules = {"count": N, "mass": rng.uniform(0.5, 2.0, N).tolist(), "radius": 0.5,
                "gap": rng.uniform(-0.01, 0.01, N - 1).tolist(),
                # random velocities: granules stick, slip and reverse
                "velocity": rng.uniform(-0.05, 0.05, N).tolist(), "friction": friction}
    return gc.scene_from_dict({
        "name": "merged", "granules": granules,
        "contacts": {"exponent": 2.5, "stiffness": rng.uniform(0.5, 2.0, N - 1).tolist()},
        "walls": {"left": {"gap": 0.0, "exponent": 2.5, "stiffness": 1.0},
                  "right": {"gap": 0.0, "exponent": 2.5, "stiffness": 1.0}},
        "run": {"stepper": "verlet", "dt": 0.01, "t_end": t_end, "stop": stop},
        "output": {"every": every, "trajectory": False}})


def test_only_coulomb_scenes_that_do_not_stop_at_rest_merge_kicks():
    assert verlet.merges_kicks(1, 0)
    assert not verlet.merges_kicks(0, 0)
    assert not verlet.merges_kicks(1, verlet.STOP_ON_REST)
    assert verlet.merges_kicks(1, verlet.STOP_ON_SEPARATION)
    assert not verlet.merges_kicks(1, verlet.STOP_ON_REST | verlet.STOP_ON_SEPARATION)


@pytest.mark.parametrize("viscous", [False, True], ids=["coulomb", "coulomb+viscous"])
def test_merged_kicks_equal_two_half_kicks(viscous):
    merged = gc.simulate(_chain(60, viscous, "t_end", 100), progress=False)
    halves = gc.simulate(_chain(60, viscous, "rest", 100), progress=False)
    assert merged.status == halves.status == gc.Status.T_END
    assert merged.steps == halves.steps == 800
    # the runs exercised what the merge has to get right
    assert merged.event_counts["stop"] > 50 and merged.event_counts["slip"] > 50
    assert merged.event_counts == halves.event_counts
    # same map up to roundoff: the two trajectories differ by rounding only
    # (O(1e-16) per step, grown over 800 steps of a nonlinear chain)
    assert np.max(np.abs(merged.x - halves.x)) < 1e-12
    assert np.max(np.abs(merged.v - halves.v)) < 1e-12
    assert np.max(np.abs(merged.energy.coulomb - halves.energy.coulomb)) < 1e-14
    if viscous:
        assert np.max(np.abs(merged.energy.viscous - halves.energy.viscous)) < 1e-14


def test_merged_trajectory_does_not_depend_on_the_output_cadence():
    every_step = gc.simulate(_chain(30, True, "t_end", 1, t_end=2.0), progress=False)
    rare = gc.simulate(_chain(30, True, "t_end", 37, t_end=2.0), progress=False)
    assert every_step.steps == rare.steps == 200
    # frames of the rare run are every 37th frame of the other, bit for bit
    idx = np.searchsorted(every_step.t, rare.t)
    assert np.array_equal(every_step.t[idx], rare.t)
    for name in ("x", "v", "f"):
        assert np.array_equal(getattr(every_step, name)[idx], getattr(rare, name)), name
    assert np.array_equal(every_step.energy.coulomb[idx], rare.energy.coulomb)
    assert every_step.event_counts == rare.event_counts


def test_synchronised_frames_close_the_ledger():
    # The frames of a merged run carry the synchronised velocities and the work of
    # the half kick to the frame's time: their ledger balance is the two-half-kick
    # run's (1.66e-6 and 2.06e-6 of the initial energy at dt = 0.01, the O(dt^2)
    # error of Verlet), not the O(eta v dt) a missing half kick would leave.
    for viscous in (False, True):
        merged = gc.simulate(_chain(60, viscous, "t_end", 10), progress=False)
        halves = gc.simulate(_chain(60, viscous, "rest", 10), progress=False)
        balance = []
        for r in (merged, halves):
            e = r.energy
            total = e.kinetic + e.potential + e.coulomb + e.viscous
            balance.append(np.abs(total - e.initial) / e.initial)
            assert e.coulomb[-1] > 0.3 * e.initial  # Coulomb friction did real work
        assert np.max(balance[0]) < 3e-6
        assert np.max(np.abs(balance[0] - balance[1])) < 1e-12


def test_separation_stop_with_merged_kicks():
    # Two granules with kinetic friction (n = 2, the paper's problem): the run that
    # stops at separation merges its kicks; adding a 'rest' stop (which does not
    # trigger first) forces two half kicks. Same step, same backtracked time and
    # state to roundoff.
    def run(stop):
        return gc.simulate(gc.scene_from_dict({
            "granules": {"count": 2, "velocity": [1.0, 0.0],
                         "friction": {"kinetic": [0.3, 0.1], "static": [0.35, 0.12]}},
            "contacts": {"exponent": 2.0, "stiffness": 1.0},
            "run": {"stepper": "verlet", "dt": 1e-3, "t_end": 50.0, "stop": stop}}),
            progress=False)

    merged, halves = run("separation"), run(["separation", "rest"])
    assert merged.status == halves.status == gc.Status.SEPARATED
    assert merged.steps == halves.steps
    assert merged.event_counts == halves.event_counts
    assert abs(merged.t_final - halves.t_final) < 1e-13
    assert np.max(np.abs(merged.x_final - halves.x_final)) < 1e-13
    assert np.max(np.abs(merged.v_final - halves.v_final)) < 1e-13
    for name in ("kinetic", "potential", "coulomb"):
        a, b = getattr(merged.energy, name), getattr(halves.energy, name)
        assert np.max(np.abs(a - b)) < 1e-13, name
