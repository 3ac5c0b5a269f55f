r"""A compliant-contact simulation of one traverse impact: the reference for the indicator.

The simulator of :mod:`roverimpact.simulate` drives a rover settled on the plane z = 0 (or
on a height field, one contact per wheel) into one obstacle plane of angle beta. What a
traverse impact needs is the rover in its terrain pose, each wheel on its own patch of
ground, the hitting wheel against the terrain feature. :func:`simulate_station_impact`
builds exactly that from the simulator's own parts (:class:`~roverimpact.simulate.system.
ContactSystem`: Pinocchio dynamics, compliant wheel/plane contacts, the loop closure
enforced as a constraint) and integrates it through the impact:

* every supporting wheel touches a plane: the terrain's tangent plane at its support
  (normal = the terrain normal there), placed so that the wheel just touches it (without
  gravity) or starts at its static indentation (with gravity, below); only that wheel can
  touch it;
* the hitting wheel touches a plane through the contact found ahead, with the contact
  normal found (the terrain feature, modelled by its tangent plane at the contact: the
  brief's fallback while the simulator cannot drive into a height field), placed so that
  the wheel just touches it; its own support plane stays;
* the state is the pose and the driving velocity at the chosen speed: the supports at
  rest along their normals, the feature approached at v_n;
* gravity (default Earth's) with every support preloaded: its plane placed so that the
  wheel starts at the indentation of its static load (the loads that hold the rover at
  rest in the support directions: :func:`~roverimpact.contact.reduced.static_loads` of the
  support rows, :func:`~roverimpact.traverse.refine.station_model`); no joint springs.
  With ``gravity = 0`` the impact forces only (the rigid-impact model the indicator comes
  from), the supports just touching.

The initial preload is the one input the harness takes from the model it checks (the
static loads); everything after is the simulator's integration of the multibody dynamics.

**Wheel geometry.** The simulator's wheel is a sphere: its point facing a plane of normal
``n`` is ``c - r n``. The indicator's wheel is a thin disc (a rim), whose point facing the
plane is ``c - r d``, ``d`` the unit part of ``n`` orthogonal to the wheel axis (the
plane rule of ``models.constraints.wheel_contact_point``). On a terrain the contact
normals leave the wheel plane (lateral slopes), where the two differ: a sphere's contact
point and lever arm are not the rim's, and neither is its approach speed. So the system
here (:class:`DiscContactSystem`) takes each wheel/plane pair's rim direction ``d`` at the
start state and keeps it (in world axes) through the impact (a few milliseconds, in which
the wheel turns by a fraction of a degree): gap :math:`n\cdot(c - p_0) - r\,n\cdot d`,
contact point ``c - r d``, Jacobian :math:`J_{lin} + r[d]_\times J_{ang}`. Everything else
is the simulator's.

The peak force on the feature's plane, refined on the dense output, is the reference
:math:`F_{max}`.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import minimize_scalar

from ..contact.reduced import static_indentation, static_loads
from ..exceptions import SolverError
from ..simulate.system import ContactSystem, Plane
from .refine import EARTH, station_model

__all__ = ["DiscContactSystem", "SimulationCheck", "StationImpact", "check_against_simulation",
           "simulate_station_impact"]


def _skew(d):
    S = np.zeros((*d.shape[:-1], 3, 3))
    S[..., 0, 1], S[..., 0, 2] = -d[..., 2], d[..., 1]
    S[..., 1, 0], S[..., 1, 2] = d[..., 2], -d[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -d[..., 1], d[..., 0]
    return S


class DiscContactSystem(ContactSystem):
    """:class:`~roverimpact.simulate.system.ContactSystem` with thin-disc wheels: the rim
    point facing each plane along the fixed unit direction ``rim_dirs[p, w]`` (world; the
    part of the plane normal orthogonal to the wheel axis at the start), instead of the
    sphere's ``c - r n`` (module docstring)."""

    def __init__(self, *args, rim_dirs, **kwargs):
        self._rim_dirs = np.asarray(rim_dirs, dtype=float)
        super().__init__(*args, **kwargs)

    def _set_planes(self):
        super()._set_planes()
        D = self._rim_dirs                                          # (np, nw, 3)
        # contact point c - r d: J_p = J_lin - skew(-r d) J_ang = J_lin + r skew(d) J_ang
        self.rSn = self.radii[None, :, None, None] * _skew(D)
        self._r_eff = self.radii[None, :] * np.einsum("pj,pwj->pw", self.N, D)

    def _gaps(self, c):
        g = self.N @ c.T - self.offsets[:, None] - self._r_eff
        return np.where(self.touch, g, np.inf)


@dataclass(frozen=True)
class StationImpact:
    """Result of :func:`simulate_station_impact`: peak force on the feature ``F_max`` [N],
    its time ``t_peak`` [s], ``contact_duration`` [s], ``separated`` (the wheel left the
    feature within the window), the approach speed ``v_n`` [m/s] of the simulated wheel."""

    F_max: float
    t_peak: float
    contact_duration: float
    separated: bool
    v_n: float


def simulate_station_impact(mbm, q, v, support, support_normal, wheel: int, point, normal,
                            *, law, ground_law, supports=None, t_after: float = 0.05,
                            gravity=EARTH, v_ref: float = 0.1, rtol: float = 1e-8,
                            atol: float = 1e-10) -> StationImpact:
    """Simulate the impact of ``wheel`` against the plane (``point``, ``normal``) from the
    state ``(q, v)`` with every wheel of ``supports`` (default all) on its own support
    plane (``support``, ``support_normal``: (n_wheels, 3)). Module docstring.

    Parameters
    ----------
    mbm : MultibodyModel
    q, v : (nq,), (nv,)
        Pose on the terrain and driving velocity.
    support, support_normal : (n_wheels, 3)
        Support points and terrain normals.
    wheel : int
        The hitting wheel.
    point, normal : (3,)
        The contact ahead and its normal (only the normal and the wheel matter: the plane
        is placed where the wheel's sphere touches it).
    law, ground_law : contact-law objects
        Of the feature and of the supports.
    supports : (n_wheels,) bool, optional
        Wheels that stand on a support plane.
    t_after : float
        Longest simulated time [s].
    gravity : (3,)
        [m/s^2]; with gravity each support starts at the indentation of its static load
        (preloaded), without it just touching.
    v_ref : float
        The ``v_i`` of the supports' law [m/s].
    """
    import pinocchio as pin

    model = mbm.model
    nw = len(mbm.wheels)
    radii = np.array([w.radius for w in mbm.wheels], dtype=float)
    data = model.createData()
    pin.framesForwardKinematics(model, data, np.asarray(q, float))
    centres = np.array([data.oMf[model.getFrameId(w.frame)].translation for w in mbm.wheels])
    axes = np.array([data.oMf[model.getFrameId(w.frame)].rotation @ np.asarray(w.axis, float)
                     for w in mbm.wheels])
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    supports = np.ones(nw, bool) if supports is None else np.asarray(supports, bool)

    def rim_dir(n, w):
        d = n - (n @ axes[w]) * axes[w]
        return d / np.linalg.norm(d)

    gravity = np.asarray(gravity, float)
    sup = np.flatnonzero(supports)
    indent = np.zeros(nw)
    if np.any(gravity != 0.0) and sup.size:
        sm = station_model(mbm, q, v, support_normal, wheel, normal, supports=supports,
                           gravity=gravity)
        loads = static_loads(sm.G[0, :-1, :-1], (sm.b_g + sm.b_v)[0, :-1])
        indent[sup] = static_indentation(ground_law, loads, v_ref)
    planes, dirs = [], []
    pairs = [(f"support_{g}", support_normal[g], g, ground_law, v_ref)
             for g in sup] + [("feature", normal, wheel, law, 1.0)]
    for name, n, w, lw, vi in pairs:
        n = np.asarray(n, float)
        n = n / np.linalg.norm(n)
        mask = np.zeros(nw, bool)
        mask[w] = True
        d = np.zeros((nw, 3))
        d[:] = [0.0, 0.0, 1.0]
        d[w] = rim_dir(n, w)
        depth = indent[w] if name != "feature" else 0.0
        planes.append(Plane(name, n, centres[w] - radii[w] * d[w] + depth * n, lw, vi,
                            wheels=mask))
        dirs.append(d)
    sysm = DiscContactSystem(model=model, wheel_frames=[w.frame for w in mbm.wheels],
                             radii=radii, planes=planes, gravity=gravity,
                             loop_closure=mbm.loop_closure, rim_dirs=np.array(dirs))
    q0 = np.asarray(q, float)
    v0 = np.asarray(v, float)
    cs0 = sysm.contacts(q0, v0)
    v_n = float(cs0.delta_dot[-1, wheel])
    if not v_n > 0:
        raise SolverError(f"the wheel does not approach the feature (v_n = {v_n:.3g} m/s)")
    v_i = [p.v_i for p in planes]
    v_i[-1] = v_n
    planes[-1].v_i = v_n
    nv = sysm.nv

    def rhs(t, y):
        qq = sysm.config(q0, y[:nv])
        tau = sysm.applied_force(qq, y[nv:], v_i).tau
        return np.concatenate([sysm.chart_rate(q0, y[:nv], y[nv:]),
                               sysm.acceleration(qq, y[nv:], tau)])

    def gap(t, y):
        return float(sysm.gaps(sysm.config(q0, y[:nv]))[-1, wheel])

    gap.terminal, gap.direction = True, 1

    def force(y):
        qq = sysm.config(q0, y[:nv])
        return float(sysm.applied_force(qq, y[nv:], v_i).f_n[-1, wheel])

    # the run starts in contact (gap 0, closing): step off the event's zero first
    y0 = np.concatenate([np.zeros(nv), v0])
    t1 = min(1e-7, 1e-3 * t_after)
    first = solve_ivp(rhs, (0.0, t1), y0, method="LSODA", rtol=rtol, atol=atol)
    sol = solve_ivp(rhs, (t1, t_after), first.y[:, -1], method="LSODA", rtol=rtol, atol=atol,
                    events=[gap], dense_output=True)
    if sol.status < 0:
        raise SolverError(f"the integrator failed: {sol.message}")
    F = np.array([force(y) for y in sol.y.T])
    i = int(np.argmax(F))
    best_f, best_t = float(F[i]), float(sol.t[i])
    for a, b in ((i - 1, i), (i, i + 1)):
        if 0 <= a and b < len(sol.t):
            r = minimize_scalar(lambda t: -force(sol.sol(t)), bounds=(sol.t[a], sol.t[b]),
                                method="bounded", options={"xatol": 1e-12})
            if -r.fun > best_f:
                best_f, best_t = float(-r.fun), float(r.x)
    separated = bool(len(sol.t_events[0]))
    return StationImpact(F_max=best_f, t_peak=best_t, contact_duration=float(sol.t[-1]),
                         separated=separated, v_n=v_n)


@dataclass(frozen=True)
class SimulationCheck:
    """Sampled impacts of a traverse, predicted and simulated (:func:`check_against_simulation`).

    Arrays (n,): ``T_c_minus`` [J], ``m_eff`` [kg], ``v_n`` [m/s] at the reference speed,
    ``F_pred`` [N] (closed form of the law), ``F_model`` [N] (the model of
    :mod:`roverimpact.traverse.refine`, weight and compliant supports), ``F_sim`` [N]
    (simulated at the reference speed), ``v_lim`` [m/s] (the model's speed limit for
    ``F_allow``; 0 where no speed keeps the impact under it), ``F_sim_at_limit`` [N]
    (simulated at ``v_lim``; where ``v_lim`` = 0, at ``s_min`` times the reference speed:
    it must exceed ``F_allow`` there), ``v_lim_closed`` [m/s] (the closed form's limit),
    ``F_sim_at_closed`` [N] (simulated at it), ``beta_deg``; scalars ``u`` [m/s],
    ``F_allow`` [N], ``spearman`` (T_c^- vs F_sim), ``spearman_model`` (F_model vs
    F_sim), ``gravity`` [m/s^2], ``s_min``, ``v_cap`` [m/s] (the model's speed cap,
    :func:`~roverimpact.traverse.refine.model_speed_cap`: a limit at the cap means none
    below it).
    """

    T_c_minus: np.ndarray
    m_eff: np.ndarray
    v_n: np.ndarray
    F_pred: np.ndarray
    F_model: np.ndarray
    F_sim: np.ndarray
    v_lim: np.ndarray
    F_sim_at_limit: np.ndarray
    v_lim_closed: np.ndarray
    F_sim_at_closed: np.ndarray
    beta_deg: np.ndarray
    u: float
    F_allow: float
    spearman: float
    spearman_model: float
    gravity: float
    s_min: float
    v_cap: float

    @property
    def no_speed(self) -> np.ndarray:
        """Impacts over ``F_allow`` at any speed (``v_lim`` = 0)."""
        return self.v_lim == 0.0

    @property
    def capped(self) -> np.ndarray:
        """Impacts under ``F_allow`` up to the model's speed cap (``v_lim`` = ``v_cap``)."""
        return self.v_lim >= self.v_cap * (1.0 - 1e-9)

    @property
    def ratio_at_limit(self) -> np.ndarray:
        """Simulated peak force at the speed limit over the allowable force (at ``s_min u``
        where there is no speed limit)."""
        return self.F_sim_at_limit / self.F_allow

    @property
    def ratio_at_closed(self) -> np.ndarray:
        """Simulated peak force at the closed form's speed limit over the allowable force."""
        return self.F_sim_at_closed / self.F_allow

    @property
    def within(self) -> np.ndarray:
        """The limit holds to 10 %: the simulated F_max at it within 10 % of ``F_allow``;
        where no speed keeps the impact under ``F_allow``, the simulation at ``s_min u`` at
        least 0.9 ``F_allow``; where the limit is the cap, at most 1.1 ``F_allow`` there."""
        r = self.ratio_at_limit
        return np.where(self.no_speed, r >= 0.9,
                        np.where(self.capped, r <= 1.1, np.abs(r - 1.0) <= 0.1))


def check_against_simulation(n: int = 50, *, seed: int = 0, u: float = 0.2,
                             law=None, ground_law=None, terrain_seed: int = 2,
                             rock_abundance: float = 0.15, gravity: float = 9.81,
                             s_min: float = 0.01) -> SimulationCheck:
    """Predicted risk against the compliant simulation at ``n`` seeded traverse impacts.

    The built-in rocker-bogie drives a 25 m sinuous path over a seeded synthetic terrain
    (30 m x 8 m at 5 cm, Golombek-Rapp ``rock_abundance``); of the impacts it meets at
    ``u`` (with ``v_n`` at least 1 % of ``u``: grazing contacts are left out), ``n`` are
    drawn (seeded, stratified over the ranks of T_c^-). Each is simulated
    (:func:`simulate_station_impact`, ``gravity`` [m/s^2] along -z, the supports
    preloaded) at ``u``, at the model's speed limit
    (:func:`~roverimpact.traverse.refine.speed_limits`, capped at
    :func:`~roverimpact.traverse.refine.model_speed_cap`; at ``s_min u`` where it is 0) for
    ``F_allow`` = the median peak force the model
    (:func:`~roverimpact.traverse.refine.peak_forces`) predicts at ``u``, and at the closed
    form's limit for the same ``F_allow``. Laws: the feature
    Hunt-Crossley k = 1e7, e = 0.5; the supports the simulator's default ground law
    (Hunt-Crossley k = 1e7, e = 0.2) unless given.
    """
    from scipy.stats import spearmanr

    from ..contact import get_law
    from ..models import rocker_bogie
    from ..models.terrain_synth import synthetic_mars
    from ..scenario.schema import ContactLawSpec
    from .compute import evaluate_stations, rover_states
    from .limits import peak_force, speed_limit_force
    from .refine import impact_models, model_speed_cap, peak_forces, speed_limits

    spec = law or ContactLawSpec(name="hunt-crossley", k=1e7, e=0.5)
    ground_law = ground_law or get_law("hunt-crossley", k=1e7, e=0.2)
    g = np.array([0.0, 0.0, -float(gravity)])
    terrain = synthetic_mars((30.0, 8.0), 0.05, seed=terrain_seed,
                             rock_abundance=rock_abundance, origin=(0.0, -4.0))
    rb = rocker_bogie()
    s_max = model_speed_cap(rb) / u
    x = np.arange(2.0, 27.0, 0.05)
    y = 0.5 * np.sin(x / 3.0)
    yaw = np.arctan(0.5 / 3.0 * np.cos(x / 3.0))
    r = evaluate_stations(rb, terrain, x, y, yaw, u=u, max_travel=0.1)
    T = r.impact.T_c_minus
    idx = np.argwhere((T > 0) & (r.impact.v_n > 0.01 * u))
    if len(idx) < n:
        raise SolverError(f"only {len(idx)} impacts on the check's path, {n} asked")
    order = idx[np.argsort(T[tuple(idx.T)], kind="stable")]
    rng = np.random.default_rng(seed)
    edges = np.linspace(0, len(order), n + 1).astype(int)
    pick = order[[rng.integers(a, b) for a, b in itertools.pairwise(edges)]]
    k, w = pick[:, 0], pick[:, 1]
    m, vn = r.impact.m_eff[k, w], r.impact.v_n[k, w]
    lw = spec.to_law()
    states = rover_states(rb, r.pose.q[k])
    models = impact_models(rb, states, r.v[k], r.pose.normal[k], np.arange(n), w,
                           r.hit["normal"][k, w], supports=np.ones(len(rb.wheels), bool),
                           gravity=g)
    F = peak_force(spec, m, vn)
    F_model = peak_forces(models, lw, ground_law).peak_force
    F_allow = float(np.median(F_model))
    v_closed = speed_limit_force(spec, m, vn, u, F_allow)
    v_lim = speed_limits(models, lw, ground_law, u, F_allow, s0=v_closed / u, s_min=s_min,
                         s_max=s_max)
    F_sim, F_lim, F_cl = np.empty(n), np.empty(n), np.empty(n)
    for i in range(n):
        args = (r.pose.point[k[i]], r.pose.normal[k[i]], int(w[i]), r.hit["point"][k[i], w[i]],
                r.hit["normal"][k[i], w[i]])

        def sim(speed, i=i, args=args):
            return simulate_station_impact(rb, r.pose.q[k[i]], r.v[k[i]] * speed / u, *args,
                                           law=lw, ground_law=ground_law, gravity=g).F_max

        F_sim[i] = sim(u)
        F_lim[i] = sim(v_lim[i] if v_lim[i] > 0 else s_min * u)
        F_cl[i] = sim(v_closed[i])
    return SimulationCheck(T_c_minus=T[k, w], m_eff=m, v_n=vn, F_pred=F, F_model=F_model,
                           F_sim=F_sim, v_lim=v_lim, F_sim_at_limit=F_lim,
                           v_lim_closed=v_closed, F_sim_at_closed=F_cl,
                           beta_deg=np.degrees(r.hit["beta"][k, w]), u=u, F_allow=F_allow,
                           spearman=float(spearmanr(T[k, w], F_sim)[0]),
                           spearman_model=float(spearmanr(F_model, F_sim)[0]),
                           gravity=float(gravity), s_min=float(s_min), v_cap=s_max * u)
