"""Many runs of one scene differing only in friction (two-granule collision maps).

The scene is packed once (:func:`~.pack.pack_run`, the packing every event run
uses) and every array of the kernel's records is moved into one byte buffer
(each array a typed view at an 8-byte aligned offset), so a run restores the
packed state with one copy, sets the point's friction and calls the kernel
from a compiled loop (:func:`_run_points`): no per-run Python, no Result
objects. Every run gives bitwise the numbers
:func:`~.driver.simulate_events` gives for the scene with that friction.
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import NamedTuple

import numpy as np
from numba import literally

from ..._compile import compile_scope, kernel, specialised
from ...codes import EventKind, Pause, Status
from ...interrupts import StopRequest, stop_signals
from ...model import LAW_LINEAR, Model
from ...result import Result
from ...units import internal_scales
from .driver import drive, grow_buffers, next_budget
from .kernel import run_events
from .modes import initial_friction_modes
from .options import EventOptions, event_options
from .pack import linear_step_cap, pack_run
from .report import build_result

__all__ = ["EventBatch", "BatchOutput", "POINT_BUDGET"]

#: Main-loop passes one point of an :class:`EventBatch` may make in the compiled
#: loop before it is resumed from Python (a two-granule collision makes 5-100).
POINT_BUDGET = 1 << 14

class FrictionPoints(NamedTuple):
    """The friction of every point, (M, N) each."""

    eta: np.ndarray
    eta_static: np.ndarray
    gamma: np.ndarray


class PointResults(NamedTuple):
    """Per-point end state written by the compiled loop (M points, N granules)."""

    code: np.ndarray     #: (M,) int64 Status
    t_final: np.ndarray  #: (M,)
    v_final: np.ndarray  #: (M, N)
    energy: np.ndarray   #: (M, 3) kinetic and elastic at the end, elastic at t = 0
    t_stop: np.ndarray   #: (M, N) time of each granule's first stop event, NaN if none


@kernel(error_model="numpy", _nrt=False)
def _extract(p, code, clock, frames, log, out):
    """Store point p's end state (see :class:`PointResults`)."""
    out.code[p] = code
    out.t_final[p] = clock.time
    nfr = clock.n_frames
    for i in range(out.v_final.shape[1]):
        out.v_final[p, i] = frames.v[nfr - 1, i]
        out.t_stop[p, i] = math.nan
    out.energy[p, 0] = frames.e[nfr - 1, 0]
    out.energy[p, 1] = frames.e[nfr - 1, 1]
    out.energy[p, 2] = frames.e[0, 1]
    for q in range(clock.n_events):
        if log.kind[q] == EventKind.STOP:
            i = log.index[q]
            if math.isnan(out.t_stop[p, i]):
                out.t_stop[p, i] = log.t[q]


@kernel(error_model="numpy")  # (NRT on: numba's slice copies need it)
def _run_points(law, coulomb, viscous, rec, flat, template, points, out, start, end):
    """Run the packed scene once per row start <= p < end of ``points``.

    ``rec`` holds the kernel's records, all views into the byte buffer ``flat``,
    whose initial contents are ``template`` (the settings' work budget
    included): each run starts from exactly the state the packing produced,
    with the point's friction and the friction-dependent entries (friction
    modes, the n = 2 step cap) set by the same functions the packing uses.
    Returns ``end``, or the first point whose run filled a buffer or spent its
    budget: its state is left in the records for the caller to resume.
    """
    law = literally(law)
    coulomb = literally(coulomb)
    viscous = literally(viscous)
    for p in range(start, end):
        flat[:] = template
        rec.model.eta[:] = points.eta[p]
        rec.model.eta_static[:] = points.eta_static[p]
        rec.model.gamma[:] = points.gamma[p]
        initial_friction_modes(rec.model, rec.state)
        if law == LAW_LINEAR:
            rec.settings[0].step_cap = linear_step_cap(rec.model)
        code = run_events(law, coulomb, viscous, None, rec.settings, rec.clock, rec.model,
                          rec.state,
                          rec.work, rec.frames, rec.log)
        if code == Pause.LOG_FULL or code == Pause.CHUNK_DONE:
            return p
        _extract(p, code, rec.clock[0], rec.frames, rec.log, out)
    return end


def _into_bytes(records):
    """Move every array of ``records`` into one byte buffer: (records of views, buffer)."""
    arrays = [records.settings, records.clock]
    for group in records[2:]:
        arrays.extend(group)
    offsets, size = [], 0
    for a in arrays:
        offsets.append(size)
        size += -(-a.nbytes // 8) * 8
    flat = np.zeros(size, dtype=np.uint8)
    views = []
    for a, off in zip(arrays, offsets):
        view = flat[off:off + a.nbytes].view(a.dtype).reshape(a.shape)
        view[...] = a
        views.append(view)
    settings, clock, *rest = views
    groups, k = [], 0
    for group in records[2:]:
        groups.append(type(group)(*rest[k:k + len(group)]))
        k += len(group)
    return type(records)(settings, clock, *groups), flat


@dataclasses.dataclass
class BatchOutput:
    """Per-point end state of :meth:`EventBatch.run` (M points, N granules).

    All numbers in the scene's scaled units, which are the kernel's.

    Attributes
    ----------
    code : ndarray, shape (M,)
        The run's :class:`~granular_chain.codes.Status` (int64).
    t_final : ndarray, shape (M,)
        Time the run ended (NaN for points a stop request left unrun).
    v_final : ndarray, shape (M, N)
        Velocities at the end.
    kinetic : ndarray, shape (M,)
        Kinetic energy at the end.
    potential : ndarray, shape (M,)
        Elastic energy at the end.
    initial : ndarray, shape (M,)
        Kinetic + elastic energy at t = 0 (EnergyLedger.initial).
    t_stop : ndarray, shape (M, N)
        Time of each granule's first stop event, NaN if none.
    wall_time : float
        Seconds in the kernel (compiled loop and resumed runs).
    last_records : EventRecords
        The kernel's records holding the last point's run.
    signal : int
        SIGINT/SIGTERM number if a stop request ended the batch early, else 0.
    """

    code: np.ndarray  #: (M,) the run's Status (int)
    t_final: np.ndarray  #: (M,)
    v_final: np.ndarray  #: (M, N)
    kinetic: np.ndarray  #: (M,) kinetic energy at the end
    potential: np.ndarray  #: (M,) elastic energy at the end
    initial: np.ndarray  #: (M,) kinetic + elastic energy at t = 0 (EnergyLedger.initial)
    t_stop: np.ndarray  #: (M, N) time of each granule's first stop event, NaN if none
    wall_time: float  #: seconds in the kernel (compiled loop and resumed runs)
    last_records: object  #: the kernel's records holding the last point's run
    signal: int = 0  #: SIGINT/SIGTERM number if a stop request ended the batch early


class EventBatch:
    """One scene run many times with different friction, the event stepper's packing reused.

    Only for scenes that are already in scaled units (the kernel's units, see
    :func:`granular_chain.units.internal_scales`), and only for points whose
    friction has the scene's features (Coulomb friction present or not, viscous
    friction present or not): :func:`granular_chain.model.friction_features` tells.

    Parameters
    ----------
    scene : Scene or EventOptions
        The Scene (read once, :func:`~.options.event_options`) or its
        :class:`~.options.EventOptions` (times in scaled units).
    model : Model
        The scene's Model, in scaled units (mass 1, force coefficient 1, largest
        speed 1).

    Raises
    ------
    ValueError
        When the model is not in the kernel's scaled units.
    """

    def __init__(self, scene, model: Model):
        """Pack the scene once and compile the batch loop for its features."""
        if model.units != "scaled" or internal_scales(model) is not None:
            raise ValueError("EventBatch needs a scene in the kernel's scaled units "
                             "(mass 1, force coefficient 1, largest speed 1)")
        self.scene, self.model = scene, model
        options = scene if isinstance(scene, EventOptions) else event_options(scene)
        packed = pack_run(model, options)
        packed.records, self._flat = _into_bytes(packed.records)
        self.packed = packed
        self._template = self._flat.copy()
        self._template_settings = self._template[:packed.records.settings.nbytes].view(
            packed.records.settings.dtype)
        self._template_settings[0]["budget"] = POINT_BUDGET
        N = model.count
        probe = self._call_args(FrictionPoints(*(np.zeros((1, N)),) * 3), _results(1, N), 0, 1)
        with compile_scope(f"event stepper, many collisions: {model.features.in_words()}"):
            self._entry = specialised(_run_points, probe, (0, 1, 2))

    def _call_args(self, points, out, start, end):
        pk = self.packed
        return [pk.law, pk.coulomb, pk.viscous, pk.records, self._flat, self._template, points,
                out, start, end]

    def run(self, eta, eta_static, gamma) -> BatchOutput:
        """Run every point (M points, N granules).

        The returned ``last_records`` hold the last point's run, from which
        :meth:`result` makes its full Result.

        Parameters
        ----------
        eta : array_like, shape (M, N)
            Kinetic (Coulomb) friction force of each granule at each point, scaled units.
        eta_static : array_like, shape (M, N)
            Static friction threshold, scaled force units.
        gamma : array_like, shape (M, N)
            Viscous friction coefficient, scaled units (force per velocity).

        Returns
        -------
        BatchOutput
            The end state of every point; points left unrun by a stop request have
            code Status.INTERRUPTED and t_final NaN.

        Raises
        ------
        ValueError
            When the three arrays do not all have shape (M, N).
        """
        shape = (len(eta), self.model.count)
        arrs = [np.ascontiguousarray(x, dtype=np.float64) for x in (eta, eta_static, gamma)]
        if not arrs[0].shape == arrs[1].shape == arrs[2].shape == shape:
            raise ValueError(f"eta, eta_static and gamma must all have shape {shape}")
        M = shape[0]
        out = _results(M, shape[1])
        call = self._call_args(FrictionPoints(*arrs), out, 0, 0)
        # The first call (16 points of at most POINT_BUDGET passes) runs without
        # the signal handlers: a single collide() costs ~130 us, and installing
        # and restoring them would add ~50 % to it. Chunks then last ~CHUNK_SECONDS.
        p, chunk, wall, last, stop = self._chunk(call, 0, 16, None, self.packed.records)
        if p < M and not stop.requested:
            with stop_signals() as stop:
                while p < M and not stop.requested:
                    p, chunk, w, last, _ = self._chunk(call, p, chunk, stop, last)
                    wall += w
        if p < M:  # stopped by a signal: the points not run are marked so
            out.code[p:] = Status.INTERRUPTED
            out.t_final[p:] = math.nan
        return BatchOutput(code=out.code, t_final=out.t_final, v_final=out.v_final,
                           kinetic=out.energy[:, 0], potential=out.energy[:, 1],
                           initial=self.packed.ke0 + out.energy[:, 2], t_stop=out.t_stop,
                           wall_time=wall, last_records=last, signal=stop.signum)

    def _chunk(self, call, p, chunk, stop, last):
        """Run points p .. p + chunk - 1 in the compiled loop, resuming from Python
        a point that filled a buffer or spent its budget. Returns the next point,
        the next chunk size, the wall time, the records of the last point and the
        stop request (``stop``, or, when None, a request whose handlers were
        installed only while a point was resumed)."""
        out = call[7]
        M = len(out.code)
        end = min(M, p + chunk)
        call[8:10] = [p, end]
        t0 = time.perf_counter()
        q = self._entry(*call)
        wall = time.perf_counter() - t0
        chunk = next_budget(chunk, wall * chunk / max(q - p, 1))
        if q >= end:
            return end, chunk, wall, last, stop or StopRequest()
        # Point q filled a buffer or spent its budget: resume it the ordinary way
        # (drive), on a copy of the records whose grown buffers replace the byte
        # buffer's views there only.
        pk = self.packed.with_records(self.packed.records)
        grow_buffers(pk)
        if stop is None:
            with stop_signals() as stop:
                c, w = drive(pk, stop)
        else:
            c, w = drive(pk, stop)
        rec = pk.records
        _extract(q, c, rec.clock[0], rec.frames, rec.log, out)
        # the last point's run: in the grown buffers if it was this one, else
        # (later points ran in the loop) in the byte buffer's views
        return q + 1, chunk, wall + w, (rec if q == M - 1 else self.packed.records), stop

    def result(self, out: BatchOutput) -> Result:
        """The full Result of the last point of ``out`` (as simulate_events returns it).

        Parameters
        ----------
        out : BatchOutput
            The output of :meth:`run` on this batch.

        Returns
        -------
        Result
            The last point's run, in the scene's scaled units.
        """
        pk = self.packed.with_records(out.last_records)
        return build_result(pk, int(out.code[-1]), out.wall_time, self.model, 1.0)


def _results(M: int, N: int) -> PointResults:
    return PointResults(code=np.zeros(M, dtype=np.int64), t_final=np.zeros(M),
                        v_final=np.zeros((M, N)), energy=np.zeros((M, 3)),
                        t_stop=np.zeros((M, N)))
