r"""Peak force and speed limit of a traverse impact with the weight and the compliant ground.

The closed form (:func:`~roverimpact.traverse.limits.peak_force`) is the peak of a mass
:math:`m_{eff}` hitting the feature's law at :math:`v_n` with the other contacts rigid and
no weight. A rover on a terrain stands on compliant ground that carries its weight: the
supports give way during the impact (the closed form is then high) and the feature takes
over part of the weight (it is then low). At the speeds rovers drive the weight share is
of the order of the impact force itself.

:func:`impact_models` builds the contact-space model of
:mod:`roverimpact.contact.reduced` for a batch of traverse impacts (:func:`station_model`
for one): at the frozen terrain pose, the normal rows of every supporting wheel (terrain
normal at its support) and the row of the feature (normal at the contact found ahead),
each at the rim point of the wheel's disc facing its normal (the geometry of the indicator
and of the validation harness, :mod:`roverimpact.traverse.validate`); the loop closure and
locked joints held rigidly; gravity and the Coriolis and centrifugal terms of the driving
velocity. The supports start at their static loads (preloaded); the feature is met at
:math:`v_n`. :func:`peak_forces` integrates it (compiled, batched: about 0.1-1 ms an
impact).

Driving at :math:`s\,u_{ref}` scales the driving velocity by ``s``: the approach rates by
``s``, the velocity terms of :math:`\tau` by :math:`s^2`, gravity not at all. The peak
force is then no power of ``s`` (the weight share does not scale), so
:func:`speed_limits` finds the speed at which it reaches the allowable force by a search in
:math:`(\log s, \log F)` started from the closed-form limit (a handful of evaluations).
Where the feature met at the slowest speed considered (1 % of the reference) already
exceeds the allowable force, no speed keeps the impact under it: the limit is 0.

**Range.** The pose is frozen: valid while the rover travels a small part of a wheel
radius during the window in which the peak is sought. :func:`model_speed_cap` (half the
smallest radius in the window, 1 m/s for the built-in rocker-bogie and a 50 ms window)
caps the limits; a limit at the cap means "none below it".

Not modelled: joint springs of the model, friction, the change of pose during the impact,
the terrain beyond the tangent planes of the contacts. Checked against the compliant
multibody simulation of each impact in tests/test_traverse_physics.py (docs/traverse.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..contact.reduced import held_inverse, law_form, reduced_impact, reduced_impact_batch
from ..exceptions import InputError, SolverError
from ..models.constraints import RIM_AXIS_TOL
from ..models.joints import lock_row
from ..scenario.schema import GRAVITY

__all__ = ["EARTH", "ImpactModels", "ModelPeaks", "impact_models", "model_speed_cap",
           "peak_forces", "speed_limits", "station_model"]

#: gravity of the harness and of the model unless told [m/s^2]
EARTH = np.array([0.0, 0.0, -GRAVITY["earth"]])


@dataclass(frozen=True)
class ImpactModels:
    """The contact-space models of a batch of traverse impacts (:func:`impact_models`).

    Attributes
    ----------
    G : (B, m, m) ndarray
        :math:`A N A^T` of the support rows, then the feature row [1/kg].
    b_g, b_v : (B, m) ndarray
        :math:`A N \\tau` of gravity and of the velocity terms at the reference speed
        [m/s^2].
    rate0 : (B, m) ndarray
        Penetration rates :math:`-A v` at the reference speed [m/s]; the last is
        :math:`v_n`.
    """

    G: np.ndarray
    b_g: np.ndarray
    b_v: np.ndarray
    rate0: np.ndarray

    def __len__(self) -> int:
        return self.G.shape[0]

    @property
    def v_n(self) -> np.ndarray:
        return self.rate0[:, -1]

    @property
    def finite(self) -> np.ndarray:
        """Items whose model is finite (a contact normal along a wheel's axis has no rim
        point facing it: NaN rows)."""
        return (np.isfinite(self.G).all(axis=(1, 2)) & np.isfinite(self.b_g).all(axis=1)
                & np.isfinite(self.b_v).all(axis=1) & np.isfinite(self.rate0).all(axis=1))

    def __getitem__(self, i) -> ImpactModels:
        i = np.atleast_1d(np.arange(len(self))[i])
        return ImpactModels(self.G[i], self.b_g[i], self.b_v[i], self.rate0[i])


def _rim_rows(J, axis, radius, n):
    """Rows n^T J_p of the rim points facing ``n`` (``c - r d``, ``d`` the unit part of
    ``n`` orthogonal to the axis, as ``models.constraints.wheel_contact_point``): J (..., 6,
    nv), axis, n (..., 3), radius (...,) -> (..., nv); NaN where ``n`` is along the axis (no
    rim point faces it)."""
    from .compute import point_rows

    n = n / np.linalg.norm(n, axis=-1)[..., None]
    d = n - np.einsum("...j,...j->...", n, axis)[..., None] * axis
    nd = np.linalg.norm(d, axis=-1)[..., None]
    # along the axis to rounding (the row assembly's RIM_AXIS_TOL): a bare d /= |d|
    # turned a residual of 1e-16 into an arbitrary rim point and a finite model
    d = np.where(nd < RIM_AXIS_TOL, np.nan, d / np.maximum(nd, 1e-300))
    return point_rows(J, -radius[..., None] * d, n[..., None, :])[..., 0, :]


def impact_models(mbm, states, v, support_normal, station, wheel, normal, *, supports,
                  locked=(), gravity=EARTH, loop_closure: bool = True) -> ImpactModels:
    """The models of the impacts (``station[i]``, ``wheel[i]``) against features of
    ``normal[i]`` (module docstring), batched.

    Parameters
    ----------
    mbm : MultibodyModel
    states : RoverStates
        :func:`~roverimpact.traverse.compute.rover_states` of the stations (k of them).
    v : (k, nv)
        Driving velocities at the reference speed.
    support_normal : (k, n_wheels, 3)
        Terrain normals at the supports.
    station, wheel : (B,) int
    normal : (B, 3)
        The features' normals.
    supports : (n_wheels,) bool
        The wheels standing on the terrain.
    locked : sequence of str
        Joints held fixed (rigid rows, as the loop closure).
    gravity : (3,)
        [m/s^2].
    """
    import pinocchio as pin

    station = np.asarray(station, int).reshape(-1)
    wheel = np.asarray(wheel, int).reshape(-1)
    normal = np.asarray(normal, float).reshape(-1, 3)
    B, nv = station.size, states.M.shape[-1]
    sup = np.flatnonzero(np.asarray(supports, bool))
    radii = np.array([w.radius for w in mbm.wheels], float)
    model = pin.Model(mbm.model)
    model.gravity.linear = np.asarray(gravity, float)
    data = model.createData()
    uniq, inv = np.unique(station, return_inverse=True)
    # per station: N (bilateral rows held), generalized gravity and velocity terms
    N = np.empty((uniq.size, nv, nv))
    tau_g = np.empty((uniq.size, nv))
    tau_v = np.empty((uniq.size, nv))
    lock = np.array([lock_row(mbm, j) for j in locked]).reshape(-1, nv)
    loops = loop_closure and mbm.loop_closure is not None and states.loop_J.shape[1] > 0
    for j, kk in enumerate(uniq):
        q, vv = states.q[kk], v[kk]
        N[j] = held_inverse(states.M[kk],
                            np.concatenate([states.loop_J[kk], lock]) if loops else lock)
        g = pin.computeGeneralizedGravity(model, data, q)
        tau_g[j] = -g
        tau_v[j] = -(pin.nonLinearEffects(model, data, q, vv) - g)
    st = station
    with np.errstate(invalid="ignore", divide="ignore"):
        rows_s = _rim_rows(states.J[st][:, sup], states.axis[st][:, sup],
                           np.broadcast_to(radii[sup], (B, sup.size)),
                           np.asarray(support_normal, float)[st][:, sup])   # (B, s, nv)
        row_f = _rim_rows(states.J[st, wheel], states.axis[st, wheel], radii[wheel],
                          normal)                                            # (B, nv)
    A = np.concatenate([rows_s, row_f[:, None, :]], axis=1)                  # (B, m, nv)
    AN = np.einsum("bmv,bvw->bmw", A, N[inv])
    G = np.einsum("bmv,bnv->bmn", AN, A)
    return ImpactModels(G=0.5 * (G + np.swapaxes(G, 1, 2)),
                        b_g=np.einsum("bmv,bv->bm", AN, tau_g[inv]),
                        b_v=np.einsum("bmv,bv->bm", AN, tau_v[inv]),
                        rate0=-np.einsum("bmv,bv->bm", A, np.asarray(v, float)[st]))


def station_model(mbm, q, v, support_normal, wheel: int, normal, *, supports=None,
                  locked=(), gravity=EARTH, loop_closure: bool = True) -> ImpactModels:
    """:func:`impact_models` of one impact from the pose ``q`` driving at ``v``
    (``support_normal`` (n_wheels, 3); ``supports`` default all wheels)."""
    from .compute import rover_states

    states = rover_states(mbm, np.asarray(q, float)[None, :], loop_closure=loop_closure)
    supports = np.ones(len(mbm.wheels), bool) if supports is None else supports
    return impact_models(mbm, states, np.asarray(v, float)[None, :],
                         np.asarray(support_normal, float)[None], [0], [wheel],
                         np.asarray(normal, float)[None], supports=supports, locked=locked,
                         gravity=gravity, loop_closure=loop_closure)


@dataclass(frozen=True)
class ModelPeaks:
    """:func:`peak_forces`: ``peak_force`` [N], ``time_of_peak`` [s], ``duration`` [s]
    (the window where the feature's contact had not ended), ``ended`` (B,)."""

    peak_force: np.ndarray
    time_of_peak: np.ndarray
    duration: np.ndarray
    ended: np.ndarray


def peak_forces(models: ImpactModels, law, ground_law, s=1.0, *, t_max: float = 0.05,
                v_ref: float = 0.1, method: str = "auto") -> ModelPeaks:
    """Peak force of every impact of ``models`` at ``s`` (scalar or (B,)) times the
    reference speed (NaN without a finite model or an approach): ``law`` on the feature,
    ``ground_law`` (``v_i = v_ref``) on the supports, preloaded by their static loads;
    ``t_max`` the window [s]. ``method``:
    ``"auto"`` (the compiled integrators, :mod:`roverimpact._kernels.reduced`, for the laws
    of :func:`~roverimpact.contact.reduced.law_form`) or ``"lsoda"`` (the reference,
    :func:`~roverimpact.contact.reduced.reduced_impact`, one impact at a time)."""
    if method not in ("auto", "lsoda"):
        raise InputError(f"method must be 'auto' or 'lsoda', got {method!r}")
    B = len(models)
    if B == 0:
        return ModelPeaks(*(np.empty(0) for _ in range(3)), np.empty(0, bool))
    s = np.broadcast_to(np.asarray(s, float), (B,))
    ok = models.finite & (models.v_n * s > 0)
    if not ok.all():                       # NaN where there is no model or no approach
        out = ModelPeaks(*(np.full(B, np.nan) for _ in range(3)), np.zeros(B, bool))
        if ok.any():
            sub = peak_forces(models[ok], law, ground_law, s[ok], t_max=t_max, v_ref=v_ref,
                              method=method)
            for f in ("peak_force", "time_of_peak", "duration", "ended"):
                getattr(out, f)[ok] = getattr(sub, f)
        return out
    G = models.G
    b = models.b_g + (s * s)[:, None] * models.b_v
    rate0 = s[:, None] * models.rate0
    m = G.shape[1]
    out = np.empty((B, 4))
    fg = law_form(ground_law, v_ref)
    fo = [law_form(law, v) for v in rate0[:, -1]] if method == "auto" else [None]
    if method == "lsoda" or fg is None or fo[0] is None:
        laws = [ground_law] * (m - 1) + [law]
        for i in range(B):
            r = reduced_impact(G[i], b[i], laws, [v_ref] * (m - 1) + [float(rate0[i, -1])],
                               rate0[i], t_max=t_max, impact=m - 1)
            out[i] = r.peak_force, r.time_of_peak, r.duration, float(r.ended)
        return ModelPeaks(out[:, 0], out[:, 1], out[:, 2], out[:, 3] > 0.5)
    L = np.empty((B, m, 5))
    L[:, :-1] = fg
    L[:, -1] = fo
    r = reduced_impact_batch(G, b, L, rate0, t_max=t_max, impact=m - 1, integrator="auto")
    return ModelPeaks(r.peak_force, r.time_of_peak, r.duration, r.ended)


def model_speed_cap(mbm, t_max: float = 0.05) -> float:
    """The largest speed [m/s] the frozen-pose model covers: half the smallest wheel radius
    travelled in the window ``t_max`` [s] (faster, the pose changes during the contact)."""
    return 0.5 * min(w.radius for w in mbm.wheels) / t_max


def speed_limits(models: ImpactModels, law, ground_law, u_ref: float, F_allow: float, *,
                 s0=None, s_min: float = 1e-2, s_max: float = np.inf, t_max: float = 0.05,
                 v_ref: float = 0.1, rtol: float = 2e-3, max_iter: int = 60,
                 method: str = "auto") -> np.ndarray:
    """The speed [m/s] of every impact at which its model peak force (:func:`peak_forces`)
    reaches ``F_allow`` [N] (module docstring), batched.

    ``s0`` (B,): first guesses of the ratio to ``u_ref`` (the closed-form limits'). 0
    where the feature met at ``s_min u_ref`` already exceeds ``F_allow`` (its weight share
    alone does); inf without an approach (``v_n <= 0``); NaN where the model is not finite
    (:attr:`ImpactModels.finite`); ``s_max u_ref`` where the force
    stays under ``F_allow`` up to that speed (the caller's cap). Otherwise a crossing: from
    ``s0`` up while under ``F_allow`` or down while over it (steps of the closed form's
    slope, at least a factor 1.5) until bracketed, then regula falsi (Illinois) in
    :math:`(\\log s, \\log F)` to ``rtol`` in the force. (The force need not increase
    with the speed everywhere: the weight share does not scale. The crossing found is then
    the one next to ``s0``.)
    """
    if not (F_allow > 0 and np.isfinite(F_allow)):
        raise InputError(f"F_allow must be a force > 0 N, got {F_allow}")
    B = len(models)
    out = np.where(models.finite, np.inf, np.nan)
    live = np.flatnonzero((models.v_n > 0) & models.finite)
    if live.size == 0:
        return out
    n_law = float(getattr(law, "n", 1.0))
    p = 2.0 * n_law / (n_law + 1.0)              # d log F / d log s of the closed form
    target = np.log(F_allow)
    x_min, x_max = np.log(s_min), np.log(s_max)
    s0 = np.ones(B) if s0 is None else np.broadcast_to(np.asarray(s0, float), (B,))
    x = np.where(np.isfinite(s0) & (s0 > 0), np.log(np.where(s0 > 0, s0, 1.0)), 0.0)
    x = np.clip(x, x_min, x_max)

    def logF(idx, xs):
        return np.log(peak_forces(models[idx], law, ground_law, np.exp(xs), t_max=t_max,
                                  v_ref=v_ref, method=method).peak_force) - target

    x_lo = np.full(B, np.nan)
    f_lo = np.full(B, np.nan)
    x_hi = np.full(B, np.nan)
    f_hi = np.full(B, np.nan)
    # walk from the first guess (up while under, down while over) until bracketed
    cur, xc = live, x[live]
    fc = logF(cur, xc)
    for _ in range(max_iter):
        done = np.abs(fc) <= rtol
        out[cur[done]] = u_ref * np.exp(xc[done])
        under = ~done & (fc < 0.0)
        over = ~done & ~under
        x_lo[cur[under]], f_lo[cur[under]] = xc[under], fc[under]
        x_hi[cur[over]], f_hi[cur[over]] = xc[over], fc[over]
        capped = under & (xc >= x_max)
        out[cur[capped]] = u_ref * np.exp(x_max)
        floor = over & (xc <= x_min)
        out[cur[floor]] = 0.0
        walk = ~done & ~capped & ~floor & ~(np.isfinite(x_lo[cur]) & np.isfinite(x_hi[cur]))
        cur, xc, fc = cur[walk], xc[walk], fc[walk]
        if cur.size == 0:
            break
        step = np.maximum(np.abs(fc) / p, np.log(1.5))
        xc = np.clip(np.where(fc < 0.0, xc + step, xc - step), x_min, x_max)
        fc = logF(cur, xc)
    if cur.size:
        raise SolverError(f"the speed limit of {cur.size} impacts was not bracketed between "
                          f"{u_ref * np.exp(x_min):.4g} and {u_ref * np.exp(x_max):.4g} m/s")
    # bracketed: regula falsi (Illinois)
    br = live[np.isinf(out[live]) & np.isfinite(x_lo[live]) & np.isfinite(x_hi[live])]
    side = np.zeros(B, int)
    for _ in range(max_iter):
        if br.size == 0:
            break
        done_hi = f_hi[br] <= rtol
        done_lo = -f_lo[br] <= rtol
        narrow = x_hi[br] - x_lo[br] <= 1e-6
        out[br[done_hi]] = u_ref * np.exp(x_hi[br[done_hi]])
        fin = ~done_hi & (done_lo | narrow)
        out[br[fin]] = u_ref * np.exp(x_lo[br[fin]])
        br = br[~done_hi & ~fin]
        if br.size == 0:
            break
        xl, fl, xh, fh = x_lo[br], f_lo[br], x_hi[br], f_hi[br]
        xn = xl - fl * (xh - xl) / (fh - fl)
        bad = ~((xl < xn) & (xn < xh))
        xn[bad] = 0.5 * (xl[bad] + xh[bad])
        fn = logF(br, xn)
        lo = fn < 0.0
        i_lo, i_hi = br[lo], br[~lo]
        x_lo[i_lo], f_lo[i_lo] = xn[lo], fn[lo]
        f_hi[i_lo] *= np.where(side[i_lo] == -1, 0.5, 1.0)
        side[i_lo] = -1
        x_hi[i_hi], f_hi[i_hi] = xn[~lo], fn[~lo]
        f_lo[i_hi] *= np.where(side[i_hi] == 1, 0.5, 1.0)
        side[i_hi] = 1
    if br.size:
        raise SolverError(f"the speed limit did not converge for {br.size} impacts")
    return out
