"""Normal contact dissipation: the dashpot in parallel with the one-sided spring.

A closed contact of overlap ``delta > 0`` and overlap rate ``w = d(delta)/dt``
(positive while the granules approach) pushes the granules apart with::

    F = k delta^(n-1) + D(delta, w)

    D = c w                                 linear dashpot (any n)
    D = A d/dt (k delta^(n-1))
      = A k (n-1) delta^(n-2) w             viscoelastic (n = 5/2: Kuwabara-Kono,
                                            Brilliantov et al. 1996)

``tensile = 0`` (the default of a scene): the total force never pulls,
``F = max(0, k delta^(n-1) + D)``, and the contact ends when it reaches zero
(Schwager and Poeschel, Granular Matter 9, 465 (2007)). ``tensile = 1``: the
contact ends at ``delta = 0`` and may pull while the granules part.

The power the dashpot takes from the motion is ``D_eff * w >= 0`` with
``D_eff = F - k delta^(n-1)`` the part of the force above the spring's, so a
clipped force still dissipates (``D_eff = -k delta^(n-1)`` then, ``w < 0``).

``damping`` is a compile-time constant of the kernels (DAMPING_NONE compiles
no dashpot at all); ``coefficient`` is ``c`` (mass/time) or ``A`` (time).
"""

import math

import numba
import numpy as np

from .contact import LAW_HERTZ, LAW_LINEAR, contact_force

DAMPING_NONE = 0
DAMPING_LINEAR = 1
DAMPING_VISCOELASTIC = 2

__all__ = ["DAMPING_NONE", "DAMPING_LINEAR", "DAMPING_VISCOELASTIC", "dashpot_force",
           "damped_contact_force", "dashpot_primitive", "dashpot_rate"]


@numba.njit(inline="always", cache=True)
def dashpot_force(law, damping, d, w, k, n, coefficient):
    """Dashpot force ``D`` of a contact of overlap ``d > 0`` and rate ``w`` (0 if d <= 0).

    Parameters
    ----------
    law : int
        Contact law (:mod:`.contact`); selects ``delta^(n-2)`` as 1, 1/sqrt(d) or a power.
    damping : int
        DAMPING_NONE, DAMPING_LINEAR or DAMPING_VISCOELASTIC.
    d, w : float
        Overlap (length) and its rate d(delta)/dt (length/time).
    k, n : float
        Force coefficient and exponent of the contact's spring.
    coefficient : float
        ``c`` (force/speed) for the linear dashpot, ``A`` (time) for the viscoelastic one.

    Returns
    -------
    float
        Force along the pushing-apart direction (force units); negative while
        the contact opens (w < 0).
    """
    if damping == DAMPING_NONE or d <= 0.0:
        return 0.0
    if damping == DAMPING_LINEAR:
        return coefficient * w
    # viscoelastic: A k (n-1) delta^(n-2) w
    if law == LAW_LINEAR:
        return coefficient * k * w
    if law == LAW_HERTZ:
        return coefficient * k * 1.5 * math.sqrt(d) * w
    return coefficient * k * (n - 1.0) * d ** (n - 2.0) * w


@numba.njit(inline="always", cache=True)
def damped_contact_force(law, damping, tensile, d, w, k, n, coefficient):
    """Total force of a contact with spring and dashpot (pushing apart when positive).

    Zero unless ``d > 0``; ``max(0, spring + dashpot)`` unless ``tensile``.
    With ``damping == DAMPING_NONE`` this is :func:`.contact.contact_force`.

    Parameters
    ----------
    law, damping, d, w, k, n, coefficient
        As in :func:`dashpot_force`.
    tensile : int
        1: the force may pull while the contact is closed (d > 0).

    Returns
    -------
    float
        Contact force (force units).
    """
    f = contact_force(law, d, k, n)
    if damping == DAMPING_NONE:
        return f
    f += dashpot_force(law, damping, d, w, k, n, coefficient)
    if tensile:
        return f
    return max(f, 0.0)


@numba.njit(inline="always", cache=True)
def dashpot_primitive(law, damping, d, k, n, coefficient):
    """``Phi(delta)`` with ``D = dPhi/dt`` while the contact is closed (0 if d <= 0).

    Both dashpots are time derivatives of a function of the overlap alone:
    ``Phi = c delta`` (linear) and ``Phi = A k delta^(n-1)`` (viscoelastic), and
    ``Phi`` is continuous at ``delta = 0``. So the dashpot's impulse over any time
    in which the force is not clipped is the change of ``Phi``, exactly, also
    across the closing of the contact where the linear dashpot's force jumps
    from 0 to ``c w``.

    Parameters
    ----------
    law, damping, d, k, n, coefficient
        As in :func:`dashpot_force`.

    Returns
    -------
    float
        ``Phi`` (force x time, an impulse).
    """
    if damping == DAMPING_NONE or d <= 0.0:
        return 0.0
    if damping == DAMPING_LINEAR:
        return coefficient * d
    return coefficient * contact_force(law, d, k, n)


def dashpot_rate(model) -> float:
    """Largest relaxation rate of a relative velocity by a dashpot (1/time; 0 without).

    A linear dashpot c between masses of reduced mass m_eff (a wall's granule
    alone for a wall contact): c / m_eff. A viscoelastic one acts like a linear
    dashpot A k_eff, k_eff the contact's linear stiffness: A (2 pi / T)^2 with T
    the shortest contact time (an estimate: 0 when T is unknown).

    Parameters
    ----------
    model : Model
        The compiled scene, scene units.

    Returns
    -------
    float
        Rate in 1/time, scene units (0 without dashpots).
    """
    feat = model.features
    c = model.contacts.damping
    if feat.damping == DAMPING_LINEAR and c.size:
        return float(np.max(c / model.contacts.reduced_mass(model.mass)))
    if feat.damping == DAMPING_VISCOELASTIC and c.size:
        T = model.shortest_period()
        return float(np.max(c)) * (2 * math.pi / T) ** 2 if math.isfinite(T) else 0.0
    return 0.0
