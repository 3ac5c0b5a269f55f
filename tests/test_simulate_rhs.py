"""The simulator's right-hand side on a file model, against a slow evaluation written here.

The tutorial's Sawppy-like URDF rover (examples/sawppy_like_beta.toml: floating base, six
wheels, two turnbuckle point loops, four locked steering joints), obstacle face in contact
with its left front wheel, friction on. The reference takes nothing from the simulator
but the plane data: per wheel/plane pair the sphere's contact point ``c - r n``, its
Jacobian from ``pin.getFrameJacobian`` and the law's force, summed in a Python loop;
``M`` by ``pin.crba`` and ``h`` by ``pin.nonLinearEffects``; the constrained acceleration
from the KKT system ``[M J^T; J 0] [a; -lam] = [tau - h; gamma]`` with ``gamma`` the
Baumgarte right-hand side and ``J_dot v`` by central differences of the loop's ``J``
(``pin.integrate``). The simulator's lean path (:meth:`ContactSystem.applied_force`,
used by the integrator) must also give the same bits as the full
:meth:`ContactSystem.contacts` path, so a run does not depend on which one it takes.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from roverimpact.scenario import load_scenario
from roverimpact.scenario.build import configuration, scenario_model
from roverimpact.simulate import SimulationConfig, build_system, initial_state

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


@pytest.fixture(scope="module")
def sawppy():
    sc = load_scenario(EXAMPLES / "sawppy_like_beta.toml")
    mbm = scenario_model(sc)
    cfg = SimulationConfig.from_scenario(sc).model_copy(update={"mu": 0.4})
    q, v = initial_state(mbm, cfg, q0=configuration(mbm, sc.configuration))
    sys_ = build_system(mbm, cfg, q_ref=q)
    # the obstacle face 2 mm into the left front wheel; a disturbed velocity
    w = [x.name for x in mbm.wheels].index("left_front")
    ob = sys_.planes[-1]
    ob.p0 = sys_.wheel_centres(q)[w] - (sys_.radii[w] - 2e-3) * ob.n
    ob.v_i = 0.3
    sys_._set_planes()
    v = v + 0.05 * np.random.default_rng(1).standard_normal(v.size)
    return mbm, cfg, sys_, q, v


def reference_rhs(mbm, cfg, sys_, q, v):
    """(tau (nv,), f_n (planes, wheels), a (nv,)) evaluated the slow way."""
    model = sys_.model
    data = model.createData()
    nv = model.nv
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    tau = np.zeros(nv)
    f_n = np.zeros((len(sys_.planes), len(mbm.wheels)))
    for k, plane in enumerate(sys_.planes):
        n = np.asarray(plane.n, float)
        for w, wheel in enumerate(mbm.wheels):
            fid = model.getFrameId(wheel.frame)
            c = data.oMf[fid].translation
            if plane.wheels is not None and not plane.wheels[w]:
                continue
            p = c - wheel.radius * n
            if p[2] > plane.z_max:
                continue
            gap = float(n @ (c - plane.p0)) - wheel.radius
            if gap >= 0.0:
                continue
            J = pin.getFrameJacobian(model, data, fid, LWA)
            r = p - c
            Jp = J[:3] - np.cross(r[:, None], J[3:], axis=0)   # v_p = v_c + w x r
            vp = Jp @ v
            vn = float(n @ vp)
            fn = max(float(plane.law.force(np.array([-gap]), np.array([-vn]), plane.v_i)[0]),
                     0.0)
            vt = vp - vn * n
            s = float(np.linalg.norm(vt))
            F = fn * n - cfg.mu * fn * np.tanh(s / cfg.v_slip) * vt / max(s, 1e-300)
            tau += Jp.T @ F
            f_n[k, w] = fn
    for iv, value, k_s, c_s, q0 in sys_.springs:
        tau[iv] -= k_s * (value(q) - q0) + c_s * v[iv]
    M = pin.crba(model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    h = pin.nonLinearEffects(model, data, q, v)
    phi, Jl = sys_.loop_closure(q)
    eps = 1e-6 / max(1.0, float(np.max(np.abs(v))))
    Jdv = (sys_.loop_closure(pin.integrate(model, q, eps * v))[1]
           - sys_.loop_closure(pin.integrate(model, q, -eps * v))[1]) @ v / (2 * eps)
    alpha = sys_.baumgarte
    gamma = -Jdv - 2 * alpha * (Jl @ v) - alpha ** 2 * phi
    m = Jl.shape[0]
    K = np.block([[M, Jl.T], [Jl, np.zeros((m, m))]])
    sol = np.linalg.lstsq(K, np.concatenate([tau - h, gamma]), rcond=None)[0]
    return tau, f_n, sol[:nv]


def test_the_right_hand_side_is_the_slow_evaluation(sawppy):
    mbm, cfg, sys_, q, v = sawppy
    tau_ref, fn_ref, a_ref = reference_rhs(mbm, cfg, sys_, q, v)
    cf = sys_.applied_force(q, v)
    assert (fn_ref[-1] > 0).sum() == 1 and (fn_ref[0] > 0).sum() == 6  # obstacle + ground
    np.testing.assert_allclose(cf.f_n, fn_ref, rtol=1e-12, atol=0.0)
    scale = np.max(np.abs(tau_ref))
    np.testing.assert_allclose(cf.tau, tau_ref, rtol=0.0, atol=1e-12 * scale)
    a = sys_.acceleration(q, v, cf.tau)
    np.testing.assert_allclose(a, a_ref, rtol=0.0, atol=1e-8 * np.max(np.abs(a_ref)))


def test_the_lean_path_gives_the_bits_of_the_full_one(sawppy):
    _, _, sys_, q, v = sawppy
    cs = sys_.contacts(q, v)
    cf = sys_.applied_force(q, v)
    assert np.array_equal(cf.tau, cs.tau + sys_.spring_torque(q, v))
    assert np.array_equal(cf.f_n, cs.f_n) and np.array_equal(cf.f_t, cs.f_t)
    assert np.array_equal(cf.delta, cs.delta) and np.array_equal(cf.gap, cs.gap)


def test_the_loop_bias_term_is_the_central_difference_of_the_whole_closure(sawppy):
    """The closure's own ``jdot_v`` (frame rows by differences, locked rows 0) gives the
    central difference of all rows the simulator took before, to rounding: the frame rows'
    product with v is a matrix-vector product of another shape, whose summation order
    BLAS may choose by shape and alignment (bits differed with numpy 2.4.6's OpenBLAS)."""
    from roverimpact.models.constraints import loop_jdot_v

    _, _, sys_, q, v = sawppy
    lc = sys_.loop_closure
    eps = 1e-6 / max(1.0, float(np.max(np.abs(v))))
    whole = (lc(pin.integrate(sys_.model, q, eps * v))[1]
             - lc(pin.integrate(sys_.model, q, -eps * v))[1]) @ v / (2 * eps)
    got = loop_jdot_v(lc, sys_.model, q, v)
    np.testing.assert_allclose(got, whole, rtol=0.0, atol=1e-12 * np.abs(whole).max())
    assert np.abs(whole[:6]).max() > 0.0 and not whole[6:].any()   # loops, then locks


def test_planes_sharing_a_law_give_the_bits_of_one_call_per_plane():
    """Consecutive planes with one law object (a support per wheel, as the traverse check
    builds them) are evaluated in one call of the law: the bits of one call per plane."""
    from roverimpact.contact import HuntCrossley
    from roverimpact.models import rocker_bogie
    from roverimpact.simulate import ContactSystem, Plane

    mbm = rocker_bogie()
    q = np.asarray(mbm.params["q_nominal"])
    v = 0.1 * np.random.default_rng(2).standard_normal(mbm.model.nv)
    ground = HuntCrossley(k=1e6, e=0.7)
    nw = len(mbm.wheels)
    planes = [Plane(f"support_{w}", np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, 1e-3 * w]),
                    ground, 0.1, wheels=np.arange(nw) == w) for w in range(nw)]
    planes.append(Plane("face", np.array([-1.0, 0.0, 0.0]), np.zeros(3),
                        HuntCrossley(k=1e7, e=0.5), 0.3))
    sys_ = ContactSystem(model=mbm.model, wheel_frames=[w.frame for w in mbm.wheels],
                         radii=[w.radius for w in mbm.wheels], planes=planes,
                         gravity=np.array([0.0, 0.0, -9.81]), mu=0.3)
    c = sys_.wheel_centres(q)
    planes[-1].p0 = c[0] + np.array([0.9 * mbm.wheels[0].radius, 0.0, 0.0])
    sys_._set_planes()
    assert sys_._law_runs == [(0, nw), (nw, nw + 1)]
    cs, cf = sys_.contacts(q, v), sys_.applied_force(q, v)
    assert (cf.f_n[:nw] > 0).sum() >= 4 and cf.f_n[-1, 0] > 0
    assert np.array_equal(cf.f_n, cs.f_n) and np.array_equal(cf.f_t, cs.f_t)
    assert np.array_equal(cf.tau, cs.tau)


def _rocker_bogie_on_planes(laws, v_i, mu=0.3):
    """The rocker-bogie on the ground (``laws[0]``) pressed by faces (``laws[1:]``) into the
    front wheel, with a disturbed velocity: pairs on every plane."""
    from roverimpact.models import rocker_bogie
    from roverimpact.simulate import ContactSystem, Plane

    mbm = rocker_bogie()
    q = np.asarray(mbm.params["q_nominal"])
    v = 0.1 * np.random.default_rng(3).standard_normal(mbm.model.nv)
    normals = [np.array([0.0, 0.0, 1.0]), np.array([-1.0, 0.0, 0.0]),
               np.array([-0.6, 0.0, 0.8])]
    planes = [Plane(f"p{k}", normals[k], np.zeros(3), law, v_i[k])
              for k, law in enumerate(laws)]
    sys_ = ContactSystem(model=mbm.model, wheel_frames=[w.frame for w in mbm.wheels],
                         radii=[w.radius for w in mbm.wheels], planes=planes,
                         gravity=np.array([0.0, 0.0, -9.81]), mu=mu)
    c, r = sys_.wheel_centres(q), sys_.radii
    for k, p in enumerate(planes):   # each plane 1 to 2 mm into the wheel(s) it faces most
        p.p0 = ((c @ p.n - r).min() + 1e-3 * (1 + k / 2)) * p.n
    sys_._set_planes()
    return sys_, q, v


def _per_pair(sys_, q, v, v_i):
    """f_n (planes, wheels) by one call of its plane's law per pair, from the indentation and
    its rate of :meth:`ContactSystem.contacts` (the simulator's own kinematics)."""
    cs = sys_.contacts(q, v, v_i)
    f = np.zeros_like(cs.f_n)
    for k, w in zip(*np.nonzero(cs.delta > 0), strict=True):
        f[k, w] = max(float(sys_.planes[k].law.force(cs.delta[k, w:w + 1],
                                                      cs.delta_dot[k, w:w + 1], v_i[k])[0]), 0.0)
    return f


def test_pairs_on_planes_of_hunt_crossley_laws_are_one_evaluation_with_the_bits_per_pair(
        monkeypatch):
    """Three planes, three Hunt–Crossley family laws (two classes), three v_i: the pairs of all
    planes are evaluated in one call of ``family_force`` with the parameters per pair, with
    the bits of one call of the plane's law per pair; a v_i changed in place (the list the
    integrator passes) is taken."""
    from roverimpact.contact import HuntCrossley, LankaraniNikravesh
    from roverimpact.contact.hunt_crossley import family_force
    from roverimpact.simulate import system

    laws = [HuntCrossley(k=1e6, e=0.7), LankaraniNikravesh(k=3e6, e=0.4),
            HuntCrossley(k=1e7, e=0.5)]
    v_i = [0.1, 0.25, 0.3]
    sys_, q, v = _rocker_bogie_on_planes(laws, v_i)
    calls = []
    monkeypatch.setattr(system, "family_force",
                        lambda *a: calls.append(a) or family_force(*a))
    for vi in (v_i, np.array([0.2, 0.05, 0.4])):
        v_i[:] = vi                                  # in place, as simulate_impact does
        calls.clear()
        cf = sys_.applied_force(q, v, v_i)
        assert len(calls) == 1 and ((cf.f_n > 0).sum(axis=1) > 0).all()
        assert np.array_equal(cf.f_n, _per_pair(sys_, q, v, v_i))
        cs = sys_.contacts(q, v, v_i)
        assert np.array_equal(cf.f_n, cs.f_n) and np.array_equal(cf.tau, cs.tau)


def test_other_laws_and_overridden_forces_are_called_per_plane():
    """Laws outside the family (Hertz, Kelvin–Voigt) and a family law whose ``force`` is its
    own are called per plane, or once for consecutive planes of one law object and one
    v_i: the bits of one call per pair."""
    from roverimpact.contact import Hertz, HuntCrossley, KelvinVoigt

    class Stiffer(HuntCrossley):
        def force(self, delta, delta_dot, v_i=1.0):
            return 2.0 * super().force(delta, delta_dot, v_i)

    shared = Stiffer(k=2e6, e=0.6)
    for laws, v_i in (
            ([Hertz(k=1e6), HuntCrossley(k=3e6, e=0.4), KelvinVoigt(k=1e7, c=2e3)],
             [0.1, 0.25, 0.3]),
            ([HuntCrossley(k=1e6, e=0.7), Stiffer(k=3e6, e=0.4), HuntCrossley(k=1e7, e=0.5)],
             [0.1, 0.25, 0.3]),
            ([shared, shared, HuntCrossley(k=1e7, e=0.5)], [0.1, 0.25, 0.3]),
            ([shared, shared, HuntCrossley(k=1e7, e=0.5)], [0.2, 0.2, 0.3])):
        sys_, q, v = _rocker_bogie_on_planes(laws, v_i)
        cf = sys_.applied_force(q, v, v_i)
        assert ((cf.f_n > 0).sum(axis=1) > 0).all()
        assert np.array_equal(cf.f_n, _per_pair(sys_, q, v, v_i))
        assert np.array_equal(cf.tau, sys_.contacts(q, v, v_i).tau)


def test_a_copied_or_pickled_system_reads_the_wheel_centres_of_its_own_data():
    """The wheel centres come from views of ``data.oMf`` kept between calls: a deep copy and
    a pickle of the system (their own ``Data``) read theirs, not the original's, nor a
    frozen copy of the views."""
    import copy
    import pickle

    from roverimpact.models import rocker_bogie

    mbm = rocker_bogie()
    sys_ = build_system(mbm, SimulationConfig())
    q = np.asarray(mbm.params["q_nominal"])
    q2 = q.copy()
    q2[:3] += [0.5, -0.2, 0.1]

    def centres(qq):               # independent: a fresh Data, one frame at a time
        data = sys_.model.createData()
        pin.framesForwardKinematics(sys_.model, data, qq)
        return np.array([data.oMf[f].translation for f in sys_.fids])

    assert np.array_equal(sys_.wheel_centres(q), centres(q))       # views bound
    for other in (copy.deepcopy(sys_), pickle.loads(pickle.dumps(sys_))):
        assert np.array_equal(other.wheel_centres(q2), centres(q2))
        assert np.array_equal(other.applied_force(q, np.zeros(sys_.nv)).gap,
                              sys_.gaps_of_centres(centres(q)))
        assert np.array_equal(sys_.wheel_centres(q), centres(q))


def _kkt_acceleration(sys_, q, v, tau):
    """The constrained acceleration from the KKT system, written here (``J`` of the
    closure, which the cases below have constant: no bias term)."""
    model = sys_.model
    data = model.createData()
    M = pin.crba(model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    h = pin.nonLinearEffects(model, data, q, v)
    phi, Jl = sys_.loop_closure(q)
    phi, Jl = np.atleast_1d(phi), np.atleast_2d(Jl)
    alpha = sys_.baumgarte
    gamma = -2 * alpha * (Jl @ v) - alpha ** 2 * phi
    m = Jl.shape[0]
    K = np.block([[M, Jl.T], [Jl, np.zeros((m, m))]])
    return np.linalg.lstsq(K, np.concatenate([tau - h, gamma]), rcond=None)[0][:model.nv]


@pytest.mark.parametrize("case", ["differential", "differential + both rockers locked",
                                  "2-D rocker locked"])
def test_constant_loop_rows_give_the_kkt_acceleration(case):
    """A loop closure whose Jacobian is constant (the rocker-bogie's differential, joints
    held by contacts.locked) is solved on its independent rows, found once: the
    acceleration equals the KKT system's, with the rows as they are (locking both rockers
    as well makes the three rows dependent: rank 2), at configurations and velocities off
    the constraint (phi != 0, J v != 0: the Baumgarte terms count)."""
    from roverimpact.models import rocker_bogie, rover2d

    rng = np.random.default_rng(3)
    if case.startswith("2-D"):
        mbm = rover2d(suspension="rocker")
        locked = ["rocker"]
    else:
        mbm = rocker_bogie()
        locked = ["rocker_left", "rocker_right"] if "locked" in case else []
    cfg = SimulationConfig(contacts={"locked": locked})
    q0, _ = initial_state(mbm, cfg)
    sys_ = build_system(mbm, cfg, q_ref=q0)
    assert getattr(sys_.loop_closure, "constant_jacobian", False)
    k = np.atleast_2d(sys_.loop_closure(q0)[1]).shape[0]
    for _ in range(4):
        q = pin.integrate(sys_.model, q0, 0.05 * rng.standard_normal(sys_.nv))
        v = rng.standard_normal(sys_.nv)
        tau = 10.0 * rng.standard_normal(sys_.nv)
        a = sys_.acceleration(q, v, tau)
        ref = _kkt_acceleration(sys_, q, v, tau)
        np.testing.assert_allclose(a, ref, rtol=0.0, atol=1e-9 * np.max(np.abs(ref)))
    _, B, Jr = sys_._rows  # r independent rows: orthonormal combinations of the k rows
    assert Jr.shape[0] == {"differential": 1, "2-D rocker locked": 1}.get(case, 2) <= k
    np.testing.assert_allclose(B @ B.T, np.eye(len(B)), atol=1e-12)
    if case == "differential":  # a closure put in its place: solved with its own rows
        locked = SimulationConfig(contacts={"locked": ["rocker_left"]})
        sys_.loop_closure = build_system(mbm, locked, q_ref=q0).loop_closure
        np.testing.assert_allclose(sys_.acceleration(q, v, tau),
                                   _kkt_acceleration(sys_, q, v, tau), rtol=0.0,
                                   atol=1e-9 * np.max(np.abs(ref)))
        assert sys_._rows[2].shape[0] == 2
