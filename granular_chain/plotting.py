"""Labels shared by every figure the package draws: mathtext names, signed numbers,
contour labels that do not overlap.

Matplotlib is not imported here: the functions take the figure's own objects.
"""

from __future__ import annotations

import re

import numpy as np

__all__ = ["tex_name", "signed", "label_contours", "overlapping"]

_GREEK = ("alpha", "beta", "gamma", "delta", "epsilon", "eta", "theta", "kappa", "lambda",
          "mu", "nu", "omega", "phi", "psi", "rho", "sigma", "tau", "xi")
# A name as the paper writes it: a Greek or Latin stem, then digits as a subscript
# (eta1 -> eta_1, v2 -> v_2).  E0 and t0 follow the same rule.
_NAME = re.compile(r"(?P<stem>[A-Za-z]+?)(?P<sub>\d+)?")


def tex_name(name: str) -> str:
    """A parameter name as mathtext: ``eta1`` -> ``$\\eta_1$``, ``gamma`` -> ``$\\gamma$``.

    Parameters
    ----------
    name : str
        A Greek letter spelled out (``eta``, ``gamma``, ``delta``...) or a Latin
        symbol (``n``, ``v``), optionally followed by digits (the subscript).
        Anything else (a dotted scene path, ``energy_ratio``) is returned unchanged.

    Returns
    -------
    str
        ``$...$`` for a symbol, else ``name`` itself.
    """
    m = _NAME.fullmatch(name)
    if m is None or (m["stem"] not in _GREEK and len(m["stem"]) > 1):
        return name
    stem = "\\" + m["stem"] if m["stem"] in _GREEK else m["stem"]
    return f"${stem}_{{{m['sub']}}}$" if m["sub"] else f"${stem}$"


def signed(x: float, digits: int = 1) -> str:
    """``x`` with ``digits`` decimals, a minus sign only when negative, zero as ``0``.

    For labels such as ``$\\delta = 0$``, ``$\\delta = 0.1$``, ``$\\delta = -0.1$``:
    never ``+0.1``, ``+0.0`` or ``-0.0``.

    Parameters
    ----------
    x : float
        The number (any unit; the caller's label names it).
    digits : int
        Decimals kept.

    Returns
    -------
    str
        The formatted number, without ``$``.
    """
    text = f"{float(x):.{digits}f}"
    if float(text) == 0.0:
        return "0"
    return text


def overlapping(boxes: list, pad: float = 0.0) -> list:
    """Pairs ``(i, j)``, ``i < j``, of the boxes that overlap.

    Parameters
    ----------
    boxes : list of matplotlib.transforms.Bbox
        Window extents (pixels), e.g. ``text.get_window_extent(renderer)``.
    pad : float
        Pixels added on every side of each box before the test; 0 tests the boxes
        as they are (touching edges do not count).

    Returns
    -------
    list of tuple of int
        Every overlapping pair, in order.
    """
    b = [(x.x0 - pad, x.y0 - pad, x.x1 + pad, x.y1 + pad) for x in boxes]
    return [(i, j) for i in range(len(b)) for j in range(i + 1, len(b))
            if b[i][0] < b[j][2] and b[j][0] < b[i][2] and b[i][1] < b[j][3] and b[j][1] < b[i][3]]


def _keep_apart(texts: list, renderer, inside, pad: float) -> list:
    """Indices of ``texts`` kept, first come first kept, so that no two kept ones
    overlap (with ``pad`` pixels) and every kept one lies inside ``inside``."""
    kept, boxes = [], []
    for i, t in enumerate(texts):
        box = t.get_window_extent(renderer)
        if not (inside.x0 <= box.x0 and box.x1 <= inside.x1
                and inside.y0 <= box.y0 and box.y1 <= inside.y1):
            continue
        if any(overlapping([box, other], pad) for other in boxes):
            continue
        kept.append(i)
        boxes.append(box)
    return kept


def label_contours(ax, cs, fmt: str = "%.3g", fontsize: float = 6, pad: float = 3.0) -> list:
    """Label the lines of ``cs`` where the labels do not overlap each other.

    Matplotlib's :meth:`~matplotlib.axes.Axes.clabel` puts one label on every long
    enough piece of every level, so close levels (a steep field, a field pressed
    against the edge of its region) pile their labels on top of each other.  Here
    the labels are first placed without cutting the lines, measured after a draw,
    and kept first come first kept when their boxes, grown by ``pad`` pixels, meet
    no kept box and lie inside the axes; a level left without a label is tried
    again at other points along its longest line; the kept positions are then labelled
    again inline (the line cut under the label).  A label that then meets another
    (its rotation can differ a little) is dropped and the rest are labelled again
    on the uncut lines, so no line keeps a gap without its label.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes of the contour set.
    cs : matplotlib.contour.QuadContourSet
        Contour lines, as returned by ``ax.contour``.
    fmt : str
        Label format of one level value.
    fontsize : float
        Label font size, points.
    pad : float
        Gap kept between two labels, pixels.

    Returns
    -------
    list of matplotlib.text.Text
        The labels drawn (possibly none).
    """
    fig = ax.get_figure()
    fig.draw_without_rendering()  # settle the layout first: positions are in pixels
    renderer = fig.canvas.get_renderer()
    trial = list(cs.clabel(fontsize=fontsize, fmt=fmt, inline=False))
    kept = [trial[i] for i in _keep_apart(trial, renderer, ax.bbox, pad)]
    kept += _place_missing(ax, cs, kept, renderer, pad)
    xy = [t.get_position() for t in kept]
    _clear_labels(cs)
    uncut = list(cs.get_paths())
    while xy:
        cs.set_paths(list(uncut))
        cs.clabel(fontsize=fontsize, fmt=fmt, inline=True, manual=xy)
        texts = list(cs.labelTexts)
        keep = _keep_apart(texts, renderer, ax.bbox, 0.0)
        if len(keep) == len(texts):
            return texts
        # a label turned into one that meets another: label the rest again on
        # uncut lines, so no line keeps a gap without its label
        xy = [texts[i].get_position() for i in keep]
        _clear_labels(cs)
    cs.set_paths(uncut)
    return []


def _clear_labels(cs) -> None:
    """Remove every label of the contour set ``cs`` (its lines stay as they are)."""
    for t in list(cs.labelTexts):
        t.remove()
    cs.labelTexts.clear()
    cs.labelCValues.clear()


def _place_missing(ax, cs, kept: list, renderer, pad: float) -> list:
    """Labels for the levels that lost all theirs in the first pass: each is tried
    at 5 points along its longest line (display space), the first that meets no
    kept label (with ``pad`` pixels) and lies inside the axes is kept."""
    boxes = [t.get_window_extent(renderer) for t in kept]
    have = {t.get_text() for t in kept}
    added = []
    for level, index in zip(cs.labelLevelList, cs.labelIndiceList):
        if cs.get_text(level, cs.labelFmt) in have:
            continue
        for x, y in _points_along(cs.get_transform(), cs.get_paths()[index]):
            cs.add_label_near(x, y, inline=False, transform=False)
            text = cs.labelTexts[-1]
            box = text.get_window_extent(renderer)
            inside = ax.bbox.x0 <= box.x0 and box.x1 <= ax.bbox.x1 \
                and ax.bbox.y0 <= box.y0 and box.y1 <= ax.bbox.y1
            if inside and not any(overlapping([box, b], pad) for b in boxes):
                boxes.append(box)
                added.append(text)
                break
            cs.pop_label()
    return added


def _points_along(transform, path, fractions=(0.5, 0.3, 0.7, 0.15, 0.85)) -> list:
    """Display points at ``fractions`` of the arc length of the longest connected
    piece of ``path`` (none for an empty path)."""
    pieces, current = [], []
    for vertex, code in zip(path.vertices, path.codes if path.codes is not None
                            else [1] + [2] * (len(path.vertices) - 1)):
        if code == 79:  # CLOSEPOLY: back to the piece's start (its own vertex is unused)
            current.append(current[0])
            continue
        if code == 1 and current:  # MOVETO starts a new piece
            pieces.append(current)
            current = []
        current.append(vertex)
    if current:
        pieces.append(current)
    if not pieces:
        return []
    xy = [transform.transform(np.asarray(p)) for p in pieces]
    lengths = [np.r_[0.0, np.cumsum(np.hypot(*np.diff(p, axis=0).T))] for p in xy]
    k = int(np.argmax([s[-1] for s in lengths]))
    s, p = lengths[k], xy[k]
    if s[-1] == 0.0:
        return []
    return [(float(np.interp(f * s[-1], s, p[:, 0])), float(np.interp(f * s[-1], s, p[:, 1])))
            for f in fractions]
