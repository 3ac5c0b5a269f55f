"""Multibody models: built-in rovers and any URDF/MJCF robot, all through Pinocchio.

* :func:`rover2d` -- parametric planar rover (DETC2014-35554, Fig. 1).
* :class:`MultibodyModel`, :class:`Wheel` -- the shared description every builder returns.
"""

from .base import MultibodyModel, Wheel
from .rover2d import Rover2DParams, rover2d

__all__ = ["MultibodyModel", "Rover2DParams", "Wheel", "rover2d"]
