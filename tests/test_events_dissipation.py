"""The event stepper with contact dashpots, body forces and driven walls.

References: the closed forms and the mpmath integration of
:mod:`granular_chain.restitution` (two-grain restitution, the viscoelastic
series, the static column) and scipy's DOP853 on the same equations (driven
walls). Two compiled feature sets only (n = 2 and n = 5/2, frictionless, with
the dissipative code in): tensile, the dashpot law, the body force and the wall
motion are runtime values of one kernel.
"""

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import granular_chain as gc
from granular_chain import restitution as R
from granular_chain.frames import FrameLog
from granular_chain.model import build_model
from granular_chain.simulate import simulate
from granular_chain.steppers.events import simulate_events
from granular_chain.two_granules import collide
from granular_chain.two_granules.problem import two_granule_scene
from conftest import fitted_order

ROOT = Path(__file__).resolve().parents[1]
M_EFF = 0.5  # the paper's two unit masses
C_CRIT = 2.0 * math.sqrt(M_EFF)  # k = 1


def _e(collision):
    """Restitution of the paper's collision (impact speed 1)."""
    return collision.v2 - collision.v1


@pytest.mark.parametrize("tensile", [False, True])
@pytest.mark.parametrize("b", [0.3, 1.0, 3.0])
def test_linear_dashpot_restitution_matches_the_closed_form(tensile, b):
    """n = 2, c = b c_crit: e and the contact time to 1e-12 of restitution.linear_dashpot
    (under-, critically and overdamped; force-zero and tensile ends)."""
    c = b * C_CRIT
    ref = R.linear_dashpot(c, 1.0, M_EFF, tensile)
    col = collide(2, stepper="event", damping={"model": "linear", "coefficient": c},
                  tensile=tensile)
    assert col.result.status == (gc.Status.SEPARATED if ref.ended else gc.Status.T_END)
    assert abs(_e(col) - ref.e) <= 1e-12
    if ref.ended:
        assert col.t_separation == pytest.approx(ref.contact_time, rel=1e-12, abs=0)
    else:
        # tensile, b >= 1: the overlap decays for ever (e = 0) and the contact never
        # opens; both granules end at the centre-of-mass speed
        assert ref.e == 0.0 and col.t_separation == math.inf
        assert col.outcome.name == "no_separation"
    assert col.result.energy.balance_error <= 1e-14


@pytest.mark.parametrize("tensile", [False, True])
def test_restitution_key_gives_e(tensile):
    """contacts.damping {model: restitution, value: e}: the two grains part with e."""
    col = collide(2, stepper="event", damping={"model": "restitution", "value": 0.8},
                  tensile=tensile)
    assert abs(_e(col) - 0.8) <= 1e-12


def _hertz_pair(v, A, tensile, rtol=1e-12):
    """Two unit grains, Hertz, viscoelastic A, impact speed v: (e, Result)."""
    spec = two_granule_scene(2.5, stepper="event", rtol=rtol)
    spec["granules"]["velocity"] = [v, 0.0]
    spec["contacts"]["damping"] = {"model": "viscoelastic", "coefficient": A}
    spec["contacts"]["tensile"] = tensile
    r = simulate(gc.scene_from_dict(spec), progress=False)
    assert r.status == gc.Status.SEPARATED, r.message
    return (r.v_final[1] - r.v_final[0]) / v, r


@pytest.mark.parametrize("tensile", [False, True])
@pytest.mark.parametrize("v, A", [(1.0, 0.1), (1.0, 0.5), (1e-3, 0.1)])
def test_viscoelastic_hertz_restitution_matches_the_reference(v, A, tensile):
    """e(v) to 1e-8 of the mpmath integration; the ledger within its promise."""
    e, r = _hertz_pair(v, A, tensile)
    ref = float(R.restitution_reference(v, 1.0, M_EFF, 2.5, "viscoelastic", A, tensile,
                                        dps=25).e)
    assert abs(e - ref) <= 1e-8
    assert r.energy.balance_error <= r.info["event_stepper"]["ledger_tolerance"]
    assert r.energy.final()["contact_dissipated"] == pytest.approx(
        0.5 * M_EFF * v * v * (1 - e * e), rel=1e-8)


def test_viscoelastic_small_speed_slope():
    """1 - e = C1 G - C2 G^2 + O(G^(5/2)) (Schwager and Poeschel): at G ~ 1e-3 the
    engine's e lies within G^(5/2) of the two-term series, and the slope
    (1 - e)/G extrapolated from two speeds is C1 to 1e-4."""
    A = 0.01
    slopes = []
    for v in (1e-6, 1e-8):
        e, _ = _hertz_pair(v, A, False)
        G = float(R.viscoelastic_group(v, 1.0, A, M_EFF))
        assert abs(e - float(R.viscoelastic_series(v, 1.0, A, M_EFF, terms=2))) <= G ** 2.5
        slopes.append((G, (1.0 - e) / G))
    (g1, s1), (g2, s2) = slopes
    c1 = s1 + (s2 - s1) * (0.0 - g1) / (g2 - g1)
    assert c1 == pytest.approx(float(R.viscoelastic_c1_exact()), rel=1e-4)


def _column(n, t_end, c=9.0, N=10, g=0.01):
    """N unit grains at rest, touching, on a left wall, gravity g towards it."""
    return gc.scene_from_dict({
        "name": "column", "granules": {"count": N, "mass": 1.0, "radius": 0.5, "gap": 0.0},
        "contacts": {"exponent": n, "stiffness": 1.0,
                     "damping": {"model": "linear", "coefficient": c}},
        "walls": {"left": {"gap": 0.0, "stiffness": 1.0, "exponent": n}},
        "body_force": {"g": g, "direction": -1},
        "run": {"stepper": "event", "t_end": t_end, **({"rtol": 1e-12} if n != 2 else {})},
        "output": {"dt": t_end / 10, "trajectory": False}})


@pytest.mark.parametrize("n, t_end", [(2.0, 300.0), (2.5, 3000.0)])
def test_column_settles_to_the_static_overlaps(n, t_end):
    """delta_i = (i m g / k)^(1/(n-1)) (i from the top) to 1e-10; the ledger (body
    work against the elastic energy and the dashpots' work) closes."""
    r = simulate(_column(n, t_end), progress=False)
    u = r.x_final - r.x[0]
    overlaps = np.concatenate([[-u[0]], u[:-1] - u[1:]])[::-1]  # top first, wall last
    ref = R.column_overlaps(10, 1.0, 0.01, 1.0, n)
    assert np.max(np.abs(overlaps / ref - 1.0)) <= 1e-10
    f = r.energy.final()
    # at rest the body work is sum_j k delta_j^n, n times the elastic energy
    assert f["body_work"] == pytest.approx(n * f["potential"], rel=1e-9)
    assert f["contact_dissipated"] > 0.0
    tol = 1e-13 if n == 2 else r.info["event_stepper"]["ledger_tolerance"]
    assert r.energy.balance_error <= tol


def _driven(n, motion, damping=None, t_end=40.0):
    """Three grains between a driven left wall and a fixed right one, all apart."""
    contacts = {"exponent": n, "stiffness": 1.0}
    if damping is not None:
        contacts["damping"] = damping
    return gc.scene_from_dict({
        "name": "driven", "granules": {"count": 3, "mass": 1.0, "radius": 0.5, "gap": 0.05},
        "contacts": contacts,
        "walls": {"left": {"gap": 0.0, "stiffness": 1.0, "exponent": n, "motion": motion},
                  "right": {"gap": 0.1, "stiffness": 1.0, "exponent": n}},
        "run": {"stepper": "event", "t_end": t_end, **({"rtol": 1e-12} if n != 2 else {})},
        "output": {"dt": 0.5, "trajectory": False}})


def _reference_end(scene, t_end):
    """End positions and velocities by DOP853 (rtol 1e-12) of the same equations:
    F = max(0, k delta^(n-1) + c delta') on delta > 0, the left wall moving."""
    from granular_chain.laws.wall_motion import wall_displacement, wall_speed
    m = build_model(scene)
    N, n = m.count, float(m.n[0])
    c = np.concatenate([[m.wall_damping[0]], m.damping, [m.wall_damping[1]]])
    d0 = np.concatenate([[m.walls[0]], m.d0, [m.walls[3]]])
    kind, p1, p2 = int(m.wall_motion[0, 0]), m.wall_motion[0, 1], m.wall_motion[0, 2]

    def rhs(t, y):
        u, v = y[:N], y[N:]
        d = np.concatenate([[d0[0] + wall_displacement(kind, p1, p2, t) - u[0]],
                            d0[1:N] + u[:-1] - u[1:], [d0[N] + u[-1]]])
        w = np.concatenate([[wall_speed(kind, p1, p2, t) - v[0]], v[:-1] - v[1:], [v[-1]]])
        F = np.where(d > 0, np.maximum(0.0, np.abs(d) ** (n - 1) + c * w), 0.0)
        return np.concatenate([v, (F[:-1] - F[1:]) / m.mass])

    sol = solve_ivp(rhs, (0.0, t_end), np.zeros(2 * N), method="DOP853", rtol=1e-12,
                    atol=1e-14, max_step=0.01)
    return sol.y[:N, -1] + m.x0, sol.y[N:, -1]


MOTIONS = {"velocity": {"velocity": 0.05},
           "sine": {"sine": {"amplitude": 0.2, "frequency": 0.3}},
           "pulse": {"pulse": {"velocity": 0.5, "duration": 1.3}}}


@pytest.mark.parametrize("kind", sorted(MOTIONS))
def test_driven_wall_follows_the_reference_and_the_ledger_closes(kind):
    """n = 2, restitution 0.8: the end state within 1e-9 of DOP853 (whose kinks at
    contact changes limit it); the wall's work balances the ledger to 1e-14."""
    scene = _driven(2.0, MOTIONS[kind], {"model": "restitution", "value": 0.8})
    r = simulate(scene, progress=False)
    assert r.status == gc.Status.T_END
    x, v = _reference_end(scene, 40.0)
    assert np.max(np.abs(r.x_final - x)) <= 1e-9 and np.max(np.abs(r.v_final - v)) <= 1e-9
    f = r.energy.final()
    assert f["wall_work"] > 1e-3 and f["contact_dissipated"] > 0.0
    assert r.energy.balance_error <= 1e-14


@pytest.mark.parametrize("kind", sorted(MOTIONS))
def test_driven_wall_hertz_follows_the_reference(kind):
    """n = 5/2, linear dashpot c = 0.2 (force-zero ends, contacts that open with
    overlap and close again): the end state within 1e-9 of DOP853, the ledger
    within the stepper's promise."""
    scene = _driven(2.5, MOTIONS[kind], {"model": "linear", "coefficient": 0.2})
    r = simulate(scene, progress=False)
    assert r.status == gc.Status.T_END
    x, v = _reference_end(scene, 40.0)
    assert np.max(np.abs(r.x_final - x)) <= 1e-9 and np.max(np.abs(r.v_final - v)) <= 1e-9
    assert r.energy.final()["wall_work"] > 1e-3
    assert r.energy.balance_error <= r.info["event_stepper"]["ledger_tolerance"]


def test_driven_wall_hertz_viscoelastic_ledger_within_its_promise():
    """n = 5/2, viscoelastic, a sine wall: the ledger within the stepper's tolerance."""
    scene = _driven(2.5, MOTIONS["sine"], {"model": "viscoelastic", "coefficient": 0.2})
    r = simulate(scene, progress=False)
    assert r.status == gc.Status.T_END and len(r.events) > 4
    assert r.energy.final()["wall_work"] > 1e-3
    assert r.energy.balance_error <= r.info["event_stepper"]["ledger_tolerance"]


class _Collect:
    """A writer keeping a copy of every frame."""

    def __init__(self):
        self.frames = []

    def write_frame(self, f):
        self.frames.append(f._replace(x=f.x.copy(), v=f.v.copy(), f=f.f.copy()))

    def close(self, result):
        pass


def _bits(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.tobytes() == b.tobytes()


def test_resumed_run_with_dashpots_gravity_and_a_driven_wall_is_bit_identical(tmp_path):
    """A checkpoint (through numpy.savez) continued: the same frames and end, bit for
    bit, with the new ledger terms (dashpot, wall and body work)."""
    spec = {"name": "all", "granules": {"count": 6, "mass": 1.0, "radius": 0.5, "gap": 0.02},
            "contacts": {"exponent": 2.0, "damping": {"model": "restitution", "value": 0.7}},
            "walls": {"left": {"gap": 0.0, "motion": {"pulse": {"velocity": 0.4,
                                                                "duration": 2.0}}},
                      "right": {"gap": 0.05}},
            "body_force": {"g": 0.02, "direction": 1},
            "run": {"stepper": "event", "t_end": 30.0}, "output": {"dt": 0.25}}
    scene = gc.scene_from_dict(spec)
    model = build_model(scene)
    a_sink = _Collect()
    a = simulate_events(scene, model, FrameLog([a_sink]))
    states = []
    simulate_events(scene, model, FrameLog([_Collect()]), checkpoint=states.append,
                    checkpoint_every=max(a.steps // 4, 1))
    assert len(states) >= 3
    np.savez(tmp_path / "s.npz", **states[len(states) // 2])
    with np.load(tmp_path / "s.npz") as data:
        state = {k: data[k] for k in data.files}
    k0 = int(state["frames"])
    sink = _Collect()
    c = simulate_events(scene, model, FrameLog([sink]), resume=state)
    assert c.t_final == a.t_final and c.steps == a.steps and c.events == a.events
    assert _bits(c.x_final, a.x_final) and _bits(c.v_final, a.v_final)
    assert len(sink.frames) == len(a_sink.frames) - k0 > 0
    for f, g in zip(sink.frames, a_sink.frames[k0:]):
        assert f.t == g.t and _bits(f.x, g.x) and _bits(f.v, g.v) and _bits(f.f, g.f)
        assert (f.contact_dissipated, f.wall_work, f.body_work) == (
            g.contact_dissipated, g.wall_work, g.body_work)
    last = a_sink.frames[-1]
    assert last.wall_work != 0.0 and last.body_work != 0.0 and last.contact_dissipated > 0.0
    assert a.energy.balance_error <= 1e-13


def test_dashpot_and_equal_drag_compose():
    """Equal drag gamma on both unit grains adds gamma/2 to the pair's dashpot:
    the relative motion is that of a linear dashpot c + gamma/2 (tensile end)."""
    c, gamma = 0.3, 0.2
    col = collide(2, gamma=(gamma, gamma), stepper="event",
                  damping={"model": "linear", "coefficient": c}, tensile=True)
    ref = R.linear_dashpot(c + gamma / 2, 1.0, M_EFF, True)
    assert col.result.status == gc.Status.SEPARATED
    assert abs(_e(col) - ref.e) <= 1e-12
    assert col.t_separation == pytest.approx(ref.contact_time, rel=1e-12, abs=0)


def _friction_dashpot_reference(n, c, eta, damping, tensile, t_end=None):
    """Independent DOP853 integration (rtol 1e-13) of two unit grains, v = (1, 0),
    unit stiffness, kinetic friction eta = static threshold, to the end of contact
    (force zero, or overlap zero when tensile) or to t_end. Grain 2 sticks while
    the contact force is below its threshold (a viscoelastic force starts from 0),
    then both slide forward (checked: neither stops in contact, so each phase's
    ODE is smooth). Returns (t, v1, v2)."""
    def force(d, w):
        if d <= 0.0:
            return 0.0
        dash = c * w if damping == "linear" else c * (n - 1.0) * d ** (n - 2.0) * w
        return d ** (n - 1.0) + dash if tensile else max(0.0, d ** (n - 1.0) + dash)

    def stuck(t, y):  # y = (d, v1): grain 2 held
        return [y[1], -force(y[0], y[1]) - eta[0]]

    def slip(t, y):
        return force(y[0], y[1]) - eta[1]
    slip.terminal, slip.direction = True, 1

    def sliding(t, y):  # y = (d, v1, v2)
        f = force(y[0], y[1] - y[2])
        return [y[1] - y[2], -f - eta[0], f - eta[1]]

    def end(t, y):
        if y[0] <= 0.0 or tensile:
            return y[0]
        w = y[1] - y[2]
        return y[0] ** (n - 1.0) + (c * w if damping == "linear"
                                     else c * (n - 1.0) * y[0] ** (n - 2.0) * w)
    end.terminal, end.direction = True, -1

    kw = dict(method="DOP853", rtol=1e-13, atol=1e-15)
    t_stop = t_end or 50.0
    t0, y0 = 0.0, [0.0, 1.0, 0.0]
    if force(1e-300, 1.0) <= eta[1]:  # no jump above the threshold: grain 2 sticks first
        a = solve_ivp(stuck, (0.0, t_stop), [0.0, 1.0], events=slip, **kw)
        t0, y0 = a.t[-1], [a.y[0, -1], a.y[1, -1], 0.0]
    if t0 >= t_stop:
        return t0, y0[1], y0[2]
    sol = solve_ivp(sliding, (t0, t_stop), y0, events=None if t_end else end,
                    dense_output=True, **kw)
    ts = np.linspace(t0, sol.t[-1], 2001)
    held = np.array(eta) > 0.0  # a grain with friction must not stop (it would stick)
    assert np.all(sol.sol(ts)[1:][held] >= -1e-12), "a grain stopped: the ODE is not valid"
    if t_end:
        return sol.t[-1], sol.y[1, -1], sol.y[2, -1]
    return sol.t_events[0][0], sol.y_events[0][0][1], sol.y_events[0][0][2]


FRICTION_DASHPOT = [  # (n, damping model, coefficient, tensile, kinetic friction)
    (2.0, "linear", 0.3, False, (0.1, 0.05)), (2.0, "linear", 0.3, True, (0.1, 0.05)),
    (2.0, "linear", 3.0, False, (0.1, 0.05)), (2.5, "linear", 0.3, False, (0.1, 0.05)),
    # grain 2 sticks until the force (from 0) reaches 0.05; a frictionless grain 1
    # may turn back (with friction it would stop and stick in contact)
    (2.5, "viscoelastic", 0.1, False, (0.0, 0.05)),
]


@pytest.mark.parametrize("n, model, c, tensile, eta", FRICTION_DASHPOT)
def test_coulomb_friction_and_dashpot_compose_in_the_event_stepper(n, model, c, tensile, eta):
    """Kinetic friction with a dashpot: the stuck second grain slips when the
    linear dashpot's force jumps on (c w at closing, above its threshold 0.05),
    or when the viscoelastic force grows through it; the end of contact and the
    velocities there agree with an independent integration to its own accuracy."""
    col = collide(n, eta=eta, stepper="event", damping={"model": model, "coefficient": c},
                  tensile=tensile)
    t_ref, v1_ref, v2_ref = _friction_dashpot_reference(n, c, eta, model, tensile)
    assert col.result.status == gc.Status.SEPARATED, col.result.message
    err = max(abs(col.v1 - v1_ref), abs(col.v2 - v2_ref), abs(col.t_separation - t_ref))
    assert err <= (1e-11 if n == 2 else 1e-10), (err, col.v1, col.v2, col.t_separation, t_ref)
    assert col.result.energy.balance_error <= 1e-12


def _pair_at(stepper, t_end, dt=None, n=2.0, model="linear", c=0.3, eta=(0.1, 0.05), gap=0.0):
    spec = two_granule_scene(n, eta, (0.0, 0.0), stepper=stepper, dt=dt, eta_static=None,
                             t_max=t_end, rtol=None, atol=None)
    spec["contacts"]["damping"] = {"model": model, "coefficient": c}
    spec["granules"]["gap"] = gap
    spec["run"].pop("stop")
    spec["run"].pop("stop_contact")
    return simulate(gc.scene_from_dict(spec), progress=False)


def _verlet_errors_at(t, n, model, c, eta, gap=0.0, steps=(0.02, 0.01, 0.005)):
    """Verlet's largest velocity error at time t against the event stepper (itself
    checked against the independent integration when the grains touch at t = 0)."""
    ev = _pair_at("event", t, n=n, model=model, c=c, eta=eta, gap=gap)
    if gap == 0.0:
        _, v1_ref, v2_ref = _friction_dashpot_reference(n, c, eta, model, False, t_end=t)
        assert abs(ev.v_final[0] - v1_ref) + abs(ev.v_final[1] - v2_ref) <= 1e-10
    errs = []
    for dt in steps:
        r = _pair_at("verlet", t, dt=dt, n=n, model=model, c=c, eta=eta, gap=gap)
        assert r.t_final == pytest.approx(t, abs=1e-12)
        errs.append(float(np.max(np.abs(r.v_final - ev.v_final))))
    return errs


def test_viscoelastic_dashpot_and_coulomb_friction_converge_in_verlet():
    """Verlet at t = 1.5, inside the contact, after grain 2 has slipped: its error
    against the event stepper falls as dt^2. Measured: 1.2e-5, 3.1e-6, 8.5e-7
    (fitted order 1.9)."""
    errs = _verlet_errors_at(1.5, 2.5, "viscoelastic", 0.1, (0.0, 0.05))
    order = fitted_order([0.02, 0.01, 0.005], errs)
    assert errs[2] < 1e-6 and 1.6 < order < 2.3, (errs, order)


@pytest.mark.parametrize("gap", [0.0, 0.0123])
def test_linear_dashpot_and_coulomb_friction_converge_in_verlet(gap):
    """A linear dashpot's force jumps to c w when the contact closes, and the stuck
    grain 2 slips at once: Verlet's closing kick gives it the part of the step
    after the closing (not the half step its opening kick held it for), and
    converges to the event stepper as dt^2, also when the closing falls inside a
    step (gap 0.0123). Measured at t = 1.5: 1.3e-5, 3.1e-6, 7.7e-7 (touching) and
    3.3e-5, 3.6e-6, 1.9e-6, 3.7e-7 (gap; dt = 0.02 ... 0.0025, fitted order 2.0);
    without that kick, 6.7e-5, 9.9e-5, 8.7e-6, 3.4e-5."""
    steps = (0.02, 0.01, 0.005, 0.0025)
    errs = _verlet_errors_at(1.5, 2.0, "linear", 0.3, (0.1, 0.05), gap=gap, steps=steps)
    order = fitted_order(steps, errs)
    assert errs[-1] < 5e-7 and 1.8 < order < 2.4, (errs, order)


def test_viscoelastic_dashpot_and_coulomb_friction_compose_in_verlet():
    """Hertz grains with kinetic friction and the viscoelastic dashpot, whose force
    starts from zero at contact: Verlet converges to itself as dt^2."""
    kw = dict(n=2.5, eta=(0.1, 0.05), damping={"model": "viscoelastic", "coefficient": 0.1})
    runs = [collide(stepper="verlet", dt=dt, **kw) for dt in (0.02, 0.01, 0.005)]
    diffs = [abs(a.v2 - b.v2) + abs(a.v1 - b.v1) for a, b in zip(runs, runs[1:])]
    order = math.log2(diffs[0] / diffs[1])
    assert all(r.result.status == gc.Status.SEPARATED for r in runs)
    assert diffs[1] < 1e-5 and 1.8 < order < 2.8, (diffs, order)


def test_friction_chain_with_dashpots_agrees_in_both_steppers():
    """scenarios/chain_friction.yaml (stick and slip along a struck chain) with linear
    contacts and a linear dashpot in each: the event stepper closes its ledger to
    roundoff, and Verlet's positions at t = 20 converge to it as dt^2.
    (Its viscous friction left out and n = 2: the kernels are then those of the
    two-grain tests above.) Measured: 1.1e-4, 3.2e-5, 6.9e-6 at dt = 0.01, 0.005,
    0.0025 (order 2.02)."""
    damping = 'contacts.damping={"model": "linear", "coefficient": 0.2}'
    common = [damping, "run.t_end=20", "granules.friction.viscous=0", "contacts.exponent=2"]
    scene = gc.load_scene(ROOT / "scenarios" / "chain_friction.yaml",
                          overrides=["run.stepper=event", "run.dt=null", *common])
    ev = simulate(scene, progress=False)
    assert ev.status == gc.Status.T_END and ev.energy.balance_error < 1e-12
    assert ev.event_counts["slip"] > 0 and ev.event_counts["stop"] > 0
    steps = (0.01, 0.005, 0.0025)
    errs = []
    for dt in steps:
        scene = gc.load_scene(ROOT / "scenarios" / "chain_friction.yaml",
                              overrides=[f"run.dt={dt}", *common])
        errs.append(float(np.max(np.abs(simulate(scene, progress=False).x_final - ev.x_final))))
    order = fitted_order(steps, errs)
    assert errs[-1] < 1e-5 and 1.8 < order < 2.4, (errs, order)
