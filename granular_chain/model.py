"""Scene -> packed float64 arrays and the set of features present.

This is the last place where strings and pydantic objects exist: kernels see
only the arrays of :class:`Model` and the integer codes of :class:`Features`.

State convention (why displacements): positions are carried as displacements
``u_i`` from the initial positions ``X_i`` (the paper's ``x_i``), and the overlap
of contact i is formed as ``delta_i = d0_i + u_i - u_(i+1)`` with the initial
overlap ``d0_i = r_i + r_(i+1) - (X_(i+1) - X_i)`` computed once. Overlaps are
then never the difference of two large absolute positions, so a chain far from
the origin or a tiny late overlap keeps its digits.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ._compile import specialised
from .contact_table import ContactTable, contact_table
from .distributions import draw, is_recipe
from .forces import total_potential
from .initial_state import read_state
from .laws.contact import LAW_HERTZ, LAW_LINEAR, LAW_POWER, contact_law, law_of_code
from .laws.damping import DAMPING_LINEAR, DAMPING_NONE, DAMPING_VISCOELASTIC
from .laws.wall_motion import WALL_FIXED, WALL_PULSE, WALL_SINE, WALL_VELOCITY
from .restitution import choose_damping, contact_time_scale, scaled_damping, solve_damping
from .scene import Scene

__all__ = ["Features", "Model", "build_model", "friction_features", "scale_problem",
           "LAW_LINEAR", "LAW_HERTZ", "LAW_POWER"]

_TINY = np.finfo(np.float64).tiny  # smallest normal double, 2.2e-308
#: Positions must resolve this fraction of the smallest radius.
_POSITION_RESOLUTION = 1e-3

@dataclass(frozen=True)
class Features:
    """What a scene needs; each flag selects a compiled building block.

    Attributes
    ----------
    law : int
        Code of the contact law of every contact (:mod:`granular_chain.laws.contact`:
        LAW_LINEAR, LAW_HERTZ, LAW_POWER for mixed exponents, or a registered law's).
    coulomb : bool
        Some granule has kinetic friction (eta_i > 0).
    viscous : bool
        Some granule has hydrodynamic friction (gamma_i > 0).
    left_wall, right_wall : bool
        Walls present.
    damping : int
        Dashpot law of the contacts (:mod:`granular_chain.laws.damping`:
        DAMPING_NONE, DAMPING_LINEAR, DAMPING_VISCOELASTIC).
    tensile : bool
        A damped contact's force may pull (ends at overlap 0, not at force 0).
    body_force : bool
        Some granule feels a body force (gravity or given forces).
    driven : bool
        Some wall moves (:mod:`granular_chain.laws.wall_motion`).
    """

    law: int
    coulomb: bool
    viscous: bool
    left_wall: bool
    right_wall: bool
    damping: int = DAMPING_NONE
    tensile: bool = False
    body_force: bool = False
    driven: bool = False

    @property
    def elastic_and_fixed(self) -> bool:
        """No dashpot, no body force, no moving wall: the features of the paper."""
        return self.damping == DAMPING_NONE and not self.body_force and not self.driven

    def in_words(self) -> str:
        """The features in one line, for the compile notice: ``"hertz (n=5/2), coulomb,
        left_wall, damping linear"``.

        Returns
        -------
        str
            The law, then the flags that are set, then the named options not 'none'.
        """
        said = self.describe()
        words = [said["law"]] + [k for k, v in said.items() if v is True]
        words += [f"{k} {v}" for k, v in said.items()
                  if k != "law" and isinstance(v, str) and v != "none"]
        return ", ".join(words)

    def describe(self) -> dict:
        """The features as a JSON-ready dict of names (law, damping) and flags.

        Returns
        -------
        dict
            ``law``, ``damping`` as words; the booleans as they are.
        """
        return {
            "law": law_of_code(self.law).words,
            "coulomb": self.coulomb, "viscous": self.viscous,
            "left_wall": self.left_wall, "right_wall": self.right_wall,
            "damping": {DAMPING_NONE: "none", DAMPING_LINEAR: "linear",
                        DAMPING_VISCOELASTIC: "viscoelastic"}[self.damping],
            "tensile": self.tensile, "body_force": self.body_force, "driven": self.driven,
        }


@dataclass(frozen=True, eq=False)
class Model:
    """A scene packed into arrays (float64, contiguous), in the scene's units.

    Frozen: a run's chain constants, attached to its Result (``result.model``)
    for the writers, diagnostics and plots; compared by identity.

    Attributes
    ----------
    mass, inv_mass, radius : ndarray, shape (N,)
        Masses m_i, 1/m_i and radii r_i, scene units (mass, 1/mass, length).
    x0 : ndarray, shape (N,)
        Initial centre positions X_i (granule 0 centred at its radius), scene
        units of length.
    v0 : ndarray, shape (N,)
        Initial velocities, scene units of speed.
    contacts : ContactTable
        Contacts 0..N, the walls as contacts 0 and N (:mod:`granular_chain.contact_table`):
        initial overlap, force coefficient, exponent and dashpot coefficient of
        each, and the walls' motion. ``d0``, ``k``, ``n``, ``damping`` (the
        neighbour contacts' rows, shape (N-1,)), ``walls``, ``wall_damping`` and
        ``wall_motion`` are read from it.
    eta, eta_static, gamma : ndarray, shape (N,)
        Kinetic friction force, static threshold (>= eta), both force, and
        viscous coefficient (force / speed), scene units.
    features : Features
        The compiled building blocks the scene needs.
    units : str
        The scene's ``units``: "scaled" or "physical" (SI).
    name : str
        The scene's name (file stems, titles).
    extras : dict
        Free-form data attached to the Model (empty by default; not read by the engine).
    body_force : ndarray, shape (N,)
        Force on each granule along +x (gravity m_i g direction, or given),
        scene units of force.
    """

    mass: np.ndarray
    inv_mass: np.ndarray
    radius: np.ndarray
    x0: np.ndarray
    v0: np.ndarray
    contacts: ContactTable
    eta: np.ndarray
    eta_static: np.ndarray
    gamma: np.ndarray
    features: Features
    units: str = "scaled"
    name: str = "scene"
    extras: dict = field(default_factory=dict)
    body_force: np.ndarray = None

    def __post_init__(self):
        # No body force is zeros of the right shape, so a Model built without one is
        # a complete one.
        if self.body_force is None:
            object.__setattr__(self, "body_force", np.zeros(self.mass.size))

    @property
    def d0(self) -> np.ndarray:
        """Initial overlaps of the neighbour contacts, shape (N-1,) (a view of the table)."""
        return self.contacts.between_granules(self.contacts.d0)

    @property
    def k(self) -> np.ndarray:
        """Force coefficients of the neighbour contacts, shape (N-1,) (a view)."""
        return self.contacts.between_granules(self.contacts.k)

    @property
    def n(self) -> np.ndarray:
        """Exponents of the neighbour contacts, shape (N-1,) (a view)."""
        return self.contacts.between_granules(self.contacts.n)

    @property
    def damping(self) -> np.ndarray:
        """Dashpot coefficients of the neighbour contacts, shape (N-1,) (a view)."""
        return self.contacts.between_granules(self.contacts.damping)

    @property
    def walls(self) -> np.ndarray:
        """(d0, k, n) of the left then the right wall contact, shape (6,), zeros where
        absent (:meth:`ContactTable.wall_triples`): the table's rows 0 and N as six
        numbers, for scripts; the engine reads the table itself."""
        return self.contacts.wall_triples()

    @property
    def wall_damping(self) -> np.ndarray:
        """Dashpot coefficients of the left and right wall contacts, shape (2,)."""
        return self.contacts.damping[[0, self.count]]

    @property
    def wall_motion(self) -> np.ndarray:
        """(kind, p1, p2) of the left and right wall, shape (2, 3) (zeros: fixed)."""
        return self.contacts.wall_motion

    @property
    def count(self) -> int:
        """Number of granules N."""
        return self.mass.size

    def energies(self, u: np.ndarray, v: np.ndarray) -> tuple[float, float]:
        """Kinetic and elastic energy of the state (u, v), shapes (N,).

        Parameters
        ----------
        u : numpy.ndarray
            Shape (N,): displacements from ``x0``, scene units of length.
        v : numpy.ndarray
            Shape (N,): velocities, scene units of speed.

        Returns
        -------
        tuple of float
            ``(kinetic, elastic)``, scene units of energy.
        """
        feat = self.features
        t = self.contacts
        args = (feat.law, int(feat.left_wall), int(feat.right_wall), u, t.d0, t.k, t.n)
        with np.errstate(over="ignore", invalid="ignore"):
            ke = 0.5 * float(np.dot(self.mass, v * v))
        pe = float(specialised(total_potential, args, (0, 1, 2))(*args))
        return ke, pe

    def shortest_period(self) -> float:
        """Shortest small-oscillation period of any contact (for default dt and checks).

        For a linear contact between masses m_a, m_b the period is
        2*pi*sqrt(mu/k) with mu the reduced mass. For n != 2 the contact has no
        fixed period; the duration of a collision at the largest relative speed
        in the scene, t_c ~ 3.2 (mu^2 / (k^2 v))^(1/(n)) scaled form, is used
        (paper Appendix A: time scale B = (m v^2/k)^(1/n) / v).

        Returns
        -------
        float
            Period in scene units of time (``inf`` without any contact).
        """
        vmax = float(np.max(np.abs(self.v0))) if self.count else 0.0
        vrel = max(vmax, 1e-300)
        rows = self.contacts.rows()
        if rows.size == 0:
            return math.inf
        t = self.contacts
        mu, k, n, d0 = t.reduced_mass(self.mass)[rows], t.k[rows], t.n[rows], t.d0[rows]
        linear = n == 2.0
        # Linear contacts: the period 2 pi sqrt(mu/k).
        periods = np.where(linear, 2 * math.pi * np.sqrt(mu / k), np.inf)
        # Other n: 3.2 times the collision time scale B of Appendix A at the
        # largest speed, or the small-oscillation period of a precompressed contact.
        with np.errstate(divide="ignore", invalid="ignore", under="ignore"):
            # Nothing moving: no collision time scale (only precompression sets one).
            # B = (mu v^2/k)^(1/n) / v, written so that a tiny v does not underflow
            b = (mu / k) ** (1.0 / n) * vrel ** (2.0 / n - 1.0) if vmax > 0 else np.full(mu.size, np.inf)
            k_local = k * (n - 1) * np.where(d0 > 0, d0, 1.0) ** (n - 2)
            b = np.where(d0 > 0, np.minimum(b, 2 * math.pi * np.sqrt(mu / k_local)), b)
        periods = np.where(linear, periods, 3.2 * b)
        return float(np.min(periods))


def _per(value, count: int) -> np.ndarray:
    if is_recipe(value):  # a seeded distribution: its count values (distributions.py)
        return np.ascontiguousarray(draw(value, count))
    if isinstance(value, dict):  # sparse {index: value}, the rest zero
        arr = np.zeros(count)
        for i, x in value.items():
            arr[i] = x
        return arr
    arr = np.asarray(value if isinstance(value, list) else [value] * count, dtype=np.float64)
    return np.ascontiguousarray(arr.reshape(count))


def hertz_stiffness(young_a, poisson_a, young_b, poisson_b, r_a, r_b):
    """Hertz force coefficient of two spheres: F = k delta^(3/2), k = (4/3) E* sqrt(R*).

    E* = 1 / ((1-nu_a^2)/E_a + (1-nu_b^2)/E_b), R* = r_a r_b / (r_a + r_b).
    For identical spheres this is (2/3) E/(1-nu^2) sqrt(R/2) = (5/2) a, with ``a`` the
    *potential* coefficient of the paper's eq. (1)-(3) (V = a delta^(5/2)).
    """
    e_star = 1.0 / ((1 - poisson_a ** 2) / young_a + (1 - poisson_b ** 2) / young_b)
    r_star = r_a * r_b / (r_a + r_b)
    return 4.0 / 3.0 * e_star * np.sqrt(r_star)


def hertz_wall_stiffness(young_granule, poisson_granule, young_wall, poisson_wall, radius):
    """Hertz force coefficient of a sphere on a flat: F = k delta^(3/2), k = (4/3) E* sqrt(r).

    The flat is a sphere of infinite radius, so R* of :func:`hertz_stiffness` is the
    granule's radius r; E* = 1 / ((1-nu_g^2)/E_g + (1-nu_w^2)/E_w) from both materials
    (Johnson, Contact Mechanics, eq. (4.22)-(4.23)).

    Parameters
    ----------
    young_granule, poisson_granule : float
        Young's modulus (pressure) and Poisson ratio of the granule.
    young_wall, poisson_wall : float
        The same for the wall.
    radius : float
        Radius of the granule (length).

    Returns
    -------
    float
        k in force / length^(3/2).
    """
    e_star = 1.0 / ((1 - poisson_granule ** 2) / young_granule
                    + (1 - poisson_wall ** 2) / young_wall)
    return 4.0 / 3.0 * e_star * math.sqrt(radius)


def _walls(scene: Scene, radius: np.ndarray) -> np.ndarray:
    """(d0, k, n) of the left then the right wall contact, shape (6,) (zeros if absent)."""
    walls = np.zeros(6)
    for j, (side, end) in enumerate((("left", 0), ("right", -1))):
        wall = getattr(scene.walls, side)
        if wall is None:
            continue
        k = wall.stiffness
        if k == "hertz":
            mat = scene.granules.material
            young = _per(mat.young, radius.size)[end]
            poisson = _per(mat.poisson, radius.size)[end]
            k = hertz_wall_stiffness(float(young), float(poisson), wall.material.young,
                                     wall.material.poisson, float(radius[end]))
        walls[3 * j:3 * j + 3] = (-wall.gap, k, wall.exponent)
    return walls


def friction_features(eta, eta_static, gamma):
    """Which friction a scene has: (coulomb, viscous) from the per-granule arrays.

    Coulomb friction is present when some granule has eta > 0 or a static
    threshold > 0, viscous friction when some gamma > 0. Works on a batch too:
    arrays of shape (..., N) give boolean arrays of shape (...).

    Parameters
    ----------
    eta, eta_static : array_like
        Shape (..., N): kinetic friction forces and static thresholds, scene
        units of force.
    gamma : array_like
        Shape (..., N): viscous coefficients, scene units of force / speed.

    Returns
    -------
    tuple
        ``(coulomb, viscous)``: bools, or boolean arrays of shape (...).
    """
    eta, eta_static, gamma = (np.asarray(a) for a in (eta, eta_static, gamma))
    coulomb = ((eta > 0) | (eta_static > 0)).any(axis=-1)
    return coulomb, (gamma > 0).any(axis=-1)


def _law(scene: Scene, n_exp: np.ndarray) -> int:
    """The contact law's code: the one ``contacts.law`` names, or by the exponents of
    every contact and wall ('auto': linear when all are 2, hertz when all are 5/2,
    the general power law otherwise)."""
    if scene.contacts.law != "auto":
        return contact_law(scene.contacts.law).code
    exps = list(n_exp) + [w.exponent for w in (scene.walls.left, scene.walls.right)
                          if w is not None]
    if all(e == 2.0 for e in exps):
        return LAW_LINEAR
    if all(e == 2.5 for e in exps):
        return LAW_HERTZ
    return LAW_POWER


def build_model(scene: Scene) -> Model:
    """Pack a validated scene into a :class:`Model`.

    Parameters
    ----------
    scene : Scene
        A validated scene (its own units are kept).

    Returns
    -------
    Model
        The arrays and features of the scene, scene units.
    """
    g = scene.granules
    N = g.count
    mass = _per(g.mass, N)
    radius = _per(g.radius, N)
    if g.state is not None:  # positions and velocities from a file, exactly
        if g._x0 is None:  # a stored scene read back: read the file now
            g._x0, g._v0 = read_state(g.state.file, g.state.frame, N)
        x0, v0 = g._x0.copy(), g._v0.copy()
        gaps = np.diff(x0) - radius[:-1] - radius[1:]
    else:
        v0 = _per(g.velocity, N)
        gaps = _per(g.gap, N - 1) if N > 1 else np.zeros(0)
        x0 = np.empty(N)
        x0[0] = radius[0]
        x0[1:] = radius[0] + np.cumsum(radius[:-1] + radius[1:] + gaps)
    d0 = np.ascontiguousarray(-gaps)
    n_exp = _per(scene.contacts.exponent, N - 1) if N > 1 else np.zeros(0)
    if scene.contacts.stiffness == "hertz":
        mat = g.material
        E = _per(mat.young, N)
        nu = _per(mat.poisson, N)
        k = hertz_stiffness(E[:-1], nu[:-1], E[1:], nu[1:], radius[:-1], radius[1:])
    else:
        k = _per(scene.contacts.stiffness, N - 1) if N > 1 else np.zeros(0)
    walls = _walls(scene, radius)
    left, right = scene.walls.left, scene.walls.right
    fr = g.friction
    eta = _per(fr.kinetic, N)
    eta_s = _per(fr.static, N) if fr.static is not None else eta.copy()
    gamma = _per(fr.viscous, N)

    law = _law(scene, n_exp)
    coulomb, viscous = friction_features(eta, eta_s, gamma)
    motion = _wall_motion(scene)
    table = contact_table(d0, k, n_exp, walls, left is not None, right is not None,
                          wall_motion=motion)
    damping_code, damping = _dashpots(scene, mass, table)
    table = dataclasses.replace(table, damping=damping)
    body = _body_force(scene, mass)
    features = Features(
        law=law,
        coulomb=bool(coulomb),
        viscous=bool(viscous),
        left_wall=left is not None,
        right_wall=right is not None,
        damping=damping_code,
        tensile=bool(scene.contacts.tensile) and damping_code != DAMPING_NONE,
        body_force=bool(np.any(body != 0.0)),
        driven=bool(np.any(motion[:, 0] != WALL_FIXED)),
    )
    return Model(
        mass=mass, inv_mass=1.0 / mass, radius=radius, x0=x0, v0=v0, contacts=table,
        eta=eta, eta_static=eta_s, gamma=gamma, features=features,
        units=scene.units, name=scene.name, body_force=body,
    )


def _dashpots(scene: Scene, mass: np.ndarray, table: ContactTable):
    """(code, coefficient of each contact, shape (N+1,)) of contacts.damping.

    ``restitution`` with every exponent 2 becomes the linear dashpot whose two-body
    restitution is e (:func:`granular_chain.restitution.choose_damping`); with any
    other exponent, the viscoelastic dashpot whose restitution is e at the impact
    speed ``speed`` (:func:`granular_chain.restitution.solve_damping`; A = c/k at
    n = 2). Each contact uses its reduced mass, a wall the end granule's mass (a
    wall is an infinite mass). A coefficient given as such is every row's, absent
    walls' too (unused there); restitution sets the contacts present.
    """
    spec = scene.contacts.damping
    N = mass.size
    if spec is None:
        return DAMPING_NONE, np.zeros(N + 1)
    if spec.model != "restitution":
        code = DAMPING_LINEAR if spec.model == "linear" else DAMPING_VISCOELASTIC
        return code, np.full(N + 1, float(spec.coefficient))
    tensile = bool(scene.contacts.tensile)
    mu = table.reduced_mass(mass)
    present = table.rows()  # neighbour contacts, then the walls: the order of the fields
    rows = [(float(table.k[j]), float(table.n[j]), float(mu[j])) for j in present]
    if all(nn == 2.0 for _, nn, _ in rows):
        coeff = [choose_damping(spec.value, kk, m, tensile) for kk, _, m in rows]
        code = DAMPING_LINEAR
    else:
        # e(g) is the same function for every contact of one exponent: one root per n
        groups = {nn: scaled_damping(spec.value, nn, tensile)
                  for nn in sorted({nn for _, nn, _ in rows})}
        coeff = [solve_damping(spec.value, spec.speed, nn, kk, m, tensile) if nn == 2.0
                 else groups[nn] * contact_time_scale(spec.speed, kk, m, nn)
                 for kk, nn, m in rows]
        code = DAMPING_VISCOELASTIC
    damping = np.zeros(N + 1)
    damping[present] = coeff
    return code, damping


def _body_force(scene: Scene, mass: np.ndarray) -> np.ndarray:
    """Force on each granule along +x, shape (N,): m_i g direction, or the given values."""
    body = scene.body_force
    if body is None:
        return np.zeros(mass.size)
    if body.g is not None:
        return mass * (float(body.g) * body.direction)
    return _per(body.force, mass.size)


def _wall_motion(scene: Scene) -> np.ndarray:
    """(kind, p1, p2) of the left and right wall, shape (2, 3) (zeros: fixed)."""
    motion = np.zeros((2, 3))
    for j, side in enumerate(("left", "right")):
        wall = getattr(scene.walls, side)
        m = wall.motion if wall is not None else None
        if m is None:
            continue
        if m.velocity is not None:
            motion[j] = (WALL_VELOCITY, m.velocity, 0.0)
        elif m.sine is not None:
            motion[j] = (WALL_SINE, m.sine.amplitude, m.sine.frequency)
        else:
            motion[j] = (WALL_PULSE, m.pulse.velocity, m.pulse.duration)
    return motion


def _contacts_with_walls(model: Model):
    """(reduced mass, k, n, initial overlap, field name) of the neighbour contacts, then
    of each wall present, from the contact table."""
    t, N = model.contacts, model.count
    mu = t.reduced_mass(model.mass)
    groups = [(np.arange(1, N), "contacts.stiffness")]
    groups += [(np.array([j]), t.field_of(j)) for j in (0, N) if t.present[j]]
    return [(mu[j], t.k[j], t.n[j], t.d0[j], name) for j, name in groups]


def scale_problem(model: Model):
    """The first quantity of the scene that double precision cannot represent, or None.

    The scene's own ranges (masses, radii, stiffnesses within 2^-511 .. 2^511) keep
    each number representable; this checks what the engine forms from them: the
    ratio mu/k that sets every contact time, the initial kinetic and elastic
    energies, and the positions, which must resolve a thousandth of the smallest
    radius (a gap of 1e300 puts a granule where the spacing of doubles is 1e284).

    Parameters
    ----------
    model : Model
        The compiled scene, scene units.

    Returns
    -------
    (str, str) or None
        The dotted field to change and what is wrong.
    """
    with np.errstate(all="ignore"):
        for mu, k, n, d0, field in _contacts_with_walls(model):
            ratio = mu / k
            bad = np.flatnonzero(~(ratio >= _TINY) | ~np.isfinite(ratio))
            if bad.size:
                i = int(bad[0])
                return field, (f"mass / stiffness = {mu[i]:.3g} / {k[i]:.3g} of contact {i} "
                               f"{'underflows' if ratio[i] < _TINY else 'overflows'} double "
                               f"precision: its contact time cannot be computed")
            pe = k * np.where(d0 > 0, d0, 0.0) ** n / n
            if not np.all(np.isfinite(pe)):
                i = int(np.flatnonzero(~np.isfinite(pe))[0])
                return "granules.gap", (f"the initial elastic energy of contact {i} (overlap "
                                        f"{d0[i]:.3g}) overflows double precision")
        ke = 0.5 * model.mass * model.v0 * model.v0
        if not np.all(np.isfinite(ke)):
            i = int(np.flatnonzero(~np.isfinite(ke))[0])
            return "granules.velocity", (f"the kinetic energy m v^2/2 of granule {i} (v = "
                                         f"{model.v0[i]:.3g}, m = {model.mass[i]:.3g}) "
                                         f"overflows double precision")
        far = np.abs(model.x0)
        spacing = np.spacing(far)
        bad = np.flatnonzero(~(spacing <= _POSITION_RESOLUTION * model.radius))
        if bad.size:
            i = int(bad[0])
            field = "granules.gap" if np.max(np.abs(model.d0), initial=0.0) > np.max(
                model.radius) else "granules.radius"
            return field, (f"puts granule {i} at x = {model.x0[i]:.3g}, where double precision "
                           f"cannot resolve a thousandth of its radius {model.radius[i]:.3g} "
                           f"(spacing of doubles there: {spacing[i]:.3g})")
    return None
