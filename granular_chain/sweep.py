"""Parameter sweeps: grids or lists of scene overrides, run on dask.distributed.

One sweep = one scene file, fixed overrides (``--set``) and axes::

    granular-chain sweep scenarios/chain_eta_map.yaml \\
        --grid 'granules.friction.kinetic[0]=0:0.5:100' \\
        --grid 'granules.friction.kinetic[1]=0:0.8:100' --quantity v1 --mask outcome=backscatter_and_propagation

Every point of the Cartesian product of the axes is a scene: load, apply the
overrides, validate, :func:`~granular_chain.simulate.simulate`, reduce the
result to a row of scalars (:data:`QUANTITIES`). Points are grouped in batches
(one dask task per batch, so the scheduler's per-task cost, ~1 ms, is paid once
per batch and not once per point) and sent to a ``LocalCluster`` of processes
(2 workers by default) or to an existing scheduler (``--scheduler ADDRESS``).

Results are one CSV, ``OUT/results.csv``: one row per point, the grid
coordinates first (named by their dotted paths), then the quantities. Rows are
appended and flushed as batches finish, so the file is always a valid prefix of
the sweep; a rerun of the same command reads it, skips every point already
there (matched by coordinates) and computes only the rest. A row cut short by
a hard kill is dropped and its point recomputed. ``OUT/sweep.json`` records the
scene's hash and the fixed overrides; a rerun with a different scene refuses
(start afresh with ``--restart``). Axes may change between runs: points of a
refined grid that were computed before are reused.

Dotted paths may index lists: ``granules.friction.kinetic[1]=...`` sets
granule 1's value; a scalar per-granule (per-contact) field is first expanded
to one value per granule (contact), so the scene file can keep ``0.0``.
"""

from __future__ import annotations

import argparse
import copy
import csv
import hashlib
import io
import itertools
import json
import math
import os
import re
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional, Sequence

import numpy as np
import yaml

from .scene import parse_yaml_value

__all__ = [
    "Axis", "parse_grid", "parse_list", "grid_points", "set_path", "evaluate_point",
    "run_sweep", "SweepStats", "read_results", "plot_heatmap", "QUANTITIES",
    "add_sweep_parser", "run_sweep_command", "SweepError",
]

#: Columns every row has, after the coordinates (empty when not applicable).
QUANTITIES = (
    "status",            # t_end, separated, at_rest, max_steps, nonfinite, ... or error
    "success",           # 1 / 0
    "t_final",           # time of the final state
    "steps",             # Verlet steps taken
    "E0",                # initial (kinetic + elastic) energy
    "kinetic", "potential", "coulomb", "viscous",  # final ledger
    "energy_ratio",      # (kinetic + potential) / E0 at the end
    "balance_error",     # max |ledger balance| / E0 over the frames
    "momentum",          # final sum m v
    "backscatter_velocity",   # most negative final velocity of the first 3 granules (0 if none)
    "backscatter_energy",     # sum m v^2/2 over the granules moving backward at the end
    "backscatter_count",      # how many move backward at the end
    "penetration_depth",      # granules that ever moved
    "backscatter_energy_max",  # largest backward kinetic energy of the first 3 over the frames (--frames)
    "pulse_death_time",       # mechanical energy < 1e-3 E0 (needs frames; inf if never)
    "pulse_speed",            # granules per unit time (only with --frames, N >= 8)
    "pulse_v_peak",           # peak velocity of the pulse (only with --frames)
    "v1", "v2", "outcome", "t_separation",  # N = 2: the collide() outcome fields
    "wall_time",         # seconds stepping (compiled kernel)
    "eval_time",         # seconds for the whole point (validation, model, run, reduction)
    "message",           # the run's message, or the error for a point that could not run
)

_INDEX = re.compile(r"^(?P<name>[A-Za-z_][A-Za-z0-9_]*)\[(?P<i>-?\d+)\]$")
_PER_GRANULE = {"granules.mass", "granules.radius", "granules.velocity",
                "granules.friction.kinetic", "granules.friction.static",
                "granules.friction.viscous", "granules.material.young",
                "granules.material.poisson"}
_PER_CONTACT = {"granules.gap", "contacts.exponent", "contacts.stiffness"}


class SweepError(ValueError):
    """A sweep that cannot start (bad axis, inconsistent resume)."""


@dataclass(frozen=True)
class Axis:
    """One axis of a sweep: a dotted path and its values (in order)."""

    path: str
    values: tuple
    spec: str

    def __len__(self) -> int:
        return len(self.values)


def parse_grid(spec: str) -> Axis:
    """``path=start:stop:num`` (inclusive, like numpy.linspace) or ``...:num:log`` (geomspace)."""
    path, _, rng = spec.partition("=")
    parts = rng.split(":")
    if not path or len(parts) not in (3, 4) or (len(parts) == 4 and parts[3] != "log"):
        raise SweepError(f"--grid {spec!r}: expected dotted.path=start:stop:num[:log]")
    try:
        a, b, n = float(parts[0]), float(parts[1]), int(parts[2])
    except ValueError:
        raise SweepError(f"--grid {spec!r}: start and stop must be numbers, num an integer") from None
    if n < 1:
        raise SweepError(f"--grid {spec!r}: num must be at least 1")
    if len(parts) == 4:
        if a <= 0 or b <= 0:
            raise SweepError(f"--grid {spec!r}: a log grid needs positive start and stop")
        vals = np.geomspace(a, b, n)
    else:
        vals = np.linspace(a, b, n)
    if _is_int(parts[0]) and _is_int(parts[1]) and all(float(v).is_integer() for v in vals):
        # whole-number ends and steps: the values are counts or indices, written as integers
        return Axis(path.strip(), tuple(int(v) for v in vals), spec)
    return Axis(path.strip(), tuple(float(v) for v in vals), spec)


def _is_int(text: str) -> bool:
    try:
        int(text)
    except ValueError:
        return False
    return True


def parse_list(spec: str) -> Axis:
    """``path=a,b,c``: values parsed as YAML (numbers, strings, ``[..]`` lists are not split)."""
    path, _, raw = spec.partition("=")
    if not path or not raw:
        raise SweepError(f"--list {spec!r}: expected dotted.path=a,b,c")
    values = []
    for item in _split_top(raw):
        try:
            values.append(parse_yaml_value(item))
        except yaml.YAMLError:
            raise SweepError(f"--list {spec!r}: {item!r} is not valid YAML") from None
    return Axis(path.strip(), tuple(values), spec)


def _split_top(raw: str) -> list[str]:
    """Split on commas outside brackets, so ``[1, 2],[3, 4]`` is two items."""
    out, depth, cur = [], 0, ""
    for ch in raw:
        if ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        if ch == "," and depth == 0:
            out.append(cur)
            cur = ""
        else:
            cur += ch
    out.append(cur)
    return [s.strip() for s in out if s.strip()]


def grid_points(axes: Sequence[Axis]) -> list[tuple]:
    """Every combination of axis values, the last axis varying fastest."""
    return list(itertools.product(*(a.values for a in axes)))


def _coord_text(value) -> str:
    """How a coordinate is written in the CSV (and matched on resume)."""
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, (int, str)) and not isinstance(value, bool):
        return str(value)
    return json.dumps(value)


def set_path(data: dict, path: str, value) -> None:
    """Set ``data[a][b][c] = value`` for ``a.b.c``; ``c[i]`` sets one item of a list.

    A per-granule (per-contact) field that holds a single number, or a sparse
    ``{index: value}`` velocity, is first expanded to one value per granule
    (contact) so that one of them can be set.
    """
    parts = path.split(".")
    target = data
    for part in parts[:-1]:
        nxt = target.get(part)
        if nxt is None:
            nxt = target[part] = {}
        if not isinstance(nxt, dict):
            raise SweepError(f"{path}: '{part}' is not a group of fields")
        target = nxt
    last = parts[-1]
    m = _INDEX.match(last)
    if m is None:
        target[last] = value
        return
    name, i = m["name"], int(m["i"])
    plain = ".".join(parts[:-1] + [name])
    current = target.get(name)
    if not isinstance(current, list):
        count = int(data.get("granules", {}).get("count", 0))
        if plain in _PER_GRANULE:
            size = count
        elif plain in _PER_CONTACT:
            size = count - 1
        else:
            raise SweepError(f"{path}: '{name}' is not a list and not a per-granule field")
        if isinstance(current, dict):  # sparse velocity mapping
            full = [0.0] * size
            for k, val in current.items():
                full[int(k)] = val
            current = full
        else:
            default = {"granules.mass": 1.0, "granules.radius": 0.5}.get(plain, 0.0)
            current = [default if current is None else current] * size
    current = list(current)
    if not -len(current) <= i < len(current):
        raise SweepError(f"{path}: index {i} out of range for {len(current)} values")
    current[i] = value
    target[name] = current


def _scene_text_hash(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()[:16]


# ---------------------------------------------------------------- one point


@dataclass(frozen=True)
class PointOptions:
    """How each point is run and reduced (sent to the workers with every batch)."""

    frames: bool = False       # keep the scene's output cadence (pulse quantities need it)
    granules: tuple = (0, 1, -1)  # v_final columns
    first: int = 3             # backscatter: the first this many granules


def _vcols(granules) -> list[str]:
    return [f"v_final[{g}]" for g in granules]


def evaluate_point(scene_data: dict, source: str, paths: Sequence[str], coords: Sequence,
                   options: PointOptions = PointOptions()) -> dict:
    """Run one point: overrides on a copy of the scene mapping, simulate, reduce to a row.

    Never raises for a bad point: a scene error or a refused run becomes a row
    with ``status = error`` and the reason in ``message`` (the sweep goes on, and
    the point counts as done).
    """
    from . import diagnostics as dg
    from .model import build_model
    from .scene import SceneError, scene_from_dict
    from .simulate import SimulationError, simulate

    start = time.perf_counter()
    row: dict[str, Any] = {p: _coord_text(c) for p, c in zip(paths, coords)}
    data = copy.deepcopy(scene_data)
    try:
        for p, c in zip(paths, coords):
            set_path(data, p, c)
        if not options.frames:
            # Only the final state: one frame at the end (a chunk per frame costs Python time).
            out = data.setdefault("output", {})
            out.pop("dt", None)
            out["every"] = 2_000_000_000
        scene = scene_from_dict(data, source=source)
        model = build_model(scene)
        result = simulate(scene, progress=False)
    except (SceneError, SimulationError, SweepError) as exc:
        row.update(status="error", success=0, message=str(exc),
                   eval_time=time.perf_counter() - start)
        return row
    N = model.count
    e = result.energy
    b = dg.backscatter(result, model, first=options.first)
    row.update(
        status=result.status.name.lower(), success=int(result.success),
        t_final=result.t_final, steps=result.steps, E0=e.initial,
        kinetic=float(e.kinetic[-1]), potential=float(e.potential[-1]),
        coulomb=float(e.coulomb[-1]), viscous=float(e.viscous[-1]),
        energy_ratio=float(e.kinetic[-1] + e.potential[-1]) / (e.initial or 1.0),
        balance_error=e.balance_error,
        momentum=float(np.dot(model.mass, result.v_final)),
        backscatter_velocity=b["velocity"], backscatter_energy=b["energy"],
        backscatter_count=b["count"], penetration_depth=dg.penetration_depth(result),
        pulse_death_time=dg.pulse_death_time(result) if options.frames else "",
        backscatter_energy_max=b["energy_max"] if options.frames else "",
        wall_time=result.wall_time, message=result.message)
    for g in options.granules:
        if -N <= g < N:
            row[f"v_final[{g}]"] = float(result.v_final[g])
    if options.frames and N >= 8:
        try:
            fit = dg.pulse_speed(result)
            row.update(pulse_speed=fit.speed, pulse_v_peak=fit.v_peak)
        except ValueError:
            pass
    if N == 2 and result.stepper is not None:
        from .two_granules import classify
        try:
            c = classify(result, 0.0 if result.dt is None else result.dt ** 2)
            row.update(v1=c.v1, v2=c.v2, outcome=c.outcome.name, t_separation=c.t_separation,
                       energy_ratio=c.energy_ratio)
        except RuntimeError as exc:
            row.update(outcome="failed", message=str(exc))
    row["eval_time"] = time.perf_counter() - start
    return row


def _run_batch(scene_data, source, paths, batch, options):
    """One dask task: a list of coordinate tuples -> a list of rows."""
    return [evaluate_point(scene_data, source, paths, coords, options) for coords in batch]


# ---------------------------------------------------------------- results file


def _read_done(path: Path, header: list[str], paths: Sequence[str]) -> set:
    """Coordinates already in results.csv; drops a last row cut short by a hard kill."""
    if not path.exists():
        return set()
    text = path.read_text()
    if not text:
        return set()
    if not text.endswith("\n"):  # a partial last line: cut it off, the point reruns
        text = text[: text.rfind("\n") + 1]
        with open(path, "r+") as fh:
            fh.truncate(len(text.encode()))
    reader = csv.reader(io.StringIO(text))
    try:
        found = next(reader)
    except StopIteration:
        return set()
    if found != header:
        raise SweepError(
            f"{path}: its columns {found[:len(paths)]}... differ from this sweep's "
            f"{header[:len(paths)]}...; use another --out or --restart")
    k = len(paths)
    return {tuple(r[:k]) for r in reader if len(r) == len(header)}


def read_results(path) -> dict[str, np.ndarray]:
    """results.csv as columns: numbers as float arrays (blank = nan), the rest as str arrays."""
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    cols = {}
    names = rows[0].keys() if rows else []
    for name in names:
        raw = [r[name] for r in rows]
        try:
            cols[name] = np.array([float(x) if x != "" else np.nan for x in raw])
        except ValueError:
            cols[name] = np.array(raw, dtype=object)
    return cols


@dataclass
class SweepStats:
    """What a call of :func:`run_sweep` did."""

    points: int               # points in the grid
    skipped: int              # already in the results file
    computed: int             # evaluated now (rows received from the workers)
    batches: int
    wall: float               # seconds, from the first submission to the last row written
    workers: int
    results: Path
    interrupted: bool = False
    setup: float = 0.0        # seconds to start the cluster
    sum_eval: float = 0.0     # sum of eval_time over the computed points
    sum_kernel: float = 0.0   # sum of wall_time (stepping) over the computed points

    def overhead_per_point(self) -> float:
        """Seconds per point that were not spent stepping, with the workers' time pooled."""
        if not self.computed:
            return 0.0
        return (self.wall * self.workers - self.sum_kernel) / self.computed

    def as_dict(self) -> dict:
        d = {k: (str(v) if isinstance(v, Path) else v) for k, v in self.__dict__.items()}
        d["overhead_per_point_s"] = self.overhead_per_point()
        d["points_per_s"] = self.computed / self.wall if self.wall > 0 else None
        return d


def _check_sweep_folder(out_dir: Path) -> None:
    """A sweep writes into a new or empty folder, or resumes one holding its own
    sweep.json; any other folder is the user's and is refused (nothing changed)."""
    if out_dir.is_symlink() or (out_dir.exists() and not out_dir.is_dir()):
        raise SweepError(f"--out {out_dir}: is not a folder")
    if not out_dir.exists() or not any(out_dir.iterdir()):
        return
    try:
        meta = json.loads((out_dir / "sweep.json").read_text())
    except (OSError, ValueError):
        meta = None
    if not isinstance(meta, dict) or "scene_sha256" not in meta:
        raise SweepError(f"--out {out_dir}: exists and is not a sweep folder (no sweep.json "
                         f"written by granular-chain sweep); nothing was changed: name a new "
                         f"folder")


def run_sweep(scene_path, axes: Sequence[Axis], *, out_dir, fixed: Sequence[str] = (),
              options: PointOptions = PointOptions(), executor: str = "dask",
              scheduler: Optional[str] = None, workers: int = 2,
              batch_size: Optional[int] = None, progress: Optional[bool] = None,
              restart: bool = False, client=None) -> SweepStats:
    """Run (or resume) a sweep; rows land in ``out_dir/results.csv`` as batches finish.

    Parameters
    ----------
    scene_path : str or Path
        The scene file.
    axes : sequence of Axis
        From :func:`parse_grid` / :func:`parse_list`.
    out_dir : str or Path
        Folder for results.csv, sweep.json and heat maps.
    fixed : sequence of str
        ``dotted.path=value`` overrides applied to every point (like ``--set``).
    options : PointOptions
    executor : {'dask', 'serial'}
        'serial' runs the batches in this process, in order (tests, debugging).
    scheduler : str, optional
        Address of a running dask scheduler; default a LocalCluster.
    workers : int
        LocalCluster worker processes (one thread each).
    batch_size : int, optional
        Points per task; default about 1/16 of each worker's share, at most 256.
    progress : bool, optional
        tqdm bar over points (default: on a terminal).
    restart : bool
        Discard an existing results.csv instead of resuming.
    client : distributed.Client, optional
        Use this client (and leave it open).

    Returns
    -------
    SweepStats
        ``interrupted`` is true after Ctrl-C: the rows written so far are kept.
    """
    from .scene import SceneError, apply_overrides, read_scene_data

    scene_path = Path(scene_path)
    try:
        data = read_scene_data(scene_path)
        text = scene_path.read_text()
    except SceneError as exc:
        raise SweepError(str(exc)) from None
    if not isinstance(data, dict):
        raise SweepError(f"{scene_path}: a scene must be a mapping of fields")
    try:
        apply_overrides(data, list(fixed), source=f"{scene_path} (--set)")
    except SceneError as exc:
        raise SweepError(str(exc)) from None
    paths = [a.path for a in axes]
    if len(set(paths)) != len(paths):
        raise SweepError("two axes set the same dotted path")
    header = paths + list(QUANTITIES) + _vcols(options.granules)
    out_dir = Path(out_dir)
    _check_sweep_folder(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    results = out_dir / "results.csv"
    meta_path = out_dir / "sweep.json"
    meta = {"scene": str(scene_path), "scene_sha256": _scene_text_hash(text),
            "fixed": list(fixed), "frames": options.frames, "first": options.first}
    if restart and results.exists():
        results.unlink()
    if results.exists() and meta_path.exists():
        old = json.loads(meta_path.read_text())
        for key in ("scene_sha256", "fixed", "frames", "first"):
            if old.get(key) != meta[key]:
                raise SweepError(
                    f"{results} was made with a different {key} ({old.get(key)!r}, now "
                    f"{meta[key]!r}); use another --out, or --restart to discard it")
    done = _read_done(results, header, paths)
    meta["axes"] = [a.spec for a in axes]
    meta_path.write_text(json.dumps(meta, indent=2) + "\n")

    allpts = grid_points(axes)
    pending = [c for c in allpts if tuple(_coord_text(v) for v in c) not in done]
    skipped = len(allpts) - len(pending)
    nworkers = workers
    stats = SweepStats(points=len(allpts), skipped=skipped, computed=0, batches=0, wall=0.0,
                       workers=nworkers, results=results)
    new_file = not results.exists() or results.stat().st_size == 0
    fh = open(results, "a", newline="")
    writer = csv.DictWriter(fh, fieldnames=header, extrasaction="ignore")
    if new_file:
        writer.writeheader()
        fh.flush()
    bar = _bar(progress, len(allpts), skipped)
    cluster = own_client = None
    try:
        if not pending:
            return stats
        t0 = time.perf_counter()
        if executor == "dask":
            if client is None:
                from distributed import Client, LocalCluster
                if scheduler:
                    client = own_client = Client(scheduler)
                else:
                    cluster = LocalCluster(n_workers=workers, threads_per_worker=1,
                                           processes=True, dashboard_address=None)
                    client = own_client = Client(cluster)
            nworkers = max(len(client.scheduler_info().get("workers", {})), 1)
            stats.workers = nworkers
        elif executor == "serial":
            nworkers = stats.workers = 1
        else:
            raise SweepError(f"executor must be 'dask' or 'serial', got {executor!r}")
        stats.setup = time.perf_counter() - t0
        if batch_size is None:
            batch_size = int(min(256, max(1, math.ceil(len(pending) / (nworkers * 16)))))
        batches = [pending[i:i + batch_size] for i in range(0, len(pending), batch_size)]
        start = time.perf_counter()

        def take(rows):
            for r in rows:
                writer.writerow(r)
            fh.flush()
            os.fsync(fh.fileno())
            stats.computed += len(rows)
            stats.batches += 1
            stats.sum_eval += sum(float(r.get("eval_time") or 0.0) for r in rows)
            stats.sum_kernel += sum(float(r.get("wall_time") or 0.0) for r in rows)
            if bar is not None:
                bar.update(len(rows))

        try:
            if executor == "serial":
                for batch in batches:
                    take(_run_batch(data, str(scene_path), paths, batch, options))
            else:
                from distributed import as_completed
                # hash=False: a content-hashed key would be shared with an earlier
                # sweep of the same scene on this client, whose release can then
                # delete the data under this one ("lost dependencies").
                [data_f] = client.scatter([data], broadcast=True, hash=False)
                futures = [client.submit(_run_batch, data_f, str(scene_path), paths, batch,
                                         options, pure=False) for batch in batches]
                try:
                    for fut in as_completed(futures):
                        take(fut.result())
                finally:
                    client.cancel(futures)
        except KeyboardInterrupt:
            stats.interrupted = True
        stats.wall = time.perf_counter() - start
        return stats
    finally:
        fh.close()
        if bar is not None:
            bar.close()
        if own_client is not None:
            own_client.close()
        if cluster is not None:
            cluster.close()


def _bar(progress, total, initial):
    if progress is False or (progress is None and not sys.stderr.isatty()):
        return None
    from tqdm import tqdm
    return tqdm(total=total, initial=initial, unit="point", smoothing=0.05, file=sys.stderr)


# ---------------------------------------------------------------- heat maps


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
    mask : dict, optional
        ``{column: value}``: only points where every column equals its value are
        coloured; the rest are grey (the paper's maps show the
        backscatter-and-propagation region only).
    transform : callable, optional
        Applied to the numbers before plotting (e.g. ``np.negative`` for -v1).
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

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
        cb = fig.colorbar(im, ax=ax, ticks=range(len(cats)))
        cb.ax.set_yticklabels(cats, fontsize=7)
    else:
        im = ax.pcolormesh(xs, ys, grid, cmap="Greys" if mask else "viridis", shading="nearest")
        fig.colorbar(im, ax=ax, label=label or quantity)
        if contours and xs.size > 3 and ys.size > 3 and np.isfinite(grid).sum() > 10:
            try:
                cs = ax.contour(xs, ys, grid, levels=8, colors="tab:red", linewidths=0.7)
                ax.clabel(cs, fontsize=6, fmt="%.3g")
            except (ValueError, TypeError):
                pass
    if not seen.all():
        ax.text(0.01, 0.01, f"{int((~seen).sum())} points not computed", transform=ax.transAxes,
                fontsize=7)
    ax.set_xlabel(x)
    ax.set_ylabel(y)
    ax.set_title(title or (quantity + (f"  (where {mask})" if mask else "")), fontsize=8)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path


# ---------------------------------------------------------------- CLI


def add_sweep_parser(subparsers) -> argparse.ArgumentParser:
    """Register ``granular-chain sweep`` on an argparse subparsers object."""
    p = subparsers.add_parser(
        "sweep", help="run a grid of scene overrides on dask.distributed (resumable)",
        description="Run every point of a grid (or list) of scene overrides in parallel on "
        "dask.distributed; results.csv grows as points finish and a rerun resumes.")
    p.add_argument("scene", help="scene YAML file")
    p.add_argument("--grid", action="append", default=[], metavar="dotted.path=start:stop:num",
                   help="an axis of evenly spaced values (inclusive; add ':log' for geometric). "
                   "Lists can be indexed: granules.friction.kinetic[1]=0:0.8:41")
    p.add_argument("--list", dest="lists", action="append", default=[],
                   metavar="dotted.path=a,b,c", help="an axis of explicit values (YAML)")
    p.add_argument("--set", dest="fixed", action="append", default=[],
                   metavar="dotted.path=value", help="override applied to every point")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="address of a running dask scheduler (default: a LocalCluster)")
    p.add_argument("--workers", type=int, default=2, help="LocalCluster worker processes")
    p.add_argument("--serial", action="store_true", help="no dask: run in this process")
    p.add_argument("--batch-size", type=int, default=None, help="points per dask task")
    p.add_argument("--out", default=None, help="folder (default outputs/sweeps/<scene stem>)")
    p.add_argument("--quantity", action="append", default=[], metavar="NAME",
                   help="heat map of this column (2-D sweeps; repeatable)")
    p.add_argument("--mask", action="append", default=[], metavar="COLUMN=VALUE",
                   help="heat maps colour only points with this value (repeatable)")
    p.add_argument("--granules", default="0,1,-1", metavar="I,J,...",
                   help="granules whose final velocity is a column (default 0,1,-1)")
    p.add_argument("--frames", action="store_true",
                   help="keep the scene's output cadence (pulse speed, pulse death time)")
    p.add_argument("--restart", action="store_true", help="discard earlier results in --out")
    p.add_argument("--quiet", action="store_true", help="no progress bar, no report")
    return p


def run_sweep_command(args) -> int:
    """Entry point of ``granular-chain sweep``: 0 done, 2 bad input, 130 interrupted."""
    try:
        axes = [parse_grid(s) for s in args.grid] + [parse_list(s) for s in args.lists]
        if not axes:
            raise SweepError("give at least one --grid or --list axis")
        granules = tuple(int(g) for g in args.granules.split(",") if g.strip())
        mask = {}
        for item in args.mask:
            k, sep, v = item.partition("=")
            if not sep:
                raise SweepError(f"--mask {item!r}: expected COLUMN=VALUE")
            mask[k] = v
        out = Path(args.out) if args.out else Path("outputs") / "sweeps" / Path(args.scene).stem
        stats = run_sweep(args.scene, axes, out_dir=out, fixed=args.fixed,
                          options=PointOptions(frames=args.frames, granules=granules),
                          executor="serial" if args.serial else "dask",
                          scheduler=args.scheduler, workers=args.workers,
                          batch_size=args.batch_size, progress=False if args.quiet else None,
                          restart=args.restart)
    except (SweepError, ValueError) as exc:
        print(f"granular-chain: {exc}", file=sys.stderr)
        return 2
    if not args.quiet:
        print(json.dumps(stats.as_dict(), indent=2))
    if stats.interrupted:
        print(f"granular-chain: interrupted after {stats.skipped + stats.computed} of "
              f"{stats.points} points; rerun the same command to resume", file=sys.stderr)
        return 130
    if args.quantity:
        if len(axes) != 2:
            print("granular-chain: heat maps need exactly two axes", file=sys.stderr)
            return 2
        for q in args.quantity:
            try:
                png = plot_heatmap(stats.results, axes[0].path, axes[1].path, q,
                                   out / f"heatmap_{_slug(q)}.png", mask=mask or None)
            except SweepError as exc:
                print(f"granular-chain: {exc}", file=sys.stderr)
                return 2
            if not args.quiet:
                print(png)
    return 0


def _same(value, want) -> bool:
    if isinstance(value, str):
        return value == str(want)
    try:
        return float(value) == float(want)
    except (TypeError, ValueError):
        return False


def _slug(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("_")
