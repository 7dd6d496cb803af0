"""Check every closed form and numerical claim of the two-granule paper.

Each printed formula is compared with an independent exact computation: the
piecewise-linear mpmath solver ``reference_collision_n2`` (matrix exponential per
stick/slip mode), closed-form phase solutions, ``scipy.integrate.solve_ivp`` in
physical units, or direct linear algebra.  Bounds:

* exact formulas: evaluated in mpmath at 40 digits, must agree with the
  reference to 1e-25 (and in float64 to a few ulps, <= 1e-14);
* small-parameter series: the error must scale with the stated order (log-log
  slope) *and* approach the leading error term we derive, with the next-order
  correction of relative size O(sqrt(eta)) (or O(delta));
* errata: the printed statement misses by orders of magnitude more than the
  corrected one.
"""
from __future__ import annotations

import functools
import math
import os
import sys

import mpmath as mp
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from granular_chain import paper as P

EXACT = mp.mpf("1e-25")  # agreement required between exact forms and the reference
FLOAT = 1e-14            # float64 evaluation of an exact form (a few ulps of O(1) values)


@pytest.fixture(autouse=True)
def _mp_precision():
    with mp.workdps(40):
        yield


@functools.lru_cache(maxsize=None)
def ref(eta1, eta2, gamma1=0, gamma2=0):
    """Reference collision; arguments are strings so that mpmath reads them exactly."""
    with mp.workdps(40):
        return P.reference_collision_n2(mp.mpf(eta1), mp.mpf(eta2), mp.mpf(gamma1), mp.mpf(gamma2))


def loglog_slope(etas, errs):
    x = np.log([float(e) for e in etas])
    y = np.log([float(abs(e)) for e in errs])
    return float(np.polyfit(x, y, 1)[0])


def a_of(eta):
    """The natural small parameter of Sec. II B: a = pi eta / sqrt2."""
    return mp.pi * eta / mp.sqrt(2)


# ---------------------------------------------------------------------------
# Reference solver sanity (the yardstick itself)
# ---------------------------------------------------------------------------
def test_reference_frictionless_is_elastic_exchange():
    r = ref("0", "0")
    assert r["outcome"] == "propagation_only"
    assert abs(r["v1"]) < EXACT and abs(r["v2"] - 1) < EXACT
    assert abs(r["t_separation"] - mp.pi / mp.sqrt(2)) < EXACT
    assert abs(r["energy_ratio"] - 1) < EXACT


def test_reference_outcomes_cover_the_enumeration():
    assert ref("0", "0.3")["outcome"] == "backscatter_and_propagation"
    assert ref("0.5", "0")["outcome"] == "propagation_only"
    assert ref("0", "1.2")["outcome"] == "backscatter_only"
    stuck = ref("0.5", "0.9")
    assert stuck["outcome"] == "stuck" and stuck["t_separation"] == math.inf
    assert ref("0", "0", "3", "3")["outcome"] == "no_separation"
    for key in (("0", "0.3"), ("0.5", "0"), ("0", "1.2"), ("0.5", "0.9")):
        assert ref(*key)["outcome"] in P.OUTCOMES


# ---------------------------------------------------------------------------
# Sec. I Eqs. (1)-(3) and Appendix A
# ---------------------------------------------------------------------------
def test_eq1_printed_potential_has_the_wrong_sign_convention():
    # delta (Eq. 2) = 2R - centre distance > 0 is the overlap
    overlap, gap = 0.01, -0.01
    assert P.hertz_potential_printed(overlap, 1.0, 2.5) == 0.0  # no repulsion on overlap
    assert np.isnan(P.hertz_potential_printed(gap, 1.0, 2.5))  # (negative)**2.5: not real
    assert P.hertz_potential_corrected(overlap, 1.0, 2.5) == pytest.approx(overlap**2.5, rel=1e-15)
    assert P.hertz_potential_corrected(gap, 1.0, 2.5) == 0.0


def test_eq3_a_is_a_potential_coefficient_and_appendix_uses_a_force_coefficient():
    Y, sigma, R = 2.0e11, 0.3, 0.005
    a = P.hertz_a_printed(Y, sigma, R)
    k = P.hertz_force_coefficient_spheres(Y, sigma, R)
    # Eq. (3) reproduces Hertz exactly as the coefficient of V = a delta^(5/2): k = (5/2) a
    assert abs(k / (2.5 * a) - 1) < 4e-16
    assert P.force_coefficient_from_potential_coefficient(a, 2.5) == pytest.approx(k, rel=4e-16)
    # force = dV/d(delta) by central differences is n a delta^(n-1), not a delta^(n-1)
    d, h = 1e-6, 1e-10
    fd = (P.hertz_potential_corrected(d + h, a, 2.5) - P.hertz_potential_corrected(d - h, a, 2.5)) / (2 * h)
    assert abs(fd / (2.5 * a * d**1.5) - 1) < 1e-8  # truncation ~(h/d)^2/8 ~ 1e-9, roundoff ~1e-12
    assert abs(fd / (a * d**1.5) - 1) > 1.4  # Appendix-A reading misses by the factor n


def _physical_iib_stop_time(m, v0, k, mu, g):
    """Stopping time of granule 1 in physical units (Sec. II B, n = 2) by solve_ivp."""
    def rhs(_, y):
        f = k * (y[0] - y[1])
        return [y[2], y[3], -mu * g - f / m, f / m]

    def stop(_, y):
        return y[2]
    stop.terminal, stop.direction = True, -1
    sol = solve_ivp(rhs, (0, 100), [0, 0, v0, 0], method="DOP853", events=stop, rtol=1e-13, atol=1e-15)
    return sol.t_events[0][0]


def test_appendix_eta_scaling_printed_is_dimensionally_wrong():
    m, v0, k, mu, g = 2.0, 0.5, 30.0, 0.05, 9.81  # friction force mu m g
    tau = _physical_iib_stop_time(m, v0, k, mu, g)
    corr = P.scaling_corrected(m, v0, k, 2, mu=mu, g=g)
    prin = P.scaling_printed(m, v0, k, 2, mu=mu, g=g)
    err_corr = abs(corr["B"] * float(P.iib_t0_exact(corr["eta"])) / tau - 1)
    err_prin = abs(prin["B"] * float(P.iib_t0_exact(prin["eta"])) / tau - 1)
    assert err_corr < 1e-10  # solve_ivp at rtol 1e-13
    assert err_prin > 1e-2   # printed eta is the corrected one divided by m
    assert prin["eta"] == pytest.approx(corr["eta"] / m, rel=1e-15)


def test_appendix_A_B_scaling_for_hertz_exponent():
    # granule 1 bouncing off a fixed granule, n = 5/2: physical bounce time = B * scaled time
    n, m, v0, k = 2.5, 0.7, 3.0, 1.0e4

    def bounce(mass, coef, vel):
        def rhs(_, y):
            return [y[1], -coef * max(y[0], 0.0) ** (n - 1) / mass]

        def back(_, y):
            return y[0]
        back.terminal, back.direction = True, -1
        sol = solve_ivp(rhs, (1e-12, 1e3), [vel * 1e-12, vel], method="DOP853", events=back,
                        rtol=1e-13, atol=1e-16)
        return sol.t_events[0][0], sol.y_events[0][0][1]
    T_scaled, v_scaled = bounce(1.0, 1.0, 1.0)
    T_phys, v_phys = bounce(m, k, v0)
    s = P.scaling_corrected(m, v0, k, n)
    assert abs(s["B"] * T_scaled / T_phys - 1) < 1e-9
    assert abs(v_phys / v0 - v_scaled) < 1e-9
    assert P.scaling_printed(m, v0, k, n)["B"] == pytest.approx(s["B"], rel=1e-15)


def test_appendix_gamma_scaling():
    m, v0, k, gt = 2.0, 0.5, 30.0, 3.0
    s = P.scaling_printed(m, v0, k, 2, gamma_tilde=gt)

    def rhs(_, y):
        f = k * (y[0] - y[1])
        return [y[2], y[3], (-gt * y[2] - f) / m, (-gt * y[3] + f) / m]

    def sep(_, y):
        return y[0] - y[1]
    sep.terminal, sep.direction = True, -1
    sol = solve_ivp(rhs, (1e-9, 100), [v0 * 1e-9, 0, v0, 0], method="DOP853", events=sep,
                    rtol=1e-13, atol=1e-16)
    tau = sol.t_events[0][0]
    assert abs(s["B"] * P.iii_t0(s["gamma"]) / tau - 1) < 1e-8
    assert s["gamma"] == pytest.approx(P.scaling_corrected(m, v0, k, 2, gamma_tilde=gt)["gamma"], rel=1e-15)


# ---------------------------------------------------------------------------
# Sec. II A: friction on granule 2 only
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("eta", ["0.1", "0.3", "0.6"])
def test_iia_exact_trajectory_and_separation(eta):
    e = mp.mpf(eta)
    r = ref("0", eta)
    slip = r["events"][0]
    assert slip["kind"] == "slip" and slip["granule"] == 1
    t0 = P.iia_t0(e)
    assert abs(slip["t"] - t0) < EXACT                               # t0 = arcsin(eta)
    for t in (t0 / 3, 2 * t0 / 3):
        assert abs(P.reference_state_n2(r, t)[0] - P.iia_x1_phase1(t)) < EXACT  # x1 = sin t
    for frac in ("0.1", "0.37", "0.62", "0.9"):
        tp = mp.mpf(frac) * P.iia_t1(e)
        x1, x2, _, _ = P.reference_state_n2(r, t0 + tp)
        assert abs(P.iia_x1(tp, e) - x1) < EXACT                     # eq:x1
        assert abs(P.iia_x2(tp, e) - x2) < EXACT                     # eq:x2
        assert abs(P.iia_x1(float(tp), float(e)) - float(x1)) < FLOAT
        assert abs(P.iia_x2(float(tp), float(e)) - float(x2)) < FLOAT
    assert abs(r["t_separation"] - t0 - P.iia_t1(e)) < EXACT         # t1 = pi/sqrt2
    assert abs(r["v1"] - P.iia_v1s(e)) < EXACT
    assert abs(r["v2"] - P.iia_v2s(e)) < EXACT
    assert abs(r["energy_ratio"] - P.iia_energy_ratio(e)) < EXACT    # E/E0 formula
    assert abs(float(r["energy_ratio"]) - P.iia_energy_ratio(float(e))) < FLOAT
    assert r["outcome"] == "backscatter_and_propagation"


def test_iia_eta_range_0669():
    em = P.iia_eta_max(exact=True)
    assert abs(P.iia_v2s(em)) < EXACT and abs(float(em) - 0.669) < 5e-4
    below = ref("0", mp.nstr(em - mp.mpf("0.002"), 30))
    above = ref("0", mp.nstr(em + mp.mpf("0.002"), 30))
    assert below["outcome"] == "backscatter_and_propagation"
    assert above["outcome"] == "backscatter_only" and above["v2"] == 0
    assert any(ev["kind"] == "stick" and ev["granule"] == 1 for ev in above["events"])


def test_iia_energy_ratio_is_nonmonotonic():
    eta_min, e_min = P.iia_energy_minimum()
    assert 0 < eta_min < P.iia_eta_max()
    assert abs(float(P.iia_energy_ratio(mp.mpf(eta_min))) - e_min) < FLOAT
    # exact energies (reference) rise from eta = 0.55 to 0.65, inside the valid range
    assert ref("0", "0.65")["energy_ratio"] - ref("0", "0.55")["energy_ratio"] > mp.mpf("0.01")


@pytest.mark.parametrize("eta", ["1", "1.5"])
def test_iia_immovable_second_granule_gives_v1_minus_one(eta):
    r = ref("0", eta)
    assert abs(r["v1"] - P.iia_stuck_second_granule_v1()) < EXACT and r["v2"] == 0
    assert abs(r["t_separation"] - mp.pi) < EXACT and r["outcome"] == "backscatter_only"


def test_iia_v1_between_minus_one_and_zero():
    v1 = [ref("0", e)["v1"] for e in ("0.05", "0.3", "0.6", "0.8", "0.95")]
    assert all(-1 <= v <= 0 for v in v1)
    assert all(b < a for a, b in zip(v1, v1[1:]))  # backward speed grows with eta


# ---------------------------------------------------------------------------
# Sec. II B: friction on granule 1 only
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("eta", ["0.1", "0.3", "0.5", "2"])
def test_iib_phase1_formulas_exact(eta):
    e = mp.mpf(eta)
    r = ref(eta, "0")
    stop = r["events"][0]
    assert stop["granule"] == 0 and stop["kind"] in ("reverse", "stick")
    assert abs(stop["t"] - P.iib_t0_exact(e)) < EXACT            # root of the printed v1(t)
    for frac in ("0.2", "0.5", "0.8"):
        t = mp.mpf(frac) * stop["t"]
        x1, x2, v1, v2 = P.reference_state_n2(r, t)
        assert abs(P.iib_x1(t, e) - x1) < EXACT                  # eq:x1model2
        assert abs(P.iib_x2(t, e) - x2) < EXACT                  # eq:x2model2
        assert abs(P.iib_v1(t, e) - v1) < EXACT                  # printed v1(t)
        assert abs(P.iib_x1(float(t), float(e)) - float(x1)) < FLOAT


@pytest.mark.parametrize("eta", ["0.05", "0.1", "0.2", "0.3", "0.5", "1", "2"])
def test_iib_closed_form_solution_matches_reference(eta):
    c = P.iib_collision_exact(mp.mpf(eta))
    r = ref(eta, "0")
    for key_c, key_r in (("v1s", "v1"), ("v2s", "v2"), ("t_separation", "t_separation"),
                         ("energy_ratio", "energy_ratio")):
        assert abs(c[key_c] - r[key_r]) < EXACT


def _series_check(printed_minus_exact, leading, order):
    """Slope over eta = 1e-2..1e-4 and convergence of error/leading -> 1 as O(sqrt(eta))."""
    etas = [mp.mpf(s) for s in ("1e-2", "3e-3", "1e-3", "3e-4", "1e-4")]
    errs = [printed_minus_exact(e) for e in etas]
    slope = loglog_slope(etas, errs)
    # the next term is O(eta^(order+1/2)) with a coefficient up to ~7x the leading one,
    # which shifts the fitted slope by at most ~0.085 on this range
    assert abs(slope - order) < 0.1, slope
    for e in (mp.mpf("1e-4"), mp.mpf("1e-6")):
        ratio = printed_minus_exact(e) / leading(e)
        assert abs(ratio - 1) < 10 * mp.sqrt(e), (e, ratio)


def test_iib_t0_small_eta_is_order_three_halves():
    _series_check(lambda e: P.iib_t0_small_eta(e) - P.iib_t0_exact(e),
                  lambda e: a_of(e) ** 1.5 / 12, 1.5)
    e = mp.mpf("1e-4")
    assert abs(P.iib_t0_small_eta_next_order(e) - P.iib_t0_exact(e)) < e**2  # measured 0.37 eta^2


def test_iib_initial_conditions_ic1_to_ic4():
    ap = P.iib_initial_conditions_small_eta
    ex = P.iib_initial_conditions_exact
    _series_check(lambda e: ap(e)[0] - ex(e)[0], lambda e: -a_of(e) ** 1.5 / 3, 1.5)          # ic1
    _series_check(lambda e: ap(e)[1] - ex(e)[1], lambda e: -7 * a_of(e) ** 1.5 / 12, 1.5)     # ic2
    _series_check(lambda e: ap(e)[3] - ex(e)[3], lambda e: -e * a_of(e) ** 0.5, 1.5)          # ic4
    assert ap(mp.mpf("0.1"))[2] == 0 == ex(mp.mpf("0.1"))[2]                                  # ic3


def test_iib_slip_condition_expression_and_threshold():
    # printed left side = exact force u(t0) + O(eta^(3/2)), coefficient -a^(3/2)/12
    _series_check(lambda e: P.iib_slip_force_printed(e) - P.iib_collision_exact(e)["u0"],
                  lambda e: -a_of(e) ** 1.5 / 12, 1.5)
    printed = P.iib_slip_critical_eta_printed()
    exact = P.iib_slip_critical_eta_exact()
    assert abs(printed - mp.mpf("0.439")) < mp.mpf("5e-4")       # "0.439..." is this root
    assert abs(exact - mp.mpf("0.444021248682535645988697474184")) < EXACT
    # at eta = 0.441 the printed condition predicts sticking, the exact dynamics slides back
    e = mp.mpf("0.441")
    assert P.iib_slip_force_printed(e) - e < 0
    kinds = [ev["kind"] for ev in ref("0.441", "0")["events"]]
    assert kinds[0] == "reverse"
    assert [ev["kind"] for ev in ref("0.447", "0")["events"]][0] == "stick"


def test_iib_t1_small_eta_is_order_three_halves():
    _series_check(lambda e: P.iib_t1_small_eta(e) - P.iib_collision_exact(e)["t1"],
                  lambda e: -a_of(e) ** 1.5 / 12, 1.5)
    # t1 measured by the reference solver (separation minus stop) is the same exact t1
    c = P.iib_collision_exact(mp.mpf("0.01"))
    r = ref("0.01", "0")
    assert abs(r["t_separation"] - r["events"][0]["t"] - c["t1"]) < EXACT
    e = mp.mpf("1e-4")
    assert abs(P.iib_t1_small_eta_next_order(e) - P.iib_collision_exact(e)["t1"]) < 2 * e**2


def test_iib_backscatter_threshold_022():
    eb = P.iib_backscatter_threshold_eta_exact()
    assert abs(eb - mp.mpf("0.22")) < mp.mpf("0.005")              # "eta <~ 0.22"
    lo = ref(mp.nstr(eb - mp.mpf("0.005"), 30), "0")
    hi = ref(mp.nstr(eb + mp.mpf("0.005"), 30), "0")
    assert lo["outcome"] == "backscatter_and_propagation"
    assert hi["outcome"] == "propagation_only"
    assert [ev["kind"] for ev in hi["events"]] == ["reverse", "stick", "separation"]


def test_iib_max_backscatter_about_3_percent_and_nonmonotonic():
    eta_star, vmax = P.iib_max_backscatter_exact()
    assert abs(vmax - mp.mpf("0.03")) < mp.mpf("0.0015")            # 3.12 %
    r = ref(mp.nstr(eta_star, 25), "0")
    assert abs(-r["v1"] - vmax) < mp.mpf("1e-18")                   # golden section to 1e-12 in eta
    v = [-ref(e, "0")["v1"] for e in ("0.02", "0.2")]
    assert 0 < v[0] < vmax and 0 < v[1] < vmax      # rises from 0, then falls
    assert abs(ref("0", "0")["v1"]) < EXACT and ref("0.3", "0")["v1"] == 0


def test_iib_t0prime_and_large_eta_claims():
    etas = [mp.mpf(10) ** (mp.mpf(k) / 4) for k in range(-12, 13)]
    assert all(P.iib_t0prime_exact(e) > P.iib_t0_exact(e) for e in etas)  # dashed above solid
    e = mp.mpf(1000)
    assert abs(e * P.iib_t0_exact(e) - 1) < 1 / e**2                # t0 ~ 1/eta
    assert abs(e * P.iib_t0prime_exact(e) - 2) < 2 / e**2           # t0' ~ 2/eta
    # closed form t0' = sqrt2 atan(sqrt2/eta) is the root of the printed x1 - x2
    e = mp.mpf("0.7")
    tp = P.iib_t0prime_exact(e)
    assert abs(P.iib_x1(tp, e) - P.iib_x2(tp, e)) < EXACT


def test_iib_energy_decreases_monotonically():
    etas = [mp.mpf(k) / 20 for k in range(0, 41)]
    E = [P.iib_collision_exact(e)["energy_ratio"] if e > 0 else mp.mpf(1) for e in etas]
    assert all(b < a for a, b in zip(E, E[1:]))


# ---------------------------------------------------------------------------
# Sec. III: hydrodynamic friction
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("s", [0.7, 2.5, 1.5 + 2.0j, -0.3 + 1.1j])
def test_iii_laplace_equations_printed_are_right(s):
    for gamma, delta in ((1.0, 0.1), (2.0, -0.3)):
        Xp, Xm = P.iii_laplace_exact(s, gamma, delta)
        M, b = P.iii_laplace_system_printed(s, gamma, delta)
        assert np.max(np.abs(M @ np.array([Xp, Xm]) - b)) < 1e-14


@pytest.mark.parametrize("s", [0.7, 1.5 + 2.0j])
def test_iii_first_order_Xplus_printed_is_wrong(s):
    gamma = 1.0
    err = {}
    for d in (1e-3, 1e-4):
        Xp, Xm = P.iii_laplace_exact(s, gamma, d)
        err[d] = (abs(P.iii_Xplus_first_order_printed(s, gamma, d) - Xp),
                  abs(P.iii_Xplus_first_order_corrected(s, gamma, d) - Xp),
                  abs(P.iii_Xminus_first_order(s, gamma, d) - Xm))
    # printed X+ error is first order in delta (ratio 10), corrected and X- second order (100)
    assert 9 < err[1e-3][0] / err[1e-4][0] < 11 and err[1e-4][0] > 1e-6
    assert 90 < err[1e-3][1] / err[1e-4][1] < 110 and err[1e-4][1] < 1e-8
    assert 90 < err[1e-3][2] / err[1e-4][2] < 110


@pytest.mark.parametrize("gamma", ["0.5", "1", "2.8"])
def test_iii_zeroth_order_exact(gamma):
    g = mp.mpf(gamma)
    r = ref("0", "0", gamma, gamma)
    assert abs(r["t_separation"] - P.iii_t0(g)) < EXACT             # t0 = pi/omega
    assert abs(r["v1"] - P.iii_v1s_first_order(g, 0)) < EXACT
    assert abs(r["v2"] - P.iii_v2s_first_order(g, 0)) < EXACT
    assert abs(r["energy_ratio"] - P.iii_energy_ratio_zeroth(g)) < EXACT
    t = P.iii_t0(g) * mp.mpf("0.4")
    x1, x2, _, _ = P.reference_state_n2(r, t)
    assert abs(x1 - x2 - P.iii_xminus_zeroth(t, g)) < EXACT


def test_iii_no_separation_iff_gamma_squared_at_least_8():
    # just below sqrt8 = 2.8284271...: the contact ends, after pi/omega (long)
    for g in ("2.8", "2.828"):
        r = ref("0", "0", g, g)
        assert r["outcome"] == "backscatter_and_propagation"
        assert abs(r["t_separation"] - P.iii_t0(mp.mpf(g))) < EXACT * r["t_separation"]
    for g in ("2.8285", "3", "5"):
        assert ref("0", "0", g, g)["outcome"] == "no_separation"
    # gamma^2 = 8 itself: u = t exp(-sqrt2 t) > 0; the decoupled x_- test is exact in mpmath
    r8 = P.reference_collision_n2(0, 0, 2 * mp.sqrt(2), 2 * mp.sqrt(2), dps=30)
    assert r8["outcome"] in ("no_separation", "backscatter_and_propagation")
    assert r8["outcome"] == "no_separation" or r8["t_separation"] > 1e10
    assert list(P.iii_separates([2.8, 2.828, 2.8285, 3.0])) == [True, True, False, False]


def _fd_in_delta(gamma, key, h="1e-8"):
    g, h = mp.mpf(gamma), mp.mpf(h)
    rp = P.reference_collision_n2(0, 0, g * (1 + h), g * (1 - h))
    rm = P.reference_collision_n2(0, 0, g * (1 - h), g * (1 + h))
    return (rp[key] - rm[key]) / (2 * h)  # truncation O(h^2) ~ 1e-16


@pytest.mark.parametrize("gamma", ["0.5", "1", "2"])
def test_iii_epsilon_and_first_order_velocities(gamma):
    g = mp.mpf(gamma)
    # first-order coefficients as printed, extracted exactly (the formulas are linear in delta)
    dt_printed = P.iii_t_separation_first_order(g, 1) - P.iii_t_separation_first_order(g, 0)
    dv1_printed = P.iii_v1s_first_order(g, 1) - P.iii_v1s_first_order(g, 0)
    dv2_printed = P.iii_v2s_first_order(g, 1) - P.iii_v2s_first_order(g, 0)
    assert abs(_fd_in_delta(gamma, "t_separation") - dt_printed) < 1e-12   # epsilon/omega
    assert abs(_fd_in_delta(gamma, "v1") - dv1_printed) < 1e-12
    assert abs(_fd_in_delta(gamma, "v2") - dv2_printed) < 1e-12
    assert abs(dv1_printed - P.iii_dvs_ddelta(g)) < EXACT and abs(dv2_printed - P.iii_dvs_ddelta(g)) < EXACT


def test_iii_first_order_errors_are_second_order():
    g = mp.mpf(1)
    deltas = [mp.mpf(d) for d in ("1e-2", "1e-3", "1e-4")]
    errs = {"v1": [], "v2": [], "t": []}
    for d in deltas:
        r = P.reference_collision_n2(0, 0, g * (1 + d), g * (1 - d))
        errs["v1"].append(P.iii_v1s_first_order(g, d) - r["v1"])
        errs["v2"].append(P.iii_v2s_first_order(g, d) - r["v2"])
        errs["t"].append(P.iii_t_separation_first_order(g, d) - r["t_separation"])
    for k, e in errs.items():
        # next term O(delta^3): slope 2 within O(delta) = 0.01 relative
        assert abs(loglog_slope(deltas, e) - 2) < 0.02, k


def test_iii_backscatter_greater_for_gamma2_larger_means_delta_negative():
    g1, g2 = P.iii_gammas(1.0, 0.1)
    assert g1 > g2  # definition: delta > 0 <=> gamma1 > gamma2
    for gamma in ("0.5", "1", "2"):
        G = mp.mpf(gamma)
        d = mp.mpf("0.1")
        v_pos = ref("0", "0", mp.nstr(G * (1 + d), 30), mp.nstr(G * (1 - d), 30))["v1"]
        v_neg = ref("0", "0", mp.nstr(G * (1 - d), 30), mp.nstr(G * (1 + d), 30))["v1"]
        assert -v_neg > -v_pos > 0          # more backscattering when gamma2 > gamma1, i.e. delta < 0
        assert P.iii_dvs_ddelta(G) > 0


def test_iii_energy_monotone_and_optimal_gamma():
    gammas = [mp.mpf(k) / 10 for k in range(0, 28)]
    E = [P.iii_energy_ratio_zeroth(g) for g in gammas]
    assert all(b < a for a, b in zip(E, E[1:]))
    gs, v = P.iii_optimal_gamma_zeroth()
    G = mp.mpf(gs)
    assert abs(P.iii_v1s_first_order(G, 0) - v) < mp.mpf("1e-15")  # float gamma*
    assert P.iii_v1s_first_order(G - mp.mpf("0.01"), 0) > v < P.iii_v1s_first_order(G + mp.mpf("0.01"), 0)
    r = ref("0", "0", mp.nstr(G, 20), mp.nstr(G, 20))
    assert abs(r["v1"] - P.iii_v1s_first_order(mp.mpf(mp.nstr(G, 20)), 0)) < EXACT


@pytest.mark.parametrize("delta", ["0.1", "-0.1"])
def test_iii_unequal_friction_energy_monotone_and_optimal_gamma(delta):
    d = mp.mpf(delta)
    gammas = [mp.mpf(k) / 5 for k in range(1, 14)]  # 0.2 .. 2.6 (gamma1, gamma2 < sqrt8)
    res = [ref("0", "0", mp.nstr(g * (1 + d), 30), mp.nstr(g * (1 - d), 30)) for g in gammas]
    E = [r["energy_ratio"] for r in res]
    assert all(b < a for a, b in zip(E, E[1:]))          # energy decreases with gamma
    back = [-r["v1"] for r in res]
    k = back.index(max(back))
    assert 0 < k < len(back) - 1                          # an interior optimal gamma
    assert all(b > a for a, b in zip(back[:k], back[1:k + 1]))
    assert all(b < a for a, b in zip(back[k:], back[k + 1:]))
