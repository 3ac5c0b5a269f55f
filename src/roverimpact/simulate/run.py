r"""The impact run: settle, drive into the obstacle, integrate through the impact.

Phases (each a scipy ``solve_ivp`` call with events):

1. *approach* from the start state until the obstacle gap of some wheel reaches 0
   (terminal event, direction -1). The state at the event is the pre-impact state
   ``(q^-, v^-)`` from which ``T_c^-`` is computed.
2. *contact* until every wheel has left the obstacle again (gap event, direction +1),
   or ``t_after`` has elapsed.

Configurations on the manifold: the state holds a chart ``dq`` around an anchor
``q_ref`` (``q = pin.integrate(q_ref, dq)``); a terminal event at ``|dq|_inf = 0.5``
re-anchors (free-flyer rotations stay far from the chart's singularity at pi).
"""

from __future__ import annotations

import contextlib
import contextvars
import math

import numpy as np
import pandas as pd
import pinocchio as pin
from scipy.integrate import solve_ivp
from scipy.optimize import minimize_scalar

from ..energy import partition
from ..exceptions import ConfigError, InputError, ModelError, SolverError
from .config import SimulationConfig, gravity_vector
from .result import SimulationResult
from .system import ContactSystem, Plane

__all__ = ["build_system", "effective_energy", "first_contact_wheel", "initial_state",
           "reuse_settled_states", "simulate_impact"]

_CHART_LIMIT = 0.5
_MAX_EVALS = 400_000
_FAR = 1.0e9


def _law(spec, override):
    return spec.to_law() if override is None else override


def reference_configuration(mbm):
    q0 = getattr(mbm, "q0", None)
    if q0 is None:
        q0 = (mbm.params or {}).get("q_nominal")
    return pin.neutral(mbm.model) if q0 is None else np.asarray(q0, dtype=float)


def _obstacle_normal(beta: float) -> np.ndarray:
    return np.array([-math.sin(beta), 0.0, math.cos(beta)])


def build_system(mbm, cfg: SimulationConfig, *, law=None, ground_law=None,
                 q_ref=None, terrain=None) -> ContactSystem:
    """Turn a :class:`~roverimpact.models.base.MultibodyModel` and a config into a system.

    The obstacle plane is created far ahead (x = 1e9 m); :func:`simulate_impact` moves it
    in front of the rover after settling. ``q_ref`` (default: the model's reference
    configuration) gives the value at which the joints of ``cfg.contacts.locked`` are
    held; a spring without ``q0`` rests at its joint's value in the model's reference
    configuration, whatever the start (as ``springref`` in :func:`export_mjcf`). ``terrain`` (a
    :class:`~roverimpact.models.terrain.Terrain` or ``{wheel: Terrain}``): the ground of
    every wheel comes from it (:mod:`roverimpact.simulate.terrain`), else the plane z = 0.
    """
    from ..models.joints import joint_reader, joint_value, lock_row

    model = mbm.model
    if not mbm.wheels:
        raise ModelError(f"model {mbm.name!r} has no wheels: nothing can touch the obstacle")
    q_nominal = reference_configuration(mbm)
    q_ref = q_nominal if q_ref is None else np.asarray(q_ref, float)
    springs = []
    for name, sp in cfg.springs.items():
        iv = int(np.flatnonzero(lock_row(mbm, name, what="simulation.springs"))[0])
        q0 = joint_value(mbm, q_nominal, name) if sp.q0 is None else sp.q0
        springs.append((iv, joint_reader(mbm, name, what="simulation.springs"), sp.k, sp.c, q0))
    loop = _with_locks(mbm, mbm.loop_closure, cfg.contacts.locked, q_ref)
    planes = []
    if cfg.ground:
        planes.append(Plane("ground", np.array([0.0, 0.0, 1.0]), np.zeros(3),
                            _law(cfg.ground_contact, ground_law), cfg.ground_contact.v_ref))
    wheels = None
    if cfg.obstacle_wheels is not None:
        names = [w.name for w in mbm.wheels]
        unknown = sorted(set(cfg.obstacle_wheels) - set(names))
        if unknown or not cfg.obstacle_wheels:
            raise ConfigError(f"obstacle_wheels: unknown or empty wheel list {unknown or []}; "
                              f"wheels of this model: {names}")
        wheels = np.array([n in cfg.obstacle_wheels for n in names])
    planes.append(Plane("obstacle", _obstacle_normal(cfg.beta), np.array([_FAR, 0.0, 0.0]),
                        _law(cfg.obstacle, law), cfg.obstacle.v_ref,
                        z_max=cfg.obstacle_height, wheels=wheels))
    ground = None
    if terrain is not None:
        from .terrain import TerrainGround

        if not cfg.ground:
            raise ConfigError("simulation.ground = false with a terrain: the wheels would not "
                              "touch it (drop [terrain] or set ground = true)")
        ground = TerrainGround(terrain, [w.name for w in mbm.wheels])
    return ContactSystem(
        terrain=ground,
        axes=np.array([w.axis for w in mbm.wheels], dtype=float),
        model=model,
        wheel_frames=[w.frame for w in mbm.wheels],
        radii=np.array([w.radius for w in mbm.wheels]),
        planes=planes,
        gravity=gravity_vector(cfg.g),
        springs=springs,
        loop_closure=loop,
        mu=cfg.mu,
        v_slip=cfg.v_slip,
        baumgarte=cfg.integrator.baumgarte,
    )


def _with_locks(mbm, loop, locked, q_ref):
    """The model's loop closure plus one row per locked joint, ``phi = theta - theta_ref``
    (held at its value in ``q_ref``, Baumgarte-stabilised like the loops), ``J = e_j``."""
    if not locked:
        return loop
    from ..models.joints import joint_reader, joint_value, lock_row

    rows = np.array([lock_row(mbm, jn, what="contacts.locked") for jn in locked])
    ref = np.array([joint_value(mbm, q_ref, jn) for jn in locked])
    return _LockedClosure(loop, [joint_reader(mbm, jn, what="contacts.locked")
                                 for jn in locked], ref, rows, mbm.model)


class _LockedClosure:
    """``q -> (phi, J)``: the rows of ``loop`` (or none), then ``theta_j(q) - theta_ref``
    with the constant rows ``e_j`` of the locked joints (:func:`_with_locks`).

    ``jdot_v``: the locked rows have no bias term (``J`` constant), the loop's own is
    :func:`~roverimpact.models.constraints.loop_jdot_v` (central differences unless the
    loop says better); ``constant_jacobian`` when the loop's ``J`` is constant too.
    """

    def __init__(self, loop, readers, ref, rows, model):
        self.loop, self.readers, self.ref, self.rows, self.model = loop, readers, ref, rows, model
        self.constant_jacobian = loop is None or bool(getattr(loop, "constant_jacobian", False))

    def __call__(self, q):
        phi = np.array([r(q) for r in self.readers]) - self.ref
        if self.loop is None:
            return phi, self.rows
        phi_l, J_l = self.loop(q)
        return (np.concatenate([np.atleast_1d(phi_l), phi]),
                np.vstack([np.atleast_2d(J_l), self.rows]))

    def jdot_v(self, q, v):
        from ..models.constraints import loop_jdot_v

        zero = np.zeros(len(self.readers))
        if self.loop is None:
            return zero
        return np.concatenate([loop_jdot_v(self.loop, self.model, q, v), zero])


# ---------------------------------------------------------------------- initial state
def _rigid_velocity(sys: ContactSystem, mbm, q, axis: np.ndarray) -> np.ndarray:
    """Generalized velocity translating the whole rover rigidly at unit speed along
    ``axis``: its base (a free-flyer, or a planar x-z-pitch chain) translates and every
    other joint is still, as the indicator's ``[velocity] u`` drives it
    (:func:`roverimpact.scenario.build.velocity` with ``base_linear = axis``). Another root:
    every wheel centre at unit speed along ``axis``, no wheel frame turning (min-norm least
    squares; then a suspension may move, as nothing else pins it)."""
    from ..scenario.build import velocity
    from ..scenario.schema import VelocitySpec

    _, J = sys.wheel_kinematics(q)
    nw = J.shape[0]
    A = J.reshape(nw * 6, sys.nv)
    b = np.tile(np.concatenate([axis, np.zeros(3)]), nw)
    if sys.loop_closure is not None:        # keep the loops closed (J_l w = 0)
        Jl = sys.loop(q)[1]
        A = np.vstack([A, Jl])
        b = np.concatenate([b, np.zeros(Jl.shape[0])])
    try:
        w = velocity(mbm, q, VelocitySpec(base_linear=tuple(float(x) for x in axis)))
    except ConfigError:  # a fixed root, or a planar one asked to move out of its plane
        w = None
    if w is None or np.linalg.norm(A @ w - b) > 1e-9 * math.sqrt(nw):
        w = np.linalg.lstsq(A, b, rcond=None)[0]
    if np.linalg.norm(A @ w - b) > 1e-6 * math.sqrt(nw):
        raise ModelError(
            f"the model cannot translate rigidly along {axis.tolist()}: settling and driving "
            "need a floating or planar base; pass q0 and v0 and set settle = false")
    return w


def _settle(sys: ContactSystem, mbm, q, cfg: SimulationConfig, mass: float, *, up=None,
            free=None):
    """Place the wheels on the ground and solve the static equilibrium (v = 0).

    ``up``: the direction the rover is lowered along onto the ground (default +z).
    ``free``: ``q -> W (nv, k)``, rigid motions of the rover along the ground (on a
    terrain: :func:`.terrain.ground_motions`) in which it is free to accelerate (a slope
    without friction at rest): the equilibrium is then ``tau(q) = M(q) W(q) a`` with the
    accelerations ``a`` unknown, and the rover is not moved along ``W`` (its place on
    the ground is kept).
    """
    ground = sys.planes[0]
    w_z = _rigid_velocity(sys, mbm, q, np.array([0.0, 0.0, 1.0]) if up is None else up)
    nw = len(sys.fids)
    law = ground.law
    delta0 = (mass * cfg.g / max(nw, 1) / law.k) ** (1.0 / law.n) if cfg.g > 0 else 0.0
    for _ in range(3):  # pure translation: exact up to the wheel frames' rotation
        gmin = float(np.min(sys.gaps(q)[0]))
        q = pin.integrate(sys.model, q, -(gmin + delta0) * w_z)
    if cfg.g == 0.0:
        return q
    kloop = 0 if sys.loop_closure is None else sys.loop(q)[0].size
    scale_f = mass * cfg.g
    scale_x = max(delta0, 1e-6)
    nv = sys.nv
    W0 = None if free is None else free(q)
    nd = 0 if W0 is None else W0.shape[1]

    def residual(x):
        qq = pin.integrate(sys.model, q, x[: sys.nv] * scale_x)
        zero = np.zeros(sys.nv)
        r = sys.applied_force(qq, zero).tau - pin.computeGeneralizedGravity(
            sys.model, sys.data, qq)
        if nd:      # rigid acceleration along the ground (x[nv + kloop:] in units of g)
            r = r - sys.mass_matrix(qq) @ (free(qq) @ x[nv + kloop:]) * cfg.g
        if kloop:
            phi, Jl = sys.loop(qq)
            r = np.concatenate([r + Jl.T @ x[sys.nv:nv + kloop] * scale_f, phi / scale_x])
            r = np.concatenate([r[: sys.nv] / scale_f, r[sys.nv:]])
        else:
            r = r / scale_f
        return np.concatenate([r, W0.T @ x[:nv]]) if nd else r

    # Newton with a forward-difference Jacobian and min-norm steps: the neutral directions
    # (translation along the ground, yaw) make the Jacobian singular, lstsq ignores them.
    x = np.zeros(sys.nv + kloop + nd)
    r = residual(x)
    h = 1e-6
    for _ in range(30):
        if np.max(np.abs(r)) < 1e-10:
            break
        Jr = np.empty((r.size, x.size))
        for i in range(x.size):
            xp = x.copy()
            xp[i] += h
            Jr[:, i] = (residual(xp) - r) / h
        step = np.linalg.lstsq(Jr, -r, rcond=1e-10)[0]
        lam = 1.0
        while lam > 1e-4:                      # backtracking on |r|
            r_new = residual(x + lam * step)
            if np.linalg.norm(r_new) < np.linalg.norm(r):
                break
            lam *= 0.5
        x, r = x + lam * step, r_new
    if not np.max(np.abs(r)) < 1e-8:
        raise SolverError(
            f"could not find the static equilibrium on the ground (residual "
            f"{np.max(np.abs(r)):.2g} of the weight): check the suspension springs "
            "and that every wheel can reach the ground, or set settle = false")
    return pin.integrate(sys.model, q, x[: sys.nv] * scale_x)


def _driving_velocity(sys: ContactSystem, mbm, q, u: float) -> np.ndarray:
    """Rigid translation at speed u along +x with each wheel rolling if it has a spin joint."""
    v = u * _rigid_velocity(sys, mbm, q, np.array([1.0, 0.0, 0.0]))
    if not sys.planes or sys.planes[0].name != "ground":
        return v
    cs = sys.contacts(q, v)
    model = sys.model
    for w, fid in enumerate(sys.fids):
        jid = model.frames[fid].parentJoint
        j = model.joints[jid]
        if j.nv != 1:
            continue
        col = cs.Jp[0, w, :, j.idx_v]          # contact-point velocity per unit spin rate
        _, Jc = sys.wheel_kinematics(q)
        if np.linalg.norm(Jc[w, :3, j.idx_v]) > 1e-9 or abs(col[0]) < 1e-12:
            continue                           # not a pure wheel-spin joint
        slip = cs.Jp[0, w] @ v
        v[j.idx_v] -= slip[0] / col[0]
    if sys.loop_closure is not None:        # exact velocity consistency: J_l v = 0
        v = partition(sys.mass_matrix(q), sys.loop(q)[1], v).v_a
    return v


# ---------------------------------------------------------------------- indicator
#: Wheels whose obstacle gaps are within this of the smallest meet the face together [m].
TIE_GAP = 1e-9


def first_contact_wheel(gaps) -> int:
    """The wheel that meets the obstacle: the first, in the model's order, of those whose
    gap (n_wheels,) is within ``TIE_GAP`` of the smallest. Wheels of a symmetric rover meet
    a face together; a bare argmin chose between them by rounding (1e-16 m), so the
    reported wheel and rows changed with the terrain's tilt or the numpy version."""
    g = np.asarray(gaps, dtype=float)
    g = np.where(np.isfinite(g), g, np.inf)
    return int(np.flatnonzero(g <= np.min(g) + TIE_GAP)[0])


def effective_energy(sys: ContactSystem, mbm, q, v, wheel: int, config: SimulationConfig,
                     simultaneous: float = 1e-6):
    """``T_c^-`` and ``m_eff`` of the state (q, v) for an obstacle contact of ``wheel``.

    The impact is built by :meth:`roverimpact.scenario.ImpactSetup.from_state`, the path
    every scenario takes: the obstacle normal of ``wheel`` (and the obstacle rows of every
    other wheel within ``simultaneous`` [m] of touching, e.g. both front wheels of a
    symmetric rover), the ground rows (``config.contacts.ground``) of every other wheel in
    ground contact, the loop closure, the locked joints (``config.contacts.locked``) and
    the active rows chosen by ``config.constraints``. ``m_eff`` is the effective mass
    along the primary obstacle row alone (others free).

    Returns
    -------
    T_c : float, m_eff : float, labels : list of str (active rows)
    """
    from ..scenario import ImpactSetup
    from ..scenario.schema import ObstacleSpec

    cs = sys.contacts(q, v)
    names = [p.name for p in sys.planes]
    io = names.index("obstacle")
    hit = [int(w) for w in np.flatnonzero(cs.gap[io] <= cs.gap[io, wheel] + simultaneous)]
    others = [mbm.wheels[w].name for w in hit if w != wheel]
    ground = []
    normals = None
    if "ground" in names:
        ig = names.index("ground")
        ground = [mbm.wheels[w].name for w in np.flatnonzero(cs.delta[ig] > 0)
                  if int(w) not in hit]
        if sys.terrain is not None:       # the terrain's normals under the ground wheels
            normals = {mbm.wheels[w].name: cs.n[ig, w] for w in range(len(mbm.wheels))}
    contacts = config.contacts.model_copy(update={"ground_wheels": ground})
    obstacle = ObstacleSpec(wheel=mbm.wheels[wheel].name,
                            normal=tuple(float(x) for x in sys.planes[io].n))
    setup = ImpactSetup.from_state(mbm, q, v, obstacle=obstacle, contacts=contacts,
                                   constraints=config.constraints, also_hit=others,
                                   ground_normals=normals)
    en = setup.partition()
    return float(en.T_c_minus), float(en.m_eff_free), list(setup.labels)


# ---------------------------------------------------------------------- integration
class _Segments:
    """Accepted steps of all solve_ivp calls, with their anchors for dense output."""

    def __init__(self):
        self.t, self.y, self.seg, self.sols, self.anchors = [], [], [], [], []

    def add(self, sol, q_ref):
        k = len(self.sols)
        self.sols.append(sol.sol)
        self.anchors.append(q_ref)
        start = 1 if self.t else 0
        self.t.extend(sol.t[start:])
        self.y.extend(sol.y.T[start:])
        self.seg.extend([k] * (len(sol.t) - start))


def _run_phase(sys, q_ref, v, imp, t0, t1, cfg, v_i, obstacle_event, direction, segs,
               counter):
    """Integrate from t0 to t1 with re-anchoring; stop at the obstacle gap event."""
    nv, io = sys.nv, len(sys.planes) - 1
    spec = cfg.integrator

    def rhs(t, y):
        counter[0] += 1
        if counter[0] > _MAX_EVALS:
            raise SolverError(
                f"the integrator needed more than {_MAX_EVALS} force evaluations: the contact "
                "is too stiff for the time limit or the run diverges; lower the stiffness, "
                "loosen integrator.rtol or shorten t_max / t_after")
        dq, vv = y[:nv], y[nv:2 * nv]
        q = sys.config(q_ref_box[0], dq)
        cf = sys.applied_force(q, vv, v_i)
        a = sys.acceleration(q, vv, cf.tau)
        return np.concatenate([sys.chart_rate(q_ref_box[0], dq, vv), a, cf.f_n[io]])

    def ev_gap(t, y):
        q = sys.config(q_ref_box[0], y[:nv])
        g = sys.gaps(q)[io]
        return float(np.min(g)) if np.isfinite(g).any() else 1.0

    ev_gap.terminal, ev_gap.direction = obstacle_event, direction

    def ev_chart(t, y):
        return float(np.max(np.abs(y[:nv]))) - _CHART_LIMIT

    ev_chart.terminal, ev_chart.direction = True, 1
    events = [ev_gap] if sys.euclidean else [ev_gap, ev_chart]
    q_ref_box = [q_ref]
    y = np.concatenate([np.zeros(nv), v, imp])
    t = t0
    while True:
        sol = solve_ivp(rhs, (t, t1), y, method=spec.method, rtol=spec.rtol, atol=spec.atol,
                        max_step=spec.max_step, first_step=spec.first_step,
                        events=events, dense_output=True)
        if sol.status < 0:
            raise SolverError(f"the integrator failed at t = {sol.t[-1]:.6g} s: {sol.message}"
                              " (try a smaller integrator.rtol or max_step)")
        segs.add(sol, q_ref_box[0])
        t, y = sol.t[-1], sol.y[:, -1].copy()
        if sol.status == 0:
            return t, sys.config(q_ref_box[0], y[:nv]), y[nv:], False
        if len(sol.t_events[0]):
            return t, sys.config(q_ref_box[0], y[:nv]), y[nv:], True
        q_ref_box[0] = sys.config(q_ref_box[0], y[:nv])   # re-anchor the chart
        y[:nv] = 0.0


def _state_at(sys, segs, k, t):
    y = segs.sols[k](t)
    return sys.config(segs.anchors[k], y[: sys.nv]), y[sys.nv: 2 * sys.nv]


def initial_state(mbm, config: SimulationConfig | dict | None = None, *, q0=None,
                  ground_law=None, terrain=None, pose: bool = True, pose_wheels=None):
    """Settled start state ``(q, v)``: static equilibrium on the ground, driving at
    ``config.speed`` along +x with rolling wheels.

    Settle once and pass the result as ``q0=, v0=`` to :func:`simulate_impact` to run many
    impacts (e.g. a sweep over beta) from the same state without settling again (with the
    same ``terrain``), or run them within :func:`reuse_settled_states`. With a
    ``terrain``: see :func:`simulate_impact`.
    """
    config = as_config(config)
    q = np.asarray(reference_configuration(mbm) if q0 is None else q0, dtype=float).copy()
    sys = build_system(mbm, config, law=_NoLaw(), ground_law=ground_law, q_ref=q,
                       terrain=terrain)
    if q.shape != (sys.nq,):
        raise InputError(f"q0 must have shape ({sys.nq},), got {q.shape}")
    if terrain is not None:
        return _start_on_terrain(sys, mbm, config, q, terrain, pose, pose_wheels)
    return _start_on_ground(sys, mbm, config, q, "initial_state", ground_law is None)


#: settled configurations of this context (:func:`reuse_settled_states`), or None
_SETTLED: contextvars.ContextVar[dict | None] = contextvars.ContextVar(
    "roverimpact_settled_states", default=None)

#: fields of a :class:`SimulationConfig` that settling on the ground does not read (they
#: set the driving speed, place the obstacle and run the impact): cases that differ in
#: them only settle to one configuration. The obstacle's law stays in the key: it decides
#: how the contact forces of all planes are evaluated (one Hunt-Crossley family or law by
#: law)
_NOT_IN_SETTLE = frozenset({"speed", "beta_deg", "distance", "obstacle_x", "t_max",
                            "t_after", "integrator", "constraints"})

#: settled configurations kept in one context, the newest (each keeps its model alive)
_SETTLED_KEPT = 16


@contextlib.contextmanager
def reuse_settled_states():
    """Within this context, a run that settles on the ground plane (no ``v0``, no terrain)
    as an earlier run did takes that run's settled configuration instead of settling
    again: the same model object, the same ``q0`` and configuration except the fields
    settling does not read (``speed``, ``beta_deg``, ``distance``, ``obstacle_x``,
    ``t_max``, ``t_after``, ``integrator``, ``constraints``). It is the configuration the
    run would compute (the same function of the same numbers), so the results are the
    same to the bit; an angle or speed sweep settles once per engine (the driving velocity
    is computed for each run). Kept for the context only: the model must not be changed in
    place within it (a study's evaluator keeps its models for a chunk). Contexts nest; an
    inner one starts empty."""
    token = _SETTLED.set({})
    try:
        yield
    finally:
        _SETTLED.reset(token)


def _start_on_ground(sys: ContactSystem, mbm, config: SimulationConfig, q, path: str,
                     reusable: bool) -> tuple[np.ndarray, np.ndarray]:
    """``(q, v)`` at t = 0 on the ground plane: settled (``config.settle``) and driving at
    ``config.speed``. The settled configuration comes from :func:`reuse_settled_states`'s
    store when a run of the same ``path`` (the function asking: the two build their
    systems differently) has settled the same model from the same ``q`` with the same
    configuration. ``reusable``: the system's laws are the configuration's (no law objects
    given beside it, which the key cannot tell)."""
    if config.settle and config.ground:
        store = _SETTLED.get()
        if store is None or not reusable:
            q = _settled_on_ground(sys, mbm, config, q)
        else:
            key = (path, id(mbm), q.tobytes(),
                   repr(sorted(config.model_dump(exclude=set(_NOT_IN_SETTLE)).items())))
            # an entry (mbm, q) keeps its model alive: the id in its key stays that model's
            hit = store.get(key)
            if hit is not None:
                q = hit[1].copy()
            else:
                q = _settled_on_ground(sys, mbm, config, q)
                if len(store) >= _SETTLED_KEPT:  # the oldest goes (a model-changing design)
                    del store[next(iter(store))]
                store[key] = (mbm, q.copy())
    return q, _driving_velocity(sys, mbm, q, config.speed)


def _settled_on_ground(sys: ContactSystem, mbm, config: SimulationConfig, q):
    """``q`` posed with every wheel on the ground plane, then in static equilibrium."""
    q = _pose_on_ground(mbm, sys, q)
    return _settle(sys, mbm, q, config, float(sum(i.mass for i in sys.model.inertias)))


def _pose_on_ground(mbm, sys: ContactSystem, q):
    """Every wheel touching the ground plane, loops closed (:func:`pose_on_terrain`), as
    the start of settling: the rigid drop alone leaves a wheel in the air when the wheels
    are not level in ``q``. Unchanged when they already touch; when no such pose exists
    (a rigid chassis whose wheels cannot all touch) settling starts from ``q`` as given."""
    from ..models.declare import base_info
    from ..models.pose import PoseError, pose_on_terrain
    from ..models.terrain import PlaneTerrain

    if not mbm.wheels or base_info(mbm).kind not in ("floating", "planar"):
        return q
    ground = sys.planes[0]
    try:
        return pose_on_terrain(mbm, PlaneTerrain(ground.p0, ground.n), q).q
    except (PoseError, InputError):
        return q


def _start_on_terrain(sys: ContactSystem, mbm, config: SimulationConfig, q, terrain,
                      pose: bool, pose_wheels):
    """``(q, v)`` at t = 0 on a terrain: posed on it (``pose``), settled (``config.settle``;
    free to accelerate along the ground), driving along it (:func:`.terrain_velocity`)."""
    from .terrain import drive_frame, ground_motions, spin_joints, terrain_velocity

    if pose:
        from ..scenario.ground import pose_scenario
        from ..scenario.schema import TerrainSpec

        q = pose_scenario(mbm, terrain, q, TerrainSpec(pose_wheels=pose_wheels))
    if config.settle:
        nbar, _, drive = drive_frame(sys, mbm, q)
        spins = spin_joints(sys)
        q = _settle(sys, mbm, q, config, float(sum(i.mass for i in sys.model.inertias)),
                    up=nbar, free=lambda qq: ground_motions(mbm, qq, nbar, drive, spins))
    return q, terrain_velocity(sys, mbm, q, config.speed, terrain, pose_wheels)


class _NoLaw:
    """Placeholder obstacle law while settling (the obstacle is far away)."""

    k, n, e = 1.0, 1.0, 1.0

    def force(self, delta, delta_dot, v_i=1.0):
        return np.zeros_like(np.asarray(delta, dtype=float))


def as_config(config):
    if config is None:
        return SimulationConfig()
    if isinstance(config, dict):
        return SimulationConfig.from_dict(config)
    return config


def simulate_impact(mbm, config: SimulationConfig | dict | None = None, *, q0=None, v0=None,
                    law=None, ground_law=None, terrain=None, pose: bool = True,
                    pose_wheels=None) -> SimulationResult:
    r"""Simulate the rover driving into the obstacle with compliant contact.

    Parameters
    ----------
    mbm : MultibodyModel
        Model with wheels (and loop closure if any).
    config : SimulationConfig or dict, optional
        Run parameters (defaults: Earth gravity, 0.1 m/s, vertical wall 1 mm ahead).
    q0 : (nq,) array_like, optional
        Start configuration (default: the model's ``params['q_nominal']`` or pin.neutral); with
        ``config.settle`` it is settled on the ground first.
    v0 : (nv,) array_like, optional
        Start velocity. If given, it is used as is (no settling, no driving velocity);
        otherwise the rover translates at ``config.speed`` along +x with rolling wheels.
    law, ground_law : contact-law objects, optional
        Override the laws named in the config (any object with ``force(delta,
        delta_dot, v_i)``, ``k``, ``n``, ``e``).
    terrain : Terrain or dict, optional
        The ground (:class:`~roverimpact.models.terrain.PlaneTerrain`, ``HeightField``,
        ``FunctionTerrain``, or ``{wheel name: Terrain}`` for every wheel) instead of the
        plane z = 0; wheels touch it as discs (:mod:`roverimpact.simulate.terrain`).
        Without ``v0`` the start is then: placed on the terrain
        (:func:`~roverimpact.models.pose.pose_on_terrain`, x, y, yaw of ``q0`` kept,
        ``pose_wheels`` touching; skipped with ``pose=False``), settled with the rover free
        to accelerate along the ground (``config.settle``), driving along the slope under
        it in the base's heading (:func:`~roverimpact.simulate.terrain.terrain_velocity`);
        the face of angle beta (from the horizontal, as in the indicator) is placed
        ``distance`` ahead of the nearest wheel, its foot on the ground.
    pose, pose_wheels
        See ``terrain``.

    Returns
    -------
    SimulationResult

    Raises
    ------
    ConfigError, InputError
        Bad configuration values, obstacle behind or inside the rover.
    SolverError
        No obstacle contact within ``t_max``, integrator failure or runaway cost.
    """
    config = as_config(config)
    q_ref = reference_configuration(mbm) if q0 is None else np.asarray(q0, dtype=float)
    sys = build_system(mbm, config, law=law, ground_law=ground_law, q_ref=q_ref,
                       terrain=terrain)
    q, v = _start_state(sys, mbm, config, q0, v0, terrain, pose, pose_wheels,
                        reusable=law is None and ground_law is None)
    gaps = _place_obstacle(sys, mbm, config, q)

    counter = [0]
    segs = _Segments()
    nw = len(sys.fids)
    t_c, q_minus, y1, hit = _run_phase(sys, q, v, np.zeros(nw), 0.0, config.t_max, config,
                                       None, True, -1, segs, counter)
    if not hit:
        raise SolverError(
            f"no obstacle contact within t_max = {config.t_max} s (nearest wheel started "
            f"{float(np.min(gaps)):.4g} m away at {config.speed} m/s): increase t_max or "
            "reduce distance")
    v_minus = y1[:sys.nv].copy()
    wheel = first_contact_wheel(sys.gaps(q_minus)[-1])
    v_n = float(sys.contacts(q_minus, v_minus).delta_dot[-1, wheel])
    if v_n <= 0.0:  # pragma: no cover - the event has direction -1
        raise SolverError("the first obstacle contact has no approach velocity")
    v_i = [p.v_i for p in sys.planes]
    v_i[-1] = v_n
    sys.planes[-1].v_i = v_n
    T_c, m_eff, labels = effective_energy(sys, mbm, q_minus, v_minus, wheel, config)
    T_minus = sys.kinetic_energy(q_minus, v_minus)
    E_minus = float(T_minus + sys.potential_energy(q_minus))
    i_contact = len(segs.t) - 1

    t_stop, q_plus, y2, separated = _run_phase(
        sys, q_minus, v_minus, np.zeros(nw), t_c, t_c + config.t_after, config, v_i, True, 1,
        segs, counter)
    v_plus = y2[:sys.nv].copy()
    impulses = y2[sys.nv:]
    T_plus = sys.kinetic_energy(q_plus, v_plus)
    E_plus = float(T_plus + sys.potential_energy(q_plus))

    names_w = [w.name for w in mbm.wheels]
    history, fn = _history(sys, segs, names_w, v_i, i_contact, t_c)
    F_max, t_peak, F_total = _peaks(sys, segs, fn, names_w, v_i, i_contact, t_c)
    return SimulationResult(
        history=history, F_max=F_max, t_peak=t_peak, F_max_total=F_total,
        impulse={f"obstacle_{wn}": float(impulses[w]) for w, wn in enumerate(names_w)},
        contact_duration=float(t_stop - t_c), separated=bool(separated),
        T_minus=T_minus, T_plus=T_plus, E_minus=E_minus, E_plus=E_plus,
        q_minus=q_minus, v_minus=v_minus, q_plus=q_plus, v_plus=v_plus,
        T_c_minus=T_c, m_eff=m_eff, v_n=v_n, contact_wheel=names_w[wheel],
        A_rows=labels,
        stats={"nfev": counter[0], "steps": len(segs.t), "segments": len(segs.sols),
               "t_contact": float(t_c)},
    )


def _start_state(sys: ContactSystem, mbm, config: SimulationConfig, q0, v0, terrain=None,
                 pose=True, pose_wheels=None, *, reusable=False):
    """``(q, v)`` at t = 0: settled on the ground and driving, or as given. ``reusable``:
    the system's laws are the configuration's (:func:`_start_on_ground`)."""
    q = np.asarray(reference_configuration(mbm) if q0 is None else q0, dtype=float).copy()
    if q.shape != (sys.nq,):
        raise InputError(f"q0 must have shape ({sys.nq},), got {q.shape}")
    if v0 is None and terrain is not None:
        q, v = _start_on_terrain(sys, mbm, config, q, terrain, pose, pose_wheels)
    elif v0 is None:  # as initial_state
        q, v = _start_on_ground(sys, mbm, config, q, "simulate_impact", reusable)
    else:
        v = np.asarray(v0, dtype=float).copy()
        if v.shape != (sys.nv,):
            raise InputError(f"v0 must have shape ({sys.nv},), got {v.shape}")
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
        raise InputError("q0 and v0 must be finite")
    settled = v0 is None and config.settle and config.ground
    if config.ground and not settled:
        _check_not_in_ground(sys, mbm, config, q)
    return q, v


def _check_not_in_ground(sys: ContactSystem, mbm, config: SimulationConfig, q) -> None:
    """Refuse a start with a wheel deeper in the ground than a few static deflections
    (a rover placed 0.2 m inside the ground would start with 1e6 N per wheel)."""
    law = sys.planes[0].law
    mass = float(sum(i.mass for i in sys.model.inertias))
    nw = len(sys.fids)
    static = (mass * config.g / max(nw, 1) / law.k) ** (1.0 / law.n) if config.g > 0 else 0.0
    tol = max(5.0 * static, 1e-6)
    depth = -sys.gaps(q)[0]
    w = int(np.argmax(depth))
    if depth[w] > tol:
        raise InputError(
            f"wheel {mbm.wheels[w].name!r} starts {depth[w]:.4g} m inside the ground (the "
            f"static deflection is about {static:.2g} m): set simulation.settle = true or "
            "raise the rover in [configuration]")


def _place_obstacle(sys: ContactSystem, mbm, config: SimulationConfig, q) -> np.ndarray:
    """Move the obstacle face ``distance`` ahead of the nearest wheel (or to ``obstacle_x``);
    return the obstacle gaps of the wheels at ``q``."""
    obst = sys.planes[-1]
    if sys.terrain is not None:
        from .terrain import face_on_terrain

        face_on_terrain(sys, mbm, config, q)
    else:
        c = sys.wheel_centres(q)
        if config.obstacle_x is None:
            x0 = (config.distance - float(np.min(c @ obst.n - sys.radii))) / math.sin(
                config.beta)
        else:
            x0 = float(config.obstacle_x)
        obst.p0 = np.array([x0, 0.0, 0.0])
    sys._set_planes()
    gaps = sys.gaps(q)[-1]
    if not np.isfinite(gaps).any():
        raise InputError(f"the obstacle (height {config.obstacle_height} m) is lower than the "
                         "contact points of every wheel: the rover would pass over it")
    if float(np.nanmin(np.where(np.isfinite(gaps), gaps, np.nan))) < 0.0:
        w = int(np.argmin(gaps))
        raise InputError(f"the obstacle is behind or inside the rover: wheel "
                         f"{mbm.wheels[w].name!r} is {-gaps[w]:.4g} m past its face; "
                         "move obstacle_x ahead of the rover (+x)")
    return gaps


def _history(sys: ContactSystem, segs: _Segments, names_w, v_i, i_contact: int, t_c: float):
    """The time history table (t, q, v, every contact's normal/tangential force and
    indentation) and the normal forces ``fn (steps, planes, wheels)``."""
    T = np.asarray(segs.t)
    Y = np.asarray(segs.y)
    nw = len(names_w)
    pl_names = [p.name for p in sys.planes]
    fn = np.empty((len(T), len(pl_names), nw))
    ft = np.empty_like(fn)
    de = np.empty_like(fn)
    rows_q, rows_v = [], []
    for i, (yk, k) in enumerate(zip(Y, segs.seg, strict=True)):
        qk = sys.config(segs.anchors[k], yk[:sys.nv])
        vk = yk[sys.nv: 2 * sys.nv]
        csk = sys.applied_force(qk, vk, v_i if i >= i_contact else None)
        fn[i], ft[i], de[i] = csk.f_n, csk.f_t, csk.delta
        rows_q.append(qk)
        rows_v.append(vk)
    data = {"t": T - t_c}
    rows_q, rows_v = np.array(rows_q), np.array(rows_v)
    for j in range(sys.nq):
        data[f"q_{j}"] = rows_q[:, j]
    for j in range(sys.nv):
        data[f"v_{j}"] = rows_v[:, j]
    for p, pn in enumerate(pl_names):
        for w, wn in enumerate(names_w):
            data[f"{pn}_{wn}_fn"] = fn[:, p, w]
            data[f"{pn}_{wn}_ft"] = ft[:, p, w]
            data[f"{pn}_{wn}_delta"] = de[:, p, w]
    return pd.DataFrame(data), fn


def _peaks(sys: ContactSystem, segs: _Segments, fn, names_w, v_i, i_contact: int, t_c: float):
    """Peak obstacle forces refined on the dense output: per wheel and summed."""
    T = np.asarray(segs.t)
    io = len(sys.planes) - 1
    nw = len(names_w)

    def f_obst(t, k, w=None):
        qk, vk = _state_at(sys, segs, k, t)
        f = sys.applied_force(qk, vk, v_i).f_n[io]
        return f.sum() if w is None else f[w]

    def refine(series, w):
        i = int(np.argmax(series))
        if series[i] <= 0.0 or i < i_contact:
            return 0.0, float(T[i] - t_c)
        best_f, best_t = float(series[i]), float(T[i])
        for a, b in ((i - 1, i), (i, i + 1)):
            if a < i_contact or b >= len(T) or segs.seg[b] != segs.seg[max(a, 0)]:
                continue
            k = segs.seg[b]
            r = minimize_scalar(lambda t, k=k: -f_obst(t, k, w), bounds=(T[a], T[b]),
                                method="bounded", options={"xatol": 1e-12 + 1e-9 * T[b]})
            if -r.fun > best_f:
                best_f, best_t = float(-r.fun), float(r.x)
        return best_f, best_t - t_c

    F_total, t_total = refine(fn[:, io, :].sum(axis=1), None)
    touched = [w for w in range(nw) if fn[:, io, w].max() > 0.0]
    F_max, t_peak = {}, {}
    for w, wn in enumerate(names_w):
        if w not in touched:
            f, tp = 0.0, float("nan")
        elif len(touched) == 1:
            f, tp = F_total, t_total
        else:
            f, tp = refine(fn[:, io, w], w)
        F_max[f"obstacle_{wn}"], t_peak[f"obstacle_{wn}"] = f, tp
    return F_max, t_peak, F_total
