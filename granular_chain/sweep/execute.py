"""Running a sweep: points in batches, one dask task per batch, on a LocalCluster or an
existing scheduler (or in this process); rows written as batches finish."""

from __future__ import annotations

import csv
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Optional, Sequence

from tqdm import tqdm

from .._compile import share_compiling
from ..extras import require
from ..interrupts import stop_signals
from ..scene import SceneError, apply_overrides, read_scene_data
from . import point
from .grid import Axis, SweepError, coord_text, grid_points
from .point import QUANTITIES, PointOptions, value_columns
from .resume import open_results, scene_text_hash

__all__ = ["SweepStats", "run_sweep", "run_batch"]


@dataclass
class SweepStats:
    """What a call of :func:`run_sweep` did.

    Attributes
    ----------
    points : int
        Points in the grid.
    skipped : int
        Points already in the results file.
    computed : int
        Points evaluated by this call (rows received from the workers).
    batches : int
        Batches submitted.
    wall : float
        Seconds from the first submission to the last row written.
    workers : int
        Worker processes.
    results : Path
        The results.csv.
    interrupted : bool
        The sweep was stopped (Ctrl-C) before every point was done.
    setup : float
        Seconds to start the cluster.
    sum_eval : float
        Sum of the points' evaluation times, seconds.
    sum_kernel : float
        Sum of the points' stepping times, seconds.
    failed : int
        Computed points that could not run (status ``error``).
    first_error : str
        The message of the first of them.
    signal : int
        The signal that stopped a serial sweep (0: none, or Ctrl-C under dask).
    """

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
    failed: int = 0           # computed points with status error
    first_error: str = ""     # the message of the first
    signal: int = 0           # the signal that stopped a serial sweep

    def overhead_per_point(self) -> float:
        """Seconds per point that were not spent stepping, with the workers' time pooled.

        Returns
        -------
        float
            Seconds (0 when nothing was computed).
        """
        if not self.computed:
            return 0.0
        return (self.wall * self.workers - self.sum_kernel) / self.computed

    def as_dict(self) -> dict:
        """The fields (paths as text) with ``overhead_per_point_s`` and ``points_per_s``.

        Returns
        -------
        dict
            JSON-ready.
        """
        d = {k: (str(v) if isinstance(v, Path) else v) for k, v in self.__dict__.items()}
        d["overhead_per_point_s"] = self.overhead_per_point()
        d["points_per_s"] = self.computed / self.wall if self.wall > 0 else None
        return d


def run_batch(scene_data, source, paths, batch, options):
    """One dask task: a list of coordinate tuples -> a list of rows.

    ``evaluate_point`` is looked up on the :mod:`granular_chain.sweep` package at
    each call, so that replacing it there (tests count the calls) takes effect.

    Parameters
    ----------
    scene_data : dict
        The scene file's mapping (as read from YAML), not yet validated.
    source : str
        Path of the scene file (for messages and relative paths).
    paths : sequence of str
        Dotted paths of the axes, in order.
    batch : list of tuple
        Coordinates of the points, one value per axis.
    options : PointOptions
        How each point is run and reduced.

    Returns
    -------
    list of dict
        One row per point (:func:`evaluate_point`).
    """
    return [point.evaluate_point(scene_data, source, paths, coords, options)
            for coords in batch]


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
        How each point is run and reduced.
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
    scene_path = Path(scene_path)
    data, text = _read_scene(scene_path, fixed)
    paths = [a.path for a in axes]
    if len(set(paths)) != len(paths):
        raise SweepError("two axes set the same dotted path")
    header = paths + list(QUANTITIES) + value_columns(options.granules)
    meta = {"scene": str(scene_path), "scene_sha256": scene_text_hash(text),
            "fixed": list(fixed), "frames": options.frames, "first": options.first}
    results, done = open_results(Path(out_dir), meta, axes, header, restart)
    every = grid_points(axes)
    pending = [c for c in every if tuple(coord_text(v) for v in c) not in done]
    stats = SweepStats(points=len(every), skipped=len(every) - len(pending), computed=0,
                       batches=0, wall=0.0, workers=workers, results=results)
    with _Rows(results, header, stats, progress) as rows, _Workers() as pool:
        if pending:
            pool.start(stats, executor, client, scheduler, workers)
            if batch_size is None:
                batch_size = int(min(256, max(1, math.ceil(len(pending) / (stats.workers * 16)))))
            batches = [pending[i:i + batch_size] for i in range(0, len(pending), batch_size)]
            start = time.perf_counter()
            try:
                stats.signal = pool.run(batches, (data, str(scene_path), paths), options,
                                        rows.take)
            except KeyboardInterrupt:
                stats.interrupted = True
            stats.interrupted = stats.interrupted or stats.signal != 0
            stats.wall = time.perf_counter() - start
    return stats


def _read_scene(scene_path: Path, fixed: Sequence[str]) -> tuple[dict, str]:
    """The scene file's mapping with the fixed overrides applied, and its text."""
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
    return data, text


class _Rows:
    """results.csv open for appending (the header first in a new file) and the
    progress bar: each batch's rows are written, flushed and counted."""

    def __init__(self, results: Path, header: list[str], stats: SweepStats,
                 progress: Optional[bool]):
        self.stats = stats
        new_file = not results.exists() or results.stat().st_size == 0
        self.fh = open(results, "a", newline="")
        self.writer = csv.DictWriter(self.fh, fieldnames=header, extrasaction="ignore")
        if new_file:
            self.writer.writeheader()
            self.fh.flush()
        self.bar = _bar(progress, stats.points, stats.skipped)

    def take(self, rows: list[dict]) -> None:
        for r in rows:
            self.writer.writerow(r)
        self.fh.flush()
        os.fsync(self.fh.fileno())
        stats = self.stats
        stats.computed += len(rows)
        stats.batches += 1
        stats.sum_eval += sum(float(r.get("eval_time") or 0.0) for r in rows)
        stats.sum_kernel += sum(float(r.get("wall_time") or 0.0) for r in rows)
        errors = [r for r in rows if r.get("status") == "error"]
        if errors and not stats.failed:
            stats.first_error = str(errors[0].get("message", ""))
        stats.failed += len(errors)
        if self.bar is not None:
            self.bar.update(len(rows))

    def __enter__(self) -> "_Rows":
        return self

    def __exit__(self, *exc) -> None:
        self.fh.close()
        if self.bar is not None:
            self.bar.close()


class _Workers:
    """Where the batches run: this process ('serial') or a dask client, of a
    LocalCluster or scheduler started here (closed at the end) or given."""

    def __init__(self):
        self.serial = True
        self.client = self.own_client = self.cluster = None

    def start(self, stats: SweepStats, executor: str, client, scheduler, workers: int) -> None:
        """Connect (dask) and record the number of workers and the set-up time."""
        t0 = time.perf_counter()
        if executor == "dask":
            self.serial = False
            if client is None:
                distributed = require("distributed", "granular_chain sweep on dask")
                Client, LocalCluster = distributed.Client, distributed.LocalCluster
                if scheduler:
                    client = self.own_client = Client(scheduler)
                else:
                    share_compiling()
                    self.cluster = LocalCluster(n_workers=workers, threads_per_worker=1,
                                                processes=True, dashboard_address=None)
                    client = self.own_client = Client(self.cluster)
            self.client = client
            stats.workers = max(len(client.scheduler_info().get("workers", {})), 1)
        elif executor == "serial":
            stats.workers = 1
        else:
            raise SweepError(f"executor must be 'dask' or 'serial', got {executor!r}")
        stats.setup = time.perf_counter() - t0

    def run(self, batches: list, task: tuple, options: PointOptions, take) -> int:
        """Run every batch of ``task`` = (scene mapping, source, paths); ``take`` gets
        each batch's rows as it finishes. Returns the signal that stopped a serial
        sweep (0: none)."""
        data, source, paths = task
        if self.serial:
            return _run_serial(batches, task, options, take)
        as_completed = require("distributed", "granular_chain sweep on dask").as_completed
        client = self.client
        # hash=False: a content-hashed key would be shared with an earlier
        # sweep of the same scene on this client, whose release can then
        # delete the data under this one ("lost dependencies").
        [data_f] = client.scatter([data], broadcast=True, hash=False)
        futures = [client.submit(run_batch, data_f, source, paths, batch, options, pure=False)
                   for batch in batches]
        try:
            for fut in as_completed(futures):
                take(fut.result())
        finally:
            client.cancel(futures)

    def __enter__(self) -> "_Workers":
        return self

    def __exit__(self, *exc) -> None:
        if self.own_client is not None:
            self.own_client.close()
        if self.cluster is not None:
            self.cluster.close()


def _run_serial(batches: list, task: tuple, options: PointOptions, take) -> int:
    """The batches in this process, point by point, under one stop request: SIGINT,
    SIGTERM or SIGHUP ends the point being run within a compiled chunk (its row,
    interrupted, is dropped: it is run again on resume) and the sweep after it.
    Returns the signal's number (0: none)."""
    data, source, paths = task
    with stop_signals() as stop:
        for batch in batches:
            rows = []
            for coords in batch:
                row = run_batch(data, source, paths, [coords], options)[0]
                if stop.requested:
                    break
                rows.append(row)
            if rows:
                take(rows)
            if stop.requested:
                return stop.signum
    return 0


def _bar(progress, total, initial):
    if progress is False or (progress is None and not sys.stderr.isatty()):
        return None
    return tqdm(total=total, initial=initial, unit="point", smoothing=0.05, file=sys.stderr)
