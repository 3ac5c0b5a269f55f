"""Small Pinocchio systems for the simulator tests, each with what the tests derive from it.

free_sphere    a free-flying ball (free-flyer, nq = 7): a "wheel" of radius r at its centre.
planar_box     a rigid box moving in the x-z plane (pin.JointModelPlanar turned so that its
               plane is x-z: nq = 4, nv = 3) with a wheel (contact disc) at an offset
               from the centre of mass, so an off-centre hit makes it rotate.
pendulum       a rod on a revolute joint (RY) with a disc at its tip.

     z
     ^   o  ball
     |  [==o==] box (disc at offset)
     +-----> x
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from roverimpact.models.base import MultibodyModel, Wheel

HC = "hunt-crossley"


class HuntCrossleyLocal:
    """f = k delta^n (1 + 3(1 - e)/2 * delta_dot / v_i) (DETC2014-35554 eq. 4), raw value."""

    def __init__(self, k, e=1.0, n=1.5):
        self.k, self.e, self.n = k, e, n

    def force(self, delta, delta_dot, v_i=1.0):
        delta = np.asarray(delta, float)
        return np.where(delta > 0, self.k * np.abs(delta) ** self.n
                        * (1 + 1.5 * (1 - self.e) * np.asarray(delta_dot) / v_i), 0.0)


def _inertia(mass, lx, ly, lz, com=(0.0, 0.0, 0.0)):
    I = np.diag([ly**2 + lz**2, lx**2 + lz**2, lx**2 + ly**2]) * mass / 12.0
    return pin.Inertia(mass, np.array(com, float), I)


def free_sphere(mass=2.0, radius=0.1):
    model = pin.Model()
    model.name = "sphere"
    j = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "root")
    I = 0.4 * mass * radius**2 * np.eye(3)
    model.appendBodyToJoint(j, pin.Inertia(mass, np.zeros(3), I), pin.SE3.Identity())
    model.addFrame(pin.Frame("ball", j, 0, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
    q0 = pin.neutral(model)
    q0[2] = 1.0
    return MultibodyModel(model=model, name="sphere", wheels=[Wheel("ball", "ball", radius)],
                          params={"q_nominal": q0.tolist()})


def planar_box(mass=5.0, lx=0.6, lz=0.2, radius=0.05, offset=(0.3, 0.0, 0.1)):
    """Box in the x-z plane; pin's planar joint (x, y, yaw) rotated by +90 deg about x so
    that its y axis is world z and its rotation axis is world -y."""
    model = pin.Model()
    model.name = "box"
    R = pin.utils.rotate("x", np.pi / 2)
    j = model.addJoint(0, pin.JointModelPlanar(), pin.SE3(R, np.zeros(3)), "root")
    # body inertia in joint axes: joint x = world x, joint y = world z, joint z = world -y
    model.appendBodyToJoint(j, _inertia(mass, lx, lz, 0.3), pin.SE3.Identity())
    off = np.array(offset, float)          # world-axes offset (x, y, z) at q = 0
    p_joint = R.T @ off
    model.addFrame(pin.Frame("disc", j, 0, pin.SE3(np.eye(3), p_joint), pin.FrameType.OP_FRAME))
    return MultibodyModel(model=model, name="box", wheels=[Wheel("disc", "disc", radius)],
                          params={"q_nominal": pin.neutral(model).tolist()})


def pendulum(mass=1.0, length=0.5, radius=0.05):
    model = pin.Model()
    model.name = "pendulum"
    j = model.addJoint(0, pin.JointModelRY(), pin.SE3.Identity(), "hinge")
    model.appendBodyToJoint(j, _inertia(mass, 0.02, 0.02, length, (0, 0, -length / 2)),
                            pin.SE3.Identity())
    model.addFrame(pin.Frame("tip", j, 0, pin.SE3(np.eye(3), np.array([0, 0, -length])),
                             pin.FrameType.OP_FRAME))
    return MultibodyModel(model=model, name="pendulum", wheels=[Wheel("tip", "tip", radius)])
