r"""Suspension reconfiguration: the setting that minimises the effective kinetic energy.

DETC2014-35554 proposes reconfiguring the suspension before a manoeuvre where impact is
expected. Given a rover with adjustable parameters (COM height ``h``, wheelbase, rocker
pivot height, ...) and an expected obstacle (a range of face angles beta and a speed u),
:func:`optimize_setting` solves

.. math::

    \min_{x \in [lo, hi]}\; J(x) = \max_{\beta \in B} T_c^-(x, \beta)
    \quad(\text{or } \operatorname{mean}_{\beta \in B})
    \qquad \text{s.t.}\quad s(x) \ge s_{min},\;\; c(x) \ge c_{min}

with

* :math:`T_c^-(x, \beta)` the effective kinetic energy of the scenario built with the
  parameters ``x`` (all betas of ``B`` in one stacked :func:`roverimpact.sweep_energy`
  call, i.e. one batched :func:`roverimpact.partition`);
* :math:`s(x)`, the **static stability margin** [m]: signed distance from the ground
  projection of the centre of mass to the boundary of the support polygon of the
  wheel-ground contact points (2-D rover: the interval ``[x_rear, x_front]`` of the
  contact points; 3-D: their convex hull in x-y), positive inside
  (:func:`roverimpact.models.geometry.stability_margin`);
* :math:`c(x)`, the **ground clearance** [m]: the height above the ground (z = 0) of the
  lowest of the chassis box corners (``chassis_length x chassis_width x chassis_height``
  of the model parameters, centred at the chassis COM) and of the origins of the non-wheel
  suspension joints (rocker and bogie pivots) (:func:`roverimpact.models.geometry.clearance`).

``scipy.optimize.minimize`` (SLSQP) runs from ``n_starts`` starts in the unit-scaled box:
the nominal setting (its nearest point in the bounds if it lies outside them) and
``n_starts - 1`` seeded Latin-hypercube points (one in each of ``n_starts - 1`` equal
slices of every variable's range); the best feasible end point wins, and the nominal
itself if it lies inside the bounds and is better. The result is then checked with the
compliant-contact simulator at the worst-case betas of the nominal and of the optimum
(:func:`roverimpact.simulate.simulate_impact`).

Optimisation file (TOML, every table validated, unknown keys rejected)::

    [scenario]                    # a scenario (same keys as a scenario file)
    model = { name = "rover2d" }
    velocity = { u = 0.3 }
    obstacle = { wheel = "front", beta_deg = 45 }
    [scenario.simulation]         # optional: SimulationConfig options for the check
    [optimize]
    variables = { h = [0.25, 0.45], wheelbase = [0.5, 0.8] }   # model parameters, SI
    objective = "worst"           # or "mean"
    beta_deg = [20, 90]           # expected obstacle angles [deg]
    n_beta = 8
    speed = 0.3                   # [m/s], overrides velocity.u
    stability_margin = 0.1        # [m]
    min_clearance = 0.05          # [m]
    n_starts = 6
    seed = 0
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import Field, field_validator, model_validator

from .._schema import StrictModel, validate
from ..exceptions import ConfigError, GroundGapWarning, RoverImpactError, SolverError
from ..models.geometry import clearance, stability_margin

__all__ = [
    "OptimizeProblem",
    "OptimizeResult",
    "OptimizeSpec",
    "SettingReport",
    "clearance",
    "load_optimization",
    "optimize_setting",
    "param_unit",
    "stability_margin",
]


def finite_bounds(variables: dict) -> dict:
    """``variables`` (name -> (lo, hi)) if every pair is finite with lo < hi (the check of
    ``[optimize]`` and of a traverse's ``[suspension]``)."""
    for name, (lo, hi) in variables.items():
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ValueError(f"variable {name!r}: bounds must be finite with lo < hi, got "
                             f"[{lo}, {hi}]")
    return variables


class OptimizeSpec(StrictModel):
    """The ``[optimize]`` table (SI units; angles in degrees)."""

    variables: dict[str, tuple[float, float]] = Field(min_length=1)
    objective: Literal["worst", "mean"] = "worst"
    beta_deg: tuple[float, float] = (20.0, 90.0)
    n_beta: int = Field(8, ge=1, le=1000)
    speed: float | None = Field(None, gt=0.0, allow_inf_nan=False)
    stability_margin: float = Field(0.05, allow_inf_nan=False)
    min_clearance: float = Field(0.0, allow_inf_nan=False)
    n_starts: int = Field(6, ge=1, le=1000)
    seed: int = Field(0, ge=0)
    maxiter: int = Field(100, ge=1)

    _bounds = field_validator("variables")(finite_bounds)

    @field_validator("beta_deg")
    @classmethod
    def _beta(cls, b):
        lo, hi = b
        if not (0.0 < lo <= hi <= 90.0):
            raise ValueError(f"beta_deg must be [lo, hi] with 0 < lo <= hi <= 90 degrees, got "
                             f"{list(b)}")
        return b

    @model_validator(mode="after")
    def _one_beta(self):
        lo, hi = self.beta_deg
        if self.n_beta == 1 and lo < hi:
            raise ValueError(f"n_beta = 1 evaluates beta = {lo:g} deg only, not the range "
                             f"beta_deg = [{lo:g}, {hi:g}]: give n_beta >= 2, or beta_deg = "
                             "[b, b] for one angle")
        return self


class OptimizeFile(StrictModel):
    scenario: dict[str, Any]
    optimize: OptimizeSpec

    @model_validator(mode="before")
    @classmethod
    def _moved(cls, data: Any):
        if isinstance(data, Mapping) and "simulation" in data:
            raise ValueError("[simulation] moved into the scenario: write [scenario.simulation]"
                             " for the simulator's options and [scenario.contact_law] for the "
                             "obstacle's law")
        return data

    @model_validator(mode="after")
    def _model(self):
        m = self.scenario.get("model")
        if not isinstance(m, Mapping) or m.get("name") not in ("rover2d", "rocker_bogie"):
            raise ValueError("scenario.model.name must be 'rover2d' or 'rocker_bogie' (the "
                             "built-in rovers have adjustable parameters)")
        return self


@dataclass
class OptimizeProblem:
    """A validated optimisation problem: base scenario, simulation options, spec."""

    scenario: dict
    spec: OptimizeSpec
    nominal: dict[str, float]

    @property
    def names(self) -> list[str]:
        return list(self.spec.variables)

    @property
    def betas_deg(self) -> np.ndarray:
        lo, hi = self.spec.beta_deg
        return np.linspace(lo, hi, self.spec.n_beta)


def load_optimization(source: str | Path | Mapping[str, Any]) -> OptimizeProblem:
    """Read and validate an optimisation file (path) or dict.

    Raises
    ------
    ConfigError
        Malformed TOML, unknown keys, bad bounds, a variable that is not a numeric
        parameter of the model, or a base scenario that does not build.
    """
    from dataclasses import fields

    from .._io import read_toml
    from ..models import RockerBogieParams, Rover2DParams
    from ..scenario import ImpactSetup, scenario_from_dict

    where = str(source) if isinstance(source, (str, Path)) else "optimisation"
    raw = read_toml(Path(source)) if isinstance(source, (str, Path)) else dict(source)
    f = validate(OptimizeFile, raw, where)
    lo, hi = f.optimize.beta_deg
    if isinstance(source, (str, Path)) and hi <= math.pi / 2:
        # a user's file: [0.35, 1.57] is 20-90 deg in radians (a traverse's segments, which
        # pass dicts, may meet such small angles)
        import warnings

        warnings.warn(f"{where}: optimize.beta_deg = {[lo, hi]} is in degrees: obstacle "
                      f"angles of at most {hi:g} deg. If you meant radians, write "
                      f"[{math.degrees(lo):.4g}, {math.degrees(hi):.4g}]", UserWarning,
                      stacklevel=2)
    scn = dict(f.scenario)
    if f.optimize.speed is not None:
        scn["velocity"] = {**dict(scn.get("velocity") or {}), "u": f.optimize.speed}
    name = scn["model"]["name"]
    cls = Rover2DParams if name == "rover2d" else RockerBogieParams
    numeric = sorted(x.name for x in fields(cls) if x.type in ("float", float))
    for var in f.optimize.variables:
        if var not in numeric:
            raise ConfigError(f"{where}: optimize.variables: {var!r} is not a numeric parameter "
                              f"of {name}; choose from {', '.join(numeric)}")
    try:
        with _ground_gaps_unsaid():
            setup = ImpactSetup.from_scenario(scenario_from_dict(scn,
                                                                 where=f"{where}: scenario"))
    except (ValueError, TypeError) as exc:
        raise ConfigError(f"{where}: scenario: {exc}") from None
    if setup.scenario.obstacle.wheel is None:
        raise ConfigError(f"{where}: scenario.obstacle must name a wheel")
    ts = setup.scenario.terrain
    if ts is not None and ts != type(ts)():
        # the limits are measured on the plane z = 0: on a slope only the lowest wheels
        # count as support (margin -inf for the rocker-bogie) and the clearance is taken
        # from z = 0, so every setting looked unstable or every limit meaningless
        raise ConfigError(f"{where}: scenario.terrain: optimize measures the stability "
                          "margin and the clearance on flat ground (the plane z = 0) and "
                          "does not take a terrain; remove [scenario.terrain], or sweep "
                          "the variables over the terrain scenario with a study")
    if not (setup.scenario.velocity.u or 0.0) > 0.0:  # the approach speed of the prediction
        raise ConfigError(f"{where}: give the driving speed, optimize.speed or "
                          "scenario.velocity.u > 0 [m/s]: the predicted peak force (and the "
                          "simulator's check) need it")
    nominal = {v: float(setup.model.params[v]) for v in f.optimize.variables}
    problem = OptimizeProblem(scenario=scn, spec=f.optimize, nominal=nominal)
    _check_bounds(problem, where)
    return problem


@contextlib.contextmanager
def _ground_gaps_unsaid():
    """A context in which a scenario's :class:`~roverimpact.exceptions.GroundGapWarning`
    is not shown: the checks of :func:`load_optimization` build the nominal setting and
    the corners of the bounds, and :func:`optimize_setting` says once what the settings it
    tries lift (each build's own warning made dozens of lines)."""
    import warnings

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=GroundGapWarning)
        yield


def param_unit(name: str) -> str:
    """SI unit of a numeric parameter of the built-in rovers: ``kg`` for masses, else
    ``m`` (lengths, heights, offsets)."""
    return "kg" if name.endswith("_mass") else "m"


def _check_bounds(problem: OptimizeProblem, where: str) -> None:
    """Build the rover at the corners of the bounds (each bound alone, the others nominal,
    beyond 6 variables), before any work: a bound the model refuses (a negative wheelbase)
    is a ConfigError naming the variable, not a failure in the middle of the search."""
    import itertools

    from ..scenario import ImpactSetup, scenario_from_dict

    bounds = problem.spec.variables
    names = list(bounds)
    if len(names) <= 6:
        settings = [dict(zip(names, c, strict=True))
                    for c in itertools.product(*(bounds[n] for n in names))]
    else:
        settings = [problem.nominal | {n: b} for n in names for b in bounds[n]]
    for values in settings:
        try:
            with _ground_gaps_unsaid():
                ImpactSetup.from_scenario(scenario_from_dict(_scenario_with(problem, values)))
        except (RoverImpactError, ValueError) as exc:
            raise ConfigError(f"{where}: optimize.variables: the rover does not build at the "
                              f"bounds {_setting_text(values)}: {exc}") from None


# -------------------------------------------------------------------------------------
# Evaluation of a setting
# -------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SettingReport:
    """A setting and its figures.

    Attributes
    ----------
    values : dict
        Parameter name -> value (SI).
    T_c : (n_beta,) ndarray
        T_c^- at each beta of the range [J].
    objective : float
        Worst (max) or mean T_c^- [J].
    beta_worst_deg : float
        Beta of the largest T_c^- [deg].
    margin, clearance : float
        Static stability margin and ground clearance [m].
    F_pred : float
        Peak force predicted from the worst T_c^- by the obstacle contact law [N].
    ground_gap : str
        The scenario's :class:`~roverimpact.exceptions.GroundGapWarning` at this setting
        (a ground wheel off z = 0 in ``[configuration]``: the stability margin counts only
        the wheels on the ground), or ``""``.
    ground_gaps : dict
        Its wheels: name -> height above z = 0 [m] (< 0: below).
    """

    values: dict
    T_c: np.ndarray
    v_n: np.ndarray
    objective: float
    beta_worst_deg: float
    margin: float
    clearance: float
    F_pred: float
    ground_gap: str = ""
    ground_gaps: dict = field(default_factory=dict)


def _scenario_with(problem: OptimizeProblem, values: Mapping[str, float]) -> dict:
    scn = dict(problem.scenario)
    model = dict(scn["model"])
    model["params"] = {**dict(model.get("params") or {}), **{k: float(v) for k, v in
                                                            values.items()}}
    scn["model"] = model
    return scn


def _law(problem: OptimizeProblem):
    """Obstacle contact law of the simulator check (used for the predicted peak force)."""
    return _sim_config(problem, 90.0).obstacle.to_law()


def _sim_config(problem: OptimizeProblem, beta_deg: float):
    from ..scenario import scenario_from_dict
    from ..simulate import SimulationConfig

    sc = scenario_from_dict(problem.scenario).with_beta(float(beta_deg))
    return SimulationConfig.from_scenario(sc)


def _setting_text(values: Mapping[str, float]) -> str:
    return "{" + ", ".join(f"{k} = {float(v):.6g}" for k, v in values.items()) + "}"


def evaluate_setting(problem: OptimizeProblem, values: Mapping[str, float],
                     law=None, *, warn_gaps: bool = True) -> SettingReport:
    """T_c^- over the beta range, objective, margin, clearance and F_pred of a setting.

    The scenario's warnings are shown; with ``warn_gaps=False`` not its
    :class:`~roverimpact.exceptions.GroundGapWarning`, which the report keeps
    (``ground_gap``, ``ground_gaps``) for :func:`optimize_setting` to say once for all the
    settings it tries."""
    import warnings

    from ..contact import peak_force
    from ..scenario import ImpactSetup, scenario_from_dict, sweep_energy

    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            setup = ImpactSetup.from_scenario(scenario_from_dict(_scenario_with(problem,
                                                                               values)))
    except (RoverImpactError, ValueError) as exc:
        raise ConfigError(f"setting {_setting_text(values)} does not build: {exc}") from None
    gapped = [w for w in caught if issubclass(w.category, GroundGapWarning)]
    for w in caught:  # shown as before; a ground gap is kept for optimize_setting
        if warn_gaps or w not in gapped:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    gaps = [str(w.message) for w in gapped]
    betas = problem.betas_deg
    en = sweep_energy(setup, np.deg2rad(betas))
    T = np.asarray(en.T_c_minus, float)
    i = int(np.argmax(T))
    obj = float(T.max() if problem.spec.objective == "worst" else T.mean())
    law = law or _law(problem)
    v_n = np.asarray(en.v_n, float)
    F = float(peak_force(T[i], v_n[i], law)) if T[i] > 0 and v_n[i] > 0 else 0.0
    return SettingReport(values={k: float(v) for k, v in values.items()}, T_c=T, v_n=v_n,
                         objective=obj, beta_worst_deg=float(betas[i]),
                         margin=stability_margin(setup.model, setup.q),
                         clearance=clearance(setup.model, setup.q), F_pred=F,
                         ground_gap=gaps[0] if gaps else "",
                         ground_gaps=dict(getattr(gapped[0].message, "gaps", {}))
                         if gapped else {})


def _warn_ground_gaps_once(tried: list[SettingReport]) -> None:
    """One :class:`~roverimpact.exceptions.GroundGapWarning` for the settings ``tried``
    that lift (or sink) a ground wheel: how many, which wheels at how many settings, and
    each wheel's largest gap (each setting's own warning, repeated, said the same dozens of
    times with other digits)."""
    import warnings

    from ..scenario.build import GROUND_GAP_ADVICE, gap_text

    gapped = [r for r in tried if r.ground_gaps]
    if not gapped:
        return
    count: dict[str, int] = {}
    worst: dict[str, float] = {}
    for r in gapped:
        for name, g in r.ground_gaps.items():
            count[name] = count.get(name, 0) + 1
            if abs(g) > abs(worst.get(name, 0.0)):
                worst[name] = g
    wheels = ", ".join(f"{name!r} at {count[name]} of them (largest {gap_text(worst[name])})"
                       for name in count)
    warnings.warn(GroundGapWarning(
        f"ground wheels off the ground z = 0 in [configuration] at {len(gapped)} of the "
        f"{len(tried)} settings tried: {wheels}; {GROUND_GAP_ADVICE}", gaps=worst),
        stacklevel=3)


@dataclass
class OptimizeResult:
    """Outcome of :func:`optimize_setting`.

    Attributes
    ----------
    nominal, best : SettingReport
    betas_deg : (n_beta,) ndarray
    reduction : float
        Relative reduction of the objective, ``1 - J(best) / J(nominal)``.
    F_sim_nominal, F_sim_best : float
        Worst simulated peak obstacle force [N] over the worst-case betas of the nominal
        and of the optimum (NaN if not simulated).
    sim_betas_deg : list of float
        Betas simulated.
    starts : list of dict
        Per start: start point, end point, objective, feasible, success.
    nominal_in_bounds : bool
        Whether the nominal setting lies inside the bounds of ``[optimize] variables``.
        If not, it is not a candidate: ``best`` is the best setting inside the bounds and
        ``reduction`` may be negative.
    """

    problem: OptimizeProblem
    nominal: SettingReport
    best: SettingReport
    betas_deg: np.ndarray
    reduction: float
    F_sim_nominal: float = math.nan
    F_sim_best: float = math.nan
    sim_betas_deg: list = field(default_factory=list)
    starts: list = field(default_factory=list)
    nominal_in_bounds: bool = True

    def at_bound(self, rtol: float = 1e-6) -> dict[str, str]:
        """Variable name -> ``"lower bound"`` or ``"upper bound"`` for each variable of the
        optimum that lies on a bound (within ``rtol`` of the bounds' width): a bound that
        stops the search, which a wider range could move."""
        out = {}
        for name, (lo, hi) in self.problem.spec.variables.items():
            x, tol = self.best.values[name], rtol * (hi - lo)
            if x >= hi - tol:
                out[name] = "upper bound"
            elif x <= lo + tol:
                out[name] = "lower bound"
        return out

    def active_constraints(self, atol: float = 1e-6) -> list[str]:
        """The constraints the optimum meets with equality (``"stability margin"``,
        ``"clearance"``, within ``atol`` [m])."""
        spec = self.problem.spec
        return [name for name, x, limit in (
            ("stability margin", self.best.margin, spec.stability_margin),
            ("clearance", self.best.clearance, spec.min_clearance)) if x <= limit + atol]

    def nominal_violations(self, atol: float = 1e-6) -> list[str]:
        """The constraints the nominal setting violates, as text (empty if feasible): the
        reduction is then measured from a setting the limits refuse."""
        spec, n = self.problem.spec, self.nominal
        return [f"{name} {x:.4g} m < {limit:g} m" for name, x, limit in (
            ("stability margin", n.margin, spec.stability_margin),
            ("clearance", n.clearance, spec.min_clearance)) if x < limit - atol]


def _feasible(r: SettingReport, spec: OptimizeSpec, tol: float = 1e-6) -> bool:
    return r.margin >= spec.stability_margin - tol and r.clearance >= spec.min_clearance - tol


def optimize_setting(problem: OptimizeProblem | str | Path | Mapping[str, Any], *,
                     simulate: bool = True, progress=None) -> OptimizeResult:
    """Find the setting of minimum worst-case (or mean) T_c^- under the constraints.

    Parameters
    ----------
    problem : OptimizeProblem, path or dict
        See the module docstring for the file layout.
    simulate : bool
        Confirm with the compliant-contact simulator (nominal and optimum, at the
        worst-case betas of both).
    progress : callable, optional
        ``progress(done, total)`` after each start and each simulation.

    Returns
    -------
    OptimizeResult

    Raises
    ------
    ConfigError
        Bad file (see :func:`load_optimization`).
    SolverError
        No start reached a setting that satisfies the constraints.
    """
    from scipy.optimize import minimize

    if not isinstance(problem, OptimizeProblem):
        problem = load_optimization(problem)
    spec = problem.spec
    names = problem.names
    lo = np.array([spec.variables[n][0] for n in names])
    hi = np.array([spec.variables[n][1] for n in names])
    law = _law(problem)
    cache: dict[tuple, SettingReport] = {}

    def report(u: np.ndarray) -> SettingReport:
        u = np.clip(u, 0.0, 1.0)
        key = tuple(np.round(u, 12))
        if key not in cache:
            cache[key] = evaluate_setting(problem, dict(zip(names, lo + u * (hi - lo),
                                                            strict=True)), law,
                                          warn_gaps=False)
        return cache[key]

    nominal = evaluate_setting(problem, problem.nominal, law, warn_gaps=False)
    scale = max(nominal.objective, 1e-12)
    cons = [{"type": "ineq", "fun": lambda u: report(u).margin - spec.stability_margin},
            {"type": "ineq", "fun": lambda u: report(u).clearance - spec.min_clearance}]
    u_raw = (np.array([problem.nominal[n] for n in names]) - lo) / (hi - lo)
    # the nominal setting is a candidate only inside the bounds (else the search's first
    # start is its nearest point in them): one outside was reported as the optimum
    inside = bool(np.all((u_raw >= -1e-12) & (u_raw <= 1.0 + 1e-12)))
    u_nom = np.clip(u_raw, 0, 1)
    starts = [u_nom, *_spread_starts(len(names), spec.n_starts - 1, spec.seed)]
    n_sims = 2 * min(2, spec.n_beta) if simulate else 0  # at most; fixed below
    best, log = None, []
    for k, u0 in enumerate(starts):
        res = minimize(lambda u: report(u).objective / scale, u0, method="SLSQP",
                       bounds=[(0.0, 1.0)] * len(names), constraints=cons,
                       options={"maxiter": spec.maxiter, "ftol": 1e-9})
        r = report(res.x)
        ok = _feasible(r, spec)
        log.append({"start": dict(zip(names, (lo + u0 * (hi - lo)).tolist(), strict=True)),
                    "end": r.values, "objective": r.objective, "feasible": ok,
                    "success": bool(res.success)})
        if ok and (best is None or r.objective < best.objective):
            best = r
        if progress is not None:
            progress(k + 1, len(starts) + n_sims)
    if inside and _feasible(nominal, spec) and (best is None
                                                or nominal.objective < best.objective):
        best = nominal
    tried = [nominal, *cache.values()]
    _warn_ground_gaps_once(tried)
    if best is None:
        gapped = [r for r in tried if r.ground_gap]
        limits = (f"stability margin >= {spec.stability_margin} m and clearance >= "
                  f"{spec.min_clearance} m")
        if len(gapped) == len(tried):
            gap = nominal.ground_gap.split(";")[0].replace(
                "ground wheels off the ground z = 0 in [configuration]: ", "")
            raise SolverError(
                f"no setting satisfies {limits}: at every setting tried ({len(tried)}) the "
                f"scenario's [configuration] lifts a ground wheel off the ground z = 0 "
                f"(nominal: {gap}), and the stability margin counts only the wheels on the "
                f"ground: the preset, not the bounds or limits, is the cause. Set "
                f"[scenario.configuration] (its joint values, base z and pitch) so that the "
                f"wheels touch, or leave it out")
        note = (f" ({len(gapped)} of the {len(tried)} settings tried had a ground wheel off "
                f"the ground in [configuration]: see the warning)" if gapped else "")
        raise SolverError(
            f"no setting within the bounds satisfies {limits} from {spec.n_starts} "
            f"starts{note}: widen the bounds or relax the constraints")
    out = OptimizeResult(problem=problem, nominal=nominal, best=best,
                         betas_deg=problem.betas_deg,
                         reduction=1.0 - best.objective / scale, starts=log,
                         nominal_in_bounds=inside)
    if simulate:
        out.sim_betas_deg = sorted({nominal.beta_worst_deg, best.beta_worst_deg})
        total = len(starts) + 2 * len(out.sim_betas_deg)
        done = len(starts)

        def step():
            nonlocal done
            done += 1
            if progress is not None:
                progress(done, total)

        out.F_sim_nominal = _simulated_peak(problem, problem.nominal, out.sim_betas_deg, step)
        out.F_sim_best = _simulated_peak(problem, best.values, out.sim_betas_deg, step)
    return out


def _spread_starts(d: int, n: int, seed: int) -> np.ndarray:
    """``n`` seeded start points in the unit box [0, 1]^d, a Latin hypercube: each
    variable's range cut into ``n`` equal slices with one start in each, so that a few
    starts cover the whole range of every variable (independent uniform draws left whole
    regions unvisited: 2 draws of 3 fell below a 1-D hump and all starts ended in the
    local minimum on its low side)."""
    from scipy.stats import qmc

    if n <= 0:
        return np.empty((0, d))
    # seed=, not rng= (scipy >= 1.15): the project supports scipy 1.13
    return qmc.LatinHypercube(d=d, seed=np.random.default_rng(seed)).random(n)


def _simulated_peak(problem: OptimizeProblem, values, betas_deg, step=None) -> float:
    """Largest simulated F_max [N] of a setting over ``betas_deg`` (``step()`` after each
    simulation)."""
    from ..scenario import ImpactSetup, scenario_from_dict
    from ..simulate import simulate_impact

    setup = ImpactSetup.from_scenario(scenario_from_dict(_scenario_with(problem, values)))
    peaks = []
    for b in betas_deg:
        peaks.append(simulate_impact(setup.model, _sim_config(problem, b)).F_max_total)
        if step is not None:
            step()
    return float(max(peaks))
