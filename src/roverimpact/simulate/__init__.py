"""Compliant-contact impact simulation: the reference peak force F_max.

``simulate_impact(model, config)`` drives a :class:`~roverimpact.models.base.MultibodyModel`
into an obstacle face with a contact law of :mod:`roverimpact.contact` and returns a
:class:`SimulationResult` (force history, F_max, impulse, T_c^- of the pre-impact state).
See docs/simulate.md for the equations, the contact geometry and the integrator.
"""

from ._config import (
    GRAVITY,
    ContactSpec,
    IndicatorSpec,
    IntegratorSpec,
    JointSpring,
    SimulationConfig,
)
from ._result import SimulationResult
from ._run import build_system, effective_energy, initial_state, simulate_impact
from ._system import ContactSystem, Plane

__all__ = [
    "GRAVITY",
    "ContactSpec",
    "ContactSystem",
    "IndicatorSpec",
    "IntegratorSpec",
    "JointSpring",
    "Plane",
    "SimulationConfig",
    "SimulationResult",
    "build_system",
    "effective_energy",
    "initial_state",
    "simulate_impact",
]
