"""The restitution theory (granular_chain.restitution) against itself, the literature and mpmath.

Closed forms for n = 2 against the independent high-precision integration, the
Schwager-Poeschel piecewise form, the inverse c(e), the undamped Hertz contact, the
viscoelastic series slope and the static column.
"""
import math

import mpmath as mp
import numpy as np
import pytest

from granular_chain import restitution as R

# A contact with nothing set to 1: the closed forms must not depend on v.
K, M, V = 3.7, 0.45, 2.3
C_CRIT = 2 * math.sqrt(K * M)


# (tensile, b = 1e3) is left out: the overlap never returns to zero and the explicit
# Taylor reference, stiff there (steps ~ 1/b), would take minutes to reach t_max.
@pytest.mark.parametrize("tensile, b", [(t, b) for t in (True, False) for b in (0.05, 0.5, 0.9, 1.0, 2.5)]
                         + [(False, 1e3)])
def test_linear_dashpot_closed_form_matches_reference(tensile, b):
    """n = 2: e and t_c, float to 1e-14 and mpmath to 1e-30, under/critical/over-damped."""
    c = b * C_CRIT
    ref = R.restitution_reference(V, K, M, 2, "linear", c, tensile, dps=40, t_max=40)
    exact = R.linear_dashpot(c, K, M, tensile, dps=40)
    flt = R.linear_dashpot(c, K, M, tensile)
    assert ref.ended == exact.ended == flt.ended == (not tensile or b < 1)
    if not ref.ended:  # tensile, b >= 1: the overlap never returns to zero
        assert exact.e == flt.e == ref.e == 0 and flt.contact_time == math.inf
        return
    with mp.workdps(40):
        assert abs(ref.e - exact.e) < 1e-30 * exact.e
        assert abs(ref.contact_time - exact.contact_time) < 1e-30 * exact.contact_time
    assert flt.e == pytest.approx(float(exact.e), rel=1e-14, abs=0)
    assert flt.contact_time == pytest.approx(float(exact.contact_time), rel=1e-14, abs=0)


@pytest.mark.parametrize("tensile", [True, False])
def test_viscoelastic_at_n2_is_the_linear_dashpot(tensile):
    """n = 2: A d/dt(k xi) = (A k) xi', so the viscoelastic reference is the c = A k closed form."""
    A = 0.1
    ref = R.restitution_reference(V, K, M, 2, "viscoelastic", A, tensile, dps=40)
    with mp.workdps(40):
        exact = R.linear_dashpot(mp.mpf(A) * mp.mpf(K), K, M, tensile, dps=40)
        assert abs(ref.e - exact.e) < 1e-30 * exact.e
        assert abs(ref.contact_time - exact.contact_time) < 1e-30 * exact.contact_time


def _schwager_poeschel(beta, w0):
    """Force-zero e of the linear dashpot, piecewise in beta as in Granular Matter 9, 465 (2007).

    Evaluated with mpmath (30 digits): for beta >> w0, beta - W cancels in float64.
    """
    with mp.workdps(30):
        beta, w0 = mp.mpf(beta), mp.mpf(w0)
        if beta < w0 / mp.sqrt(2):
            w = mp.sqrt(w0 ** 2 - beta ** 2)
            e = mp.exp(-beta / w * (mp.pi - mp.atan(2 * beta * w / (w0 ** 2 - 2 * beta ** 2))))
        elif beta < w0:
            w = mp.sqrt(w0 ** 2 - beta ** 2)
            e = mp.exp(-beta / w * mp.atan(2 * beta * w / (2 * beta ** 2 - w0 ** 2)))
        else:
            W = mp.sqrt(beta ** 2 - w0 ** 2)
            e = mp.exp(-beta / W * mp.log((beta + W) / (beta - W)))
        return float(e)


@pytest.mark.parametrize("b", [1e-6, 0.1, 0.5, 0.7, 0.75, 0.95, 1.3, 10.0, 1e3])
def test_force_zero_matches_piecewise_arctan_form(b):
    w0 = math.sqrt(K / M)
    e = R.linear_dashpot(b * C_CRIT, K, M, tensile=False).e
    assert e == pytest.approx(_schwager_poeschel(b * w0, w0), rel=1e-13, abs=0)


def test_force_zero_special_values():
    """Critical damping: t_c = 2/w0 and e = e^-2; b = 1/sqrt 2: t_c = pi/(2 w)."""
    w0 = math.sqrt(K / M)
    crit = R.linear_dashpot(C_CRIT, K, M)
    assert crit.e == pytest.approx(math.exp(-2), rel=1e-15)
    assert crit.contact_time == pytest.approx(2 / w0, rel=1e-15)
    mid = R.linear_dashpot(C_CRIT / math.sqrt(2), K, M)
    assert mid.contact_time == pytest.approx(math.pi / 2 / (w0 / math.sqrt(2)), rel=1e-14)
    # b -> 1 from either side is continuous (no cancellation in the formulas)
    for b in (1 - 1e-9, 1 + 1e-9):
        assert R.linear_dashpot(b * C_CRIT, K, M).e == pytest.approx(math.exp(-2), rel=2e-9)


@pytest.mark.parametrize("tensile", [True, False])
@pytest.mark.parametrize("e", [1e-6, 0.01, 0.1, math.exp(-2), 0.5, 0.9, 1 - 1e-9])
def test_choose_damping_round_trip(e, tensile):
    c = R.choose_damping(e, K, M, tensile)
    assert R.linear_dashpot(c, K, M, tensile).e == pytest.approx(e, rel=1e-13, abs=0)
    if tensile:
        assert c < C_CRIT


def test_choose_damping_edges():
    assert R.choose_damping(1.0, K, M) == 0.0
    for bad in (0.0, -0.1, 1.5):
        with pytest.raises(ValueError):
            R.choose_damping(bad, K, M)
    # ending at zero force spares the dashpot's final pull, so a given c gives a larger e
    # and a target e needs a larger c than when tensile; below e^-2 it is overdamped
    assert R.choose_damping(0.5, K, M, False) > R.choose_damping(0.5, K, M, True)
    assert R.choose_damping(0.1, K, M, False) > C_CRIT > R.choose_damping(0.2, K, M, False)


def _hertz_constant_by_quadrature():
    """2 int_0^Xm dX / sqrt(1 - (4/5) X^(5/2)), Xm = (5/4)^(2/5): the undamped Hertz t_c/tau_u.

    With X = Xm (1 - s^2) the integrand 2 Xm 2 s / sqrt(1 - (1 - s^2)^(5/2)) is smooth.
    """
    xm = (mp.mpf(5) / 4) ** (mp.mpf(2) / 5)
    f = lambda s: 2 * s / mp.sqrt(-mp.expm1(mp.mpf(2.5) * mp.log1p(-s ** 2)))
    return 2 * xm * mp.quad(f, [0, 1])


@pytest.mark.parametrize("tensile", [True, False])
def test_undamped_hertz_is_elastic_and_lasts_the_hertz_time(tensile):
    ref = R.restitution_reference(0.7, 2.0, 0.5, 2.5, "linear", 0.0, tensile, dps=35)
    with mp.workdps(35):
        assert abs(ref.e - 1) < 1e-25
        t_hertz = R.hertz_contact_time(0.7, 2.0, 0.5)
        assert abs(ref.contact_time / t_hertz - 1) < 1e-25
        m, k, v = mp.mpf(0.5), mp.mpf(2.0), mp.mpf(0.7)
        const = t_hertz / (m ** 2 / (k ** 2 * v)) ** (mp.mpf(1) / 5)
        assert abs(const - _hertz_constant_by_quadrature()) < 1e-25
        assert abs(const - mp.mpf("3.2180654597190430845")) < 1e-18


def test_viscoelastic_c1_closed_form():
    """C1 (Gamma functions) = first-order energy loss along the elastic orbit; = 1.15344."""
    with mp.workdps(30):
        xm = (mp.mpf(5) / 4) ** (mp.mpf(2) / 5)
        loss = 3 * mp.quad(lambda x: mp.sqrt(x) * mp.sqrt(1 - mp.mpf(4) / 5 * x ** mp.mpf(2.5)), [0, xm])
        c1 = R.viscoelastic_c1_exact()
        assert abs(loss / mp.mpf(1.5) - c1) < 1e-25
        assert abs(c1 - R.VISCOELASTIC_C1) < 1e-5      # the paper's digits
        assert abs(mp.mpf(3) / 5 * c1 ** 2 - R.VISCOELASTIC_C2) < 1e-5


@pytest.mark.parametrize("tensile", [False, True])
def test_viscoelastic_series_slope_from_reference(tensile):
    """(1 - e)/G -> C1 over impact speeds spanning 20 decades; the G^2 term is C2 = (3/5) C1^2.

    G = (3/2) A (k/m)^(2/5) v^(1/5); the reference is integrated at each speed, nothing
    is fitted: (C1 - (1-e)/G)/G must tend to C2 as G -> 0, with an O(G) remainder when
    the contact ends at xi = 0 and an O(G^(1/2)) one when it ends at zero force
    (delayed recovery enters e at order G^(5/2)).
    """
    k, m, A = 2.0, 0.5, 1e-3
    with mp.workdps(30):
        c1 = R.viscoelastic_c1_exact()
        c2_exact = 3 * c1 ** 2 / 5
        for v in (1e5, 1.0, 1e-5, 1e-10, 1e-15):
            G = mp.mpf(1.5) * 1e-3 * (mp.mpf(k) / m) ** 0.4 * mp.mpf(v) ** 0.2
            e = R.restitution_reference(v, k, m, 2.5, "viscoelastic", A, tensile, dps=25).e
            slope = (1 - e) / G
            c2 = (c1 - slope) / G
            # measured remainders: tensile -0.523 G, force-zero +(0.17..0.266) G^(1/2)
            tol = 0.6 * G if tensile else 0.3 * G ** 0.5
            assert abs(c2 - c2_exact) < tol, (v, G, slope, c2)
            series = R.viscoelastic_series(v, k, A, m)
            # measured |series - e| <= 0.27 G^(5/2) (+ float roundoff)
            assert abs(series - float(e)) < 0.3 * G ** 2.5 + 2e-16, (v, series, e)
        assert G < 3e-6 and abs(slope - R.VISCOELASTIC_C1) < 1e-5  # the paper's digits
        assert abs(G - float(R.viscoelastic_group(v, k, A, m))) < 1e-15 * G


def test_reference_precision_other_exponent():
    """n = 7/3 viscoelastic, force-zero: 30 and 45 digits agree to 1e-25 (a non-analytic start)."""
    a = R.restitution_reference(1.3, 1.1, 0.8, 7 / 3, "viscoelastic", 0.2, False, dps=30)
    b = R.restitution_reference(1.3, 1.1, 0.8, 7 / 3, "viscoelastic", 0.2, False, dps=45)
    assert abs(a.e - b.e) < 1e-25 and abs(a.contact_time - b.contact_time) < 1e-25
    assert 0.5 < a.e < 0.8


def test_reference_refuses_bad_input():
    with pytest.raises(NotImplementedError):
        R.restitution_reference(1, 1, 1, math.pi)
    with pytest.raises(ValueError):
        R.restitution_reference(1, 1, 1, 2, "coulomb", 0.1)
    with pytest.raises(ValueError):
        R.restitution_reference(1, 1, 1, 2, "linear", -0.1)


def test_column_overlaps():
    N, m, g, k, n = 5, 0.2, 9.81, 1e4, 2.5
    d = R.column_overlaps(N, m, g, k, n)
    i = np.arange(1, N + 1)
    np.testing.assert_allclose(d, (i * m * g / k) ** (1 / (n - 1)), rtol=1e-15)
    # every contact carries the weight above it: k d^(n-1) = load
    np.testing.assert_allclose(k * d ** (n - 1), i * m * g, rtol=1e-14)
    masses = np.array([1.0, 2.0, 3.0])
    np.testing.assert_allclose(R.column_overlaps(3, masses, g, 5.0, 2.0), np.array([1, 3, 6]) * g / 5.0,
                               rtol=1e-15)
