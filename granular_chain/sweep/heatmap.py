"""Heat maps of a two-axis sweep from its results.csv."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Optional

import numpy as np

from ..extras import require
from ..plotting import label_contours, tex_name
from ..rundir import write_atomic
from .grid import SweepError
from .resume import read_results

__all__ = ["plot_heatmap", "slug"]

# colour-bar labels of the quantities whose name is not a symbol (v1 -> $v_1$ is made
# by tex_name)
_QUANTITY_LABELS = {"energy_ratio": r"$E/E_0$ at the end", "E0": r"$E_0$"}


def plot_heatmap(results, x: str, y: str, quantity: str, path, *, mask: Optional[dict] = None,
                 title: Optional[str] = None, contours: bool = True,
                 transform=None, label: Optional[str] = None) -> Path:
    """Heat map of ``quantity`` over two coordinates of a 2-D grid, as a PNG.

    Parameters
    ----------
    results : str, Path or dict
        results.csv or the columns from :func:`read_results`.
    x, y : str
        Coordinate columns (dotted paths) on the horizontal and vertical axes.
    quantity : str
        Column to show; a text column (``status``, ``outcome``) is shown as categories.
    path : str or Path
        PNG written (its folder is created).
    mask : dict, optional
        ``{column: value}``: only points where every column equals its value are
        coloured; the rest are grey (the paper's maps show the
        backscatter-and-propagation region only).
    title : str, optional
        Title (default: the quantity and the mask).
    contours : bool
        Draw labelled iso-lines over a numeric quantity.
    transform : callable, optional
        Applied to the numbers before plotting (e.g. ``np.negative`` for -v1).
    label : str, optional
        Colour-bar label (default: the quantity, in mathtext when it is a symbol such
        as ``v1``).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    SweepError
        A column named is not in the results.
    """
    require("matplotlib", "granular_chain sweep heat maps").use("Agg")
    plt = require("matplotlib.pyplot", "granular_chain sweep heat maps")
    ListedColormap = require("matplotlib.colors", "granular_chain sweep heat maps").ListedColormap

    cols = read_results(results) if not isinstance(results, dict) else results
    for c in (x, y, quantity):
        if c not in cols:
            raise SweepError(f"heat map: no column {c!r} (have {', '.join(cols)})")
    xs = np.unique(cols[x].astype(float))
    ys = np.unique(cols[y].astype(float))
    ix = np.searchsorted(xs, cols[x].astype(float))
    iy = np.searchsorted(ys, cols[y].astype(float))
    raw = cols[quantity]
    categorical = raw.dtype == object
    if categorical:
        cats = sorted(set(raw.tolist()))
        values = np.array([cats.index(v) for v in raw], dtype=float)
    else:
        values = raw.astype(float)
        if transform is not None:
            values = transform(values)
    keep = np.ones(values.size, dtype=bool)
    for col, want in (mask or {}).items():
        if col not in cols:
            raise SweepError(f"heat map mask: no column {col!r}")
        keep &= np.array([_same(v, want) for v in cols[col]])
    grid = np.full((ys.size, xs.size), np.nan)
    grid[iy[keep], ix[keep]] = values[keep]
    seen = np.zeros_like(grid, dtype=bool)
    seen[iy, ix] = True
    fig, ax = plt.subplots(figsize=(5.6, 4.6), dpi=120)
    ax.set_facecolor("0.85")
    if categorical:
        cmap = ListedColormap(plt.get_cmap("tab10").colors[: len(cats)])
        im = ax.pcolormesh(xs, ys, grid, cmap=cmap, vmin=-0.5, vmax=len(cats) - 0.5,
                           shading="nearest")
        colorbar = fig.colorbar(im, ax=ax, ticks=range(len(cats)))
        colorbar.ax.set_yticklabels(cats, fontsize=7)
    else:
        im = ax.pcolormesh(xs, ys, grid, cmap="Greys" if mask else "viridis", shading="nearest")
        fig.colorbar(im, ax=ax, label=label or _QUANTITY_LABELS.get(quantity, tex_name(quantity)))
        if contours and xs.size > 3 and ys.size > 3 and np.isfinite(grid).sum() > 10:
            try:
                cs = ax.contour(xs, ys, grid, levels=8, colors="tab:red", linewidths=0.7)
            except (ValueError, TypeError):
                cs = None
            if cs is not None:
                fig.tight_layout()  # the labels are kept apart in pixels: lay out first
                label_contours(ax, cs)
    if not seen.all():
        ax.text(0.01, 0.01, f"{int((~seen).sum())} points not computed", transform=ax.transAxes,
                fontsize=7)
    ax.set_xlabel(x)
    ax.set_ylabel(y)
    ax.set_title(title or (quantity + (f"  (where {mask})" if mask else "")), fontsize=8)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, fig.savefig)
    plt.close(fig)
    return path



def _same(value, want) -> bool:
    if isinstance(value, str):
        return value == str(want)
    try:
        return float(value) == float(want)
    except (TypeError, ValueError):
        return False


def slug(name: str) -> str:
    """``name`` as a file-name part (runs of other characters become '_').

    Parameters
    ----------
    name : str
        Any text.

    Returns
    -------
    str
        Letters, digits, ``_``, ``.`` and ``-`` only.
    """
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("_")
