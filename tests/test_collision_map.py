"""collision_map: point by point bitwise the numbers of collide(..., stepper="event").

Also collide()'s batched fast path (a cached, packed scene per friction
feature set) against the ordinary scene -> simulate() path: the whole Result.
"""

import math

import numpy as np
import pytest

from granular_chain import scene_from_dict
from granular_chain.result import Status
from granular_chain.simulate import simulate
from granular_chain.two_granules import (OUTCOMES, CollisionMap, Outcome, classify, collide,
                                         collision_map, two_granule_scene)


def _same(a, b) -> bool:
    """Bitwise equality of two floats (NaN and signed zero included)."""
    return np.float64(a).tobytes() == np.float64(b).tobytes()


def _check_point(m: CollisionMap, idx, n, eta, gamma, eta_static=None, **kw):
    try:
        c = collide(n, eta=eta, gamma=gamma, stepper="event", eta_static=eta_static, **kw)
    except RuntimeError:
        assert m.status[idx] < 0 and m.outcome[idx] == -1, (idx, eta, gamma)
        assert math.isnan(m.v1[idx]) and math.isnan(m.t_separation[idx])
        return None
    got = (m.v1[idx], m.v2[idx], m.energy_ratio[idx], m.t_separation[idx])
    want = (c.v1, c.v2, c.energy_ratio, c.t_separation)
    assert all(_same(a, b) for a, b in zip(got, want)), (idx, eta, gamma, got, want)
    assert OUTCOMES[m.outcome[idx]] is c.outcome, (idx, eta, gamma)
    assert Status(int(m.status[idx])) is c.result.status
    stops = [e.t for e in c.result.events if e.kind == "stop" and e.index == 0]
    assert _same(m.t_stop1[idx], stops[0] if stops else math.nan)
    return c.outcome


# A grid reaching every Coulomb outcome at n = 2: frictionless and one-sided
# rows, the backscattering band (eta1 < 0.2196, eta2 = 0), propagation only,
# backscatter only (eta2 large), stuck (both large), and the band of small
# eta2 < eta1 where slips at eta_s = eta once chattered (Zeno).
ETA1 = np.array([0.0, 0.02, 0.05, 0.094, 0.15, 0.3, 0.45, 0.7, 1.0])
ETA2 = np.array([0.0, 0.003, 0.01, 0.1, 0.3, 0.6, 0.9, 1.2])


@pytest.mark.parametrize("workers", [1, 2])
def test_coulomb_grid_n2_bitwise(workers):
    E1, E2 = np.meshgrid(ETA1, ETA2)
    m = collision_map(E1, E2, workers=workers)
    assert m.v1.shape == E1.shape and m.workers == workers
    seen = set()
    for idx in np.ndindex(E1.shape):
        seen.add(_check_point(m, idx, 2.0, (E1[idx], E2[idx]), (0.0, 0.0)))
    assert {Outcome.backscatter_and_propagation, Outcome.propagation_only,
            Outcome.backscatter_only, Outcome.stuck} <= seen
    assert (m.status < 0).any() == (None in seen)


def test_workers_split_identical():
    """Two processes over row blocks give the bytes one process gives."""
    e = np.linspace(0.0, 1.0, 70)
    E1, E2 = np.meshgrid(e, e)
    one = collision_map(E1, E2, workers=1)
    two = collision_map(E1, E2, workers=2)
    for f in ("v1", "v2", "energy_ratio", "t_separation", "outcome", "status", "t_stop1"):
        assert getattr(one, f).tobytes() == getattr(two, f).tobytes(), f
    assert two.workers == 2


def test_hertz_grid_bitwise():
    e1 = np.array([0.0, 0.05, 0.2, 0.5])
    e2 = np.array([0.0, 0.1, 0.4, 0.9])
    m = collision_map(e1[None, :], e2[:, None], n=2.5)
    assert m.v1.shape == (4, 4)
    for idx in np.ndindex(m.v1.shape):
        _check_point(m, idx, 2.5, (e1[idx[1]], e2[idx[0]]), (0.0, 0.0))


def test_hertz_tight_tolerance_bitwise():
    eta1 = np.array([0.0, 0.1, 0.3])
    m = collision_map(eta1, 0.2, n=2.5, rtol=1e-10, atol=1e-12)
    for i, e in enumerate(eta1):
        _check_point(m, (i,), 2.5, (e, 0.2), (0.0, 0.0), rtol=1e-10, atol=1e-12)


def test_drag_on_one_granule_bitwise():
    """Drag on one granule only (gamma = (0, g) and (g, 0)). Equal masses never end
    both_forward: on 31 x 31 (gamma1, gamma2) in [0, 3]^2 and 41 x 41 (eta1, eta2)
    in [0, 1]^2, n = 2 and 5/2, no point does, so that outcome is not reachable here."""
    g = np.array([0.5, 1.5, 3.0])
    m = collision_map(0.0, 0.0, gamma=(0.0, g))
    for i, x in enumerate(g):
        _check_point(m, (i,), 2.0, (0.0, 0.0), (0.0, x))
    m = collision_map(0.0, 0.0, gamma=[g, 0.0])
    for i, x in enumerate(g):
        _check_point(m, (i,), 2.0, (0.0, 0.0), (x, 0.0))
    assert not (m.outcome == OUTCOMES.index(Outcome.both_forward)).any()


def test_viscous_and_mixed_bitwise():
    """Viscous friction (gamma^2 >= 8: no separation), with and without Coulomb
    friction, gamma broadcast as arrays: every feature set in one call."""
    g = np.array([0.0, 0.5, 1.0, 2.0, 2.8, 2.83, 3.5])
    eta1 = np.array([0.0, 0.1])
    m = collision_map(eta1[:, None], 0.05 * (eta1[:, None] > 0), gamma=(g[None, :], 0.9 * g))
    seen = set()
    for idx in np.ndindex(m.v1.shape):
        e1 = eta1[idx[0]]
        seen.add(_check_point(m, idx, 2.0, (e1, 0.05 * (e1 > 0)), (g[idx[1]], 0.9 * g[idx[1]])))
    m = collision_map(0.0, 0.0, gamma=(g, g))
    for i in range(g.size):
        seen.add(_check_point(m, (i,), 2.0, (0.0, 0.0), (g[i], g[i])))
    assert Outcome.no_separation in seen
    assert m.t_separation[-1] == math.inf and OUTCOMES[m.outcome[-1]] is Outcome.no_separation


def test_eta_static_bitwise():
    m = collision_map([0.1, 0.2], 0.3, eta_static=([0.2, 0.5], 0.3))
    _check_point(m, (0,), 2.0, (0.1, 0.3), (0.0, 0.0), eta_static=(0.2, 0.3))
    _check_point(m, (1,), 2.0, (0.2, 0.3), (0.0, 0.0), eta_static=(0.5, 0.3))


def test_failed_points_reported_in_status():
    """A failed run (here drag 1e300 on granule 2: the series diverges) is a failed
    status with outcome -1, never a silent NaN; its neighbour in the map is unaffected."""
    m = collision_map([0.0, 0.0], [0.0, 0.3], gamma=([0.0, 0.0], [1e300, 0.0]))
    assert m.status[0] == int(Status.NONFINITE) and m.outcome[0] == -1 and m.failed[0]
    assert math.isnan(m.v1[0]) and math.isnan(m.energy_ratio[0])
    assert m.status[1] == int(Status.SEPARATED) and not m.failed[1]
    assert m.outcomes()[0] is None and m.outcomes()[1] is Outcome.backscatter_and_propagation
    # the failed run's end state is the ordinary path's
    r = simulate(scene_from_dict(two_granule_scene(2.0, (0.0, 0.0), (0.0, 1e300),
                                                   stepper="event", t_max=1000.0)),
                 progress=False)
    assert r.status == Status.NONFINITE


def test_no_zeno_where_a_granule_slips_at_eta_s_equal_eta():
    """Regression: granule 2 slipping at k delta = eta_s = eta starts with zero
    acceleration; the roundoff of the force balance at the located slip was taken
    as a slope, a stop was found ulps later, and slip and stop repeated at one
    instant until the run ended as Zeno (3.3 % of the points of [0, 1]^2, e.g.
    (0.04, 0.495) and (0.015, 0.005)). Now every point of a 41 x 41 map succeeds
    and those points agree with the exact piecewise-linear solution."""
    from granular_chain.paper import reference_collision_n2
    e = np.linspace(0.0, 1.0, 41)
    E1, E2 = np.meshgrid(e, e)
    m = collision_map(E1, E2, workers=1)
    assert not m.failed.any(), int(m.failed.sum())
    for eta in [(0.04, 0.495), (0.015, 0.005), (0.05, 0.01), (0.3, 0.1), (0.7, 0.2)]:
        c = collide(2.0, eta, stepper="event")
        r = reference_collision_n2(*eta)
        assert c.outcome.name == r["outcome"], eta
        err = max(abs(c.v1 - float(r["v1"])), abs(c.v2 - float(r["v2"])))
        assert err <= 1e-15, (eta, err)
        assert abs(c.t_separation - float(r["t_separation"])) <= 1e-14 * float(r["t_separation"])


@pytest.mark.parametrize("gamma1", [1e2, 1e4, 1e6, 1e9])
def test_heavily_overdamped_slow_mode_exact(gamma1):
    """Drag gamma1 on granule 1, granule 2 held by static friction: the overlap obeys
    delta'' + gamma1 delta' + delta = 0 (delta(0) = 0, delta'(0) = 1) and never
    reopens. At t_max = 1000 the velocity is (r1 e^(r1 t) - r2 e^(r2 t)) / (r1 - r2),
    dominated by the slow rate r1 ~ -1/gamma1. The cosh/sinh form lost
    log10(gamma1^2) digits of it (1e-4 relative at 1e6), and the run sampled at the
    fast rate took ~1e10 steps at gamma1 = 1e6 (an apparent hang)."""
    import mpmath as mp
    with mp.workdps(40):
        c = mp.mpf(gamma1)
        kap = mp.sqrt(c * c / 4 - 1)
        r1, r2 = -c / 2 + kap, -c / 2 - kap
        want = float((r1 * mp.e ** (r1 * 1000) - r2 * mp.e ** (r2 * 1000)) / (r1 - r2))
    m = collision_map([0.0], [10.0], gamma=(gamma1, 0.0))
    assert OUTCOMES[m.outcome[0]] is Outcome.no_separation
    assert abs(m.v1[0] - want) <= 1e-13 * abs(want), (m.v1[0], want)


@pytest.mark.parametrize("eta", [(0.0, 0.3), (0.1, 0.0), (0.3, 0.6), (0.05, 0.01), (0.5, 0.5)])
@pytest.mark.parametrize("gamma", [(0.0, 0.0), (1.0, 0.5)])
@pytest.mark.parametrize("n", [2.0, 2.5])
def test_collide_fast_path_whole_result(n, eta, gamma):
    """collide()'s cached batch gives the Result the scene -> simulate path gives."""
    scene = scene_from_dict(two_granule_scene(n, eta, gamma, stepper="event"))
    slow = simulate(scene, progress=False)
    rest = 1e-14 if n == 2.0 else 100 * scene.run.rtol
    try:
        fast = collide(n, eta, gamma, stepper="event").result
    except RuntimeError as exc:
        assert not slow.success and slow.message in str(exc)
        return
    assert classify(slow, rest).outcome is classify(fast, rest).outcome
    for f in ("t", "x", "v", "f", "x_final", "v_final"):
        assert getattr(fast, f).tobytes() == getattr(slow, f).tobytes(), f
    for f in ("kinetic", "potential", "coulomb", "viscous"):
        assert getattr(fast.energy, f).tobytes() == getattr(slow.energy, f).tobytes(), f
    assert _same(fast.energy.initial, slow.energy.initial) and _same(fast.t_final, slow.t_final)
    assert (fast.status, fast.message, fast.steps, fast.events, fast.event_counts, fast.info) == (
        slow.status, slow.message, slow.steps, slow.events, slow.event_counts, slow.info)


@pytest.mark.parametrize("kwargs, match", [
    (dict(eta1=np.zeros(3), eta2=np.zeros(4)), "broadcast"),
    (dict(eta1=[0.1, -0.2], eta2=0.0), "eta1 must be finite and >= 0"),
    (dict(eta1=0.1, eta2=[0.0, math.nan]), "eta2 must be finite"),
    (dict(eta1=0.1, eta2=0.0, gamma=(-1.0, 0.0)), r"gamma\[0\]"),
    (dict(eta1=0.1, eta2=0.0, gamma=0.5), "gamma must be a pair"),
    (dict(eta1=0.1, eta2=0.0, gamma=np.zeros(2)), "gamma must be a pair"),
    (dict(eta1=0.3, eta2=0.0, eta_static=(0.2, 0.0)), "below the kinetic friction"),
    (dict(eta1=0.1, eta2=0.0, t_max=-1.0), "t_end"),
])
def test_bad_input_raises_valueerror(kwargs, match):
    with pytest.raises(ValueError, match=match):
        collision_map(**kwargs)


def test_collide_bad_friction_still_scene_error():
    """The fast path leaves invalid friction to the scene's own validation."""
    with pytest.raises(ValueError, match="granules.friction.kinetic"):
        collide(2.0, eta=(-0.1, 0.0), stepper="event")
    with pytest.raises(ValueError, match="granules.friction.static"):
        collide(2.0, eta=(0.3, 0.0), eta_static=(0.1, 0.0), stepper="event")


def test_event_batch_resumes_full_buffers():
    """A run that fills the event buffer is resumed with grown buffers inside
    EventBatch.run: same end state and same full Result as simulate()."""
    from granular_chain.model import build_model
    from granular_chain.steppers.events import EventBatch

    def scene(g):
        return scene_from_dict({
            "granules": {"count": 3, "radius": 2.0, "gap": 0.5, "velocity": [1.0, 0.0, -0.5],
                         "friction": {"viscous": [g, g, g]}},
            "walls": {"left": {"gap": 0.5}, "right": {"gap": 0.5}},
            "run": {"stepper": "event", "t_end": 120.0},
            "output": {"trajectory": False}})

    gs = [0.01, 0.02, 0.005]
    batch = EventBatch(scene(gs[0]), build_model(scene(gs[0])))
    gam = np.array([[g] * 3 for g in gs])
    out = batch.run(np.zeros((3, 3)), np.zeros((3, 3)), gam)
    for p, g in enumerate(gs):
        r = simulate(scene(g), progress=False)
        assert len(r.events) > 72  # more than the packed event buffer holds
        assert out.code[p] == 0 and r.status == Status.T_END
        assert out.v_final[p].tobytes() == r.v_final.tobytes()
        assert _same(out.t_final[p], r.t_final) and _same(out.initial[p], r.energy.initial)
        assert _same(out.kinetic[p], r.energy.kinetic[-1])
    full = batch.result(out)
    assert full.v.tobytes() == r.v.tobytes() and full.events == r.events
    assert full.message == r.message and full.info == r.info
