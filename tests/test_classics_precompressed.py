"""Experiment ``precompressed`` (granular_chain.classics.precompressed).

Tolerances come from the methods: the event stepper's (1e-10 over a run, its series
at rtol 1e-12), the anharmonic frequency shift measured at ten times the amplitude
(it grows as the amplitude squared: over 100 at the table's amplitude), Verlet's
error measured by halving dt (Richardson, order 2), the nonlinear correction to the
struck pulse measured at a second overlap (it grows as v_max / (c0 delta0)).
"""

import math

import numpy as np
import pytest
from scipy.linalg import expm

from granular_chain.classics import SCENES
from granular_chain.classics import precompressed as pc
from granular_chain.classics.hertz_wave import NESTERENKO_CONSTANT, solve_travelling_wave

#: What the event stepper promises over one of these runs (its series at rtol 1e-12).
EVENT_TOLERANCE = 1e-10


def _error(m):
    return m["omega"] / m["reference"] - 1.0


# ----------------------------------------------------------------------------
# the exact references
# ----------------------------------------------------------------------------
def test_linearised_lattice_formulas():
    """K = 1.5 delta0^(1/2); omega -> c0 q at small q; v_g = d omega / dq; omega(pi)
    = 2 c0."""
    assert pc.stiffness(0.01) == pytest.approx(0.15, rel=1e-15)
    assert pc.sound_speed(1e-4) == pytest.approx(math.sqrt(1.5) * 0.1, rel=1e-15)
    c0 = pc.sound_speed(0.01)
    assert float(pc.frequency(1e-4, 0.01)) / (c0 * 1e-4) == pytest.approx(1.0, abs=1e-9)
    assert float(pc.frequency(math.pi, 0.01)) == pytest.approx(2.0 * c0, rel=1e-15)
    q, h = 1.1, 1e-5
    slope = (pc.frequency(q + h, 0.01) - pc.frequency(q - h, 0.01)) / (2 * h)
    assert float(slope) == pytest.approx(float(pc.group_velocity(q, 0.01)), rel=1e-9)
    assert pc.velocity_scale(0.01) == pytest.approx(c0 * 0.01, rel=1e-15)


def test_long_wave_speed_has_both_limits():
    """Eq. (4): 1 as rho -> 0 (the sound speed, to first order in rho), Nesterenko's
    (16/25)^(1/5) v_max^(1/5) as delta0 -> 0 (rho -> inf), faster in between."""
    assert pc.long_wave_speed(1e-8) == pytest.approx(1.0, abs=1e-7)
    delta0 = 1e-12
    c0, v = pc.sound_speed(delta0), 1e-4
    speed = c0 * pc.long_wave_speed(v / pc.velocity_scale(delta0))
    assert speed / v ** 0.2 == pytest.approx(NESTERENKO_CONSTANT, rel=1e-3)
    values = [pc.long_wave_speed(r) for r in (0.01, 0.1, 1.0, 10.0)]
    assert all(b > a > 1.0 for a, b in zip(values, values[1:]))


def test_linear_pulse_solves_the_linearised_chain():
    """The normal-mode solution against the matrix exponential of the walled lattice
    u'' = -K L u (L the fixed-end Laplacian)."""
    count, delta0, v0, t = 12, 0.01, 1e-3, 7.5
    K = pc.stiffness(delta0)
    lap = 2 * np.eye(count) - np.eye(count, k=1) - np.eye(count, k=-1)
    system = np.block([[np.zeros((count, count)), np.eye(count)],
                       [-K * lap, np.zeros((count, count))]])
    state = expm(system * t) @ np.r_[np.zeros(count), v0, np.zeros(count - 1)]
    got = pc.linear_pulse(delta0, v0, count, np.array([0.0, t]))
    assert np.allclose(got[0], np.r_[v0, np.zeros(count - 1)], rtol=0, atol=1e-18)
    assert np.max(np.abs(got[1] - state[count:])) < 1e-14 * v0


# ----------------------------------------------------------------------------
# the engine
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("j", [1, 16])
def test_mode_frequency_event_within_the_anharmonic_shift(j):
    """A normal mode's frequency from the event stepper: off eq. (3) by the
    anharmonic shift (measured at ten times the amplitude, over 100) and the
    stepper's tolerance, no more."""
    m = pc.mode_frequency(SCENES, pc.MODE_DELTA0, j, pc.AMPLITUDE, "event")
    loud = pc.mode_frequency(SCENES, pc.MODE_DELTA0, j, 10 * pc.AMPLITUDE, "event")
    shift = abs(_error(loud)) / 100.0
    assert abs(_error(m)) < 1.5 * shift + EVENT_TOLERANCE
    assert m["energy_error"] < EVENT_TOLERANCE


def test_anharmonic_shift_falls_as_the_amplitude_squared():
    """The error is the amplitude's, not the engine's: mode 1's frequency shift at
    eps = 1e-2 is 100 times that at 1e-3 (to the event stepper's tolerance), and
    negative (the Hertz contact softens)."""
    big = _error(pc.mode_frequency(SCENES, pc.MODE_DELTA0, 1, 1e-2, "event"))
    small = _error(pc.mode_frequency(SCENES, pc.MODE_DELTA0, 1, 1e-3, "event"))
    assert big < 0 and small < 0
    assert abs(big / small - 100.0) < 100.0 * 1.5 * EVENT_TOLERANCE / abs(small)


def test_sound_speed_across_four_decades_of_precompression():
    """omega_1 / (2 sin(q_1/2)) against c0 = sqrt(1.5) delta0^(1/4) at delta0 = 1e-4
    and 1e-1: within the anharmonic shift (the same at every delta0 for the same
    eps, measured once at ten times the amplitude) and the stepper's tolerance."""
    loud = pc.mode_frequency(SCENES, 1e-4, 1, 10 * pc.AMPLITUDE, "event")
    shift = abs(_error(loud)) / 100.0
    for delta0 in (1e-4, 1e-1):
        m = pc.mode_frequency(SCENES, delta0, 1, pc.AMPLITUDE, "event")
        c = m["omega"] / (2.0 * math.sin(m["q"] / 2.0))
        assert abs(c / pc.sound_speed(delta0) - 1.0) < 1.5 * shift + EVENT_TOLERANCE


def test_mode_frequency_verlet_within_its_measured_error():
    """Verlet's frequency misses eq. (3) by its own error, measured by halving dt:
    within 1.5 times the Richardson estimate and not far below it."""
    args = (SCENES, pc.MODE_DELTA0, 8, pc.AMPLITUDE, "verlet")
    coarse, fine = pc.mode_frequency(*args), pc.mode_frequency(*args,
                                                                 fraction=pc.VERLET_FRACTION / 2)
    estimate = 4.0 / 3.0 * abs(coarse["omega"] - fine["omega"]) / coarse["reference"]
    assert 0.5 * estimate < abs(_error(coarse)) < 1.5 * estimate


@pytest.mark.slow
def test_crossover_from_sound_to_the_solitary_wave():
    """The struck chain: at strong precompression the pulse is the linearised
    lattice's, its difference from it growing as rho = v_max / (c0 delta0) (measured
    at two overlaps); Verlet's speed within its measured error of the event
    stepper's; at delta0 = 0 the exact discrete wave's speed (to the pulse's
    relaxation left by granule 20); between, faster than c0, and the long-wave
    solitary wave within its discreteness error at delta0 = 0 (0.8 %)."""
    strong, weaker = (pc.struck_pulse(SCENES, d, "event") for d in (1e-1, 3e-2))
    d1, d2 = (p["speed"] / p["linear"] - 1.0 for p in (strong, weaker))
    assert d1 < 0 and d2 < 0
    assert d1 / d2 == pytest.approx(strong["rho"] / weaker["rho"], rel=0.1)
    verlet = pc.struck_pulse(SCENES, 1e-1, "verlet")
    half = pc.struck_pulse(SCENES, 1e-1, "verlet", half=True)
    estimate = 4.0 / 3.0 * abs(verlet["speed"] - half["speed"])
    assert abs(verlet["speed"] - strong["speed"]) < 1.5 * estimate + EVENT_TOLERANCE
    constant = solve_travelling_wave().speed_constant
    bare = pc.struck_pulse(SCENES, 0.0, "event")
    assert bare["speed"] / (constant * bare["v_max"] ** 0.2) == pytest.approx(1.0, abs=1e-7)
    gap = 1.0 - constant / NESTERENKO_CONSTANT
    for delta0 in (1e-4, 1e-5):
        p = pc.struck_pulse(SCENES, delta0, "event")
        assert p["rho"] > 1.0 and p["speed"] > p["c0"]
        assert abs(p["speed"] / (p["c0"] * pc.long_wave_speed(p["rho"])) - 1.0) < gap


def test_group_velocity_of_a_packet_event():
    """A packet at q = pi/2: its centroid's speed from the event stepper against the
    linearised lattice's packet from the same start, within the anharmonic change
    (measured at ten times the amplitude, over 100) and the stepper's tolerance; and
    the linearised packet a little slower than v_g(q) (its spread in q)."""
    q = math.pi / 2
    p = pc.packet_speed(SCENES, q, pc.AMPLITUDE, "event")
    loud = pc.packet_speed(SCENES, q, 10 * pc.AMPLITUDE, "event")
    shift = abs(loud["speed"] / loud["linear"] - 1.0) / 100.0
    assert abs(p["speed"] / p["linear"] - 1.0) < 1.5 * shift + EVENT_TOLERANCE
    assert -1e-3 < p["linear"] / p["group_velocity"] - 1.0 < 0
