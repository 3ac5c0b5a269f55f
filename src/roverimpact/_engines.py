"""The simulation engines' names, checked without importing the simulators.

A study's or a scenario's ``simulate`` names engines; checking those names, and finding
the engines' columns in a results table (``roverimpact report``), needs the names alone.
The engines themselves are :data:`roverimpact.simulate.engines.ENGINES` (a test keeps the
two lists equal).
"""

from __future__ import annotations

from .exceptions import ConfigError

__all__ = ["ENGINE_NAMES", "engine_name", "engines_of"]

#: The simulators a scenario can run in: ``"own"`` (:func:`roverimpact.simulate.simulate_impact`,
#: the reference), ``"mujoco"`` (MuJoCo's soft contact) and ``"mujoco_laws"`` (MuJoCo's
#: dynamics, the scenario's laws); :mod:`roverimpact.simulate.engines`.
ENGINE_NAMES = ("own", "mujoco", "mujoco_laws")


def engine_name(name) -> str:
    """``name`` checked against :data:`ENGINE_NAMES` (case-insensitive, ``-`` as ``_``).

    >>> engine_name("MuJoCo")
    'mujoco'
    >>> engine_name("mujoco-laws")
    'mujoco_laws'

    Raises
    ------
    ConfigError
        Not a string, or an unknown engine; the message lists the known ones.
    """
    key = name.strip().lower().replace("-", "_") if isinstance(name, str) else None
    if key not in ENGINE_NAMES:
        raise ConfigError(f"unknown simulation engine {name!r}: choose one of "
                          f"{', '.join(ENGINE_NAMES)}")
    return key


def engines_of(simulate) -> tuple[str, ...]:
    """The engines of an evaluator's ``simulate`` argument: ``False`` -> ``()``, ``True``
    -> ``("own",)``, a name or a sequence of names as given (checked)."""
    if simulate is True:
        return ("own",)
    if not simulate:
        return ()
    names = (simulate,) if isinstance(simulate, str) else tuple(simulate)
    return tuple(engine_name(n) for n in names)
