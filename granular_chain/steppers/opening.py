"""Whether a contact's opening is resolved or only its overlap decaying through roundoff.

A tensile contact ends when its overlap returns to zero. With a linear dashpot at
damping ratio b >= 1 (n = 2) the closed form
(:func:`granular_chain.restitution.linear_dashpot`, ``tensile=True``) is a sum of
decaying exponentials of one sign: the overlap never reaches zero and the relative
speed decays with it. A stepper's overlap, carried to a few ulps, still crosses zero
once it has decayed to roundoff, at a relative speed that is itself roundoff. Such a
crossing is not the end of a collision: ``stop: separation`` does not stop there
(docs/robustness.md, "Openings below roundoff").
"""

from __future__ import annotations

import math

__all__ = ["ROUNDOFF_FACTOR", "opening_floor", "resolved_opening", "roundoff_note"]

#: An opening is resolved when its relative speed exceeds this many times the
#: roundoff floor of :func:`opening_floor` (measured at the spurious openings of a
#: tensile overdamped dashpot: 4 (event stepper) and 0.3 (Verlet) times the floor).
ROUNDOFF_FACTOR = 64.0


def opening_floor(speeds, positions=(), dt=None) -> float:
    """The relative speed the stepper cannot tell from zero at this contact (scene units).

    Parameters
    ----------
    speeds : sequence of float
        Velocities of the contact's two granules (length/time).
    positions : sequence of float
        The numbers whose difference is the overlap (Verlet: the granules'
        displacements and the contact's offset), length.
    dt : float, optional
        The step (time). Verlet: the overlap is a difference of positions, so a
        speed below ``ulp(position) / dt`` does not move it by one ulp in a step.
        None: the stepper carries the overlap itself (event stepper), only the
        speeds' roundoff counts.

    Returns
    -------
    float
        ``eps max|v| + ulp(max|x|) / dt``.
    """
    floor = 2.0 ** -52 * max(abs(float(s)) for s in speeds)
    if dt is not None and positions:
        floor += math.ulp(max(abs(float(x)) for x in positions)) / float(dt)
    return floor


def resolved_opening(w: float, floor: float) -> bool:
    """True when an opening at relative speed ``w`` is a real end of the contact.

    Parameters
    ----------
    w : float
        Opening speed ``v_right - v_left`` (positive: the granules move apart).
    floor : float
        Its :func:`opening_floor`, in the same units.

    Returns
    -------
    bool
        ``w > ROUNDOFF_FACTOR * floor``; False for an overlap that only decayed
        through roundoff (the contact never opens, ``e = 0``).
    """
    return float(w) > ROUNDOFF_FACTOR * float(floor)


def roundoff_note(contact: int, t: float, ratio: float) -> str:
    """The end message's note on an unresolved opening of the watched contact.

    Parameters
    ----------
    contact : int
        The watched contact (``run.stop_contact``).
    t : float
        When its overlap crossed zero (time, units of the run's messages).
    ratio : float
        The relative speed then over its :func:`opening_floor` (dimensionless).

    Returns
    -------
    str
        Starts with ``"; "``: appended to the message of the run's end.
    """
    return (f"; contact {contact} never opened: its overlap decayed through roundoff at "
            f"t = {t:.6g} (relative speed {ratio:.2g} x its roundoff floor, below "
            f"{ROUNDOFF_FACTOR:g}), which is not a separation")
