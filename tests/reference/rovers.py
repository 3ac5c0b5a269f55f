"""Independent references for the model tests (no CRBA, no roverimpact code).

``kinetic_energy_bodies`` sums, over the bodies, 1/2 m |v_G|^2 + 1/2 w^T I_G w from the body
spatial velocities of Pinocchio's forward kinematics (first-order recursion, not the
CRBA), with the centre of mass velocity v_G = v_O + w x c in the body frame.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin


def kinetic_energy_bodies(model, q, v) -> float:
    data = model.createData()
    pin.forwardKinematics(model, data, q, v)
    T = 0.0
    for j in range(1, model.njoints):
        I = model.inertias[j]
        w = data.v[j].angular
        vG = data.v[j].linear + np.cross(w, I.lever)
        T += 0.5 * I.mass * vG @ vG + 0.5 * w @ I.inertia @ w
    return float(T)


def random_state(model, rng):
    """Random configuration (within ±1 on 1-DoF joints, normalized quaternions) and velocity."""
    q = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
    v = rng.normal(size=model.nv)
    return q, v


#: An arm of one hinge on a base pitched 20 degrees, free in the file (<freejoint
#: name='fly'>): the tests of a fixed base on a file with a free root
FREE_ROOT_ARM_MJCF = ("<mujoco><worldbody><body name='base' pos='0.3 0 1' euler='0 20 0'>"
                      "<freejoint name='fly'/><geom type='box' size='.2 .1 .1'/>"
                      "<body name='arm' pos='0.2 0 0'><joint name='j' axis='0 1 0'/>"
                      "<geom type='capsule' fromto='0 0 0 0.4 0 0' size='0.05'/></body>"
                      "</body></worldbody></mujoco>")
