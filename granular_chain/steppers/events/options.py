"""What the event stepper reads from a scene, read in one place: :func:`event_options`."""

from __future__ import annotations

import math
from typing import NamedTuple, Optional

from ..schedule import Schedule, event_schedule

__all__ = ["EventOptions", "event_options", "series_order", "frame_interval"]

# n = 2: order and relative size of the first neglected terms (below roundoff).
LINEAR_ORDER = 24
LINEAR_RTOL = 2e-17
# n = 2: largest step times the eigenvalue bound L (see kernel.taylor_step, step_cap).
LINEAR_STEP = 0.5



class EventOptions(NamedTuple):
    """The scene's run and output settings the event stepper uses (times in the
    units the stepper runs in)."""

    t_end: float
    rtol: float                 #: relative tolerance (n != 2; n = 2 is exact)
    atol: float                 #: absolute tolerance (n != 2)
    max_steps: int
    max_events: int
    stop_contact: int           #: model contact whose opening is "separation"
    stop_separation: bool       #: end the run when that contact opens
    stop_rest: bool             #: end the run when every granule is at rest
    output_dt: Optional[float]  #: output cadence in time (None: the default)
    output_every: Optional[int]  #: a frame every this many steps (None: none)
    cadence_frames: int = 0     #: without output.dt: frames spread over t_end (0: none)

    def in_time_unit(self, B: float) -> "EventOptions":
        """The options with their times (``t_end``, ``output_dt``) in units of ``B``.

        Parameters
        ----------
        B : float
            The new time unit, in the options' current time unit (seconds of the
            scene, or its time scale); must be > 0.

        Returns
        -------
        EventOptions
            A copy with ``t_end / B`` and ``output_dt / B`` (None stays None);
            the tolerances and counts unchanged.
        """
        return self._replace(t_end=self.t_end / B,
                             output_dt=self.output_dt / B if self.output_dt is not None else None)


def event_options(scene, schedule: Optional[Schedule] = None) -> EventOptions:
    """The :class:`EventOptions` of a scene (``scene.run`` and ``scene.output``).

    Parameters
    ----------
    scene : Scene
        A validated scene; its times are in scene units.
    schedule : Schedule, optional
        The run's :class:`~granular_chain.steppers.schedule.Schedule` (worked out
        from the scene when not given).

    Returns
    -------
    EventOptions
        Its run and output settings, times in scene units.
    """
    run, out = scene.run, scene.output
    stops = run.stop_conditions
    schedule = event_schedule(scene) if schedule is None else schedule
    return EventOptions(
        t_end=run.t_end, rtol=run.rtol, atol=run.atol, max_steps=run.max_steps,
        max_events=run.max_events, stop_contact=run.stop_contact,
        stop_separation="separation" in stops, stop_rest="rest" in stops,
        output_dt=out.dt, output_every=out.every, cadence_frames=schedule.cadence_frames)


def series_order(rtol: float) -> int:
    """Taylor order for a relative tolerance (Jorba & Zou: about -ln(tol)/2, at least 8).

    Parameters
    ----------
    rtol : float
        Relative tolerance of the step control, dimensionless, > 0.

    Returns
    -------
    int
        The order P, ``ceil(-ln(rtol) / 2) + 2`` clipped to [8, 30].
    """
    return int(min(30, max(8, math.ceil(-0.5 * math.log(rtol)) + 2)))


def frame_interval(options: EventOptions) -> float:
    """Output cadence in time (0: none): ``output.dt`` if given, else t_end spread over
    the schedule's ``cadence_frames`` (a chain longer than FRAMES_AT_EVENTS_MAX_N
    without output.every; :mod:`granular_chain.steppers.schedule`).

    Parameters
    ----------
    options : EventOptions
        The run's options, times in the unit the stepper runs in.

    Returns
    -------
    float
        Time between cadence frames, in the unit of ``options.t_end``; 0.0 when
        frames are recorded at event batches or every ``output.every`` steps only.
    """
    if options.output_dt is not None:
        return float(options.output_dt)
    if options.cadence_frames == 0:
        return 0.0
    return float(options.t_end) / options.cadence_frames
