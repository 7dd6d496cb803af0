"""Classic experiment ``backscatter_friction``: the paper's two granules against a
chain's first granule, with Coulomb friction.

Tolerances come from the methods: the event stepper's series tolerance (1e-10
over a run, as in tests/test_classics.py), DOP853's own change between rtol 3e-14
and 1e-13, the bisection's width; Verlet's convergence to DOP853.
"""

import math

import numpy as np
import pytest

from granular_chain.classics import SCENES
from granular_chain.classics import backscatter_friction as bf
from granular_chain.paper.coulomb_on_granule1 import (iib_backscatter_threshold_eta_exact,
                                                      iib_collision_exact)

#: What the event stepper promises over one of these runs (its series at rtol 1e-12).
EVENT_TOLERANCE = 1e-10


def _reference(case, n, count, eta):
    """DOP853's velocity and its own error (change from rtol 3e-14 to 1e-13)."""
    ref = bf.reference_backscatter(case, n, count, eta)
    return ref, abs(ref - bf.reference_backscatter(case, n, count, eta, 1e-13))


# ----------------------------------------------------------------------------
# the reference with friction, against the paper's closed forms
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("eta", [0.05, 0.3, 0.6])
def test_reference_gives_sec_iia_closed_form(eta):
    """Friction on the struck granule, n = 2: v1 = -eta pi / (2 sqrt 2) at separation
    (paper Sec. II A), within ten times DOP853's own error."""
    ref, error = _reference("struck", 2.0, 2, eta)
    assert abs(ref + eta * math.pi / (2 * math.sqrt(2))) <= 10 * max(error, bf.REFERENCE_RTOL)


@pytest.mark.parametrize("eta", [0.05, 0.15, 0.25])
def test_reference_gives_sec_iib_closed_form(eta):
    """Friction on the striker, n = 2: the paper's Sec. II B solution, with the striker
    held (v1 = 0 exactly) beyond eta = 0.2196."""
    ref, error = _reference("striker", 2.0, 2, eta)
    exact = float(iib_collision_exact(eta)["v1s"])
    assert abs(ref - exact) <= 10 * max(error, bf.REFERENCE_RTOL)
    assert (ref == 0.0) == (eta > 0.2196)


def test_edge_bisection_brackets_the_exact_edge():
    """Bisection on DOP853's velocity finds Sec. II B's exact edge 0.2195624104 to its
    bracket's width."""
    edge = bf.backscatter_edge(lambda e: bf.reference_backscatter("striker", 2.0, 2, e, 1e-12),
                               tol=1e-8)
    assert abs(edge - float(iib_backscatter_threshold_eta_exact())) < 1e-8


# ----------------------------------------------------------------------------
# the engine against the references
# ----------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("case", list(bf.CASES))
@pytest.mark.parametrize("n", bf.EXPONENTS)
def test_event_stepper_matches_dop853_in_a_chain(case, n):
    """The striker's velocity at separation, event stepper against DOP853, N = 2 and 20,
    every eta of the case: within the event stepper's 1e-10 plus DOP853's own error
    (its change from rtol 1e-13 to 3e-14, at most 3.4e-11 here)."""
    for count in (2, 20):
        for eta in bf.ETAS[case]:
            ref, error = _reference(case, n, count, eta)
            assert error < EVENT_TOLERANCE
            got = bf.engine_backscatter(SCENES, case, n, count, eta)["v"]
            assert abs(got - ref) < EVENT_TOLERANCE + error, (count, eta)


@pytest.mark.slow
def test_event_stepper_edge_matches_the_paper_and_moves_in_a_chain():
    """Where backscattering ends under striker friction: two granules at n = 2 on the
    paper's exact edge (to the bisection's width plus the velocity error over its slope),
    and a chain of 20 still throwing its striker back beyond it (the paper's outlook)."""
    def velocity(count):
        return lambda e: bf.engine_backscatter(SCENES, "striker", 2.0, count, e)["v"]

    exact = float(iib_backscatter_threshold_eta_exact())
    assert abs(bf.backscatter_edge(velocity(2)) - exact) < 1e-9
    chain_edge = bf.backscatter_edge(velocity(20), tol=1e-6)
    assert chain_edge > exact + 1e-3
    between = 0.5 * (exact + chain_edge)
    assert velocity(20)(between) < 0.0 and velocity(2)(between) == 0.0


@pytest.mark.slow
@pytest.mark.parametrize("case", list(bf.CASES))
def test_verlet_converges_to_dop853(case):
    """Verlet (N = 20, n = 2, eta = 0.1): stick, slip and the separation fall within a
    step, so its error is not smooth in dt; measured against DOP853 (exact to 1e-10),
    it shrinks from dt = 0.02 to 0.01 by more than the first order's factor 2 and stays
    below the change between the two steps."""
    ref, _ = _reference(case, 2.0, 20, 0.1)
    coarse, fine = (bf.engine_backscatter(SCENES, case, 2.0, 20, 0.1, "verlet", dt)["v"]
                    for dt in (2 * bf.VERLET_DT, bf.VERLET_DT))
    assert abs(fine - ref) < 0.5 * abs(coarse - ref)
    assert abs(fine - ref) < abs(coarse - fine)


def test_a_chain_throws_back_its_frictionless_striker():
    """No friction: two granules exchange velocities (no backscatter), a chain of 20
    Hertz granules sends its striker back at 0.0711 v0 (the solitary wave's rebound)."""
    two, _ = _reference("struck", 2.5, 2, 0.0)
    chain, _ = _reference("struck", 2.5, 20, 0.0)
    assert abs(two) < 1e-12
    assert abs(chain + 0.0710850171) < 1e-9


def test_frictions_place_the_friction():
    assert bf.frictions("struck", 3, 0.2) == [0.0, 0.2, 0.2]
    assert bf.frictions("striker", 3, 0.2) == [0.2, 0.0, 0.0]
    with pytest.raises(RuntimeError, match="bracket"):
        bf.backscatter_edge(lambda e: -1.0, 0.1, 0.4)
    assert np.isclose(bf.backscatter_edge(lambda e: min(e - 0.25, 0.0), 0.1, 0.4), 0.25)
