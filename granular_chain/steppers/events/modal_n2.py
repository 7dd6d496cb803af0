"""Exact modal solution of a two-granule linear (n = 2) mode: exact near critical damping.

Why not the Taylor series here
------------------------------
A Taylor (or any) stepper rounds the state once per step. Near critical
damping (gamma^2 -> 8 for the paper's pair) the mode pair is nearly defective:
a relative perturbation eps of the state at time s reaches the answer at t0 as
a relative error ~ eps s (t0 - s), and t0 = pi/omega grows without bound
(gamma = 2.8284: t0 = 507, measured 3.4e-11). Evaluating the closed form from
the start of the mode has no such accumulation; what remains is the
conditioning of the closed form's own ingredients, handled here:

* ``D = K - c^2/4`` is formed with an exact product (Dekker's TwoProduct) and
  TwoSum, so omega = sqrt(D) keeps its relative digits when D << K (plain
  double loses them: 8 eps / (8 - gamma^2)).
* omega, omega*tau, c*tau and the event time tau are double-doubles: the
  answer decays like exp(-c tau / 2), whose relative error is (c tau / 2) times
  that of tau, 717 * eps at gamma = 2.8284 in plain double.
* ``S(tau) = sin(omega tau)/omega`` (cosh/sinh for D < 0, tau at D = 0) is the
  stable phi-function: it tends to tau as omega -> 0 with no cancellation,
  because omega itself is accurate.

The mode
--------
Granules 0 and 1, one closed linear contact (overlap delta, force k delta),
each granule either moving (frictionless, or sliding with a Coulomb force
f_i = -eta_i s_i) or stuck. With both moving and equal drag rates
c = gamma_0/m_0 = gamma_1/m_1, the relative and centre-of-mass motions decouple:

    delta'' + c delta' + K delta = b,   K = k (1/m_0 + 1/m_1),  b = f_0/m_0 - f_1/m_1
    M V' = -c M V + F,                  M = m_0 + m_1,          F = f_0 + f_1

With one granule moving (the other stuck) the same scalar equation holds for
delta with K = k/m_i, c = c_i, b = +-f_i/m_i. With y = delta - b/K,
B = w_0 + c y_0 / 2 (w = delta'):

    y(tau) = e^(-c tau/2) [y_0 C(tau) + B S(tau)]
    w(tau) = e^(-c tau/2) [w_0 C(tau) - (K y_0 + c w_0/2) S(tau)]

C = cos(omega tau), S = sin(omega tau)/omega (D > 0); cosh, sinh/kappa (D < 0);
1, tau (D = 0).
"""

import math

import numba

from ..._compile import callee
import numpy as np

PI_HI = 3.141592653589793
PI_LO = 1.2246467991473532e-16
SPLIT = 134217729.0  # 2^27 + 1

#: The mode record (one element of a structured array; the kernel keeps it in
#: ``Workspace.modal``). All fields float64, the sliding signs included, so the
#: arithmetic on them is that of plain doubles.
MODE_DTYPE = np.dtype([
    ("c", np.float64),            # drag rate gamma/m of the relative motion (1/time)
    ("k_rate", np.float64),       # K: k (1/m0 + 1/m1), or k/m_i with one granule stuck
    ("drive", np.float64),        # b: constant forcing of delta'' (Coulomb forces / masses)
    ("y0", np.float64),           # delta - b/K at the mode's start
    ("w0", np.float64),           # delta' at the mode's start
    ("d_hi", np.float64),         # D = K - c^2/4, double-double high part
    ("d_lo", np.float64),         #   and low part
    ("om_hi", np.float64),        # omega = sqrt(|D|), double-double high part
    ("om_lo", np.float64),        #   and low part
    ("v_cm0", np.float64),        # centre-of-mass velocity at the start (both moving)
    ("f_cm", np.float64),         # net friction force / total mass (both moving)
    ("case", np.float64),         # 0 both granules move, 1 only granule 0, 2 only granule 1
    ("share0", np.float64),       # m1 / M: granule 0's share of the relative motion
    ("share1", np.float64),       # m0 / M
    ("delta0", np.float64),       # overlap at the start
    ("v0_init", np.float64),      # velocities at the start (0 for a stuck granule)
    ("v1_init", np.float64),
    ("eta_s_other", np.float64),  # static threshold of the stuck granule (one moving)
    ("k_contact", np.float64),    # the contact's force coefficient k
    ("s0", np.float64),           # friction modes (2 frictionless, +-1 sliding, 0 stuck)
    ("s1", np.float64),
    ("m_total", np.float64),      # M = m0 + m1
    ("limit", np.float64),        # overlap at which the centres meet
], align=True)


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def two_sum(a, b):
    """a + b = s + e exactly (Knuth's TwoSum).

    Parameters
    ----------
    a, b : float
        The addends, any units (the same for both).

    Returns
    -------
    s, e : float
        The rounded sum and its rounding error, in the units of ``a``.
    """
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def two_prod(a, b):
    """a*b = p + e exactly (Dekker; no FMA needed).

    Parameters
    ----------
    a, b : float
        The factors, any units.

    Returns
    -------
    p, e : float
        The rounded product and its rounding error, units of ``a * b``.
    """
    p = a * b
    t = SPLIT * a
    ah = t - (t - a)
    al = a - ah
    t = SPLIT * b
    bh = t - (t - b)
    bl = b - bh
    e = ((ah * bh - p) + ah * bl + al * bh) + al * bl
    return p, e


@callee(error_model="numpy", _nrt=False)
def setup(p, coulomb, viscous, model, state):
    """Fill the mode record ``p`` of granules 0, 1 and their closed contact 1.

    Friction a feature the scene lacks (``coulomb``, ``viscous`` 0) is left out.

    Parameters
    ----------
    p : record of MODE_DTYPE
        The record written (``Workspace.modal[0]``).
    coulomb : int
        Compile-time feature code: nonzero when some granule has Coulomb friction.
    viscous : int
        Compile-time feature code: nonzero when some granule has viscous friction.
    model : ChainArrays
        The two-granule chain's constants (N = 2), kernel units.
    state : MotionState
        Its state at the mode's start (kernel units) and friction modes.

    Returns
    -------
    bool
        False when the mode is not covered (overlap negative, both granules
        stuck, both moving with unequal drag rates, or c^2 overflowing: those
        stay with the Taylor series), else True.
    """
    overlap = state.overlap
    if overlap[1] < 0.0:
        return False
    mass, eta, v, slide = model.mass, model.eta, state.v, state.slide
    m0, m1, k_contact, d0, v0, v1 = mass[0], mass[1], model.stiffness[1], overlap[1], v[0], v[1]
    g0 = model.gamma[0] if viscous else 0.0
    g1 = model.gamma[1] if viscous else 0.0
    eta0 = eta[0] if coulomb else 0.0
    eta1 = eta[1] if coulomb else 0.0
    s0 = slide[0]
    s1 = slide[1]
    eta_s_other = 0.0
    if s0 != 0 and s1 == 0:
        eta_s_other = model.eta_static[1]
    elif s0 == 0 and s1 != 0:
        eta_s_other = model.eta_static[0]
    mv0 = s0 != 0
    mv1 = s1 != 0
    f0 = -eta0 * s0 if (s0 == 1 or s0 == -1) else 0.0
    f1 = -eta1 * s1 if (s1 == 1 or s1 == -1) else 0.0
    if mv0 and mv1:
        c = g0 / m0
        if g1 / m1 != c:
            return False
        K = k_contact * (1.0 / m0 + 1.0 / m1)
        b = f0 / m0 - f1 / m1
        w0 = v0 - v1
        M = m0 + m1
        p.case = 0.0
        p.v_cm0 = (m0 * v0 + m1 * v1) / M
        p.f_cm = (f0 + f1) / M
        p.share0 = m1 / M
        p.share1 = m0 / M
        p.m_total = M
    elif mv0:
        c = g0 / m0
        K = k_contact / m0
        b = f0 / m0
        w0 = v0
        p.case = 1.0
    elif mv1:
        c = g1 / m1
        K = k_contact / m1
        b = -f1 / m1
        w0 = -v1
        p.case = 2.0
    else:
        return False
    p.c = c
    p.k_rate = K
    p.drive = b
    p.y0 = d0 - b / K
    p.w0 = w0
    p.delta0 = d0
    p.v0_init = v0 if mv0 else 0.0
    p.v1_init = v1 if mv1 else 0.0
    p.eta_s_other = eta_s_other
    p.k_contact = k_contact
    p.s0 = s0
    p.s1 = s1
    # D = K - c^2/4 with its low part (exact product, then TwoSum).
    cp, ce = two_prod(c, c)
    dh, d_lo = two_sum(K, -0.25 * cp)
    d_lo -= 0.25 * ce
    dh, d_lo = two_sum(dh, d_lo)
    p.d_hi = dh
    p.d_lo = d_lo
    if dh > 0.0:
        oh = math.sqrt(dh)
        sp, se = two_prod(oh, oh)
        ol = ((dh - sp) - se + d_lo) / (2.0 * oh)
    elif dh < 0.0:
        oh = math.sqrt(-dh)
        sp, se = two_prod(oh, oh)
        ol = ((-dh - sp) - se - d_lo) / (2.0 * oh)
    else:
        oh = 0.0
        ol = 0.0
    p.om_hi = oh
    p.om_lo = ol
    # c^2 overflows for c > ~1e154: the closed form is then not evaluable
    return math.isfinite(dh) and math.isfinite(oh)


@callee(error_model="numpy", _nrt=False)
def _csa(p, th, tl):
    """e^(-c tau/2) C(tau), e^(-c tau/2) S(tau), e^(-c tau) for tau = th + tl."""
    c = p.c
    cp, ce = two_prod(c, th)
    corr = ce + c * tl
    A = math.exp(-0.5 * cp) * (1.0 - 0.5 * corr)
    E = math.exp(-cp) * (1.0 - corr)
    dh = p.d_hi
    oh = p.om_hi
    ol = p.om_lo
    if dh > 0.0:
        xh, xe = two_prod(oh, th)
        xl = xe + oh * tl + ol * th
        sh = math.sin(xh)
        ch = math.cos(xh)
        sn = sh + xl * ch
        cs = ch - xl * sh
        S = sn / oh * (1.0 - ol / oh)
        return A * cs, A * S, E
    if dh < 0.0:
        kap = oh + ol
        tau = th + tl
        x = kap * tau
        if x < 20.0:
            return A * math.cosh(x), A * math.sinh(x) / kap, E
        half = 0.5 * c
        r1 = -p.k_rate / (kap + half)  # kappa - c/2 without cancellation
        r2 = -(kap + half)
        e1 = math.exp(r1 * tau)
        e2 = math.exp(r2 * tau)
        return 0.5 * (e1 + e2), 0.5 * (e1 - e2) / kap, E
    return A, A * (th + tl), E


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def slow_rate(K, half_c, kap):
    """Slow decay rate of an overdamped mode, c/2 - sqrt(c^2/4 - K), written as
    K / (c/2 + kap) (kap = sqrt(c^2/4 - K)): the difference form cancels to nothing
    when c^2 >> K (gamma = 1e6: 12 digits lost)."""
    return K / (half_c + kap)


@callee(error_model="numpy", _nrt=False)
def state(p, th, tl):
    """delta, w = delta', v0, v1, du0, du1 at tau = th + tl from the mode start.

    At tau = 0 the mode's initial state is returned exactly (the closed form
    would round it), so event functions agree with the state settle saw.

    Parameters
    ----------
    p : record of MODE_DTYPE
        The mode record filled by :func:`setup` (kernel units).
    th, tl : float
        Time from the mode's start as a double-double th + tl, kernel time units.

    Returns
    -------
    delta, w, v0, v1, du0, du1 : float
        Overlap (length), its rate (length / time), the two velocities, and the
        two granules' displacements since the mode's start (length); kernel units.
    """
    if th == 0.0 and tl == 0.0:
        return p.delta0, p.w0, p.v0_init, p.v1_init, 0.0, 0.0
    c = p.c
    K = p.k_rate
    y0 = p.y0
    w0 = p.w0
    B = w0 + 0.5 * c * y0
    tau = th + tl
    case = p.case
    if tau * (math.sqrt(K) + 0.5 * c + abs(p.om_hi)) < 0.5:
        # Early in the mode: increments from the initial state with expm1 and
        # 2 sin^2(x/2) (no 1 - 1 cancellation), so a granule that has just
        # stopped or slipped at a near-balanced force gets the sign of its tiny
        # velocity right (the direct form rounds it to +-1e-17).
        A = math.exp(-0.5 * c * tau)
        Am1 = math.expm1(-0.5 * c * tau)
        dh = p.d_hi
        if dh > 0.0:
            om = p.om_hi + p.om_lo
            sh = math.sin(0.5 * om * tau)
            cm1 = -2.0 * sh * sh
            S = math.sin(om * tau) / om
        elif dh < 0.0:
            kap = p.om_hi + p.om_lo
            sh = math.sinh(0.5 * kap * tau)
            cm1 = 2.0 * sh * sh
            S = math.sinh(kap * tau) / kap
        else:
            cm1 = 0.0
            S = tau
        ACm1 = A * cm1 + Am1
        AS = A * S
        dy = y0 * ACm1 + B * AS
        dw = w0 * ACm1 - (K * y0 + 0.5 * c * w0) * AS
        delta = p.delta0 + dy
        w = w0 + dw
        if case == 0.0:
            x = c * tau
            if x < 1e-3:
                ph1 = tau * (1.0 - x / 2.0 + x * x / 6.0 - x * x * x / 24.0 + x ** 4 / 120.0)
                ph2 = tau * tau * (0.5 - x / 6.0 + x * x / 24.0 - x * x * x / 120.0
                                   + x ** 4 / 720.0)
            else:
                ph1 = -math.expm1(-x) / c
                ph2 = (tau - ph1) / c
            dV = p.v_cm0 * math.expm1(-x) + p.f_cm * ph1
            dU = p.v_cm0 * ph1 + p.f_cm * ph2
            return (delta, w, p.v0_init + dV + p.share0 * dw, p.v1_init + dV - p.share1 * dw,
                    dU + p.share0 * dy, dU - p.share1 * dy)
        if case == 1.0:
            return delta, w, w, 0.0, dy, 0.0
        return delta, w, 0.0, -w, 0.0, -dy
    dh = p.d_hi
    kap = p.om_hi + p.om_lo
    if dh < 0.0 and kap > 0.25 * c:
        # Strongly overdamped: y = al e^(r1 tau) + be e^(r2 tau) on the two real
        # rates (slow r1 = -K/(kap + c/2) without cancellation, fast r2 =
        # -(kap + c/2), r1 - r2 = 2 kap). The cosh/sinh form subtracts two terms
        # of size e^(kap tau) to leave the slow one, losing log10(kap/|r1|)
        # digits (1e-4 relative in v at gamma = 1e6); here at most a factor 2
        # (kap > c/4), while for kap <= c/4 the cosh/sinh form loses as little.
        s_ = kap + 0.5 * c
        r1 = -slow_rate(K, 0.5 * c, kap)
        r2 = -s_
        e1 = math.exp(r1 * tau)
        e2 = math.exp(r2 * tau)
        al = (w0 + s_ * y0) / (2.0 * kap)
        be = (r1 * y0 - w0) / (2.0 * kap)
        y = al * e1 + be * e2
        w = al * r1 * e1 + be * r2 * e2
        cp, ce = two_prod(c, th)
        E = math.exp(-cp) * (1.0 - (ce + c * tl))
    else:
        AC, AS, E = _csa(p, th, tl)
        y = y0 * AC + B * AS
        w = w0 * AC - (K * y0 + 0.5 * c * w0) * AS
    delta = y + p.drive / K
    dd = delta - p.delta0
    if case == 0.0:
        # phi1 = (1 - e^(-c tau))/c, phi2 = (tau - phi1)/c, both -> tau, tau^2/2 at c -> 0
        if c * tau < 1e-3:
            x = c * tau
            ph1 = tau * (1.0 - x / 2.0 + x * x / 6.0 - x * x * x / 24.0 + x ** 4 / 120.0)
            ph2 = tau * tau * (0.5 - x / 6.0 + x * x / 24.0 - x * x * x / 120.0
                               + x ** 4 / 720.0)
        else:
            ph1 = -math.expm1(-c * tau) / c
            ph2 = (tau - ph1) / c
        V = p.v_cm0 * E + p.f_cm * ph1
        dU = p.v_cm0 * ph1 + p.f_cm * ph2
        return delta, w, V + p.share0 * w, V - p.share1 * w, dU + p.share0 * dd, dU - p.share1 * dd
    if case == 1.0:
        return delta, w, w, 0.0, dd, 0.0
    return delta, w, 0.0, -w, 0.0, -dd


@callee(error_model="numpy", _nrt=False)
def g_event2(p, kind, th, tl):
    """Event function and its time derivative (g < 0 on the valid side).

    Kinds: 0 open, 1 stop of granule 0, 2 stop of granule 1, 3 slip of the
    stuck granule (k delta > eta_s), 4 overlap reaching ``limit`` (the centres meet).

    Parameters
    ----------
    p : record of MODE_DTYPE
        The mode record filled by :func:`setup` (kernel units).
    kind : int
        Event function: 0 open, 1 stop of granule 0, 2 stop of granule 1, 3 slip
        of the stuck granule, 4 the centres meeting.
    th, tl : float
        Time from the mode's start as a double-double th + tl, kernel time units.

    Returns
    -------
    g, dg : float
        The event function at tau = th + tl and dg/dtau, kernel units (length,
        velocity or force, and those per time).
    """
    delta, w, v0, v1, du0, du1 = state(p, th, tl)
    c = p.c
    wd = p.drive - p.k_rate * delta - c * w  # delta''
    if kind == 0:
        return -delta, -w
    if kind == 4:
        return delta - p.limit, w
    if kind == 3:
        return p.k_contact * delta - p.eta_s_other, p.k_contact * w
    case = p.case
    if case == 0.0:
        V = v0 - p.share0 * w
        Vd = -c * V + p.f_cm
        a0 = Vd + p.share0 * wd
        a1 = Vd - p.share1 * wd
    elif case == 1.0:
        a0 = wd
        a1 = 0.0
    else:
        a0 = 0.0
        a1 = -wd
    if kind == 1:
        return -p.s0 * v0, -p.s0 * a0
    return -p.s1 * v1, -p.s1 * a1


@callee(error_model="numpy", _nrt=False)
def g_event(p, kind, th, tl):
    """The event function alone (:func:`g_event2` without the derivative).

    Parameters
    ----------
    p : record of MODE_DTYPE
        The mode record filled by :func:`setup` (kernel units).
    kind : int
        Event function: 0 open, 1 stop of granule 0, 2 stop of granule 1, 3 slip
        of the stuck granule, 4 the centres meeting.
    th, tl : float
        Time from the mode's start as a double-double th + tl, kernel time units.

    Returns
    -------
    float
        g at tau = th + tl, kernel units (length, velocity or force).
    """
    g, gd = g_event2(p, kind, th, tl)
    return g


@callee(error_model="numpy", _nrt=False)
def _root_in_bracket(p, kind, lo, hi):
    """Root of g on [lo, hi] with g(lo) < 0 <= g(hi), to an ulp, as (th, tl).

    Newton's method kept inside the bracket (a bisection step whenever a Newton
    step leaves it or fails to halve the previous step, as in Numerical
    Recipes' rtsafe): 4-6 evaluations of the closed form instead of the ~55
    of plain bisection to 2 ulps, which were most of a collision's cost. Then
    one Newton step on the double-double tau.
    """
    x = 0.5 * (lo + hi)
    step_old = hi - lo
    for _ in range(200):
        g, d = g_event2(p, kind, x, 0.0)
        if g < 0.0:
            lo = x
        else:
            hi = x
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break  # the bracket is down to adjacent doubles
        xn = x - g / d if d != 0.0 else mid
        if not (lo < xn < hi) or abs(xn - x) > 0.5 * step_old:
            xn = mid
        step = abs(xn - x)
        step_old = step
        x = xn
        if step <= 2.2e-16 * abs(x):
            break  # converged: the next step would be below an ulp
    th, tl = x, 0.0
    g1, d1 = g_event2(p, kind, th, tl)
    if d1 != 0.0:
        corr = -g1 / d1
        if abs(corr) < 8.0 * 2.2e-16 * abs(th) + 1e-300:
            th, tl = two_sum(th, tl + corr)
    return th, tl


@callee(error_model="numpy", _nrt=False)
def _max_of(p, kind, lo, hi):
    """Interior maximum of g on [lo, hi] with g'(lo) > 0 > g'(hi) (bisection on g')."""
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        g, d = g_event2(p, kind, mid, 0.0)
        if d > 0.0:
            lo = mid
        else:
            hi = mid
    return lo


@callee(error_model="numpy", _nrt=False)
def sample_step(p):
    """Sampling interval: a quarter of the fastest time scale of the mode.

    Parameters
    ----------
    p : record of MODE_DTYPE
        The mode record filled by :func:`setup` (kernel units).

    Returns
    -------
    float
        The interval, kernel time units.
    """
    rate = max(math.sqrt(p.k_rate), 0.5 * p.c, abs(p.om_hi))
    return 0.25 / rate


@callee(error_model="numpy", _nrt=False)
def slow_sample_step(p):
    """Largest sampling interval: sample_step, or a quarter of the slow time
    scale 1/lambda_slow of an overdamped mode (D <= 0).

    lambda_slow = K / (c/2 + sqrt(c^2/4 - K)) (the stable form of c/2 - sqrt(c^2/4 - K)).

    Parameters
    ----------
    p : record of MODE_DTYPE
        The mode record filled by :func:`setup` (kernel units).

    Returns
    -------
    float
        The interval, kernel time units.
    """
    fast = sample_step(p)
    if p.d_hi > 0.0:
        return fast
    return max(fast, 0.25 / slow_rate(p.k_rate, 0.5 * p.c, abs(p.om_hi)))


@callee(error_model="numpy", _nrt=False)
def overlap_bound(p):
    """Upper bound on delta over the whole mode (inf when there is none).

    y = delta - b/K obeys y'' + c y' + K y = 0 with c >= 0, so K y^2 + w^2
    never grows: delta <= b/K + sqrt(y0^2 + w0^2/K) at every time of the mode.

    Parameters
    ----------
    p : record of MODE_DTYPE
        The mode record filled by :func:`setup` (kernel units).

    Returns
    -------
    float
        The bound, kernel length units (``math.inf`` when K <= 0).
    """
    K = p.k_rate
    if not (K > 0.0):
        return math.inf
    y0 = p.y0
    w0 = p.w0
    return p.drive / K + math.sqrt(y0 * y0 + w0 * w0 / K)


@callee(error_model="numpy", _nrt=False)
def open_root_analytic(p, h):
    """First tau in (0, h] with y(tau) = 0 when b = 0 (delta = y): closed form.

    Parameters
    ----------
    p : record of MODE_DTYPE
        The mode record filled by :func:`setup` (kernel units).
    h : float
        End of the interval searched, kernel time units.

    Returns
    -------
    th, tl : float
        The root as a double-double, kernel time units, polished by Newton steps
        on the accurate evaluator; (0, 0) when the contact opens at once and
        (inf, 0) when there is no root in (0, h].
    """
    y0 = p.y0
    c = p.c
    B = p.w0 + 0.5 * c * y0
    dh = p.d_hi
    # y/A = y0 C + B S: a zero where y0 C + B S = 0.
    if dh > 0.0:
        om = p.om_hi + p.om_lo
        # angle theta in (0, pi] with y0 cos + (B/om) sin = 0
        if y0 == 0.0:
            if B > 0.0:
                th_h, th_l = PI_HI, PI_LO  # first positive zero of sin
            elif B < 0.0:
                return 0.0, 0.0  # leaves at once
            else:
                return math.inf, 0.0  # nothing moves
        else:
            ang = math.atan2(-y0 * om, B)  # theta with tan(theta) = -y0 om / B
            while ang <= 0.0:
                ang += math.pi
            th_h, th_l = ang, 0.0
        # tau = theta / omega in double-double
        q = th_h / p.om_hi
        ph, pe = two_prod(q, p.om_hi)
        r = ((th_h - ph) - pe + th_l - q * p.om_lo) / p.om_hi
        th, tl = two_sum(q, r)
    elif dh < 0.0:
        kap = p.om_hi + p.om_lo
        if B == 0.0:
            return math.inf, 0.0
        z = -kap * y0 / B
        if not (0.0 < z < 1.0):
            return math.inf, 0.0
        th, tl = math.atanh(z) / kap, 0.0
    else:
        if B == 0.0 or -y0 / B <= 0.0:
            return math.inf, 0.0
        th, tl = -y0 / B, 0.0
    if not (th <= h):
        return math.inf, 0.0
    for _ in range(2):
        delta, w, v0, v1, du0, du1 = state(p, th, tl)
        if w == 0.0:
            break
        th, tl = two_sum(th, tl - delta / w)
    return th, tl


@callee(error_model="numpy", _nrt=False)
def _acc_roundoff(p):
    """Roundoff bound of a granule's acceleration at the start of the mode:
    1e-12 times the terms that cancel in it (drive, spring, drag, shared force)."""
    c = p.c
    s = abs(p.drive) + p.k_rate * abs(p.delta0) + c * abs(p.w0)
    if p.case == 0.0:
        s += abs(p.f_cm) + c * abs(p.v_cm0)
    return 1e-12 * s


@callee(error_model="numpy", _nrt=False)
def first_root(p, kind, lo, hi, nsamp):
    """First tau in [lo, hi] where g_event(kind) reaches 0 from below, as (th, tl).

    Sampling at ``nsamp`` points with the derivative: a sign change is located
    to an ulp (:func:`_root_in_bracket`); an interior maximum between two samples (g' from + to -) is
    located on g' and checked, so a grazing dip between samples is not missed
    (the same rule as the Taylor path's polynomial roots).

    Parameters
    ----------
    p : record of MODE_DTYPE
        The mode record filled by :func:`setup` (kernel units).
    kind : int
        Event function: 0 open, 1 stop of granule 0, 2 stop of granule 1, 3 slip
        of the stuck granule, 4 the centres meeting.
    lo : float
        Start of the window, kernel time units: 0 (the mode's start) or the end
        of a window already searched (g < 0 there).
    hi : float
        End of the window, kernel time units.
    nsamp : int
        Number of samples in the window, >= 1.

    Returns
    -------
    th, tl : float
        The root as a double-double, kernel time units; (inf, 0) when g stays
        negative on [lo, hi].
    """
    ga, da = g_event2(p, kind, lo, 0.0)
    if ga > 0.0:
        return lo, 0.0
    if ga == 0.0 and lo == 0.0 and (kind == 1 or kind == 2) and abs(da) <= _acc_roundoff(p):
        # A granule that just slipped at |F| = eta_s = eta starts with zero
        # acceleration; what g' shows is the roundoff of the force balance at
        # the located slip. Taken as a slope, it put a spurious maximum of g
        # (a stop) ulps after the start, and the slip and that stop repeated
        # at one instant until the run ended as Zeno (3 % of a (eta1, eta2) map).
        da = 0.0
    # ga == 0 (a granule that just stopped or slipped, a contact at delta = 0):
    # the slope there can be roundoff, so the samples decide (below).
    a = lo
    for s in range(1, nsamp + 1):
        b = lo + (hi - lo) * s / nsamp
        gb, db = g_event2(p, kind, b, 0.0)
        if gb >= 0.0 and not (ga == 0.0 and s == 1 and gb == 0.0):
            if ga == 0.0:
                # started on the boundary going negative: step inside first
                x = b - a
                found = False
                for _ in range(60):
                    x *= 0.5
                    if g_event(p, kind, a + x, 0.0) < 0.0:
                        found = True
                        break
                if not found:
                    return a, 0.0
                a = a + x
            return _root_in_bracket(p, kind, a, b)
        if da > 0.0 and db < 0.0:
            xm = _max_of(p, kind, a, b)
            if g_event(p, kind, xm, 0.0) >= 0.0:
                if ga == 0.0:
                    return xm, 0.0
                return _root_in_bracket(p, kind, a, xm)
        a = b
        ga = gb
        da = db
    return math.inf, 0.0
