"""PNG plots of a run: space-time diagram, energy ledger, granule velocities, a rendered frame.

``granular-chain plot RUN_DIR`` (or ``run --plots``) writes into ``RUN_DIR/plots/``:

``spacetime.png``
    Granule index (horizontal) against time (vertical), colour = velocity on a
    diverging map centred at 0: a pulse is a bright diagonal band whose slope is
    its speed, backscatter shows as the opposite colour.
``energy.png``
    Kinetic, elastic, dissipated (Coulomb, viscous) and their sum against time, and
    below it the balance error relative to the initial energy.
``velocities.png``
    v_i(t) of chosen granules (default: first, quarter, middle, three quarters, last).
``frame.png``
    One frame rendered by pyvista off-screen: granules as spheres coloured by velocity,
    closed contacts as tubes coloured by force. Needs an OpenGL that works without a
    display: the PyPI vtk wheels (>= 9.4) pick EGL when there is no X server (system
    libEGL + Mesa, e.g. Debian ``libegl1 libegl-mesa0 libgl1-mesa-dri``). If rendering
    is impossible (no pyvista, no OpenGL) the other plots are still written and a
    :class:`~granular_chain.notices.PlotSkippedWarning` says why.

The first three need matplotlib alone (the ``[plots]`` extra), on the Agg backend (no
display needed); frame.png needs pyvista too (the ``[vtk]`` extra).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from ..extras import missing, require
from ..notices import PlotSkippedWarning, warn
from ..result import run_model
from .vtk import contact_overlap_force

__all__ = ["write_plots", "plot_spacetime", "plot_energy", "plot_velocities", "render_frame",
           "default_granules", "frame_unavailable", "PLOT_DIR"]

PLOT_DIR = "plots"
# Cells of the space-time diagram at most, about its axes' size in pixels: a
# longer or larger run is reduced block by block, each block drawn as its value
# of largest magnitude, so a pulse one granule and one frame wide still shows,
# at full colour, at any N (a cell narrower than a pixel would be blended away).
_MAX_COLUMNS, _MAX_ROWS = 500, 600
# Granules rendered in frame.png at most: a longer chain is shown around the
# granule moving fastest (the pulse), as the whole chain would be sub-pixel spheres.
_FRAME_GRANULES = 200


def _pyplot():
    """matplotlib.pyplot on the Agg backend (no display needed); the [plots] extra."""
    matplotlib = require("matplotlib", "granular_chain PNG plots")
    matplotlib.use("Agg", force=True)
    return require("matplotlib.pyplot", "granular_chain PNG plots")


def _save(fig, path: Path) -> Path:
    # Written beside and renamed, so a PNG is never seen half written.
    tmp = path.with_name(f".{path.name}.tmp")
    fig.savefig(tmp, dpi=120, format="png")
    os.replace(tmp, path)
    return path


def _units(scene) -> tuple[str, str, str]:
    if scene is not None and scene.units == "physical":
        return "$t$ [s]", "$v$ [m/s]", "energy [J]"
    return "$t$ (scaled)", "$v$ (scaled)", "energy (scaled)"


def default_granules(count: int) -> list[int]:
    """First, quarter, middle, three-quarter and last granule (without repeats).

    Parameters
    ----------
    count : int
        Number of granules in the chain.

    Returns
    -------
    list of int
        Sorted indices.
    """
    picks = [0, count // 4, count // 2, (3 * count) // 4, count - 1]
    return sorted(set(i for i in picks if 0 <= i < count))


def plot_spacetime(result, path, scene=None) -> Path:
    """Space-time diagram of the velocity: index against time, colour = v.

    Parameters
    ----------
    result : Result
        The run (frames of ``t``, ``x``, ``v`` and the energy ledger).
    path : str or Path
        PNG file written (its folder must exist).
    scene : Scene, optional
        The run's scene: physical or scaled units on the axes, its name in the title.

    Returns
    -------
    Path
        ``path``.
    """
    plt = _pyplot()
    TwoSlopeNorm = require("matplotlib.colors", "granular_chain PNG plots").TwoSlopeNorm

    t, v = result.t, result.v
    F, N = v.shape
    bn, bt = -(-N // _MAX_COLUMNS), -(-F // _MAX_ROWS)  # ceil: blocks of bt frames x bn granules
    tlab, vlab, _ = _units(scene)
    fig, ax = plt.subplots(figsize=(7, 6), constrained_layout=True)
    if bt == 1 and bn == 1:
        vv = v
        # 'nearest' puts each frame at its own time, so unequal frame spacing (a short
        # last chunk, a located separation) is drawn where it happened.
        cells = dict(X=np.arange(N), Y=t, shading="nearest")
    else:
        vv = peak_blocks(v, bt, bn)
        edges_t = np.append(t[::bt], t[-1])  # block k spans frames k*bt .. (k+1)*bt
        cells = dict(X=np.append(np.arange(0, N, bn), N) - 0.5, Y=edges_t, shading="flat")
    vmax = float(np.max(np.abs(vv))) or 1.0
    mesh = ax.pcolormesh(cells.pop("X"), cells.pop("Y"), vv, cmap="RdBu_r",
                         norm=TwoSlopeNorm(0.0, -vmax, vmax), rasterized=True, **cells)
    fig.colorbar(mesh, ax=ax, label=f"velocity {vlab}")
    ax.set_xlabel("granule index $i$")
    ax.set_ylabel(tlab)
    # a "$" of the name is literal, not the start of mathtext
    name = scene.name.replace("$", r"\$") if scene is not None else "run"
    shown = "" if bt == bn == 1 else f", cells: peak of ${bt} \\times {bn}$"
    ax.set_title(f"{name}: velocity of every granule ($N = {N}$, {F} frames{shown})",
                 fontsize="medium")
    _save(fig, Path(path))
    plt.close(fig)
    return Path(path)


def peak_blocks(v: np.ndarray, bt: int, bn: int) -> np.ndarray:
    """Reduce (F, N) to blocks of bt frames x bn granules, each the signed value of
    largest magnitude in its block; shape (ceil(F/bt), ceil(N/bn)).

    Works one row of blocks at a time, so the extra memory is one block row.
    """
    F, N = v.shape
    nb = -(-N // bn)
    out = np.empty((-(-F // bt), nb))
    for k, a in enumerate(range(0, F, bt)):
        rows = np.zeros((min(bt, F - a), nb * bn))  # padding of zeros never wins a peak
        rows[:, :N] = v[a:a + bt]
        blocks = rows.reshape(rows.shape[0], nb, bn).transpose(1, 0, 2).reshape(nb, -1)
        out[k] = blocks[np.arange(nb), np.argmax(np.abs(blocks), axis=1)]
    return out


def plot_energy(result, path, scene=None) -> Path:
    """Energy ledger against time and the relative balance error below it.

    Parameters
    ----------
    result : Result
        The run (frames of ``t``, ``x``, ``v`` and the energy ledger).
    path : str or Path
        PNG file written (its folder must exist).
    scene : Scene, optional
        The run's scene: physical or scaled units on the axes, its name in the title.

    Returns
    -------
    Path
        ``path``.
    """
    plt = _pyplot()
    led, t = result.energy, result.t
    tlab, _, elab = _units(scene)
    fig, (ax, bx) = plt.subplots(2, 1, figsize=(7, 6), sharex=True, constrained_layout=True,
                                 gridspec_kw={"height_ratios": [3, 1]})
    ax.plot(t, led.kinetic, label="kinetic")
    ax.plot(t, led.potential, label="elastic (contacts)")
    ax.plot(t, led.coulomb, label="dissipated, Coulomb")
    ax.plot(t, led.viscous, label="dissipated, viscous")
    for name, label in (("contact_dissipated", "dissipated, contacts"),
                        ("wall_work", "work done by walls"), ("body_work", "work done by body forces"),
                        ("stage_work", "put in at stage starts")):
        if np.any(getattr(led, name) != 0.0):
            ax.plot(t, getattr(led, name), label=label)
    ax.plot(t, led.balance + led.initial, "k--", lw=1,
            label="sum (minus work done on the chain)")
    ax.axhline(led.initial, color="0.6", lw=0.8, zorder=0)
    ax.set_ylabel(elab)
    ax.legend(loc="best", fontsize="small")
    ax.set_title("energy ledger")
    bx.plot(t, led.balance / led.scale, color="C3")
    bx.axhline(0.0, color="0.6", lw=0.8)
    bx.set_ylabel("balance / initial")
    bx.set_xlabel(tlab)
    bx.ticklabel_format(axis="y", style="sci", scilimits=(-2, 2))
    _save(fig, Path(path))
    plt.close(fig)
    return Path(path)


def plot_velocities(result, path, scene=None, granules: Optional[Sequence[int]] = None) -> Path:
    """Velocity against time of the chosen granules.

    Parameters
    ----------
    result : Result
        The run (frames of ``t``, ``x``, ``v`` and the energy ledger).
    path : str or Path
        PNG file written (its folder must exist).
    scene : Scene, optional
        The run's scene: physical or scaled units on the axes, its name in the title.
    granules : sequence of int, optional
        Granule indices drawn (default :func:`default_granules`).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ValueError
        An index outside the chain.
    """
    plt = _pyplot()
    N = result.v.shape[1]
    granules = default_granules(N) if granules is None else list(granules)
    bad = [i for i in granules if not 0 <= i < N]
    if bad:
        raise ValueError(f"granule indices {bad} are outside 0..{N - 1}")
    tlab, vlab, _ = _units(scene)
    fig, ax = plt.subplots(figsize=(7, 4.5), constrained_layout=True)
    for i in granules:
        ax.plot(result.t, result.v[:, i], lw=1.2, label=f"granule {i}")
    ax.axhline(0.0, color="0.6", lw=0.8, zorder=0)
    ax.set_xlabel(tlab)
    ax.set_ylabel(vlab)
    ax.legend(loc="best", fontsize="small")
    ax.set_title("velocities of chosen granules")
    _save(fig, Path(path))
    plt.close(fig)
    return Path(path)


def _prefer_egl() -> None:
    # Without a display the wheel's default X window fails first and logs a warning
    # before falling back to EGL; asking for EGL directly is quiet. A user's own
    # choice (the variable already set) wins.
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")


def render_frame(result, path, scene, time: Optional[float] = None,
                 window_size=(1600, 420)) -> Path:
    """Render one frame with pyvista off-screen and save it as a PNG.

    Parameters
    ----------
    result : Result
        The run (frames of ``t``, ``x``, ``v`` and the energy ledger).
    path : str or Path
        PNG file written (its folder must exist).
    scene : Scene
        The run's scene (radii and contact laws of the granules drawn).
    time : float, optional
        Render the frame closest to this time (default: the middle of the run).
    window_size : (int, int)
        Image width and height, pixels.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    Exception
        Whatever VTK raises when no off-screen OpenGL context can be made
        (:func:`write_plots` turns that into a message).
    """
    _prefer_egl()
    pv = require("pyvista", "granular_chain frame.png")

    pv.OFF_SCREEN = True
    model = run_model(result, scene)
    t = result.t
    target = 0.5 * (t[0] + t[-1]) if time is None else float(time)
    i = int(np.argmin(np.abs(t - target)))
    lo, hi = frame_window(result.v[i])
    x, v = result.x[i, lo:hi], result.v[i, lo:hi]
    radius, k, n = model.radius[lo:hi], model.k[lo:hi - 1], model.n[lo:hi - 1]
    pts = np.zeros((x.size, 3))
    pts[:, 0] = x
    cloud = pv.PolyData(pts)
    cloud.point_data["diameter"] = 2.0 * radius
    cloud.point_data["velocity"] = v
    spheres = cloud.glyph(geom=pv.Sphere(radius=0.5, theta_resolution=24, phi_resolution=16),
                          scale="diameter", orient=False)
    vmax = float(np.max(np.abs(v))) or 1.0  # the frame's own scale: its pulse is always red
    pl = pv.Plotter(off_screen=True, window_size=list(window_size))
    pl.set_background("white")
    bar = {"color": "black", "vertical": False, "position_y": 0.06, "height": 0.1,
           "width": 0.4, "title_font_size": 14, "label_font_size": 12, "n_labels": 5}
    pl.add_mesh(spheres, scalars="velocity", cmap="RdBu_r", clim=(-vmax, vmax),
                smooth_shading=True,
                scalar_bar_args={**bar, "title": "velocity", "position_x": 0.55})
    if x.size > 1:
        # the neighbour contacts of the window (no wall is drawn)
        overlap, force = contact_overlap_force(x, radius, k, n, law=model.features.law)[:2]
        closed = np.flatnonzero(overlap > 0.0)
        if closed.size:
            lines = np.column_stack([np.full(closed.size, 2), closed, closed + 1]).ravel()
            contacts = pv.PolyData(pts.copy(), lines=lines)
            contacts.cell_data["force"] = force[closed]
            # Tubes lifted in front of the spheres (+z) so the contacts stay visible.
            contacts.points[:, 2] = 1.05 * float(np.max(radius))
            tube = contacts.tube(radius=0.08 * float(np.min(radius)))
            pl.add_mesh(tube, scalars="force", cmap="viridis",
                        clim=(0.0, float(np.max(force[closed])) or 1.0),
                        scalar_bar_args={**bar, "title": "contact force (closed contacts)",
                                         "position_x": 0.05})
    N = result.v.shape[1]
    which = "" if hi - lo == N else f",  granules {lo}..{hi - 1} of {N}"
    pl.add_text(f"t = {t[i]:.4g}   (frame {i} of {t.size - 1}{which})", position="upper_edge",
                font_size=11, color="black")
    # Parallel projection looking down -z; the chain fills the width and sits above
    # the colour bars (parallel_scale is half the visible height in world units).
    span = float(x.max() - x.min() + 4.0 * np.max(radius))
    half_height = 0.5 * span * window_size[1] / window_size[0]
    xc = 0.5 * float(x.max() + x.min())
    yc = -0.25 * half_height
    pl.enable_parallel_projection()
    pl.camera.focal_point = (xc, yc, 0.0)
    pl.camera.position = (xc, yc, 10.0 * span)
    pl.camera.up = (0.0, 1.0, 0.0)
    pl.camera.parallel_scale = half_height
    pl.camera.clipping_range = (1.0, 20.0 * span)
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp.png")
    try:
        pl.screenshot(str(tmp))
    finally:
        pl.close()
    os.replace(tmp, path)
    return path


def frame_window(v: np.ndarray, most: int = _FRAME_GRANULES) -> tuple[int, int]:
    """Granules ``lo..hi-1`` drawn in frame.png: all of them, or ``most`` centred on
    the fastest granule (the pulse) when the chain is longer."""
    N = v.size
    if N <= most:
        return 0, N
    centre = int(np.argmax(np.abs(v)))
    lo = min(max(centre - most // 2, 0), N - most)
    return lo, lo + most


def write_plots(result, folder, scene=None, *, granules: Optional[Sequence[int]] = None,
                frame_time: Optional[float] = None, render: bool = True,
                subdir: str = PLOT_DIR) -> list[Path]:
    """Write the PNGs into ``folder/plots/`` (``folder/subdir``); return the paths written.

    The three plots need matplotlib alone (the ``[plots]`` extra). The rendered frame
    needs pyvista (the ``[vtk]`` extra), the scene (radii, contact laws) and a working
    off-screen OpenGL; when any is missing it is skipped with a
    :class:`~granular_chain.notices.PlotSkippedWarning` saying why.

    Parameters
    ----------
    result : Result
        The run (frames of ``t``, ``x``, ``v`` and the energy ledger).
    folder : str or Path
        Run folder; the PNGs go to ``folder/subdir``.
    scene : Scene, optional
        The run's scene: physical or scaled units on the axes, its name in the title.
    granules : sequence of int, optional
        Granules of ``velocities.png`` (default :func:`default_granules`).
    frame_time : float, optional
        Time of the rendered frame, in the run's time unit (default: mid-run).
    render : bool
        Render ``frame.png`` with pyvista.
    subdir : str
        Subfolder of ``folder`` ('' writes into ``folder`` itself).

    Returns
    -------
    list of Path
        The PNGs written.

    Raises
    ------
    granular_chain.extras.MissingExtraError
        matplotlib is not installed (nothing is written).
    """
    _pyplot()  # before the folder is made
    out = Path(folder) / subdir if subdir else Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    paths = [plot_spacetime(result, out / "spacetime.png", scene),
             plot_energy(result, out / "energy.png", scene),
             plot_velocities(result, out / "velocities.png", scene, granules)]
    skipped = render and frame_unavailable(scene)
    if skipped:
        warn(skipped, PlotSkippedWarning)
    elif render:
        try:
            paths.append(render_frame(result, out / "frame.png", scene, frame_time))
        except Exception as exc:  # noqa: BLE001 - any VTK/OpenGL failure means "cannot render"
            warn(f"frame.png skipped: off-screen rendering failed "
                 f"({exc.__class__.__name__}: {exc}); the other plots are written",
                 PlotSkippedWarning)
    return paths


def frame_unavailable(scene) -> str:
    """Why frame.png cannot be rendered (no scene, no pyvista), in one line; '' if it can.

    Parameters
    ----------
    scene : Scene or None
        The run's scene.

    Returns
    -------
    str
        The reason, or ''.
    """
    if scene is None:
        return "frame.png skipped: no scene stored with the run"
    _prefer_egl()  # before VTK is first imported
    return missing(("pyvista", "vtkmodules"), "frame.png skipped")
