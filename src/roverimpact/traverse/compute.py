r"""Along a path: the rover on the terrain, the next impact of every wheel, T_c^- of each.

For a batch of stations (base x, y and yaw on the path) :func:`evaluate_stations`

1. places the rover on the terrain (:func:`place_on_path`: the pose-on-terrain solver of
   :mod:`roverimpact.models.pose`, batched, warm-started from every ``stride``-th station);
2. gives it the **driving velocity** at the reference speed ``u`` (:func:`driving_velocity`):
   the base moving horizontally along its heading at ``u`` (``scenario.build.velocity``,
   wheels rolling), plus the rates of the pose's unknowns (height, roll, pitch, suspension)
   that keep every supporting wheel on the terrain and the loops closed,
   :math:`C\,(v_u + T\,\dot x) = 0` with :math:`C` the support rows
   :math:`n_w^T J_p(p_w)` and the loop rows (least squares, minimum norm);
3. finds, for every wheel, the next terrain point it meets rolling off its support
   (:func:`~roverimpact.traverse.lookahead.first_contact_ahead`, look-ahead ``max_travel``);
4. builds the candidate rows of that impact exactly as a scenario does
   (:func:`roverimpact.scenario.build.candidate_constraints`, same labels and order): a
   normal row (and no-slip rows for ``ground = "noslip"``/``"coulomb"``) at the support of
   every other supporting wheel, with the terrain normal there; the loop closure; locked
   joints; the obstacle row :math:`a = n^T J_p` at the contact point of the hitting wheel
   (lever from the wheel centre as at contact: the rover translated rigidly by the travel,
   which leaves M and the Jacobians unchanged);
5. chooses the active rows with :func:`roverimpact.scenario.build.active_mask` (the one
   place the active set is chosen; ``"auto"``: the contacts that hold through the impact)
   and computes, batched over stations, :math:`T_c^-` (:func:`roverimpact.partition` of the
   active rows), :math:`v_n = -a v` and :math:`m_{eff}` along the normal with the other
   active rows held (:func:`roverimpact.effective_mass`).

With the driving velocity every support row and loop row has zero rate, so
:math:`T_c^- = \tfrac12 m_{eff} v_n^2` exactly; an impact needs :math:`v_n` above the
touching speed :math:`u\sqrt{2\,\delta/r}` (:func:`touch_speeds`; a contact found ahead
that the wheel does not approach faster is no impact: T_c^- = 0). A wheel of radius ``r``
rolling at ``u`` onto a bump of height ``h`` meets it at the rim angle
:math:`\theta`, :math:`r(1 - \cos\theta) = h`, with :math:`v_n = u \sin\theta \approx
u\sqrt{2h/r}`; :math:`\delta` = :data:`POSE_TOL`, the pose solver's tolerance on every
wheel's gap, below which a terrain point ahead cannot be told from the wheel's own
support (a height field of a plane with rounding-level noise gave such "impacts").
:func:`roverimpact.scenario.ImpactSetup.from_state` computes the same numbers one impact at
a time (the tests compare them).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from ..energy import effective_mass, partition
from ..exceptions import InputError
from ..models.declare import base_info
from ..models.joints import lock_row
from ..models.pose import PoseProblem, TerrainPose, place, pose_on_terrain
from ..scenario.build import active_mask, friction_of, velocity
from ..scenario.schema import ContactsSpec, VelocitySpec
from .lookahead import first_contact_ahead

__all__ = ["POSE_TOL", "ImpactBatch", "RoverStates", "StationResult", "drive_velocity",
           "driving_velocity", "evaluate_stations", "impact_energies", "place_on_path",
           "point_rows", "rover_states", "touch_speeds"]

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED

#: Tolerance [m] of the pose solver on every wheel's gap (:func:`place_on_path`); a new
#: contact lower than this above the wheel's rolling line is touching (:func:`touch_speeds`).
POSE_TOL = 1e-9


def touch_speeds(radius, u: float, tol: float = POSE_TOL) -> np.ndarray:
    r"""Normal approach speed [m/s] at or below which a wheel of ``radius`` [m] driven at
    ``u`` only touches what it meets: :math:`u\sqrt{2\,tol/r}`, the approach of a wheel
    rolling at ``u`` onto a bump ``tol`` high (:math:`v_n = u\sin\theta`,
    :math:`r(1 - \cos\theta) = tol`). Proportional to ``u``, as every ``v_n`` of a pose is,
    so whether an event is an impact does not depend on the speed."""
    return float(u) * np.sqrt(2.0 * tol / np.asarray(radius, dtype=float))


# ------------------------------------------------------------------------------ poses
def place_on_path(mbm, terrain, x, y, yaw, *, wheels=None, fixed=(), stride: int = 4,
                  tol: float = POSE_TOL, max_iter: int = 20, q0=None) -> TerrainPose:
    """The rover posed at every station ``(x, y, yaw)`` (arrays (k,)), batched.

    Every ``stride``-th station (and the last) is solved from the nominal pose lifted to
    the terrain height; the others start from the linear interpolation of those solutions
    (base height, attitude and suspension), which halves the Gauss-Newton steps. A station
    that fails from the interpolated guess is retried from the nominal one. Failed
    stations keep ``status != "ok"`` (no exception).
    """
    x, y, yaw = (np.atleast_1d(np.asarray(a, dtype=float)) for a in (x, y, yaw))
    k = x.size
    z_nom = place(mbm, 0.0, 0.0, 0.0, q=q0)
    kind = base_info(mbm).kind

    def guess(i, q=None):
        return place(mbm, x[i], y[i], yaw[i] if kind == "floating" else 0.0,
                     q=z_nom if q is None else q)

    def nominal(idx):
        Q = np.array([guess(i) for i in idx]).reshape(-1, mbm.model.nq)
        if kind == "floating":
            Q[:, 2] += terrain.height(x[idx], y[idx])
        elif kind == "planar":
            jz = mbm.model.joints[mbm.model.getJointId(base_info(mbm).joints[1])].idx_q
            Q[:, jz] += terrain.height(x[idx], y[idx])
        return Q

    stride = max(1, int(stride))
    coarse = np.unique(np.r_[np.arange(0, k, stride), k - 1])
    first = pose_on_terrain(mbm, terrain, nominal(coarse), wheels=wheels, fixed=fixed,
                            tol=tol, max_iter=max_iter, check=False)
    Q = np.empty((k, mbm.model.nq))
    status = np.empty(k, dtype=object)
    fields_ = {}
    Q[coarse] = first.q.reshape(-1, mbm.model.nq)
    status[coarse] = np.asarray(first.status).reshape(-1)
    rest = np.setdiff1d(np.arange(k), coarse)
    result = None
    if rest.size:
        good = coarse[status[coarse] == "ok"]
        if good.size:
            j = np.clip(np.searchsorted(good, rest), 1, max(good.size - 1, 1))
            a = good[np.clip(j - 1, 0, good.size - 1)]
            b = good[np.clip(j, 0, good.size - 1)]
            w = np.where(b > a, (rest - a) / np.maximum(b - a, 1), 0.0)[:, None]
            Qi = (1 - w) * Q[a] + w * Q[b]
            G = np.array([guess(i, q) for i, q in zip(rest, Qi, strict=True)])
        else:
            G = nominal(rest)
        second = pose_on_terrain(mbm, terrain, G, wheels=wheels, fixed=fixed, tol=tol,
                                 max_iter=max_iter, check=False)
        st2 = np.asarray(second.status).reshape(-1)
        Q[rest] = second.q.reshape(-1, mbm.model.nq)
        status[rest] = st2
        fields_[1] = (rest, second)
    fields_[0] = (coarse, first)
    # retry failures from the nominal guess (coarse failures from a neighbour's solution)
    bad = np.flatnonzero(status != "ok")
    retry = None
    if bad.size:
        ok = np.flatnonzero(status == "ok")
        if ok.size:
            near = ok[np.clip(np.searchsorted(ok, bad), 0, ok.size - 1)]
            G = np.array([guess(i, Q[j]) for i, j in zip(bad, near, strict=True)])
            from_coarse = np.isin(bad, coarse)
            G[~from_coarse] = nominal(bad[~from_coarse])
        else:
            G = nominal(bad)
        retry = pose_on_terrain(mbm, terrain, G, wheels=wheels, fixed=fixed, tol=tol,
                                max_iter=max(4, max_iter // 2), check=False)
        fields_[2] = (bad, retry)
    # assemble one TerrainPose over all stations (the latest attempt of each station wins)
    nw = len(mbm.wheels)
    gap = np.full((k, nw), np.nan)
    point = np.full((k, nw, 3), np.nan)
    normal = np.full((k, nw, 3), np.nan)
    iters = np.zeros(k, dtype=int)
    rank = np.zeros(k, dtype=int)
    loop = None
    for key in sorted(fields_):
        idx, res = fields_[key]
        st = np.asarray(res.status).reshape(-1)
        take = np.ones(idx.size, bool) if key < 2 else (st == "ok")
        if key == 2:
            status[idx[take]] = st[take]
        sel = idx[take]
        Q[sel] = res.q.reshape(-1, mbm.model.nq)[take]
        gap[sel] = res.gap.reshape(-1, nw)[take]
        point[sel] = res.point.reshape(-1, nw, 3)[take]
        normal[sel] = res.normal.reshape(-1, nw, 3)[take]
        iters[sel] += np.asarray(res.iterations).reshape(-1)[take]
        rank[sel] = np.asarray(res.rank).reshape(-1)[take]
        lr = res.loop_residual.reshape(idx.size, -1)
        if loop is None:
            loop = np.full((k, lr.shape[1]), np.nan)
        loop[sel] = lr[take]
        result = res
    return TerrainPose(q=Q, wheels=result.wheels, chosen=result.chosen, gap=gap, point=point,
                       normal=normal, loop_residual=loop, iterations=iters,
                       solved=result.solved, rank=rank, status=status.astype(str))


# ------------------------------------------------------------------------------ states
@dataclass(frozen=True)
class RoverStates:
    """Kinematics of the posed rover at every station (batch axis k first).

    Attributes
    ----------
    q : (k, nq)
    M : (k, nv, nv)
        Mass matrix (Pinocchio CRBA).
    J : (k, n_wheels, 6, nv)
        ``LOCAL_WORLD_ALIGNED`` frame Jacobian of every wheel frame (linear; angular).
    centre, axis : (k, n_wheels, 3)
        Wheel centres [m] and unit spin axes (world).
    loop_J : (k, n_loop, nv)
        Loop-closure rows (n_loop = 0 without loops).
    """

    q: np.ndarray
    M: np.ndarray
    J: np.ndarray
    centre: np.ndarray
    axis: np.ndarray
    loop_J: np.ndarray


def rover_states(mbm, Q, *, loop_closure: bool = True) -> RoverStates:
    """One Pinocchio pass per configuration: M, wheel frame Jacobians, centres, axes."""
    model = mbm.model
    data = model.createData()
    Q = np.asarray(Q, dtype=float).reshape(-1, model.nq)
    k, nv, nw = Q.shape[0], model.nv, len(mbm.wheels)
    fids = [model.getFrameId(w.frame) for w in mbm.wheels]
    axes = np.array([w.axis for w in mbm.wheels], dtype=float)
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    loop = mbm.loop_closure if loop_closure else None
    nl = 0 if loop is None else int(np.atleast_1d(np.asarray(loop(Q[0])[0])).size) if k else 0
    M = np.empty((k, nv, nv))
    J = np.empty((k, nw, 6, nv))
    C = np.empty((k, nw, 3))
    A = np.empty((k, nw, 3))
    L = np.empty((k, nl, nv))
    for i in range(k):
        Mi = pin.crba(model, data, Q[i])
        M[i] = np.triu(Mi) + np.triu(Mi, 1).T
        pin.computeJointJacobians(model, data, Q[i])
        pin.updateFramePlacements(model, data)
        for w, f in enumerate(fids):
            oMf = data.oMf[f]
            C[i, w] = oMf.translation
            A[i, w] = oMf.rotation @ axes[w]
            J[i, w] = np.asarray(pin.getFrameJacobian(model, data, f, _LWA)).reshape(6, nv)
        if nl:
            L[i] = np.asarray(loop(Q[i])[1], dtype=float).reshape(nl, nv)
    return RoverStates(q=Q, M=M, J=J, centre=C, axis=A, loop_J=L)


def point_rows(J, lever, dirs):
    r"""Rows :math:`d^T J_p` of points at ``lever`` from the frame origin:
    :math:`d^T J_{lin} + (r \times d)^T J_{ang}`. ``J (..., 6, nv)``, ``lever (..., 3)``,
    ``dirs (..., m, 3)`` -> ``(..., m, nv)``."""
    rxd = np.cross(lever[..., None, :], dirs)
    return (np.einsum("...mj,...jv->...mv", dirs, J[..., :3, :])
            + np.einsum("...mj,...jv->...mv", rxd, J[..., 3:, :]))


def _tangent_dirs(axis, n, planar: bool):
    """No-slip directions of :class:`roverimpact.models.constraints.GroundContact`:
    long = a x n (unit), lat = n x long."""
    t = np.cross(axis, n)
    t /= np.linalg.norm(t, axis=-1)[..., None]
    return [t] if planar else [t, np.cross(n, t)]


def _spin_index(mbm, wheel) -> int | None:
    name = wheel.spin if wheel.spin is not None else (
        wheel.frame if mbm.model.existJointName(wheel.frame) else None)
    if name is None:
        return None
    return int(np.flatnonzero(lock_row(mbm, name, what="wheel spin"))[0])


def drive_velocity(mbm, Q, u: float) -> np.ndarray:
    """``scenario.build.velocity(mbm, q, VelocitySpec(u=u))`` for every row of ``Q``
    (k, nq), vectorised: the base moving horizontally along its heading at ``u`` (a
    floating base: world velocity ``u h``, ``h`` the chassis x axis made horizontal, in
    the base's axes; a planar base: x rate ``u``), wheels spinning at ``u / r``."""
    Q = np.asarray(Q, dtype=float).reshape(-1, mbm.model.nq)
    V0 = velocity(mbm, Q[0], VelocitySpec(u=float(u)))
    V = np.broadcast_to(V0, (Q.shape[0], V0.size)).copy()
    info = base_info(mbm)
    if info.kind == "floating":
        j = mbm.model.joints[mbm.model.getJointId(info.joints[0])]
        iq, iv = j.idx_q, j.idx_v
        x, y, z, w = (Q[:, iq + 3 + i] for i in range(4))
        nrm = x * x + y * y + z * z + w * w
        s = 2.0 / nrm
        R = np.empty((Q.shape[0], 3, 3))             # rotation of the unit quaternion
        R[:, 0, 0] = 1 - s * (y * y + z * z)
        R[:, 0, 1] = s * (x * y - z * w)
        R[:, 0, 2] = s * (x * z + y * w)
        R[:, 1, 0] = s * (x * y + z * w)
        R[:, 1, 1] = 1 - s * (x * x + z * z)
        R[:, 1, 2] = s * (y * z - x * w)
        R[:, 2, 0] = s * (x * z - y * w)
        R[:, 2, 1] = s * (y * z + x * w)
        R[:, 2, 2] = 1 - s * (x * x + y * y)
        h = R[:, :, 0].copy()
        h[:, 2] = 0.0
        h /= np.linalg.norm(h, axis=1)[:, None]
        V[:, iv:iv + 3] = np.einsum("kji,kj->ki", R, u * h)
        V[:, iv + 3:iv + 6] = 0.0
    return V


def driving_velocity(mbm, problem: PoseProblem, states: RoverStates, support, normal, u,
                     *, chosen, rolling: bool = False) -> np.ndarray:
    r"""The rover driving at ``u`` along its heading over the terrain, (k, nv).

    :math:`v = v_u + T\dot x` with :math:`v_u` the scenario's ``[velocity] u``
    (:func:`drive_velocity`: the base moving horizontally along its heading at ``u``,
    wheels spinning at ``u/r``), ``T`` the pose problem's tangent map and :math:`\dot x`
    the minimum-norm least-squares solution of :math:`C T \dot x = -C v_u`, ``C`` the
    support rows of the ``chosen`` wheels (:math:`n_w^T J_p(p_w)`) and the loop rows: the
    rate of the pose along the path. With ``rolling``, each wheel's spin is then set so
    that its support point does not slip along ``a x n`` (the no-slip rows of a
    scenario's ``ground = "noslip"``).
    """
    k = states.q.shape[0]
    V = drive_velocity(mbm, states.q, u)
    T = np.array([problem.tangent(q) for q in states.q]).reshape(k, mbm.model.nv, problem.nx)
    ic = np.flatnonzero(chosen)
    lever = support[:, ic] - states.centre[:, ic]
    rows = point_rows(states.J[:, ic], lever, normal[:, ic, None, :])[:, :, 0, :]
    C = np.concatenate([rows, states.loop_J], axis=1)
    G = C @ T
    rhs = -np.einsum("kmv,kv->km", C, V)
    dx = np.einsum("kxm,km->kx", np.linalg.pinv(G, rcond=1e-10), rhs)
    V = V + np.einsum("kvx,kx->kv", T, dx)
    if rolling:
        for w, wheel in enumerate(mbm.wheels):
            j = _spin_index(mbm, wheel)
            if j is None:
                continue
            lev = support[:, w] - states.centre[:, w]
            t = _tangent_dirs(states.axis[:, w], normal[:, w], True)[0]
            Jp = point_rows(states.J[:, w], lev, t[:, None, :])[:, 0, :]
            slip = np.einsum("kv,kv->k", Jp, V)
            col = Jp[:, j]
            ok = np.abs(col) > 1e-12
            V[ok, j] -= slip[ok] / col[ok]
    return V


# ------------------------------------------------------------------------------ impacts
@dataclass(frozen=True)
class ImpactBatch:
    """T_c^- and its companions of every (station, wheel) impact; shapes (k, n_wheels).

    ``T_c_minus`` [J] (0 where no impact: nothing found ahead, or not approached),
    ``v_n`` [m/s] (normal approach speed; NaN where nothing found), ``m_eff`` [kg] (along
    the normal, the other active rows held; NaN without impact), ``rank`` (of the active
    rows), ``held`` (the labels of the active rows other than the obstacle's, ``;``-joined).
    """

    T_c_minus: np.ndarray
    v_n: np.ndarray
    m_eff: np.ndarray
    rank: np.ndarray
    held: np.ndarray


def _labels(mbm, obstacle: str, ground: list, contacts: ContactsSpec, planar: bool,
            loop_closure: bool):
    """Candidate row labels in the order of ``scenario.build.candidate_constraints``."""
    labels = []
    for g in ground:
        labels.append(f"ground:{g}:normal")
        if contacts.ground in ("noslip", "coulomb"):
            labels.append(f"ground:{g}:long")
            if not planar:
                labels.append(f"ground:{g}:lat")
    if loop_closure and mbm.loop_closure is not None:
        labels += [f"loop:{n}" for n in mbm.loop_names]
    labels += [f"lock:{j}" for j in contacts.locked]
    labels.append(f"obstacle:{obstacle}:normal")
    return labels


def impact_energies(mbm, states: RoverStates, v, support, normal, hit, *, chosen,
                    contacts: ContactsSpec = ContactsSpec(), constraints="auto",
                    planar: bool = False, touch=0.0) -> ImpactBatch:
    """T_c^-, v_n, m_eff of every wheel's impact (module docstring, steps 4 and 5).

    Parameters
    ----------
    mbm : MultibodyModel
    states : RoverStates
    v : (k, nv)
        Driving velocity at the reference speed.
    support, normal : (k, n_wheels, 3)
        Support point of every wheel and the terrain normal there.
    hit : AheadContact
        :func:`first_contact_ahead` of every wheel, batch (k, n_wheels).
    chosen : (n_wheels,) bool
        The wheels on the terrain (ground-contact candidates).
    contacts : ContactsSpec
        ``ground`` (friction model), ``mu``, ``locked``, ``loop_closure`` as in a scenario.
    constraints : "auto", "all" or list of str
        :func:`roverimpact.scenario.build.active_mask`.
    planar : bool
        A planar model (no lateral no-slip row).
    touch : float or (n_wheels,) array_like
        Normal approach speed [m/s] of each wheel at or below which a contact is touching,
        no impact (T_c^- = 0, ``v_n`` kept): :func:`touch_speeds` at the reference speed.
    """
    k, nw = states.centre.shape[:2]
    touch = np.broadcast_to(np.asarray(touch, dtype=float), (nw,))
    nv = states.M.shape[-1]
    T_c = np.zeros((k, nw))
    v_n = np.full((k, nw), np.nan)
    m_eff = np.full((k, nw), np.nan)
    rank = np.zeros((k, nw), dtype=int)
    held = np.full((k, nw), "", dtype=object)
    names = [w.name for w in mbm.wheels]
    lock_rows = np.array([lock_row(mbm, j) for j in contacts.locked]).reshape(-1, nv)
    friction = friction_of(contacts)
    noslip = contacts.ground in ("noslip", "coulomb")
    for w in range(nw):
        items = np.flatnonzero(np.asarray(hit.found)[:, w])
        if items.size == 0:
            continue
        ground = [g for g in range(nw) if chosen[g] and g != w]
        labels = _labels(mbm, names[w], [names[g] for g in ground], contacts, planar,
                         contacts.loop_closure)
        blocks = []
        if ground:
            lev = support[items][:, ground] - states.centre[items][:, ground]
            nrm = normal[items][:, ground]
            dirs = [nrm]
            if noslip:
                dirs += _tangent_dirs(states.axis[items][:, ground], nrm, planar)
            D = np.stack(dirs, axis=2)                       # (b, g, d, 3)
            R = point_rows(states.J[items][:, ground], lev, D)  # (b, g, d, nv)
            blocks.append(R.reshape(items.size, -1, nv))
        if contacts.loop_closure and mbm.loop_closure is not None:
            blocks.append(states.loop_J[items])
        if lock_rows.size:
            blocks.append(np.broadcast_to(lock_rows, (items.size, *lock_rows.shape)))
        n_hit = np.asarray(hit.normal)[items, w]
        lev = np.asarray(hit.point)[items, w] - np.asarray(hit.centre)[items, w]
        a = point_rows(states.J[items, w], lev, n_hit[:, None, :])
        blocks.append(a)
        A = np.concatenate(blocks, axis=1)
        M, vv = states.M[items], v[items]
        vn = -np.einsum("bv,bv->b", a[:, 0], vv)
        v_n[items, w] = vn
        app = vn > max(touch[w], 0.0)
        if not app.any():
            continue
        it, A, M, vv = items[app], A[app], M[app], vv[app]
        keep = active_mask(constraints, labels, M, A, vv, obstacle_row=len(labels) - 1,
                           **friction)
        Aa = A * keep[..., None]
        p = partition(M, Aa, vv, want_velocities=False)
        T_c[it, w] = p.T_c
        rank[it, w] = p.rank
        m_eff[it, w] = effective_mass(M, Aa[:, -1], held=Aa[:, :-1], single_row=True)
        lab = np.array(labels[:-1], dtype=object)
        held[it, w] = [";".join(lab[kk[:-1]]) for kk in keep]
    return ImpactBatch(T_c_minus=T_c, v_n=v_n, m_eff=m_eff, rank=rank, held=held)


# ------------------------------------------------------------------------------ stations
@dataclass
class StationResult:
    """Everything computed at a batch of stations (see :func:`evaluate_stations`):
    ``pose``, driving velocity ``v`` (k, nv), the contacts ahead ``hit`` (arrays (k, nw)),
    ``impact`` (:class:`ImpactBatch`), ``extra["wheel_speed"]`` (k, nw): the speed of each
    wheel centre under the driving velocity [m/s]; ``extra["chosen"]`` the wheels on the
    terrain; ``extra["states"]`` (:class:`RoverStates` of the posed stations) and
    ``extra["ok_index"]`` (their indices) where any station was posed."""

    pose: TerrainPose
    v: np.ndarray
    hit: object
    impact: ImpactBatch
    wheels: tuple[str, ...]
    extra: dict = field(default_factory=dict)


def evaluate_stations(mbm, terrain, x, y, yaw, *, u: float, max_travel: float,
                      contacts: ContactsSpec = ContactsSpec(), constraints="auto",
                      wheels=None, step: float | None = None, stride: int = 4,
                      q0=None) -> StationResult:
    """Poses, driving velocities, next contacts and impact energies at stations (k,).

    Stations whose pose failed have NaN/zero results (``pose.status`` says why).

    Parameters
    ----------
    mbm : MultibodyModel
    terrain : Terrain
    x, y, yaw : (k,) array_like
        Base position [m] and heading [rad] of each station.
    u : float
        Reference speed [m/s] (> 0).
    max_travel : float
        Look-ahead of every wheel [m].
    contacts : ContactsSpec
        ``ground``, ``mu``, ``locked`` (rows of every impact; the suspension joints among
        them also held at the nominal in the pose), ``loop_closure``.
    constraints : "auto", "all" or list of str
    wheels : sequence of str, optional
        Wheels placed on the terrain (default all).
    step : float, optional
        Scan step of the look-ahead.
    stride : int
        Warm-start stride of :func:`place_on_path`.
    q0 : (nq,), optional
        Nominal configuration (suspension angles of the guesses).
    """
    if not (np.isfinite(u) and u > 0):
        raise InputError(f"the reference speed must be > 0 m/s, got {u}")
    # the locked joints that are pose unknowns (suspension joints) stay at the nominal;
    # the others (a robot file's steering) are not solved for anyway
    fixed = [j for j in contacts.locked if j in mbm.lockable_joints]
    pose = place_on_path(mbm, terrain, x, y, yaw, wheels=wheels, fixed=fixed, stride=stride,
                         q0=q0)
    ok = np.asarray(pose.status) == "ok"
    k, nw = pose.gap.shape
    chosen = np.array([n in pose.chosen for n in pose.wheels])
    planar = bool(mbm.params.get("planar", False)) or base_info(mbm).kind == "planar"
    problem = PoseProblem(mbm, terrain, wheels=list(pose.chosen), fixed=fixed)
    idx = np.flatnonzero(ok)
    nv = mbm.model.nv
    v = np.full((k, nv), np.nan)
    T_c = np.zeros((k, nw))
    nan = np.full((k, nw), np.nan)
    hit_all = {"found": np.zeros((k, nw), bool), "distance": np.full((k, nw), np.inf),
               "point": np.full((k, nw, 3), np.nan), "normal": np.full((k, nw, 3), np.nan),
               "beta": nan.copy(), "alpha": nan.copy(), "centre": np.full((k, nw, 3), np.nan)}
    speed = nan.copy()
    imp = ImpactBatch(T_c_minus=T_c, v_n=nan.copy(), m_eff=nan.copy(),
                      rank=np.zeros((k, nw), int), held=np.full((k, nw), "", dtype=object))
    if idx.size:
        st = rover_states(mbm, pose.q[idx], loop_closure=contacts.loop_closure)
        sup, nrm = pose.point[idx], pose.normal[idx]
        vi = driving_velocity(mbm, problem, st, sup, nrm, u, chosen=chosen,
                              rolling=contacts.ground != "normal")
        v[idx] = vi
        speed[idx] = np.linalg.norm(np.einsum("kwjv,kv->kwj", st.J[:, :, :3], vi), axis=-1)
        heading = np.stack([np.cos(yaw), np.sin(yaw), np.zeros_like(yaw)], -1)[idx] \
            if base_info(mbm).kind == "floating" else np.tile([1.0, 0.0, 0.0], (idx.size, 1))
        hit = first_contact_ahead(terrain, st.centre, st.axis,
                                  np.array([w.radius for w in mbm.wheels]),
                                  np.broadcast_to(heading[:, None, :], st.centre.shape),
                                  sup, max_travel=max_travel, step=step)
        for key in hit_all:
            hit_all[key][idx] = getattr(hit, key)
        ib = impact_energies(mbm, st, vi, sup, nrm, hit, chosen=chosen, contacts=contacts,
                             constraints=constraints, planar=planar,
                             touch=touch_speeds([w.radius for w in mbm.wheels], u))
        for key in ("T_c_minus", "v_n", "m_eff", "rank", "held"):
            getattr(imp, key)[idx] = getattr(ib, key)
    x_, y_, yaw_ = (np.atleast_1d(np.asarray(a, float)) for a in (x, y, yaw))
    extra = {"x": x_, "y": y_, "yaw": yaw_, "wheel_speed": speed, "chosen": chosen}
    if idx.size:
        extra["states"], extra["ok_index"] = st, idx
    return StationResult(pose=pose, v=v, hit=hit_all, impact=imp, wheels=pose.wheels,
                         extra=extra)
