"""Experiment heavy_striker (granular_chain.classics.heavy_striker).

Tolerances come from the methods: the event stepper's series tolerance (1e-10 over
a run), a peak read through three frames (its parabola's correction bounds its
error), Verlet's error measured by halving dt (Richardson, order 2), DOP853's own
change between two tolerances, and a wave's amplitude drift over the fitted
granules (a wave still relaxing has the speed of its mean amplitude).
"""

import numpy as np
import pytest

from granular_chain.classics import SCENES
from granular_chain.classics import heavy_striker as hs
from granular_chain.classics.hertz_wave import solve_travelling_wave

EVENT_TOLERANCE = 1e-10
#: The speed constant read from peak times three frames apart (0.01) resolves
#: ~1e-8: the stationary single wave of M = m reads -7e-9 from the exact one.
SPEED_RESOLUTION = 1e-8


@pytest.mark.parametrize("ratio", [2.0, 10.0])
def test_event_stepper_matches_dop853_on_the_short_chain(ratio):
    """Every granule's velocity at t = 32 within 1e-10 of DOP853 (whose own error is
    below 1e-11), and the leading wave's peak at granule 20 within the peak
    reading's own error (its parabola's correction)."""
    got = hs.short_chain(SCENES, ratio, "event")
    ref = hs.reference_train(ratio, got["peak_time"])
    loose = hs.reference_train(ratio, got["peak_time"], 1e-13)
    assert np.max(np.abs(ref["v_final"] - loose["v_final"])) < 0.1 * EVENT_TOLERANCE
    assert np.max(np.abs(got["v_final"] - ref["v_final"])) < EVENT_TOLERANCE
    # the peak read from frames: the parabola moves it by ~h^2 v''; its error is far less
    assert abs(got["amplitude"] - ref["amplitude"]) < 1e-8


def test_verlet_within_its_measured_error():
    """M/m = 5: Verlet's leading peak at granule 20 and striker velocity miss DOP853
    by their own error, measured by halving dt (within 1.5 times the Richardson
    estimate, and of its size)."""
    coarse = hs.short_chain(SCENES, 5.0, "verlet")
    fine = hs.short_chain(SCENES, 5.0, "verlet", hs.VERLET_DT / 2)
    ref = hs.reference_train(5.0, hs.short_chain(SCENES, 5.0, "event")["peak_time"])
    for key, r in (("amplitude", ref["amplitude"]), ("striker", ref["v_final"][0])):
        c = coarse[key] if key == "amplitude" else coarse["v_final"][0]
        f = fine[key] if key == "amplitude" else fine["v_final"][0]
        estimate = 4.0 / 3.0 * abs(c - f)
        assert 0.5 * estimate < abs(c - r) < 1.5 * estimate, key


def test_each_wave_of_the_train_is_the_exact_solitary_wave():
    """M/m = 5 (event stepper): three separated waves of decreasing amplitude, each
    with speed W_max^(-1/5) v_max^(1/5) within its drift and the reading's
    resolution; momentum and energy kept."""
    constant = solve_travelling_wave().speed_constant
    d = hs.run_train(SCENES, 5.0, "event")
    assert len(d["amplitude"]) == 3 and np.all(np.diff(d["amplitude"]) < 0)
    assert max(d["valley"]) < 1e-6  # the chain at rest between two waves
    for a, c, drift in zip(d["amplitude"], d["speed"], d["drift"]):
        assert abs(c / a ** 0.2 / constant - 1) < 0.2 * abs(drift) + SPEED_RESOLUTION
    assert abs(d["momentum"] - 1) < 1e-13
    assert abs(d["energy"] - 1) < EVENT_TOLERANCE
    assert 0.0 < d["striker"] < 0.01  # still pushing, ever more slowly


@pytest.mark.slow
def test_heavy_striker_experiment():
    """The whole experiment: one wave at M = m (the striker rebounds at -0.0711 v0),
    more waves and a slower decay along the train the heavier the striker; every
    event-stepper row against DOP853 within 1e-8, every speed constant within its
    drift, Verlet's rows within 1.5 times its measured error."""
    out = hs.compute(SCENES)
    d = out.data
    assert d["1"]["event"]["waves"] == 1 and abs(d["1"]["event"]["striker"] + 0.0711) < 1e-4
    waves = [d[f"{r:g}"]["event"]["waves"] for r in hs.RATIOS]
    assert waves == sorted(waves) and waves[-1] >= 5
    ratios = [d[f"{r:g}"]["event"]["amplitude"][1] / d[f"{r:g}"]["event"]["amplitude"][0]
              for r in hs.RATIOS[1:]]
    assert np.all(np.diff(ratios) > 0)
    for r in hs.RATIOS:
        m = d[f"{r:g}"]
        assert m["reference"]["error"] < 1e-9
        assert m["short"]["event"]["state_diff"] < EVENT_TOLERANCE
        err = m["verlet_error"]["amplitude"]
        for k, (a, b) in enumerate(zip(m["verlet"]["amplitude"], m["event"]["amplitude"])):
            assert abs(a - b) < 1.5 * err[k] + 1e-8
    for row in out.rows:
        if "c/v_max^(1/5)" in row.quantity:
            assert abs(row.rel_diff) < 1e-6, row
        if row.quantity.endswith("event") and "chain of" in row.quantity:
            assert abs(row.engine - row.reference) < 1e-8, row
