"""granular_chain.boundaries: outcome boundaries found from a parameter range alone.

References: the exact thresholds of ``granular_chain/paper/`` (mpmath, the values
``docs/paper_check.md`` cites: rows 10, 21, 23, 36) and, for the n = 5/2
never-separating friction, an independent scipy DOP853 integration of the
relative coordinate. For n = 2 the event stepper's modes are exact, so the engine's
boundary must match the exact value to the bracket width (1e-12 relative) plus a
few ulp of the engine's roundoff (docs/paper_check.md: <= 3.1e-15 relative in the
velocities; a velocity that vanishes linearly with slope ~1 moves the boundary by
the same amount).
"""

import json
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from granular_chain import paper as P
from granular_chain.two_granules import find_boundaries, separation_limit, trace_curves
from granular_chain.cli import main
from granular_chain.two_granules import collide

TOL = 1e-12
ROUNDOFF = 1e-14  # relative: the engine's velocities to <= 3.1e-15, with margin


def _one(bs, below, above):
    hits = [b for b in bs if (b.below, b.above) == (below, above)]
    assert len(hits) == 1, [(b.value, b.below, b.above) for b in bs]
    return hits[0]


def test_n2_eta2_threshold_0669_from_the_range_alone():
    """Row 10: both move iff eta2 < (1 + pi^2/8)^(-1/2); engine 0.66909459929421."""
    bs = find_boundaries("eta2", 0.0, 1.0)
    b = _one(bs, "backscatter_and_propagation", "backscatter_only")
    exact = float(P.iia_eta_max(exact=True))
    assert b.bracket[1] - b.bracket[0] <= TOL * b.value
    assert abs(b.value - exact) <= TOL * exact + ROUNDOFF
    assert b.method == "secant:v2" and b.collisions <= 20  # bisection needs ~33
    lo, hi = b.bracket
    assert collide(2, eta=(0, lo), stepper="event").outcome.name == b.below
    assert collide(2, eta=(0, hi), stepper="event").outcome.name == b.above
    # the only other change is the rest-tolerance edge next to 0 (v1 ~ -1.1 eta2
    # counts as rest below 1e-14 relative): no spurious boundaries
    assert len(bs) == 2 and bs[0].value < 1e-13
    assert bs.scan_collisions == 128 and bs.grid == 128


def test_n2_eta1_thresholds_0220_and_0444():
    """Rows 23 and 21: backscattering ends at 0.2195624104 (an outcome boundary);
    granule 1 stops sliding back at 0.4440212487, not the printed 0.439 (the
    outcome stays propagation_only: found with by='events')."""
    bs = find_boundaries("eta1", 0.0, 1.0, by="events")
    eb = float(P.iib_backscatter_threshold_eta_exact(dps=20))
    ec = float(P.iib_slip_critical_eta_exact(dps=20))
    b = _one([x for x in bs if x.value > 0.1], "backscatter_and_propagation", "propagation_only")
    assert abs(b.value - eb) <= TOL * eb + ROUNDOFF
    c = [x for x in bs if 0.3 < x.value < 0.6]
    assert len(c) == 1 and (c[0].below, c[0].above) == ("propagation_only",) * 2
    assert abs(c[0].value - ec) <= TOL * ec + ROUNDOFF
    assert "slip" in c[0].events_below and "slip" not in c[0].events_above
    assert abs(c[0].value - float(P.iib_slip_critical_eta_printed(dps=20))) > 5e-3
    # by outcome, the back-sliding onset is not a boundary
    plain = find_boundaries("eta1", 0.0, 1.0)
    assert not [x for x in plain if 0.3 < x.value < 0.6]
    assert abs(_one(plain, "backscatter_and_propagation", "propagation_only").value - eb) \
        <= TOL * eb + ROUNDOFF


def test_n2_equal_gamma_sqrt8():
    """Row 36: no separation iff gamma^2 >= 8. The engine's discrete boundary is set
    by t_max = 1000 and the underflow of exp(-gamma t/2) (a 'stuck' band where both
    speeds underflow to 0), 1e-6 .. 1e-5 relative below sqrt 8; extrapolating
    1/t_sep^2 -> 0 from the separated side recovers sqrt 8 to roundoff."""
    s8 = math.sqrt(8.0)
    bs = find_boundaries("gamma", 2.0, 4.0)
    assert [(b.below, b.above) for b in bs] == [
        ("backscatter_and_propagation", "stuck"), ("stuck", "no_separation")]
    for b in bs:
        assert 1e-7 < (s8 - b.value) / s8 < 1e-5
    value, err, n = separation_limit("gamma", bs[0].bracket[0], bs[-1].bracket[1])
    assert abs(value - s8) <= 4 * np.finfo(float).eps * s8 and err < 1e-13 and n == 6


def _separates(gamma, t_max=1000.0):
    """Independent reference: u'' = -2 u^(3/2) - gamma u', u(0) = 0, u'(0) = 1 (the
    overlap of the two granules, equal drag); does u return to 0 before t_max?"""
    def rhs(t, y):
        return [y[1], -2.0 * max(y[0], 0.0) ** 1.5 - gamma * y[1]]

    def opened(t, y):
        return y[0]
    opened.terminal, opened.direction = True, -1
    r = solve_ivp(rhs, (0.0, t_max), [0.0, 1.0], method="DOP853", rtol=1e-13, atol=1e-18,
                  events=opened)
    return r.status == 1


def test_n25_equal_gamma_never_separating_threshold():
    """n = 5/2, gamma1 = gamma2: the collision never ends above gamma_c = 1.48838926808;
    the separation speed v2 - v1 vanishes linearly there (the indicator)."""
    bs = find_boundaries("gamma", 1.0, 2.0, {"n": 2.5}, grid=16)
    b = _one(bs, "backscatter_and_propagation", "no_separation")
    assert b.method == "secant:v2-v1"
    assert b.error is not None and b.error < 1e-11  # the stepper's share (rtol/10 rerun)
    lo, hi = 1.488389268, 1.48838927  # reference bisection to 1e-11
    assert _separates(lo) and not _separates(hi)
    while hi - lo > 1e-11:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _separates(mid) else (lo, mid)
    assert lo - 1e-11 <= b.value <= hi + 1e-11
    for d, want in ((-1e-9, b.below), (1e-9, b.above)):
        g = b.value * (1 + d)
        assert collide(2.5, gamma=(g, g), stepper="event").outcome.name == want


def test_curve_in_eta_plane_points_separate_the_two_outcomes():
    """Every 4th point of each traced curve in (eta1, eta2), moved 1e-9 along its
    normal to either side, gives the two outcomes the curve claims."""
    curves = trace_curves(("eta1", "eta2"), ((0.0, 1.0), (0.0, 1.0)), seeds=2, step=0.02)
    pairs = {(c.below, c.above) for c in curves}
    assert ("backscatter_and_propagation", "backscatter_only") in pairs
    assert ("backscatter_and_propagation", "propagation_only") in pairs
    checked = 0
    for c in curves:
        assert c.points.shape == c.normals.shape and len(c.points) > 20
        assert np.allclose(np.hypot(*c.normals.T), 1.0)
        for p, nv in zip(c.points[::4], c.normals[::4]):
            for s, want in ((-1e-9, c.below), (1e-9, c.above)):
                q = p + s * nv
                assert collide(2, eta=tuple(q), stepper="event").outcome.name == want, (p, s)
            checked += 1
    assert checked >= 30
    both_back = next(c for c in curves if (c.below, c.above) ==
                     ("backscatter_and_propagation", "backscatter_only"))
    # it runs from the 0.669 threshold on the eta2 axis to a corner with 'stuck'
    end = both_back.points[np.argmin(both_back.points[:, 0])]
    assert abs(end[1] - float(P.iia_eta_max())) < 1e-3 and end[0] < 1e-3
    assert "corner" in both_back.ends and "edge" in both_back.ends


def test_cli_json_and_bad_input(capsys):
    assert main(["boundaries", "--param", "eta2", "--range", "0.5", "0.8", "--grid", "8",
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    [b] = out["boundaries"]
    for key in ("value", "bracket", "below", "above", "collisions", "seconds"):
        assert key in b
    assert abs(b["value"] - float(P.iia_eta_max())) < 1e-12
    for argv in (["--param", "mu", "--range", "0", "1"],
                 ["--param", "eta1", "--range", "1", "0"],
                 ["--param", "eta1", "--range", "0", "1", "--set", "n=abc"],
                 ["--param", "eta1", "--range", "0", "1", "--set", "zeta=1"],
                 ["scenarios/hertz_chain.yaml", "--param", "eta1", "--range", "0", "1"]):
        assert main(["boundaries"] + argv) == 2
        err = capsys.readouterr().err
        assert err.startswith("granular-chain:") and err.count("\n") == 1, err


def test_cli_takes_friction_from_a_two_granule_scene(capsys):
    """scenarios/two_granules.yaml has eta2 = 0.3: along eta1 backscattering ends
    where the exact solution says (here checked against a collide() bracket)."""
    assert main(["boundaries", "scenarios/two_granules.yaml", "--param", "eta1", "--range",
                 "0.2", "0.45", "--grid", "8", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["fixed"]["eta2"] == 0.3 and out["fixed"]["n"] == 2.0
    b = out["boundaries"][0]
    lo, hi = b["bracket"]
    assert collide(2, eta=(lo, 0.3), stepper="event").outcome.name == b["below"]
    assert collide(2, eta=(hi, 0.3), stepper="event").outcome.name == b["above"]


def test_trace_on_dask_gives_the_serial_curves():
    """The seed lines as dask tasks (LocalCluster, 2 processes): the same curves,
    bit for bit, in the same order."""
    kw = dict(plane=("eta1", "eta2"), box=((0.0, 1.0), (0.0, 1.0)), seeds=1, step=0.05)
    serial = trace_curves(**kw)
    dask = trace_curves(**kw, executor="dask", workers=2)
    assert len(serial) == len(dask) >= 2
    for a, b in zip(serial, dask):
        assert (a.below, a.above, a.ends) == (b.below, b.above, b.ends)
        assert a.points.tobytes() == b.points.tobytes()
