"""Experiment tapered (granular_chain.classics.tapered).

Tolerances come from the methods: the event stepper's series tolerance (1e-10 of
the largest speed over a run), DOP853's own change between two tolerances, and
Verlet's error measured by halving dt (Richardson, order 2).
"""

import numpy as np
import pytest

from granular_chain.classics import SCENES
from granular_chain.classics import tapered as tp

EVENT_TOLERANCE = 1e-10


@pytest.fixture(scope="module")
def steepest():
    """The steepest taper, q = 0.1: event, Verlet at dt and dt/2, DOP853 at two
    tolerances."""
    runs = {s: tp.run_tapered(SCENES, 0.1, *spec[:1], spec[1] or tp.VERLET_DT)
            for s, spec in tp.STEPPERS.items()}
    t_end = 130.0
    ref = tp.reference_tapered(0.1, runs["event"]["times"], t_end)
    loose = tp.reference_tapered(0.1, runs["event"]["times"], t_end, 1e-13)
    return runs, ref, loose


def test_chain_arrays_are_the_scenes():
    """The reference's per-contact k and masses are the scene's recipes: k = 1 for
    the first two spheres of radius 1/2 (E = 3, nu = 0), masses as radius cubed."""
    c = tp.chain(0.1)
    assert abs(c["k"][0] - 2.0 * np.sqrt(0.5 * 0.45 / 0.95)) < 1e-15
    assert np.allclose(c["mass"], 0.729 ** np.arange(tp.COUNT), rtol=1e-13)


def test_event_stepper_matches_dop853(steepest):
    """Every granule's velocity at t_end within the event stepper's tolerance of the
    largest speed plus DOP853's own error (its change against rtol 1e-13)."""
    runs, ref, loose = steepest
    own = np.max(np.abs(ref["v_final"] - loose["v_final"]))
    fastest = np.max(np.abs(ref["v_final"]))
    assert own < 1e-8 * fastest
    diff = np.max(np.abs(np.subtract(runs["event"]["v_final"], ref["v_final"])))
    assert diff < EVENT_TOLERANCE * fastest + own
    assert runs["event"]["separated"]
    assert abs(runs["event"]["momentum"] - 1) < 1e-14
    assert abs(runs["event"]["energy"] - 1) < EVENT_TOLERANCE * (fastest / tp.V0) ** 2


def test_verlet_within_its_measured_error(steepest):
    """The last granule's final velocity from Verlet misses DOP853 by its own error,
    measured by halving dt (within 1.5 times the estimate, and of its size)."""
    runs, ref, _ = steepest
    estimate = 4.0 / 3.0 * abs(runs["verlet"]["v_last"] - runs["verlet_half"]["v_last"])
    error = abs(runs["verlet"]["v_last"] - ref["v_last"])
    assert 0.5 * estimate < error < 1.5 * estimate


@pytest.mark.slow
def test_tapered_experiment():
    """The whole experiment: the steeper the taper, the smaller the last contact's
    peak force, the last granule's energy and the mid-chain momentum relative to
    the striker's, and the larger the velocities (Sen et al.); every final velocity
    against DOP853 within the event stepper's tolerance plus DOP853's error."""
    out = tp.compute(SCENES)
    ev = [out.data[f"{q:g}"]["event"] for q in tp.TAPERS]
    for key in ("force_ratio", "energy_last", "energy_middle", "momentum_middle"):
        assert np.all(np.diff([e[key] for e in ev]) < 0), key
    for key in ("v_last", "v_middle"):
        assert np.all(np.diff([e[key] for e in ev]) > 0), key
    for q in tp.TAPERS:
        d = out.data[f"{q:g}"]
        assert d["state_diff"]["event"] < EVENT_TOLERANCE * d["reference"]["v_last"] \
            + d["reference"]["error"]
    assert abs(ev[0]["v_last"] - 0.98568) < 1e-5  # q = 0: the uniform chain
