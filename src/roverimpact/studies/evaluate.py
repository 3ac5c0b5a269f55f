r"""Evaluators: what a study computes for one case.

All the wiring from studies to the model, contact-law and simulator layers lives in this
module. An *evaluator* has

- ``name`` (written into the results manifest),
- ``validate(scenario: dict) -> dict``: the normalized scenario (defaults filled in);
  raises :class:`~roverimpact.exceptions.ConfigError`,
- ``evaluate(base, overrides, *, simulate) -> dict[str, array]``: one output column per
  quantity, one entry per override dict (a case is ``apply_overrides(base, ov)``).

A case is a scenario (:class:`roverimpact.scenario.Scenario`, with its optional
``[simulation]`` table). :func:`evaluate_case` (one scenario dict -> dict of outputs) is the
single entry point into the scenario / contact / simulate layers;
:class:`ScenarioEvaluator` batches it. Any plain function ``scenario_dict -> dict``
becomes an evaluator with :class:`FunctionEvaluator`.

Output columns (SI): ``T_c_minus`` [J], ``m_eff`` [kg], ``v_n`` [m/s] (approach
speed along the normal), ``F_pred`` [N] (peak force predicted by the contact law from
T_c^-), the baselines' inputs ``m_total`` [kg] (mass of the whole model) and
``m_eff_free`` [kg] (effective mass of the obstacle row alone, 1 / (a M^-1 a^T)) and the
baselines ``T_n_total`` = 1/2 m_total v_n^2 [J] and ``T_c_obstacle`` = 1/2 m_eff_free
v_n^2 [J] (T_c^- with the obstacle row only; see :mod:`roverimpact.studies.indicators`),
and with ``simulate``: ``F_max`` [N], ``contact_duration`` [s], ``T_c_minus_sim`` [J],
``contact_whole_window`` (bool: the contact had not ended when the simulation stopped,
``t_after`` after first contact; then ``F_max`` is the largest force within the window,
not the peak of a finished impact, and ``contact_duration`` equals ``t_after``; False also
where the simulation failed) and ``sim_error``.

With ``simulate`` (or a ``[band]`` in the scenario) also the refined prediction of
:mod:`roverimpact.simulate.newtons` (the obstacle contact with every wheel's compliant,
preloaded ground contact and the weight; no integration of the multibody system):
``F_pred_refined`` [N] (its peak force), ``contact_duration_pred`` [s] and
``F_pred_refined_mujoco`` [N] when MuJoCo is among the engines (the same model with the
spring-dampers the MuJoCo engine puts in place of a nonlinear law:
:meth:`~roverimpact.simulate.newtons.ReducedSystem.impact_mujoco`), ``not_an_impact``
(bool: no approach (v_n <= 0), or the predicted contact lasts the
whole window ``simulation.t_after``, or a simulated engine's did
(``contact_whole_window``): the case is a resting contact, not an impact; F_max and the
ratio F_pred_refined / F_max mean nothing there and the statistics leave it out), and
with a ``[band]`` the band ``F_lo``, ``F_hi`` [N] of ``F_pred_refined`` over its k and e
ranges (:func:`roverimpact.scenario.schema.band_laws`, the nominal law included).

``simulate`` names the engines (:meth:`roverimpact.studies.config.Study.engines`; ``True``
is ``("own",)``): the first engine's columns are the plain names above, each further
engine's carry its name as a suffix (``F_max_mujoco``, ``contact_whole_window_mujoco``,
``sim_error_mujoco``, ...).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from contextlib import nullcontext
from typing import Any, NamedTuple

import numpy as np

from .._engines import engines_of
from ..contact import peak_force
from ..exceptions import InputError, RoverImpactError
from ..scenario import ImpactSetup, Scenario, scenario_from_dict, sweep_energy
from ..scenario.block import (
    STATE_NUMBERS,
    STATE_PREFIXES,
    block_key,
    is_number,
    member_block,
    state_block,
    state_key,
)
from ..scenario.build import (
    jam_total_mass,
    model_key,
    pulling_applies,
    scenario_model,
    total_mass,
    warn_if_pulling,
    warn_jammed,
)
from .config import apply_overrides

__all__ = [
    "INDICATOR_COLUMNS",
    "REFINED_COLUMNS",
    "SIMULATION_COLUMNS",
    "FunctionEvaluator",
    "ScenarioEvaluator",
    "engine_suffix",
    "engines_of",
    "evaluate_case",
    "get_evaluator",
]

#: Output columns every study produces (simulate adds ``F_max``, ``contact_duration`` and
#: ``contact_whole_window``).
INDICATOR_COLUMNS = ("T_c_minus", "m_eff", "v_n", "F_pred", "m_total", "m_eff_free",
                     "T_n_total", "T_c_obstacle")
SIMULATION_COLUMNS = ("F_max", "contact_duration", "contact_whole_window")
#: Columns of the refined prediction (with ``simulate`` or a ``[band]``; the band adds
#: ``F_lo`` and ``F_hi``).
REFINED_COLUMNS = ("F_pred_refined", "contact_duration_pred", "not_an_impact")


def engine_suffix(index: int, engine: str) -> str:
    """Column suffix of the ``index``-th engine of a study: ``""`` for the first (the
    reference: ``F_max``), ``"_<engine>"`` for the others (``F_max_mujoco``)."""
    return "" if index == 0 else f"_{engine}"


def _baselines(v_n, m_total, m_eff_free) -> dict[str, np.ndarray]:
    """The baseline indicators: 1/2 m_total v_n^2 and T_c^- of the obstacle row alone
    (1/2 m_eff_free v_n^2: for one row, T_c = (a v)^2 / (2 a M^-1 a^T)) [J]; 0 where
    there is no approach (v_n <= 0), as T_c^-."""
    v = np.maximum(np.asarray(v_n, float), 0.0)
    return {"T_n_total": 0.5 * np.asarray(m_total, float) * v * v,
            "T_c_obstacle": 0.5 * np.asarray(m_eff_free, float) * v * v}


def _law_of(sc: Scenario):
    """Contact law of the scenario's ``[contact_law]`` (None if absent)."""
    return None if sc.contact_law is None else sc.contact_law.to_law()


def _peak_force(T_c_minus, v_n, law) -> np.ndarray:
    """Predicted peak force [N] (NaN without a law, 0 where there is no approach)."""
    T = np.atleast_1d(np.asarray(T_c_minus, float))
    v = np.broadcast_to(np.atleast_1d(np.asarray(v_n, float)), T.shape)
    out = np.full(T.shape, np.nan)
    if law is None:
        return out
    hit = (T > 0) & (v > 0) & np.isfinite(T)
    out[~hit] = 0.0
    if hit.any():
        out[hit] = np.asarray(peak_force(T[hit], v[hit], law), float)
    return out


def _obstacle_law(spec, m_eff, k=None, e=None):
    """The obstacle law of ``spec`` (optionally another k / e); laws whose damping needs a
    mass (Kelvin-Voigt from e) get ``m_eff``."""
    from ..contact import get_law, law_class

    m = float(m_eff) if law_class(spec.name).needs_mass and spec.c is None else None
    return get_law(spec.name, k=spec.k if k is None else k, e=spec.e if e is None else e,
                   n=spec.n, c=spec.c, m_eff=m)


def _refined(sc: Scenario, setup, m_eff: float, engines: Sequence[str] = ()
             ) -> dict[str, Any]:
    """F_pred_refined, contact_duration_pred, not_an_impact (and F_lo, F_hi with a band)
    of one case (:mod:`roverimpact.simulate.newtons`); NaN where the model does not apply
    (no contact law, a terrain, ...)."""
    from ..simulate.newtons import reduced_system

    out: dict[str, Any] = {"F_pred_refined": np.nan, "contact_duration_pred": np.nan,
                           "not_an_impact": False}
    band = sc.band
    if band is not None:
        out["F_lo"] = out["F_hi"] = np.nan
    if sc.contact_law is None:
        return out
    try:
        rs = reduced_system(sc, setup)
        if rs is None:
            return out
        if not (rs.v_n > 0.0):
            out.update(F_pred_refined=0.0, contact_duration_pred=0.0, not_an_impact=True)
            if band is not None:
                out["F_lo"] = out["F_hi"] = 0.0
            return out
        spec = sc.contact_law
        r = rs.impact(_obstacle_law(spec, m_eff))
    except RoverImpactError:
        return out
    out.update(F_pred_refined=r.peak_force, contact_duration_pred=r.duration,
               not_an_impact=not r.ended)
    if "mujoco" in engines:
        try:
            rm = rs.impact_mujoco(_obstacle_law(spec, m_eff), m_eff)
        except RoverImpactError:
            rm = None
        out["F_pred_refined_mujoco"] = np.nan if rm is None else rm.peak_force
    if band is not None:
        from ..scenario.schema import band_laws

        Fs = [r.peak_force] + [rs.impact(_obstacle_law(spec, m_eff, kk, ee)).peak_force
                               for kk, ee in band_laws(spec, band.k, band.e, band.n)]
        out["F_lo"], out["F_hi"] = float(min(Fs)), float(max(Fs))
    return out


def _not_an_impact(out: dict[str, Any]) -> dict[str, Any]:
    """Fold every engine's ``contact_whole_window*`` into ``not_an_impact``."""
    if "not_an_impact" in out:
        ww = [bool(v) for k, v in out.items() if k.startswith("contact_whole_window")]
        out["not_an_impact"] = bool(out["not_an_impact"]) or any(ww)
    return out


def _simulate_one(sc: Scenario, model, engine: str = "own", suffix: str = ""
                  ) -> dict[str, Any]:
    """F_max (summed obstacle normal force, the papers' f_n) and duration of one engine;
    NaN on failure. Column names end in ``suffix``."""
    from ..simulate import simulate_scenario  # here: a study that only ranks needs none

    try:
        res = simulate_scenario(sc, model=model, engine=engine)
    except RoverImpactError as exc:
        out = {"F_max": np.nan, "contact_duration": np.nan, "T_c_minus_sim": np.nan,
               "contact_whole_window": False, "sim_error": f"{type(exc).__name__}: {exc}"}
    else:
        out = {"F_max": float(res.F_max_total),
               "contact_duration": float(res.contact_duration),
               "T_c_minus_sim": float(res.T_c_minus),
               "contact_whole_window": not bool(res.separated), "sim_error": ""}
    return {k + suffix: v for k, v in out.items()}


def _settle_once(engines: Sequence[str]):
    """:func:`roverimpact.simulate.reuse_settled_states` when ``engines`` simulate, else
    nothing: only the studies that simulate import the simulators (``python -X importtime``
    shows what the others save)."""
    if not engines:
        return nullcontext()
    from ..simulate import reuse_settled_states

    return reuse_settled_states()


def _simulate_all(sc: Scenario, model, engines: Sequence[str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for i, engine in enumerate(engines):
        out.update(_simulate_one(sc, model, engine, engine_suffix(i, engine)))
    return out


def evaluate_case(scenario: Mapping[str, Any], *, simulate=False) -> dict[str, Any]:
    """Evaluate one study scenario: indicator, predicted and (optionally) simulated force.

    Parameters
    ----------
    scenario : dict
        A scenario as in a scenario file (nested dicts), with an optional ``simulation``
        table of simulator options.
    simulate : bool, str or sequence of str
        Also run the compliant-contact simulation: ``True`` (the own engine), an engine
        name (``"own"``, ``"mujoco"``) or several (the first without, the others with a
        suffix, :func:`engine_suffix`).

    Returns
    -------
    dict
        ``T_c_minus`` [J], ``m_eff`` [kg], ``v_n`` [m/s], ``F_pred`` [N], ``m_total``
        [kg], ``m_eff_free`` [kg], ``T_n_total`` [J], ``T_c_obstacle`` [J] and, with
        ``simulate``, ``F_max`` [N], ``contact_duration`` [s], ``T_c_minus_sim`` [J]
        (the simulator's own T_c^- at first contact), ``contact_whole_window`` (the
        contact lasted the whole simulated window) and ``sim_error`` ("" if none); with
        ``simulate`` or a ``[band]`` also :data:`REFINED_COLUMNS` (and ``F_lo``,
        ``F_hi``, ``F_pred_refined_mujoco``; module docstring).
    """
    engines = engines_of(simulate)
    sc = scenario_from_dict(dict(scenario))
    setup = ImpactSetup.from_scenario(sc)
    en = setup.partition()
    m_total = total_mass(setup.model)
    out: dict[str, Any] = {
        "T_c_minus": float(en.T_c_minus),
        "m_eff": float(en.m_eff),
        "v_n": float(en.v_n),
        "F_pred": float(_peak_force(en.T_c_minus, en.v_n, _law_of(sc))[0]),
        "m_total": m_total,
        "m_eff_free": float(en.m_eff_free),
    }
    out.update({k: float(v) for k, v in _baselines(en.v_n, m_total, en.m_eff_free).items()})
    if engines or sc.band is not None:
        out.update(_refined(sc, setup, float(en.m_eff), engines))
    out.update(_simulate_all(sc, setup.model, engines))
    return _not_an_impact(out)


_BETA = "obstacle.beta_deg"


class ScenarioEvaluator:
    """Evaluator of the built-in rovers (and robot files) through the scenario layer.

    Batched: cases that differ only in the impact angle ``obstacle.beta_deg`` and the
    contact law share one ``ImpactSetup.from_scenario`` (Pinocchio evaluates ``M``, ``A``, ``v``
    once) and get T_c^- for all their angles from one stacked
    :func:`roverimpact.scenario.sweep_energy` call; the predicted peak force is one
    vectorized ``peak_force`` call per law. Cases that each change a built-in rover's
    numbers (parameters, speed, angle: a model-changing design) are computed in blocks of
    their model family (:func:`roverimpact.scenario.block.member_block`): the first case
    of each family is validated, the others are made from their numbers. Simulations run
    one per case.
    """

    name = "scenario"

    def validate(self, scenario: Mapping[str, Any]) -> dict:
        """Schema check (cheap): the normalized scenario, ConfigError if invalid."""
        sc = scenario_from_dict(dict(scenario))
        return sc.model_dump(mode="json", exclude_none=True)

    def cheap(self, base: Mapping[str, Any], params: Sequence[str]) -> bool:
        """Whether the indicator-only cases of a study of ``base`` sweeping ``params``
        cost tens of microseconds each: they share one model and differ in the angle,
        the contact law or the simulation settings (an angle sweep); or ``base`` has a
        state block (:func:`~roverimpact.scenario.block.state_key`: any model without
        terrain or declared loops) and they differ in joint values, joint rates and the
        speed too; or ``base`` is a built-in model with a model family (the rovers, the
        rigid body: :func:`~roverimpact.scenario.block.block_key`) and they differ in its
        numbers (``model.params``, ``velocity.u``) too. Cases built one by one (terrains,
        declared loops, a robot file's own numbers) cost milliseconds."""
        rest = ("contact_law.", "simulation.")
        if all(p == _BETA or p.startswith(rest) for p in params):
            return True
        states = all(p in STATE_NUMBERS or p.startswith((*STATE_PREFIXES, *rest))
                     for p in params)
        family = all(p in _FAMILY_NUMBERS or p.startswith(("model.params.", *rest))
                     for p in params)
        if not (states or family):
            return False
        try:
            sc = scenario_from_dict(dict(base))
        except InputError:  # (a base the checks refuse: they say why)
            return False
        return (state_key(sc) if states else block_key(sc)) is not None

    def check(self, scenario: Mapping[str, Any], *, simulate=False,
              models: dict[str, Any] | None = None) -> None:
        """Deep check (builds the model): unknown model parameters, bad geometry, law,
        and with ``simulate`` a scenario the simulator cannot run, or a model an engine
        cannot take (:func:`roverimpact.simulate.engines.check_engine`).

        ``models``: a dict that the checks of one study share (:func:`prepare_study`
        passes one): a model built by an earlier check with the same
        :func:`~roverimpact.scenario.build.model_key` is reused, so that the checks of a
        study of joint values, speeds or angles of a robot file load it once."""
        engines = engines_of(simulate)
        sc = scenario_from_dict(dict(scenario))
        setup = ImpactSetup.from_scenario(sc) if models is None else self._setup(sc, models)
        _law_of(sc)
        if engines:
            from ..simulate import SimulationConfig
            from ..simulate.engines import check_engine

            cfg = SimulationConfig.from_scenario(sc)
            for engine in engines:
                check_engine(engine, setup.model, cfg, terrain=sc.terrain is not None)

    def _one_by_one(self, base, overrides, indices, models, errors, m_total, own) -> None:
        """The cases ``indices`` each with its own setup (on the models built in this
        call, ``models``), into ``own`` and ``m_total``: a case that cannot be posed gets
        its own error, recorded in ``errors`` (or raised if that is None)."""
        for i in indices:
            try:
                setup = self._setup(scenario_from_dict(apply_overrides(base, overrides[i])),
                                    models)
            except InputError as exc:
                if errors is None:
                    raise
                errors[i] = f"{type(exc).__name__}: {exc}"
                continue
            m_total[i] = total_mass(setup.model)
            own.add(i, setup)

    @staticmethod
    def _state_block(first: Scenario, part: Sequence[_State], models: dict[str, Any]):
        """:func:`~roverimpact.scenario.block.state_block` of the cases ``part`` of
        ``first``'s state block, on the model built in this call; None if it raises (a
        case that cannot be posed: then each is computed on its own, which raises its own
        error)."""
        try:
            model = _model_of(first, models)
            names = part[0].joints.keys()
            joints = {nm: np.array([m.joints[nm] for m in part]) for nm in names}
            rates = {nm: np.array([m.rates[nm] for m in part]) for nm in part[0].rates}
            beta = (None if first.obstacle.beta_deg is None
                    else np.array([m.beta_deg for m in part]))
            return state_block(first, joints, rates, [m.u for m in part], beta, model=model)
        except RoverImpactError:
            return None

    @staticmethod
    def _setup(sc: Scenario, models: dict[str, Any]) -> ImpactSetup:
        """The setup of one scenario, reusing a model built in this call (``models``, by
        :func:`~roverimpact.scenario.build.model_key`)."""
        return ImpactSetup.from_scenario(sc, model=_model_of(sc, models))

    def evaluate(self, base, overrides, *, simulate=False,
                 errors: list[str] | None = None) -> dict[str, np.ndarray]:
        """The outputs of the cases ``overrides`` of ``base`` (arrays over the cases).

        ``errors``: None (a case that cannot be posed raises its error), or a list of one
        string per case: a case of its own (one that changes the model: the usual case
        that cannot be posed) that cannot be posed gets its error there (``"ModelError:
        ..."``) and missing outputs (NaN; False and "" for flags and texts), and the other
        cases are computed. In a block of a model family, the members whose numbers the
        family refuses are found by halving the block over
        :func:`~roverimpact.models.family.family_numbers` (no model is built), the others
        stay one block; a state block (cases that differ in joint values, joint rates,
        speed and angle of one model: :func:`~roverimpact.scenario.block.state_block`)
        with a case that cannot be posed is computed case by case on its model. A case of
        a group sharing one model still raises.
        """
        engines = engines_of(simulate)
        n = len(overrides)
        T = np.full(n, np.nan)
        m_eff = np.full(n, np.nan)
        m_eff_free = np.full(n, np.nan)
        m_total = np.full(n, np.nan)
        v_n = np.full(n, np.nan)
        F_pred = np.full(n, np.nan)
        sims: list[dict] = [{} for _ in range(n)]
        refined: list[dict] = [{} for _ in range(n)]
        groups: dict[str, list[int]] = {}
        laws: dict[str, list[int]] = {}
        keys = _CaseKeys()
        for i, ov in enumerate(overrides):
            gkey, lkey = keys(ov)
            groups.setdefault(gkey, []).append(i)
            laws.setdefault(lkey, []).append(i)
        own = _OwnCases(T, m_eff, m_eff_free, v_n)
        models: dict[str, Any] = {}  # built models of this call, by what builds them
        pending: list[tuple[list[int], ImpactSetup]] = []  # refined / simulated cases
        # cases of one model family: their numbers (_Member), by block_key; the first
        # case of each (validated) by block_key and by _family_key
        blocks: dict[str, list[_Member]] = {}
        firsts: dict[str, Scenario] = {}
        family: dict[str, tuple[str | None, Scenario]] = {}
        # cases of one model that differ in numbers of joint values and rates, speed and
        # angle (a configuration sweep of a robot file): their first case (validated; None
        # where it has no state block) and their numbers, by _state_group
        states: dict[str, Scenario | None] = {}
        state_members: dict[str, list[_State]] = {}
        for idx in groups.values():
            try:
                ov = overrides[idx[0]]
                fkey = skey = None
                if len(idx) == 1 and not engines:
                    # a case of its own (a model-changing design): computed with the other
                    # cases of its model family, in blocks; after the first, from its numbers
                    # (no scenario of its own, unless they need the full validation). Cases
                    # that set joint values or rates: with the other cases of their model
                    # in a state block (one model), likewise
                    if not _sets_joints(ov):
                        fkey = _family_key(ov)
                        bkey, first = family.get(fkey, (None, None))
                        if bkey is not None:
                            member = _member(idx[0], first, ov)
                            if member is not None:
                                blocks[bkey].append(member)
                                continue
                    skey = _state_group(ov)
                    first = states.get(skey)
                    if first is not None:
                        state = _state(idx[0], first, ov)
                        if state is not None:
                            state_members[skey].append(state)
                            continue
                sc = scenario_from_dict(apply_overrides(base, ov))
                if skey is not None and sc.band is None:
                    if fkey is not None:
                        if fkey not in family:
                            family[fkey] = (block_key(sc), sc)
                        bkey = family[fkey][0]
                        if bkey is not None:
                            firsts.setdefault(bkey, sc)
                            blocks.setdefault(bkey, []).append(_member_of(idx[0], sc))
                            continue
                    if skey not in states:
                        states[skey] = sc if state_key(sc) is not None else None
                    state = _state(idx[0], sc, ov) if states[skey] is not None else None
                    if state is not None:
                        state_members.setdefault(skey, []).append(state)
                        continue
                setup = self._setup(sc, models)
                m_total[idx] = total_mass(setup.model)
                if engines or sc.band is not None:
                    pending.append((idx, setup))
                if len(idx) == 1:
                    # a case of its own: the setup was built at its angle, so its T_c^- is the
                    # setup's partition (as evaluate_case computes it), batched with the other
                    # such cases of the same shape
                    own.add(idx[0], setup)
                    continue
                if sc.obstacle.beta_deg is not None:
                    betas = np.array([float(overrides[i].get(_BETA, sc.obstacle.beta_deg))
                                      for i in idx])
                    en = sweep_energy(setup, np.deg2rad(betas))
                else:
                    en = setup.partition()
                T[idx] = en.T_c_minus
                m_eff[idx] = en.m_eff
                m_eff_free[idx] = en.m_eff_free
                v_n[idx] = en.v_n
            except InputError as exc:  # (a case of its own may be recorded: errors)
                if errors is None or len(idx) != 1:
                    raise
                errors[idx[0]] = f"{type(exc).__name__}: {exc}"
        for bkey, members in blocks.items():
            first = firsts[bkey]
            pulling = pulling_applies(first.constraints, first.contacts)
            for s in range(0, len(members), _OwnCases.BLOCK):
                part = members[s:s + _OwnCases.BLOCK]
                refused: list[_Member] = []
                blk = _block(first, part)
                if blk is None and errors is not None:
                    part, refused = _numbers_refused(first, part)
                    if part:  # (the family's first case may be one refused)
                        blk = _block(first, part) or _block(scenario_from_dict(
                            apply_overrides(base, overrides[part[0].index])), part)
                if blk is not None:
                    idx = [m.index for m in part]
                    m_total[idx] = blk.total_mass
                    own.add_block(idx, blk, pulling)
                    part = []
                # case by case: the error of the case's own build
                self._one_by_one(base, overrides, sorted(m.index for m in part + refused),
                                 models, errors, m_total, own)
        for skey, part_all in state_members.items():
            first = states[skey]
            pulling = pulling_applies(first.constraints, first.contacts)
            for s in range(0, len(part_all), _OwnCases.BLOCK):
                part = part_all[s:s + _OwnCases.BLOCK]
                blk = self._state_block(first, part, models)
                if blk is not None:
                    idx = [m.index for m in part]
                    m_total[idx] = blk.total_mass
                    own.add_block(idx, blk, pulling)
                    continue
                # case by case: the error of the case's own build
                self._one_by_one(base, overrides, [m.index for m in part], models, errors,
                                 m_total, own)
        own.flush()
        missing = [i for i, e in enumerate(errors) if e] if errors is not None else []
        # the predicted peak force: one vectorized call per contact law over all the cases
        for members in laws.values():
            sc_i = scenario_from_dict(apply_overrides(base, overrides[members[0]]))
            F_pred[members] = _peak_force(T[members], v_n[members], _law_of(sc_i))
        F_pred[missing] = np.nan
        # the refined prediction (needs m_eff) and the simulations, case by case; the
        # cases of one model that settle alike (an angle or speed sweep) settle once per
        # engine (reuse_settled_states: the same configuration, the same bits)
        with _settle_once(engines):
            for idx, setup in pending:
                for i in idx:
                    sc_i = scenario_from_dict(apply_overrides(base, overrides[i]))
                    if engines or sc_i.band is not None:
                        refined[i] = _refined(sc_i, setup, float(m_eff[i]), engines)
                    if engines:
                        sims[i] = _simulate_all(sc_i, setup.model, engines)
                    sims[i] = _not_an_impact(refined[i] | sims[i])
        out = {"T_c_minus": T, "m_eff": m_eff, "v_n": v_n, "F_pred": F_pred,
               "m_total": m_total, "m_eff_free": m_eff_free,
               **_baselines(v_n, m_total, m_eff_free)}
        if any(sims):
            out.update(_columns(sims, missing))
        return out


#: Built models kept during one evaluate call (cases that change the speed or the angle
#: but not the model reuse it; a design that changes the model every case fills this).
_MODELS = 64


class _OwnCases:
    """The partition of cases that each have their own setup, batched: ``M``, ``A``, ``v``
    of up to :attr:`BLOCK` cases of the same shape are stacked (the setups themselves are
    not kept) and go through one batched :func:`roverimpact.partition` and
    :func:`roverimpact.energy.row_masses` call, the same quantities as
    :meth:`ImpactSetup.partition` (tested to 1e-12 against it). Cases come one setup at
    a time (:meth:`add`) or as a block of a model family
    (:meth:`add_block`: :func:`roverimpact.scenario.block.member_block`)."""

    BLOCK = 256

    def __init__(self, T, m_eff, m_eff_free, v_n):
        self.out = (T, m_eff, m_eff_free, v_n)
        # (shape of M, shape of A, obstacle row) -> [cases, count]; a part of the cases is
        # (indices, M, A, v, labels, total mass of each or None, whether the pulling check
        # of contacts.ground = "noslip" with constraints = "auto" applies)
        self.pending: dict[tuple, list] = {}

    def add(self, i: int, setup: ImpactSetup) -> None:
        # what warn_if_jammed needs, without the model: its labels and total mass
        total = jam_total_mass(setup.model)
        self._add((setup.M.shape, setup.A.shape, setup.obstacle_row),
                  (np.array([i]), setup.M[None], setup.A[None], setup.v[None], setup.labels,
                   None if total is None else np.array([total]),
                   pulling_applies(setup.constraints, setup.contacts)))

    def add_block(self, idx, blk, pull: bool = False) -> None:
        """The cases ``idx`` of an :class:`~roverimpact.scenario.block.ImpactBlock`, by
        active set (``pull``: the block's scenarios hold the wheels with no-slip rows and
        ``constraints = "auto"``: :func:`pulling_applies`)."""
        idx = np.asarray(idx)
        patterns, which = np.unique(blk.active, axis=0, return_inverse=True)
        which = which.reshape(-1)
        for p, mask in enumerate(patterns):
            sel = np.flatnonzero(which == p)
            rows = np.flatnonzero(mask)
            obstacle_row = int(np.flatnonzero(rows == blk.obstacle_row)[0])
            A = blk.A[sel][:, rows]
            self._add((blk.M.shape[1:], A.shape[1:], obstacle_row),
                      (idx[sel], blk.M[sel], A, blk.v[sel],
                       tuple(blk.labels[r] for r in rows),
                       blk.total_mass[sel] if blk.vehicle else None, pull))

    def _add(self, key, part) -> None:
        entry = self.pending.setdefault(key, [[], 0])
        entry[0].append(part)
        entry[1] += len(part[0])
        if entry[1] >= self.BLOCK:
            self._run(key, self.pending.pop(key)[0])

    def flush(self) -> None:
        for key in list(self.pending):
            self._run(key, self.pending.pop(key)[0])

    def _run(self, key, parts) -> None:
        from ..energy import partition, row_masses

        obstacle_row = key[2]
        idx = np.concatenate([pt[0] for pt in parts])
        M = np.concatenate([pt[1] for pt in parts])
        A = np.concatenate([pt[2] for pt in parts])
        v = np.concatenate([pt[3] for pt in parts])
        p = partition(M, A, v, want_velocities=False)
        a = A[:, obstacle_row, :]
        others = np.delete(A, obstacle_row, axis=1)
        m_eff, m_eff_free = row_masses(M, a, others)
        v_n = 0.0 - np.einsum("kn,kn->k", a, v)  # +0.0, not -0.0 (build._energy)
        T, me, mf, vn = self.out
        T[idx], me[idx], mf[idx], vn[idx] = np.where(v_n > 0.0, p.T_c, 0.0), m_eff, \
            m_eff_free, v_n  # no approach, no impact (build.no_approach)
        s = 0
        for pt in parts:
            n, labels, total, pull = len(pt[0]), pt[4], pt[5], pt[6]
            if total is not None:
                for j in np.flatnonzero(m_eff[s:s + n] > total * (1.0 + 1e-9)):
                    warn_jammed(float(m_eff[s + j]), float(total[j]), labels, obstacle_row)
            if pull:  # as ImpactSetup.partition and sweep_energy warn
                warn_if_pulling(M[s:s + n], A[s:s + n], v[s:s + n], labels, obstacle_row,
                                stacklevel=2)
            s += n


class _CaseKeys:
    """``(group key, law key)`` of a case's overrides. Cases with the same group key share
    M, A and v (their overrides differ in beta, contact law or simulation settings only);
    cases with the same law key have the same contact law (the base's, with the same law
    overrides). Which keys take part is worked out once per set of override keys (a
    study's cases share one), not per case."""

    def __init__(self):
        self._plans: dict[tuple[str, ...], tuple[list[str], list[str]]] = {}

    def __call__(self, ov: Mapping[str, Any]) -> tuple[str, str]:
        names = tuple(ov)
        plan = self._plans.get(names)
        if plan is None:
            group = sorted(k for k in names if k != _BETA
                           and not k.startswith(("contact_law.", "simulation.")))
            law = sorted(k for k in names if k.startswith("contact_law."))
            plan = self._plans[names] = (group, law)
        group, law = plan
        return (repr([(k, ov[k]) for k in group]), repr([(k, ov[k]) for k in law]))


class _Member(NamedTuple):
    """A case of a model family in a block: its index and the numbers that make it
    (:func:`~roverimpact.scenario.block.member_block`)."""

    index: int
    params: dict[str, Any]
    u: float
    beta_deg: float | None


def _block(first: Scenario, part: Sequence[_Member]):
    """:func:`~roverimpact.scenario.block.member_block` of the members ``part`` of
    ``first``'s family; None if it raises (a member that cannot be posed: then each is
    computed on its own, which raises that member's own error)."""
    try:
        return member_block(first, [m.params for m in part], [m.u for m in part],
                            None if first.obstacle.beta_deg is None
                            else [m.beta_deg for m in part])
    except RoverImpactError:
        return None


def _numbers_refused(first: Scenario, part: list[_Member]
                     ) -> tuple[list[_Member], list[_Member]]:
    """``part`` split into the members whose numbers ``first``'s model family takes and
    those it refuses (:func:`~roverimpact.models.family.family_numbers` of halves, then of
    halves of those refused: no model is built), each in order."""
    from ..models.family import family_numbers

    try:
        family_numbers(first.model.name, first.model.preset, [m.params for m in part])
        return part, []
    except InputError:
        if len(part) == 1:
            return [], part
    h = len(part) // 2
    good, bad = _numbers_refused(first, part[:h])
    good2, bad2 = _numbers_refused(first, part[h:])
    return good + good2, bad + bad2


def _member_of(index: int, sc: Scenario) -> _Member:
    return _Member(index, sc.model.params, sc.velocity.u, sc.obstacle.beta_deg)


def _member(index: int, first: Scenario, ov: Mapping[str, Any]) -> _Member | None:
    """The numbers of the case ``ov`` of ``first``'s :func:`_family_key`: its overrides
    differ from ``first``'s in numbers of ``model.params``, ``velocity.u`` and
    ``obstacle.beta_deg`` only, so the rest of ``first`` (validated) is the case's. The
    values as the schema makes them (a parameter's int stays an int, ``u`` and
    ``beta_deg`` floats; ``tests/test_study_scale.py`` checks the results against a
    validated scenario per case). None where the case needs its own validation: a speed
    or angle it would refuse (:func:`_speed_and_angle`)."""
    params = first.model.params
    changed = False
    for k, v in ov.items():
        if k.startswith("model.params.") and is_number(v):
            if not changed:
                params, changed = dict(params), True
            params[k[_PARAMS:]] = int(v) if isinstance(v, int) else float(v)
    ub = _speed_and_angle(first, ov)
    return None if ub is None else _Member(index, params, *ub)


def _speed_and_angle(first: Scenario, ov: Mapping[str, Any]) -> tuple[float, float] | None:
    """``(velocity.u, obstacle.beta_deg)`` of the case ``ov`` of ``first``'s block: its
    own numbers or ``first``'s; None where the case needs its own validation (a speed that
    is not finite, an angle outside [0, 90] degrees or beside an obstacle normal)."""
    u = ov.get("velocity.u")
    if is_number(u):
        if not math.isfinite(u):
            return None
        u = float(u)
    else:
        u = first.velocity.u
    beta = ov.get(_BETA)
    if is_number(beta):
        if not 0.0 <= beta <= 90.0 or first.obstacle.normal is not None:
            return None
        beta = float(beta)
    else:
        beta = first.obstacle.beta_deg
    return u, beta


_PARAMS = len("model.params.")


def _family_key(ov: Mapping[str, Any]) -> str:
    """Cases of one call with the same key have the same
    :func:`~roverimpact.scenario.block.block_key` (they differ in numbers of
    ``model.params``, ``velocity.u`` and ``obstacle.beta_deg`` only; computed for the
    first of them)."""
    return repr(sorted((k, None if is_number(v) and (k.startswith("model.params.")
                                                   or k in _FAMILY_NUMBERS) else v)
                       for k, v in ov.items()))


_FAMILY_NUMBERS = ("velocity.u", _BETA)


def _model_of(sc: Scenario, models: dict[str, Any]):
    """The model of ``sc`` (:func:`~roverimpact.scenario.build.scenario_model`): one built
    earlier in this call or check (``models``, by
    :func:`~roverimpact.scenario.build.model_key`), else built and kept there (at most
    ``_MODELS`` of them)."""
    key = model_key(sc)
    model = models.get(key)
    if model is None:
        model = scenario_model(sc)
        if len(models) < _MODELS:
            models[key] = model
    return model


class _State(NamedTuple):
    """A case of a state block: its index and the numbers that make it
    (:func:`~roverimpact.scenario.block.state_block`)."""

    index: int
    joints: dict[str, float]
    rates: dict[str, float]
    u: float
    beta_deg: float | None


def _state_group(ov: Mapping[str, Any]) -> str:
    """Cases of one call with the same key have the same
    :func:`~roverimpact.scenario.block.state_key` (they differ in numbers of joint values,
    joint rates, ``velocity.u`` and ``obstacle.beta_deg`` only; computed for the first of
    them)."""
    return repr(sorted((k, None if is_number(v) and (k.startswith(STATE_PREFIXES)
                                                   or k in STATE_NUMBERS) else v)
                       for k, v in ov.items()))


_CONF, _RATE = STATE_PREFIXES


def _sets_joints(ov: Mapping[str, Any]) -> bool:
    """Whether the case ``ov`` sets a joint value or rate to a number."""
    return any(k.startswith(STATE_PREFIXES) and is_number(v) for k, v in ov.items())


def _state(index: int, first: Scenario, ov: Mapping[str, Any]) -> _State | None:
    """The numbers of the case ``ov`` of ``first``'s :func:`_state_group`: its joint
    values and rates that ``ov`` sets (by joint name), its speed and angle; the rest of
    ``first`` (validated) is the case's. None where the case needs its own validation: a
    joint value or rate that is not finite, a speed or angle it would refuse
    (:func:`_speed_and_angle`)."""
    joints, rates = {}, {}
    for k, v in ov.items():
        if is_number(v) and k.startswith(STATE_PREFIXES):
            if not math.isfinite(v):
                return None
            if k.startswith(_CONF):
                joints[k[len(_CONF):]] = float(v)
            else:
                rates[k[len(_RATE):]] = float(v)
    ub = _speed_and_angle(first, ov)
    return None if ub is None else _State(index, joints, rates, *ub)


def _columns(rows: Sequence[Mapping[str, Any]], missing: Sequence[int] = ()
             ) -> dict[str, np.ndarray]:
    """Columns of the per-case ``rows``; the rows ``missing`` (cases that could not be
    posed) get "" in a column of texts, False in one of flags, NaN in the others (the
    column's type is that of the other rows)."""
    keys: dict[str, None] = {}
    for r in rows:
        keys.update(dict.fromkeys(r))
    gone = set(missing)
    out = {}
    for k in keys:
        vals = [r.get(k, np.nan) for r in rows]
        given = [v for i, v in enumerate(vals) if i not in gone]
        if any(isinstance(v, str) for v in given):
            fill, dtype = "", object
        elif given and all(isinstance(v, (bool, np.bool_)) for v in given):
            fill, dtype = False, bool
        else:
            fill, dtype = np.nan, float
        for i in gone:
            vals[i] = fill
        out[k] = np.array(vals, dtype=dtype)
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

    def evaluate(self, base, overrides, *, simulate: bool = False,
                 errors: list[str] | None = None):
        """The function's outputs for each case; ``errors`` as for
        :meth:`ScenarioEvaluator.evaluate` (an InputError of the function records the
        case)."""
        rows, missing = [], []
        for i, ov in enumerate(overrides):
            try:
                rows.append(self.fn(apply_overrides(base, ov)))
            except InputError as exc:
                if errors is None:
                    raise
                errors[i] = f"{type(exc).__name__}: {exc}"
                rows.append({})
                missing.append(i)
        return _columns(rows, missing)


def get_evaluator(evaluator=None):
    """The default :class:`ScenarioEvaluator`, an evaluator object, or a wrapped function."""
    if evaluator is None:
        return ScenarioEvaluator()
    if hasattr(evaluator, "evaluate") and hasattr(evaluator, "validate"):
        return evaluator
    if callable(evaluator):
        return FunctionEvaluator(evaluator)
    raise TypeError(f"not an evaluator: {evaluator!r}")
