"""The compiled scalar laws against calculus and exact solutions."""

import math

import numpy as np
import pytest

from granular_chain.laws import contact, friction


@pytest.mark.parametrize("law,n", [(contact.LAW_LINEAR, 2.0), (contact.LAW_HERTZ, 2.5),
                                   (contact.LAW_POWER, 3.3), (contact.LAW_POWER, 1.5)])
def test_force_is_derivative_of_energy(law, n):
    # A central difference of V differs from V' by h^2 V3(xi)/6 (truncation, V3
    # the third derivative) plus at most ~2 eps |V| / h (rounding): the bound.
    k = 1.7
    eps = np.finfo(float).eps
    for d in (0.05, 0.3, 0.9):
        h = 1e-5
        num = (contact.contact_energy(law, d + h, k, n) - contact.contact_energy(law, d - h, k, n)) / (2 * h)
        exact = contact.contact_force(law, d, k, n)
        v3 = max(abs(k * (n - 1) * (n - 2) * (d + s) ** (n - 3)) for s in (-h, h))
        bound = h * h * v3 / 6 + 4 * eps * contact.contact_energy(law, d + h, k, n) / h
        assert abs(num - exact) <= bound
        assert exact == pytest.approx(k * d ** (n - 1), rel=1e-15)


@pytest.mark.parametrize("law", [contact.LAW_LINEAR, contact.LAW_HERTZ, contact.LAW_POWER])
def test_no_attraction_ever(law):
    for d in (-1.0, -1e-12, 0.0):
        assert contact.contact_force(law, d, 1.0, 2.5 if law else 2.0) == 0.0
        assert contact.contact_energy(law, d, 1.0, 2.5 if law else 2.0) == 0.0


def test_phi_functions_match_their_definitions():
    for c in (1e-9, 1e-4, 0.3, 2.0, 50.0):
        for t in (1e-3, 0.1, 1.0):
            p1 = friction.phi1(c, t)
            assert p1 == pytest.approx(-math.expm1(-c * t) / c, rel=1e-15)
            # phi2 = integral_0^t phi1: check with a high-order quadrature
            xs, ws = np.polynomial.legendre.leggauss(30)
            tt = 0.5 * t * (xs + 1)
            quad = 0.5 * t * np.sum(ws * (-np.expm1(-c * tt) / c))
            assert friction.phi2(c, t) == pytest.approx(quad, rel=2e-14)
    assert friction.phi1(0.0, 0.3) == 0.3
    assert friction.phi2(0.0, 0.3) == pytest.approx(0.045, rel=1e-15)


def _coulomb(v, F, eta, eta_s, m=1.3, h=0.05):
    return friction.coulomb_kick(v, F, eta, eta_s, 1 / m, h)


def test_coulomb_kick_sliding_stopping_sticking_reversing():
    m, h = 1.3, 0.05
    # Sliding without stopping: v + h (F - eta)/m, work -eta * distance.
    v1, wc, wv, code = _coulomb(1.0, 0.2, 0.5, 0.5)
    assert v1 == pytest.approx(1.0 + h * (0.2 - 0.5) / m, rel=1e-15)
    assert wc == pytest.approx(-0.5 * (1.0 + v1) / 2 * h, rel=1e-14) and code == 0
    # Stops (t* = v m / (eta - F)) and sticks: |F| <= eta_s.
    v1, wc, wv, code = _coulomb(0.01, 0.2, 0.5, 0.6)
    t_stop = 0.01 * m / 0.3
    assert v1 == 0.0 and code == friction.STOPPED
    assert wc == pytest.approx(-0.5 * 0.01 * t_stop / 2, rel=1e-14)
    # Stops then reverses: the spring beats the static threshold.
    v1, wc, wv, code = _coulomb(0.01, -0.9, 0.5, 0.6)
    t_stop = 0.01 * m / 1.4
    assert v1 == pytest.approx((-0.9 + 0.5) / m * (h - t_stop), rel=1e-14)
    assert code == friction.STOPPED | friction.SLIPPED
    # At rest, below threshold: stays exactly at rest, no work.
    assert _coulomb(0.0, 0.59, 0.5, 0.6) == (0.0, 0.0, 0.0, 0)
    # Energy theorem against an independent fine integration of
    # m dv/dt = F - eta sgn v with stick (explicit, 2e5 sub-steps, error ~1e-6).
    for v, F in ((0.7, -0.3), (0.01, -2.0), (-0.4, 0.1), (0.0, 1.5)):
        v1, wc, wv, code = _coulomb(v, F, 0.5, 0.6)
        n = 200000
        dt = h / n
        vv, w_c = v, 0.0
        for _ in range(n):
            if vv == 0.0 and abs(F) <= 0.6:
                continue
            s = math.copysign(1.0, vv) if vv != 0.0 else math.copysign(1.0, F)
            vn = vv + (F - 0.5 * s) / m * dt
            if vv != 0.0 and vn * vv < 0:
                vn = 0.0
            w_c += -0.5 * abs(0.5 * (vv + vn)) * dt
            vv = vn
        assert v1 == pytest.approx(vv, abs=1e-6)
        assert wc == pytest.approx(w_c, abs=1e-7)
        assert wv == 0.0


def test_viscous_drift_is_the_exponential_solution():
    m, gamma, dt = 2.0, 50.0, 0.3  # gamma dt / m = 7.5: explicit damping would explode
    c = gamma / m
    for v in (1.0, -0.3):
        du, v1, wv = friction.viscous_drift(v, m, math.exp(-c * dt), friction.phi1(c, dt))
        assert v1 == pytest.approx(v * math.exp(-c * dt), rel=1e-15)
        assert du == pytest.approx(v * (1 - math.exp(-c * dt)) / c, rel=1e-15)
        # W = -gamma integral v^2 dt = -(m v^2 / 2)(1 - exp(-2 c dt))
        assert wv == pytest.approx(-0.5 * m * v * v * (1 - math.exp(-2 * c * dt)), rel=1e-14)
