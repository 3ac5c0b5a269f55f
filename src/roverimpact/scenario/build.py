"""The one path from a scenario, or a model in a given state, to (M, A, v) before impact.

:meth:`ImpactSetup.from_scenario` builds the model (:func:`make_model`), its configuration
and velocity from a :class:`~.schema.Scenario`, then calls :meth:`ImpactSetup.from_state`,
which every other caller uses too (the simulator at its first obstacle contact, sweeps):
candidate rows (:func:`candidate_constraints`), the active ones (:func:`choose_active_rows`,
the one place where the active set is chosen) and the energies
(:meth:`ImpactSetup.partition`: T_c^-, m_eff, v_n). The impact angle convention is in
:mod:`roverimpact.scenario`.

Row labels (:mod:`roverimpact.models.constraints`) name the contact before the last
colon: ``"<contact>:normal"`` is a unilateral contact row, ``"<contact>:long"`` and
``"<contact>:lat"`` its no-slip rows, anything else (``"loop:..."``, ``"lock:..."``) a
bilateral row.
"""

from __future__ import annotations

import fnmatch
import functools
import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..energy import RTOL, partition, row_masses
from ..exceptions import ConfigError, GroundGapWarning, InputError, ModelError
from ..unilateral import active_set
from .schema import (
    BaseSpec,
    ConfigurationSpec,
    ContactsSpec,
    ModelSpec,
    ObstacleSpec,
    Scenario,
    VelocitySpec,
    as_scenario,
    is_example_robot_name,
)

__all__ = [
    "GROUND_GAP_ADVICE",
    "ImpactEnergy",
    "ImpactSetup",
    "active_mask",
    "base_heading",
    "base_slices",
    "candidate_constraints",
    "choose_active_rows",
    "configuration",
    "energy_of",
    "gap_text",
    "holding_rows",
    "make_model",
    "normal_from_beta",
    "scenario_model",
    "velocity",
]



@dataclass(frozen=True)
class ImpactEnergy:
    """Energy indicators of an impact (one configuration, or a batch over beta).

    Attributes
    ----------
    T : float or (k,) array
        Kinetic energy 1/2 v^T M v [J].
    T_c_minus : float or (k,) array
        Effective kinetic energy T_c^- (constrained part, obstacle row included) [J];
        0 where the contact does not approach (``v_n <= 0``: no impact).
    T_a : float or (k,) array
        Admissible part T - T_c^- [J] (``T`` where ``v_n <= 0``).
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


_F8 = np.dtype(np.float64)
# T_c_at's result array (T, T_c, T_a, rank): one per thread, not one per call (an
# allocation is a few percent of the call; the compiled kernel runs without the GIL)
_TC_RESULT = threading.local()


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
    constraints : "auto", "all" or list of str
        How the active rows were chosen (:func:`choose_active_rows`).

    Notes
    -----
    Threads may share a setup: :meth:`T_c_at`, :meth:`evaluate` and
    :func:`~roverimpact.scenario.sweep_energy` give each thread its own Pinocchio ``data``
    (made on the thread's first call), and the threads get the results of one thread.
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
    constraints: Any = "auto"
    contacts: ContactsSpec = field(default_factory=ContactsSpec, repr=False)
    scenario: Scenario | None = field(default=None, repr=False)
    _cs: Any = field(default=None, repr=False, compare=False)
    _active: Any = field(default=None, repr=False, compare=False)
    _heading: Any = field(default=None, repr=False, compare=False)
    # what T_c_at needs at every call, made once: the shape of one q and the active rows
    _tc_args: Any = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self):
        # T_c_at hands v to a compiled kernel as it is: a C float64 array, whatever the
        # caller gave (a column of a matrix, V[:, i], made numba refuse it)
        v = self.v
        if not (isinstance(v, np.ndarray) and v.dtype == np.float64 and v.flags.c_contiguous):
            object.__setattr__(self, "v", np.ascontiguousarray(v, dtype=float))
        if self._cs is not None:
            rows = np.ascontiguousarray(self._active, dtype=np.int64)  # no copy (flatnonzero)
            object.__setattr__(self, "_tc_args", ((self.model.model.nq,), rows))

    def partition(self) -> ImpactEnergy:
        """T, T_c^-, T_a, m_eff along the normal and v_n of this setup.

        Warns (:class:`~roverimpact.exceptions.HeldRowsWarning`) when the model is a
        vehicle (floating or planar base) and the held rows make ``m_eff`` exceed its
        total mass."""
        en = _energy(self.M, self.A, self.v, self.obstacle_row)
        warn_if_jammed(self.model, en.m_eff, self.labels, self.obstacle_row)
        if pulling_applies(self.constraints, self.contacts):
            warn_if_pulling(self.M, self.A, self.v, self.labels, self.obstacle_row)
        return en

    def evaluate(self, q=None) -> tuple[np.ndarray, np.ndarray]:
        """Recompute ``(M, A)`` with the same active rows at ``q`` (default: this ``q``).

        ``q`` may be a batch ``(..., nq)``: then ``M`` is ``(..., n, n)`` and ``A``
        ``(..., m, n)``, computed in one pass (one Pinocchio call sequence per configuration,
        one compiled call for all rows), ready for a batched
        :func:`roverimpact.partition` (``partition(M, A, v)``).
        """
        q = self.q if q is None else np.asarray(q, dtype=float)
        M, A_all = self._cs.evaluate(q)
        return M, A_all.take(self._active, axis=-2)  # A_all[..., active, :], cheaper

    def T_c_at(self, q) -> float:
        r"""T_c^- [J] of this setup's active rows and velocity ``v`` at one configuration
        ``q`` (nq,): ``partition(*self.evaluate(q), self.v).T_c`` (to rounding) in one
        Pinocchio pass and one compiled call, with no ``M``, ``A`` or result object made
        in Python: for loops over single configurations (the 3-D rover in 9.5 us against
        15.5-17.4 us end to end in the quieter runs of ``benchmarks/bench_models.py`` on
        2026-11-29, a 2-core machine shared with other jobs; many configurations at once
        are faster batched, through :meth:`evaluate`). Its first call compiles that kernel
        (about 2 s on a fresh install).

        Raises
        ------
        ModelError
            ``q`` is not one configuration of the model.
        InputError
            ``q`` holds NaN or inf; what :func:`roverimpact.partition` raises for ``M``,
            ``A`` and ``v`` at ``q`` (a mass matrix that is not positive definite, ...).
        """
        q = np.asarray(q, _F8)  # a dtype object, not float: half the time
        shape, rows = self._tc_args
        if q.shape != shape:
            raise ModelError(f"q must have shape ({shape[0]},) for model {self.model.name!r} "
                             f"(T_c_at takes one configuration; evaluate() takes a batch), "
                             f"got {q.shape}")
        res = getattr(_TC_RESULT, "res", None)
        if res is None:
            res = _TC_RESULT.res = np.empty(4)
        if self._cs.partition_at(q, rows, self.v, RTOL, res):
            if not np.isfinite(q).all():
                raise InputError(f"q contains NaN or inf: {q}")
            M, A = self.evaluate(q)  # the same arrays: partition names the problem
            return float(partition(M, A, self.v, want_velocities=False).T_c)
        return float(res[1])

    @classmethod
    def from_scenario(cls, scenario: Scenario, *, base_dir: str | Path | None = None,
                      model=None) -> ImpactSetup:
        """Evaluate a scenario: model, q, v, M, A (active rows) -> :class:`ImpactSetup`.

        ``base_dir`` resolves a relative ``model.file`` (default: current directory;
        :func:`~roverimpact.scenario.load_scenario` makes it absolute already).
        ``model``: the :func:`scenario_model` of a scenario with the same ``[model]``,
        ``contacts.loops`` and ``[configuration]`` (:func:`model_key`), reused instead of
        building it again (the model is not modified).
        """
        scenario = as_scenario(scenario)
        mbm = scenario_model(scenario, base_dir) if model is None else model
        q = configuration(mbm, scenario.configuration)
        normals = None
        ts = scenario.terrain
        if ts is not None:
            from .ground import ground_on_terrain, make_terrain, pose_scenario

            terrain = make_terrain(ts, mbm, q)
            if ts.pose:
                q = pose_scenario(mbm, terrain, q, ts)
        v = velocity(mbm, q, scenario.velocity)
        if ts is not None:
            ground = [w.name for w in ground_wheels(mbm, scenario.obstacle, scenario.contacts)]
            follow = bool(scenario.velocity.u) and scenario.velocity.base_linear is None
            if follow and ts.pose:
                from .ground import driving_velocity

                v = driving_velocity(mbm, terrain, q, v, scenario.velocity.u, ts)
            normals, v = ground_on_terrain(mbm, terrain, q, v, ground=ground, spec=ts,
                                           follow=follow and not ts.pose,
                                           loop_rows=scenario.contacts.loop_closure)
        if scenario.contacts.loop_closure and mbm.loop_closure is not None:
            # declared loops' positions are checked where they are attached
            _check_loops(mbm, q, v, positions=not scenario.contacts.loops)
        setup = cls.from_state(mbm, q, v, obstacle=scenario.obstacle,
                               contacts=scenario.contacts, constraints=scenario.constraints,
                               scenario=scenario, ground_normals=normals)
        if ts is None:
            _warn_ground_gaps(mbm, q, scenario, setup._cs.data)
        return setup

    @classmethod
    def from_state(cls, mbm, q, v, *, obstacle: ObstacleSpec,
                   contacts: ContactsSpec = ContactsSpec(), constraints="auto",
                   also_hit: Sequence[str] = (), scenario: Scenario | None = None,
                   ground_normals: dict | None = None) -> ImpactSetup:
        """The impact of a model in a given state ``(q, v)``: candidate rows, active rows.

        Parameters
        ----------
        mbm : MultibodyModel
        q : (nq,) array_like
            Configuration.
        v : (nv,) array_like
            Generalized velocity just before impact.
        obstacle : ObstacleSpec or dict
            The impact contact and the face normal (``beta_deg`` relative to the heading
            of the base at ``q``, or ``normal``).
        contacts : ContactsSpec or dict
            Ground wheels, no-slip rows, locked joints, loop closure.
        constraints : "auto", "all", a pattern or list of patterns
            Which candidate rows are active (:func:`choose_active_rows`).
        also_hit : str or sequence of str
            Further wheels touching the same face at the same instant (a symmetric rover's
            two front wheels): their obstacle rows join the candidates.
        scenario : Scenario, optional
            Kept on the result (sweeps over beta re-use it).
        ground_normals : dict, optional
            ``{wheel: outward normal}`` of the ground under the ground wheels (terrain);
            default: the plane z = 0 under every wheel.
        """
        from ..models.kinematics import ConstraintSet

        # C arrays: T_c_at hands v to a compiled kernel as it is (a column of a matrix,
        # V[:, i], made numba refuse it)
        q = np.ascontiguousarray(q, dtype=float)
        v = np.ascontiguousarray(v, dtype=float)
        nq, nv = mbm.model.nq, mbm.model.nv
        if q.shape != (nq,):
            raise ModelError(f"q must have shape ({nq},) for model {mbm.name!r} (one "
                             f"configuration), got {q.shape}")
        if v.shape != (nv,):
            raise ModelError(f"v must have shape ({nv},) for model {mbm.name!r} (one "
                             f"velocity), got {v.shape}")
        if not np.isfinite(q).all():
            raise InputError(f"q contains NaN or inf: {q}")
        from .._schema import validate

        obstacle = validate(ObstacleSpec, obstacle, "obstacle")
        contacts = validate(ContactsSpec, contacts, "contacts")
        if isinstance(constraints, str) and constraints not in ("auto", "all"):
            constraints = [constraints]  # one pattern
        also_hit = [also_hit] if isinstance(also_hit, str) else list(also_hit)
        heading = base_heading(mbm, q)
        if obstacle.normal is not None:
            normal = np.asarray(obstacle.normal, float)
            normal = normal / np.linalg.norm(normal)
        else:
            normal = normal_from_beta(np.deg2rad(obstacle.beta_deg), heading)
        cons = candidate_constraints(mbm, obstacle, contacts, normal, also_hit=also_hit,
                                     ground_normals=ground_normals)
        cs = ConstraintSet(mbm, cons)
        M, A_all = cs.evaluate(q)
        labels = list(cs.labels)
        obstacle_all = len(labels) - 1
        _check_contact_rows(A_all, labels)
        active = choose_active_rows(constraints, labels, M, A_all, v,
                                    obstacle_row=obstacle_all, **friction_of(contacts))
        obstacle_row = int(np.flatnonzero(active == obstacle_all)[0])
        point = cons[-1].contact_point(cs.data, cs._fids[-1])
        return cls(
            M=M, A=A_all[active], labels=tuple(labels[i] for i in active), v=v, q=q,
            obstacle_row=obstacle_row, contact_point=point, normal=normal, model=mbm,
            candidate_labels=tuple(labels), constraints=constraints,
            contacts=contacts, scenario=scenario,
            _cs=cs, _active=active,
            _heading=heading,
        )


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


def make_model(spec: ModelSpec, base_dir: str | Path | None = None, *,
               loops: Sequence = (), configuration_spec: ConfigurationSpec | None = None):
    """The model of a scenario's ``[model]`` table (the one ``[model]`` builder).

    A built-in rover (``name`` with ``params`` and, for ``rocker_bogie``, ``preset``) or a
    URDF/MJCF file (``file``, relative to ``base_dir``, default the current directory) with
    its declared ``base`` and ``wheels``. ``loops`` (``[[contacts.loops]]``) join the
    model's loop closure; a ``distance`` loop without a length keeps the distance it has in
    ``configuration_spec`` (default: the nominal configuration).
    """
    from ..models import load_robot, rigid_body, rocker_bogie, rover2d
    from ..models.declare import FrameLoop, attach_frame_loops, declare_base, declare_wheels

    if spec.file is not None:
        f = spec.file
        if not is_example_robot_name(f) and not Path(f).is_absolute():
            f = str(Path(base_dir if base_dir is not None else Path.cwd()) / f)
        floating = spec.floating_base
        if spec.base is not None:  # fixed: no free-flyer added, an MJCF's free joints removed
            mjcf = f.lower().endswith((".xml", ".mjcf"))
            floating = {"floating": None if mjcf else True, "fixed": False}.get(spec.base.kind)
        mbm = load_robot(f, floating_base=floating)
        if spec.base is not None:
            declare_base(mbm, spec.base.kind, spec.base.joints)
        if spec.wheels:
            declare_wheels(mbm, spec.wheels)
    elif spec.name == "rover2d":
        mbm = rover2d(**spec.params)
    elif spec.name == "rigid_body":
        mbm = rigid_body(**spec.params)
    else:
        mbm = rocker_bogie(spec.preset, **spec.params)
    if loops:
        q_ref = configuration(mbm, configuration_spec or ConfigurationSpec())
        attach_frame_loops(mbm, [FrameLoop(lp.name, lp.kind, lp.frame_a, tuple(lp.point_a),
                                           lp.frame_b, tuple(lp.point_b), lp.length)
                                 for lp in loops], q_ref)
    return mbm


def _check_contact_rows(A, labels) -> None:
    """One ConfigError naming the contacts whose normal row is zero: the point cannot move
    along the normal at all (a body fixed to the world, a normal out of a planar model's
    plane), so there is no impact to analyse there (the partition said "unilateral row 1
    is all zeros" without naming it). ``A`` (m, n), or (k, m, n) for k states: those of
    the first state that has such rows."""
    norms = np.linalg.norm(A, axis=-1)
    norms = norms.reshape(-1, norms.shape[-1]) if norms.ndim > 1 else norms[None]
    scale = np.maximum(norms.max(axis=-1, initial=0.0), 1e-300)
    normal = np.array([lab.endswith(":normal") for lab in labels], dtype=bool)
    zero = normal & ~(norms > 1e-12 * scale[:, None])
    states = np.flatnonzero(zero.any(axis=-1))
    if states.size:
        dead = [lab for lab, z in zip(labels, zero[states[0]], strict=True) if z]
        raise ConfigError(
            f"the contact rows {dead} are zero: the point cannot move along its normal at "
            "all (a body fixed to the world, or a normal out of the plane of a planar "
            "model); move the contact to a moving body, or give a normal it can move along")


def _loop_joints(mbm, row) -> list[str]:
    """Names of the joints a loop-closure row ``row`` (nv,) involves."""
    model = mbm.model
    cols = set(np.flatnonzero(np.abs(row) > 1e-12 * max(np.abs(row).max(), 1e-300)).tolist())
    return [model.names[j] for j in range(1, model.njoints)
            if cols & set(range(model.joints[j].idx_v,
                                model.joints[j].idx_v + model.joints[j].nv))]


#: how far a ground wheel may be off the plane z = 0, in wheel radii: a compliant ground's
#: deflection (a MuJoCo state's 0.3 mm under a 0.1 m wheel) is touching
GROUND_GAP_TOL = 0.01


def _warn_ground_gaps(mbm, q, scenario: Scenario, data) -> None:
    """A :class:`~roverimpact.exceptions.GroundGapWarning` naming the ground wheels whose
    lowest rim point is more than :data:`GROUND_GAP_TOL` radii off z = 0 at ``q`` (a base
    left at z = 0, a suspension joint set in [configuration]): their ground rows would hold
    a wheel in the air or in the ground."""
    import warnings

    import pinocchio as pin

    wheels = ground_wheels(mbm, scenario.obstacle, scenario.contacts)
    if not wheels:
        return
    model = mbm.model  # ``data``: a Data of this model to use (the setup's, no new one)
    pin.framesForwardKinematics(model, data, np.asarray(q, float))
    gaps = {}
    for w in wheels:
        oMf = data.oMf[model.getFrameId(w.frame)]
        a = oMf.rotation @ np.asarray(w.axis, float)
        a_z = a[2] / np.linalg.norm(a)
        gap = oMf.translation[2] - w.radius * np.sqrt(max(0.0, 1.0 - a_z * a_z))
        if abs(gap) > GROUND_GAP_TOL * w.radius:
            gaps[w.name] = float(gap)
    if gaps:
        off = ", ".join(f"{name!r} {gap_text(g)}" for name, g in gaps.items())
        warnings.warn(GroundGapWarning(
            f"ground wheels off the ground z = 0 in [configuration]: {off}; "
            f"{GROUND_GAP_ADVICE}", gaps=gaps), stacklevel=3)


#: what a :class:`~roverimpact.exceptions.GroundGapWarning` advises
GROUND_GAP_ADVICE = (
    "their ground rows hold them as if they touched. Set configuration.base (z, roll, "
    "pitch) and the joints so that they touch, leave them out of contacts.ground_wheels, or "
    "add [terrain] (plane = {point = [0, 0, 0], normal = [0, 0, 1]}): terrain.pose places "
    "the rover on it")


def gap_text(gap: float) -> str:
    """A ground wheel's gap [m] as a :class:`~roverimpact.exceptions.GroundGapWarning` says
    it: ``"0.062 m above"`` (``"below"`` for a negative gap)."""
    return f"{abs(gap):.3g} m {'above' if gap > 0 else 'below'}"


def check_states(mbm, scenario: Scenario, Q, V, A, labels, data) -> None:
    """What :meth:`ImpactSetup.from_scenario` checks of a scenario without terrain at its
    state, for k states at once (a block of scenarios that differ in joint values, rates,
    speed and angle: :func:`~roverimpact.scenario.block.state_block`): ``Q`` (k, nq),
    ``V`` (k, nv) and candidate rows ``A`` (k, m, nv) (``labels``). A contact row that
    is zero, a built-in loop opened or driven apart raise the error of the first state
    that has it (the same checks as one state's, over the arrays); ground wheels off the
    ground are a :class:`~roverimpact.exceptions.GroundGapWarning` per state. ``data``: a
    Data of the model."""
    _check_contact_rows(A, labels)
    loop = mbm.loop_closure
    if scenario.contacts.loop_closure and loop is not None:
        positions = not scenario.contacts.loops
        phi, J = None, None
        if getattr(loop, "constant_jacobian", False):
            try:  # the built-in closures take a batch; another is checked state by state
                phi, J = loop(Q)
            except (TypeError, ValueError, IndexError):
                phi = None
            if phi is not None and np.shape(phi) != (len(Q), np.shape(J)[0]):
                phi = None
        if phi is None:
            for q, v in zip(Q, V, strict=True):
                _check_loops(mbm, q, v, positions=positions)
        else:
            if positions:
                check_loop_closed(mbm, phi, J)
            _check_loop_rates(mbm, J, V)
    if ground_wheels(mbm, scenario.obstacle, scenario.contacts):
        for q in Q:
            _warn_ground_gaps(mbm, q, scenario, data)


def _check_loops(mbm, q, v, *, positions: bool) -> None:
    """:func:`check_loop_closed` (if ``positions``) and :func:`_check_loop_rates` on one
    evaluation of the loop-closure residual and rows."""
    phi, J = mbm.loop_closure(q)
    if positions:
        check_loop_closed(mbm, phi, J)
    _check_loop_rates(mbm, J, v)


def check_loop_closed(mbm, phi, J, atol: float = 1e-9) -> None:
    """Refuse a configuration whose joint values open a built-in closed loop (the
    rocker-bogie's differential: one rocker turned, the other not), named by loop row;
    the loop-closure rows would otherwise hold a mechanism that cannot be assembled.
    ``phi, J``: the loop closure's residual and rows at that configuration; ``phi`` (k, r)
    for k configurations of constant rows ``J`` (r, nv): the first that opens a loop."""
    phi = np.asarray(phi, dtype=float)
    phi = phi.reshape(-1, phi.shape[-1]) if phi.ndim > 1 else phi[None]
    bad = np.abs(phi) > atol
    states = np.flatnonzero(bad.any(axis=-1))
    if states.size:
        phi = phi[states[0]]
        i = int(np.flatnonzero(bad[states[0]])[0])
        name = mbm.loop_names[i]
        hint = ("a mimic joint's value is its leader's times the multiplier, plus the offset"
                if name.startswith("mimic:") else
                "a MuJoCo tendon equality holds sum(coef * joint value) of its fixed tendon "
                "at its value at qpos0 plus polycoef c0 (c1 times the change of tendon2's)"
                if name.startswith("tendon:") else
                "the rocker-bogie's differential turns its rockers by opposite angles")
        raise ConfigError(
            f"configuration: the joint values open the loop {name!r} by "
            f"{abs(float(phi[i])):.3g} (rad or m); its joints {_loop_joints(mbm, J[i])} move "
            f"together: set them all, to values that close it ({hint})")


def _check_loop_rates(mbm, J, v, rtol: float = 1e-6) -> None:
    """Refuse joint rates that pull a closed loop apart (``J_loop v`` not 0, ``J`` the
    loop-closure rows): the state of a mechanism other than the one declared. Named by
    loop row. ``v`` (nv,), or (k, nv) for k states: the first that does."""
    v = np.asarray(v, dtype=float)
    v = v.reshape(-1, v.shape[-1]) if v.ndim > 1 else v[None]
    rates = v @ J.T
    scale = np.linalg.norm(J, axis=1) * np.linalg.norm(v, axis=1)[:, None]
    bad = np.abs(rates) > rtol * scale + 1e-12
    states = np.flatnonzero(bad.any(axis=-1))
    if states.size:
        rate = rates[states[0]]
        i = int(np.flatnonzero(bad[states[0]])[0])
        raise ConfigError(
            f"velocity: the joint rates open the loop {mbm.loop_names[i]!r} at "
            f"{abs(rate[i]):.3g} m/s; the rates of a closed loop must move it as one "
            "mechanism (e.g. from the loop's own velocity analysis, or a MuJoCo state)")


def model_key(scenario: Scenario) -> str:
    """What :func:`scenario_model` depends on: scenarios with the same key have the same
    model. That is ``[model]`` and ``contacts.loops``, and ``[configuration]`` only where
    there are declared loops (a ``distance`` loop without a length keeps the distance it
    has there): a configuration sweep of one model file builds its model once."""
    import json

    loops = scenario.contacts.loops
    data = {"model": scenario.model.model_dump(mode="json"),
            "loops": [lp.model_dump(mode="json") for lp in loops]}
    if loops:
        data["configuration"] = scenario.configuration.model_dump(mode="json")
    return json.dumps(data, sort_keys=True)


def scenario_model(scenario: Scenario, base_dir: str | Path | None = None):
    """:func:`make_model` of a whole scenario (its ``[model]``, loops and configuration)."""
    return make_model(scenario.model, base_dir, loops=scenario.contacts.loops,
                      configuration_spec=scenario.configuration)


def _joint(model, name: str, what: str):
    if not model.existJointName(name):
        raise ConfigError(f"{what}: unknown joint {name!r}; joints: {list(model.names[1:])}")
    return model.joints[model.getJointId(name)]


def _base_quaternions(base: BaseSpec, quat: np.ndarray) -> np.ndarray:
    """The base quaternions (..., 4) (x y z w) with the roll, pitch and yaw that ``base``
    gives replaced, the others kept from ``quat`` (the nominal orientation: a file's own
    pose of its free body)."""
    import pinocchio as pin

    given = (base.roll_deg, base.pitch_deg, base.yaw_deg)
    # once per distinct nominal orientation: a model family's k cases mostly share one
    flat, back = np.unique(np.asarray(quat, dtype=float).reshape(-1, 4), axis=0,
                           return_inverse=True)
    out = np.empty_like(flat)
    for i, xyzw in enumerate(flat):
        rpy = pin.rpy.matrixToRpy(pin.Quaternion(xyzw).normalized().toRotationMatrix())
        rpy = [np.deg2rad(g) if g is not None else r for g, r in zip(given, rpy, strict=True)]
        out[i] = pin.Quaternion(pin.rpy.rpyToMatrix(*rpy)).coeffs()
    return out[back.reshape(-1)].reshape(np.shape(quat))


def base_slices(mbm):
    """``(kind, q indices, v indices)`` of the base coordinates (kind: ``"floating"``,
    ``"planar"`` or ``"fixed"``; one index per base joint)."""
    from ..models.declare import base_info

    info = base_info(mbm)
    model = mbm.model
    js = [model.joints[model.getJointId(n)] for n in info.joints]
    return info.kind, [j.idx_q for j in js], [j.idx_v for j in js]


def _set_multi(jm, name: str, values, what: str, kind: str):
    """A multi-DoF joint's coordinates from MuJoCo's order (positions or rates)."""
    vals = np.asarray(values, dtype=float).reshape(-1)
    short = jm.shortname().removeprefix("JointModel")
    n = jm.nq if kind == "q" else jm.nv
    if vals.size != n or not np.all(np.isfinite(vals)):
        raise ConfigError(f"{what}: joint {name!r} ({short}) takes {n} finite values, got "
                          f"{vals.tolist()}")
    if kind == "q" and short in ("FreeFlyer", "Spherical"):
        quat = vals[-4:]                       # MuJoCo: w x y z; Pinocchio: x y z w
        if not np.linalg.norm(quat) > 1e-9:
            raise ConfigError(f"{what}: joint {name!r}: the quaternion is zero")
        vals = np.concatenate([vals[:-4], quat[1:], quat[:1]]) / np.r_[
            np.ones(vals.size - 4), np.full(4, np.linalg.norm(quat))]
    return vals


def configuration(mbm, spec: ConfigurationSpec, q_nominal=None, *, joints=None
                  ) -> np.ndarray:
    """The configuration ``q`` of ``[configuration]``: the model's nominal one, the base
    pose, then joint values by name (1-DoF: a number, continuous and mimic joints included;
    free and ball joints: a list in MuJoCo's order).

    ``q_nominal`` (k, nq): the nominal configurations of a family of models
    (:class:`~roverimpact.models.family.FamilyNumbers`) in place of the model's; then
    ``q`` is (k, nq). ``joints``: the joint values in place of ``spec.joints``, where a
    1-DoF joint's value may be an array (k,) of values, one per configuration (a block of
    scenarios that differ in them: :func:`~roverimpact.scenario.block.state_block`); then
    ``q`` is (k, nq)."""
    import pinocchio as pin

    from ..models.joints import set_joint_value

    model = mbm.model
    if q_nominal is not None:
        q = np.array(q_nominal, dtype=float)
    else:
        q = np.array(mbm.params.get("q_nominal", pin.neutral(model)), dtype=float)
        if q.shape != (model.nq,):
            q = pin.neutral(model)
    joints = spec.joints if joints is None else joints
    members = _members(joints)
    if members is not None and q.ndim == 1:
        q = np.array(np.broadcast_to(q, (members, model.nq)))
    kind, iq, _ = base_slices(mbm)
    b = spec.base
    if kind == "planar":
        if b.y not in (None, 0.0) or b.roll_deg or b.yaw_deg:
            raise ConfigError("configuration.base: a planar base has x, z, pitch_deg only")
        if b.x is not None:
            q[..., iq[0]] = b.x
        if b.z is not None:
            q[..., iq[1]] = b.z
        if b.pitch_deg is not None:
            q[..., iq[2]] = np.deg2rad(b.pitch_deg)
    elif kind == "floating":
        i0 = iq[0]
        for i, val in enumerate((b.x, b.y, b.z)):
            if val is not None:
                q[..., i0 + i] = val
        if (b.roll_deg, b.pitch_deg, b.yaw_deg) != (None, None, None):
            q[..., i0 + 3:i0 + 7] = _base_quaternions(b, q[..., i0 + 3:i0 + 7])
    elif b != BaseSpec():
        raise ConfigError("configuration.base: this model has a fixed base; remove [base] or "
                          "declare [model.base] kind = 'floating'")
    for name, val in joints.items():
        if isinstance(val, list):
            j = _joint(model, name, "configuration.joints")
            if j.nq == 1 or j.nv == 1:
                raise ConfigError(f"configuration.joints: joint {name!r} has one degree of "
                                  "freedom: give one number")
            q[..., j.idx_q:j.idx_q + j.nq] = _set_multi(j, name, val, "configuration.joints",
                                                        "q")
        else:
            q = _as_config_error(set_joint_value, mbm, q, name, val,
                                 what="configuration.joints")
    _check_kept(mbm, joints, q, "configuration.joints")
    return q


def _members(values: Mapping) -> int | None:
    """The number of members of joint values or rates given as arrays (k,) (all of one
    length), None if every value is a number or a list."""
    sizes = {len(val) for val in values.values() if isinstance(val, np.ndarray)}
    if len(sizes) > 1:
        raise ValueError(f"joint values of different lengths: {sorted(sizes)}")
    return sizes.pop() if sizes else None


def _check_kept(mbm, given: dict, x, what: str) -> None:
    """Refuse joint values (or rates) that a later one changed through a coupling (a
    mimic, a MuJoCo joint equality): ``ja = 0.3`` and ``jb = 0.3`` with ``jb = 0.2 - ja``
    became ja = -0.1, silently. A value may be an array (k,) over the rows of ``x``
    (k, n); the first row changed is named."""
    from ..models.joints import joint_coordinate, joint_value

    for name, val in given.items():
        if isinstance(val, list):
            continue
        jc = joint_coordinate(mbm, name)
        got = (joint_value(mbm, x, name) if what.startswith("configuration")
               else x[..., jc.idx_v])
        d = np.asarray(got, dtype=float) - val
        if jc.kind == "continuous" and what.startswith("configuration"):
            d = (d + np.pi) % (2.0 * np.pi) - np.pi
        bad = np.abs(d) > 1e-9 * np.maximum(1.0, np.abs(val))
        if np.any(bad):
            i = int(np.flatnonzero(np.ravel(bad))[0])
            given_i = float(np.ravel(np.broadcast_to(val, np.shape(bad)))[i])
            got_i = float(np.ravel(np.broadcast_to(got, np.shape(bad)))[i])
            raise ConfigError(
                f"{what}: {name} = {given_i:g} was changed to {got_i:.6g} by "
                "another joint set after it through their coupling (a mimic joint or a "
                "joint equality): give one joint of a coupling, or values that agree")


def _as_config_error(fn, *args, **kwargs):
    """A joint the scenario names but the model lacks is the scenario's error."""
    try:
        return fn(*args, **kwargs)
    except ModelError as exc:
        raise ConfigError(str(exc)) from None


def base_heading(mbm, q) -> np.ndarray:
    """Driving direction of the base at ``q``: its x axis made horizontal (floating base),
    else the world x axis."""
    import pinocchio as pin

    kind, iq, _ = base_slices(mbm)
    if kind == "floating":
        i0 = iq[0]
        R = pin.Quaternion(np.asarray(q[i0 + 3:i0 + 7])).normalized().toRotationMatrix()
        h = R[:, 0].copy()
        h[2] = 0.0
        if np.linalg.norm(h) < 1e-9:
            raise ConfigError("the base points straight up or down: beta has no heading")
        return h / np.linalg.norm(h)
    return np.array([1.0, 0.0, 0.0])


def _spin_joint(mbm, wheel) -> str | None:
    if wheel.spin is not None:
        return wheel.spin
    return wheel.frame if mbm.model.existJointName(wheel.frame) else None


def _rolling_signs(mbm) -> dict[str, float]:
    """``{spin joint: +1 or -1}`` for the wheels of ``mbm``: the sign of the spin rate
    ``u / r`` that rolls a wheel on that hinge forward along the base's heading (its x
    axis) on the ground below it (the base's z axis up). At a unit rate the wheel turns at
    ``w`` and the rim point below its centre moves at ``-r w x z``, which must cancel the
    drive: forward when ``(w x z) . x = w_y > 0`` in the base's axes (a hinge about +y),
    backward for a hinge written about -y. The hinge's axis is taken through the joint
    placements from the base at zero joint angles (a suspension would have to turn by
    more than 90 degrees to flip it); 1 for a joint that is not a plain hinge. Computed
    once per model."""
    signs = mbm.__dict__.get("_rolling_signs")
    if signs is not None:
        return signs
    from ..models.declare import base_info, placed_axis

    model = mbm.model
    base = base_info(mbm).joints
    stop = model.getJointId(base[-1]) if base else 0
    signs = {}
    for w in mbm.wheels:
        spin = _spin_joint(mbm, w)
        if spin is None or spin in signs:
            continue
        j = model.getJointId(spin)
        a = placed_axis(model, j, stop) if j < model.njoints and model.joints[j].nv == 1 \
            else None
        signs[spin] = -1.0 if a is not None and a[1] < -1e-9 else 1.0
    mbm.__dict__["_rolling_signs"] = signs
    return signs


def velocity(mbm, q, spec: VelocitySpec, *, u=None, wheel_radius=None, joints=None
             ) -> np.ndarray:
    """The velocity ``v`` of ``[velocity]``: the base driving at ``u`` with rolling wheels
    (or ``base_linear``, ``base_angular``), then joint rates by name (1-DoF: a number; free
    and ball joints: a list in MuJoCo's order).

    A batch (a family of models, or k configurations, at one base pose ``q``): ``u`` (k,)
    speeds in place of ``spec.u``, ``wheel_radius`` (k, n_wheels) radii in place of the
    wheels', ``joints`` rates in place of ``spec.joints`` where a 1-DoF joint's rate may
    be an array (k,); then ``v`` is (k, nv)."""
    import pinocchio as pin

    from ..models.joints import set_joint_rate

    model = mbm.model
    joints = spec.joints if joints is None else joints
    u = np.asarray(spec.u if u is None else u, dtype=float)
    members = _members(joints)
    if members is not None and u.ndim == 0:
        u = np.full(members, float(u))
    v = np.zeros((*u.shape, model.nv))
    kind, iq, iv = base_slices(mbm)
    heading = base_heading(mbm, q)
    lin = (u[..., None] * heading if spec.base_linear is None
           else np.asarray(spec.base_linear, float))
    ang = np.zeros(3) if spec.base_angular is None else np.asarray(spec.base_angular, float)
    if kind == "planar":
        if np.any(np.abs(lin[..., 1]) > 0) or abs(ang[0]) > 0 or abs(ang[2]) > 0:
            raise ConfigError("velocity: a planar base moves in x-z with pitch rate about y "
                              "only (base_linear y and base_angular x, z must be 0)")
        v[..., iv[0]], v[..., iv[1]], v[..., iv[2]] = lin[..., 0], lin[..., 2], ang[1]
    elif kind == "floating":
        i0, v0 = iq[0], iv[0]
        R = pin.Quaternion(np.asarray(q[i0 + 3:i0 + 7])).normalized().toRotationMatrix()
        v[..., v0:v0 + 3], v[..., v0 + 3:v0 + 6] = lin @ R, ang @ R
    elif np.any(u != 0) or spec.base_linear is not None or spec.base_angular is not None:
        raise ConfigError("velocity: u/base_linear/base_angular need a moving base; this model "
                          "has a fixed base (set joint rates in velocity.joints)")
    if np.any(u != 0):
        signs = _rolling_signs(mbm)
        for k, w in enumerate(mbm.wheels):
            spin = _spin_joint(mbm, w)
            if spin is not None:
                r = w.radius if wheel_radius is None else wheel_radius[..., k]
                v = _as_config_error(set_joint_rate, mbm, v, spin, signs[spin] * u / r,
                                     what=f"wheel {w.name!r}")
    for name, val in joints.items():
        if isinstance(val, list):
            j = _joint(model, name, "velocity.joints")
            if j.nv == 1:
                raise ConfigError(f"velocity.joints: joint {name!r} has one degree of freedom: "
                                  "give one number")
            rates = _set_multi(j, name, val, "velocity.joints", "v")
            if j.shortname() == "JointModelFreeFlyer":  # MuJoCo: world linear, body angular
                R = pin.Quaternion(np.asarray(q[j.idx_q + 3:j.idx_q + 7])).normalized() \
                    .toRotationMatrix()
                rates = np.concatenate([R.T @ rates[:3], rates[3:]])
            v[..., j.idx_v:j.idx_v + j.nv] = rates
        else:
            v = _as_config_error(set_joint_rate, mbm, v, name, val, what="velocity.joints")
    _check_kept(mbm, joints, v, "velocity.joints")
    return v


def _wheel(mbm, name: str, what: str):
    for w in mbm.wheels:
        if w.name == name:
            return w
    raise ConfigError(f"{what}: unknown wheel {name!r}; wheels: {[w.name for w in mbm.wheels]}")


def ground_wheels(mbm, obstacle: ObstacleSpec, contacts: ContactsSpec,
                  also_hit: Sequence[str] = ()) -> list:
    """The wheels on the ground (``contacts.ground_wheels``; ``"others"``: every wheel but
    the one hitting the obstacle and those in ``also_hit``)."""
    if contacts.ground_wheels == "others":
        return [w for w in mbm.wheels if w.name != obstacle.wheel and w.name not in also_hit]
    return [_wheel(mbm, n, "contacts.ground_wheels") for n in contacts.ground_wheels]


def candidate_constraints(mbm, obstacle: ObstacleSpec, contacts: ContactsSpec,
                          normal: np.ndarray, *, also_hit: Sequence[str] = (),
                          ground_normals: dict | None = None) -> list:
    """The candidate constraints of an impact, the obstacle contact last.

    Ground contacts (:func:`ground_wheels`; on the plane z = 0 or, with
    ``ground_normals``, a plane of that normal through each wheel's contact), the loop
    closure, locked joints, the obstacle rows of the ``also_hit`` wheels, then the
    obstacle contact.
    """
    from ..models.constraints import GroundContact, LockedJoint, LoopClosure, PointContact
    from ..models.declare import warn_site_twin

    cons = []
    obs = obstacle
    cw = contacts
    planar = bool(mbm.params.get("planar", False))
    for w in ground_wheels(mbm, obs, cw, also_hit):
        n = (0.0, 0.0, 1.0) if ground_normals is None else tuple(
            float(x) for x in ground_normals[w.name])
        cons.append(GroundContact(w, normal=n, noslip=cw.ground in ("noslip", "coulomb"),
                                  planar=planar))
    if cw.loop_closure and mbm.loop_closure is not None:
        cons.append(LoopClosure(tuple(mbm.loop_names)))
    for jn in cw.locked:
        _joint(mbm.model, jn, "contacts.locked")
        cons.append(LockedJoint(jn))
    planar = bool(mbm.params.get("planar", False)) or base_slices(mbm)[0] == "planar"
    for k, pt in enumerate(cw.points):
        cons.extend(_point_contacts(mbm, pt, k, planar))
    n = tuple(float(x) for x in normal)
    for name in also_hit:
        w = _wheel(mbm, name, "obstacle")
        cons.append(PointContact(w.name, w.frame, n, wheel=w))
    if obs.wheel is not None:
        w = _wheel(mbm, obs.wheel, "obstacle.wheel")
        cons.append(PointContact(w.name, w.frame, n, wheel=w))
    else:
        if not mbm.model.existFrame(obs.frame):
            names = sorted({f.name for f in mbm.model.frames})
            raise ConfigError(f"obstacle.frame: unknown frame/body {obs.frame!r}; frames: {names}")
        warn_site_twin(mbm, obs.frame, "obstacle.frame")
        cons.append(PointContact(obs.frame, obs.frame, n, point=tuple(obs.point)))
    return cons


def active_mask(spec, labels, M, A, v, *, obstacle_row: int, friction: str = "frictionless",
                mu=None) -> np.ndarray:
    """Which rows of ``A`` are active: the ONE place where the active set is chosen.

    Parameters
    ----------
    spec : "auto", "all" or list of str
        ``"auto"``: the rows that hold through the impact (unilateral LCP, see
        :func:`holding_rows`). ``"all"``: every candidate row. A list: rows whose label
        matches an entry (exact or ``fnmatch`` pattern); every entry must match at least
        one candidate.
    labels : sequence of str
        Labels of all candidate rows (rows of ``A``).
    M : (n, n) array_like
    A : (..., m, n) array_like
        Candidate rows; a leading batch axis (e.g. over beta) is allowed.
    v : (n,) array_like
    obstacle_row : int
        The obstacle row, always active.
    friction, mu
        How ``"auto"`` treats the no-slip rows (:func:`holding_rows`).

    Returns
    -------
    (..., m) bool ndarray
    """
    labels = list(labels)
    A = np.asarray(A, dtype=float)
    if spec == "auto":  # the contacts that hold through the impact (unilateral LCP)
        return holding_rows(labels, M, A, v, obstacle_row=obstacle_row, friction=friction,
                            mu=mu)
    keep = np.zeros(len(labels), dtype=bool)
    if spec == "all":
        keep[:] = True
    else:
        for pat in spec:
            hit = [i for i, lab in enumerate(labels) if lab == pat or fnmatch.fnmatchcase(lab, pat)]
            if not hit:
                raise ConfigError(f"constraints: {pat!r} matches no candidate row; candidates: "
                                  f"{labels}")
            keep[hit] = True
    keep[obstacle_row] = True
    return np.broadcast_to(keep, (*A.shape[:-2], len(labels))).copy()


def _point_contacts(mbm, pt, k: int, planar: bool) -> list:
    """The rows of a ``[[contacts.points]]`` contact: its normal, and with ``tangential``
    its no-slip rows (two world directions orthogonal to the normal; one in the x-z plane
    for a planar model)."""
    from ..models.constraints import PointContact
    from ..models.declare import warn_site_twin

    if not mbm.model.existFrame(pt.frame):
        names = sorted({f.name for f in mbm.model.frames if f.name != "universe"})
        raise ConfigError(f"contacts.points[{k}]: unknown frame {pt.frame!r}; frames: {names}")
    warn_site_twin(mbm, pt.frame, f"contacts.points[{k}].frame")
    name = pt.name or f"{pt.frame}{k}"
    n = np.asarray(pt.normal, float)
    n = n / np.linalg.norm(n)
    point = tuple(float(x) for x in pt.point)
    out = [PointContact(name, pt.frame, tuple(n), point=point, label=f"point:{name}:normal")]
    if pt.tangential:
        if planar:
            t = np.cross([0.0, 1.0, 0.0], n)
            dirs = [("long", t / np.linalg.norm(t))]
        else:
            e = np.eye(3)[int(np.argmin(np.abs(n)))]
            t1 = np.cross(e, n)
            t1 /= np.linalg.norm(t1)
            dirs = [("long", t1), ("lat", np.cross(n, t1))]
        out += [PointContact(name, pt.frame, tuple(float(x) for x in d), point=point,
                             label=f"point:{name}:{tag}") for tag, d in dirs]
    return out


def choose_active_rows(spec, labels, M, A, v, *, obstacle_row: int, **friction
                       ) -> np.ndarray:
    """Indices of the active rows of one candidate Jacobian ``A`` (m, n): the rows
    :func:`active_mask` keeps, increasing."""
    return np.flatnonzero(active_mask(spec, labels, M, A, v, obstacle_row=obstacle_row,
                                      **friction))


def holding_rows(labels, M, A, v, *, obstacle_row: int, friction: str = "frictionless",
                 mu=None, restitution=0.0, facets: int = 8) -> np.ndarray:
    """Rows of an impact's candidate Jacobian that hold through the impact (``"auto"``).

    Unilateral rows (labels ``"<contact>:normal"``: ground contacts, declared points, the
    obstacle) and bilateral rows (any other label: loop closures, locked joints); the
    no-slip rows of a contact are ``"<contact>:long"`` and ``":lat"``. The impact problem
    decides which contacts hold, with

    - ``friction="frictionless"``: :func:`roverimpact.active_set`; no-slip rows are not
      held (the wheels slide freely along the ground);
    - ``"no-slip"``: the same problem, and a contact that holds keeps its no-slip rows as
      bilateral rows (wheels that cannot slide);
    - ``"coulomb"``: the impact problem with Coulomb friction ``mu`` at every contact with
      no-slip rows (:func:`roverimpact.frictional.frictional_active_set`): a sticking
      contact holds its normal and no-slip rows, a sliding one its normal row.

    The obstacle row is always kept.

    Parameters
    ----------
    labels : sequence of str
        One label per row of ``A`` (see :mod:`roverimpact.models.constraints`).
    M : (n, n) array_like
    A : (..., m, n) array_like
        Candidate rows; a leading batch axis (e.g. over beta) is allowed.
    v : (n,) array_like
    obstacle_row : int
        Index of the obstacle row in ``A``.
    friction : {"frictionless", "no-slip", "coulomb"}
    mu : float, (k,) array_like or dict, optional
        Friction coefficient (``"coulomb"``): one value, one per unilateral row, or
        ``{contact: mu}`` by contact name (``"ground:left_front"``, ``"point:p0"``, and
        ``"default"``); ``inf`` = no slip.
    facets : int
        Friction directions of a 3-D contact (the polyhedral cone).

    Returns
    -------
    (..., m) bool ndarray
        ``True`` for the rows to hold when computing T_c^-.
    """
    labels = tuple(labels)
    A = np.asarray(A, dtype=float)
    if A.ndim < 2 or A.shape[-2] != len(labels):
        raise InputError(f"{len(labels)} labels for A of shape {A.shape}")
    if not 0 <= int(obstacle_row) < len(labels):
        raise InputError(f"obstacle_row must index a row of A (0..{len(labels) - 1}), got "
                         f"{obstacle_row}")
    if friction not in ("frictionless", "no-slip", "coulomb"):
        raise InputError(f"friction must be one of 'frictionless', 'no-slip', 'coulomb', got "
                         f"{friction!r}")
    uni, bil, tangent, source = _row_roles(labels, int(obstacle_row))
    keep = np.zeros((*A.shape[:-2], len(labels)), dtype=bool)
    B = A[..., bil, :] if len(bil) else None
    if friction == "coulomb":
        mu = _mu_of(mu, labels, uni)
    if friction == "coulomb" and len(tangent):
        from ..frictional import frictional_active_set

        contacts = [i for i in uni]
        slots = {c: [t for t, s_ in zip(tangent, source, strict=True) if s_ == c]
                 for c in contacts}
        tm = max(1, max(len(x) for x in slots.values()))
        Tg = np.zeros((*A.shape[:-2], len(contacts), tm, A.shape[-1]))
        ntan = np.zeros(len(contacts), dtype=np.int64)
        for ci, c in enumerate(contacts):
            for ti, t in enumerate(slots[c]):
                Tg[..., ci, ti, :] = A[..., t, :]
            ntan[ci] = len(slots[c])
        hold_n, hold_t = frictional_active_set(
            M, v, A[..., uni, :], Tg, mu, B, ntan=ntan, restitution=restitution,
            facets=facets)
        keep[..., uni] = hold_n
        for ci, c in enumerate(contacts):
            for ti, t in enumerate(slots[c]):
                keep[..., t] = hold_t[..., ci, ti]
    else:
        keep[..., uni] = active_set(M, v, A[..., uni, :], B, restitution=restitution)
        if friction == "no-slip":
            keep[..., tangent] = keep[..., source]
    keep[..., bil] = True
    keep[..., obstacle_row] = True
    return keep


_FRICTION = {"normal": "frictionless", "noslip": "no-slip", "coulomb": "coulomb"}


def friction_of(contacts: ContactsSpec) -> dict:
    """``friction`` and ``mu`` of :func:`holding_rows` from ``[contacts]``."""
    return {"friction": _FRICTION[contacts.ground], "mu": contacts.mu}


def _mu_of(mu, labels, uni) -> np.ndarray:
    """One friction coefficient per unilateral row, each at most ``MU_MAX`` or inf."""
    mu = _mu_values(mu, labels, uni)
    from ..frictional import MU_MAX

    big = np.isfinite(mu) & (mu > MU_MAX)
    if big.any():
        i = int(np.argmax(big))
        raise ConfigError(f"contacts.mu of {labels[uni[i]].rpartition(':')[0]} is "
                          f"{float(mu[i]):g}: give at most {MU_MAX:g}, or inf for a contact "
                          "that cannot slip (a larger finite mu is beyond float64 in the "
                          "friction cone)")
    return mu


def _mu_values(mu, labels, uni) -> np.ndarray:
    """One friction coefficient per unilateral row (by contact name for a mapping)."""
    if mu is None:
        raise ConfigError('contacts.ground = "coulomb" needs contacts.mu, the friction '
                          "coefficient")
    if isinstance(mu, dict):
        names = [labels[i].rpartition(":")[0] for i in uni]
        unknown = sorted(set(mu) - set(names) - {"default"})
        # a contact without tangent rows (a scenario's obstacle: its row is the normal) has
        # no use for a mu: it may be given, it is not needed
        rubbing = {lab.rpartition(":")[0] for lab in labels if lab.endswith((":long", ":lat"))}
        missing = [nm for nm in names if nm not in mu and nm in rubbing
                   ] if "default" not in mu else []
        if unknown or missing:
            raise ConfigError(f"contacts.mu: give a value per contact {names} (or a 'default')"
                              + (f"; unknown {unknown}" if unknown else "")
                              + (f"; missing {missing}" if missing else ""))
        return np.array([float(mu.get(nm, mu.get("default", 0.0))) for nm in names])
    mu = np.asarray(mu, dtype=float)
    if mu.ndim == 0:
        return np.full(len(uni), float(mu))
    if mu.shape != (len(uni),):
        raise InputError(f"mu: give one value or one per contact ({len(uni)}), got {mu.shape}")
    return mu


def _row_kind(label: str) -> tuple[str, str | None]:
    """``("unilateral" | "tangent" | "bilateral", contact)`` of a row label."""
    contact, _, kind = label.rpartition(":")
    if contact and kind == "normal":
        return "unilateral", contact
    if contact and kind in ("long", "lat"):
        return "tangent", contact
    return "bilateral", None


@functools.lru_cache(maxsize=256)
def _row_roles(labels: tuple[str, ...], obstacle_row: int):
    """Index arrays for :func:`holding_rows`: unilateral rows, bilateral rows, the no-slip
    rows whose contact has a unilateral normal row, and those normal rows."""
    kinds = [_row_kind(lab) for lab in labels]
    uni = [i for i, (kd, _) in enumerate(kinds) if kd == "unilateral" or i == obstacle_row]
    bil = [i for i, (kd, _) in enumerate(kinds) if kd == "bilateral" and i not in uni]
    contact_row = {kinds[i][1]: i for i in uni if kinds[i][1] is not None}
    tangent = [i for i, (kd, c) in enumerate(kinds) if kd == "tangent" and c in contact_row]
    source = [contact_row[kinds[i][1]] for i in tangent]

    def arr(x):
        a = np.array(x, dtype=np.int64)
        a.flags.writeable = False
        return a

    return arr(uni), arr(bil), arr(tangent), arr(source)


# ----------------------------------------------------------------------------------------
# Energy
# ----------------------------------------------------------------------------------------


def warn_if_jammed(mbm, m_eff, labels, obstacle_row: int) -> None:
    """:class:`HeldRowsWarning` when a vehicle's ``m_eff`` (others held) exceeds its
    total mass (:func:`pinocchio.computeTotalMass`)."""
    total = jam_total_mass(mbm)
    if total is not None:
        warn_jammed(float(np.max(m_eff)), total, labels, obstacle_row, stacklevel=4)


def total_mass(mbm) -> float:
    """Mass of the whole model [kg] (every body of the Pinocchio model): a study's
    ``m_total``."""
    return float(sum(Y.mass for Y in mbm.model.inertias))


def jam_total_mass(mbm) -> float | None:
    """Total mass of a vehicle (floating or planar base) that :func:`warn_if_jammed`
    compares ``m_eff`` with; None for a fixed base (never warned)."""
    import pinocchio as pin

    if mbm is None or base_slices(mbm)[0] not in ("floating", "planar"):
        return None
    return float(pin.computeTotalMass(mbm.model))


def warn_jammed(m_max: float, total: float, labels, obstacle_row: int,
                stacklevel: int = 3) -> None:
    """The :class:`HeldRowsWarning` of :func:`warn_if_jammed`, for a known total mass."""
    import warnings

    from ..exceptions import HeldRowsWarning

    if m_max > total * (1.0 + 1e-9):
        held = [lb for k, lb in enumerate(labels) if k != obstacle_row]
        warnings.warn(HeldRowsWarning(
            f"m_eff = {m_max:.4g} kg exceeds the vehicle's total mass {total:.4g} kg: the "
            f"held rows {held} brace it; if they do not all hold through the impact "
            '(constraints = "auto" decides; contacts.ground = "noslip" holds every wheel '
            "bilaterally), T_c^- is too high"), stacklevel=stacklevel)


def pulling_contact(M, A, v, labels, obstacle_row: int, tol: float = 1e-6):
    """``(contact, impulse)`` of the held contact whose normal impulse is most negative
    when every row of ``A`` (m, n) holds through the impact (restitution 0, the obstacle
    approaching), or None when no held contact pulls (to ``tol`` times the obstacle's
    impulse). One :func:`roverimpact.impulsive_impact` solve; with dependent rows (an
    impulse not unique) a small linear program looks for impulses, among those that
    give the same velocity after impact, with no negative normal among them."""
    from ..impulse import impulsive_impact

    A = np.asarray(A, dtype=float)
    nz = np.flatnonzero(np.max(np.abs(A), axis=-1) > 0.0)  # a zero row takes no impulse
    if obstacle_row not in nz or float(A[obstacle_row] @ v) >= 0.0:
        return None
    A = A[nz]
    labels = [labels[i] for i in nz]
    obs = int(np.flatnonzero(nz == obstacle_row)[0])
    normal = np.array([i for i, lb in enumerate(labels)
                       if i != obs and lb.endswith(":normal")], dtype=np.int64)
    if not normal.size:
        return None
    res = impulsive_impact(M, A, v, restitution=0.0)
    p = np.asarray(res.impulse, dtype=float)
    floor = -tol * abs(float(p[obs]))
    if np.min(p[normal]) >= floor:
        return None
    if int(res.rank) < len(labels):  # p + N z, N spanning the null space of A^T
        from scipy.optimize import linprog

        Vt = np.linalg.svd(A.T)[2]
        N = Vt[int(res.rank):].T
        k = N.shape[1]
        # max t: p_i + N_i z >= t on the normal rows, t <= 0
        lp = linprog(np.r_[np.zeros(k), -1.0],
                     A_ub=np.c_[-N[normal], np.ones(len(normal))], b_ub=p[normal],
                     bounds=[(None, None)] * k + [(None, 0.0)], method="highs")
        if lp.status == 0:
            if -lp.fun >= floor:
                return None
            p = p + N @ lp.x[:k]
    i = int(normal[np.argmin(p[normal])])
    return labels[i].rpartition(":")[0], float(p[i]), float(p[obs])


def pulling_contact_of(M, A, v, labels, obstacle_row: int, keep=None):
    """:func:`pulling_contact` of a stack ``A`` (k, m, n) whose held rows are ``keep``
    (k, m; default all): the first item found to pull, or None. ``M`` (n, n) or (k, n, n)
    and ``v`` (n,) or (k, n): one system or one per item (a study's cases). One batched
    impulse solve per distinct held set; then :func:`pulling_contact` on the items whose
    impulse pulls, the most pulling (relative to the obstacle's impulse) first, until one
    is confirmed."""
    from ..impulse import impulsive_impact

    M, A, v = np.asarray(M, float), np.asarray(A, float), np.asarray(v, float)
    k = A.shape[0]
    M = np.broadcast_to(M, (k, *M.shape[-2:]))
    v = np.broadcast_to(v, (k, v.shape[-1]))
    if keep is None:
        keep = np.ones(A.shape[:2], dtype=bool)
    todo = []  # (relative pull, item, rows, labels, obstacle row)
    for mask in np.unique(keep, axis=0):
        items = np.flatnonzero((keep == mask).all(axis=-1))
        sub = A[items][:, mask]
        ob = int(np.sum(mask[:obstacle_row]))
        lab = [lb for lb, k in zip(labels, mask, strict=True) if k]
        normal = [i for i, lb in enumerate(lab) if i != ob and lb.endswith(":normal")]
        approach = np.einsum("kn,kn->k", sub[:, ob], v[items]) < 0.0
        items, sub = items[approach], sub[approach]
        if not (len(sub) and normal):
            continue
        if (np.max(np.abs(sub), axis=-1) > 0.0).all():
            p = np.asarray(impulsive_impact(M[items], sub, v[items], restitution=0.0).impulse)
            rel = np.min(p[:, normal], axis=-1) / np.abs(p[:, ob])
        else:  # a zero row: pulling_contact drops it
            rel = np.full(len(sub), -np.inf)
        todo += [(r, i, Ai, lab, ob) for r, i, Ai in zip(rel, items, sub, strict=True)
                 if r < -1e-6]
    for _, i, Ai, lab, ob in sorted(todo, key=lambda t: t[0]):
        hit = pulling_contact(M[i], Ai, v[i], lab, ob)
        if hit is not None:
            return hit
    return None


def pulling_applies(constraints, contacts) -> bool:
    """Whether :func:`warn_if_pulling` applies to a scenario's ``constraints`` and
    ``[contacts]``: the wheels held with no-slip rows (``ground = "noslip"``) among the
    rows ``constraints = "auto"`` chose."""
    return constraints == "auto" and contacts.ground == "noslip"


def warn_if_pulling(M, A, v, labels, obstacle_row: int, keep=None,
                    stacklevel: int = 4) -> None:
    """:class:`~roverimpact.exceptions.PullingContactWarning` when a held contact of
    ``contacts.ground = "noslip"`` needs a pulling normal impulse (:func:`pulling_contact`
    of one system ``A`` (m, n); :func:`pulling_contact_of` of a stack (k, m, n), ``M`` and
    ``v`` one system or one per item, ``keep`` its held rows, default all)."""
    import warnings

    from ..exceptions import PullingContactWarning

    hit = (pulling_contact(M, A, v, labels, obstacle_row) if np.ndim(A) == 2
           else pulling_contact_of(M, A, v, labels, obstacle_row, keep))
    if hit is not None:
        contact, p_n, p_obs = hit
        warnings.warn(PullingContactWarning(
            f"held contact {contact} needs a pulling normal impulse ({p_n:.3g} N s against "
            f"the obstacle's {p_obs:.3g} N s) to keep its no-slip rows "
            '(contacts.ground = "noslip"): it cannot hold, and T_c^- is too high; '
            'contacts.ground = "coulomb" with mu = inf decides which wheels hold'),
            stacklevel=stacklevel)


def _energy(M, A, v, obstacle_row: int) -> ImpactEnergy:
    """T, T_c^-, m_eff (others held, and free), v_n; ``A`` may carry a leading batch axis."""
    p = partition(M, A, v, want_velocities=False)
    a = A[..., obstacle_row, :]
    v_n = 0.0 - (a @ v)  # +0.0, not -0.0, where the contact does not move along n
    others = np.delete(A, obstacle_row, axis=-2)
    m_eff, m_eff_free = row_masses(M, a, others)

    def sc(x):
        return x[()] if np.ndim(x) == 0 else x

    T_c, T_a = no_approach(p.T_c, p.T_a, p.T, v_n)
    return ImpactEnergy(T=p.T, T_c_minus=sc(T_c), T_a=sc(T_a), m_eff=sc(m_eff),
                        m_eff_free=sc(m_eff_free), v_n=sc(v_n), rank=p.rank)


def no_approach(T_c, T_a, T, v_n):
    """``(T_c^-, T_a)`` with no impact where the obstacle contact does not approach
    (``v_n <= 0``: the wheel moves along or away from the face): T_c^- = 0 and T_a = T
    there, as the traverse and the predicted peak force (0) have it. The partition's
    T_c of such a velocity is the energy a bilateral row would take, not an impact's."""
    hit = np.asarray(v_n) > 0.0
    if hit.all():
        return T_c, T_a
    return np.where(hit, T_c, 0.0), np.where(hit, T_a, T)


def energy_of(scenario: Scenario | ImpactSetup | dict | str | Path) -> ImpactEnergy:
    """Effective kinetic energy T_c^-, T, T_a, m_eff and v_n of a scenario (a
    :class:`Scenario`, its dict as read from TOML, the path of its TOML file, or a built
    :class:`ImpactSetup`).

    Examples
    --------
    >>> import roverimpact as ri
    >>> sc = ri.Scenario.model_validate({"model": {"name": "rover2d"},
    ...     "velocity": {"u": 0.5}, "obstacle": {"wheel": "front", "beta_deg": 0.0}})
    >>> round(float(ri.energy_of(sc).T_c_minus), 12)   # horizontal face: no approach
    0.0
    """
    setup = scenario if isinstance(scenario, ImpactSetup) else ImpactSetup.from_scenario(scenario)
    return setup.partition()
