r"""Robot arms near people: ISO/TS 15066 transient-contact speed limits and exact effective mass.

* :mod:`.iso_ts_15066`: the standard's two-body model of a free (transient) collision,
  :math:`v_{rel,max} = F_{max} / \sqrt{\mu K}` with :math:`\mu^{-1} = m_H^{-1} + m_R^{-1}`
  and the crude robot mass :math:`m_R = M/2 + m_L`; its body regions and areas.
* :mod:`.arm`: the exact robot-side mass of a point of an arm link along a direction u,
  :math:`m_u = 1 / (u^T J_p M(q)^{-1} J_p^T u)` (the effective mass of the row
  :math:`a = u^T J_p`), and how far the standard's single number is from it (Pinocchio,
  imported lazily).
"""

from .arm import (
    READY_POSES,
    arm_effective_masses,
    load_arm,
    point_effective_mass,
    point_speed_limits,
)
from .iso_ts_15066 import (
    BODY_AREAS,
    BODY_REGIONS,
    ISO_TS_15066_SOURCE,
    BodyArea,
    BodyRegion,
    body_region,
    iso_robot_mass,
    max_transient_speed,
    reduced_mass,
    transfer_energy,
)

__all__ = [
    "BODY_AREAS",
    "BODY_REGIONS",
    "ISO_TS_15066_SOURCE",
    "READY_POSES",
    "BodyArea",
    "BodyRegion",
    "arm_effective_masses",
    "body_region",
    "iso_robot_mass",
    "load_arm",
    "max_transient_speed",
    "point_effective_mass",
    "point_speed_limits",
    "reduced_mass",
    "transfer_energy",
]
