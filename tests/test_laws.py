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
            if c * t < 30:  # beyond, 1 - exp(-c t) rounds to 1 and t is not recoverable
                assert friction.phi1_inverse(c, p1) == pytest.approx(t, rel=1e-9)
    assert friction.phi1(0.0, 0.3) == 0.3
    assert friction.phi2(0.0, 0.3) == pytest.approx(0.045, rel=1e-15)


def _coulomb(v, F, eta, eta_s, m=1.3, gamma=0.0, h=0.05):
    c = gamma / m
    E = math.exp(-c * h)
    viscous = 1 if gamma > 0 else 0
    return friction.coulomb_kick(viscous, v, F, eta, eta_s, m, 1 / m, c, E,
                                 friction.phi1(c, h), friction.phi2(c, h), h)


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
    # Energy theorem: dKE = F * displacement + W.
    for v, F in ((0.7, -0.3), (0.01, -2.0), (-0.4, 0.1), (0.0, 1.5)):
        v1, wc, wv, code = _coulomb(v, F, 0.5, 0.6, gamma=0.8)
        # independent fine integration of m dv/dt = F - eta sgn v - gamma v with stick
        n = 200000
        dt = h / n
        vv, x, w_c, w_v = v, 0.0, 0.0, 0.0
        for _ in range(n):
            if vv == 0.0 and abs(F) <= 0.6:
                continue
            s = math.copysign(1.0, vv) if vv != 0.0 else math.copysign(1.0, F)
            a = (F - 0.5 * s - 0.8 * vv) / m
            vn = vv + a * dt
            if vv != 0.0 and vn * vv < 0:
                vn = 0.0
            x += 0.5 * (vv + vn) * dt
            w_c += -0.5 * abs(0.5 * (vv + vn)) * dt
            w_v += -0.8 * (0.5 * (vv + vn)) ** 2 * dt
            vv = vn
        assert v1 == pytest.approx(vv, abs=1e-6)
        assert wc == pytest.approx(w_c, abs=1e-7)
        assert wv == pytest.approx(w_v, abs=1e-7)


def test_viscous_kick_is_the_exponential_solution():
    m, gamma, h = 2.0, 5.0, 0.3  # gamma h / m = 0.75: explicit damping would be poor here
    c = gamma / m
    for v, F in ((1.0, 0.0), (0.3, -2.0)):
        v1, wc, wv, code = friction.viscous_kick(v, F, m, 1 / m, math.exp(-c * h),
                                                 friction.phi1(c, h), friction.phi2(c, h))
        vinf = F / gamma
        exact = vinf + (v - vinf) * math.exp(-c * h)
        assert v1 == pytest.approx(exact, rel=1e-14)
        # W = -gamma * integral v^2 dt, closed form
        a = v - vinf
        integral = vinf ** 2 * h + 2 * vinf * a * (1 - math.exp(-c * h)) / c + a * a * (1 - math.exp(-2 * c * h)) / (2 * c)
        assert wv == pytest.approx(-gamma * integral, rel=1e-12)
