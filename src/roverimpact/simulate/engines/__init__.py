"""Other simulators running the same impact scenario as :mod:`roverimpact.simulate`.

* :func:`simulate_impact_mujoco` -- MuJoCo (``pip install mujoco``): the rover exported by
  :func:`roverimpact.models.export_mjcf.export_mjcf`, MuJoCo's own soft contact with
  solref/solimp set from the scenario's contact law (engine ``"mujoco"``), or the
  scenario's laws themselves applied as forces, MuJoCo computing the dynamics
  (:func:`simulate_impact_mujoco_laws`, engine ``"mujoco_laws"``). Same
  :class:`~roverimpact.simulate.SimulationConfig`, same
  :class:`~roverimpact.simulate.SimulationResult`. See docs/simulate.md, "MuJoCo as a
  second engine".

Engines by name (``roverimpact simulate --engine NAME``, a study's ``simulate = "NAME"``):
:data:`ENGINE_NAMES`, :func:`get_engine`, :func:`check_engine`.

``mujoco`` is imported when a function runs, not at import time.
"""

from __future__ import annotations

from collections.abc import Callable

from ..._engines import ENGINE_NAMES, engine_name
from ...exceptions import ConfigError, ModelError
from ..config import SimulationConfig
from ..result import SimulationResult
from .mujoco import (
    ENGINES,
    LinearContact,
    check_frictionless,
    equivalent_kelvin_voigt,
    linear_contact,
    simulate_impact_mujoco,
    simulate_impact_mujoco_laws,
)

__all__ = ["ENGINES", "ENGINE_NAMES", "LinearContact", "check_engine", "engine_name",
           "equivalent_kelvin_voigt", "get_engine", "linear_contact", "simulate_impact_mujoco",
           "simulate_impact_mujoco_laws", "simulate_scenario"]

def get_engine(name: str) -> Callable:
    """The function ``(mbm, config, *, q0=None, v0=None) -> SimulationResult`` of an engine."""
    return ENGINES[engine_name(name)]


def check_engine(name: str, mbm, config, *, terrain: bool = False) -> None:
    """Refuse, before any run, a model the engine cannot take (one :class:`ConfigError`
    naming the model and what is unsupported).

    The own engine takes every model with wheels. MuJoCo takes what
    :func:`~roverimpact.models.export_mjcf.mjcf_element` can write: trees of
    prismatic/revolute joints with an optional free-flyer root, linear loop closures,
    wheels on moving bodies, springs on 1-DoF joints; a robot file (URDF/MJCF) goes
    through the same Pinocchio model (its inertias and joints; wheels as spheres, as in
    the own engine).
    """
    name = engine_name(name)
    if name == "own":
        return
    if terrain:
        raise ConfigError("the MuJoCo engine drives on the plane z = 0 only; a scenario with "
                          "[terrain] runs in the own engine (engine 'own')")
    if name == "mujoco_laws":
        check_frictionless(getattr(config, "mu", 0.0))
    from ...models.export_mjcf import mjcf_element

    try:
        mjcf_element(mbm, springs=getattr(config, "springs", None) or None)
    except ModelError as exc:
        msg = str(exc).removeprefix("export_mjcf: ")
        raise ConfigError(f"the MuJoCo engine cannot run model {mbm.name!r}: {msg}; run it "
                          "with the own engine (engine 'own')") from None


def simulate_scenario(scenario, *, model=None, where: str = "scenario",
                      engine: str = "own") -> SimulationResult:
    """Run the simulation a scenario describes (what ``roverimpact simulate`` does).

    The model of ``[model]`` (or ``model``, already built), the start configuration of
    ``[configuration]`` (settled on the ground unless ``simulation.settle = false``) and
    :meth:`SimulationConfig.from_scenario`, in the simulator ``engine`` (``"own"`` or
    ``"mujoco"``, :data:`ENGINE_NAMES`). With ``[terrain]`` (the own engine): the ground
    of :func:`~roverimpact.scenario.ground.make_terrain`, the rover placed on it as the
    indicator places it (``terrain.pose``, ``pose_wheels``), see
    :func:`~roverimpact.simulate.simulate_impact`.

    Raises
    ------
    ConfigError
        An unknown engine, or a model or terrain the engine cannot take (before any run).
    """
    from ...scenario.build import configuration, scenario_model

    run = get_engine(engine)
    cfg = SimulationConfig.from_scenario(scenario, where=where)
    ts = scenario.terrain
    mbm = scenario_model(scenario) if model is None else model
    check_engine(engine, mbm, cfg, terrain=ts is not None)
    q0 = configuration(mbm, scenario.configuration)
    if ts is None:
        return run(mbm, cfg, q0=q0)
    from ...scenario.ground import make_terrain

    return run(mbm, cfg, q0=q0, terrain=make_terrain(ts, mbm, q0), pose=ts.pose,
               pose_wheels=ts.pose_wheels)
