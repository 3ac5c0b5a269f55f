"""Reading a simulation from a scenario TOML file.

The file is a scenario file (see :mod:`roverimpact.scenario`) with an extra
``[simulation]`` table holding a :class:`SimulationConfig`. From the scenario tables the
simulator uses ``[model]`` (which rover or robot file), ``[obstacle] beta_deg``,
``[contact_law]`` (the obstacle law), ``[velocity] u`` (driving speed) and, for the T_c^-
of the pre-impact state, ``[contacts] ground, locked`` and ``constraints`` (the
``indicator`` table); values given in ``[simulation]`` win. ``[configuration]`` and the
rest of ``[velocity]`` are not used: the run starts settled on flat ground.
"""

from __future__ import annotations

from pathlib import Path

from .._io import read_toml
from ..exceptions import ConfigError
from ._config import SimulationConfig

_SCENARIO_TABLES = {"description", "constraints", "model", "configuration", "velocity",
                    "contacts", "obstacle", "contact_law", "simulation"}


def build_model(spec: dict, base_dir: Path, where: str):
    """Model from a ``[model]`` table: ``name`` (rover2d | rocker_bogie) with ``preset`` and
    ``params``, or ``file`` (URDF/MJCF) with ``floating_base``."""
    from ..models import load_robot, rocker_bogie, rover2d

    if not isinstance(spec, dict):
        raise ConfigError(f"{where}: [model] must be a table")
    unknown = sorted(set(spec) - {"name", "file", "preset", "floating_base", "params"})
    if unknown:
        raise ConfigError(f"{where}: unknown key(s) in [model]: {unknown}")
    name, file = spec.get("name"), spec.get("file")
    if (name is None) == (file is None):
        raise ConfigError(f"{where}: give exactly one of model.name or model.file")
    params = spec.get("params", {})
    if file is not None:
        path = Path(file)
        if not path.is_absolute():
            path = base_dir / path
        return load_robot(str(path), floating_base=spec.get("floating_base"))
    if name == "rover2d":
        return rover2d(**params)
    if name == "rocker_bogie":
        return rocker_bogie(spec.get("preset"), **params)
    raise ConfigError(f"{where}: unknown model.name {name!r}; use 'rover2d' or 'rocker_bogie'")


def simulation_settings(raw: dict, where: str = "simulation config") -> dict:
    """The ``[simulation]`` table completed from the scenario tables.

    ``beta_deg`` and ``obstacle_wheels`` (the obstacle is in front of ``obstacle.wheel``
    only) from ``[obstacle]``, the obstacle law from ``[contact_law]``, ``speed``
    from ``[velocity] u`` and the indicator's ``ground``, ``locked`` (``[contacts]``) and
    ``constraints``, so that the simulator's T_c^- uses the scenario's constraint choice.
    Values given in ``[simulation]`` win. Used for scenario files and for study cases.
    """
    if not isinstance(raw.get("simulation", {}), dict):
        raise ConfigError(f"{where}: [simulation] must be a table")
    sim = dict(raw.get("simulation") or {})
    obstacle = raw.get("obstacle") or {}
    if obstacle.get("beta_deg") is not None and "beta_deg" not in sim:
        sim["beta_deg"] = obstacle["beta_deg"]
    if obstacle.get("wheel") is not None and "obstacle_wheels" not in sim:
        sim["obstacle_wheels"] = [obstacle["wheel"]]  # the obstacle is in that wheel's path
    law = raw.get("contact_law")
    if law is not None and "obstacle" not in sim:
        sim["obstacle"] = {("law" if k == "name" else k): v for k, v in law.items()
                           if v is not None}
    contacts = raw.get("contacts") or {}
    ind = dict(sim.get("indicator", {}))
    for key in ("ground", "locked"):
        if key in contacts and key not in ind:
            ind[key] = contacts[key]
    if "constraints" in raw and "constraints" not in ind:
        ind["constraints"] = raw["constraints"]
    if ind:
        sim["indicator"] = ind
    if "u" in (raw.get("velocity") or {}) and "speed" not in sim:
        sim["speed"] = raw["velocity"]["u"]
    return sim


def simulation_from_dict(raw: dict, *, where: str = "simulation config",
                         base_dir: Path | None = None):
    """``(model, SimulationConfig)`` from a parsed scenario/simulation dict."""
    unknown = sorted(set(raw) - _SCENARIO_TABLES)
    if unknown:
        raise ConfigError(f"{where}: unknown table(s) {unknown}; known: "
                          f"{sorted(_SCENARIO_TABLES)}")
    if "model" not in raw:
        raise ConfigError(f"{where}: missing [model] table (e.g. name = \"rover2d\")")
    cfg = SimulationConfig.from_dict(simulation_settings(raw, where), where)
    model = build_model(raw["model"], base_dir or Path.cwd(), where)
    return model, cfg


def load_simulation(path: str | Path):
    """``(model, SimulationConfig)`` from a TOML file (ConfigError naming the file)."""
    path = Path(path)
    return simulation_from_dict(read_toml(path), where=str(path), base_dir=path.parent)
