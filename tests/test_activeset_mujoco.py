"""The automatic active set against MuJoCo (an independent contact solver).

The built-in planar rover (rigid suspension, 0.5 m/s) with both wheels on the ground, its
front wheel against a face of angle beta: the rover exported to MJCF, the wheels' spheres
on a frictionless ground plane and a frictionless obstacle plane, gravity off, a very stiff
critically damped contact (``solref`` time constant 0.2 ms). MuJoCo's soft contact is not
quite plastic: the obstacle rebounds with e ~ 0.12, so MuJoCo loses (1 - e^2) T_c^-.

At 90 deg the front wheel is pressed into the ground: MuJoCo keeps its ground contact
closed and lifts the rear wheel, as the LCP does when the front wheel's ground row is a
candidate (``contacts.ground_wheels = ["rear", "front"]``, docs/active-set.md); at 45 deg
the face lifts the front wheel off the ground. The default candidates (``"others"``: every
wheel but the obstacle's) leave that row out, and T_c^- at 90 deg is the obstacle-only
value, 1.84 J, where MuJoCo's impact takes 2.34 J (= (1 - e^2) 2.38 J, the LCP's T_c^-
with the front wheel's ground row).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import roverimpact as ri

mujoco = pytest.importorskip("mujoco")

from roverimpact.models import rover2d  # noqa: E402
from roverimpact.models.export_mjcf import export_mjcf  # noqa: E402

TC = 2e-4  # MuJoCo contact time constant [s]


def _setup(beta, ground_wheels):
    sc = ri.Scenario.model_validate({
        "model": {"name": "rover2d"}, "velocity": {"u": 0.5},
        "contacts": {"ground_wheels": ground_wheels},
        "obstacle": {"wheel": "front", "beta_deg": beta}})
    return ri.ImpactSetup.from_scenario(sc)


def _mujoco_impact(tmp_path, beta, q, v, names, wheel_centre):
    """(T^- - T^+, normal velocities of front ground, rear ground, obstacle after)."""
    mbm = rover2d()
    path = export_mjcf(mbm, tmp_path / f"rover2d_{beta:g}.xml")
    spec = mujoco.MjSpec.from_file(str(path))
    spec.option.gravity = [0.0, 0.0, 0.0]
    spec.option.timestep = TC / 20
    spec.option.iterations = 200
    spec.option.tolerance = 1e-14
    b = np.radians(beta)
    n = np.array([-np.sin(b), 0.0, np.cos(b)])
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[5, 5, 0.1])
    x = np.cross([0.0, 1.0, 0.0], n)
    R = np.column_stack([x, np.cross(n, x), n])
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, R.flatten())
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[5, 5, 0.1],
                            pos=wheel_centre - 0.15 * n, quat=quat)
    for g in spec.geoms:  # the wheel spheres, the ground and the face
        g.condim = 1
        g.solref = [TC, 1.0]
        g.solimp = [0.9999, 0.9999, 0.001, 0.5, 2]
    m = spec.compile()
    d = mujoco.MjData(m)
    adr = [m.joint(nm).dofadr[0] for nm in names]
    d.qpos[[m.joint(nm).qposadr[0] for nm in names]] = q
    d.qvel[adr] = v
    mujoco.mj_forward(m, d)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    T0 = 0.5 * d.qvel @ M @ d.qvel
    for _ in range(600):  # 30 time constants
        mujoco.mj_step(m, d)
    mujoco.mj_fullM(m, d, M)
    return T0 - 0.5 * d.qvel @ M @ d.qvel, d.qvel[adr].copy()


@pytest.mark.parametrize("beta", [45.0, 90.0])
def test_front_wheel_ground_contact_holds_at_a_wall_as_in_mujoco(tmp_path, beta):
    s = _setup(beta, ["rear", "front"])
    cand = s.candidate_labels
    names = list(s.model.model.names[1:])
    fid = s.model.model.getFrameId(s.model.wheels[0].frame)
    data = s.model.model.createData()
    pin.framesForwardKinematics(s.model.model, data, s.q)
    lost, v_plus = _mujoco_impact(tmp_path, beta, s.q, s.v, names,
                                  data.oMf[fid].translation.copy())
    every = ri.ImpactSetup.from_scenario(ri.Scenario.model_validate({
        "model": {"name": "rover2d"}, "velocity": {"u": 0.5}, "constraints": "all",
        "contacts": {"ground_wheels": ["rear", "front"]},
        "obstacle": {"wheel": "front", "beta_deg": beta}}))
    rows = dict(zip(cand, every.A @ v_plus, strict=True))  # MuJoCo's velocities after
    r = ri.unilateral_impact(every.M, every.v, every.A)
    held = dict(zip(cand, r.active, strict=True))
    # the LCP's held set is MuJoCo's: closed contacts at ~0, released ones lift off
    for lab, h in held.items():
        if lab.startswith("ground"):
            assert (abs(rows[lab]) < 0.01) == bool(h), (lab, rows[lab], h)
    assert held["ground:front:normal"] == (beta == 90.0)
    e = rows["obstacle:front:normal"] / (-(every.A[-1] @ every.v))  # MuJoCo's rebound
    assert 0.05 < e < 0.2
    T_c = float(s.partition().T_c_minus)
    assert lost == pytest.approx((1 - e**2) * T_c, rel=0.005)
    if beta == 90.0:  # the default candidates miss the front wheel's ground row
        T_others = float(_setup(beta, "others").partition().T_c_minus)
        assert T_others < 0.85 * lost  # 1.84 J against 2.34 J
