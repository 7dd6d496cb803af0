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
    contact force on the granule from its neighbours and walls, i.e. ``Result.f``;
    friction is not included because a stuck granule's static friction force is not
    a state variable), ``friction_state`` (int8: 1 stuck = at rest exactly with
    Coulomb friction present, 0 sliding/moving, -1 no Coulomb friction on that granule).
line cells, N - 1
    Every neighbour pair ``(i, i+1)``, open or closed, with cell data ``overlap``
    ``delta_i = r_i + r_(i+1) - (x_(i+1) - x_i)`` (negative = gap), ``force``
    ``k_i max(delta_i, 0)^(n_i - 1)`` (compressive, >= 0; the contact law of
    :mod:`granular_chain.laws.contact`) and ``in_contact`` (uint8).
    All pairs are kept, not only the closed ones, so every frame has the same
    topology: ParaView's temporal filters (Plot Data Over Time on a contact) then
    follow one contact through the run, and Threshold on ``in_contact`` shows only the
    closed ones. Wall contacts have no second point, so they are not cells: their
    overlap and force are field data.
field data
    ``TimeValue`` (ParaView's per-file time), ``frame`` (index), ``friction_state_legend``;
    ``wall_overlap`` and ``wall_force``, shape (2,): the left then the right wall
    contact, as the cells' ``overlap`` and ``force`` (a chain without that wall:
    overlap NaN, force 0). With them the contact forces add up to ``net_force``:
    ``net_force_0 = wall_force_left - force_0``, ``net_force_(N-1) = force_(N-2) -
    wall_force_right``.

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
from xml.sax.saxutils import quoteattr

from typing import NamedTuple

import numba
import numpy as np

from ..laws.contact import LAW_POWER, contact_force

__all__ = ["contact_overlap_force", "ContactForces", "WallContact", "wall_contacts",
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
    walls = model.walls
    left = right = None
    if model.features.left_wall:
        left = WallContact(float(walls[0]), float(walls[1]), float(walls[2]),
                           float(model.x0[0]))
    if model.features.right_wall:
        right = WallContact(float(walls[3]), float(walls[4]), float(walls[5]),
                            float(model.x0[-1]))
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


@numba.njit(cache=True)
def _law_forces(law, overlap, k, n, force):
    """``force[i] = F(overlap[i])`` by the contact law ``law`` of :mod:`..laws.contact`
    (LAW_LINEAR, LAW_HERTZ or LAW_POWER); arrays of shape (M,)."""
    for i in range(overlap.size):
        force[i] = contact_force(law, overlap[i], k[i], n[i])


def contact_overlap_force(x, radius, k, n, walls=(None, None),
                          law: int = LAW_POWER) -> ContactForces:
    """Overlap and compressive force of every contact, neighbours and walls.

    The force is the contact law of :mod:`granular_chain.laws.contact`, the one
    the steppers call: ``law`` is the run's (``model.features.law``); the general
    power law ``k max(delta, 0)^(n - 1)`` by default. The overlaps are formed
    from positions, the steppers' from displacements: the two differ by a few
    ulps of the largest position.

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

    Returns
    -------
    ContactForces
    """
    x = np.asarray(x, dtype=np.float64)
    overlap = np.ascontiguousarray(radius[:-1] + radius[1:] - (x[1:] - x[:-1]))
    force = np.empty(overlap.size)
    _law_forces(law, overlap, np.ascontiguousarray(k, dtype=np.float64),
                np.ascontiguousarray(n, dtype=np.float64), force)
    left, right = walls
    wall_overlap = np.array([np.nan, np.nan])
    wall_k, wall_n = np.zeros(2), np.full(2, 2.0)
    if left is not None:  # delta_L = d0_L - u_0, with u_0 = x_0 - x0_0
        wall_overlap[0], wall_k[0], wall_n[0] = left.d0 - (x[0] - left.x0), left.k, left.n
    if right is not None:  # delta_R = d0_R + u_(N-1)
        wall_overlap[1], wall_k[1], wall_n[1] = right.d0 + (x[-1] - right.x0), right.k, right.n
    wall_force = np.zeros(2)
    _law_forces(law, np.nan_to_num(wall_overlap, nan=0.0), wall_k, wall_n, wall_force)
    return ContactForces(overlap, force, wall_overlap, wall_force)


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
    """

    def __init__(self, folder, radius, mass, k, n, eta_static, *, compression="zlib",
                 walls=(None, None), law: int = LAW_POWER):
        import pyvista as pv  # heavy: imported only when a VTK series is asked for
        from vtkmodules.vtkIOXML import vtkXMLPolyDataWriter

        self.folder = Path(folder)
        (self.folder / FRAME_DIR).mkdir(parents=True, exist_ok=True)
        self.radius = np.ascontiguousarray(radius, dtype=np.float64)
        self.k = np.asarray(k, dtype=np.float64)
        self.n = np.asarray(n, dtype=np.float64)
        self.eta_static = np.asarray(eta_static, dtype=np.float64)
        self.walls = tuple(walls)
        self.law = int(law)
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
        contacts = contact_overlap_force(x, self.radius, self.k, self.n, self.walls, self.law)
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
        (:func:`granular_chain.readback.run_model`).
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
    from ..readback import run_model

    model = run_model(result, scene)
    frames = range(result.t.size)
    if progress:
        from tqdm import tqdm
        frames = tqdm(frames, desc="writing VTK", unit="frame", leave=False, delay=1.0)
    with VTKSeriesWriter(folder, model.radius, model.mass, model.k, model.n,
                         model.eta_static, compression=compression,
                         walls=wall_contacts(model), law=model.features.law) as series:
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
                                      walls=wall_contacts(model), law=model.features.law)
        self._indexed = -1.0
        if resume_frames is not None:
            self._resume(Path(folder), int(resume_frames))

    def _resume(self, folder: Path, frames: int) -> None:
        """Continue after the first ``frames`` frames of the index (a run restarted from
        a checkpoint); the frame files after them are removed (the engine wrote them)."""
        from xml.etree import ElementTree

        entries = [(float(d.get("timestep")), d.get("file")) for d in
                   ElementTree.parse(folder / PVD_NAME).getroot().iter("DataSet")]
        if len(entries) < frames:
            raise ValueError(f"{folder / PVD_NAME} lists {len(entries)} frames, fewer than "
                             f"the checkpoint's {frames}")
        self.series._entries = entries[:frames]
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
