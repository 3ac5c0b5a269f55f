"""roverimpact: impact analysis of planetary rovers and other multibody systems.

The public API is what this module exports; submodules whose name starts with an
underscore are private.
"""

from . import contact
from ._version import __version__
from .contact import impact_1dof, peak_force
from .energy import Partition, effective_mass, partition, projector
from .exceptions import ConfigError, InputError, ModelError, RoverImpactError, SolverError
from .impulse import ImpactResult, impulsive_impact
from .safety import (
    BODY_REGIONS,
    arm_effective_masses,
    max_transient_speed,
    point_effective_mass,
)

__all__ = [
    "BODY_REGIONS",
    "ConfigError",
    "ImpactResult",
    "InputError",
    "ModelError",
    "Partition",
    "RoverImpactError",
    "SolverError",
    "__version__",
    "arm_effective_masses",
    "contact",
    "effective_mass",
    "impact_1dof",
    "impulsive_impact",
    "max_transient_speed",
    "partition",
    "peak_force",
    "point_effective_mass",
    "projector",
]
