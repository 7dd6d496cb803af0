"""trajectory.h5: positions, velocities, forces and the energy ledger at the output frames.

The file is netCDF-4 (HDF5 with dimension scales) following the CF conventions,
so netCDF tools and xarray read it with named dimensions::

    import xarray as xr
    ds = xr.open_dataset("outputs/hertz_chain/trajectory.h5", engine="h5netcdf")
    ds.v.sel(granule=10)                      # v_10(t), a DataArray over time

and h5py reads it as plain HDF5 (``h5py.File(path)["x"][...]``, shape (frames, granules)).

Layout (``units`` and ``long_name`` on every variable; scaled scenes use CF's
dimensionless unit ``"1"``, physical ones SI):

``time`` (time), unlimited, and ``granule`` (granule)
    Dimension scales: frame times (elapsed since the run's start: a plain
    coordinate, not CF's calendar time axis, which needs a reference date), and
    granule indices 0..N-1 from the left.
``x``, ``v``, ``f`` (time, granule)
    Centre positions, velocities, net contact force (neighbours and walls).
``kinetic``, ``potential``, ``coulomb``, ``viscous``, ``contact_dissipated``, ``wall_work``,
``body_work``, ``stage_work``, ``balance`` (time)
    The energy ledger (the columns of energy.csv).
``stage`` (time)
    A staged run's (``run.stages``) stage index of each frame, 0 for the first
    stage; only in the files of staged runs.
``mass``, ``radius``, ``friction_kinetic``, ``friction_static``, ``friction_viscous`` (granule)
    The per-granule values the run used (drawn values, for scenes with distributions).
``x_final``, ``v_final`` (granule); ``event_time``, ``event_kind``, ``event_index``,
``event_step`` (event)
    The final state and the event log (written when the run is closed);
    ``event_kind`` is a CF flag variable: int8 codes with ``flag_values`` 0..3 and
    ``flag_meanings`` "contact_close contact_open stop slip"
    (:func:`event_kind_names` reads it, and the strings of earlier files).

Global attributes: ``Conventions``, ``title``, ``source``, ``engine_version``,
``scene`` (the validated scene as YAML text: distributions appear as their recipe,
from which the drawn values are reproducible), ``scene_name``, ``units_system``;
after the run: ``status`` (a name such as ``t_end``), ``status_code``,
``success`` (1/0), ``message``, ``stepper``, ``dt``, ``steps``, ``wall_time_s``,
``t_final``, ``energy_initial``, ``event_counts`` and ``info`` (JSON text).

:class:`TrajectoryWriter` appends frames while a run goes (resizable datasets,
one chunk's worth of frames held in memory: a chunk of a (time, granule) array
holds whole frames, at most 16 and at most 512 KiB, one of a (time,) array 512
frames); :func:`write_trajectory` streams a finished
:class:`~granular_chain.result.Result` through it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import h5py
import numpy as np

from .._compile import kernel
from ..conventions import EVENT_FIELDS as _EVENT_FIELDS
from ..conventions import FRAME_FIELDS, LEDGER_FIELDS
from ..conventions import GRANULE_FIELDS as _GRANULE_FIELDS
from ..conventions import LEDGER_TERMS as _LEDGER_TERMS
from ..conventions import TIME_NAME as _TIME
from ..conventions import cf_attrs as _attrs
from ..conventions import event_columns as _event_columns
from ..conventions import final_attrs, granule_values, root_attrs
from ..result import ledger_balance, run_model

__all__ = ["TrajectoryWriter", "TrajectoryFrames", "write_trajectory", "FRAME_FIELDS",
           "LEDGER_FIELDS"]

# Values in one chunk of a (time, granule) array, at most: 512 KiB of float64, so
# reading one frame reads little more than it (a chunk holds at least one frame).
_CHUNK_VALUES = 2 ** 16
_SERIES_ROWS = 512  # frames in one chunk of a (time,) array

@kernel(nogil=True)
def _copy_frame(row, x_rows, v_rows, f_rows, x, v, f):
    """Copy one frame's x, v, f (shape (N,)) into row ``row`` of a block's
    (rows, N) arrays, without the GIL.

    Three numpy copies would let go of the GIL and take it back three times a
    frame, each a hand-over with the stepping thread; this call does it once
    (docs/performance.md, "Writing while the run goes", for what the writers'
    thread costs the stepping thread).
    """
    x_rows[row, :] = x
    v_rows[row, :] = v
    f_rows[row, :] = f


def _doubles(a) -> np.ndarray:
    """``a`` as a contiguous float64 array (itself when it is one already)."""
    return np.ascontiguousarray(a, dtype=np.float64)


class _Block:
    """The frames of one HDF5 chunk along time, for growable variables of the same
    shape and chunks, (time,) or (time, granule): filled in memory, then written whole.

    A chunk spans ``rows`` frames and every granule. The block starts at frame
    ``base``, a multiple of ``rows``, and holds ``fill`` frames. :meth:`write`
    stores it as one chunk per variable with HDF5's direct chunk write (no
    selection, no type conversion, no chunk cache), after setting each
    variable's length to ``base + fill``: a block written before it is full is
    written again, whole, as it fills.
    """

    def __init__(self, h5, names):
        self.datasets = {name: h5[name] for name in names}
        first = next(iter(self.datasets.values()))
        shape = first.chunks
        if shape[1:] != first.shape[1:]:
            raise ValueError(f"{h5.filename}: the chunks of {first.name} do not span a whole "
                             f"frame ({shape}); this file cannot be continued")
        self.rows, self.base, self.fill = shape[0], 0, 0
        # (in the dataset's own type: a direct chunk write stores the bytes as they are)
        self.values = {name: np.zeros(shape, dtype=ds.dtype)
                       for name, ds in self.datasets.items()}

    def start_at(self, frames: int) -> None:
        """Continue after the first ``frames`` frames of the file (read back the
        partial block they end in)."""
        self.base = frames - frames % self.rows
        self.fill = frames - self.base
        for name, values in self.values.items():
            values[:self.fill] = self.datasets[name][self.base:frames]

    def write(self) -> None:
        """Store the block in the file (each variable's length set to its last frame);
        nothing when it is empty (the chunk before it is in the file)."""
        if not self.fill:
            return
        end = self.base + self.fill
        for name, values in self.values.items():
            dsid = self.datasets[name].id
            dsid.set_extent((end, *values.shape[1:]))
            dsid.write_direct_chunk((self.base,) + (0,) * (values.ndim - 1), values)

    def next_block(self) -> None:
        """The block is written and full: go on with the next one."""
        self.base += self.rows
        self.fill = 0


class TrajectoryWriter:
    """Append output frames to ``folder/trajectory.h5`` while a run goes.

    Frames are gathered in one HDF5 chunk's worth (``chunk_frames`` frames of the
    (time, granule) arrays, fewer when N is so large that a chunk would pass
    512 KiB; 512 frames of the (time,) ledger arrays), and each full chunk is
    written as it is with HDF5's direct chunk write. So memory does not grow
    with the number of frames, and writing a frame costs little more than
    copying it into the chunk and the chunk into the file's pages.

    Parameters
    ----------
    folder : path
        Folder the file is written into (``folder/trajectory.h5``, replaced).
    scene : Scene or None
        Stored as YAML text; sets the units.
    count : int
        Number of granules N.
    chunk_frames : int
        Frames in one chunk of the (time, granule) arrays, at most.
    resume_frames : int, optional
        Continue an existing file after its first ``resume_frames`` frames (a run
        restarted from a checkpoint); later frames and the final state are dropped.
    model : Model, optional
        The run's chain constants: its per-granule arrays (masses, radii, friction)
        are stored with the frames.

    Notes
    -----
    Use as a context manager; :meth:`close` with the run's Result writes the
    final state, events and status. Leaving the block without it flushes the
    frames and closes the file without a status (readers then refuse it).
    """

    def __init__(self, folder, scene, count: int, *, chunk_frames: int = 16,
                 resume_frames: Optional[int] = None, model=None):
        self.path = Path(folder) / "trajectory.h5"
        self.count = int(count)
        self._units = scene.units if scene is not None else "scaled"
        if resume_frames is not None:
            self._h5 = h5py.File(self.path, "a")
        else:
            self._h5 = h5py.File(self.path, "w", track_order=True)
        try:
            if resume_frames is None:  # (a continued file keeps its chunks)
                self._create(scene, model, max(1, min(int(chunk_frames),
                                                      _CHUNK_VALUES // max(self.count, 1))))
            self._states = _Block(self._h5, FRAME_FIELDS)
            rows = [self._states.values[name] for name in FRAME_FIELDS]
            # compiled (or loaded from the cache) here, not by the writers' thread mid-run
            _copy_frame(0, *rows, *(r[0] for r in rows))
            self._ledger = _Block(self._h5, ("time", *_LEDGER_TERMS))
            # a staged run's stage index of each frame (run.stages)
            self._stage = _Block(self._h5, ("stage",)) if "stage" in self._h5 else None
            if resume_frames is not None:
                self._reopen(int(resume_frames))
                # (a run extended to a later t_end: the file describes the new scene)
                self._h5.attrs.update(root_attrs(scene))
        except BaseException:
            self._h5.close()
            raise

    @property
    def frames(self) -> int:
        """Frames written so far (in the file, or in the chunk being filled)."""
        return self._ledger.base + self._ledger.fill

    def _reopen(self, frames: int) -> None:
        """Continue a file from its first ``frames`` frames (a run restarted from a
        checkpoint): later frames and what :meth:`close` wrote are dropped."""
        h5 = self._h5
        if h5["time"].shape[0] < frames:
            raise ValueError(f"{self.path} holds {h5['time'].shape[0]} frames, fewer than the "
                             f"checkpoint's {frames}")
        for name in ("balance", "x_final", "v_final", *_EVENT_FIELDS, "event"):
            if name in h5:
                del h5[name]
        for name in ("status", "status_code", "success", "message", "steps", "wall_time_s",
                     "t_final", "energy_initial", "event_counts", "info", "dt"):
            if name in h5.attrs:
                del h5.attrs[name]
        for name in ("time", *FRAME_FIELDS, *_LEDGER_TERMS):
            h5[name].resize(frames, axis=0)
        for block in self._blocks():
            block.start_at(frames)

    def _blocks(self) -> tuple:
        """The blocks of growable variables, each written whole (see :class:`_Block`)."""
        return (self._states, self._ledger) + ((self._stage,) if self._stage else ())

    def _create(self, scene, model, rows: int) -> None:
        """The variables, dimensions and attributes of a new file; ``rows``: frames in
        a chunk of the (time, granule) arrays."""
        h5, n = self._h5, self.count
        h5.attrs.update(root_attrs(scene))
        time = h5.create_dataset("time", shape=(0,), maxshape=(None,), dtype="f8",
                                 chunks=(_SERIES_ROWS,))
        time.attrs.update(_attrs(self._units, "time", _TIME))
        time.make_scale("time")
        granule = h5.create_dataset("granule", data=np.arange(n, dtype=np.int64))
        granule.attrs.update(_attrs(self._units, "", "granule index, 0 at the left end"))
        granule.make_scale("granule")
        for name, (kind, text) in FRAME_FIELDS.items():  # a chunk: whole frames
            ds = h5.create_dataset(name, shape=(0, n), maxshape=(None, n), dtype="f8",
                                   chunks=(rows, n))
            ds.attrs.update(_attrs(self._units, kind, text))
            ds.dims[0].attach_scale(time)
            ds.dims[1].attach_scale(granule)
        for name in _LEDGER_TERMS:  # balance needs the initial energy: written by close()
            self._series(name)
        if scene is not None and scene.run.stages:
            stage = h5.create_dataset("stage", shape=(0,), maxshape=(None,), dtype="i4",
                                      chunks=time.chunks)
            stage.attrs.update(_attrs(self._units, "", "stage index (run.stages), 0 first"))
            stage.dims[0].attach_scale(time)
        for name, values in granule_values(model).items():
            _, kind, text = _GRANULE_FIELDS[name]
            self._put(name, values, ("granule",), kind, text)

    def _series(self, name: str):
        """An empty, growable (time,) ledger variable."""
        time = self._h5["time"]
        ds = self._h5.create_dataset(name, shape=(0,), maxshape=(None,), dtype="f8",
                                     chunks=time.chunks)
        ds.attrs.update(_attrs(self._units, "energy", LEDGER_FIELDS[name]))
        ds.dims[0].attach_scale(time)
        return ds

    def _put(self, name, data, dims, kind, text, dtype="f8") -> None:
        """A fixed-size variable attached to existing dimension scales."""
        ds = self._h5.create_dataset(name, data=np.asarray(data), dtype=dtype)
        ds.attrs.update(_attrs(self._units, kind, text))
        for i, dim in enumerate(dims):
            ds.dims[i].attach_scale(self._h5[dim])

    def write_frame(self, t, x, v, f, kinetic, potential, coulomb, viscous,
                    contact_dissipated=0.0, wall_work=0.0, body_work=0.0, stage_work=0.0,
                    stage=0) -> None:
        """Append one frame: time, state arrays of shape (N,) and the ledger terms
        (energy units; the last three are zero in a scene without dashpots, moving
        walls or body forces).

        Parameters
        ----------
        t : float
            Frame time, scene units of time.
        x, v, f : numpy.ndarray
            Shape (N,) each: centre positions, velocities and net spring forces,
            scene units (length, speed, force).
        kinetic, potential : float
            Kinetic and elastic energy, scene units of energy.
        coulomb, viscous : float
            Energy dissipated so far by Coulomb friction and drag, scene units of energy.
        contact_dissipated, wall_work, body_work, stage_work : float
            Energy dissipated by dashpots and work of moving walls, body forces and
            stage changes so far, scene units of energy (0 when absent).
        stage : int
            The frame's stage index (written in the files of staged runs only).
        """
        states, ledger = self._states, self._ledger
        values = states.values
        _copy_frame(states.fill, values["x"], values["v"], values["f"], _doubles(x),
                    _doubles(v), _doubles(f))
        j, series = ledger.fill, ledger.values
        series["time"][j] = t
        for name, value in zip(_LEDGER_TERMS, (kinetic, potential, coulomb, viscous,
                                               contact_dissipated, wall_work, body_work,
                                               stage_work)):
            series[name][j] = value
        blocks = self._blocks()
        if self._stage is not None:
            self._stage.values["stage"][self._stage.fill] = stage
        for block in blocks:
            block.fill += 1
        if any(block.fill == block.rows for block in blocks):
            self._write_blocks()

    def _write_blocks(self) -> None:
        """Write both blocks (so every variable has the same frames), going on with
        the next block of each that is full."""
        for block in self._blocks():
            block.write()
            if block.fill == block.rows:
                block.next_block()

    def flush(self) -> None:
        """Write the frames gathered so far to the file (and the file to the system)."""
        if any(block.fill for block in self._blocks()):
            self._write_blocks()
        self._h5.flush()

    def close(self, result) -> None:
        """Flush, then write the ledger balance, final state, events and status; close the file.

        Parameters
        ----------
        result : Result
            The finished run (its energy, final state, events and status; scene units).
        """
        self.flush()
        h5 = self._h5
        bal = self._series("balance")
        bal.resize(self.frames, axis=0)
        step = 2 ** 16  # the ledger is read back in slices: memory stays bounded
        for a in range(0, self.frames, step):
            b = min(a + step, self.frames)
            terms = {name: h5[name][a:b] for name in _LEDGER_TERMS}
            bal[a:b] = ledger_balance(**terms, initial=result.energy.initial)
        self._put("x_final", result.x_final, ("granule",), "length", "final granule position")
        self._put("v_final", result.v_final, ("granule",), "velocity", "final granule velocity")
        self._write_events(result.events)
        h5.attrs.update(final_attrs(result))
        h5.close()

    def _write_events(self, events) -> None:
        ev = self._h5.create_dataset("event", data=np.arange(len(events), dtype=np.int64))
        ev.attrs.update(_attrs(self._units, "", "event number"))
        ev.make_scale("event")
        for name, (values, kind, text) in _event_columns(events).items():
            self._put(name, values, ("event",), kind, text, dtype=values.dtype)

    def __enter__(self) -> "TrajectoryWriter":
        return self

    def __exit__(self, exc_type, *exc) -> None:
        if self._h5.id.valid:  # not closed with a Result: keep the frames, no status
            try:
                if exc_type is None:
                    self.flush()
            finally:
                self._h5.close()


class TrajectoryFrames:
    """``trajectory.h5`` as a frame writer attached to a run (frames appended as they come).

    Parameters
    ----------
    folder : path
        Where ``trajectory.h5`` is written.
    scene : Scene
        Stored in the file; sets the units.
    count : int
        Number of granules N.
    resume_frames : int, optional
        Continue the file after this many frames (a run restarted from a checkpoint).
    model : Model, optional
        The run's chain constants (per-granule arrays stored with the frames).
    """

    def __init__(self, folder, scene, count: int, resume_frames: Optional[int] = None,
                 model=None):
        self.writer = TrajectoryWriter(folder, scene, count, resume_frames=resume_frames,
                                       model=model)
        self._open = True

    def flush(self) -> None:
        """Put the frames written so far on disk (before a checkpoint)."""
        self.writer.flush()

    def write_frame(self, frame) -> None:
        """Append one frame.

        Parameters
        ----------
        frame : Frame
            Time, positions, velocities, forces and ledger terms (scene units).
        """
        self.writer.write_frame(frame.t, frame.x, frame.v, frame.f, frame.kinetic,
                                frame.potential, frame.coulomb, frame.viscous,
                                frame.contact_dissipated, frame.wall_work, frame.body_work,
                                frame.stage_work, frame.stage)

    def close(self, result=None) -> None:
        """Close the file: with the run's Result, its final state, events and status;
        without (the run raised), the frames so far and no status.

        Parameters
        ----------
        result : Result, optional
            The finished run.
        """
        if not self._open:
            return
        self._open = False
        if result is None:
            self.writer.__exit__(None, None, None)
        else:
            self.writer.close(result)


def write_trajectory(result, folder: Path, scene=None) -> Path:
    """Write ``folder/trajectory.h5`` from a finished Result (streamed through
    :class:`TrajectoryWriter`); returns the path. ``scene`` is stored with the
    frames (and gives the chain constants of a Result that has none).

    Parameters
    ----------
    result : Result
        A finished run, scene units.
    folder : path
        Folder the file is written into (replaced if present).
    scene : Scene, optional
        The run's scene, stored as YAML; sets the units attributes.

    Returns
    -------
    pathlib.Path
        ``folder/trajectory.h5``.
    """
    led = result.energy
    with TrajectoryWriter(folder, scene, result.x.shape[1],
                          model=run_model(result, scene)) as w:
        for i in range(result.t.size):
            w.write_frame(result.t[i], result.x[i], result.v[i], result.f[i], led.kinetic[i],
                          led.potential[i], led.coulomb[i], led.viscous[i],
                          led.contact_dissipated[i], led.wall_work[i], led.body_work[i],
                          led.stage_work[i])
        w.close(result)
    return w.path
