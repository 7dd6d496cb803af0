"""VTK time series: one ``.vtp`` per output frame and a ``.pvd`` index with the physical times.

ParaView (File > Open ``run.pvd``) and pyvista open the run as one time series::

    import pyvista as pv
    reader = pv.get_reader("outputs/chain_friction/run.pvd")
    reader.time_values                       # the frame times, exactly Result.t
    reader.set_active_time_value(reader.time_values[10])
    frame = reader.read()[0]                 # a pyvista.PolyData
    frame.point_data["velocity"]

Layout of one frame (``vtk/frame_NNNNNN.vtp``, VTK XML PolyData, binary, zlib):

points, shape (N, 3)
    Granule centres ``(x_i, 0, 0)``.
point data, shape (N,)
    ``radius``, ``mass``, ``velocity`` (signed, along the chain), ``net_force`` (the net
    force on the granule from its neighbours, walls and body force, i.e. ``Result.f``;
    friction is not included because a stuck granule's static friction force is not
    a state variable), ``friction_state`` (int8: 1 stuck = at rest exactly with
    Coulomb friction present, 0 sliding/moving, -1 no Coulomb friction on that granule).
line cells, N - 1
    Every neighbour pair ``(i, i+1)``, open or closed, with cell data ``overlap``
    ``delta_i = r_i + r_(i+1) - (x_(i+1) - x_i)`` (negative = gap), ``force``
    (pushing apart when positive: the contact law of :mod:`granular_chain.laws.contact`
    ``k_i max(delta_i, 0)^(n_i - 1)`` plus, with dashpots, the dashpot force of
    :mod:`granular_chain.laws.damping` at the frame's velocities, clipped at 0 unless
    the contacts are tensile) and ``in_contact`` (uint8).
    All pairs are kept, not only the closed ones, so every frame has the same
    topology: ParaView's temporal filters (Plot Data Over Time on a contact) then
    follow one contact through the run, and Threshold on ``in_contact`` shows only the
    closed ones. Wall contacts have no second point, so they are not cells: their
    overlap and force are field data.
field data
    ``TimeValue`` (ParaView's per-file time), ``frame`` (index), ``friction_state_legend``;
    ``wall_overlap`` and ``wall_force``, shape (2,): the left then the right wall
    contact, as the cells' ``overlap`` and ``force`` (a chain without that wall:
    overlap NaN, force 0), a driven wall where it is at the frame's time (its speed
    in its dashpot). With them the contact forces add up to ``net_force`` less the
    body force ``b_i`` (gravity or given forces; 0 without): ``net_force_i - b_i =
    force_(i-1) - force_i``, with ``force_(-1) = wall_force_left`` and ``force_(N-1)
    = wall_force_right``.

What is written by hand: only the ``.pvd`` collection index (a ten-line XML file). VTK
has no writer for it outside ParaView, and meshio does not write it either (meshio's
time series are XDMF). The frames themselves are written by VTK's
``vtkXMLPolyDataWriter`` from pyvista meshes.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Optional
from xml.etree import ElementTree
from xml.sax.saxutils import quoteattr

from typing import NamedTuple

import numba
import numpy as np
from tqdm import tqdm

from .._compile import kernel, specialised
from ..extras import require
from ..laws.contact import LAW_POWER, contact_force
from ..laws.damping import DAMPING_NONE, damped_contact_force
from ..laws.wall_motion import wall_displacement, wall_speed
from ..result import run_model

__all__ = ["contact_overlap_force", "ContactForces", "WallContact", "wall_contacts",
           "Dissipation", "dissipation_of",
           "friction_state", "VTKSeriesWriter", "VTKFrames", "write_vtk", "FRAME_DIR",
           "PVD_NAME"]

FRAME_DIR = "vtk"
PVD_NAME = "run.pvd"
FRICTION_LEGEND = "1 stuck (v == 0 with Coulomb friction), 0 sliding or moving, " \
                  "-1 no Coulomb friction on this granule"


class WallContact(NamedTuple):
    """A fixed wall beyond an end granule, as the writers need it (scene units)."""

    d0: float  #: initial overlap of the wall contact (negative: a gap)
    k: float   #: force coefficient
    n: float   #: potential exponent
    x0: float  #: initial centre position of the end granule it touches


def wall_contacts(model) -> tuple:
    """``(left, right)``: the :class:`WallContact` of each wall of ``model``, or None.

    Parameters
    ----------
    model : Model
        The chain constants of the run.

    Returns
    -------
    (WallContact or None, WallContact or None)
        Left and right wall.
    """
    t = model.contacts
    left, right = (WallContact(float(t.d0[j]), float(t.k[j]), float(t.n[j]), float(model.x0[end]))
                   if t.present[j] else None for j, end in ((0, 0), (model.count, -1)))
    return left, right


class ContactForces(NamedTuple):
    """Overlaps and compressive forces of the contacts of one frame.

    Attributes
    ----------
    overlap, force : ndarray, shape (N-1,)
        Neighbour contacts i, i+1: ``delta_i = r_i + r_(i+1) - (x_(i+1) - x_i)``
        (negative is a gap) and ``F(delta_i) >= 0``.
    wall_overlap, wall_force : ndarray, shape (2,)
        The left then the right wall contact (NaN and 0 where there is no wall).
    """

    overlap: np.ndarray
    force: np.ndarray
    wall_overlap: np.ndarray
    wall_force: np.ndarray


@kernel()
def _law_forces(law, overlap, k, n, force):
    """``force[i] = F(overlap[i])`` by the contact law ``law`` of :mod:`..laws.contact`
    (LAW_LINEAR, LAW_HERTZ, LAW_POWER or a registered law's); arrays of shape (M,).
    Compiled once per law (its code a compile-time constant)."""
    law = numba.literally(law)
    for i in range(overlap.size):
        force[i] = contact_force(law, overlap[i], k[i], n[i])


class Dissipation(NamedTuple):
    """What sets a frame's contact forces besides positions: dashpots and driven walls.

    Attributes
    ----------
    damping : int
        Dashpot law (:mod:`granular_chain.laws.damping`).
    tensile : int
        1: a damped contact may pull while closed.
    coefficient : ndarray, shape (N+1,)
        Dashpot coefficient of the left wall, the N-1 contacts, the right wall.
    motion : ndarray, shape (2, 3)
        (kind, p1, p2) of the left and right wall (:mod:`granular_chain.laws.wall_motion`).
    """

    damping: int
    tensile: int
    coefficient: np.ndarray
    motion: np.ndarray


def dissipation_of(model) -> Optional[Dissipation]:
    """The :class:`Dissipation` of ``model``, or None for fixed walls and no dashpots.

    Parameters
    ----------
    model : Model
        The chain constants of the run.

    Returns
    -------
    Dissipation or None
    """
    feat = model.features
    if feat.damping == DAMPING_NONE and not feat.driven:
        return None
    t = model.contacts
    return Dissipation(int(feat.damping), int(feat.tensile), t.damping.copy(),
                       t.wall_motion.copy())


@kernel()
def _damped_forces(law, damping, tensile, overlap, rate, k, n, coefficient, force):
    """``force[i]``: spring plus dashpot of contact i (:func:`..laws.damping.damped_contact_force`)
    at overlap ``overlap[i]`` and overlap rate ``rate[i]``; arrays of shape (M,).
    Compiled once per law (its code a compile-time constant)."""
    law = numba.literally(law)
    for i in range(overlap.size):
        force[i] = damped_contact_force(law, damping, tensile, overlap[i], rate[i], k[i], n[i],
                                        coefficient[i])


def _wall_state(motion, t):
    """((s_L, s_R), (s_L', s_R')): the walls' displacements and speeds at time t."""
    s = tuple(float(wall_displacement(int(m[0]), m[1], m[2], t)) for m in motion)
    ds = tuple(float(wall_speed(int(m[0]), m[1], m[2], t)) for m in motion)
    return s, ds


def contact_overlap_force(x, radius, k, n, walls=(None, None), law: int = LAW_POWER,
                          v=None, t: float = 0.0,
                          dissipation: Optional[Dissipation] = None) -> ContactForces:
    """Overlap and force of every contact, neighbours and walls.

    The force is the contact law of :mod:`granular_chain.laws.contact`, the one
    the steppers call: ``law`` is the run's (``model.features.law``); the general
    power law ``k max(delta, 0)^(n - 1)`` by default. With ``dissipation`` it is
    the steppers' whole contact force: the dashpots' at velocities ``v``
    (:func:`granular_chain.laws.damping.damped_contact_force`) and the driven walls
    where they are at time ``t``. The overlaps are formed from positions, the
    steppers' from displacements: the two differ by a few ulps of the largest
    position.

    Parameters
    ----------
    x : ndarray, shape (N,)
        Centre positions.
    radius : ndarray, shape (N,)
        Radii r_i.
    k, n : ndarray, shape (N-1,)
        Force coefficient and potential exponent of each contact.
    walls : (WallContact or None, WallContact or None)
        The left and right wall (:func:`wall_contacts`); none by default.
    law : int
        The contact law code of every contact and wall (:mod:`..laws.contact`).
    v : ndarray, shape (N,), optional
        Velocities (needed with ``dissipation``).
    t : float
        Time of the frame since the run's start (driven walls).
    dissipation : Dissipation, optional
        Dashpots and wall motion (:func:`dissipation_of`); None: springs and fixed walls.

    Returns
    -------
    ContactForces
    """
    x = np.asarray(x, dtype=np.float64)
    N = x.size
    d = np.zeros(N + 1)  # left wall, the N-1 contacts, right wall
    d[1:N] = radius[:-1] + radius[1:] - (x[1:] - x[:-1])
    kk, nn = np.zeros(N + 1), np.full(N + 1, 2.0)
    kk[1:N], nn[1:N] = k, n
    left, right = walls
    present = [left is not None, right is not None]
    (s_left, s_right), (ds_left, ds_right) = (
        _wall_state(dissipation.motion, t) if dissipation is not None else ((0.0, 0.0),) * 2)
    if left is not None:  # delta_L = d0_L + s_L - u_0, with u_0 = x_0 - x0_0
        d[0], kk[0], nn[0] = left.d0 + s_left - (x[0] - left.x0), left.k, left.n
    if right is not None:  # delta_R = d0_R + u_(N-1) - s_R
        d[N], kk[N], nn[N] = right.d0 + (x[-1] - right.x0) - s_right, right.k, right.n
    force = np.zeros(N + 1)
    # each kernel compiled for the run's law, its code a compile-time constant
    # (specialised: looked up once per law, not typed again at every frame)
    if dissipation is None or dissipation.damping == DAMPING_NONE:
        args = (int(law), d, kk, nn, force)
        specialised(_law_forces, args, (0,))(*args)
    else:
        v = np.asarray(v, dtype=np.float64)
        rate = np.empty(N + 1)  # d(delta)/dt: the left side's speed less the right side's
        rate[1:N] = v[:-1] - v[1:]
        rate[0], rate[N] = ds_left - v[0], v[-1] - ds_right
        args = (int(law), int(dissipation.damping), int(dissipation.tensile), d, rate, kk, nn,
                dissipation.coefficient, force)
        specialised(_damped_forces, args, (0,))(*args)
    wall_overlap = np.where(present, d[[0, N]], np.nan)
    wall_force = np.where(present, force[[0, N]], 0.0)
    return ContactForces(d[1:N].copy(), force[1:N].copy(), wall_overlap, wall_force)


def friction_state(v, eta_static):
    """int8 per granule: 1 stuck, 0 sliding or moving, -1 no Coulomb friction.

    The Verlet kicks set a stopped granule's velocity to exactly 0.0 and keep it
    there while the net force stays below the static threshold, so ``v == 0`` is the
    stuck state itself, not a tolerance.

    Parameters
    ----------
    v : ndarray, shape (N,)
        Velocities (scene units).
    eta_static : ndarray, shape (N,)
        Static friction thresholds (scene force units; 0: no Coulomb friction).

    Returns
    -------
    ndarray of int8, shape (N,)
        The state of each granule.
    """
    state = np.where(np.asarray(v) == 0.0, 1, 0).astype(np.int8)
    state[np.asarray(eta_static) <= 0.0] = -1
    return state


class VTKSeriesWriter:
    """Write a VTK time series frame by frame; the ``.pvd`` index is written on a clean exit.

    Used as a context manager (the shape of meshio's XDMF time-series writer):
    topology and constant point data are set once, each :meth:`write_frame` fills
    the same buffers and writes one ``.vtp``, and the index is written only when the
    ``with`` block ends without an exception, so a series cut short has no index.

    Parameters
    ----------
    folder : path
        Output folder; frames go to ``folder/vtk/``, the index to ``folder/run.pvd``.
    radius, mass : ndarray, shape (N,)
        Radii and masses of the granules (scene units).
    k, n : ndarray, shape (N-1,)
        Contact force coefficients and exponents (:attr:`granular_chain.Result.model`).
    eta_static : ndarray, shape (N,)
        Static friction thresholds (0 = no Coulomb friction on that granule).
    compression : {"zlib", "lz4", "lzma", None}
        Compression of the binary appended data.
    walls : (WallContact or None, WallContact or None)
        The wall contacts (:func:`wall_contacts`); none by default.
    law : int
        The run's contact law code (``model.features.law``); the general power
        law by default.
    dissipation : Dissipation, optional
        Dashpots and driven walls (:func:`dissipation_of`); None: springs and fixed walls.
    """

    def __init__(self, folder, radius, mass, k, n, eta_static, *, compression="zlib",
                 walls=(None, None), law: int = LAW_POWER,
                 dissipation: Optional[Dissipation] = None):
        # heavy: imported only when a VTK series is asked for
        pv = require("pyvista", "granular_chain VTK series")
        vtkXMLPolyDataWriter = require("vtkmodules.vtkIOXML",
                                       "granular_chain VTK series").vtkXMLPolyDataWriter

        self.folder = Path(folder)
        (self.folder / FRAME_DIR).mkdir(parents=True, exist_ok=True)
        self.radius = np.ascontiguousarray(radius, dtype=np.float64)
        self.k = np.asarray(k, dtype=np.float64)
        self.n = np.asarray(n, dtype=np.float64)
        self.eta_static = np.asarray(eta_static, dtype=np.float64)
        self.walls = tuple(walls)
        self.law = int(law)
        self.dissipation = dissipation
        N = self.radius.size
        self._points = np.zeros((N, 3))
        lines = np.empty((max(N - 1, 0), 3), dtype=np.int64)
        lines[:, 0] = 2
        lines[:, 1] = np.arange(N - 1)
        lines[:, 2] = np.arange(1, N)
        mesh = pv.PolyData(self._points, lines=lines.ravel() if N > 1 else None)
        # pyvista keeps numpy arrays it is given by reference: the buffers below are
        # filled in place for each frame and the mesh marked modified, no rebuild.
        self._mesh = mesh
        self._points = mesh.points  # the VTK-backed view
        mesh.point_data["radius"] = self.radius
        mesh.point_data["mass"] = np.ascontiguousarray(mass, dtype=np.float64)
        self._v = np.zeros(N)
        self._f = np.zeros(N)
        self._state = np.zeros(N, dtype=np.int8)
        mesh.point_data["velocity"] = self._v
        mesh.point_data["net_force"] = self._f
        mesh.point_data["friction_state"] = self._state
        self._v = mesh.point_data["velocity"]
        self._f = mesh.point_data["net_force"]
        self._state = mesh.point_data["friction_state"]
        if N > 1:
            mesh.cell_data["overlap"] = np.zeros(N - 1)
            mesh.cell_data["force"] = np.zeros(N - 1)
            mesh.cell_data["in_contact"] = np.zeros(N - 1, dtype=np.uint8)
        mesh.field_data["friction_state_legend"] = [FRICTION_LEGEND]
        self._writer = vtkXMLPolyDataWriter()
        self._writer.SetInputData(mesh)
        self._writer.SetDataModeToAppended()
        self._writer.EncodeAppendedDataOff()  # raw binary, not base64
        if compression is None:
            self._writer.SetCompressorTypeToNone()
        else:
            setter = {"zlib": self._writer.SetCompressorTypeToZLib,
                      "lz4": self._writer.SetCompressorTypeToLZ4,
                      "lzma": self._writer.SetCompressorTypeToLZMA}[compression]
            setter()
        self._entries: list[tuple[float, str]] = []

    def prime(self) -> None:
        """Write the mesh once to a scratch file, removed again: VTK's XML writer lays
        out the first file it writes differently from the later ones (the arrays no
        frame changes, radius and mass, close with ``/>`` there and with
        ``</DataArray>`` after), so a series continued by a new writer (a restarted
        run) goes on in the layout of the run never stopped, byte for byte."""
        scratch = self.folder / FRAME_DIR / ".prime.vtp"
        self._writer.SetFileName(str(scratch))
        try:
            if self._writer.Write() != 1:
                raise OSError(f"VTK could not write {scratch}")
        finally:
            scratch.unlink(missing_ok=True)

    @property
    def mesh(self):
        """The frame mesh as last written (a pyvista.PolyData sharing the buffers)."""
        return self._mesh

    def write_frame(self, t: float, x, v, f) -> Path:
        """Write one frame at time ``t`` with positions ``x``, velocities ``v``, net forces ``f``.

        Parameters
        ----------
        t : float
            Time (scene units).
        x, v, f : ndarray, shape (N,)
            Positions, velocities and net forces (scene units).

        Returns
        -------
        Path
            The ``.vtp`` written.
        """
        mesh = self._mesh
        self._points[:, 0] = x
        self._v[:] = v
        self._f[:] = f
        self._state[:] = friction_state(v, self.eta_static)
        contacts = contact_overlap_force(x, self.radius, self.k, self.n, self.walls, self.law,
                                         v, t, self.dissipation)
        if self.radius.size > 1:
            mesh.cell_data["overlap"][:] = contacts.overlap
            mesh.cell_data["force"][:] = contacts.force
            mesh.cell_data["in_contact"][:] = contacts.overlap > 0.0
        mesh.field_data["wall_overlap"] = contacts.wall_overlap
        mesh.field_data["wall_force"] = contacts.wall_force
        index = len(self._entries)
        mesh.field_data["TimeValue"] = np.array([t], dtype=np.float64)
        mesh.field_data["frame"] = np.array([index], dtype=np.int64)
        mesh.Modified()
        name = f"{FRAME_DIR}/frame_{index:06d}.vtp"
        self._writer.SetFileName(str(self.folder / name))
        if self._writer.Write() != 1:
            raise OSError(f"VTK could not write {self.folder / name}")
        self._entries.append((float(t), name))
        return self.folder / name

    def write_index(self) -> Path:
        """Write ``run.pvd`` (by hand: no library writes ParaView's collection format).

        Returns
        -------
        Path
            ``folder/run.pvd``.
        """
        lines = ['<?xml version="1.0"?>',
                 '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
                 "  <Collection>"]
        for t, name in self._entries:
            # repr() is the shortest string that parses back to the same double,
            # so a reader's time values equal Result.t exactly.
            lines.append(f'    <DataSet timestep="{t!r}" group="" part="0" '
                         f"file={quoteattr(name)}/>")
        lines += ["  </Collection>", "</VTKFile>", ""]
        path = self.folder / PVD_NAME
        tmp = path.with_suffix(".pvd.tmp")
        tmp.write_text("\n".join(lines), encoding="utf-8")
        os.replace(tmp, path)
        return path

    def __enter__(self) -> "VTKSeriesWriter":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.write_index()


def write_vtk(result, folder, scene, *, compression: Optional[str] = "zlib",
              progress: bool = False, should_stop=None) -> Path:
    """Write every frame of ``result`` as a VTK time series; return the ``.pvd`` path.

    Parameters
    ----------
    result : Result
        The finished run.
    folder : path
        Output folder (``run.pvd`` and ``vtk/`` are created in it).
    scene : Scene
        The run's scene: only for a Result without its chain constants
        (:func:`granular_chain.result.run_model`).
    compression : {"zlib", "lz4", "lzma", None}
        Compression of the binary appended data.
    progress : bool
        Show a bar of frames written (tqdm).
    should_stop : callable, optional
        Asked before each frame; when it returns true the series ends there
        (with a valid index of the frames written), so a stop request is
        honoured within one frame.

    Returns
    -------
    Path
        ``folder/run.pvd``.
    """
    model = run_model(result, scene)
    frames = range(result.t.size)
    if progress:
        frames = tqdm(frames, desc="writing VTK", unit="frame", leave=False, delay=1.0)
    with VTKSeriesWriter(folder, model.radius, model.mass, model.k, model.n,
                         model.eta_static, compression=compression,
                         walls=wall_contacts(model), law=model.features.law,
                         dissipation=dissipation_of(model)) as series:
        for i in frames:
            if should_stop is not None and should_stop():
                break
            series.write_frame(float(result.t[i]), result.x[i], result.v[i], result.f[i])
    return Path(folder) / PVD_NAME


class VTKFrames:
    """The VTK series as a frame writer attached to a run (frames written as they come).

    The ``.pvd`` index is rewritten after each of the first 100 frames and then
    at most once a second (and at the end), so it is valid at every moment and
    ParaView can follow a running job.

    Parameters
    ----------
    folder : path
        Output folder (``run.pvd`` and ``vtk/``).
    model : Model
        Radii, masses, contact constants and static friction of the chain.
    compression : {"zlib", "lz4", "lzma", None}
        Compression of the binary appended data.
    resume_frames : int, optional
        Frames kept from an existing series (a restart); None starts a new one.
    """

    def __init__(self, folder, model, *, compression: Optional[str] = "zlib",
                 resume_frames: Optional[int] = None):
        self.series = VTKSeriesWriter(folder, model.radius, model.mass, model.k, model.n,
                                      model.eta_static, compression=compression,
                                      walls=wall_contacts(model), law=model.features.law,
                                      dissipation=dissipation_of(model))
        self._indexed = -1.0
        if resume_frames is not None:
            self._resume(Path(folder), int(resume_frames))

    def _resume(self, folder: Path, frames: int) -> None:
        """Continue after the first ``frames`` frames of the index (a run restarted from
        a checkpoint); the frame files after them are removed (the engine wrote them)."""
        entries = [(float(d.get("timestep")), d.get("file")) for d in
                   ElementTree.parse(folder / PVD_NAME).getroot().iter("DataSet")]
        if len(entries) < frames:
            raise ValueError(f"{folder / PVD_NAME} lists {len(entries)} frames, fewer than "
                             f"the checkpoint's {frames}")
        self.series._entries = entries[:frames]
        self.series.prime()
        for k, path in enumerate(sorted((folder / FRAME_DIR).glob("frame_*.vtp"))):
            if k >= frames:
                path.unlink()
        self.series.write_index()

    def flush(self) -> None:
        """Rewrite the ``.pvd`` index so it lists every frame written (before a checkpoint)."""
        self.series.write_index()

    def write_frame(self, frame) -> None:
        """Write one frame as a ``.vtp`` (and the index on its cadence).

        Parameters
        ----------
        frame : Frame
            One output frame (time, positions, velocities, ledger; scene units).
        """
        self.series.write_frame(frame.t, frame.x, frame.v, frame.f)
        now = time.monotonic()
        if len(self.series._entries) <= 100 or now - self._indexed >= 1.0:
            self.series.write_index()
            self._indexed = now

    def close(self, result=None) -> None:
        """Write the final index.

        Parameters
        ----------
        result : Result, optional
            The finished run (unused: every row came with the frames).
        """
        self.series.write_index()
