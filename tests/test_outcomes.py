"""The outcome names and the rule naming them are defined once and used everywhere.

The compiled classifier of the engine's runs (two_granules.outcomes.outcome_code),
the exact reference's classifier (paper.reference) and boundaries' indicators
all read SEPARATION_SIGNS; here each is checked against the rule written out.
"""

import itertools

import pytest

from granular_chain import paper
from granular_chain.codes import Status
from granular_chain.two_granules import OUTCOMES, SEPARATION_SIGNS, Outcome
from granular_chain.two_granules.outcomes import outcome_code, outcome_of_signs


def _by_rule(status, v1, v2):
    """The outcome as the paper defines it, written out independently."""
    if status == Status.SEPARATED:
        if v1 < 0 < v2:
            return Outcome.backscatter_and_propagation
        if v1 == 0 < v2:
            return Outcome.propagation_only
        if v1 < 0 == v2:
            return Outcome.backscatter_only
        if v1 > 0 and v2 > 0:
            return Outcome.both_forward
        return Outcome.stuck
    if status == Status.AT_REST and v1 == 0 and v2 == 0:
        return Outcome.stuck
    if status in (Status.T_END, Status.AT_REST):
        return Outcome.no_separation
    return None


@pytest.mark.parametrize("status", list(Status))
def test_compiled_classifier_follows_the_rule(status):
    speeds = (-0.3, -1e-16, 0.0, 1e-16, 0.7)
    for v1, v2 in itertools.product(speeds, speeds):
        code = outcome_code(int(status), v1, v2, 1e-14)
        # speeds below 1e-14 of the faster granule count as rest
        r1, r2 = (0.0 if abs(v) <= 1e-14 * max(abs(v1), abs(v2)) else v for v in (v1, v2))
        want = _by_rule(status, r1, r2)
        assert (OUTCOMES[code] if code >= 0 else None) is want, (status, v1, v2)


def test_sign_rule_names_every_separated_outcome_once():
    assert set(SEPARATION_SIGNS) == set(Outcome) - {Outcome.no_separation}
    assert len(set(SEPARATION_SIGNS.values())) == len(SEPARATION_SIGNS)
    for outcome, (s1, s2) in SEPARATION_SIGNS.items():
        assert outcome_of_signs(s1, s2) is outcome
        assert _by_rule(Status.SEPARATED, s1, s2) is outcome


def test_reference_names_outcomes_with_the_same_enum():
    assert paper.OUTCOMES == tuple(o.name for o in Outcome)
    r = paper.reference_collision_n2(0.1, 0.0, dps=20)
    assert r["outcome"] == Outcome.backscatter_and_propagation.name
