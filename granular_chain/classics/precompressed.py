"""Experiment ``precompressed``: sound, dispersion and the solitary-wave crossover of a
precompressed Hertz chain.

Scene ``scenarios/classics/precompressed.yaml``: equal Hertz spheres (n = 5/2, scaled
units m = k = 1) between two walls, every contact (the wall contacts included) at the
overlap ``delta0``, so the static force ``delta0^(3/2)`` balances everywhere. Linearised
about ``delta0`` the chain is a lattice of springs of stiffness (exact)::

    K = (n - 1) k delta0^(n-2) = 1.5 delta0^(1/2)                                (1)
    c0 = sqrt(K / m)        (sound speed, granules per unit time)                 (2)
    omega(q) = 2 sqrt(K / m) |sin(q / 2)|,   v_g(q) = sqrt(K / m) cos(q / 2)      (3)

(q per granule; Nesterenko, Dynamics of Heterogeneous Materials (Springer 2001),
ch. 1; Sen, Hong, Bang, Avalos & Doney, Phys. Rep. 462, 21 (2008)). Between the
walls the lattice's normal modes are ``sin(q (i + 1))``, ``q = pi j / (N + 1)``, exactly.

Three measurements:

1. The dispersion relation. 31 granules at ``delta0 = 0.01`` are started in normal
   mode ``j`` with velocity amplitude ``eps c0 delta0`` (strain amplitude ``eps delta0``)
   and run for 8 periods; the mode's phase at the end (from the projections of the
   displacements and velocities on it) gives omega, against eq. (3). The error from
   the amplitude is the anharmonic frequency shift, of order ``eps^2``: it is measured
   by running at ``10 eps`` (its shift over 100), and the amplitude study shows the
   ``eps^2`` law. Both steppers; Verlet's error by halving dt.
   The group velocity: a right-moving Gaussian packet (300 granules, width 20, carrier
   q) run while it travels 120 granules; the speed of the centroid of
   ``(omega u)^2 + v^2`` against that of the linearised lattice from the same start
   (:func:`linear_lattice`, exact), and against ``v_g(q)`` of eq. (3), from which a
   packet of finite width differs by its spread in q.
2. The sound speed: ``omega / (2 sin(q/2))`` of the longest mode (j = 1), against
   eq. (2), for ``delta0 = 1e-4 .. 1e-1``.
3. The crossover: granule 0 struck at ``v0 = 1e-4`` (100 granules); the pulse speed
   from per-granule peak times over granules 20..70
   (:func:`granular_chain.diagnostics.pulse_speed`) as ``delta0`` drops from 0.1 to 0,
   against the ratio ``rho = v_max / (c0 delta0)`` of the pulse's peak velocity to
   the precompression's velocity scale. References: the linearised lattice's own
   pulse (eq. (3)'s lattice solved exactly by its normal modes, the same peak fit:
   the ``rho -> 0`` limit), the exact discrete solitary wave ``C v_max^(1/5)``
   (:mod:`.hertz_wave`, ``rho = inf``), and between them the speed of the long-wave
   solitary wave of Nesterenko's continuum equation on a precompressed chain
   (:func:`long_wave_speed`, an approximation).
"""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from .. import diagnostics as dg
from ..scene import read_scene_data, scene_from_dict
from ..simulate import simulate
from .experiment import Experiment, Outcome, figure_file
from .hertz_wave import NESTERENKO_CONSTANT, solve_travelling_wave
from .table import Row

__all__ = ["EXPERIMENT", "SCENE", "stiffness", "sound_speed", "frequency", "group_velocity",
           "velocity_scale", "long_wave_speed", "mode_frequency", "linear_lattice", "linear_pulse",
           "packet_speed", "PACKET_QS",
           "struck_pulse", "compute", "figure", "MODE_COUNT", "MODE_DELTA0", "MODES",
           "AMPLITUDE", "AMPLITUDES", "SOUND_DELTA0S", "CROSS_DELTA0S", "VERLET_DELTA0S",
           "VERLET_FRACTION", "FIRST", "LAST", "LINEAR_BELOW", "SOLITARY_ABOVE"]

SCENE = "precompressed.yaml"
#: Granules of the normal-mode runs, their overlap, the modes j (q = pi j / 32).
MODE_COUNT, MODE_DELTA0, MODES = 31, 1e-2, (1, 4, 8, 16, 24, 31)
#: Strain amplitude over delta0 of the mode runs, and of the amplitude study (mode 1).
AMPLITUDE, AMPLITUDES = 1e-4, (1e-2, 1e-3, 1e-4)
#: Overlaps of the sound-speed measurement.
SOUND_DELTA0S = (1e-4, 1e-3, 1e-2, 1e-1)
#: Overlaps of the crossover (the struck chain), and those also run with Verlet.
CROSS_DELTA0S = (1e-1, 3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 0.0)
VERLET_DELTA0S = (1e-1, 1e-4)
#: Verlet's step in units of the fastest time scale 1/sqrt(K) (mode runs) or of the
#: frame interval (struck runs: two steps per frame); its error is measured at half.
VERLET_FRACTION = 0.05
#: Granules of the pulse-speed fit; frames per granule of travel.
FIRST, LAST, FRAMES_PER_GRANULE = 20, 70, 50
PERIODS = 8
#: Wave packets: carriers q, granules, start and width (granules), travel (granules).
PACKET_QS = (math.pi / 4, math.pi / 2, 3 * math.pi / 4)
PACKET_COUNT, PACKET_START, PACKET_WIDTH, PACKET_TRAVEL = 300, 80.0, 20.0, 120.0
#: The crossover's table compares with the linearised lattice's pulse below this
#: rho = v_max / (c0 delta0) (above it the lattice's pulse is slower than the
#: engine's by more than 7 %), with the long-wave solitary wave above the second
#: (below it the struck pulse has formed no solitary wave by granule 70).
LINEAR_BELOW, SOLITARY_ABOVE = 1.0, 0.1
LATTICE = "linearised lattice, eq. (3) (exact)"
LINEAR_PACKET = "linearised lattice's packet, normal modes (exact)"
LINEAR_PULSE = "linearised lattice struck, normal modes (exact), same fit"
LONG_WAVE = "long-wave solitary wave (Nesterenko's equation; approximate)"
SOLITARY = "exact discrete wave C v_max^(1/5) (Petviashvili, computed)"


def stiffness(delta0: float, k: float = 1.0, n: float = 2.5) -> float:
    """Eq. (1): the contact stiffness ``(n - 1) k delta0^(n-2)`` of the linearised chain.

    Parameters
    ----------
    delta0 : float
        Static overlap per contact (length).
    k, n : float
        Force coefficient and exponent of the contact (force ``k delta^(n-1)``).

    Returns
    -------
    float
        K (force / length).
    """
    return (n - 1.0) * k * delta0 ** (n - 2.0)


def sound_speed(delta0: float) -> float:
    """Eq. (2): ``c0 = sqrt(K)`` (granules per unit time, m = k = 1, n = 5/2).

    Parameters
    ----------
    delta0 : float
        Static overlap per contact.

    Returns
    -------
    float
    """
    return math.sqrt(stiffness(delta0))


def frequency(q, delta0: float):
    """Eq. (3): ``omega(q) = 2 sqrt(K) |sin(q/2)|`` (per unit time).

    Parameters
    ----------
    q : float or ndarray
        Wavenumber, radians per granule.
    delta0 : float
        Static overlap per contact.

    Returns
    -------
    float or ndarray
    """
    return 2.0 * sound_speed(delta0) * np.abs(np.sin(np.asarray(q) / 2.0))


def group_velocity(q, delta0: float):
    """Eq. (3): ``v_g(q) = sqrt(K) cos(q/2)`` (granules per unit time, 0 <= q <= pi).

    Parameters
    ----------
    q : float or ndarray
        Wavenumber, radians per granule.
    delta0 : float
        Static overlap per contact.

    Returns
    -------
    float or ndarray
    """
    return sound_speed(delta0) * np.cos(np.asarray(q) / 2.0)


def velocity_scale(delta0: float) -> float:
    """The precompression's velocity scale ``c0 delta0``: the particle velocity of a
    linear wave whose strain is ``delta0``.

    Parameters
    ----------
    delta0 : float
        Static overlap per contact.

    Returns
    -------
    float
    """
    return sound_speed(delta0) * delta0


def long_wave_speed(rho: float) -> float:
    """Speed over c0 of the long-wave solitary wave on a precompressed chain whose peak
    particle velocity is ``rho c0 delta0``.

    Nesterenko's long-wave equation (m = k = a = 1), strain ``xi``:
    ``V^2 (xi - xi0) = xi^(3/2) - xi0^(3/2) + (1/10) xi^(1/4) (xi^(5/4))''``; its first
    integral between ``xi0`` and the peak ``xi_m = xi_r xi0`` gives::

        V / c0 = sqrt((4/15) (3 + 2 xi_r^(5/2) - 5 xi_r)) / (xi_r - 1)             (4)

    and the particle velocity ``v = V (xi - xi0)``, so ``rho = (V/c0)(xi_r - 1)``.
    It tends to 1 as ``rho -> 0`` and to ``(16/25)^(1/5) v_max^(1/5)`` as ``delta0 -> 0``.

    Parameters
    ----------
    rho : float
        ``v_max / (c0 delta0)``, > 0.

    Returns
    -------
    float
        ``V / c0``.
    """
    from scipy.optimize import brentq
    def excess(e):  # rho^2 - (4/15)(3 + 2 (1+e)^(5/2) - 5 (1+e)), written without cancellation
        return (4.0 / 15.0) * (2.0 * math.expm1(2.5 * math.log1p(e)) - 5.0 * e) - rho * rho

    e = brentq(excess, 0.0, 1.0 + 4.0 * rho ** 0.8, xtol=1e-300, rtol=1e-15)
    return rho / e


def _data(folder: Path, delta0: float, count: int, velocity, run: dict, output: dict) -> dict:
    """The scene's data with ``count`` granules at overlap ``delta0`` (walls too)."""
    data = read_scene_data(Path(folder) / SCENE)
    data["granules"].update(count=count, gap=-float(delta0), velocity=velocity)
    for side in ("left", "right"):
        data["walls"][side]["gap"] = -float(delta0)
    data["run"], data["output"] = run, output
    return data


def _run(data: dict, label: str):
    """Simulate the scene ``data``; refuse a run that did not succeed (a ledger that
    missed its tolerance makes the run inaccurate, not successful)."""
    result = simulate(scene_from_dict(data, source=f"{SCENE} ({label})"), progress=False)
    if not result.status.success:
        raise RuntimeError(f"precompressed: {label}: {result.message}")
    return result


def mode_frequency(folder: Path, delta0: float, j: int, amplitude: float, stepper: str,
                   count: int = MODE_COUNT, fraction: float = VERLET_FRACTION) -> dict:
    """Run the chain started in normal mode ``j`` and measure its angular frequency.

    Granule ``i`` starts at ``v_i = eps c0 delta0 sin(q (i + 1))``, ``q = pi j/(N + 1)``,
    displacements zero. After :data:`PERIODS` periods (of eq. (3)) the mode's
    coordinates ``a_u``, ``a_v`` (projections of displacement and velocity) give its
    phase ``theta = atan2(omega a_u, a_v)``, unwrapped near ``omega_ref t``, and
    ``omega = theta / t`` (iterated: omega enters ``theta`` only through the ratio of
    the two projections' amplitudes).

    Parameters
    ----------
    folder : Path
        The scenes' folder.
    delta0 : float
        Static overlap.
    j : int
        Mode number, 1..count.
    amplitude : float
        ``eps``: strain amplitude over delta0 (velocity amplitude over ``c0 delta0``).
    stepper : str
        ``event`` or ``verlet``.
    count : int
        Granules.
    fraction : float
        Verlet's dt in units of ``1/sqrt(K)``.

    Returns
    -------
    dict
        ``q`` (per granule), ``omega`` (measured, per unit time), ``reference``
        (eq. (3)), ``energy_error`` (the run's ledger).
    """
    q = math.pi * j / (count + 1)
    shape = np.sin(q * np.arange(1, count + 1))
    w_ref = float(frequency(q, delta0))
    t_end = PERIODS * 2.0 * math.pi / w_ref
    run = {"stepper": "event", "t_end": t_end}
    output = {"dt": t_end}  # the first and last frames only
    if stepper == "verlet":
        run = {"stepper": "verlet", "t_end": t_end, "dt": fraction / sound_speed(delta0)}
        output = {"every": 1_000_000}
    v0 = amplitude * velocity_scale(delta0) * shape
    result = _run(_data(folder, delta0, count, [float(v) for v in v0], run, output),
                  f"mode {j}, delta0={delta0:g}, {stepper}")
    x = np.asarray(result.x)
    t = float(result.t[-1])
    a_u = shape @ (result.x_final - x[0])
    a_v = shape @ result.v_final
    omega = w_ref
    for _ in range(3):
        theta = math.atan2(omega * a_u, a_v)
        theta += 2.0 * math.pi * round((w_ref * t - theta) / (2.0 * math.pi))
        omega = theta / t
    return {"q": q, "omega": omega, "reference": w_ref,
            "energy_error": float(result.energy.balance_error)}


def linear_lattice(delta0: float, u0: np.ndarray, v0: np.ndarray, t: np.ndarray) -> tuple:
    """Displacements and velocities of the linearised walled chain (eq. (1)) by its
    normal modes ``phi_j = sqrt(2/(N+1)) sin(q_j (i + 1))``: each mode's coordinate
    is ``a_j cos(omega_j t) + (b_j / omega_j) sin(omega_j t)``.

    Parameters
    ----------
    delta0 : float
        Static overlap (sets K).
    u0, v0 : ndarray, shape (N,)
        Initial displacements (from equilibrium) and velocities.
    t : ndarray, shape (F,)
        Times.

    Returns
    -------
    u, v : ndarray, shape (F, N)
        Displacements and velocities.
    """
    count = len(u0)
    q = math.pi * np.arange(1, count + 1) / (count + 1)
    phi = math.sqrt(2.0 / (count + 1)) * np.sin(np.outer(np.arange(1, count + 1), q))
    a, b, w = phi.T @ u0, phi.T @ v0, frequency(q, delta0)
    c, s = np.cos(np.outer(t, w)), np.sin(np.outer(t, w))
    return (a * c + b / w * s) @ phi.T, (b * c - a * w * s) @ phi.T


def linear_pulse(delta0: float, v0: float, count: int, t: np.ndarray) -> np.ndarray:
    """Velocities of the linearised walled chain after granule 0 starts at ``v0``
    (:func:`linear_lattice`).

    Parameters
    ----------
    delta0 : float
        Static overlap (sets K).
    v0 : float
        Granule 0's initial velocity.
    count : int
        Granules.
    t : ndarray, shape (F,)
        Times.

    Returns
    -------
    ndarray, shape (F, count)
        Velocities.
    """
    start = np.zeros(count)
    start[0] = v0
    return linear_lattice(delta0, np.zeros(count), start, np.asarray(t, float))[1]


def packet_speed(folder: Path, q: float, amplitude: float, stepper: str,
                 fraction: float = VERLET_FRACTION) -> dict:
    """A right-moving wave packet of carrier ``q`` and its group velocity.

    :data:`PACKET_COUNT` granules at :data:`MODE_DELTA0`, displaced by
    ``u_i = A g_i cos(q i)`` with velocities ``A omega g_i sin(q i)``, ``g`` a Gaussian
    of :data:`PACKET_WIDTH` granules centred on granule :data:`PACKET_START`, strain
    amplitude ``eps delta0``; run while it travels :data:`PACKET_TRAVEL` granules at
    ``v_g(q)``. The speed is the shift of the centroid of ``(omega u)^2 + v^2`` over
    the time; the reference is that of the linearised lattice from the same start.

    Parameters
    ----------
    folder : Path
        The scenes' folder.
    q : float
        Carrier wavenumber, radians per granule.
    amplitude : float
        ``eps``: strain amplitude over delta0.
    stepper : str
        ``event`` or ``verlet``.
    fraction : float
        Verlet's dt in units of ``1/sqrt(K)``.

    Returns
    -------
    dict
        ``q``, ``speed`` (engine, granules per unit time), ``linear`` (the linearised
        lattice's packet), ``group_velocity`` (eq. (3)), ``energy_error``.
    """
    delta0, count = MODE_DELTA0, PACKET_COUNT
    i = np.arange(count)
    w, vg = float(frequency(q, delta0)), float(group_velocity(q, delta0))
    envelope = amplitude * delta0 / (2.0 * math.sin(q / 2.0)) * np.exp(
        -0.5 * ((i - PACKET_START) / PACKET_WIDTH) ** 2)
    u0, v0 = envelope * np.cos(q * i), w * envelope * np.sin(q * i)
    t_end = PACKET_TRAVEL / vg
    run, output = {"stepper": "event", "t_end": t_end}, {"dt": t_end}
    if stepper == "verlet":
        run = {"stepper": "verlet", "t_end": t_end, "dt": fraction / sound_speed(delta0)}
        output = {"every": 1_000_000}
    data = _data(folder, delta0, count, [float(v) for v in v0], run, output)
    data["granules"]["gap"] = [float(g) for g in np.diff(u0) - delta0]
    data["walls"]["left"]["gap"] = float(u0[0] - delta0)
    data["walls"]["right"]["gap"] = float(-u0[-1] - delta0)
    result = _run(data, f"packet q={q:.4g}, {stepper}")
    t = float(result.t[-1])
    u_end = result.x_final - np.asarray(result.x)[0] + u0
    u_lin, v_lin = linear_lattice(delta0, u0, v0, np.array([t]))

    def centroid(u, v):
        density = (w * u) ** 2 + v ** 2
        return float(i @ density / density.sum())

    start = centroid(u0, v0)
    return {"q": q, "speed": (centroid(u_end, result.v_final) - start) / t,
            "linear": (centroid(u_lin[0], v_lin[0]) - start) / t, "group_velocity": vg,
            "energy_error": float(result.energy.balance_error)}


def struck_pulse(folder: Path, delta0: float, stepper: str, half: bool = False) -> dict:
    """The scene's struck chain at overlap ``delta0``: speed and peak velocity of its
    leading pulse over granules :data:`FIRST`..:data:`LAST`.

    Parameters
    ----------
    folder : Path
        The scenes' folder.
    delta0 : float
        Static overlap (0: touching chain, walls just touching).
    stepper : str
        ``event`` or ``verlet`` (two steps per frame, four when ``half``: the same
        frames, so the peak fits differ by the stepper's error alone).
    half : bool
        Verlet at half its step.

    Returns
    -------
    dict
        ``delta0``, ``speed`` (granules per unit time), ``v_max`` (mean peak velocity
        over the fit), ``rho`` (``v_max / (c0 delta0)``, inf at delta0 = 0), ``c0``,
        ``linear`` (the linearised lattice's pulse speed by the same fit; nan at 0),
        ``energy_error``.
    """
    base = read_scene_data(Path(folder) / SCENE)
    v0, count = float(base["granules"]["velocity"][0]), int(base["granules"]["count"])
    c0, wave = sound_speed(delta0), NESTERENKO_CONSTANT * (0.68 * v0) ** 0.2  # an estimate
    frame = 1.0 / (FRAMES_PER_GRANULE * max(c0, wave))
    # past the last fitted granule's peak, which lags the front by up to ~10 granules
    # near rho ~ 0.1, and before the wall's reflection comes back to it
    t_end = frame * FRAMES_PER_GRANULE * (LAST + 30)
    run, output = {"stepper": "event", "t_end": t_end}, {"dt": frame}
    if stepper == "verlet":
        per = 4 if half else 2
        run = {"stepper": "verlet", "t_end": t_end, "dt": frame / per}
        output = {"every": per}
    result = _run(_data(folder, delta0, count, {0: v0}, run, output),
                  f"struck, delta0={delta0:g}, {stepper}")
    fit = dg.pulse_speed(result, FIRST, LAST)
    peaks, _ = dg.peak_times(result, list(range(FIRST, LAST + 1)))
    if not np.all(np.diff(peaks) > 0.0):  # a granule's largest velocity is not its pulse's
        raise RuntimeError(f"precompressed: struck, delta0={delta0:g}, {stepper}: the peak "
                           f"times over granules {FIRST}..{LAST} do not increase")
    out = {"delta0": delta0, "speed": fit.speed, "v_max": fit.v_peak, "c0": c0,
           "rho": fit.v_peak / velocity_scale(delta0) if delta0 > 0 else math.inf,
           "linear": math.nan, "energy_error": float(result.energy.balance_error)}
    if delta0 > 0 and stepper == "event":
        t = np.asarray(result.t)
        lattice = SimpleNamespace(t=t, v=linear_pulse(delta0, v0, count, t), x=result.x)
        out["linear"] = dg.pulse_speed(lattice, FIRST, LAST).speed
    return out



def _modes(folder: Path) -> dict:
    """Every mode of :data:`MODES` at :data:`AMPLITUDE` (event, Verlet at dt and dt/2)
    and at ten times it (event: the anharmonic shift's size, over 100 at AMPLITUDE)."""
    out = {}
    for j in MODES:
        d = {"event": mode_frequency(folder, MODE_DELTA0, j, AMPLITUDE, "event"),
             "loud": mode_frequency(folder, MODE_DELTA0, j, 10 * AMPLITUDE, "event"),
             "verlet": mode_frequency(folder, MODE_DELTA0, j, AMPLITUDE, "verlet"),
             "verlet_half": mode_frequency(folder, MODE_DELTA0, j, AMPLITUDE, "verlet",
                                           fraction=VERLET_FRACTION / 2)}
        w = d["event"]["reference"]
        d["anharmonic_estimate"] = abs(d["loud"]["omega"] / w - 1.0) / 100.0
        d["verlet_error_estimate"] = 4.0 / 3.0 * abs(d["verlet"]["omega"]
                                                     - d["verlet_half"]["omega"]) / w
        out[str(j)] = d
    return out


def _packets(folder: Path) -> dict:
    """Every packet of :data:`PACKET_QS` at :data:`AMPLITUDE` (event) and at ten times it
    (the anharmonic change's size, over 100 at AMPLITUDE); Verlet (dt, dt/2) at pi/2."""
    out = {}
    for q in PACKET_QS:
        d = {"event": packet_speed(folder, q, AMPLITUDE, "event"),
             "loud": packet_speed(folder, q, 10 * AMPLITUDE, "event")}
        d["anharmonic_estimate"] = abs(d["loud"]["speed"] / d["loud"]["linear"] - 1.0) / 100.0
        if q == PACKET_QS[1]:
            d["verlet"] = packet_speed(folder, q, AMPLITUDE, "verlet")
            half = packet_speed(folder, q, AMPLITUDE, "verlet", VERLET_FRACTION / 2)
            d["verlet_error_estimate"] = 4.0 / 3.0 * abs(d["verlet"]["speed"] - half["speed"]) \
                / d["verlet"]["linear"]
        out[f"{q / math.pi:g}"] = d
    return out


def _sound(folder: Path) -> dict:
    """Sound speed ``omega_1 / (2 sin(q_1/2))`` from mode 1 at each overlap of
    :data:`SOUND_DELTA0S` (event stepper)."""
    out = {}
    for delta0 in SOUND_DELTA0S:
        m = mode_frequency(folder, delta0, 1, AMPLITUDE, "event")
        out[repr(delta0)] = {"c": m["omega"] / (2.0 * math.sin(m["q"] / 2.0)),
                             "c0": sound_speed(delta0), "energy_error": m["energy_error"]}
    return out


def _crossover(folder: Path) -> dict:
    """The struck chain at each overlap of :data:`CROSS_DELTA0S` (event), with the
    long-wave speed at its rho; Verlet (dt and dt/2) at :data:`VERLET_DELTA0S`."""
    event = []
    for delta0 in CROSS_DELTA0S:
        p = struck_pulse(folder, delta0, "event")
        p["long_wave"] = (p["c0"] * long_wave_speed(p["rho"]) if delta0 > 0 else math.nan)
        event.append(p)
    verlet = {}
    for delta0 in VERLET_DELTA0S:
        a = struck_pulse(folder, delta0, "verlet")
        b = struck_pulse(folder, delta0, "verlet", half=True)
        a["error_estimate"] = 4.0 / 3.0 * abs(a["speed"] - b["speed"]) / a["speed"]
        verlet[repr(delta0)] = a
    return {"event": event, "verlet": verlet}


def _pulse_rows(p: dict, what: str, references: dict) -> list:
    """The rows of one struck pulse ``p``: against the linearised lattice's pulse where
    rho < :data:`LINEAR_BELOW`, the long-wave solitary wave where rho >
    :data:`SOLITARY_ABOVE` (``references``: the event run's dict, holding both)."""
    rows = []
    if p["rho"] < LINEAR_BELOW:
        rows.append(Row(what, p["speed"], references["linear"], LINEAR_PULSE))
    if p["rho"] > SOLITARY_ABOVE:
        rows.append(Row(what, p["speed"], references["long_wave"], LONG_WAVE))
    return rows


def _rows(modes: dict, packets: dict, sound: dict, amplitude: dict, cross: dict,
          constant: float) -> list:
    """The table."""
    rows = []
    for j, d in modes.items():
        q = f"q=pi*{j}/{MODE_COUNT + 1}"
        rows.append(Row(f"omega({q}), delta0={MODE_DELTA0:g}, eps={AMPLITUDE:g}, event",
                        d["event"]["omega"], d["event"]["reference"], LATTICE))
        rows.append(Row(f"omega({q}), delta0={MODE_DELTA0:g}, Verlet dt={VERLET_FRACTION}/c0",
                        d["verlet"]["omega"], d["event"]["reference"], LATTICE))
    for key, d in packets.items():
        e, what = d["event"], f"group velocity (packet), q=pi*{key}, delta0={MODE_DELTA0:g}"
        rows.append(Row(f"{what}, eps={AMPLITUDE:g}, event", e["speed"], e["linear"],
                        LINEAR_PACKET))
        rows.append(Row(f"{what}, eps={AMPLITUDE:g}, event", e["speed"], e["group_velocity"],
                        "v_g = sqrt(K) cos(q/2), eq. (3): a packet of width 20 lags it"))
        if "verlet" in d:
            rows.append(Row(f"{what}, Verlet dt={VERLET_FRACTION}/c0", d["verlet"]["speed"],
                            e["linear"], LINEAR_PACKET))
    for delta0, d in sound.items():
        rows.append(Row(f"sound speed omega_1/(2 sin(q_1/2)), delta0={float(delta0):g}, event",
                        d["c"], d["c0"], "linearised lattice c0 = sqrt(1.5) delta0^(1/4) (exact)"))
    for eps, d in amplitude.items():
        rows.append(Row(f"omega(q=pi/{MODE_COUNT + 1}), delta0={MODE_DELTA0:g}, "
                        f"eps={float(eps):g}, event", d["omega"], d["reference"],
                        LATTICE + ": the anharmonic shift ~ eps^2"))
    event = {p["delta0"]: p for p in cross["event"]}
    for p in cross["event"]:
        what = f"pulse speed, delta0={p['delta0']:g}, v_max/(c0 delta0)={p['rho']:.4g}, event"
        if p["delta0"] == 0.0:
            rows.append(Row(what, p["speed"], constant * p["v_max"] ** 0.2, SOLITARY))
        else:
            rows += _pulse_rows(p, what, p)
    for delta0, p in cross["verlet"].items():
        e = event[float(delta0)]
        what = f"pulse speed, delta0={float(delta0):g}, Verlet dt=frame/2"
        rows += _pulse_rows(p, what, e)
        rows.append(Row(what, p["speed"], e["speed"], "event stepper, same scene and frames"))
    return rows


def compute(folder: Path) -> Outcome:
    """Run the experiment: the dispersion relation, the sound speed, the amplitude
    study, the crossover.

    Parameters
    ----------
    folder : Path
        The scenes' folder.

    Returns
    -------
    Outcome
        Its table and (``data``) every number behind it, with the error estimates
        (``anharmonic_estimate``, ``verlet_error_estimate`` per mode and packet;
        ``error_estimate`` of each Verlet pulse speed).
    """
    constant = solve_travelling_wave().speed_constant
    modes = _modes(folder)
    packets = _packets(folder)
    sound = _sound(folder)
    amplitude = {repr(eps): mode_frequency(folder, MODE_DELTA0, 1, eps, "event")
                 for eps in AMPLITUDES}
    cross = _crossover(folder)
    rows = _rows(modes, packets, sound, amplitude, cross, constant)
    data = {"modes": modes, "packets": packets, "sound": sound, "amplitude": amplitude, "crossover": cross,
            "wave_constant": constant, "mode_delta0": MODE_DELTA0, "mode_count": MODE_COUNT}
    return Outcome(rows=rows, data=_finite(data))


def _finite(value):
    """``value`` with every non-finite float as None (JSON has no inf or nan)."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_finite(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def figure(outcome: Outcome, path: Path) -> None:
    """Two panels: the measured omega(q) and group velocities on the lattice's curves, and the pulse
    speed over c0 and over ``C v_max^(1/5)`` against ``v_max / (c0 delta0)``.

    Parameters
    ----------
    outcome : Outcome
        What :func:`compute` returned.
    path : Path
        The PNG written.
    """
    d = outcome.data
    with figure_file(path, 2, (11, 4)) as (fig, (a, b)):
        q = np.linspace(0.0, math.pi, 200)
        c0 = sound_speed(d["mode_delta0"])
        a.plot(q, frequency(q, d["mode_delta0"]) / c0, "k-", lw=1, label=r"$2|\sin(q/2)|$ (lattice)")
        a.plot(q, q, "k:", lw=1, label=r"$q$ (sound)")
        for s, mark in (("event", "o"), ("verlet", "x")):
            a.plot([m[s]["q"] for m in d["modes"].values()],
                   [m[s]["omega"] / c0 for m in d["modes"].values()], mark, ms=6,
                   label=f"engine, {s}")
        a.plot(q, np.cos(q / 2.0), "k--", lw=1, label=r"$v_g / c_0 = \cos(q/2)$")
        a.plot([p["event"]["q"] for p in d["packets"].values()],
               [p["event"]["speed"] / c0 for p in d["packets"].values()], "s", ms=6,
               label="engine, packet centroid (event)")
        a.set_xlabel("q (radians per granule)")
        a.set_ylabel(r"$\omega / c_0$,  $v_g / c_0$")
        a.legend(fontsize=8)
        ev = [p for p in d["crossover"]["event"] if p["delta0"] > 0]
        rho = np.array([p["rho"] for p in ev])
        b.semilogx(rho, [p["speed"] / p["c0"] for p in ev], "o", color="tab:red",
                   label="engine (event): speed / $c_0$")
        lin = [p for p in ev if p["rho"] < LINEAR_BELOW]
        b.semilogx([p["rho"] for p in lin], [p["linear"] / p["c0"] for p in lin], "k+", ms=8,
                   label="linearised lattice struck (same fit)")
        line = np.geomspace(rho.min(), rho.max(), 100)
        b.semilogx(line, [long_wave_speed(r) for r in line], "k-", lw=1,
                   label="long-wave solitary wave (Nesterenko)")
        b.semilogx(rho, [p["speed"] / (d["wave_constant"] * p["v_max"] ** 0.2) for p in ev],
                   "s", color="tab:blue", ms=4, label=r"engine: speed / $C v_{max}^{1/5}$")
        b.axhline(1.0, color="grey", lw=0.5)
        b.set_xlabel(r"$v_{max} / (c_0 \delta_0)$")
        b.set_ylabel("pulse speed, scaled")
        b.set_ylim(0.5, 2.0)
        b.legend(fontsize=7)
        fig.suptitle("Precompressed Hertz chain (scenarios/classics/precompressed.yaml)", fontsize=10)


EXPERIMENT = Experiment(
    name="precompressed",
    title="Precompressed Hertz chain: sound speed, dispersion omega(q), crossover to the "
          "solitary wave",
    scenes=(SCENE,), compute=compute, figure=figure)
