r"""A planar rigid body hitting an obstacle at a corner: the textbook case with a closed form.

::

              h  G --> u            coordinates (x, z, theta) of the COM G,
                 |\                 M = diag(m, m, I)
                 | \ r = (l, -h)
                 +--C  / obstacle face at angle beta with the ground

The body translates at speed u and its front-bottom corner C (frame ``"contact"``, at
``(lever, 0, -com_height)`` from the centre of mass G) strikes a face whose outward normal
is ``n = (-sin beta, 0, cos beta)``. The contact row is the velocity of C along ``-n``,
so with :math:`d = -n`:

.. math::  \frac{1}{m_{eff}} = \frac1m + \frac{(h \sin\beta - l\cos\beta)^2}{I},
           \qquad T_c^- = \tfrac12 m_{eff} v_n^2, \quad v_n = u \sin\beta .

A scenario names it ``model.name = "rigid_body"`` with ``obstacle.frame = "contact"``;
tests compare the scenario path with this closed form.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import pinocchio as pin

from ..exceptions import ModelError
from ._build import add_body, check_finite, check_positive
from .base import MultibodyModel

__all__ = ["RigidBodyParams", "rigid_body"]


@dataclass(frozen=True)
class RigidBodyParams:
    """Parameters of the planar rigid body (SI units).

    Attributes
    ----------
    mass : float
        Mass m [kg] (default 20).
    inertia : float
        Central moment of inertia I about the y axis [kg m^2] (default 1).
    com_height : float
        Height h of the COM above the contact corner C [m] (default 0.3).
    lever : float
        Horizontal distance l from the COM to C [m] (default 0.4).
    """

    mass: float = 20.0
    inertia: float = 1.0
    com_height: float = 0.3
    lever: float = 0.4

    def __post_init__(self):
        check_positive(self, ("mass", "inertia"))
        check_finite(self, ("com_height", "lever"))


def rigid_body(params: RigidBodyParams | None = None, **overrides) -> MultibodyModel:
    """Build the planar rigid body (joints ``base_x``, ``base_z``, ``base_pitch``).

    Returns
    -------
    MultibodyModel
        No wheels; the frame ``"contact"`` at the corner C; ``params`` with
        ``planar=True`` and ``q_nominal`` (C on the ground, z = ``com_height``).

    Examples
    --------
    >>> from roverimpact.models import rigid_body
    >>> rb = rigid_body(mass=2.0)
    >>> rb.model.nv, rb.model.existFrame("contact")
    (3, True)
    """
    if params is None:
        params = RigidBodyParams()
    if overrides:
        known = set(RigidBodyParams.__dataclass_fields__)
        bad = sorted(set(overrides) - known)
        if bad:
            raise ModelError(f"unknown rigid_body parameter(s) {bad}; known: {sorted(known)}")
        params = RigidBodyParams(**{**asdict(params), **overrides})
    p = params
    model = pin.Model()
    model.name = "rigid_body"
    jx = add_body(model, 0, pin.JointModelPX(), (0, 0, 0), "base_x", "base_x_link", 0.0)
    jz = add_body(model, jx, pin.JointModelPZ(), (0, 0, 0), "base_z", "base_z_link", 0.0)
    I3 = np.diag([p.inertia, p.inertia, p.inertia])
    jb = add_body(model, jz, pin.JointModelRY(), (0, 0, 0), "base_pitch", "body", p.mass,
                  inertia=I3)
    body = model.getFrameId("body")
    model.addFrame(pin.Frame("contact", jb, body,
                             pin.SE3(np.eye(3), np.array([p.lever, 0.0, -p.com_height])),
                             pin.FrameType.OP_FRAME))
    q_nominal = np.array([0.0, p.com_height, 0.0])
    info = asdict(p) | {"planar": True, "total_mass": p.mass, "q_nominal": q_nominal.tolist(),
                        "builder": "rigid_body"}
    return MultibodyModel(model=model, name="rigid_body", params=info)
