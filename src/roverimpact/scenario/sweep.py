"""T_c^- over many impact angles beta, reusing M, v and the other rows of a built setup."""

from __future__ import annotations

import numpy as np

from ..energy import partition, row_masses
from ..exceptions import InputError
from ..models.constraints import RIM_AXIS_TOL
from .build import (
    ImpactEnergy,
    ImpactSetup,
    active_mask,
    friction_of,
    no_approach,
    normal_from_beta,
    pulling_applies,
    warn_if_jammed,
    warn_if_pulling,
)
from .schema import Scenario

__all__ = ["sweep_energy"]


def _energy_sweep(M, A, v, obstacle_row: int, keep) -> ImpactEnergy:
    """:func:`~.build._energy` for a stack of candidate rows ``A`` (k, m, n), one ``M`` and
    ``v``, and the active rows of each item ``keep`` (k, m): one partition and one
    :func:`roverimpact.energy.row_masses` call for all items (``M`` factorised once;
    inactive rows are zero rows, which neither counts)."""
    Ak = A * keep[..., None]  # inactive rows: zero
    p = partition(M, Ak, v, want_velocities=False)
    rows = A[:, obstacle_row, :]
    v_n = 0.0 - (rows @ v)  # +0.0, not -0.0 (build._energy)
    m_eff, m_eff_free = row_masses(M, rows, np.delete(Ak, obstacle_row, axis=1))
    T_c, T_a = no_approach(p.T_c, p.T_a, p.T, v_n)
    return ImpactEnergy(T=p.T, T_c_minus=T_c, T_a=T_a, m_eff=m_eff,
                        m_eff_free=m_eff_free, v_n=v_n, rank=p.rank)


def _obstacle_basis(setup: ImpactSetup):
    from ..models.constraints import point_jacobian

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
    scenario : Scenario, dict, path or ImpactSetup
        The obstacle normal of the scenario is replaced; the configuration is kept.
    beta : (k,) array_like
        Impact angles [rad] in [0, pi/2].

    Returns
    -------
    ImpactEnergy
        Fields are (k,) arrays.
    """
    setup = scenario if isinstance(scenario, ImpactSetup) else ImpactSetup.from_scenario(scenario)
    try:
        beta = np.atleast_1d(np.asarray(beta, dtype=float))
    except (TypeError, ValueError):  # a string, None, a ragged list
        beta = np.array([[np.nan]])
    if beta.ndim != 1 or not np.all(np.isfinite(beta)):
        raise InputError("beta must be a 1-D array of finite angles [rad]")
    if np.any(beta < -1e-12) or np.any(beta > np.pi / 2 + 1e-12):
        raise InputError("beta must be in [0, pi/2] rad (0 to 90 degrees)")
    N = normal_from_beta(beta, setup._heading)  # (k, 3)
    J, wheel, oMf = _obstacle_basis(setup)
    if wheel is None:
        rows = N @ J
    else:
        a = oMf.rotation @ np.asarray(wheel.axis, float)
        d = N - (N @ a)[:, None] * a
        nd = np.linalg.norm(d, axis=1, keepdims=True)
        # a normal along the wheel axis (a face hit): d = n, as the row assembly does
        d = np.where(nd < RIM_AXIS_TOL, N, d / np.maximum(nd, 1e-300))
        r = -wheel.radius * d
        rows = N @ J[:3] + np.cross(r, N) @ J[3:]
    # the active rows may depend on beta ("auto"): decided per beta among all candidates
    A_all = setup._cs.evaluate(setup.q)[1]
    obs = len(setup.candidate_labels) - 1
    A = np.broadcast_to(A_all, (len(beta), *A_all.shape)).copy()
    A[:, obs, :] = rows
    keep = active_mask(setup.constraints, setup.candidate_labels, setup.M, A, setup.v,
                       obstacle_row=obs, **friction_of(setup.contacts))
    en = _energy_sweep(setup.M, A, setup.v, obs, keep)
    if np.any(en.m_eff > 0):
        worst = int(np.argmax(en.m_eff))
        warn_if_jammed(setup.model, en.m_eff,
                     [lb for lb, k in zip(setup.candidate_labels, keep[worst], strict=True) if k],
                     int(np.sum(keep[worst][:obs])))
    if pulling_applies(setup.constraints, setup.contacts):
        warn_if_pulling(setup.M, A, setup.v, setup.candidate_labels, obs, keep, stacklevel=3)
    return en
