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

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from types import SimpleNamespace

import numpy as np
import pinocchio as pin

from ..exceptions import ModelError
from ._build import (
    Body,
    FamilyNumbers,
    add_bodies,
    check_finite,
    check_positive,
    family_columns,
    numbers_ok,
)
from .base import MultibodyModel

__all__ = ["RigidBodyParams", "rigid_body", "rigid_body_numbers"]

_POSITIVE = ("mass", "inertia")
_FINITE = ("com_height", "lever")


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
        check_positive(self, _POSITIVE)
        check_finite(self, _FINITE)


def _params(params: RigidBodyParams, overrides: Mapping) -> RigidBodyParams:
    """``params`` with ``overrides``, checked."""
    if not overrides:
        return params
    known = set(RigidBodyParams.__dataclass_fields__)
    bad = sorted(set(overrides) - known)
    if bad:
        raise ModelError(f"unknown rigid_body parameter(s) {bad}; known: {sorted(known)}")
    return RigidBodyParams(**{**asdict(params), **overrides})


def _layout(p) -> list[Body]:
    """The bodies of the rigid body of parameters ``p`` (numbers or (k,) arrays): two
    massless sliders and the body on a pitch joint."""
    inertia = np.multiply.outer(np.asarray(p.inertia, dtype=float), np.eye(3))
    return [
        Body(-1, "PX", (0, 0, 0), "base_x", "base_x_link", 0.0),
        Body(0, "PZ", (0, 0, 0), "base_z", "base_z_link", 0.0),
        Body(1, "RY", (0, 0, 0), "base_pitch", "body", p.mass, inertia=inertia),
    ]


def _corner(p) -> tuple:
    """The contact corner C in the body's joint frame."""
    return (p.lever, 0.0, -p.com_height)


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
    p = _params(RigidBodyParams() if params is None else params, overrides)
    model = pin.Model()
    model.name = "rigid_body"
    jb = add_bodies(model, _layout(p))[-1]
    body = model.getFrameId("body")
    model.addFrame(pin.Frame("contact", jb, body,
                             pin.SE3(np.eye(3), np.array(_corner(p), dtype=float)),
                             pin.FrameType.OP_FRAME))
    q_nominal = np.array([0.0, p.com_height, 0.0])
    info = asdict(p) | {"planar": True, "total_mass": p.mass, "q_nominal": q_nominal.tolist(),
                        "builder": "rigid_body"}
    return MultibodyModel(model=model, name="rigid_body", params=info)


def rigid_body_numbers(preset: str | None, params: Sequence[Mapping]) -> FamilyNumbers:
    """The numbers of the rigid bodies ``rigid_body(**params[i])`` without building them
    (:class:`~roverimpact.models.family.ModelFamily` writes them into one model: the body's
    inertia and the contact corner's placement), each parameter set checked as
    :func:`rigid_body` checks it.

    Raises
    ------
    ModelError
        As :func:`rigid_body`, for the first bad parameter set; a preset (the rigid body
        has none).
    """
    if preset is not None:
        raise ModelError(f"rigid_body has no presets, got {preset!r}")
    base = asdict(RigidBodyParams())
    params = list(params)
    p = family_columns(base, params)
    if p is None or not numbers_ok(p, _POSITIVE, _FINITE):
        # the first bad set raises as the builder does; numbers of other types that the
        # builder takes (numpy integers) are read from the checked sets
        checked = [_params(RigidBodyParams(), ov) for ov in params]
        p = SimpleNamespace(**{name: np.array([float(getattr(c, name)) for c in checked])
                               for name in base})
    q_nominal = np.zeros((len(params), 3))
    q_nominal[:, 1] = p.com_height
    return FamilyNumbers.of_layout(_layout(p), len(params), q_nominal, [],
                                   frames={"contact": _corner(p)})
