"""The weight model of a traverse impact (roverimpact.traverse.refine) against independent
references: its rows against the traverse's T_c^- pipeline and Pinocchio's constrained
dynamics, its compiled integrators against scipy's LSODA, its speed limits against the
power law of the closed form (no weight) and against its own peak force.

The model against the compliant multibody simulation (what it is for) is in
tests/test_traverse_physics.py.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from roverimpact.contact import get_law
from roverimpact.contact.reduced import reduced_impact
from roverimpact.energy import effective_mass
from roverimpact.models import rocker_bogie
from roverimpact.models.terrain_synth import synthetic_mars
from roverimpact.scenario.schema import ContactLawSpec
from roverimpact.traverse.compute import evaluate_stations, rover_states
from roverimpact.traverse.limits import peak_force, speed_limit_force
from roverimpact.traverse.refine import (
    ImpactModels,
    impact_models,
    model_speed_cap,
    peak_forces,
    speed_limits,
)

HC = get_law("hunt-crossley", k=1e7, e=0.5)
GROUND = get_law("hunt-crossley", k=1e7, e=0.2)


@pytest.fixture(scope="module")
def traverse():
    """Impacts of the rocker-bogie on 3 m of rough seeded terrain, their weight models."""
    terrain = synthetic_mars((8.0, 4.0), 0.05, seed=3, rock_abundance=0.2, origin=(-1, -2))
    rb = rocker_bogie()
    x = np.arange(0.5, 3.5, 0.05)
    r = evaluate_stations(rb, terrain, x, 0.1 * np.sin(x), 0.1 * np.cos(x), u=0.1,
                          max_travel=0.1)
    items = np.argwhere(r.impact.T_c_minus > 0)
    k, w = items[:, 0], items[:, 1]
    st = rover_states(rb, r.pose.q[k])
    models = impact_models(rb, st, r.v[k], r.pose.normal[k], np.arange(k.size), w,
                           r.hit["normal"][k, w], supports=np.ones(6, bool))
    return rb, r, k, w, st, models


def test_rows_are_the_traverse_rows_and_pinocchio_dynamics(traverse):
    """Against the T_c^- pipeline and Pinocchio: 1/G_oo is the effective mass of the
    feature row with the differential held (energy.effective_mass on the pipeline's own
    obstacle row); the support rows' G is A M^-1 A^T projected by the differential (a KKT
    solve); b_g is minus the gap accelerations of the rover released at rest under gravity
    with the differential enforced (Pinocchio's RNEA for gravity, a KKT solve); the
    penetration rates are those of the driving velocity (supports at rest, v_n last)."""
    rb, r, k, w, st, M = traverse
    assert len(M) > 30
    for i in range(0, len(M), 7):
        q, Mi, L = st.q[i], st.M[i], st.loop_J[i]
        # the pipeline's obstacle row: lever from the centre to the contact point found
        lev = r.hit["point"][k[i], w[i]] - r.hit["centre"][k[i], w[i]]
        n = r.hit["normal"][k[i], w[i]]
        J = st.J[i, w[i]]
        a = n @ J[:3] + np.cross(lev, n) @ J[3:]
        assert 1.0 / M.G[i, -1, -1] == pytest.approx(
            float(effective_mass(Mi, a, held=L, single_row=True)), rel=1e-7)
        assert M.rate0[i, -1] == pytest.approx(r.impact.v_n[k[i], w[i]], rel=1e-7)
        assert np.abs(M.rate0[i, :-1]).max() < 1e-7   # the pose solved to 1e-9
        # KKT: [M L^T; L 0] [acc; lam] = [-g; 0]
        g = pin.rnea(rb.model, rb.model.createData(), q, np.zeros(rb.model.nv),
                     np.zeros(rb.model.nv))
        nv, nl = Mi.shape[0], L.shape[0]
        K = np.block([[Mi, L.T], [L, np.zeros((nl, nl))]])
        acc = np.linalg.solve(K, np.concatenate([-g, np.zeros(nl)]))[:nv]
        # the rows: supports at the pose's support points (rim points facing the normals)
        sup = r.pose.point[k[i]] - st.centre[i]
        rows = [r.pose.normal[k[i], j] @ st.J[i, j, :3]
                + np.cross(sup[j], r.pose.normal[k[i], j]) @ st.J[i, j, 3:] for j in range(6)]
        A = np.array([*rows, a])
        assert M.b_g[i] == pytest.approx(A @ acc, rel=1e-6, abs=1e-9)
        Kinv = np.linalg.inv(K)[:nv, :nv]
        assert M.G[i] == pytest.approx(A @ Kinv @ A.T, rel=1e-6, abs=1e-12)


def test_velocity_terms_scale_with_the_square_of_the_speed(traverse):
    rb, r, k, w, st, _ = traverse
    a = impact_models(rb, st, r.v[k], r.pose.normal[k], np.arange(k.size), w,
                      r.hit["normal"][k, w], supports=np.ones(6, bool))
    b = impact_models(rb, st, 2.0 * r.v[k], r.pose.normal[k], np.arange(k.size), w,
                      r.hit["normal"][k, w], supports=np.ones(6, bool))
    assert b.b_v == pytest.approx(4.0 * a.b_v, rel=1e-9, abs=1e-15)
    assert b.b_g == pytest.approx(a.b_g) and b.rate0 == pytest.approx(2.0 * a.rate0)
    none = impact_models(rb, st, r.v[k], r.pose.normal[k], np.arange(k.size), w,
                         r.hit["normal"][k, w], supports=np.ones(6, bool), gravity=[0, 0, 0])
    assert np.abs(none.b_g).max() == 0.0


@pytest.mark.parametrize("s", [1.0, 0.3, 0.02])
def test_compiled_integrators_match_lsoda(traverse, s):
    """Every impact at 1, 0.3 and 0.02 times the reference speed (the last makes the
    Hunt-Crossley damping stiff for the explicit step: the Rosenbrock pair takes those):
    the compiled peak forces equal LSODA's (rtol 1e-8) to 1e-4 of the force, or 1e-4 N."""
    import roverimpact.contact.reduced as red

    *_, M = traverse
    pick = np.arange(0, len(M), max(1, len(M) // 25))
    fast = peak_forces(M[pick], HC, GROUND, s)
    ref = peak_forces(M[pick], HC, GROUND, s, method="lsoda")
    assert fast.peak_force == pytest.approx(ref.peak_force, rel=1e-4, abs=1e-4)
    assert np.array_equal(fast.ended, ref.ended)
    if s == 0.02:   # some of these went the stiff way
        G, b = M.G[pick], M.b_g[pick] + s * s * M.b_v[pick]
        rate = s * M.rate0[pick]
        m = G.shape[1]
        k = np.full((len(pick), m), 1e7)
        n = np.full((len(pick), m), 1.5)
        a = np.column_stack([np.full((len(pick), m - 1), GROUND.z / 0.1),
                             HC.z / rate[:, -1]])
        loads = np.zeros((len(pick), m))
        loads[:, :-1] = red.static_loads_batch(G[:, :-1, :-1], b[:, :-1])
        L = np.stack([k, n, a, np.zeros_like(k), np.zeros_like(k)], axis=-1)
        _, _, stiff, _ = red._steps(G, b, L, loads, rate[:, -1], m - 1, 0.05)
        assert stiff.any()


def test_rigid_supports_without_weight_give_the_closed_form_limit(traverse):
    """Without gravity: the feature's row alone gives the closed form's limit of
    (m = 1/G_oo, v_n) (traverse.limits: the power law); with supports 1000 times stiffer
    than the feature, unloaded, the closed form's of the pipeline's m_eff (the supports
    that hold through the impact, the automatic active set, held rigid)."""
    _, r, k, w, _, M = traverse
    flat = ImpactModels(M.G, np.zeros_like(M.b_g), np.zeros_like(M.b_v), M.rate0)
    one = ImpactModels(M.G[:, -1:, -1:], np.zeros((len(M), 1)), np.zeros((len(M), 1)),
                       M.rate0[:, -1:])
    spec = ContactLawSpec(name="hunt-crossley", k=1e7, e=0.5)
    m, vn = 1.0 / M.G[:, -1, -1], M.v_n
    F0 = peak_force(spec, m, vn)
    F_allow = float(np.median(F0))
    closed = speed_limit_force(spec, m, vn, 0.1, F_allow)
    lim_one = speed_limits(one, HC, GROUND, 0.1, F_allow, s0=1.0, s_max=1e3)
    assert lim_one == pytest.approx(closed, rel=2e-3)
    stiff = get_law("hunt-crossley", k=1e10, e=0.2)
    held = speed_limit_force(spec, r.impact.m_eff[k, w], vn, 0.1, F_allow)
    lim = speed_limits(flat, HC, stiff, 0.1, F_allow, s0=held / 0.1, s_max=1e3)
    assert np.median(np.abs(lim / held - 1)) < 0.02


def test_speed_limits_reach_the_allowable_force(traverse):
    """With the weight: at each finite positive limit the model's peak force is F_allow
    (to the 2e-3 of the search); a limit of 0 means over F_allow at s_min; the cap means
    under it there."""
    *_, M = traverse
    u, F_allow, cap = 0.1, 45.0, 1.0
    lim = speed_limits(M, HC, GROUND, u, F_allow, s0=np.ones(len(M)), s_max=cap / u)
    inner = (lim > 0) & (lim < cap * (1 - 1e-9))
    assert inner.sum() > 5 and (lim == 0).sum() > 0
    F = peak_forces(M[inner], HC, GROUND, lim[inner] / u).peak_force
    assert F == pytest.approx(F_allow, rel=2.5e-3)
    zero = np.flatnonzero(lim == 0)
    assert (peak_forces(M[zero], HC, GROUND, 0.01).peak_force >= F_allow).all()
    top = np.flatnonzero(lim >= cap * (1 - 1e-9))
    if top.size:
        assert (peak_forces(M[top], HC, GROUND, cap / u).peak_force <= F_allow).all()


def test_model_speed_cap_and_no_approach(traverse):
    rb, *_, M = traverse
    assert model_speed_cap(rb, 0.05) == pytest.approx(0.5 * 0.1 / 0.05)
    back = ImpactModels(M.G[:2], M.b_g[:2], M.b_v[:2], -M.rate0[:2])
    assert np.isinf(speed_limits(back, HC, GROUND, 0.1, 40.0)).all()


def test_one_impact_lsoda_agrees_with_reduced_impact(traverse):
    """peak_forces(method="lsoda") is reduced_impact with the supports' and the feature's
    laws and v_i (the feature's its approach speed)."""
    *_, M = traverse
    G, b, rate = M.G[0], M.b_g[0] + M.b_v[0], M.rate0[0]
    m = G.shape[0]
    r = reduced_impact(G, b, [GROUND] * (m - 1) + [HC], [0.1] * (m - 1) + [rate[-1]], rate,
                       t_max=0.05, impact=m - 1)
    assert peak_forces(M[0], HC, GROUND, method="lsoda").peak_force[0] == r.peak_force


def test_degenerate_and_receding_items_are_nan_not_errors(traverse):
    """A feature normal along the wheel axis (no rim point faces it) and a receding
    feature: NaN peak forces and limits (inf for the receding one), the others computed."""
    rb, r, k, w, st, M = traverse
    nrm = r.hit["normal"][k[:3], w[:3]].copy()
    a = st.axis[1, w[1]]
    nrm[1] = a
    # and along the axis to rounding: a residual of 1e-13 across it (which rounding alone
    # left, or not, by numpy version) once gave an arbitrary rim point and a finite model
    tilted = a + 1e-13 * np.cross(a, [0.0, 0.0, 1.0])
    bad = impact_models(rb, st, r.v[k], r.pose.normal[k], np.arange(3), w[:3], nrm,
                        supports=np.ones(6, bool))
    assert list(bad.finite) == [True, False, True]
    nrm[1] = tilted
    assert list(impact_models(rb, st, r.v[k], r.pose.normal[k], np.arange(3), w[:3], nrm,
                              supports=np.ones(6, bool)).finite) == [True, False, True]
    F = peak_forces(bad, HC, GROUND).peak_force
    assert np.isnan(F[1]) and np.isfinite(F[[0, 2]]).all()
    lim = speed_limits(bad, HC, GROUND, 0.1, 40.0)
    assert np.isnan(lim[1]) and not np.isnan(lim[[0, 2]]).any()
    back = ImpactModels(M.G[:2], M.b_g[:2], M.b_v[:2], M.rate0[:2] * [[1.0], [-1.0]])
    F = peak_forces(back, HC, GROUND).peak_force
    assert np.isfinite(F[0]) and np.isnan(F[1])


def test_weight_share_grows_with_gravity(traverse):
    """The same impacts without gravity, on Mars and on Earth: the model's peak forces
    grow with g (the weight share)."""
    rb, r, k, w, st, _ = traverse
    F = {}
    for name, g in (("none", 0.0), ("mars", 3.721), ("earth", 9.81)):
        M = impact_models(rb, st, r.v[k], r.pose.normal[k], np.arange(k.size), w,
                          r.hit["normal"][k, w], supports=np.ones(6, bool),
                          gravity=[0.0, 0.0, -g])
        F[name] = peak_forces(M, HC, GROUND).peak_force
    assert np.median(F["none"]) < np.median(F["mars"]) < np.median(F["earth"])
    assert (F["earth"] >= F["none"] * (1 - 1e-6)).mean() > 0.9
