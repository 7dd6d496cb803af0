"""The result of a run: arrays, energy ledger, event log, status and message.

Shaped after scipy's ``OdeResult``: one flat object, ``status`` (an enum,
every way a run can end has its own), a human ``message`` and ``success``.
"""

from __future__ import annotations

import html
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from . import dataset
from .codes import Status
from .extras import require
from .model import build_model

__all__ = ["Status", "Event", "EnergyLedger", "Result", "TERMS_ADDED", "ledger_balance",
           "run_model"]


# What a run ending with Status.OVERLAP tells the user to change.
OVERLAP_ADVICE = ("the contact is too soft for this impact (granules would pass "
                  "through each other): raise contacts.stiffness or lower the velocities")


@dataclass(frozen=True)
class Event:
    """One non-smooth moment of the motion.

    Attributes
    ----------
    t : float
        Time of the event, scene units of time.
    kind : str
        One of ``contact_close``, ``contact_open``, ``stop``, ``slip``.
    index : int
        Contact index (contacts: -1 left wall, N-1 right wall) or granule index.
    step : int
        Verlet: the step at whose end the event was seen (``t`` is that step's end,
        ``step * dt`` or t_end for a shortened last step; a stop or slip of the half
        kick that synchronises the velocities at a frame carries the frame's step).
        -1 for the event stepper, which takes no steps: its times are exact.
    """

    t: float
    kind: str
    index: int
    step: int = -1


@dataclass
class EnergyLedger:
    """Energy bookkeeping at each output frame, all arrays of shape (F,).

    ``initial + wall_work + body_work + stage_work = kinetic + potential + coulomb
    + viscous + contact_dissipated`` holds up to the integrator's error, reported as
    :attr:`balance_error`.

    Attributes
    ----------
    kinetic, potential : ndarray
        Kinetic energy sum(m v^2 / 2) and elastic energy of the contacts, scene
        units of energy (as every term below).
    coulomb, viscous : ndarray
        Energy dissipated so far by kinetic (Coulomb) and hydrodynamic friction (>= 0).
    initial : float
        Kinetic plus elastic energy at t = 0.
    streamed_error : float or None
        Largest relative |balance| (dimensionless, relative to :attr:`scale`) over
        frames streamed to writers and not kept here; None when every frame is kept.
    contact_dissipated : ndarray
        Energy dissipated so far by the contacts' dashpots (>= 0; zeros when elastic).
    wall_work : ndarray
        Work done on the chain so far by moving walls (either sign; zeros when fixed),
        units of energy.
    body_work : ndarray
        Work done on the chain so far by body forces, sum_i f_i u_i (either sign).
    stage_work : ndarray
        Energy put in so far by the velocity changes at the starts of the stages of a
        staged run (``run.stages``): the sum of their kinetic energy changes (either
        sign; zeros in a run without stages).
    """

    kinetic: np.ndarray
    potential: np.ndarray
    coulomb: np.ndarray
    viscous: np.ndarray
    initial: float
    #: Largest relative |balance| over frames that were streamed to writers and not
    #: kept here (None when every frame is kept); :attr:`balance_error` includes it.
    streamed_error: Optional[float] = None
    contact_dissipated: Optional[np.ndarray] = None
    wall_work: Optional[np.ndarray] = None
    body_work: Optional[np.ndarray] = None
    stage_work: Optional[np.ndarray] = None

    def __post_init__(self):
        for name in TERMS_ADDED:
            if getattr(self, name) is None:
                setattr(self, name, np.zeros_like(np.asarray(self.kinetic, dtype=np.float64)))

    @property
    def balance(self) -> np.ndarray:
        """kinetic + potential + coulomb + viscous + contact_dissipated - wall_work
        - body_work - stage_work - initial, shape (F,)."""
        return ledger_balance(self.kinetic, self.potential, self.coulomb, self.viscous,
                              self.contact_dissipated, self.wall_work, self.body_work,
                              self.initial, self.stage_work)

    @property
    def scale(self) -> float:
        """Energy the balance is measured against: the initial energy, or, for a run
        that starts with none (a column settling, a chain at rest driven by a wall),
        the largest energy the ledger holds at any frame."""
        if self.initial > 0 or self.kinetic.size == 0:
            return self.initial if self.initial > 0 else 1.0
        held = max(float(np.max(np.abs(getattr(self, name)))) for name in (
            "kinetic", "potential", "coulomb", "viscous", *TERMS_ADDED))
        return held if held > 0 else 1.0

    @property
    def balance_error(self) -> float:
        """Largest |balance| over the frames, relative to :attr:`scale`."""
        streamed = self.streamed_error or 0.0
        if self.kinetic.size == 0:
            return streamed
        return max(float(np.max(np.abs(self.balance)) / self.scale), streamed)

    def final(self) -> dict:
        """The ledger's last frame (what summary.json lists under ``energy``).

        Returns
        -------
        dict
            The terms at the last frame (scene units of energy) under their
            summary.json names, the final ``balance_error`` (energy), its value
            relative to :attr:`scale` and :attr:`balance_error` (dimensionless).
        """
        out = {
            "kinetic": float(self.kinetic[-1]),
            "potential": float(self.potential[-1]),
            "friction_dissipated": float(self.coulomb[-1]),
            "viscous_dissipated": float(self.viscous[-1]),
            "contact_dissipated": float(self.contact_dissipated[-1]),
            "wall_work": float(self.wall_work[-1]),
            "body_work": float(self.body_work[-1]),
            "stage_work": float(self.stage_work[-1]),
            "initial": float(self.initial),
            "balance_error": float(self.balance[-1]),
            "balance_error_relative": float(self.balance[-1] / self.scale),
            "max_balance_error_relative": self.balance_error,
        }
        return out


#: Ledger terms of the dissipative contacts, driven walls, body forces and stage
#: changes (zeros when a scene has none of them).
TERMS_ADDED = ("contact_dissipated", "wall_work", "body_work", "stage_work")


def ledger_balance(kinetic, potential, coulomb, viscous, contact_dissipated, wall_work,
                   body_work, initial, stage_work=0.0):
    """Energy balance of the ledger's terms (arrays or floats, energy units): zero for
    an exact run. Summed in this order everywhere (writers, streamed frames).

    Parameters
    ----------
    kinetic, potential : float or numpy.ndarray
        Kinetic and elastic energy, scene units of energy; arrays of one shape,
        (F,) for a ledger.
    coulomb, viscous, contact_dissipated : float or numpy.ndarray
        Energy dissipated so far by Coulomb friction, drag and dashpots, same
        units and shape.
    wall_work, body_work : float or numpy.ndarray
        Work done on the chain by moving walls and body forces, same units and shape.
    initial : float
        Kinetic plus elastic energy at t = 0, scene units of energy.
    stage_work : float or numpy.ndarray
        Energy put in by the stages' velocity changes (``run.stages``), same units
        and shape (0 without stages).

    Returns
    -------
    float or numpy.ndarray
        The balance, scene units of energy, the shape of the terms.
    """
    return (kinetic + potential + coulomb + viscous - initial
            + contact_dissipated - wall_work - body_work - stage_work)


@dataclass
class Result:
    """Everything a run produced.

    Attributes
    ----------
    t : ndarray, shape (F,)
        Times of the output frames (the scene's time unit).
    x, v, f : ndarray, shape (F, N)
        Centre positions, velocities and net spring forces at the frames, scene
        units (length, speed, force).
    energy : EnergyLedger
        Energy ledger at the frames.
    events : list of Event
        Event log (event stepper; Verlet with ``output.events``, else empty).
    event_counts : dict
        Number of events of each kind.
    status : Status
        How the run ended.
    message : str
        Human explanation of the status.
    steps : int
        Steps (Verlet) or mode segments (event stepper) taken.
    wall_time : float
        Seconds spent stepping (compilation included on a cold cache).
    stepper : str
        ``verlet`` or ``event``.
    dt : float or None
        Verlet time step, scene units of time (None for the event stepper).
    t_final : float
        Time of the final state (for stop: separation, the located separation
        time), scene units of time.
    x_final, v_final : ndarray, shape (N,)
        Final positions and velocities, scene units (never NaN: a run that
        produced NaN ends at its last finite frame).
    info : dict
        Extra facts (features, units mapping, warnings).
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    f: np.ndarray
    energy: EnergyLedger
    status: Status
    message: str
    steps: int
    wall_time: float
    stepper: str
    dt: Optional[float]
    t_final: float
    x_final: np.ndarray
    v_final: np.ndarray
    events: list = field(default_factory=list)
    event_counts: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)

    @property
    def success(self) -> bool:
        """True when :attr:`status` counts as a success."""
        return self.status.success

    @property
    def scene(self):
        """The scene the run was made from, when known (always after
        :func:`granular_chain.read_run`); not a dataclass field, so
        ``dataclasses.replace`` does not carry it over."""
        return self.__dict__.get("_scene")

    @scene.setter
    def scene(self, value) -> None:
        self.__dict__["_scene"] = value

    @property
    def model(self):
        """The chain constants the run used (a :class:`~granular_chain.model.Model`, in
        the scene's units: radii, masses, contact k and n, walls, friction), attached by
        :func:`granular_chain.simulate` and, built once from the stored scene, by
        :func:`granular_chain.read_run`; None for a Result put together by hand. Not a
        dataclass field, like :attr:`scene`."""
        return self.__dict__.get("_model")

    @model.setter
    def model(self, value) -> None:
        self.__dict__["_model"] = value

    def __repr__(self) -> str:
        name = self.scene.name if self.scene is not None else self.info.get("scene_name")
        who = f"{name!r}, " if name else ""
        return (f"Result({who}N={self.x_final.size}, frames={self.t.size}, steps={self.steps}, "
                f"status={self.status}, t={self.t_final:.6g})")

    def _repr_html_(self) -> str:
        """An HTML table of the run for notebooks: status, message, time reached, size,
        steps and events, the energy ledger's last frame and its balance error, wall
        time and warnings (every text escaped).

        Returns
        -------
        str
            A ``<table>`` element.
        """
        name = self.scene.name if self.scene is not None else self.info.get("scene_name")
        steps = "mode segments" if self.stepper == "event" else "steps"
        counts = ", ".join(f"{k} {n}" for k, n in sorted(self.event_counts.items()) if n)
        led = self.energy.final()
        rows = [("scene", name or "-"),
                ("status", f"{self.status.name.lower()} ({int(self.status)})"),
                ("success", "yes" if self.success else "no"), ("message", self.message),
                ("stepper", self.stepper + (f", dt = {self.dt:.6g}" if self.dt else "")),
                ("t_final", f"{self.t_final:.10g}"), ("granules (N)", str(self.x_final.size)),
                ("frames", str(self.t.size)), (steps, str(self.steps)),
                ("events", f"{len(self.events)}" + (f" ({counts})" if counts else ""))]
        rows += [(f"energy: {k}", f"{led[k]:.6g}") for k in (
            "initial", "kinetic", "potential", "friction_dissipated", "viscous_dissipated",
            "contact_dissipated", "wall_work", "body_work") if led[k] or k in (
            "initial", "kinetic", "potential")]
        rows += [("energy balance error (relative)", f"{self.energy.balance_error:.3g}"),
                 ("wall time", f"{self.wall_time:.3g} s")]
        rows += [("warning", w) for w in self.info.get("warnings", [])]
        colour = "#1a7f37" if self.success else "#cf222e"
        body = "".join(
            f"<tr><th style='text-align:left'>{html.escape(k)}</th>"
            f"<td style='text-align:left'>{html.escape(str(v))}</td></tr>" for k, v in rows)
        return (f"<table><caption style='text-align:left; color:{colour}'><b>Result</b> "
                f"{html.escape(str(name or ''))}</caption>{body}</table>")

    def to_xarray(self):
        """The frames as an ``xarray.Dataset``, dimensions (time, granule), laid out as
        trajectory.h5 (needs the ``analysis`` extra).

        Returns
        -------
        xarray.Dataset
            Variables x, v, f (time, granule), the ledger terms (time), per-granule
            constants and the final state (granule), the event log (event); scene units.
        """
        require("xarray", "Result.to_xarray")
        return dataset.to_xarray(self, self.scene, run_model(self))

    def events_frame(self):
        """The event log as a ``pandas.DataFrame`` with columns step, t, kind, index (one
        row per event, as events.csv; empty for a Verlet run without ``output.events``).

        Returns
        -------
        pandas.DataFrame
            One row per event: step (int, -1 for the event stepper), t (scene units of
            time), kind (str), index (int).
        """
        pd = require("pandas", "Result.events_frame")
        return pd.DataFrame({"step": np.array([e.step for e in self.events], dtype=np.int64),
                             "t": np.array([e.t for e in self.events], dtype=np.float64),
                             "kind": pd.Series([e.kind for e in self.events], dtype=object),
                             "index": np.array([e.index for e in self.events], dtype=np.int64)})

    def ledger_frame(self):
        """The energy ledger as a ``pandas.DataFrame`` indexed by frame time ``t``, columns
        kinetic, potential, coulomb, viscous, contact_dissipated, wall_work, body_work,
        stage_work, balance (the columns of energy.csv).

        Returns
        -------
        pandas.DataFrame
            Shape (F, 9), scene units of energy.
        """
        pd = require("pandas", "Result.ledger_frame")
        led = self.energy
        return pd.DataFrame({"kinetic": led.kinetic, "potential": led.potential,
                             "coulomb": led.coulomb, "viscous": led.viscous,
                             **{name: getattr(led, name) for name in TERMS_ADDED},
                             "balance": led.balance}, index=pd.Index(self.t, name="t"))

    def summary(self) -> dict:
        """A JSON-ready summary (what ``granular-chain run`` writes as summary.json).

        Returns
        -------
        dict
            Status, stepper, dt, final state, event counts, the ledger's last
            frame (:meth:`EnergyLedger.final`), steps, frames, wall time and
            :attr:`info`; numbers in scene units.
        """
        return {
            "status": str(self.status),
            "status_code": int(self.status),
            "success": self.success,
            "message": self.message,
            "stepper": self.stepper,
            "dt": self.dt,
            "t_final": float(self.t_final),
            "x_final": [float(a) for a in self.x_final],
            "v_final": [float(a) for a in self.v_final],
            "event_counts": {k: int(n) for k, n in self.event_counts.items()},
            "energy": self.energy.final(),
            "steps": int(self.steps),
            "frames": int(self.t.size),
            "wall_time_s": float(self.wall_time),
            **{k: v for k, v in self.info.items()},
        }


def run_model(result, scene=None):
    """The chain constants of a run: ``result.model``, built from its scene if need be.

    :func:`granular_chain.simulate` attaches the Model it ran; a Result read
    back by :func:`~granular_chain.readback.read_run`, or put together by hand, gets it here, built once
    from ``scene`` (default ``result.scene``) and attached. This is the one
    place where a Result's Model is rebuilt from a Scene.

    Parameters
    ----------
    result : Result
        A run, as simulate() returned it or read_run() read it.
    scene : Scene, optional
        Scene to build the Model from (default ``result.scene``).

    Returns
    -------
    Model or None
        None when the Result has neither a Model nor a scene.
    """
    if result.model is None:
        scene = scene if scene is not None else result.scene
        if scene is not None:
            result.model = build_model(scene)
    return result.model
