"""roverimpact: impact analysis of planetary rovers and other multibody systems.

The public API is what this module exports; submodules whose name starts with an
underscore are private. Names are loaded on first use (PEP 562), so ``import roverimpact``
needs numpy alone and a command pays only for what it uses.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ._lazy import attach as _attach
from ._version import __version__

#: public name -> module that defines it (relative to this package)
_EXPORTS = {
    # core: numbers in, numbers out
    "Partition": ".energy", "effective_mass": ".energy", "partition": ".energy",
    "projector": ".energy",
    "ImpactResult": ".impulse", "impulsive_impact": ".impulse",
    "UnilateralImpactResult": ".unilateral", "active_set": ".unilateral",
    "unilateral_impact": ".unilateral",
    "ConfigError": ".exceptions", "InputError": ".exceptions", "ModelError": ".exceptions",
    "RoverImpactError": ".exceptions", "SolverError": ".exceptions",
    # contact laws and closed forms
    "impact_1dof": ".contact", "peak_force": ".contact",
    # models
    "MultibodyModel": ".models", "export_urdf": ".models", "load_robot": ".models",
    "rocker_bogie": ".models", "rover2d": ".models",
    # scenarios
    "ImpactEnergy": ".scenario", "ImpactSetup": ".scenario", "Scenario": ".scenario",
    "energy_of": ".scenario", "load_scenario": ".scenario", "sweep_energy": ".scenario",
    # simulation
    "GRAVITY": ".simulate", "SimulationConfig": ".simulate",
    "SimulationResult": ".simulate", "simulate_impact": ".simulate",
    # robot safety
    "BODY_REGIONS": ".safety", "arm_effective_masses": ".safety",
    "max_transient_speed": ".safety", "point_effective_mass": ".safety",
    # studies and reports
    "Agreement": ".studies", "Study": ".studies", "StudyResult": ".studies",
    "agreement": ".studies", "run_study": ".studies",
    "optimize_setting": ".studies.optimize",
    "TrustGrid": ".studies.trust", "trust_map": ".studies.trust",
    "reproduce": ".report.reproduce",
}
_SUBPACKAGES = {"contact", "experiments", "models", "report", "safety", "scenario", "simulate",
                "studies"}

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


__getattr__, __dir__ = _attach(__name__, _EXPORTS, _SUBPACKAGES)

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs
    from . import contact
    from .contact import impact_1dof, peak_force
    from .energy import Partition, effective_mass, partition, projector
    from .exceptions import ConfigError, InputError, ModelError, RoverImpactError, SolverError
    from .impulse import ImpactResult, impulsive_impact
    from .models import MultibodyModel, export_urdf, load_robot, rocker_bogie, rover2d
    from .report.reproduce import reproduce
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
    from .studies.trust import TrustGrid, trust_map
    from .unilateral import UnilateralImpactResult, active_set, unilateral_impact
