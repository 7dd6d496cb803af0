"""``run``: the stepper, when to stop, tolerances and ``stages``."""

from __future__ import annotations

from typing import Annotated, Any, Literal, Optional, Union

from pydantic import (
    BeforeValidator,
    Discriminator,
    Field,
    Tag,
    ValidationInfo,
    model_validator,
)

from .values import Bool, Finite, Int, Positive, _FieldProblem, _Strict, _index_key, _name


#: Default of ``run.energy_tolerance`` (relative ledger error): see its description.
DEFAULT_ENERGY_TOLERANCE = 1e-2

#: The options only one stepper reads, by ``run.stepper``: ``run.dt``,
#: ``run.check_dt`` and ``run.accept_inaccurate_dt`` (Verlet's time step),
#: ``output.events`` (Verlet's event log: the event stepper always logs) and
#: ``output.thermo`` (steps between thermo lines: the event stepper writes one after
#: each 1/20 of t_end); ``run.rtol``, ``run.atol`` and ``run.max_events`` (the event
#: stepper's series tolerances and event cap). The ``run`` ones are fields of one
#: member of :data:`Run` only; the ``output`` ones are checked by the scene. Every
#: other field of ``run`` and ``output`` is read by both.
STEPPER_OPTIONS = {
    "verlet": ("run.dt", "run.check_dt", "run.accept_inaccurate_dt", "output.events",
               "output.thermo"),
    "event": ("run.rtol", "run.atol", "run.max_events"),
}


def _run_options(stepper: str) -> list[str]:
    """The fields of ``run`` that only ``stepper`` reads (:data:`STEPPER_OPTIONS`)."""
    return [p.split(".")[1] for p in STEPPER_OPTIONS[stepper] if p.startswith("run.")]


#: Granule velocities given by index: {index: value}.
SparseVelocity = dict[Annotated[int, BeforeValidator(_index_key)], Finite]


class Stage(_Strict):
    """One stage of a staged run (``run.stages``): the run goes on from the state the
    stage before it ended in, changed as the stage says, until the stage's t_end.

    Only granule velocities change at a stage's start, and only those listed; the
    change's energy enters the ledger as ``stage_work``. The first stage runs the
    scene as written from t = 0.
    """

    t_end: Positive = Field(..., description="The stage ends at this time (the run's "
                            "clock, from t = 0 at the first stage's start); strictly "
                            "greater than the stage before's.")
    name: Optional[Annotated[str, BeforeValidator(_name)]] = Field(
        None, description="A name for the stage, recorded in summary.json (default "
        "stage<k>, k from 0).")
    velocity: SparseVelocity = Field(
        default_factory=dict, description="Velocities set at the stage's start, "
        "{index: value} (e.g. {0: 0.5} strikes granule 0); the others keep theirs. "
        "Not in the first stage (granules.velocity sets the start).")
    velocity_add: SparseVelocity = Field(
        default_factory=dict, description="Velocities added at the stage's start, "
        "{index: change}, after run.stages[k].velocity. Not in the first stage.")

    def changes(self) -> bool:
        """Whether the stage changes the state at its start."""
        return bool(self.velocity or self.velocity_add)


class _RunCommon(_Strict):
    """What both steppers read: when to stop, the ledger's tolerance, the stages.
    :class:`RunVerlet` and :class:`RunEvent` add the options of their stepper."""

    stepper: str
    t_end: Positive = Field(10.0, description="Stop at this time at the latest.")
    stop: Union[Literal["t_end", "separation", "rest"], list[Literal["separation", "rest"]]] = Field(
        "t_end",
        description="Extra stop condition(s) besides t_end: 'separation' = first opening of "
        "contact stop_contact after it has been closed, 'rest' = every granule at rest "
        "(exactly, held by static friction); a list stops at whichever comes first.")

    @property
    def stop_conditions(self) -> set:
        """The stop conditions besides t_end: a subset of {"separation", "rest"}."""
        s = self.stop
        return set(s) if isinstance(s, list) else ({s} - {"t_end"})
    stop_contact: Annotated[int, Int] = Field(0, ge=0, description="Contact index for stop: separation.")
    max_steps: Annotated[int, Int] = Field(2_000_000_000, ge=1, description="Refuse to take more steps.")
    energy_tolerance: Optional[Positive] = Field(
        DEFAULT_ENERGY_TOLERANCE, description="Largest relative energy-ledger error a "
        "successful run may have: a run that misses it ends with status inaccurate (exit "
        "status 1); null: no such judgement. Default 0.01: every shipped scene at its own dt "
        "keeps its Verlet ledger within 1.2e-4, so 0.01 flags only runs whose energy is "
        "visibly wrong (chain_walls.yaml with exponents 1.001: 0.046 at its default step). "
        "The event stepper also holds its runs to the far tighter tolerance it promises.")
    stages: Optional[list[Stage]] = Field(
        None, description="Run in stages, one after another in one run folder: each "
        "goes on from the state the stage before ended in, with the velocities its "
        "fields set or add, to its own t_end (e.g. settle under gravity, then strike). "
        "run.t_end may be left out (it is the last stage's) or equal to it. Not with "
        "run.stop conditions, moving walls, output.checkpoint_every or output.thermo; "
        "granular-chain run --restart does not continue a staged run.", min_length=1)

    @model_validator(mode="before")
    @classmethod
    def _other_steppers_options(cls, data: Any, info: ValidationInfo) -> Any:
        """An option of the other stepper is not a field here: say so in one line,
        naming the stepper that reads it. One set to null is left out (as not given:
        ``--set run.dt=null`` unsets a Verlet step when the stepper changes). The
        scene of a finished run, read back for its record, may hold the other
        stepper's defaults (scenes were once stored with every option of both):
        those are left out too."""
        if not isinstance(data, dict):
            return data
        mine = cls.model_fields["stepper"].default
        other, = (s for s in STEPPER_OPTIONS if s != mine)
        foreign = [name for name in _run_options(other) if name in data]
        stored = (info.context or {}).get("stored")
        given = [name for name in foreign if data[name] is not None and not stored]
        if given:
            raise _FieldProblem(f"run.{given[0]}", (
                f"is read by the {other} stepper only; with run.stepper: {mine} it would "
                f"be ignored: remove it (or set it to null), or use run.stepper: {other}"))
        return {k: v for k, v in data.items() if k not in foreign} if foreign else data

    @model_validator(mode="after")
    def _stage_times(self) -> "_RunCommon":
        """Stage ends strictly increasing; run.t_end, when given, the last stage's."""
        if not self.stages:
            return self
        for k in range(1, len(self.stages)):
            if not self.stages[k].t_end > self.stages[k - 1].t_end:
                raise _FieldProblem(f"run.stages[{k}].t_end", (
                    f"{self.stages[k].t_end:g} is not after the stage before's t_end "
                    f"{self.stages[k - 1].t_end:g}: stage ends must increase strictly"))
        first, last = self.stages[0], self.stages[-1].t_end
        if first.changes():
            raise _FieldProblem(f"run.stages[0].{'velocity' if first.velocity else 'velocity_add'}",
                                "the first stage starts from the scene as written: give "
                                "the starting velocities in granules.velocity")
        if "t_end" in self.model_fields_set and self.t_end != last:
            raise _FieldProblem("run.t_end", f"is {self.t_end:g} but the last stage ends at "
                                f"{last:g}: leave run.t_end out, or make them equal")
        self.__dict__["t_end"] = last  # (an assignment would validate the model again)
        return self


_STEPPER = ("Time stepper: 'verlet' (fixed step, the default) or 'event' (exact "
            "event-driven motion); each takes its own options besides the common ones.")


class RunVerlet(_RunCommon):
    """``run`` with ``stepper: verlet`` (the default): velocity Verlet at a fixed step."""

    stepper: Literal["verlet"] = Field("verlet", description=_STEPPER)
    dt: Optional[Positive] = Field(
        None, description="Verlet time step; default 1/200 of the shortest contact period.")
    check_dt: Bool = Field(
        True, description="Refuse a Verlet dt above the stability limit of the stiffest "
        "contact (turn off only to study instability: the run then stops at the first "
        "non-finite state with status nonfinite); off, run.dt is not held to the accuracy "
        "bound either.")
    accept_inaccurate_dt: Bool = Field(
        False, description="Run a Verlet run.dt above the accuracy bound (1/50 of the "
        "shortest contact period or collision time; with linear dashpots also 1/40 of the "
        "shortest relaxation time m_eff/c), which is otherwise refused before the run with "
        "the bound in the message. The run is still judged by run.energy_tolerance.")


class RunEvent(_RunCommon):
    """``run`` with ``stepper: event``: the exact event-driven stepper."""

    stepper: Literal["event"] = Field("event", description=_STEPPER)
    rtol: Positive = Field(1e-12, description="Relative tolerance (event stepper, n != 2).")
    atol: Positive = Field(1e-14, description="Absolute tolerance (event stepper, n != 2).")
    max_events: Annotated[int, Int] = Field(1_000_000, ge=1, description="Event stepper: most events.")


def own_stepper_options(scene: dict) -> dict:
    """A stored scene mapping with its ``run`` holding only the options of its own
    stepper: a run folder written when scenes were stored with every option of both
    steppers compares equal to the scene it continues with (``--restart``).

    Parameters
    ----------
    scene : dict
        A scene mapping as stored in summary.json or a checkpoint.

    Returns
    -------
    dict
        The same mapping (a shallow copy with a new ``run`` when anything is left out).
    """
    run = scene.get("run") if isinstance(scene, dict) else None
    if not isinstance(run, dict):
        return scene
    mine = run.get("stepper", "verlet")
    foreign = {name for owner in STEPPER_OPTIONS if owner != mine for name in _run_options(owner)}
    if not foreign & set(run):
        return scene
    return {**scene, "run": {k: v for k, v in run.items() if k not in foreign}}


def _stepper_tag(data: Any) -> str:
    """Which member of :data:`Run` a ``run`` mapping (or model) is: by its ``stepper``
    (default verlet); an unknown stepper's tag matches no member, and the error
    names ``run.stepper`` (:mod:`.messages`)."""
    stepper = data.get("stepper", "verlet") if isinstance(data, dict) else getattr(
        data, "stepper", "verlet")
    return f"stepper[{stepper}]"


#: The ``run`` section: :class:`RunVerlet` or :class:`RunEvent`, chosen by
#: ``run.stepper``, so that an option the chosen stepper ignores is not a field.
Run = Annotated[Union[Annotated[RunVerlet, Tag("stepper[verlet]")],
                      Annotated[RunEvent, Tag("stepper[event]")]],
                Discriminator(_stepper_tag)]
