"""Compliant-contact impact simulation: the reference peak force F_max.

``simulate_impact(model, config)`` drives a :class:`~roverimpact.models.base.MultibodyModel`
into an obstacle face with a contact law of :mod:`roverimpact.contact` and returns a
:class:`SimulationResult` (force history, F_max, impulse, T_c^- of the pre-impact state).
A scenario file with a ``[simulation]`` table describes a run
(:meth:`SimulationConfig.from_scenario`); :func:`simulate_scenario` runs it in the own
simulator or in MuJoCo (``engine="mujoco"``, :mod:`roverimpact.simulate.engines`). See
docs/simulate.md for the equations, the contact geometry and the integrator.
"""

from .config import GRAVITY, ContactLawSpec, IntegratorSpec, JointSpring, SimulationConfig
from .engines import simulate_scenario
from .result import SimulationResult
from .run import (
    build_system,
    effective_energy,
    initial_state,
    reuse_settled_states,
    simulate_impact,
)
from .system import ContactForces, ContactSystem, Plane

__all__ = [
    "GRAVITY",
    "ContactForces",
    "ContactLawSpec",
    "ContactSystem",
    "IntegratorSpec",
    "JointSpring",
    "Plane",
    "SimulationConfig",
    "SimulationResult",
    "build_system",
    "effective_energy",
    "initial_state",
    "reuse_settled_states",
    "simulate_impact",
    "simulate_scenario",
]
