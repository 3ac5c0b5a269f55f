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

#: Study scenarios are scenario files plus an optional ``[simulation]`` table (the
#: options of :class:`roverimpact.simulate.SimulationConfig`: gravity, friction ``mu``,
#: springs, integrator...). Speed, impact angle and contact law default to the scenario's.
SIMULATION_KEY = "simulation"

_LAYER_ERRORS = (ValueError, TypeError, KeyError)


def _scenario_module():
    mod = _optional("scenario")
    if mod is None or not hasattr(mod, "scenario_from_dict"):
        raise ConfigError(
            "the scenario layer (roverimpact.scenario) is not available in this "
            "installation, so rover studies cannot run; use model.name = 'rigid_body' "
            "for the closed-form demonstration model"
        )
    return mod


def _split(scenario: Mapping[str, Any]) -> tuple[dict, dict]:
    scn = dict(scenario)
    sim = scn.pop(SIMULATION_KEY, None) or {}
    return scn, dict(sim)


def _parse(scenario: Mapping[str, Any], where: str = "scenario"):
    """Validated ``(Scenario, simulation dict)`` of a study scenario."""
    scn, sim = _split(scenario)
    return _scenario_module().scenario_from_dict(scn, where=where), sim


def _law_of(sc):
    """Contact law of the scenario's ``[contact_law]`` (None if absent)."""
    spec = getattr(sc, "contact_law", None)
    if spec is None:
        return None
    from ..contact import get_law

    return get_law(spec.name, k=spec.k, e=spec.e, n=spec.n)


def _peak_force(T_c_minus, v_n, law) -> np.ndarray:
    """Predicted peak force [N] (NaN without a law, 0 where there is no approach)."""
    T = np.atleast_1d(np.asarray(T_c_minus, float))
    v = np.broadcast_to(np.atleast_1d(np.asarray(v_n, float)), T.shape)
    out = np.full(T.shape, np.nan)
    if law is None:
        return out
    from ..contact import peak_force

    hit = (T > 0) & (v > 0) & np.isfinite(T)
    out[~hit] = 0.0
    if hit.any():
        out[hit] = np.asarray(peak_force(T[hit], v[hit], law), float)
    return out


def simulation_config(sc, sim: Mapping[str, Any]):
    """The :class:`~roverimpact.simulate.SimulationConfig` of a study scenario.

    Completed from the scenario as for a scenario file
    (:func:`roverimpact.simulate._files.simulation_settings`): ``speed`` from
    ``velocity.u``, ``beta_deg`` from ``obstacle.beta_deg``, the obstacle law from
    ``[contact_law]``, and the simulator's T_c^- with the scenario's constraint choice.
    """
    from ..simulate import SimulationConfig
    from ..simulate._files import simulation_settings

    raw = sc.model_dump(include={"obstacle", "contact_law", "contacts", "constraints",
                                 "velocity"})
    if not raw["velocity"].get("u"):
        raw["velocity"].pop("u", None)  # unset speed: the simulation table must give it
    raw["simulation"] = dict(sim)
    where = "study scenario [simulation]"
    return SimulationConfig.from_dict(simulation_settings(raw, where), source=where)


def _simulate_one(sc, sim: Mapping[str, Any], model) -> dict[str, Any]:
    """F_max (summed obstacle normal force, the papers' f_n) and duration; NaN on failure."""
    from ..exceptions import RoverImpactError
    from ..simulate import simulate_impact

    try:
        res = simulate_impact(model, simulation_config(sc, sim))
    except (RoverImpactError, *_LAYER_ERRORS) as exc:
        return {"F_max": np.nan, "contact_duration": np.nan, "T_c_minus_sim": np.nan,
                "sim_error": f"{type(exc).__name__}: {exc}"}
    return {"F_max": float(res.F_max_total), "contact_duration": float(res.contact_duration),
            "T_c_minus_sim": float(res.T_c_minus), "sim_error": ""}


def evaluate_case(scenario: Mapping[str, Any], *, simulate: bool = False) -> dict[str, Any]:
    """Evaluate one study scenario: indicator, predicted and (optionally) simulated force.

    This function (with :class:`ScenarioEvaluator`, its batched form) is the only place
    where studies call the scenario, contact and simulate layers.

    Parameters
    ----------
    scenario : dict
        A scenario as in a scenario file (nested dicts), plus an optional
        ``simulation`` table of simulator options.
    simulate : bool
        Also run the compliant-contact simulation.

    Returns
    -------
    dict
        ``T_c_minus`` [J], ``m_eff`` [kg], ``v_n`` [m/s], ``F_pred`` [N] and, with
        ``simulate``, ``F_max`` [N], ``contact_duration`` [s], ``T_c_minus_sim`` [J]
        (the simulator's own T_c^- at first contact) and ``sim_error`` ("" if none).
    """
    if _is_rigid_body(scenario):
        return _rigid_body_single(scenario, simulate)
    sc, sim = _parse(scenario)
    setup = sc.build()
    en = setup.partition()
    out: dict[str, Any] = {
        "T_c_minus": float(en.T_c_minus),
        "m_eff": float(en.m_eff),
        "v_n": float(en.v_n),
        "F_pred": float(_peak_force(en.T_c_minus, en.v_n, _law_of(sc))[0]),
    }
    if simulate:
        out.update(_simulate_one(sc, sim, setup.model))
    return out


def simulator_available() -> bool:
    """True when the compliant-contact simulator layer is installed."""
    sim = _optional("simulate")
    return sim is not None and hasattr(sim, "simulate_impact")


_BETA = "obstacle.beta_deg"


class ScenarioEvaluator:
    """Evaluator of the built-in rovers (and robot files) through the scenario layer.

    Batched: cases that differ only in the impact angle ``obstacle.beta_deg`` and the
    contact law share one ``Scenario.build()`` (Pinocchio evaluates ``M``, ``A``, ``v``
    once) and get T_c^- for all their angles from one stacked
    :func:`roverimpact.scenario.sweep_energy` call; the predicted peak force is one
    vectorized ``peak_force`` call per law. Simulations run one per case.
    """

    name = "scenario"

    def validate(self, scenario: Mapping[str, Any]) -> dict:
        """Schema check (cheap): the normalized scenario, ConfigError if invalid."""
        if _is_rigid_body(scenario):
            return RigidBodyEvaluator().validate(scenario)
        sc, sim = _parse(scenario)
        try:
            simulation_config(sc, sim)
        except _LAYER_ERRORS as exc:
            raise ConfigError(str(exc)) from None
        out = sc.model_dump(mode="json")
        if sim:
            out[SIMULATION_KEY] = sim
        return out

    def check(self, scenario: Mapping[str, Any]) -> None:
        """Deep check (builds the model): unknown model parameters, bad geometry, law."""
        if _is_rigid_body(scenario):
            return
        sc, _ = _parse(scenario)
        try:
            sc.build()
            _law_of(sc)
        except ConfigError:
            raise
        except _LAYER_ERRORS as exc:
            raise ConfigError(f"{type(exc).__name__}: {exc}") from None

    def evaluate(self, base, overrides, *, simulate: bool = False) -> dict[str, np.ndarray]:
        if _is_rigid_body(base):
            return RigidBodyEvaluator().evaluate(base, overrides, simulate=simulate)
        from ..scenario import sweep_energy

        n = len(overrides)
        T = np.full(n, np.nan)
        m_eff = np.full(n, np.nan)
        v_n = np.full(n, np.nan)
        F_pred = np.full(n, np.nan)
        sims: list[dict] = [{} for _ in range(n)]
        groups: dict[str, list[int]] = {}
        for i, ov in enumerate(overrides):
            key = _group_key(ov)
            groups.setdefault(key, []).append(i)
        for idx in groups.values():
            first = apply_overrides(base, overrides[idx[0]])
            sc, _sim = _parse(first)
            setup = sc.build()
            if sc.obstacle.beta_deg is not None:
                betas = np.array([float(overrides[i].get(_BETA, sc.obstacle.beta_deg))
                                  for i in idx])
                en = sweep_energy(setup, np.deg2rad(betas))
            else:
                en = setup.partition()
            T[idx] = en.T_c_minus
            m_eff[idx] = en.m_eff
            v_n[idx] = en.v_n
            laws: dict[str, list[int]] = {}
            for i in idx:
                laws.setdefault(_law_key(overrides[i]), []).append(i)
            for members in laws.values():
                sc_i = _parse(apply_overrides(base, overrides[members[0]]))[0]
                F_pred[members] = _peak_force(T[members], v_n[members], _law_of(sc_i))
            if simulate:
                for i in idx:
                    sc_i, sim_i = _parse(apply_overrides(base, overrides[i]))
                    sims[i] = _simulate_one(sc_i, sim_i, setup.model)
        out = {"T_c_minus": T, "m_eff": m_eff, "v_n": v_n, "F_pred": F_pred}
        if simulate:
            out.update(_columns(sims))
        return out


def _group_key(ov: Mapping[str, Any]) -> str:
    """Cases with the same key share M, A and v (they differ in beta / contact law only)."""
    items = sorted((k, v) for k, v in ov.items()
                   if k != _BETA and not k.startswith(("contact_law.", SIMULATION_KEY + ".")))
    return repr(items)


def _law_key(ov: Mapping[str, Any]) -> str:
    return repr(sorted((k, v) for k, v in ov.items() if k.startswith("contact_law.")))


def _columns(rows: Sequence[Mapping[str, Any]]) -> dict[str, np.ndarray]:
    keys: dict[str, None] = {}
    for r in rows:
        keys.update(dict.fromkeys(r))
    out = {}
    for k in keys:
        vals = [r.get(k, np.nan) for r in rows]
        out[k] = (np.array(vals, dtype=object) if any(isinstance(v, str) for v in vals)
                  else np.array(vals, dtype=float))
    return out


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
        90.0, ge=0.0, le=90.0,
        description="angle of the obstacle face with the ground [deg] (90: vertical wall)",
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
                 +--C  / obstacle face at angle beta with the ground

    As in the scenario layer, the outward obstacle normal is
    ``n = (-sin beta, cos beta)`` (beta = 90 deg: vertical wall). The contact row is the
    velocity of C along ``d = -n``: ``a = [d_x, d_z, r_x d_z - r_z d_x]``, so ``T_c^-``
    comes from :func:`roverimpact.partition` with ``A = a`` and ``v = (u, 0, 0)``; the
    approach speed is ``v_n = u sin(beta)``. Computed batched
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
        dx, dz = np.sin(beta), -np.cos(beta)
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
