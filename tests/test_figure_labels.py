"""The package's figures are readable: Greek letters and math in mathtext, no signed
zero or spurious "+" in legends, contour labels that do not overlap.

The figures are built from small synthetic inputs (the engine's collision runs
are replaced by smooth fields of the same shape), so the checks cover the
drawing code, not the physics, and run in a few seconds.  Every figure is kept
when it is saved (``Figure.savefig`` is wrapped) and drawn again for the checks.
"""

from __future__ import annotations

import re
import types

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")

from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from granular_chain import plotting  # noqa: E402
from granular_chain.paper import figures  # noqa: E402
from granular_chain.two_granules import OUTCOMES, Outcome  # noqa: E402

GREEK = ("alpha", "beta", "gamma", "delta", "epsilon", "eta", "theta", "kappa", "lambda",
         "mu", "nu", "omega", "phi", "psi", "rho", "sigma", "tau", "xi")
BARE_GREEK = re.compile(r"(?<![A-Za-z\\])(" + "|".join(GREEK) + r")(?:_?\d+)?(?![A-Za-z])",
                        re.IGNORECASE)
# "+0.0", "-0", "-0.00", a "+" in front of a number: never in a legend
SIGNED_ZERO = re.compile(r"[+-]0(?:\.0*)?(?![\d.]*[1-9])")
PLUS_NUMBER = re.compile(r"(?<![\w)}])\+\s*\d")


@pytest.fixture
def saved(monkeypatch):
    """Every figure saved while the test runs (``Figure.savefig`` still writes)."""
    figs = []
    original = Figure.savefig

    def keep(self, *args, **kwargs):
        figs.append(self)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", keep)
    return figs


def only(figs) -> Figure:
    """The one figure saved, with an Agg canvas again (pyplot.close took it away)."""
    fig, = figs
    if not hasattr(fig.canvas, "get_renderer"):
        FigureCanvasAgg(fig)
    return fig


# ----------------------------------------------------------------------------
# synthetic inputs
# ----------------------------------------------------------------------------
def _fake_collisions(n, points, processes=1):
    """The dict of :func:`figures.collision_values` from smooth made-up fields."""
    p = np.array([tuple(map(float, q)) for q in points]).reshape(-1, 4)
    s = p.sum(axis=1)
    return {"v1": -0.1 * np.sin(s), "v2": np.cos(s), "energy": 1 / (1 + s),
            "t_sep": 2.0 + 0 * s, "outcome": np.zeros(len(p), int), "t_stop1": 1 / (1 + s)}


def hertz_like(grid: int = 41) -> dict:
    """Fields over (eta1, eta2) shaped like Fig. hertz: -v1 flattening to 0 at the
    edge of an elliptic 'both move' region (so its low levels crowd there), v2 and
    E/E0 falling across it."""
    e1, e2 = np.linspace(0.0, 0.3, grid), np.linspace(0.0, 0.7, grid)
    E1, E2 = np.meshgrid(e1, e2)
    r = np.hypot(E1 / 0.26, (E2 - 0.3) / 0.36)
    inside = r < 1.0
    both = OUTCOMES.index(Outcome.backscatter_and_propagation)
    other = OUTCOMES.index(Outcome.propagation_only) if hasattr(Outcome, "propagation_only") \
        else (both + 1) % len(OUTCOMES)
    depth = np.clip(1.0 - r, 0.0, None)
    return {"eta1": e1, "eta2": e2, "outcome": np.where(inside, both, other),
            "v1": -(0.1 + E2) * np.clip(depth / 0.15, 0.0, 1.0), "v2": 1.0 - E1 - E2,
            "energy": 1.0 - 0.8 * np.hypot(E1, E2)}


def all_texts(fig) -> list:
    """(kind, text) of every title, axis label, legend entry, annotation, colour-bar
    label and suptitle of ``fig``."""
    out = []
    if fig._suptitle is not None:
        out.append(("suptitle", fig._suptitle.get_text()))
    for ax in fig.axes:
        out += [("title", ax.get_title(loc)) for loc in ("left", "center", "right")]
        out += [("xlabel", ax.get_xlabel()), ("ylabel", ax.get_ylabel())]
        legend = ax.get_legend()
        if legend is not None:
            out += [("legend", t.get_text()) for t in legend.get_texts()]
        out += [("text", t.get_text()) for t in ax.texts]
    return [(k, t) for k, t in out if t]


def outside_math(text: str) -> str:
    """``text`` with its ``$...$`` parts removed."""
    parts = re.split(r"(?<!\\)\$", text)
    return "".join(parts[0::2])


def contour_labels(ax) -> list:
    """The contour labels of ``ax`` (Text objects of its contour sets)."""
    return [t for c in ax.collections for t in getattr(c, "labelTexts", [])]


def check_texts(fig, where: str) -> list:
    """Readability defects of every text of ``fig``."""
    fig.canvas.draw()  # a mathtext error raises here
    bad = []
    for kind, text in all_texts(fig):
        if text.count("$") - text.count(r"\$") & 1:
            bad.append(f"{where} {kind}: unbalanced $ in {text!r}")
        word = BARE_GREEK.search(outside_math(text))
        if word:
            bad.append(f"{where} {kind}: {word.group(0)!r} outside mathtext in {text!r}")
        if kind == "legend" and (SIGNED_ZERO.search(text) or PLUS_NUMBER.search(text)):
            bad.append(f"{where} {kind}: signed number in {text!r}")
    return bad


def overlaps(texts, renderer) -> list:
    """Pairs of texts whose drawn boxes overlap (independent of plotting.overlapping)."""
    boxes = [t.get_window_extent(renderer).extents for t in texts]
    return [(texts[i].get_text(), texts[j].get_text())
            for i in range(len(boxes)) for j in range(i + 1, len(boxes))
            if min(boxes[i][2], boxes[j][2]) > max(boxes[i][0], boxes[j][0])
            and min(boxes[i][3], boxes[j][3]) > max(boxes[i][1], boxes[j][1])]


# ----------------------------------------------------------------------------
# the checks on the checks
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("text, defects", [
    ("engine, $\\delta$ = +0.0", 1), ("$\\delta = -0.0$", 1), ("x -0", 1), ("v = -0.05", 0),
    ("delta = +0.1", 2), ("eta = 0.1", 1), ("friction eta2", 1), ("theta and Beta", 1),
    ("$\\eta_1 = 0.1$", 0), ("metadata, Zeta", 0), ("$\\delta = 0.1$, $\\delta = -0.1$", 0),
    ("a $b", 1),
])
def test_the_text_checks_find_what_they_say(text, defects):
    """Each rule fires on its defect (as a legend entry) and is quiet on a correct one."""
    from matplotlib import pyplot as plt
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1], label=text)
    ax.legend()
    try:
        found = check_texts(fig, "t")
    finally:
        plt.close(fig)
    assert len(found) == defects, found


@pytest.mark.parametrize("x, text", [(0.0, "0"), (-0.0, "0"), (0.04, "0"), (-0.04, "0"),
                                     (0.1, "0.1"), (-0.1, "-0.1"), (0.4, "0.4"), (-0.4, "-0.4"),
                                     (2.25, "2.2"), (-1e-12, "0")])
def test_signed_prints_zero_as_0_and_no_plus(x, text):
    assert plotting.signed(x) == text


@pytest.mark.parametrize("name, tex", [("eta1", "$\\eta_{1}$"), ("gamma", "$\\gamma$"),
                                       ("delta", "$\\delta$"), ("n", "$n$"), ("v2", "$v_{2}$"),
                                       ("energy_ratio", "energy_ratio"), ("steps", "steps"),
                                       ("granules.friction.kinetic[0]",
                                        "granules.friction.kinetic[0]")])
def test_tex_name(name, tex):
    assert plotting.tex_name(name) == tex


# ----------------------------------------------------------------------------
# the figures
# ----------------------------------------------------------------------------
def test_hertz_contour_labels_do_not_overlap(tmp_path, saved, monkeypatch):
    """Every panel of Fig. hertz keeps several labels, none overlapping another or
    leaving its axes; on the same data matplotlib's own clabel does pile them up
    (so the data is a real test)."""
    data = hertz_like()
    figures.fig_hertz(tmp_path, data=data)
    fig = only(saved)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    panels = [ax for ax in fig.axes if contour_labels(ax)]
    assert len(panels) == 3
    for ax in panels:
        labels = contour_labels(ax)
        assert len(labels) >= 3, [t.get_text() for t in labels]
        assert not overlaps(labels, renderer)
        inside = ax.get_window_extent(renderer)
        for t in labels:
            b = t.get_window_extent(renderer)
            assert inside.x0 <= b.x0 and b.x1 <= inside.x1 and inside.y0 <= b.y0 \
                and b.y1 <= inside.y1, t.get_text()
    assert not check_texts(fig, "hertz")

    saved.clear()
    monkeypatch.setattr(figures, "label_contours",
                        lambda ax, cs: ax.clabel(cs, fontsize=6, fmt="%.3g"))
    figures.fig_hertz(tmp_path, data=data)
    fig = only(saved)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    assert any(overlaps(contour_labels(ax), renderer) for ax in fig.axes)


def test_label_contours_keeps_every_label_when_none_meet(tmp_path):
    """Well separated closed levels: nothing is dropped, each level is labelled once."""
    from matplotlib import pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 5))
    x = np.linspace(-1, 1, 60)
    X, Y = np.meshgrid(x, x)
    cs = ax.contour(x, x, X**2 + Y**2, levels=[0.1, 0.4, 0.8])
    labels = plotting.label_contours(ax, cs)
    fig.canvas.draw()
    assert sorted(t.get_text() for t in labels) == ["0.1", "0.4", "0.8"]
    assert not overlaps(labels, fig.canvas.get_renderer())
    plt.close(fig)


@pytest.mark.parametrize("name", ["velocity", "energy", "timecompare2", "timecompare3",
                                  "finalv1", "finalv1m5"])
def test_paper_figure_labels(name, tmp_path, saved, monkeypatch):
    """Titles, axis labels, legends and annotations of every 1-D paper figure."""
    monkeypatch.setattr(figures, "collision_values", _fake_collisions)
    monkeypatch.setattr(figures, "_iib_state_at_stop",
                        lambda eta: (np.full(len(eta), 0.9), np.full(len(eta), 0.5)))
    monkeypatch.setattr(figures, "iib_back_sliding_times",
                        lambda eta, u0, v20: (0.5 + 0 * eta, 0.6 + 0 * eta))
    kwargs = {"m": 9} if name != "timecompare2" else {"m": 12}
    figures.FIGURES[name](tmp_path, **kwargs)
    fig = only(saved)
    assert not check_texts(fig, name)
    if name == "finalv1m5":
        legend = [t for k, t in all_texts(fig) if k == "legend"]
        for value in ("0", "0.1", "-0.1"):
            assert any(f"$\\delta = {value}$" in t for t in legend), legend


def test_heatmap_labels_and_contour_labels(tmp_path, saved):
    """A sweep heat map: symbols in mathtext, contour labels apart."""
    from granular_chain.sweep import plot_heatmap
    d = hertz_like(25)
    E1, E2 = np.meshgrid(d["eta1"], d["eta2"])
    cols = {"a": E1.ravel(), "b": E2.ravel(), "v1": -d["v1"].ravel() + 0.01 * E1.ravel()}
    plot_heatmap(cols, "a", "b", "v1", tmp_path / "h.png")
    fig = only(saved)
    fig.canvas.draw()
    cbar_labels = [ax.get_ylabel() for ax in fig.axes]
    assert "$v_{1}$" in cbar_labels
    ax = fig.axes[0]
    labels = contour_labels(ax)
    assert labels and not overlaps(labels, fig.canvas.get_renderer())
    assert not check_texts(fig, "heatmap")


def test_boundary_plot_labels(tmp_path, saved, monkeypatch):
    """The boundary figure over (eta1, eta2): axis names in mathtext."""
    from granular_chain.two_granules import curves, maps
    monkeypatch.setattr(maps, "collision_map",
                        lambda e1, e2, n, gamma: types.SimpleNamespace(
                            outcome=(np.asarray(e1) > 0.1).astype(int)))
    curve = types.SimpleNamespace(plane=("eta1", "eta2"), points=np.array([[0.1, 0.0], [0.1, 1.0]]),
                                  corners=[])
    curves.plot_curves([curve], tmp_path / "c.png", ((0.0, 0.3), (0.0, 0.7)), m=8)
    fig = only(saved)
    ax = fig.axes[0]
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("$\\eta_{1}$", "$\\eta_{2}$")
    assert not check_texts(fig, "boundaries")
