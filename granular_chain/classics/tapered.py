"""Experiment ``tapered``: a pulse in a tapered chain struck at its large end.

Scene ``scenarios/classics/tapered.yaml``: :data:`COUNT` frictionless Hertz
spheres, radii ``r_i = 0.5 (1 - q)^i``, masses ``m_i = (1 - q)^(3 i)`` (one
density), each contact's coefficient ``k = (4/3) E* sqrt(R*)`` from its two radii
(E = 3, nu = 0: k = 1 for two spheres of radius 1/2); granule 0 strikes the
others at v0 = 0.01. Run for the taper ratios ``q`` of :data:`TAPERS`. In a tapered
chain the pulse speeds up and its velocity grows as it runs into ever lighter
grains, while its energy, momentum and force fall: each grain keeps part of its
forward momentum when it pushes a lighter one, so the chain behind the pulse moves
forward and the pulse is absorbed (Sen, Manciu & Wright, Phys. Rev. E 57, 2386
(1998); Nakagawa, Agui, Wu & Sen, Granular Matter 4, 167 (2003); Doney & Sen,
Phys. Rev. Lett. 97, 155502 (2006)). Those papers give the attenuation as
figures; the reference here is computed: the same equations (per-contact ``k``,
per-granule mass) integrated independently by scipy's DOP853 at
rtol = atol = 3e-14 (:func:`.chain_ode.integrate_chain_at`), stopped at the times
the engine finds each peak and at t_end; its own error is its change against a
run at rtol 1e-13.

Measured for every q (both steppers; Verlet's error by halving dt, Richardson
``(4/3) |a(dt) - a(dt/2)|``): the peak force of the last contact over that of the
first (the striker's), the peak velocity, kinetic energy and momentum of granule
:data:`MIDDLE` relative to the striker's, the last granule's final velocity and
kinetic energy relative to the striker's, and momentum and energy at t_end.
Every ratio is independent of v0 (Hertz scaling).
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np

from .. import diagnostics as dg
from ..model import hertz_stiffness
from ..scene import read_scene_data, scene_from_dict
from ..simulate import simulate
from .chain_ode import integrate_chain_at
from .experiment import Experiment, Outcome, figure_file, final_energy
from .table import Row, conservation_rows

__all__ = ["EXPERIMENT", "SCENE", "TAPERS", "COUNT", "MIDDLE", "V0", "VERLET_DT",
           "REFERENCE_RTOL", "chain", "run_tapered", "reference_tapered", "compute", "figure"]

SCENE = "tapered.yaml"
#: Taper ratios q (radius ratio 1 - q between neighbours).
TAPERS = (0.0, 0.02, 0.05, 0.1)
#: Granules in the chain, and the one whose peak is read mid-chain.
COUNT, MIDDLE = 20, 10
#: The striker's speed (scaled units).
V0 = 0.01
#: Verlet's step (the small end is the stiffest; its error is measured at half of it).
VERLET_DT = 3e-3
#: The reference's tolerance (DOP853); its error is measured against rtol 1e-13.
REFERENCE_RTOL = 3e-14
REFERENCE = "DOP853 rtol=atol=3e-14 (scipy, computed)"
#: The frames' spacing (the scene's output.dt).
FRAME_DT = 0.015
STEPPERS = {"event": ("event", None), "verlet": ("verlet", VERLET_DT),
            "verlet_half": ("verlet", VERLET_DT / 2)}


def chain(q: float) -> dict:
    """The tapered chain's arrays, written apart from the scene's recipes.

    Parameters
    ----------
    q : float
        Taper ratio.

    Returns
    -------
    dict
        ``radius``, ``mass`` (shape (COUNT,)), ``k`` (shape (COUNT-1,), Hertz's
        from the radii, E = 3, nu = 0), ``reach`` (``r_i + r_{i+1}``).
    """
    r = 0.5 * (1.0 - q) ** np.arange(COUNT)
    k = np.array([hertz_stiffness(3.0, 0.0, 3.0, 0.0, r[i], r[i + 1]) for i in range(COUNT - 1)])
    return {"radius": r, "mass": (r / 0.5) ** 3, "k": k, "reach": r[:-1] + r[1:]}


def _scene(folder: Path, q: float, stepper: str, dt):
    """The scene at taper ``q`` with ``stepper`` (Verlet: frames every :data:`FRAME_DT`)."""
    data = read_scene_data(Path(folder) / SCENE)
    data["granules"]["radius"]["ratio"] = 1.0 - q
    data["granules"]["mass"]["ratio"] = (1.0 - q) ** 3
    if stepper == "verlet":
        data["run"].update(stepper="verlet", dt=dt)
        data["output"] = {"every": int(round(FRAME_DT / dt))}
    return scene_from_dict(data, source=f"{SCENE} (q = {q:g}, {stepper})")


def run_tapered(folder: Path, q: float, stepper: str, dt: float = VERLET_DT) -> dict:
    """Run the chain of taper ``q`` and read its pulse.

    Parameters
    ----------
    folder : Path
        The scenes' folder.
    q : float
        Taper ratio.
    stepper : str
        ``event`` or ``verlet``.
    dt : float
        Verlet's step.

    Returns
    -------
    dict
        ``times`` (peak times of the first contact's force, the last contact's
        force and granule :data:`MIDDLE`'s velocity), ``force_first``,
        ``force_last`` (peak forces), ``v_middle`` (peak velocity / v0),
        ``v_last`` (final velocity of the last granule / v0), ``separated``
        (the last contact open and the last granule faster than the one before
        at t_end), ``momentum``, ``energy`` (at t_end over their initial
        values), ``energy_error`` (the ledger), ``v_final`` (list).
    """
    c = chain(q)
    result = simulate(_scene(folder, q, stepper, dt), progress=False)
    x = np.asarray(result.x)
    delta = c["reach"] - np.diff(x, axis=1)
    force = c["k"] * np.maximum(delta, 0.0) ** 1.5
    frames = SimpleNamespace(t=np.asarray(result.t), v=force[:, [0, COUNT - 2]])
    tf, fp = dg.peak_times(frames, [0, 1])
    tv, vp = dg.peak_times(result, [MIDDLE])
    largest = [np.max(frames.v[:, 0]), np.max(frames.v[:, 1]),
               np.max(np.asarray(result.v)[:, MIDDLE])]
    v = result.v_final
    overlap = np.maximum(c["reach"] - np.diff(result.x_final), 0.0)
    return {"times": [float(tf[0]), float(tf[1]), float(tv[0])],
            "force_first": float(fp[0]), "force_last": float(fp[1]),
            "v_middle": float(vp[0]) / V0, "v_last": float(v[-1]) / V0,
            "separated": bool(overlap[-1] <= 0.0 and v[-1] > v[-2]),
            "momentum": float(c["mass"] @ v) / V0, "energy": final_energy(result) / (0.5 * V0 ** 2),
            "energy_error": float(result.energy.balance_error), "v_final": v.tolist(),
            "reading": [float(abs(a - b) / a) for a, b in zip((fp[0], fp[1], vp[0]), largest)]}


def reference_tapered(q: float, times, t_end: float, rtol: float = REFERENCE_RTOL) -> dict:
    """The same quantities by DOP853 at the engine's peak times.

    Parameters
    ----------
    q : float
        Taper ratio.
    times : sequence of float
        The engine's peak times (first force, last force, middle velocity).
    t_end : float
        End time.
    rtol : float
        DOP853's tolerance.

    Returns
    -------
    dict
        ``force_first``, ``force_last``, ``v_middle`` (at those times), ``v_last``
        (at t_end, / v0), ``v_final`` (ndarray).
    """
    c = chain(q)
    order = np.argsort(times)
    x0 = np.r_[0.0, np.cumsum(c["reach"])]
    # the reach as the centres' distances themselves: every contact starts at an
    # overlap of exactly 0 (r_i + r_{i+1} from the cumulative sum's roundoff would
    # leave +-1e-17 overlaps, whose crossings DOP853 would chase forever)
    states = integrate_chain_at(c["mass"], x0, np.r_[V0, np.zeros(COUNT - 1)], np.diff(x0),
                                [*np.asarray(times)[order], t_end], k=c["k"], rtol=rtol)
    at = {int(i): states[j] for j, i in enumerate(order)}
    force = lambda s, j: float(c["k"][j] * max(s.overlaps[j], 0.0) ** 1.5)  # noqa: E731
    return {"force_first": force(at[0], 0), "force_last": force(at[1], COUNT - 2),
            "v_middle": float(at[2].v[MIDDLE]) / V0, "v_last": float(states[-1].v[-1]) / V0,
            "v_final": states[-1].v}


def _measure(folder: Path, q: float, t_end: float) -> dict:
    """Every run at one taper: both steppers, the reference, Verlet's error."""
    d = {key: run_tapered(folder, q, s, dt or VERLET_DT) for key, (s, dt) in STEPPERS.items()}
    ref = reference_tapered(q, d["event"]["times"], t_end)
    loose = reference_tapered(q, d["event"]["times"], t_end, 1e-13)
    keys = ("force_first", "force_last", "v_middle", "v_last")
    d["reference"] = {k: ref[k] for k in keys}
    d["reference"]["error"] = float(max(np.max(np.abs(ref["v_final"] - loose["v_final"])) / V0,
                                        *(abs(ref[k] / loose[k] - 1) for k in keys)))
    d["state_diff"] = {s: float(np.max(np.abs(np.subtract(d[s]["v_final"], ref["v_final"]))) / V0)
                       for s in STEPPERS}
    d["verlet_error"] = {k: 4.0 / 3.0 * abs(d["verlet"][k] - d["verlet_half"][k]) for k in keys}
    c = chain(q)
    for s in (*STEPPERS, "reference"):
        e = d[s]
        e["force_ratio"] = e["force_last"] / e["force_first"]
        e["energy_last"] = c["mass"][-1] * e["v_last"] ** 2  # over the striker's m0 v0^2 / 2
        e["energy_middle"] = c["mass"][MIDDLE] * e["v_middle"] ** 2
        e["momentum_middle"] = c["mass"][MIDDLE] * e["v_middle"]
    return d


_QUANTITIES = (
    ("force_ratio", "peak force, last contact / first contact"),
    ("energy_last", "kinetic energy of the last granule at t_end / E0"),
    ("v_last", "last granule's velocity at t_end / v0"),
    ("energy_middle", f"peak kinetic energy of granule {MIDDLE} / E0"),
    ("momentum_middle", f"peak momentum of granule {MIDDLE} / (m0 v0)"),
    ("v_middle", f"peak velocity of granule {MIDDLE} / v0"),
)


def _rows(q: float, d: dict) -> list:
    """The table's rows for one taper."""
    rows = []
    for key, what in _QUANTITIES:
        for s, name in (("event", "event"), ("verlet", f"Verlet dt={VERLET_DT}")):
            rows.append(Row(f"q={q:g} {what}, {name}", d[s][key], d["reference"][key],
                            REFERENCE))
    return rows + conservation_rows(f"q={q:g}", d, "(m0 v0)", "E0")


def compute(folder: Path) -> Outcome:
    """Run the experiment for every taper of :data:`TAPERS`.

    Parameters
    ----------
    folder : Path
        The scenes' folder.

    Returns
    -------
    Outcome
        Its table and (``data``, keyed by q) every number behind it.

    Raises
    ------
    RuntimeError
        The last granule has not left the chain by t_end.
    """
    t_end = float(read_scene_data(Path(folder) / SCENE)["run"]["t_end"])
    rows, data = [], {}
    for q in TAPERS:
        d = _measure(folder, q, t_end)
        bad = [s for s in STEPPERS if not d[s]["separated"]]
        if bad:
            raise RuntimeError(f"tapered: q={q:g}: the last granule is still in the chain at "
                               f"t_end ({', '.join(bad)}): raise run.t_end in {SCENE}")
        rows += _rows(q, d)
        data[f"{q:g}"] = d
    return Outcome(rows=rows, data=data)


def figure(outcome: Outcome, path: Path) -> None:
    """The attenuation against the taper ratio (event stepper): the last contact's
    peak force over the first's, the last granule's and granule :data:`MIDDLE`'s
    kinetic energy and momentum over the striker's, and the velocity growth.

    Parameters
    ----------
    outcome : Outcome
        What :func:`compute` returned.
    path : Path
        The PNG written.
    """
    q = np.array([float(k) for k in outcome.data])
    ev = [d["event"] for d in outcome.data.values()]
    with figure_file(path, 2, (11, 4)) as (fig, (a, b)):
        for key, what in _QUANTITIES[:2] + _QUANTITIES[3:5]:
            a.plot(q, [e[key] for e in ev], "o-", ms=4, label=what)
        a.set_xlabel("taper ratio q")
        a.set_ylabel("relative to the striker")
        a.legend(fontsize=7)
        b.semilogy(q, [e["v_last"] for e in ev], "o-", ms=4, label=_QUANTITIES[2][1])
        b.semilogy(q, [e["v_middle"] for e in ev], "s-", ms=4, label=_QUANTITIES[5][1])
        b.set_xlabel("taper ratio q")
        b.set_ylabel(r"velocity / $v_0$")
        b.legend(fontsize=7)
        fig.suptitle(f"Tapered chain of {COUNT} struck at its large end, event stepper "
                     "(scenarios/classics/tapered.yaml)", fontsize=10)


EXPERIMENT = Experiment(
    name="tapered",
    title="Tapered chain struck at its large end, q = 0..0.1: force, energy and momentum "
          "of the pulse against the taper",
    scenes=(SCENE,), compute=compute, figure=figure)
