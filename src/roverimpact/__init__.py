"""roverimpact: impact analysis of planetary rovers and other multibody systems.

The public API is what this module exports; submodules whose name starts with an
underscore are private.
"""

from ._version import __version__
from .energy import Partition, effective_mass, partition, projector
from .exceptions import ConfigError, InputError, ModelError, RoverImpactError, SolverError
from .impulse import ImpactResult, impulsive_impact

__all__ = [
    "ConfigError",
    "ImpactResult",
    "InputError",
    "ModelError",
    "Partition",
    "RoverImpactError",
    "SolverError",
    "__version__",
    "effective_mass",
    "impulsive_impact",
    "partition",
    "projector",
]
