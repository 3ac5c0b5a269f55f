r"""Evaluators: what a study computes for one case.

All the wiring from studies to the model, contact-law and simulator layers lives in this
module. An *evaluator* has

- ``name`` (written into the results manifest),
- ``validate(scenario: dict) -> dict``: the normalized scenario (defaults filled in);
  raises :class:`~roverimpact.exceptions.ConfigError` or a pydantic ``ValidationError``,
- ``evaluate(base, overrides, *, simulate) -> dict[str, array]``: one output column per
  quantity, one entry per override dict (a case is ``apply_overrides(base, ov)``).

:func:`evaluate_case` (one scenario dict -> dict of outputs) is the single entry point
into the scenario / contact / simulate layers; :class:`ScenarioEvaluator` batches it.
Any plain function ``scenario_dict -> dict`` becomes an evaluator with
:class:`FunctionEvaluator`. :class:`RigidBodyEvaluator` is a closed-form planar rigid
body hit at an obstacle (used by the tests and the documentation; it is not a rover).

Output columns (SI): ``T_c_minus`` [J], ``m_eff`` [kg], ``v_n`` [m/s] (approach
speed along the normal), ``F_pred`` [N] (peak force predicted by the contact law from
T_c^-), and with ``simulate``: ``F_max`` [N], ``contact_duration`` [s].
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from ..energy import partition
from ..exceptions import ConfigError
from .config import apply_overrides

__all__ = [
    "FunctionEvaluator",
    "RigidBodyEvaluator",
    "ScenarioEvaluator",
    "evaluate_case",
    "get_evaluator",
]

#: Output columns every study produces (simulate adds ``F_max`` and ``contact_duration``).
INDICATOR_COLUMNS = ("T_c_minus", "m_eff", "v_n", "F_pred")
SIMULATION_COLUMNS = ("F_max", "contact_duration")


def _optional(module: str):
    """Import ``roverimpact.<module>`` or return None if that layer has not landed."""
    try:
        return importlib.import_module(f"roverimpact.{module}")
    except ImportError:
        return None


# -------------------------------------------------------------------------------------
# The single entry point into the scenario / contact / simulate layers
# -------------------------------------------------------------------------------------


def _scenario_module():
    mod = _optional("scenario")
    if mod is None or not hasattr(mod, "Scenario"):
        raise ConfigError(
            "the scenario layer (roverimpact.scenario.Scenario) is not available in this "
            "installation, so rover studies cannot run; use model.name = 'rigid_body' "
            "for the closed-form demonstration model"
        )
    return mod


def evaluate_case(scenario: Mapping[str, Any], *, simulate: bool = False) -> dict[str, float]:
    """Evaluate one scenario: the indicator, the predicted and (optionally) simulated force.

    Parameters
    ----------
    scenario : dict
        A scenario as in a scenario file (nested dicts).
    simulate : bool
        Also run the compliant-contact simulation.

    Returns
    -------
    dict
        ``T_c_minus`` [J], ``m_eff`` [kg], ``v_n`` [m/s], ``F_pred`` [N] and, with
        ``simulate``, ``F_max`` [N] and ``contact_duration`` [s] (NaN where a layer is
        not available).
    """
    if _is_rigid_body(scenario):
        return _rigid_body_single(scenario, simulate)
    mod = _scenario_module()
    scn = mod.Scenario.model_validate(dict(scenario))
    built = scn.build()
    out = {
        "T_c_minus": float(built.T_c_minus),
        "m_eff": float(built.m_eff),
        "v_n": float(built.v_n),
        "F_pred": _peak_force(built.T_c_minus, built.v_n, scn),
    }
    if simulate:
        out.update(_simulate(scn, built))
    return out


def _peak_force(T_c_minus, v_n, scn) -> float:
    contact = _optional("contact")
    if contact is None or not hasattr(contact, "peak_force"):
        return float("nan")
    law = contact.get_law(scn.contact) if hasattr(scn, "contact") else None
    return float(contact.peak_force(T_c_minus, v_n, law))


def _simulate(scn, built) -> dict[str, float]:
    sim = _optional("simulate")
    if sim is None or not hasattr(sim, "simulate"):
        return {"F_max": float("nan"), "contact_duration": float("nan")}
    res = sim.simulate(scn)
    return {"F_max": float(res.F_max), "contact_duration": float(res.contact_duration)}


def simulator_available() -> bool:
    """True when the compliant-contact simulator layer is installed."""
    sim = _optional("simulate")
    return sim is not None and hasattr(sim, "simulate")


class ScenarioEvaluator:
    """Evaluator of the built-in rovers through the scenario layer (see :func:`evaluate_case`)."""

    name = "scenario"

    def validate(self, scenario: Mapping[str, Any]) -> dict:
        if _is_rigid_body(scenario):
            return RigidBodyEvaluator().validate(scenario)
        mod = _scenario_module()
        return mod.Scenario.model_validate(dict(scenario)).model_dump(mode="json")

    def evaluate(self, base, overrides, *, simulate: bool = False) -> dict[str, np.ndarray]:
        if _is_rigid_body(base):
            return RigidBodyEvaluator().evaluate(base, overrides, simulate=simulate)
        rows = [evaluate_case(apply_overrides(base, ov), simulate=simulate) for ov in overrides]
        return _columns(rows)


def _columns(rows: Sequence[Mapping[str, float]]) -> dict[str, np.ndarray]:
    keys: dict[str, None] = {}
    for r in rows:
        keys.update(dict.fromkeys(r))
    return {k: np.array([r.get(k, np.nan) for r in rows]) for k in keys}


class FunctionEvaluator:
    """Wrap a plain function ``scenario_dict -> dict of outputs`` as an evaluator.

    Parameters
    ----------
    fn : callable
        Called once per case with the full scenario dict; must be picklable for
        distributed runs (a module-level function).
    validate : callable, optional
        ``scenario -> normalized scenario``; default: returns the scenario unchanged.
    name : str, optional
    """

    def __init__(self, fn: Callable[[dict], Mapping[str, float]], validate=None, name=None):
        self.fn = fn
        self._validate = validate
        self.name = name or getattr(fn, "__qualname__", "function")

    def validate(self, scenario):
        return dict(self._validate(scenario)) if self._validate else dict(scenario)

    def evaluate(self, base, overrides, *, simulate: bool = False):
        return _columns([self.fn(apply_overrides(base, ov)) for ov in overrides])


def get_evaluator(evaluator=None):
    """The default :class:`ScenarioEvaluator`, an evaluator object, or a wrapped function."""
    if evaluator is None:
        return ScenarioEvaluator()
    if hasattr(evaluator, "evaluate") and hasattr(evaluator, "validate"):
        return evaluator
    if callable(evaluator):
        return FunctionEvaluator(evaluator)
    raise TypeError(f"not an evaluator: {evaluator!r}")


# -------------------------------------------------------------------------------------
# Closed-form demonstration model: a planar rigid body hitting an obstacle
# -------------------------------------------------------------------------------------


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class RigidBodyParams(_Strict):
    mass: float = Field(20.0, gt=0, description="mass m [kg]")
    inertia: float = Field(1.0, gt=0, description="central moment of inertia I [kg m^2]")
    com_height: float = Field(0.3, description="height h of the COM above the contact point [m]")
    lever: float = Field(
        0.4, description="horizontal distance from the COM to the contact point [m]"
    )


class RigidBodyModel(_Strict):
    name: str = Field(pattern="^rigid_body$")
    params: RigidBodyParams = RigidBodyParams()


class RigidBodyObstacle(_Strict):
    beta_deg: float = Field(
        0.0, ge=-89.999, le=89.999,
        description="inclination of the obstacle normal from horizontal [deg]",
    )


class RigidBodyMotion(_Strict):
    speed: float = Field(0.5, gt=0, description="forward speed u [m/s]")


class RigidBodyScenario(_Strict):
    """Scenario of the closed-form planar rigid body (see :class:`RigidBodyEvaluator`)."""

    model: RigidBodyModel
    obstacle: RigidBodyObstacle = RigidBodyObstacle()
    motion: RigidBodyMotion = RigidBodyMotion()


def _is_rigid_body(scenario: Mapping[str, Any]) -> bool:
    model = scenario.get("model") if isinstance(scenario, Mapping) else None
    if isinstance(model, Mapping):
        return model.get("name") == "rigid_body"
    return model == "rigid_body"


class RigidBodyEvaluator:
    r"""A planar rigid body translating at speed u hits an obstacle at its front-bottom point.

    ::

              h  G --> u            coordinates (x, z, theta) of the COM G,
                 |\                 M = diag(m, m, I)
                 | \ r = (l, -h)
                 +--C  obstacle normal d = (cos beta, -sin beta)

    The contact row is ``a = [d_x, d_z, r_x d_z - r_z d_x]`` (velocity of C along d), so
    ``T_c^-`` comes from :func:`roverimpact.partition` with ``A = a`` and
    ``v = (u, 0, 0)``; the approach speed is ``v_n = u cos(beta)``. Computed batched
    over all cases (one ``partition`` call on stacked arrays).
    """

    name = "rigid_body"

    def validate(self, scenario):
        return RigidBodyScenario.model_validate(dict(scenario)).model_dump(mode="json")

    def evaluate(self, base, overrides, *, simulate: bool = False):
        n = len(overrides)
        if n == 0:
            return {k: np.empty(0) for k in ("T_c_minus", "m_eff", "v_n")}
        b = RigidBodyScenario.model_validate(dict(base))
        defaults = {
            "model.params.mass": b.model.params.mass,
            "model.params.inertia": b.model.params.inertia,
            "model.params.com_height": b.model.params.com_height,
            "model.params.lever": b.model.params.lever,
            "obstacle.beta_deg": b.obstacle.beta_deg,
            "motion.speed": b.motion.speed,
        }
        col = {k: np.array([float(ov.get(k, d)) for ov in overrides]) for k, d in defaults.items()}
        m, inertia = col["model.params.mass"], col["model.params.inertia"]
        h, lever = col["model.params.com_height"], col["model.params.lever"]
        beta = np.deg2rad(col["obstacle.beta_deg"])
        u = col["motion.speed"]
        dx, dz = np.cos(beta), -np.sin(beta)
        M = np.zeros((n, 3, 3))
        M[:, 0, 0] = M[:, 1, 1] = m
        M[:, 2, 2] = inertia
        A = np.stack([dx, dz, lever * dz - (-h) * dx], axis=-1)[:, None, :]
        v = np.zeros((n, 3))
        v[:, 0] = u
        p = partition(M, A, v, want_velocities=False)
        a = A[:, 0, :]
        m_eff = 1.0 / np.einsum("bi,bi->b", a * (1.0 / np.stack([m, m, inertia], -1)), a)
        out = {"T_c_minus": np.asarray(p.T_c, float), "m_eff": m_eff, "v_n": u * dx}
        return out


def _rigid_body_single(scenario, simulate):
    cols = RigidBodyEvaluator().evaluate(scenario, [{}], simulate=simulate)
    return {k: float(v[0]) for k, v in cols.items()}
