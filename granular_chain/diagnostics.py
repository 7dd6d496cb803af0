"""Diagnostics of a chain run: the pulse, its width, backscattering, the energy ledger.

Pure functions of a :class:`~granular_chain.result.Result` (plus the masses, read
from a :class:`~granular_chain.model.Model` or a :class:`~granular_chain.scene.Scene`
where energies are needed). Nothing here runs a simulation (the command
``granular-chain diagnose``, :mod:`granular_chain.cli.diagnose`, does when it
is handed a scene file).

Frames matter. Every quantity is read off the recorded frames ``result.t``,
``result.v`` (shape ``(F, N)``), so its resolution is the output cadence:

* per-granule peak times (:func:`peak_times`, :func:`pulse_speed`) need frames
  much finer than the time the pulse takes to cross one granule (for a Hertz
  chain in scaled units, ~1 time unit): ``output.every`` of a few steps, or
  ``output.dt`` <= 0.05. The peak of each granule is refined by a parabola
  through the three frames around the largest sample, which makes the error
  O(frame spacing^3) for a smooth peak rather than O(frame spacing);
* widths are snapshots at single frames;
* maxima over time (:func:`backscatter` ``energy_max``) can miss a maximum that
  falls between frames.

Units are the scene's (scaled or SI). Speeds come in two forms: in granules per
unit time (from fitting granule index against peak time) and in length per unit
time (fitting the granules' initial centre positions instead).

Long-wave reference (Nesterenko): for a chain of equal masses ``m``, spacing
``a`` (= 2R for touching spheres) and contact force ``F = k delta^(3/2)``, the
continuum limit ``u_tt = -c^2 d/dx[(-u_x)^(3/2) + (a^2/10) ...]`` with
``c^2 = k a^(5/2) / m`` has the solitary wave

    xi(x) = (5 V^2 / (4 c^2))^2 cos^4(sqrt(10) x / (5 a)),   |x| <= 5 pi a / (2 sqrt 10)

(strain ``xi = -u_x``), so ``V = (2/sqrt 5) c xi_m^(1/4)``. The particle velocity
in the wave is ``v = V xi`` (travelling wave), so with the peak particle
velocity ``v_m = V xi_m``::

    V_s = (16/25)^(1/5) c^(4/5) v_m^(1/5) = (16/25)^(1/5) a (k/m)^(2/5) v_m^(1/5)

about 0.9146 in scaled units (m = k = a = 1, v_m = 1). The wave spans
``5 pi a / sqrt 10 = 4.97 a``: "about five granules". (V. F. Nesterenko,
J. Appl. Mech. Tech. Phys. 24, 733 (1983); *Dynamics of Heterogeneous
Materials*, Springer 2001, Sec. 1.3; S. Sen et al., Phys. Rep. 462, 21 (2008),
eq. (12)-(14).) :func:`nesterenko_speed` returns it; tests report the ratio
to the measured speed, they do not force it.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Optional, Sequence

import numpy as np

from .result import Result, Status, run_model

__all__ = [
    "PulseFit", "peak_times", "pulse_speed", "pulse_position", "pulse_width",
    "pulse_widths_along", "fitted_width", "backscatter", "energy_ledger", "pulse_death_time",
    "penetration_depth", "nesterenko_speed", "nesterenko_width", "summarize",
    "frame_resolution", "FRAME_INTERVAL_WARN", "PEAK_SHORTFALL_WARN",
]

# Half-width of the cos^4 hump in units of a: the support is |x| <= 5 pi a / (2 sqrt 10).
NESTERENKO_WIDTH = 5.0 * math.pi / math.sqrt(10.0)  # 4.967 a


def nesterenko_speed(v_max: float, k: float = 1.0, m: float = 1.0, a: float = 1.0) -> float:
    """Nesterenko's long-wave solitary wave speed for a Hertz chain (length per time).

    Parameters
    ----------
    v_max : float
        Peak particle velocity in the wave (not the striker's speed).
    k : float
        Force coefficient, F = k delta^(3/2).
    m : float
        Granule mass.
    a : float
        Spacing of the centres (2R for touching equal spheres).

    Returns
    -------
    float
        ``(16/25)^(1/5) * a * (k/m)^(2/5) * v_max^(1/5)`` (see the module docstring).
    """
    c = a ** 1.25 * math.sqrt(k / m)
    return (16.0 / 25.0) ** 0.2 * c ** 0.8 * v_max ** 0.2


def nesterenko_width(a: float = 1.0) -> float:
    """Length of the support of Nesterenko's cos^4 solitary wave, 5 pi a / sqrt(10) = 4.97 a.

    Parameters
    ----------
    a : float
        Spacing of the centres (any length unit; the result is in the same unit).

    Returns
    -------
    float
        The support length.
    """
    return NESTERENKO_WIDTH * a


def _masses(result: Result, model_or_scene, count: int) -> np.ndarray:
    """Masses from a Model or an array; for a Scene, those of the run
    (``result.model``); unit masses when None."""
    if model_or_scene is None:
        return np.ones(count)
    if isinstance(model_or_scene, np.ndarray):
        return model_or_scene
    mass = getattr(model_or_scene, "mass", None)
    if isinstance(mass, np.ndarray):
        return mass
    return _run_model(result, model_or_scene).mass


def _run_model(result: Result, scene):
    """The Model the run used (attached by simulate and read_run; for a Result put
    together by hand, built from ``scene`` by :func:`~.result.run_model`)."""
    return run_model(result, scene)


def _reference_chain(result: Result, model_or_scene) -> Optional[dict]:
    """k, m, a of contact 0 and granule 0 for Nesterenko's formula (Hertz contacts only)."""
    if model_or_scene is None:
        return None
    model = model_or_scene
    if not hasattr(model, "k"):  # a Scene: the run's own constants
        model = _run_model(result, model_or_scene)
    if model.count < 2 or float(model.n[0]) != 2.5:
        return None
    return {"k": float(model.k[0]), "m": float(model.mass[0]),
            "a": float(model.x0[1] - model.x0[0])}


def _parabola_peak(y0, y1, y2):
    """Offset (in samples, within [-1, 1]) and height of the parabola through 3 samples."""
    den = y0 - 2.0 * y1 + y2
    if den >= 0.0:  # not a strict maximum: keep the sample
        return 0.0, y1
    s = 0.5 * (y0 - y2) / den
    s = min(max(s, -1.0), 1.0)
    return s, y1 - 0.25 * (y0 - y2) * s


def peak_times(result: Result, granules: Optional[Sequence[int]] = None):
    """Time at which each granule reaches its largest (forward) velocity, and that velocity.

    Needs frames at a fine cadence (``output.every`` of a few steps): the peak
    is the largest frame, refined by a parabola through it and its two
    neighbouring frames (uniform frame spacing assumed, as Verlet output is).

    Parameters
    ----------
    result : Result
        With ``v`` of shape (F, N).
    granules : sequence of int, optional
        Which granules (default all).

    Returns
    -------
    t_peak, v_peak : ndarray, shape (len(granules),)
        Peak time and peak velocity; ``nan`` for a granule that never moved
        forward, or whose largest velocity is at the first or last frame
        (a peak the run did not resolve).
    """
    v = np.asarray(result.v)
    t = np.asarray(result.t)
    idx = np.arange(v.shape[1]) if granules is None else np.asarray(granules, dtype=int)
    tp = np.full(idx.size, np.nan)
    vp = np.full(idx.size, np.nan)
    for out, i in enumerate(idx):
        col = v[:, i]
        j = int(np.argmax(col))
        if col[j] <= 0.0 or j == 0 or j == col.size - 1:
            continue
        s, h = _parabola_peak(col[j - 1], col[j], col[j + 1])
        step = (t[j + 1] - t[j - 1]) / 2.0
        tp[out] = t[j] + s * step
        vp[out] = h
    return tp, vp


@dataclass(frozen=True)
class PulseFit:
    """The leading pulse fitted over a range of granules.

    Attributes
    ----------
    speed : float
        Granules per unit time: slope of granule index against peak time.
    speed_length : float
        Length per unit time: slope of initial centre position against peak time.
    v_peak : float
        Mean peak velocity over the fitted granules.
    v_peak_spread : float
        (max - min) / mean of the peak velocities over the fitted granules: near 0
        for a steady solitary wave.
    first, last : int
        Granule range fitted (inclusive).
    residual : float
        RMS of the index-vs-time fit residual, in granules.
    """

    speed: float
    speed_length: float
    v_peak: float
    v_peak_spread: float
    first: int
    last: int
    residual: float

    def as_dict(self) -> dict:
        """The fields as a dict (JSON-ready).

        Returns
        -------
        dict
            Field name -> value.
        """
        return asdict(self)


def pulse_speed(result: Result, first: Optional[int] = None, last: Optional[int] = None) -> PulseFit:
    """Speed of the leading pulse from a straight-line fit of index (and position) vs peak time.

    Needs frames at a fine cadence (see :func:`peak_times`). The default range
    skips the first 10 granules (the pulse is still forming behind the striker)
    and the last 5 (the free end reflects it): granules ``[10, N-6]``, shrunk for
    short chains.

    Parameters
    ----------
    result : Result
        A finished run (frames of positions and velocities, its energy ledger).
    first, last : int, optional
        Inclusive range of granules used in the fit.

    Returns
    -------
    PulseFit
    """
    N = result.v.shape[1]
    if first is None:
        first = min(10, max(N // 4, 1))
    if last is None:
        last = max(N - 6, first + 2)
    last = min(last, N - 1)
    idx = np.arange(first, last + 1)
    tp, vp = peak_times(result, idx)
    ok = np.isfinite(tp)
    if ok.sum() < 3:
        raise ValueError(f"pulse_speed: fewer than 3 granules in {first}..{last} reached a "
                         f"resolved forward peak; run longer or fit fewer granules")
    idx, tp, vp = idx[ok], tp[ok], vp[ok]
    slope, icpt = np.polyfit(tp, idx, 1)
    x0 = np.asarray(result.x[0])[idx]
    slope_x = np.polyfit(tp, x0, 1)[0]
    res = float(np.sqrt(np.mean((idx - (slope * tp + icpt)) ** 2)))
    vmean = float(np.mean(vp))
    return PulseFit(speed=float(slope), speed_length=float(slope_x), v_peak=vmean,
                    v_peak_spread=float((vp.max() - vp.min()) / vmean), first=int(idx[0]),
                    last=int(idx[-1]), residual=res)


def pulse_position(result: Result):
    """Leading pulse at each frame: position (fractional granule index) and peak velocity.

    The position is the granule of largest forward velocity, refined by a
    parabola through it and its neighbours in index.

    Parameters
    ----------
    result : Result
        A finished run (frames of positions and velocities, its energy ledger).

    Returns
    -------
    position, v_peak : ndarray, shape (F,)
        ``nan`` where no granule moves forward.
    """
    v = np.asarray(result.v)
    F, N = v.shape
    pos = np.full(F, np.nan)
    peak = np.full(F, np.nan)
    for f in range(F):
        row = v[f]
        j = int(np.argmax(row))
        if row[j] <= 0.0:
            continue
        if 0 < j < N - 1:
            s, h = _parabola_peak(row[j - 1], row[j], row[j + 1])
        else:
            s, h = 0.0, row[j]
        pos[f] = j + s
        peak[f] = h
    return pos, peak


#: diagnose warns when the frame interval exceeds this fraction of the pulse's
#: duration at a granule (:func:`frame_resolution`; struck Hertz chain, fraction
#: 0.28, 0.57, 1.1, 2.8: peak 0.3 %, 3.6 %, 20 %, 60 % low) ...
FRAME_INTERVAL_WARN = 1.0 / 3.0
#: ... or when the peak read from the frames falls short of the snapshots' by more
#: than this fraction (the snapshots' own scatter, a pulse decaying along a damped
#: chain, is a few per cent).
PEAK_SHORTFALL_WARN = 0.05


def frame_resolution(result: Result, fit: PulseFit) -> dict:
    """Whether the frames resolve the pulse in time, and how far the peak velocity
    read from them falls short of the pulse's own.

    :func:`peak_times` reads each granule's peak from its velocity at the frames
    only. Once the frame interval nears the time the pulse takes to pass one
    granule, most granules' peaks fall between frames and their mean
    (``fit.v_peak``) is low: frames 5 time units apart give 0.27 for the 0.68 of
    the struck Hertz chain (scenarios/chain_striker.yaml). A single frame,
    read across the granules (:func:`pulse_position`), samples the pulse in
    space at one granule's spacing instead, which the frame interval does not
    coarsen: the largest such snapshot peak over the frames whose pulse lies in
    the fitted granules is the reference. The pulse's duration at a granule is
    its half-maximum width in that snapshot (granules) over its speed (granules
    per unit time).

    Parameters
    ----------
    result : Result
        A finished run with frames ``t`` (F,) and ``v`` (F, N).
    fit : PulseFit
        The pulse fitted over ``fit.first``..``fit.last`` (:func:`pulse_speed`).

    Returns
    -------
    dict
        ``frame_interval`` (median spacing of the frames, time), ``pulse_duration``
        (time the pulse stays above half its peak at one granule, time),
        ``v_peak_frames`` (= ``fit.v_peak``), ``v_peak_snapshots`` (velocity),
        ``shortfall`` = 1 - v_peak_frames / v_peak_snapshots (dimensionless;
        None without a snapshot in range) and ``warning`` ('' unless the frame
        interval exceeds :data:`FRAME_INTERVAL_WARN` of the duration or the
        shortfall exceeds :data:`PEAK_SHORTFALL_WARN`).
    """
    t = np.asarray(result.t)
    interval = float(np.median(np.diff(t))) if t.size > 1 else math.nan
    pos, peak = pulse_position(result)
    inside = np.flatnonzero((pos >= fit.first) & (pos <= fit.last))
    out = {"frame_interval": interval, "pulse_duration": None, "v_peak_frames": fit.v_peak,
           "v_peak_snapshots": None, "shortfall": None, "warning": ""}
    if inside.size == 0:
        return out
    best = int(inside[np.argmax(peak[inside])])
    width = pulse_width(result, best, 0.5)["interpolated"]  # granules, at half maximum
    duration = width / fit.speed if fit.speed > 0.0 else math.nan
    granule, sampled, local = _local_snapshot_peaks(result, fit, pos[inside], peak[inside],
                                                    fit.speed * interval)
    if granule.size == 0:
        return out
    reference = float(np.mean(local))
    shortfall = 1.0 - float(np.mean(sampled)) / reference
    out.update(pulse_duration=duration, v_peak_snapshots=reference, shortfall=shortfall)
    if shortfall > PEAK_SHORTFALL_WARN or interval > FRAME_INTERVAL_WARN * duration:
        out["warning"] = _coarse_frames_warning(out)
    return out


def _coarse_frames_warning(frames: dict) -> str:
    """The sentence :func:`frame_resolution` warns with (its numbers in ``frames``)."""
    interval, duration = frames["frame_interval"], frames["pulse_duration"]
    sampled, reference = frames["v_peak_frames"], frames["v_peak_snapshots"]
    head = (f"frames {interval:.3g} time units apart are too coarse for the pulse, which "
            f"passes a granule in about {duration:.3g} (above half its peak): ")
    tail = f"; peak times, speeds and peaks need output.dt <= {duration / 10:.2g}"
    if frames["shortfall"] > PEAK_SHORTFALL_WARN:
        return head + (f"the peak velocity read from the frames, {sampled:.3g}, is about "
                       f"{100 * frames['shortfall']:.0f}% below the pulse's own, about "
                       f"{reference:.3g} in snapshots across the granules") + tail
    return head + (f"the peak velocity read from the frames, {sampled:.3g}, may be a few "
                   f"per cent low (snapshots across the granules give {reference:.3g}, "
                   f"within their own scatter)") + tail


def _local_snapshot_peaks(result: Result, fit: PulseFit, pos: np.ndarray, peak: np.ndarray,
                          travel: float):
    """Each fitted granule's peak from its frames, beside the largest snapshot peak
    with the pulse within ``max(1, travel)`` granules of it (a pulse that decays
    along the chain is compared with itself nearby, not with its start).

    Parameters
    ----------
    result : Result
        The run (frames ``t``, ``v``).
    fit : PulseFit
        The fitted granule range.
    pos, peak : ndarray, shape (K,)
        Pulse position (granules) and snapshot peak (velocity) at K frames.
    travel : float
        Granules the pulse travels between two frames.

    Returns
    -------
    granule, sampled, local : ndarray, shape (G,)
        Granules with both a resolved peak and a snapshot nearby; their peak from the
        frames and the local snapshot peak (velocity).
    """
    order = np.argsort(pos)
    pos, peak = pos[order], peak[order]
    reach = max(1.0, travel)
    granule = np.arange(fit.first, fit.last + 1)
    _, sampled = peak_times(result, granule)
    lo = np.searchsorted(pos, granule - reach, side="left")
    hi = np.searchsorted(pos, granule + reach, side="right")
    keep = np.isfinite(sampled) & (hi > lo)
    local = np.array([peak[a:b].max() for a, b in zip(lo[keep], hi[keep])])
    return granule[keep], sampled[keep], local


def pulse_width(result: Result, frame: int, fraction: float = 0.5) -> dict:
    """Width of the pulse at one frame.

    Parameters
    ----------
    result : Result
        A finished run (frames of positions and velocities, its energy ledger).
    frame : int
        Frame index (negative counts from the end).
    fraction : float
        Threshold as a fraction of the frame's peak forward velocity.

    Returns
    -------
    dict
        ``count``: number of granules with ``v > fraction * v_peak`` (the discrete
        definition); ``interpolated``: the width of the contiguous run around the
        peak where v exceeds the threshold, with its two edges located by linear
        interpolation between granules (a continuous number of granules, the
        full width at ``fraction`` of the maximum); ``peak_index`` and ``v_peak``.
    """
    row = np.asarray(result.v[frame])
    j = int(np.argmax(row))
    vmax = float(row[j])
    if vmax <= 0.0:
        return {"count": 0, "interpolated": 0.0, "peak_index": j, "v_peak": vmax}
    thr = fraction * vmax
    count = int(np.sum(row > thr))
    lo = j
    while lo > 0 and row[lo - 1] > thr:
        lo -= 1
    hi = j
    while hi < row.size - 1 and row[hi + 1] > thr:
        hi += 1
    left = lo - ((row[lo] - thr) / (row[lo] - row[lo - 1]) if lo > 0 else 0.0)
    right = hi + ((row[hi] - thr) / (row[hi] - row[hi + 1]) if hi < row.size - 1 else 0.0)
    return {"count": count, "interpolated": float(right - left), "peak_index": j, "v_peak": vmax}


def fitted_width(result: Result, frame: int) -> dict:
    """Support length of a cos^4 hump fitted to the velocity profile at one frame.

    Fits ``v_i = v_m cos^4(pi (i - c) / L)`` for ``|i - c| < L/2`` (zero outside),
    Nesterenko's profile shape, by least squares over the granules around the
    peak; ``L`` (in granules) is comparable with Nesterenko's 5 pi / sqrt(10) = 4.97.

    Parameters
    ----------
    result : Result
        A finished run (frames of positions and velocities, its energy ledger).
    frame : int
        Frame index (negative counts from the end).

    Returns
    -------
    dict
        ``length`` L, ``centre`` c, ``v_max`` v_m, ``rms`` residual over v_m.
    """
    from scipy.optimize import least_squares
    row = np.asarray(result.v[frame], dtype=float)
    j = int(np.argmax(row))
    lo, hi = max(j - 8, 0), min(j + 9, row.size)
    i = np.arange(lo, hi, dtype=float)
    y = row[lo:hi]

    def model(p):
        vm, c, L = p
        z = np.pi * (i - c) / L
        return np.where(np.abs(z) < np.pi / 2, vm * np.cos(z) ** 4, 0.0)

    guess = pulse_width(result, frame, 0.5)["interpolated"] / 0.3641  # FWHM of cos^4 = 0.364 L
    sol = least_squares(lambda p: model(p) - y, [row[j], float(j), max(guess, 1.0)],
                        bounds=([0, lo, 0.5], [np.inf, hi, 50.0]))
    vm, c, L = sol.x
    return {"length": float(L), "centre": float(c), "v_max": float(vm),
            "rms": float(np.sqrt(np.mean(sol.fun ** 2)) / max(vm, 1e-300))}


def pulse_widths_along(result: Result, granules: Sequence[int], fraction: float = 0.5):
    """Pulse width when the peak sits at each given granule (for spreading vs distance).

    For each granule i, the frame closest to its peak time (:func:`peak_times`)
    is used. Needs frames at a fine cadence.

    Parameters
    ----------
    result : Result
        A finished run (frames of positions and velocities, its energy ledger).
    granules : sequence of int
        Granule indices where the peak is looked at.
    fraction : float
        Threshold as a fraction of the peak forward velocity, dimensionless.

    Returns
    -------
    ndarray, shape (len(granules),)
        Interpolated widths (see :func:`pulse_width`), ``nan`` if unresolved.
    """
    tp, _ = peak_times(result, granules)
    t = np.asarray(result.t)
    out = np.full(len(granules), np.nan)
    for k, tk in enumerate(tp):
        if np.isfinite(tk):
            out[k] = pulse_width(result, int(np.argmin(np.abs(t - tk))), fraction)["interpolated"]
    return out


def backscatter(result: Result, model_or_scene=None, first: Optional[int] = None) -> dict:
    """Backscattered velocity and energy of the first granules.

    Parameters
    ----------
    result : Result
        A finished run (frames of positions and velocities, its energy ledger).
    model_or_scene : Model, Scene or ndarray, optional
        Source of the masses (unit masses if None).
    first : int, optional
        Only granules ``0 .. first-1`` (default all).

    Returns
    -------
    dict
        ``velocity``: the most negative final velocity among them (0 if none moves back);
        ``energy``: sum of m v^2 / 2 over those moving backward at the end (``v_final < 0``);
        ``count``: how many move backward at the end;
        ``energy_max``: the largest value over the frames of that same sum (with
        friction every granule eventually stops, so the final value can be zero
        although the pulse did throw granules back; this needs fine frames);
        ``t_energy_max``: its time; ``velocity_min``: the most negative velocity
        any of them reached at a frame; ``fraction``, ``fraction_max``: energies
        over the initial energy.
    """
    N = result.v.shape[1]
    k = N if first is None else min(first, N)
    m = _masses(result, model_or_scene, N)[:k]
    vf = np.asarray(result.v_final)[:k]
    back = vf < 0
    e_final = float(0.5 * np.sum(m[back] * vf[back] ** 2))
    v = np.asarray(result.v)[:, :k]
    eb = 0.5 * np.sum(m * np.minimum(v, 0.0) ** 2, axis=1)
    j = int(np.argmax(eb))
    e0 = result.energy.initial or 1.0
    return {
        "velocity": float(min(vf.min(), 0.0)) if k else 0.0,
        "energy": e_final,
        "count": int(back.sum()),
        "energy_max": float(eb[j]),
        "t_energy_max": float(result.t[j]),
        "velocity_min": float(min(v.min(), 0.0)) if k else 0.0,
        "fraction": e_final / e0,
        "fraction_max": float(eb[j]) / e0,
    }


def energy_ledger(result: Result) -> dict:
    """Energy ledger over time: arrays of shape (F,) keyed by name.

    ``t``, ``kinetic``, ``potential``, ``coulomb`` and ``viscous`` (dissipated so
    far), ``mechanical`` (kinetic + potential) and ``balance`` (sum of all four
    minus the initial energy: the integrator's error, zero for an exact ledger).

    Parameters
    ----------
    result : Result
        A finished run (frames of positions and velocities, its energy ledger).

    Returns
    -------
    dict of ndarray, shape (F,)
        As above; energies in the run's units (scene units: scaled or joules).
    """
    e = result.energy
    return {
        "t": np.asarray(result.t), "kinetic": e.kinetic, "potential": e.potential,
        "coulomb": e.coulomb, "viscous": e.viscous,
        "mechanical": e.kinetic + e.potential, "balance": e.balance,
    }


def pulse_death_time(result: Result, threshold: float = 1e-3) -> float:
    """Time at which the mechanical energy first falls below ``threshold`` times the initial.

    Under Coulomb friction the pulse dies in finite time (a run with ``stop:
    rest`` ends exactly then: ``result.t_final`` with status AT_REST, returned
    directly when the threshold is never crossed earlier). Returns ``inf`` if
    the run ended with more energy left.

    Parameters
    ----------
    result : Result
        A finished run (frames of positions and velocities, its energy ledger).
    threshold : float
        Fraction of the initial energy, dimensionless.

    Returns
    -------
    float
        Time in the run's units, or ``inf``.
    """
    e = result.energy
    mech = e.kinetic + e.potential
    below = np.flatnonzero(mech <= threshold * e.initial)
    if below.size:
        return float(result.t[below[0]])
    if result.status == Status.AT_REST:
        return float(result.t_final)
    return math.inf


def penetration_depth(result: Result, tol: float = 0.0) -> int:
    """Number of granules that ever moved (|v| > tol at some frame, or a final displacement).

    For a pulse dying under friction: how far into the chain it got.

    Parameters
    ----------
    result : Result
        A finished run (frames of positions and velocities, its energy ledger).
    tol : float
        Speed a granule must exceed to count as moving, in the run's velocity units.

    Returns
    -------
    int
        Granules from the first to the last that moved (0 if none).
    """
    v = np.abs(np.asarray(result.v))
    moved = np.any(v > tol, axis=0) | (np.asarray(result.x[-1]) != np.asarray(result.x[0]))
    nz = np.flatnonzero(moved)
    return int(nz[-1] + 1) if nz.size else 0


def summarize(result: Result, model_or_scene=None, *, first: int = 3,
              pulse: bool = True) -> dict:
    """Scalar diagnostics of one run (JSON-ready): what ``granular-chain diagnose`` prints.

    Pulse speed and width are included when ``pulse`` is true and the run has
    enough frames to resolve them; otherwise they are left out with a reason.

    Parameters
    ----------
    result : Result
        A finished run (frames of positions and velocities, its energy ledger).
    model_or_scene : Model, Scene or ndarray, optional
        Source of the masses (unit masses if None).
    first : int
        How many leading granules count for ``backscatter`` (the rest in ``backscatter_all``).
    pulse : bool
        Fit the pulse speed and width (needs frames at a fine cadence).

    Returns
    -------
    dict
        Status, energies, backscatter, pulse fit (or why not) with how well the
        frames resolve it (``pulse.frames``, :func:`frame_resolution`), death
        time, penetration depth, and ``warnings`` (a list of sentences: frames too
        coarse for the pulse's peak); in the run's units.
    """
    N = result.v.shape[1]
    e = result.energy
    out = {
        "status": result.status.name.lower(), "t_final": float(result.t_final),
        "granules": int(N), "frames": int(result.t.size),
        "energy": {"initial": float(e.initial), "kinetic": float(e.kinetic[-1]),
                   "potential": float(e.potential[-1]), "coulomb": float(e.coulomb[-1]),
                   "viscous": float(e.viscous[-1]),
                   "max_balance_error_relative": e.balance_error},
        "backscatter": backscatter(result, model_or_scene, first=min(first, N)),
        "backscatter_all": backscatter(result, model_or_scene),
        "pulse_death_time": pulse_death_time(result),
        "penetration_depth": penetration_depth(result),
        "warnings": [],  # what the frames cannot tell (frame_resolution)
    }
    if pulse and N >= 8:
        try:
            fit = pulse_speed(result)
            out["pulse"] = fit.as_dict()
            frames = frame_resolution(result, fit)
            warning = frames.pop("warning")
            out["pulse"]["frames"] = frames
            if warning:
                out["warnings"].append(warning)
            mid = (fit.first + fit.last) // 2
            w = pulse_widths_along(result, [mid])[0]
            out["pulse"]["width_half_max"] = float(w)
            tp, _ = peak_times(result, [mid])
            if np.isfinite(tp[0]):
                fr = int(np.argmin(np.abs(result.t - tp[0])))
                out["pulse"]["width_count_1pct"] = pulse_width(result, fr, 0.01)["count"]
                out["pulse"]["width_cos4_fit"] = fitted_width(result, fr)["length"]
                ref = _reference_chain(result, model_or_scene)
                if ref is not None:
                    vs = nesterenko_speed(fit.v_peak, **ref)
                    out["pulse"]["nesterenko_speed"] = vs
                    out["pulse"]["speed_over_nesterenko"] = fit.speed_length / vs
        except ValueError as exc:
            out["pulse"] = {"unresolved": str(exc)}
    if not math.isfinite(out["pulse_death_time"]):
        out["pulse_death_time"] = None
    return out
