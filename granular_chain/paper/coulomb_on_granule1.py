"""Sec. II B of the paper: kinetic friction ``eta`` on granule 1, frictionless granule 2.

Granule 1 slows down and stops at ``t0`` while the contact is still
compressed; it then sticks or slides back, and the collision ends with or
without backscattering. Closed forms as printed (small-eta approximations
among them), their exact counterparts (mpmath), and the exact thresholds: the
slip limit 0.4440... (printed 0.439), the end of backscattering 0.2196...
(printed ~0.22) and the largest backscattering, 3.1 % at eta = 0.094. Scaled
units (Appendix A).
"""
from __future__ import annotations

import mpmath

from .arithmetic import arithmetic_for
from .roots import bracket_root, first_root_after, golden_min

__all__ = ["iib_x1", "iib_x2", "iib_v1", "iib_v2", "iib_t0_small_eta",
           "iib_t0_small_eta_next_order", "iib_t0_exact", "iib_t0prime_exact",
           "iib_initial_conditions_small_eta", "iib_initial_conditions_exact",
           "iib_slip_force_printed", "iib_slip_critical_eta_printed",
           "iib_slip_critical_eta_exact", "iib_t1_small_eta", "iib_t1_small_eta_next_order",
           "iib_back_sliding_overlap", "iib_back_sliding_v1", "iib_collision_exact",
           "iib_backscatter_threshold_eta_exact",
           "iib_max_backscatter_exact"]


def iib_x1(t, eta):
    """Sec. II B Eq. (``eq:x1model2``), as printed (exact while v1 > 0).

    ``x1(t) = 1/4 [ -eta + 2t - eta t^2 + eta cos(sqrt2 t) + sqrt2 sin(sqrt2 t) ]``.

    Parameters
    ----------
    t : float, ndarray or mpf
        Scaled time, ``0 <= t <= t0`` (granule 1 still moving forward).
    eta : float or mpf
        Scaled friction of granule 1.

    Returns
    -------
    Same type as ``t``
    """
    arith = arithmetic_for(t, eta)
    t, eta = arith.num(t), arith.num(eta)
    r2 = arith.sqrt(arith.num(2))
    return (-eta + 2 * t - eta * t**2 + eta * arith.cos(r2 * t) + r2 * arith.sin(r2 * t)) / 4


def iib_x2(t, eta):
    """Sec. II B Eq. (``eq:x2model2``), as printed (exact while v1 > 0).

    ``x2(t) = 1/4 [ eta + 2t - eta t^2 - eta cos(sqrt2 t) - sqrt2 sin(sqrt2 t) ]``.

    Parameters
    ----------
    t : float, ndarray or mpf
        Time since first contact, units of ``B``.
    eta : float, ndarray or mpf
        Kinetic friction force on granule 1, scaled (units of ``m v0^2/A``).

    Returns
    -------
    same type as ``t``
        Position of granule 2 from its start, units of ``A``.
    """
    arith = arithmetic_for(t, eta)
    t, eta = arith.num(t), arith.num(eta)
    r2 = arith.sqrt(arith.num(2))
    return (eta + 2 * t - eta * t**2 - eta * arith.cos(r2 * t) - r2 * arith.sin(r2 * t)) / 4


def iib_v1(t, eta):
    """Sec. II B, printed ``v1(t) = 1/4 [2 - 2 eta t + 2 cos(sqrt2 t) - sqrt2 eta sin(sqrt2 t)]`` (exact).

    Parameters
    ----------
    t : float, ndarray or mpf
        Time since first contact, units of ``B``.
    eta : float, ndarray or mpf
        Kinetic friction force on granule 1, scaled (units of ``m v0^2/A``).

    Returns
    -------
    same type as ``t``
        Velocity of granule 1, units of ``v0``.
    """
    arith = arithmetic_for(t, eta)
    t, eta = arith.num(t), arith.num(eta)
    r2 = arith.sqrt(arith.num(2))
    return (2 - 2 * eta * t + 2 * arith.cos(r2 * t) - r2 * eta * arith.sin(r2 * t)) / 4


def iib_v2(t, eta):
    """Derivative of Eq. (``eq:x2model2``) (not printed).

    ``v2(t) = 1/4 [2 - 2 eta t - 2 cos(sqrt2 t) + sqrt2 eta sin(sqrt2 t)]``.

    Parameters
    ----------
    t : float, ndarray or mpf
        Time since first contact, units of ``B``.
    eta : float, ndarray or mpf
        Kinetic friction force on granule 1, scaled (units of ``m v0^2/A``).

    Returns
    -------
    same type as ``t``
        Velocity of granule 2, units of ``v0``.
    """
    arith = arithmetic_for(t, eta)
    t, eta = arith.num(t), arith.num(eta)
    r2 = arith.sqrt(arith.num(2))
    return (2 - 2 * eta * t - 2 * arith.cos(r2 * t) + r2 * eta * arith.sin(r2 * t)) / 4


def iib_t0_small_eta(eta):
    """Sec. II B Eq. (``eq:t0model2``): ``t0 = pi/sqrt2 - (pi eta/sqrt2)^(1/2) + O(eta^(3/2))``.

    Stopping time of granule 1.  Verdict: correct to the stated order; our
    expansion gives the next term ``-(pi eta/sqrt2)^(3/2)/12``
    (:func:`iib_t0_small_eta_next_order`).

    Parameters
    ----------
    eta : float, ndarray or mpf
        Kinetic friction force on granule 1, scaled (units of ``m v0^2/A``).

    Returns
    -------
    Same type as ``eta``
    """
    arith = arithmetic_for(eta)
    eta = arith.num(eta)
    r2 = arith.sqrt(arith.num(2))
    return arith.pi() / r2 - arith.sqrt(arith.pi() * eta / r2)


def iib_t0_small_eta_next_order(eta):
    """Eq. (``eq:t0model2``) with the next term (derived here, not printed).

    With ``a = pi eta / sqrt2``, ``t0 = pi/sqrt2 - a^(1/2) - a^(3/2)/12 + O(eta^(5/2))``
    (expand ``4 v1`` about ``pi/sqrt2``: ``2 tau^2 - sqrt2 pi eta - tau^4/3 + O(eta tau^3) = 0``).

    Parameters
    ----------
    eta : float, ndarray or mpf
        Kinetic friction force on granule 1, scaled (units of ``m v0^2/A``).

    Returns
    -------
    same type as ``eta``
        Stopping time of granule 1, units of ``B``.
    """
    arith = arithmetic_for(eta)
    eta = arith.num(eta)
    r2 = arith.sqrt(arith.num(2))
    a = arith.pi() * eta / r2
    return arith.pi() / r2 - arith.sqrt(a) - a * arith.sqrt(a) / 12


def iib_t0_exact(eta, dps=30):
    """Exact stopping time of granule 1 in Sec. II B: first root of the printed ``v1(t)``.

    ``v1`` decreases strictly while granule 1 slides forward, ``v1(0) = 1`` and
    ``v1(pi/sqrt2) = -sqrt2 pi eta / 4 < 0``, so the root is unique in ``(0, pi/sqrt2)``.

    Parameters
    ----------
    eta : float or mpf, > 0
        Kinetic friction force on granule 1, scaled (units of ``m v0^2/A``).
    dps : int
        Decimal digits.

    Returns
    -------
    mpf
    """
    with mpmath.workdps(dps + 10):
        e = mpmath.mpf(eta)
        t0 = bracket_root(lambda t: iib_v1(t, e), mpmath.mpf(0), mpmath.pi / mpmath.sqrt(2))
    return +t0


def iib_t0prime_exact(eta, dps=30):
    """Sec. II B: time ``t0'`` at which ``x1 = x2`` if Eqs. (x1model2, x2model2) stayed valid.

    Closed form (derived here): ``x1 - x2 = sin(theta)/sqrt2 - eta/2 (1 - cos theta)``,
    ``theta = sqrt2 t``, vanishes at ``tan(theta/2) = sqrt2/eta``:
    ``t0' = sqrt2 * arctan(sqrt2/eta)``.  Limits: ``pi/sqrt2`` as eta -> 0 and
    ``2/eta`` as eta -> infinity, as the paper states; the paper's claim that
    ``t0' > t0`` for all eta is checked in the tests.

    Parameters
    ----------
    eta : float or mpf, > 0
        Kinetic friction force on granule 1, scaled (units of ``m v0^2/A``).
    dps : int
        Decimal digits of the mpmath computation.

    Returns
    -------
    mpf
    """
    with mpmath.workdps(dps + 10):
        e = mpmath.mpf(eta)
        r = mpmath.sqrt(2) * mpmath.atan(mpmath.sqrt(2) / e)
    return +r


def iib_initial_conditions_small_eta(eta):
    """Sec. II B Eqs. (``ic1``)-(``ic4``), as printed (small-eta approximation).

    ``x1(t0) = [2 sqrt2 pi - (pi^2 + 4) eta] / 8``,
    ``x2(t0) = [2 sqrt2 pi - 4 (2^(3/4)) sqrt(pi eta) - (pi^2 - 4) eta] / 8``,
    ``v1(t0) = 0``, ``v2(t0) = [2 - sqrt2 pi eta] / 2``.

    Verdict: correct, each with error ``O(eta^(3/2))`` (the coefficient
    ``4 * 2^(3/4) = 8 * 2^(-1/4)`` is right: ``8 (pi eta/sqrt2)^(1/2)``).  With
    ``a = pi eta/sqrt2`` our expansion gives printed minus exact:
    ``x1: -a^(3/2)/3``, ``x2: -7 a^(3/2)/12``, ``v2: -eta a^(1/2)``, each + O(eta^2).

    Parameters
    ----------
    eta : float, ndarray or mpf
        Kinetic friction force on granule 1, scaled (units of ``m v0^2/A``).

    Returns
    -------
    tuple
        ``(x1, x2, v1, v2)`` at ``t = t0``.
    """
    arith = arithmetic_for(eta)
    eta = arith.num(eta)
    pi = arith.pi()
    r2 = arith.sqrt(arith.num(2))
    x1 = (2 * r2 * pi - (pi**2 + 4) * eta) / 8
    x2 = (2 * r2 * pi - 4 * arith.num(2) ** arith.num(0.75) * arith.sqrt(pi * eta) - (pi**2 - 4) * eta) / 8
    v2 = (2 - r2 * pi * eta) / 2
    return x1, x2, 0 * eta, v2


def iib_initial_conditions_exact(eta, dps=30):
    """Exact ``(x1, x2, v1, v2)`` at the exact stopping time of granule 1 (Sec. II B).

    Printed Eqs. (x1model2, x2model2) at :func:`iib_t0_exact`; ``v2 = 1 - eta t0``
    (momentum balance: ``(x1+x2)'' = -eta`` while granule 1 slides forward).

    Parameters
    ----------
    eta : float, ndarray or mpf
        Kinetic friction force on granule 1, scaled (units of ``m v0^2/A``).
    dps : int
        Decimal digits of the mpmath computation.

    Returns
    -------
    tuple of mpf
    """
    with mpmath.workdps(dps + 10):
        e = mpmath.mpf(eta)
        t0 = iib_t0_exact(e, dps + 10)
        out = (iib_x1(t0, e), iib_x2(t0, e), mpmath.mpf(0), 1 - e * t0)
    return tuple(+v for v in out)


def iib_slip_force_printed(eta):
    """Sec. II B slip condition, left-hand side as printed.

    ``[x1(t0) - x2(t0)] = 1/2 [ -eta - eta cos(2^(1/4) sqrt(eta pi)) + sqrt2 sin(2^(1/4) sqrt(eta pi)) ]``;
    granule 1 slides back iff this exceeds ``eta``.

    It is the exact phase-1 spring force ``x1 - x2`` evaluated at the *small-eta*
    ``t0`` of Eq. (t0model2) (``sqrt2 (pi eta/sqrt2)^(1/2) = 2^(1/4) sqrt(pi eta)``).
    Verdict: approximate; printed minus exact force is ``-a^(3/2)/12 + O(eta^2)``,
    ``a = pi eta/sqrt2`` (the printed ``t0`` is late by ``a^(3/2)/12`` and
    ``u' = -v2 = -1 + O(eta)`` there).

    Parameters
    ----------
    eta : float, ndarray or mpf
        Kinetic friction force on granule 1, scaled (units of ``m v0^2/A``).

    Returns
    -------
    Same type as ``eta``
    """
    arith = arithmetic_for(eta)
    eta = arith.num(eta)
    p = arith.num(2) ** arith.num(0.25) * arith.sqrt(eta * arith.pi())
    return (-eta - eta * arith.cos(p) + arith.sqrt(arith.num(2)) * arith.sin(p)) / 2


def iib_slip_critical_eta_printed(dps=30):
    """Sec. II B: critical ``eta = 0.439...`` of the printed slip condition.

    Root of ``iib_slip_force_printed(eta) = eta``: 0.438861157...  It reproduces
    the printed 0.439, but only for the approximated force; the exact threshold is
    :func:`iib_slip_critical_eta_exact` = 0.444021... (erratum: 1.2 % low).

    Parameters
    ----------
    dps : int
        Decimal digits of the mpmath computation.

    Returns
    -------
    mpf
    """
    with mpmath.workdps(dps + 10):
        r = bracket_root(lambda e: iib_slip_force_printed(e) - e, mpmath.mpf("0.3"), mpmath.mpf("0.6"))
    return +r


def iib_slip_critical_eta_exact(dps=30):
    """Corrected critical friction for back-sliding of granule 1 (Sec. II B).

    Root of ``u(t0(eta)) = eta`` with the exact stopping time ``t0`` and the exact
    phase-1 force ``u = x1 - x2``: ``eta_c = 0.4440212486825...``.  Granule 1 slides
    back for ``eta < eta_c`` and sticks for ``eta >= eta_c`` (the printed 0.439 is
    the root of the small-eta approximation of the force).

    Parameters
    ----------
    dps : int
        Decimal digits of the mpmath computation.

    Returns
    -------
    mpf
    """
    with mpmath.workdps(dps + 10):
        def g(e):
            t0 = iib_t0_exact(e, dps + 10)
            return iib_x1(t0, e) - iib_x2(t0, e) - e
        r = bracket_root(g, mpmath.mpf("0.3"), mpmath.mpf("0.6"))
    return +r


def iib_t1_small_eta(eta):
    """Sec. II B Eq. (``omega1``): ``t1 = (pi eta/sqrt2)^(1/2) - eta + O(eta^(3/2))``.

    Duration of the back-sliding phase (from the stop of granule 1 to separation)
    assuming granule 1 still slides back at separation.  Verdict: correct to the
    stated order; our expansion gives ``t1 = a^(1/2) - eta + a^(3/2)/12 + O(eta^2)``,
    ``a = pi eta/sqrt2`` (:func:`iib_t1_small_eta_next_order`).

    Parameters
    ----------
    eta : float, ndarray or mpf
        Kinetic friction force on granule 1, scaled (units of ``m v0^2/A``).

    Returns
    -------
    Same type as ``eta``
    """
    arith = arithmetic_for(eta)
    eta = arith.num(eta)
    return arith.sqrt(arith.pi() * eta / arith.sqrt(arith.num(2))) - eta


def iib_t1_small_eta_next_order(eta):
    """Eq. (``omega1``) with the next term (derived here, not printed).

    ``t1 = a^(1/2) - eta + a^(3/2)/12 + O(eta^2)``, ``a = pi eta/sqrt2``: solve
    ``u(t1) = 0`` with ``u0 = a^(1/2) - eta - a^(3/2)/4``, ``v2(t0) = 1 - a + eta a^(1/2)``.

    Parameters
    ----------
    eta : float, ndarray or mpf
        Kinetic friction force on granule 1, scaled (units of ``m v0^2/A``).

    Returns
    -------
    same type as ``eta``
        Back-sliding time ``t1`` after the stop, units of ``B``.
    """
    arith = arithmetic_for(eta)
    eta = arith.num(eta)
    a = arith.pi() * eta / arith.sqrt(arith.num(2))
    return arith.sqrt(a) - eta + a * arith.sqrt(a) / 12


def iib_back_sliding_overlap(tp, eta, u0, v20):
    """Sec. II B Eqs. (``motionx1``, ``motionx2``): overlap ``u = x1 - x2`` while granule 1
    slides back (derived here; exact).

    ``u(t') = eta/2 + (u0 - eta/2) cos(sqrt2 t') - v20/sqrt2 sin(sqrt2 t')``, ``t' = t - t0``.

    Parameters
    ----------
    tp : float or mpf
        Time since granule 1 stopped, ``t' = t - t0``.
    eta : float or mpf
        Scaled friction of granule 1.
    u0, v20 : float or mpf
        Overlap and velocity of granule 2 when granule 1 stopped (``u0 > eta``).

    Returns
    -------
    Same type as ``tp``
    """
    arith = arithmetic_for(tp, eta, u0, v20)
    r2 = arith.sqrt(arith.num(2))
    return eta / 2 + (u0 - eta / 2) * arith.cos(r2 * tp) - v20 / r2 * arith.sin(r2 * tp)


def iib_back_sliding_v1(tp, eta, u0, v20):
    """Velocity of granule 1 while it slides back (Sec. II B, derived here; exact).

    ``v1(t') = [v20 (1 - cos(sqrt2 t')) + eta t' - sqrt2 (u0 - eta/2) sin(sqrt2 t')]/2``;
    arguments as :func:`iib_back_sliding_overlap`. Its first positive root is the time
    granule 1 would stop again (the dashed curve of Fig. ``timecompare3``).

    Parameters
    ----------
    tp : float, ndarray or mpf
        Time since the phase began, ``t' = t - t0``, units of ``B``.
    eta : float, ndarray or mpf
        Kinetic friction force on granule 1, scaled (units of ``m v0^2/A``).
    u0, v20 : float or mpf
        Overlap (units of ``A``) and velocity of granule 2 (units of ``v0``) when granule 1 stopped.

    Returns
    -------
    same type as ``tp``
        Velocity of granule 1, units of ``v0``.
    """
    arith = arithmetic_for(tp, eta, u0, v20)
    r2 = arith.sqrt(arith.num(2))
    return (v20 * (1 - arith.cos(r2 * tp)) + eta * tp
            - r2 * (u0 - eta / 2) * arith.sin(r2 * tp)) / 2


def iib_collision_exact(eta, dps=30):
    """Exact solution of the Sec. II B problem (friction ``eta`` on granule 1 only).

    Closed-form phases, derived here independently of the generic solver:

    1. ``t < t0``: printed Eqs. (x1model2, x2model2); ``t0`` = :func:`iib_t0_exact`.
    2. If ``u0 = x1-x2 > eta`` at ``t0``: Eqs. (motionx1, motionx2) for ``t' = t - t0``,
       ``u(t') = eta/2 + (u0 - eta/2) cos(sqrt2 t') - v20/sqrt2 sin(sqrt2 t')``,
       ``v1(t') = [v20 (1 - cos(sqrt2 t')) + eta t' - sqrt2 (u0 - eta/2) sin(sqrt2 t')]/2``.
       ``t1`` is the first root of ``u``; ``t_stop`` the first root of ``v1`` (the
       granule-1 stopping time of the dashed curve of Fig. timecompare3).
    3. If granule 1 is at rest (stuck) while in contact, granule 2 (frictionless)
       leaves with ``v2 = sqrt(v2^2 + u^2)`` (spring energy), after ``atan(u/v2)``.

    Parameters
    ----------
    eta : float or mpf, > 0
        Kinetic friction force on granule 1, scaled (units of ``m v0^2/A``).
    dps : int
        Decimal digits of the mpmath computation.

    Returns
    -------
    dict
        ``t0``, ``u0``, ``v20`` (state at the stop), ``slides_back`` (bool),
        ``t1`` and ``t_stop`` (phase-2 times after ``t0``, mpf; ``None`` when
        ``slides_back`` is False), ``v1s``, ``v2s``, ``energy_ratio``,
        ``t_separation`` (from ``t = 0``), all mpf.
    """
    with mpmath.workdps(dps + 10):
        e = mpmath.mpf(eta)
        r2 = mpmath.sqrt(2)
        t0 = iib_t0_exact(e, dps + 10)
        u0 = iib_x1(t0, e) - iib_x2(t0, e)
        v20 = 1 - e * t0
        out = {"t0": t0, "u0": u0, "v20": v20, "slides_back": bool(u0 > e),
               "t1": None, "t_stop": None}
        if u0 > e:
            def u(tp):
                return iib_back_sliding_overlap(tp, e, u0, v20)

            def v1(tp):
                return iib_back_sliding_v1(tp, e, u0, v20)

            # u decreases from u0 > 0 to its minimum eta/2 - sqrt(A^2 + v20^2/2) < 0
            # at theta = pi - psi, A = u0 - eta/2
            psi = mpmath.atan2(v20 / r2, u0 - e / 2)
            t1 = bracket_root(u, mpmath.mpf(0), (mpmath.pi - psi) / r2)
            # v1 < 0 just after 0 and v1(theta = 2 pi) = eta pi > 0
            t_stop = first_root_after(v1, mpmath.pi * r2, mpmath.mpf(1) / 64)
            out["t1"], out["t_stop"] = t1, t_stop
            if t_stop > t1:
                v1s = v1(t1)
                v2s = v20 + e * t1 - v1s
                t_sep = t0 + t1
            else:
                v2 = v20 + e * t_stop
                us = u(t_stop)
                v1s = mpmath.mpf(0)
                v2s = mpmath.sqrt(v2**2 + us**2)
                t_sep = t0 + t_stop + mpmath.atan2(us, v2)
        else:
            v1s = mpmath.mpf(0)
            v2s = mpmath.sqrt(v20**2 + u0**2)
            t_sep = t0 + mpmath.atan2(u0, v20)
        out.update(v1s=v1s, v2s=v2s, energy_ratio=v1s**2 + v2s**2, t_separation=t_sep)
        out = {k: (+v if isinstance(v, mpmath.mpf) else v) for k, v in out.items()}
    return out


def iib_backscatter_threshold_eta_exact(dps=30):
    """Sec. II B claim "backscattering (and propagation) if eta <~ 0.22", exact value.

    Root of ``t_stop(eta) = t1(eta)`` (granule 1 stops exactly at separation):
    ``eta_b = 0.2195624104...``.  Verdict: the printed ``~0.22`` is right to its 2 digits.

    Parameters
    ----------
    dps : int
        Decimal digits of the mpmath computation.

    Returns
    -------
    mpf
    """
    with mpmath.workdps(dps + 10):
        def g(e):
            c = iib_collision_exact(e, dps + 10)
            return c["t_stop"] - c["t1"]
        r = bracket_root(g, mpmath.mpf("0.15"), mpmath.mpf("0.3"))
    return +r


def iib_max_backscatter_exact(dps=20):
    """Sec. II B claim: the backward speed of granule 1 peaks at "approximately 3%".

    Golden-section maximisation of ``-v1^(s)(eta)`` from :func:`iib_collision_exact`.

    Parameters
    ----------
    dps : int
        Decimal digits of the mpmath computation.

    Returns
    -------
    (mpf, mpf)
        ``(eta_star, -v1s_max)`` = ``(0.094024..., 0.0311918...)``: 3.1 % of the
        initial velocity (the printed "approximately 3%" is right).
    """
    with mpmath.workdps(dps + 10):
        def f(e):
            return iib_collision_exact(e, dps)["v1s"]  # minimise v1s
        e = golden_min(f, mpmath.mpf("0.02"), mpmath.mpf("0.2"),
                       mpmath.mpf(10) ** (-(dps // 2 + 2)))
        v = -f(e)
    return +e, +v
