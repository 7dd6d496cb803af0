"""Experiment ``dimers`` (granular_chain.classics.dimers): the struck dimer chain's
decay and transmission against the mass ratio, its resonances and anti-resonances.

Tolerances come from the methods: the event stepper's series tolerance (1e-10 of the
state over a run), DOP853's own change between rtol 1e-10 and 1e-11, Verlet's error
measured by halving dt (Richardson, order 2), the quartic peak reading's error of
order dt^5, the parabola's own error measured on the engine's decay.
"""

import numpy as np
import pytest

from granular_chain.classics import EXPERIMENTS, SCENES
from granular_chain.classics import dimers as dm
from granular_chain.classics.chain_ode import integrate_chain

#: What the event stepper promises over one of these runs (its series at rtol 1e-12).
EVENT_TOLERANCE = 1e-10


# ----------------------------------------------------------------------------
# the pieces, checked on their own (fast)
# ----------------------------------------------------------------------------
def test_quartic_peak_reading_of_a_smooth_pulse():
    """A sech^2 pulse of width 0.3 sampled every 0.01 with its peak between frames:
    height and time recovered to the quartic's error, of order |v^(5)| dt^5 / 80
    (at most 1e-8 here; 1.8e-9 found), where the parabola of three frames misses by 4.5e-7."""
    t = 0.01 * np.arange(400)
    for t0 in (1.2345678, 2.0, 2.0049):
        v = (1.0 / np.cosh((t - t0) / 0.3) ** 2)[:, None]
        tp, vp = dm.peak_heights(t, v, [0])
        assert abs(vp[0] - 1.0) < 1e-8 and abs(tp[0] - t0) < 1e-6


def test_peak_at_the_edge_is_not_read():
    """A largest frame within two frames of either end is no resolved peak: nan."""
    t = 0.01 * np.arange(50)
    tp, vp = dm.peak_heights(t, np.exp(-t)[:, None], [0])
    assert np.isnan(tp[0]) and np.isnan(vp[0])


def test_sampled_reference_keeps_its_integration():
    """integrate_chain with t_eval: the same final state as without (bit for bit), the
    samples at the times asked, the last one the final state (dense output)."""
    mass, x0, v0 = [1.0, 0.3, 1.0, 0.3], [0.0, 2.0, 4.0, 6.0], [1.0, 0.0, 0.0, 0.0]
    plain = integrate_chain(mass, x0, v0, [2.0] * 3, t_end=8.0, rtol=1e-10)
    times = 0.5 * np.arange(17)
    sampled = integrate_chain(mass, x0, v0, [2.0] * 3, t_end=8.0, rtol=1e-10, t_eval=times)
    assert np.array_equal(plain.v, sampled.v) and plain.v_samples is None
    assert np.array_equal(sampled.t_samples, times) and sampled.v_samples.shape == (17, 4)
    assert np.allclose(sampled.v_samples[-1], sampled.v, rtol=0, atol=1e-12)
    assert np.array_equal(sampled.v_samples[0], v0)


def test_extrema_of_a_scan():
    """Local minima are resonances, maxima anti-resonances, each with the bracket of its
    neighbours, the largest mass ratio first."""
    eps = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7]
    rate = [0.3, 0.1, 0.5, 0.2, 0.9, 0.4, 0.0]
    found = dm.extrema({"eps": eps, "rate": rate})
    assert found["resonances"] == [(0.3, 0.5), (0.1, 0.3)]
    assert found["anti_resonances"] == [(0.4, 0.6), (0.2, 0.4)]


def test_experiment_is_registered():
    """Listed after the experiments before it, with its scene."""
    names = list(EXPERIMENTS)
    assert names.index("dimers") > names.index("newtons_cradle") > names.index("solitary_wave")
    assert EXPERIMENTS["dimers"] is dm.EXPERIMENT
    assert (SCENES / dm.SCENE).is_file()


# ----------------------------------------------------------------------------
# the experiment (one run, read by every test below)
# ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def outcome():
    return dm.EXPERIMENT.run()


@pytest.mark.slow
def test_resonances_and_anti_resonance_in_order(outcome):
    """The first anti-resonance lies above the first resonance, which lies above the
    second; each inside the scan's bracket and an extremum of the engine's decay there:
    below (resonance) or above (anti-resonance) every scanned decay in its bracket, with
    the second difference over eps* +- h of the matching sign; the leading pulse's peaks
    were read."""
    located, scanned = outcome.data["located"], outcome.data["scan"]
    anti, first, second = (located[k]["eps"] for k in
                           ("anti-resonance 1", "resonance 1", "resonance 2"))
    assert 1.0 > anti > first > second > 0.0
    eps, rate = np.asarray(scanned["eps"]), np.asarray(scanned["rate"])
    for d in located.values():
        low, high = d["bracket"]
        assert low < d["eps"] < high
        sign = 1.0 if d["kind"] == "resonance" else -1.0
        inside = rate[(eps >= low) & (eps <= high)]
        assert inside.size == 3
        assert np.all(sign * (inside - d["engine"]["rate"]) > 0.0)
        assert sign * d["second_difference"] > 0.0
    assert scanned["ordered"]


@pytest.mark.slow
def test_pulse_barely_decays_at_the_resonances(outcome):
    """The physics claim: at a resonance the pulse travels on (decay below 1e-4 per
    cell, under 1 % of the decay at the anti-resonance, where it loses more than
    25 % of its peak velocity over the 12 cells)."""
    located = outcome.data["located"]
    worst = located["anti-resonance 1"]["engine"]["rate"]
    assert worst * (dm.LAST_CELL - dm.FIRST_CELL) > -np.log(0.75)
    for key in ("resonance 1", "resonance 2"):
        assert abs(located[key]["engine"]["rate"]) < min(1e-4, 0.01 * worst)


@pytest.mark.slow
def test_event_stepper_matches_dop853(outcome):
    """At each located extremum the event stepper's decay and transmission equal the
    DOP853 reference's within that reference's own error (twice it) plus the event
    stepper's tolerance."""
    for d in outcome.data["located"].values():
        own = d["reference_error"]
        for q in ("rate", "transmission"):
            assert abs(d["engine"][q] - d["reference"][q]) < 2 * own[q] + EVENT_TOLERANCE


@pytest.mark.slow
def test_located_mass_ratios_match_the_reference(outcome):
    """Resonances and the anti-resonance: the engine's parabola vertex equals the reference's within what the decay's
    differences (reference error plus event tolerance) move a vertex by, and Brent's
    optimum is the reference's vertex within the parabola's own error (measured on
    the engine: its vertex against Brent's optimum) plus Brent's xatol."""
    h = outcome.data["parabola_step"]
    for key in ("resonance 1", "resonance 2", "anti-resonance 1"):
        d = outcome.data["located"][key]
        own = d["reference_error"]["rate"]
        curvature = abs(d["second_difference"])
        moved = h * 2 * (2 * own + EVENT_TOLERANCE) / curvature
        assert abs(d["engine_vertex"] - d["reference_vertex"]) < moved
        assert abs(d["eps"] - d["reference_vertex"]) < (abs(d["eps"] - d["engine_vertex"])
                                                        + moved + dm.XATOL)


@pytest.mark.slow
def test_verlet_within_its_measured_error(outcome):
    """Verlet at dt = 0.01 misses the reference by its own error, measured by halving
    dt: within 1.5 times the Richardson estimate plus the reference's error."""
    located, verlet = outcome.data["located"], outcome.data["verlet"]
    for key, d in verlet.items():
        ref, own = located[key]["reference"], located[key]["reference_error"]
        for q in ("rate", "transmission"):
            assert abs(d["dt"][q] - ref[q]) < 1.5 * d["error"][q] + 2 * own[q]


@pytest.mark.slow
def test_momentum_and_energy_conserved(outcome):
    """Momentum to roundoff and energy to the stepper's ledger: the event stepper
    within its tolerance; Verlet's energy within its measured error (halving dt)."""
    for d in outcome.data["located"].values():
        assert abs(d["engine"]["momentum"] - 1.0) < 1e-12
        assert abs(d["engine"]["energy"] - 1.0) < EVENT_TOLERANCE
    for d in outcome.data["verlet"].values():
        assert abs(d["dt"]["momentum"] - 1.0) < 1e-12
        drift = abs(d["dt"]["energy"] - 1.0)
        assert drift < 1.5 * 4.0 / 3.0 * abs(d["dt"]["energy"] - d["half"]["energy"]) + 1e-12
