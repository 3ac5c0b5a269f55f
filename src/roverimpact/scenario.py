r"""Impact scenarios: from a physical description to (M, A, v) just before impact.

A :class:`Scenario` (pydantic v2, unknown keys are errors) names a model (a built-in
rover with parameters, or a URDF/MJCF file), a configuration, a velocity, which
constraints are active and the obstacle contact. :meth:`Scenario.build` evaluates the
model with Pinocchio and returns an :class:`ImpactSetup` (M, A, v, labels, ...);
:meth:`ImpactSetup.partition` returns the effective kinetic energy :math:`T_c^-`.

Impact angle convention (DETC2014-35554, Fig. 1): for a rover driving along its heading
:math:`\hat x_h` (world +x for the planar rover), the outward normal of the obstacle face
at the contact point is

.. math::  n(\beta) = -\sin\beta\,\hat x_h + \cos\beta\,\hat z,

so :math:`\beta = 0` is a horizontal face (top of a step) and :math:`\beta = 90^\circ` a
vertical wall facing the rover. :math:`\beta` is given in **degrees** in files and on the
command line, radians inside. The obstacle row is :math:`a = n^T J_p` (``a v < 0`` when
approaching) and the normal approach speed is :math:`v_n = -a v`.

TOML layout (see ``examples/*.toml``)::

    description = "..."
    constraints = "auto"           # or "all", or a list of row labels ["ground:rear:normal"]
    [model]        name = "rover2d" | "rocker_bogie"  or  file = "arm.urdf"
                   preset = "mer"; floating_base = false
    [model.params] h = 0.4 ...     # builder parameters (SI)
    [configuration] joints = {rocker = 0.1}; base = {x = 0, z = 0.3, pitch_deg = 5}
    [velocity]     u = 0.5; joints = {...}; base_linear = [..]; base_angular = [..]
    [contacts]     ground_wheels = "others" | ["rear"]; ground = "noslip" | "normal"
                   locked = ["rocker"]; loop_closure = true
    [obstacle]     wheel = "front" | frame = "panda_hand"; point = [0, 0, 0.1]
                   beta_deg = 45  |  normal = [-1, 0, 0]
    [contact_law]  name = "hunt_crossley"; k = 1e6; e = 0.8; n = 1.5
"""

from __future__ import annotations

import fnmatch
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, ValidationError, field_validator, model_validator

from ._io import validation_message
from .energy import partition
from .exceptions import ConfigError, InputError

__all__ = [
    "ImpactEnergy",
    "ImpactSetup",
    "Scenario",
    "choose_active_rows",
    "energy_of",
    "load_scenario",
    "normal_from_beta",
    "sweep_energy",
]

Vec3 = tuple[float, float, float]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class ModelSpec(_Strict):
    """Which model: a built-in rover (``name``) or a robot file (``file``)."""

    name: Literal["rover2d", "rocker_bogie"] | None = None
    file: str | None = None
    preset: str | None = None
    floating_base: bool | None = None
    params: dict[str, float | int | bool | str] = {}

    @model_validator(mode="after")
    def _one_source(self):
        if (self.name is None) == (self.file is None):
            raise ValueError("give exactly one of model.name (built-in rover) or model.file")
        if self.preset is not None and self.name != "rocker_bogie":
            raise ValueError("model.preset applies to name = 'rocker_bogie' only")
        if self.file is not None and self.params:
            raise ValueError("model.params apply to built-in rovers only")
        return self


class BaseSpec(_Strict):
    """Base pose (world): position [m] and roll/pitch/yaw [deg]; unset = model's nominal."""

    x: float | None = None
    y: float | None = None
    z: float | None = None
    roll_deg: float = 0.0
    pitch_deg: float = 0.0
    yaw_deg: float = 0.0


class ConfigurationSpec(_Strict):
    """Joint values by name [rad or m] and the base pose."""

    joints: dict[str, float] = {}
    base: BaseSpec = BaseSpec()


class VelocitySpec(_Strict):
    """Velocity just before impact.

    ``u`` [m/s] drives the rover along its heading with every wheel rolling (spin u/r);
    ``joints`` [rad/s or m/s] sets joint rates by name (after ``u``); ``base_linear``
    [m/s] and ``base_angular`` [rad/s] set the base twist in world axes (replacing what
    ``u`` set for the base).
    """

    u: float = 0.0
    joints: dict[str, float] = {}
    base_linear: Vec3 | None = None
    base_angular: Vec3 | None = None


class ContactsSpec(_Strict):
    """Candidate constraint rows besides the obstacle.

    ``ground_wheels``: wheels on flat ground (z = 0); ``"others"`` = every wheel except
    the one hitting the obstacle. ``ground``: ``"normal"`` rows only or ``"noslip"``
    (normal + tangential rows). ``locked``: joints held fixed. ``loop_closure``: include
    the model's closed-loop rows (rocker-bogie differential).
    """

    ground_wheels: Literal["others"] | list[str] = "others"
    ground: Literal["normal", "noslip"] = "noslip"
    locked: list[str] = []
    loop_closure: bool = True


class ObstacleSpec(_Strict):
    """The impact contact: a wheel rim or a point of a frame, and the obstacle normal."""

    wheel: str | None = None
    frame: str | None = None
    point: Vec3 = (0.0, 0.0, 0.0)
    normal: Vec3 | None = None
    beta_deg: float | None = None

    @model_validator(mode="after")
    def _one_each(self):
        if (self.wheel is None) == (self.frame is None):
            raise ValueError("obstacle: give exactly one of wheel or frame")
        if (self.normal is None) == (self.beta_deg is None):
            raise ValueError("obstacle: give exactly one of normal or beta_deg")
        if self.beta_deg is not None and not (0.0 <= self.beta_deg <= 90.0):
            raise ValueError(f"obstacle.beta_deg must be in [0, 90] degrees, got {self.beta_deg}")
        if self.normal is not None:
            nv = np.asarray(self.normal, dtype=float)
            if not np.all(np.isfinite(nv)) or not np.linalg.norm(nv) > 1e-12:
                raise ValueError(f"obstacle.normal must be a non-zero finite vector, got "
                                 f"{list(self.normal)}")
        return self


class ContactLawSpec(_Strict):
    """Contact law for the predicted peak force (roverimpact.contact.get_law)."""

    name: str
    k: float
    e: float | None = None
    n: float | None = None

    @field_validator("k")
    @classmethod
    def _k_pos(cls, k):
        if not (np.isfinite(k) and k > 0):
            raise ValueError(f"contact_law.k must be > 0, got {k}")
        return k


class Scenario(_Strict):
    """A complete impact scenario; see the module docstring for the TOML layout.

    ``constraints`` selects the active rows among the candidates: ``"auto"`` (default: the
    contacts that hold through the impact, :func:`roverimpact.activeset.holding_rows`),
    ``"all"`` or a list of labels (``fnmatch`` patterns allowed, e.g.
    ``"ground:*:normal"``); the obstacle row is always active. The choice is made by
    :func:`choose_active_rows`.
    """

    description: str = ""
    model: ModelSpec
    configuration: ConfigurationSpec = ConfigurationSpec()
    velocity: VelocitySpec = VelocitySpec()
    contacts: ContactsSpec = ContactsSpec()
    obstacle: ObstacleSpec
    constraints: Literal["auto", "all"] | list[str] = "auto"
    contact_law: ContactLawSpec | None = None

    def build(self, *, base_dir: str | Path | None = None) -> ImpactSetup:
        """Evaluate the scenario: model, q, v, M, A (active rows) -> :class:`ImpactSetup`.

        ``base_dir`` resolves a relative ``model.file`` (default: current directory;
        :func:`load_scenario` passes the TOML file's directory).
        """
        return _build(self, Path(base_dir) if base_dir is not None else Path.cwd())

    def with_beta(self, beta_deg: float) -> Scenario:
        """Copy with the obstacle normal given by ``beta_deg`` (degrees)."""
        obs = self.obstacle.model_copy(update={"beta_deg": beta_deg, "normal": None})
        ObstacleSpec.model_validate(obs.model_dump())
        return self.model_copy(update={"obstacle": obs})


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario TOML file.

    Raises
    ------
    ConfigError
        Missing or malformed file, unknown keys, bad values (one message naming them).
    """
    from ._io import read_toml

    path = Path(path)
    raw = read_toml(path)
    sc = scenario_from_dict(raw, where=str(path))
    model = sc.model
    f = model.file
    if f is not None and not _is_special(f) and not Path(f).is_absolute():
        model = model.model_copy(update={"file": str(path.parent / model.file)})
        sc = sc.model_copy(update={"model": model})
    return sc


def _is_special(file: str) -> bool:
    from .models.robot import ERD_SCHEME

    return file.startswith(ERD_SCHEME)


def scenario_from_dict(raw: dict, *, where: str = "scenario") -> Scenario:
    """Validate a scenario given as a dict (as read from TOML)."""
    try:
        return Scenario.model_validate(raw)
    except ValidationError as exc:
        raise ConfigError(validation_message(exc, where, "invalid scenario: ")) from None


# ----------------------------------------------------------------------------------------
# Result types
# ----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ImpactEnergy:
    """Energy indicators of an impact (one configuration, or a batch over beta).

    Attributes
    ----------
    T : float or (k,) array
        Kinetic energy 1/2 v^T M v [J].
    T_c_minus : float or (k,) array
        Effective kinetic energy T_c^- (constrained part, obstacle row included) [J].
    T_a : float or (k,) array
        Admissible part T - T_c^- [J].
    m_eff : float or (k,) array
        Effective mass along the impact normal with the other active rows held
        (persistent) [kg]: 1 / (a N a^T), N = M^-1 - M^-1 B^T (B M^-1 B^T)^+ B M^-1.
        ``inf`` if the other rows already block the normal direction.
    m_eff_free : float or (k,) array
        Effective mass of the obstacle row alone, 1 / (a M^-1 a^T) [kg].
    v_n : float or (k,) array
        Normal approach speed -n·v_p [m/s] (> 0 when approaching).
    rank : int or (k,) array
        Rank of the active rows.
    """

    T: Any
    T_c_minus: Any
    T_a: Any
    m_eff: Any
    m_eff_free: Any
    v_n: Any
    rank: Any

    def as_dict(self) -> dict:
        def conv(x):
            x = np.asarray(x)
            return x.item() if x.ndim == 0 else x.tolist()

        return {k: conv(getattr(self, k)) for k in
                ("T", "T_c_minus", "T_a", "m_eff", "m_eff_free", "v_n", "rank")}


@dataclass(frozen=True)
class ImpactSetup:
    """The system just before impact, ready for :func:`roverimpact.partition`.

    Attributes
    ----------
    M : (n, n) ndarray
        Mass matrix at ``q`` (Pinocchio CRBA) [kg, kg m, kg m^2].
    A : (m, n) ndarray
        Active constraint rows, the obstacle row included.
    labels : tuple of str
        One label per row of ``A``.
    v : (n,) ndarray
        Generalized velocity before impact.
    q : (nq,) ndarray
        Configuration.
    obstacle_row : int
        Index of the obstacle row in ``A``.
    contact_point : (3,) ndarray
        World position of the impact contact point [m].
    normal : (3,) ndarray
        Unit outward normal of the obstacle face (world).
    model : MultibodyModel
        The model.
    candidate_labels : tuple of str
        All candidate rows (active or not).
    """

    M: np.ndarray
    A: np.ndarray
    labels: tuple[str, ...]
    v: np.ndarray
    q: np.ndarray
    obstacle_row: int
    contact_point: np.ndarray
    normal: np.ndarray
    model: Any
    candidate_labels: tuple[str, ...] = ()
    scenario: Scenario | None = field(default=None, repr=False)
    _cs: Any = field(default=None, repr=False, compare=False)
    _active: Any = field(default=None, repr=False, compare=False)
    _heading: Any = field(default=None, repr=False, compare=False)

    def partition(self) -> ImpactEnergy:
        """T, T_c^-, T_a, m_eff along the normal and v_n of this setup."""
        return _energy(self.M, self.A, self.v, self.obstacle_row)

    def evaluate(self, q=None) -> tuple[np.ndarray, np.ndarray]:
        """Recompute ``(M, A)`` with the same active rows at ``q`` (default: this ``q``).

        ``q`` may be a batch ``(..., nq)``: then ``M`` is ``(..., n, n)`` and ``A``
        ``(..., m, n)``, computed in one pass (one Pinocchio call sequence per configuration,
        one compiled call for all rows), ready for a batched
        :func:`roverimpact.partition` (``partition(M, A, v)``).
        """
        q = self.q if q is None else np.asarray(q, dtype=float)
        M, A_all = self._cs.evaluate(q)
        return M, A_all[..., self._active, :]

    def obstacle_basis(self):
        """``(B (3, n), wheel)``: the obstacle row is n^T B (+ rim-point term for wheels)."""
        return _obstacle_basis(self)


# ----------------------------------------------------------------------------------------
# Building
# ----------------------------------------------------------------------------------------


def normal_from_beta(beta, heading=(1.0, 0.0, 0.0)) -> np.ndarray:
    r"""Outward obstacle normal :math:`n = -\sin\beta\,\hat x_h + \cos\beta\,\hat z` (world).

    Parameters
    ----------
    beta : float or (k,) array_like
        Impact angle [rad], in [0, pi/2].
    heading : (3,) array_like
        Driving direction; its horizontal part is used.

    Returns
    -------
    (3,) or (k, 3) ndarray
    """
    h = np.asarray(heading, dtype=float).copy()
    h[2] = 0.0
    nh = np.linalg.norm(h)
    if not nh > 1e-12:
        raise InputError("heading has no horizontal component: beta is undefined")
    h /= nh
    b = np.asarray(beta, dtype=float)
    return -np.sin(b)[..., None] * h + np.cos(b)[..., None] * np.array([0.0, 0.0, 1.0])


def _make_model(spec: ModelSpec, base_dir: Path):
    from .models import load_robot, rocker_bogie, rover2d

    if spec.file is not None:
        f = spec.file
        if not _is_special(f) and not Path(f).is_absolute():
            f = str(base_dir / f)
        return load_robot(f, floating_base=spec.floating_base)
    if spec.name == "rover2d":
        return rover2d(**spec.params)
    return rocker_bogie(spec.preset, **spec.params)


def _joint(model, name: str, what: str):
    if not model.existJointName(name):
        raise ConfigError(f"{what}: unknown joint {name!r}; joints: {list(model.names[1:])}")
    return model.joints[model.getJointId(name)]


def _base_kind(model) -> str:
    if model.njoints > 1 and model.joints[1].shortname() == "JointModelFreeFlyer":
        return "free"
    names = list(model.names)
    if names[1:4] == ["base_x", "base_z", "base_pitch"]:
        return "planar"
    return "fixed"


def _rpy_matrix(base: BaseSpec) -> np.ndarray:
    import pinocchio as pin

    return pin.rpy.rpyToMatrix(*np.deg2rad([base.roll_deg, base.pitch_deg, base.yaw_deg]))


def _configuration(mbm, spec: ConfigurationSpec) -> np.ndarray:
    import pinocchio as pin

    model = mbm.model
    q = np.array(mbm.params.get("q_nominal", pin.neutral(model)), dtype=float)
    if q.shape != (model.nq,):
        q = pin.neutral(model)
    kind = _base_kind(model)
    b = spec.base
    if kind == "planar":
        if b.y not in (None, 0.0) or b.roll_deg or b.yaw_deg:
            raise ConfigError("configuration.base: the planar rover has x, z, pitch_deg only")
        q[0] = q[0] if b.x is None else b.x
        q[1] = q[1] if b.z is None else b.z
        q[2] = np.deg2rad(b.pitch_deg)
    elif kind == "free":
        for i, val in enumerate((b.x, b.y, b.z)):
            if val is not None:
                q[i] = val
        q[3:7] = pin.Quaternion(_rpy_matrix(b)).coeffs()
    elif b != BaseSpec():
        raise ConfigError("configuration.base: this model has a fixed base; remove [base] or "
                          "set model.floating_base = true")
    for name, val in spec.joints.items():
        j = _joint(model, name, "configuration.joints")
        if j.nq != 1:
            raise ConfigError(f"configuration.joints: joint {name!r} has {j.nq} coordinates; "
                              "only 1-DoF joints can be set by value")
        q[j.idx_q] = val
    return q


def _heading(mbm, q) -> np.ndarray:
    import pinocchio as pin

    kind = _base_kind(mbm.model)
    if kind == "free":
        R = pin.Quaternion(np.asarray(q[3:7])).normalized().toRotationMatrix()
        h = R[:, 0].copy()
        h[2] = 0.0
        if np.linalg.norm(h) < 1e-9:
            raise ConfigError("the base points straight up or down: beta has no heading")
        return h / np.linalg.norm(h)
    return np.array([1.0, 0.0, 0.0])


def _velocity(mbm, q, spec: VelocitySpec) -> np.ndarray:
    import pinocchio as pin

    model = mbm.model
    v = np.zeros(model.nv)
    kind = _base_kind(model)
    heading = _heading(mbm, q)
    lin = spec.u * heading if spec.base_linear is None else np.asarray(spec.base_linear, float)
    ang = np.zeros(3) if spec.base_angular is None else np.asarray(spec.base_angular, float)
    if kind == "planar":
        if abs(lin[1]) > 0 or abs(ang[0]) > 0 or abs(ang[2]) > 0:
            raise ConfigError("velocity: the planar rover moves in x-z with pitch rate about y "
                              "only (base_linear y and base_angular x, z must be 0)")
        v[0], v[1], v[2] = lin[0], lin[2], ang[1]
    elif kind == "free":
        R = pin.Quaternion(np.asarray(q[3:7])).normalized().toRotationMatrix()
        v[0:3], v[3:6] = R.T @ lin, R.T @ ang
    elif spec.u or spec.base_linear is not None or spec.base_angular is not None:
        raise ConfigError("velocity: u/base_linear/base_angular need a moving base; this model "
                          "has a fixed base (set joint rates in velocity.joints)")
    if spec.u:
        for w in mbm.wheels:
            j = _joint(model, w.frame, "wheel")
            v[j.idx_v] = spec.u / w.radius
    for name, val in spec.joints.items():
        j = _joint(model, name, "velocity.joints")
        if j.nv != 1:
            raise ConfigError(f"velocity.joints: joint {name!r} has {j.nv} velocity components")
        v[j.idx_v] = val
    return v


def _wheel(mbm, name: str, what: str):
    for w in mbm.wheels:
        if w.name == name:
            return w
    raise ConfigError(f"{what}: unknown wheel {name!r}; wheels: {[w.name for w in mbm.wheels]}")


def _candidates(sc: Scenario, mbm, normal: np.ndarray):
    from .models.kinematics import GroundContact, LockedJoint, LoopClosure, PointContact

    cons = []
    obs = sc.obstacle
    cw = sc.contacts
    planar = bool(mbm.params.get("planar", False))
    if cw.ground_wheels == "others":
        ground = [w for w in mbm.wheels if w.name != obs.wheel]
    else:
        ground = [_wheel(mbm, n, "contacts.ground_wheels") for n in cw.ground_wheels]
    for w in ground:
        cons.append(GroundContact(w, noslip=cw.ground == "noslip", planar=planar))
    if cw.loop_closure and mbm.loop_closure is not None:
        cons.append(LoopClosure(tuple(mbm.loop_names)))
    for jn in cw.locked:
        _joint(mbm.model, jn, "contacts.locked")
        cons.append(LockedJoint(jn))
    n = tuple(float(x) for x in normal)
    if obs.wheel is not None:
        w = _wheel(mbm, obs.wheel, "obstacle.wheel")
        cons.append(PointContact(w.name, w.frame, n, wheel=w))
    else:
        if not mbm.model.existFrame(obs.frame):
            names = sorted({f.name for f in mbm.model.frames})
            raise ConfigError(f"obstacle.frame: unknown frame/body {obs.frame!r}; frames: {names}")
        cons.append(PointContact(obs.frame, obs.frame, n, point=tuple(obs.point)))
    return cons


def choose_active_rows(spec, labels, M, A, v, *, obstacle_row: int) -> np.ndarray:
    """Indices of the active rows of ``A`` (the ONE place where the active set is chosen).

    Parameters
    ----------
    spec : "auto", "all" or list of str
        ``"auto"``: the rows that hold through the impact (unilateral LCP, see
        :func:`roverimpact.activeset.holding_rows`). ``"all"``: every candidate row.
        A list: rows whose label matches an entry (exact or ``fnmatch`` pattern); every
        entry must match at least one candidate.
    labels : sequence of str
        Labels of all candidate rows (rows of ``A``).
    M, A, v : arrays
        Mass matrix, candidate rows and velocity (unused by ``"all"`` and lists; an
        LCP-based ``"auto"`` decides from them).
    obstacle_row : int
        The obstacle row, always active.

    Returns
    -------
    (k,) int ndarray, increasing.
    """
    labels = list(labels)
    if spec == "auto":  # the contacts that hold through the impact (unilateral LCP)
        from .activeset import holding_rows

        return np.flatnonzero(holding_rows(labels, M, A, v, obstacle_row=obstacle_row))
    if spec == "all":
        keep = set(range(len(labels)))
    else:
        keep = set()
        for pat in spec:
            hit = [i for i, lab in enumerate(labels) if lab == pat or fnmatch.fnmatchcase(lab, pat)]
            if not hit:
                raise ConfigError(f"constraints: {pat!r} matches no candidate row; candidates: "
                                  f"{labels}")
            keep.update(hit)
    keep.add(obstacle_row)
    return np.array(sorted(keep), dtype=np.int64)


def _build(sc: Scenario, base_dir: Path) -> ImpactSetup:
    mbm = _make_model(sc.model, base_dir)
    q = _configuration(mbm, sc.configuration)
    v = _velocity(mbm, q, sc.velocity)
    heading = _heading(mbm, q)
    if sc.obstacle.normal is not None:
        normal = np.asarray(sc.obstacle.normal, float)
        normal = normal / np.linalg.norm(normal)
    else:
        normal = normal_from_beta(np.deg2rad(sc.obstacle.beta_deg), heading)
    from .models.kinematics import ConstraintSet

    cons = _candidates(sc, mbm, normal)
    cs = ConstraintSet(mbm, cons)
    M, A_all = cs.evaluate(q)
    labels = list(cs.labels)
    obstacle_all = len(labels) - 1
    active = choose_active_rows(sc.constraints, labels, M, A_all, v, obstacle_row=obstacle_all)
    obstacle_row = int(np.flatnonzero(active == obstacle_all)[0])
    fid = cs._fids[-1]
    point = cons[-1].contact_point(cs.data, fid)
    return ImpactSetup(
        M=M, A=A_all[active], labels=tuple(labels[i] for i in active), v=v, q=q,
        obstacle_row=obstacle_row, contact_point=point, normal=normal, model=mbm,
        candidate_labels=tuple(labels), scenario=sc, _cs=cs, _active=active, _heading=heading,
    )


# ----------------------------------------------------------------------------------------
# Energy
# ----------------------------------------------------------------------------------------


def _energy(M, A, v, obstacle_row: int) -> ImpactEnergy:
    """T, T_c^-, m_eff (others persistent and free), v_n; A may carry a leading batch axis."""
    p = partition(M, A, v, want_velocities=False)
    a = A[..., obstacle_row, :]
    v_n = -(a @ v)
    L = np.linalg.cholesky(M)
    W = np.linalg.solve(L, np.swapaxes(A, -1, -2))  # (..., n, m) whitened rows
    w_o = W[..., :, obstacle_row]
    g_free = np.sum(w_o * w_o, axis=-1)
    others = np.delete(W, obstacle_row, axis=-1)
    if others.shape[-1]:
        U, s, _ = np.linalg.svd(others, full_matrices=False)
        keep = s > 1e-9 * np.maximum(s[..., :1], 1e-300)
        U = U * keep[..., None, :]
        w_perp = w_o - np.einsum("...ik,...k->...i", U, np.einsum("...ik,...i->...k", U, w_o))
        g = np.sum(w_perp * w_perp, axis=-1)
    else:
        g = g_free
    with np.errstate(divide="ignore"):
        tiny = g <= 1e-12 * np.maximum(g_free, 1e-300)
        m_eff = np.where(tiny, np.inf, 1.0 / np.where(tiny, 1.0, g))
        m_eff_free = 1.0 / g_free

    def sc(x):
        return x[()] if np.ndim(x) == 0 else x

    return ImpactEnergy(T=p.T, T_c_minus=p.T_c, T_a=p.T_a, m_eff=sc(m_eff),
                        m_eff_free=sc(m_eff_free), v_n=sc(v_n), rank=p.rank)


def _energy_sweep(M, A, v, obstacle_row: int, group) -> ImpactEnergy:
    """:func:`_energy` for a stack ``A`` (k, m, n) with one ``M`` and ``v``.

    Items with the same ``group`` id share every row except the obstacle row (zero rows are
    dropped), so the orthonormal basis of the other whitened rows is computed once per
    group, and only the obstacle row is whitened per item. This gives the same ``m_eff``
    as :func:`_energy` (one SVD per item) at a fraction of the cost.
    """
    from scipy.linalg import solve_triangular

    p = partition(M, A, v, want_velocities=False)
    rows = A[:, obstacle_row, :]
    v_n = -(rows @ v)
    L = np.linalg.cholesky(M)
    w_o = solve_triangular(L, rows.T, lower=True, check_finite=False)  # (n, k)
    g_free = np.sum(w_o * w_o, axis=0)
    g = np.empty_like(g_free)
    group = np.asarray(group)
    for gid in np.unique(group):
        sel = np.flatnonzero(group == gid)
        others = np.delete(A[sel[0]], obstacle_row, axis=0)
        others = others[np.any(others != 0.0, axis=1)]
        wo = w_o[:, sel]
        if others.shape[0]:
            W = solve_triangular(L, others.T, lower=True, check_finite=False)
            U, sv, _ = np.linalg.svd(W, full_matrices=False)
            U = U[:, sv > 1e-9 * max(sv[0], 1e-300)]
            wo = wo - U @ (U.T @ wo)
        g[sel] = np.sum(wo * wo, axis=0)
    with np.errstate(divide="ignore"):
        tiny = g <= 1e-12 * np.maximum(g_free, 1e-300)
        m_eff = np.where(tiny, np.inf, 1.0 / np.where(tiny, 1.0, g))
        m_eff_free = 1.0 / g_free
    return ImpactEnergy(T=p.T, T_c_minus=p.T_c, T_a=p.T_a, m_eff=m_eff,
                        m_eff_free=m_eff_free, v_n=v_n, rank=p.rank)


def energy_of(scenario: Scenario | ImpactSetup) -> ImpactEnergy:
    """Effective kinetic energy T_c^-, T, T_a, m_eff and v_n of a scenario.

    Examples
    --------
    >>> import roverimpact as ri
    >>> sc = ri.Scenario.model_validate({"model": {"name": "rover2d"},
    ...     "velocity": {"u": 0.5}, "obstacle": {"wheel": "front", "beta_deg": 0.0}})
    >>> round(float(ri.energy_of(sc).T_c_minus), 12)   # horizontal face: no approach
    0.0
    """
    setup = scenario if isinstance(scenario, ImpactSetup) else scenario.build()
    return setup.partition()


def _obstacle_basis(setup: ImpactSetup):
    from .models.kinematics import point_jacobian

    cs = setup._cs
    cs.kinematics(setup.q)
    c = cs.constraints[-1]
    fid = cs._fids[-1]
    data = cs.data
    if c.wheel is not None:
        import pinocchio as pin

        J = pin.getFrameJacobian(cs.mbm.model, data, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        return J, c.wheel, data.oMf[fid]
    p = c.contact_point(data, fid)
    return point_jacobian(cs.mbm.model, data, fid, p - data.oMf[fid].translation), None, None


def sweep_energy(scenario: Scenario | ImpactSetup, beta) -> ImpactEnergy:
    """T_c^- and friends for many impact angles, reusing M, v and the other rows.

    Only the obstacle row changes with beta: ``a(beta) = n(beta)^T J_p``, where for a wheel
    the rim point ``p = c - r d(n)`` moves with ``n`` (for an upright wheel
    ``(p - c) x n = 0`` and the row is ``n^T J_c``), and for a frame point ``p`` is fixed.

    Parameters
    ----------
    scenario : Scenario or ImpactSetup
        The obstacle normal of the scenario is replaced; the configuration is kept.
    beta : (k,) array_like
        Impact angles [rad] in [0, pi/2].

    Returns
    -------
    ImpactEnergy
        Fields are (k,) arrays.
    """
    setup = scenario if isinstance(scenario, ImpactSetup) else scenario.build()
    beta = np.atleast_1d(np.asarray(beta, dtype=float))
    if beta.ndim != 1 or not np.all(np.isfinite(beta)):
        raise InputError("beta must be a 1-D array of finite angles [rad]")
    if np.any(beta < -1e-12) or np.any(beta > np.pi / 2 + 1e-12):
        raise InputError("beta must be in [0, pi/2] rad (0 to 90 degrees)")
    N = normal_from_beta(beta, setup._heading)  # (k, 3)
    J, wheel, oMf = setup.obstacle_basis()
    if wheel is None:
        rows = N @ J
    else:
        a = oMf.rotation @ np.asarray(wheel.axis, float)
        d = N - (N @ a)[:, None] * a
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        r = -wheel.radius * d
        rows = N @ J[:3] + np.cross(r, N) @ J[3:]
    if setup.scenario is not None and setup.scenario.constraints == "auto":
        # the set that holds depends on beta: decide per beta among all candidate rows
        from .activeset import holding_rows

        A_all = setup._cs.evaluate(setup.q)[1]
        obs = len(setup.candidate_labels) - 1
        A = np.broadcast_to(A_all, (len(beta), *A_all.shape)).copy()
        A[:, obs, :] = rows
        keep = holding_rows(setup.candidate_labels, setup.M, A, setup.v, obstacle_row=obs)
        group = np.unique(keep, axis=0, return_inverse=True)[1].reshape(-1)
        # zero rows are dropped
        return _energy_sweep(setup.M, A * keep[..., None], setup.v, obs, group)
    A = np.broadcast_to(setup.A, (len(beta), *setup.A.shape)).copy()
    A[:, setup.obstacle_row, :] = rows
    return _energy_sweep(setup.M, A, setup.v, setup.obstacle_row, np.zeros(len(beta), int))

