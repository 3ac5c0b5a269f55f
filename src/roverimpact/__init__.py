"""roverimpact: impact analysis of planetary rovers and other multibody systems.

The public API is what this module exports; submodules whose name starts with an
underscore are private.
"""

from . import contact
from ._version import __version__
from .activeset import UnilateralImpactResult, active_set, unilateral_impact
from .contact import impact_1dof, peak_force
from .energy import Partition, effective_mass, partition, projector
from .exceptions import ConfigError, InputError, ModelError, RoverImpactError, SolverError
from .impulse import ImpactResult, impulsive_impact
from .models import (
    MultibodyModel,
    export_urdf,
    load_robot,
    rocker_bogie,
    rover2d,
)
from .safety import (
    BODY_REGIONS,
    arm_effective_masses,
    max_transient_speed,
    point_effective_mass,
)
from .scenario import (
    ImpactEnergy,
    ImpactSetup,
    Scenario,
    energy_of,
    load_scenario,
    sweep_energy,
)
from .simulate import GRAVITY, SimulationConfig, SimulationResult, simulate_impact
from .studies import Agreement, Study, StudyResult, agreement, run_study
from .studies.optimize import optimize_setting
from .studies.reproduce import reproduce
from .studies.trust import TrustGrid, trust_map

__all__ = [
    "BODY_REGIONS",
    "GRAVITY",
    "Agreement",
    "ConfigError",
    "ImpactEnergy",
    "ImpactResult",
    "ImpactSetup",
    "InputError",
    "ModelError",
    "MultibodyModel",
    "Partition",
    "RoverImpactError",
    "Scenario",
    "SimulationConfig",
    "SimulationResult",
    "SolverError",
    "Study",
    "StudyResult",
    "TrustGrid",
    "UnilateralImpactResult",
    "__version__",
    "active_set",
    "agreement",
    "arm_effective_masses",
    "contact",
    "effective_mass",
    "energy_of",
    "export_urdf",
    "impact_1dof",
    "impulsive_impact",
    "load_robot",
    "load_scenario",
    "max_transient_speed",
    "optimize_setting",
    "partition",
    "peak_force",
    "point_effective_mass",
    "projector",
    "reproduce",
    "rocker_bogie",
    "rover2d",
    "run_study",
    "simulate_impact",
    "sweep_energy",
    "trust_map",
    "unilateral_impact",
]
