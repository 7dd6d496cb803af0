"""What a classic experiment is: a name, a title, its scene files, a function
returning its table, and a figure."""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterator

from ..extras import require
from ..scene import Scene, load_scene
from .table import Row

__all__ = ["Experiment", "Outcome", "SCENES", "scene_of", "figure_file", "final_energy"]

#: Where the experiments' scenes are: ``scenarios/classics/`` of the source tree, installed
#: with the package as ``granular_chain/classics/scenes/`` (a link to it in the source tree).
SCENES = Path(__file__).resolve().parent / "scenes"


@dataclass
class Outcome:
    """What an experiment found.

    Attributes
    ----------
    rows : list of Row
        The table.
    data : dict
        Further numbers and curves (JSON-ready), for the figure and the JSON file.
    """

    rows: list
    data: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Experiment:
    """One classic experiment.

    Attributes
    ----------
    name : str
        Its name on the command line (``granular-chain classics NAME``).
    title : str
        One line saying what it is.
    scenes : tuple of str
        Its scene files, in :data:`SCENES`.
    compute : callable(Path) -> Outcome
        Runs it, given the folder holding its scenes.
    figure : callable(Outcome, Path) -> None
        Draws its figure into a PNG file (needs matplotlib).
    """

    name: str
    title: str
    scenes: tuple
    compute: Callable[[Path], Outcome]
    figure: Callable[[Outcome, Path], None]

    def run(self, scenes: Path = SCENES) -> Outcome:
        """Run the experiment.

        Parameters
        ----------
        scenes : Path
            The folder holding its scene files (default :data:`SCENES`).

        Returns
        -------
        Outcome
        """
        return self.compute(Path(scenes))

    def rows(self, scenes: Path = SCENES) -> list[Row]:
        """The experiment's table (it runs the experiment).

        Parameters
        ----------
        scenes : Path
            The folder holding its scene files.

        Returns
        -------
        list of Row
        """
        return self.run(scenes).rows


def scene_of(folder: Path, name: str, overrides=()) -> Scene:
    """Load the scene ``folder/name`` with ``--set``-style overrides.

    Parameters
    ----------
    folder : Path
        The scenes' folder.
    name : str
        The file's name.
    overrides : sequence of str
        ``dotted.path=value`` items.

    Returns
    -------
    Scene
    """
    return load_scene(Path(folder) / name, list(overrides))


def final_energy(result) -> float:
    """Kinetic plus contact energy at the end of a run, from the engine's own energy
    ledger (its last frame, which is the final state).

    Parameters
    ----------
    result : Result
        A finished run.

    Returns
    -------
    float
        Energy, scene units.

    Raises
    ------
    RuntimeError
        The run's last frame is not its final state.
    """
    if float(result.t[-1]) != float(result.t_final):
        raise RuntimeError(f"the last frame (t = {result.t[-1]}) is not the run's end "
                           f"(t = {result.t_final}): no ledger entry for the final state")
    return float(result.energy.kinetic[-1] + result.energy.potential[-1])


@contextmanager
def figure_file(path: Path, panels: int = 1, size: tuple = (7.0, 4.2)) -> Iterator[tuple]:
    """A matplotlib figure of ``panels`` side by side, laid out, written to ``path``
    (PNG, 120 dpi) and closed when the block ends (closed, unwritten, on an error).

    Parameters
    ----------
    path : Path
        The PNG written.
    panels : int
        Axes in one row.
    size : tuple of float
        Width and height, inches.

    Yields
    ------
    tuple
        ``(figure, axes)``: one Axes for one panel, else an array of them.

    Raises
    ------
    MissingExtraError
        matplotlib is not installed (the ``plots`` extra).
    """
    require("matplotlib", "granular-chain classics").use("Agg")
    plt = require("matplotlib.pyplot", "granular-chain classics")
    fig, axes = plt.subplots(1, panels, figsize=size)
    try:
        yield fig, axes
        fig.tight_layout()
        fig.savefig(path, dpi=120)
    finally:
        plt.close(fig)
