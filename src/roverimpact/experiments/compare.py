"""Measured peak forces next to a model's T_c^- and F_max, condition by condition."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from .._io import read_toml
from ..exceptions import ConfigError, InputError
from .trials import ScenarioModelConfig

__all__ = ["ModelComparison", "ScenarioModel", "compare_with_model", "scenario_model"]




#: Keys of the scenario's ``[simulation]`` table that each condition sets.


@dataclass(frozen=True)
class ScenarioModel:
    r"""The rover model of the comparison: a scenario evaluated at each (beta, speed).

    For a condition the scenario gets ``obstacle.beta_deg`` = :math:`\beta` and
    ``velocity.u`` = speed (the driving speed, m/s); then

    - :math:`T_c^-` [J] is the effective kinetic energy of the scenario
      (:func:`roverimpact.energy_of`, with the scenario's constraint choice),
    - :math:`F_{max}` [N] is the peak of the summed obstacle normal force of the
      compliant-contact simulation (:func:`roverimpact.simulate_impact`) configured from
      the scenario as for ``roverimpact simulate`` (obstacle law from ``[contact_law]``,
      the rest from ``[simulation]``).

    Both come from :func:`roverimpact.studies.evaluate.evaluate_case`, the studies' single
    entry point into the scenario and simulate layers.

    Attributes
    ----------
    scenario : dict
        The scenario as read from TOML (with its optional ``simulation`` table).
    source : str
        Where it came from (for messages).
    simulate : bool
        Simulate each condition for F_max (default); ``False``: T_c^- and the simpler
        indicators only, ``F_max`` and ``contact_duration`` NaN (no contact law needed).
    """

    scenario: dict
    source: str = "scenario"
    simulate: bool = True

    @classmethod
    def from_file(cls, path: str | Path, *, simulate: bool = True) -> ScenarioModel:
        """Read a scenario TOML file; a relative ``model.file`` is taken from its folder.

        Raises
        ------
        ConfigError
            Missing or malformed file or invalid scenario.
        """
        path = Path(path)
        if not path.is_file():
            raise ConfigError(f"{path}: no such scenario file (model.scenario of the trials "
                              "file, relative to the trials file)")
        return cls.from_dict(read_toml(path), source=str(path), base_dir=path.parent,
                             simulate=simulate)

    @classmethod
    def from_dict(cls, raw: dict, *, source: str = "scenario",
                  base_dir: str | Path | None = None, simulate: bool = True
                  ) -> ScenarioModel:
        """Validate a scenario dict (schema and simulation settings; the model is built
        on the first call)."""
        from ..models.robot_data import is_example_robot
        from ..studies.evaluate import ScenarioEvaluator

        raw = dict(raw)
        model = raw.get("model")
        if isinstance(model, dict) and isinstance(model.get("file"), str) and base_dir:
            f = model["file"]
            if not is_example_robot(f) and not Path(f).is_absolute():
                raw["model"] = model | {"file": str(Path(base_dir) / f)}
        out = cls(raw, source, bool(simulate))
        try:
            ScenarioEvaluator().validate(out.case(math.radians(45.0), 0.5))
        except ConfigError as exc:
            raise ConfigError(f"{source}: {exc}") from None
        return out

    def case(self, beta: float, speed: float) -> dict:
        """The scenario dict of one condition (``beta`` [rad], ``speed`` [m/s])."""
        from ..studies.config import apply_overrides

        return apply_overrides(self.scenario, {
            "obstacle.beta_deg": round(math.degrees(beta), 9), "obstacle.normal": None,
            "velocity.u": float(speed)})

    def __call__(self, beta: float, speed: float) -> dict:
        """``{"T_c_minus": J, "F_max": N, "m_eff": kg, "v_n": m/s, "contact_duration": s,
        "sim_error": str}`` for ``beta`` [rad] and ``speed`` [m/s]; F_max is NaN and
        ``sim_error`` says why if the simulation failed (NaN and ``""`` without
        :attr:`simulate`)."""
        from ..studies.evaluate import evaluate_case

        out = evaluate_case(self.case(beta, speed), simulate=self.simulate)
        if not self.simulate:
            out = out | {"F_max": math.nan, "contact_duration": math.nan, "sim_error": ""}
        keys = ("T_c_minus", "F_max", "m_eff", "v_n", "contact_duration", "sim_error",
                "m_total", "m_eff_free", "T_n_total", "T_c_obstacle")
        return {k: out[k] for k in keys}


@dataclass
class ModelComparison:
    """Measured peaks next to the model, with rank agreement.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per condition (beta, speed): ``n``, ``F_peak_mean``, ``F_peak_std``,
        ``T_c_minus``, ``F_max`` (model), ``F_ratio`` = measured / model and any other
        scalar the model returns (e.g. ``m_eff``, ``v_n``, ``sim_error``).
    stats : dict
        ``kendall_tau_Tc``, ``kendall_p_Tc``, ``spearman_rho_Tc``, ``spearman_p_Tc`` (measured
        peak vs model T_c^-), the same with suffix ``_Fmax`` (vs model F_max), and for the
        baselines the model returns (:mod:`roverimpact.studies.indicators`) with suffixes
        ``_vn`` (v_n), ``_Tn_total`` (1/2 m_total v_n^2) and ``_Tc_obstacle`` (T_c^- with
        the obstacle row only).
    indicators : IndicatorComparison or None
        T_c^- and the baselines against the measured mean peak, on the same conditions,
        with bootstrap intervals and the statements of
        :func:`roverimpact.studies.indicators.statements`; None with fewer than 3
        conditions.
    """

    table: pd.DataFrame
    stats: dict
    indicators: object = None


def compare_with_model(trials_df: pd.DataFrame, model_fn: Callable[[float, float], dict]
                       ) -> ModelComparison:
    """Compare measured peak forces with a model's T_c^- and F_max, condition by condition.

    Parameters
    ----------
    trials_df : pandas.DataFrame
        Needs columns ``beta_deg``, ``speed`` and ``F_peak`` (e.g.
        :attr:`ExperimentResult.trials`). Repeats are averaged per (beta, speed).
    model_fn : callable
        ``model_fn(beta_rad, speed) -> {"T_c_minus": ..., "F_max": ...}`` (SI units), e.g.
        a :class:`ScenarioModel` (the rover scenario and simulator). Other keys of the
        dict become columns of the table.

    Returns
    -------
    ModelComparison
        Kendall tau and Spearman rho with p-values
        (:func:`roverimpact.studies.stats.rank_correlation`) over the conditions where the
        model value and the measured mean are finite (``n_conditions_Tc``,
        ``n_conditions_Fmax`` count them); NaN with fewer than 3 such conditions or a
        constant column.
    """
    from ..studies.stats import rank_correlation

    need = {"beta_deg", "speed", "F_peak"}
    if trials_df is None or trials_df.empty or not need <= set(trials_df.columns):
        raise InputError(f"trials_df must be non-empty with columns {sorted(need)}")
    table = (trials_df.groupby(["beta_deg", "speed"], sort=True)["F_peak"]
             .agg(n="size", F_peak_mean="mean", F_peak_std="std").reset_index())
    out = []
    for beta_deg, speed in zip(table["beta_deg"], table["speed"], strict=True):
        res = model_fn(math.radians(beta_deg), float(speed))
        try:
            out.append({"T_c_minus": float(res["T_c_minus"]), "F_max": float(res["F_max"])}
                       | {k: v for k, v in res.items() if k not in ("T_c_minus", "F_max")})
        except (KeyError, TypeError):
            raise InputError("model_fn must return a dict with keys 'T_c_minus' and 'F_max'"
                             ) from None
    model_cols = pd.DataFrame(out)
    table["T_c_minus"] = model_cols["T_c_minus"].to_numpy()
    table["F_max"] = model_cols["F_max"].to_numpy()
    table["F_ratio"] = table["F_peak_mean"] / table["F_max"]
    for col in model_cols.columns.drop(["T_c_minus", "F_max"]):
        table[col] = model_cols[col].to_numpy()
    stats: dict = {}
    for key, col in (("Tc", "T_c_minus"), ("Fmax", "F_max"), ("vn", "v_n"),
                     ("Tn_total", "T_n_total"), ("Tc_obstacle", "T_c_obstacle")):
        if col not in table:
            continue
        rc = rank_correlation(table["F_peak_mean"], table[col])
        stats |= {f"n_conditions_{key}": rc.n,
                  f"kendall_tau_{key}": rc.kendall_tau, f"kendall_p_{key}": rc.kendall_p,
                  f"spearman_rho_{key}": rc.spearman_rho, f"spearman_p_{key}": rc.spearman_p}
    stats = {"n_conditions": len(table)} | stats
    from ..studies.indicators import compare_indicators

    ind = compare_indicators(table, "F_peak_mean", force_label="the measured peak")
    return ModelComparison(table, stats, ind)




def scenario_model(cfg: ScenarioModelConfig, base_dir: str | Path = ".") -> ScenarioModel:
    """The :class:`ScenarioModel` of a trials file's ``[model]`` (``base_dir / scenario``,
    simulated unless ``simulate = false``)."""
    return ScenarioModel.from_file(Path(base_dir) / cfg.scenario, simulate=cfg.simulate)
