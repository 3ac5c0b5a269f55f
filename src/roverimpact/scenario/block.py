"""Many scenarios of one model family at once: M, A, v and the active rows of a block.

A study whose cases change a built-in model's parameters (COM height, masses, lengths),
the speed and the impact angle builds, case by case, models that differ in numbers only.
Scenarios with the same :func:`block_key` are such a block: :func:`impact_block` builds
one model of the family and its constraint set, writes each member's numbers into that
model for its Pinocchio pass (:class:`roverimpact.models.family.ModelFamily`), and
computes the configurations, velocities, obstacle normals and active rows of the whole
block with arrays over the block. Member ``i`` of the result is what
:meth:`~roverimpact.scenario.ImpactSetup.from_scenario` gives for ``scenarios[i]``: the
same candidate rows, ``M``, ``A``, ``v`` and active set (tested to 1e-12).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..exceptions import InputError
from .build import (
    active_mask,
    base_heading,
    base_slices,
    candidate_constraints,
    check_states,
    configuration,
    friction_of,
    normal_from_beta,
    scenario_model,
    total_mass,
    velocity,
)
from .schema import Scenario

__all__ = ["ImpactBlock", "block_key", "impact_block", "member_block", "state_block",
           "state_key"]

#: The tables of a scenario that make its impact setup (the others: the contact law, the
#: simulation, the band, do not change M, A, v).
_SETUP_TABLES = {"model", "configuration", "velocity", "contacts", "obstacle", "constraints"}


def block_key(scenario: Scenario) -> str | None:
    """What a block's scenarios share; None if the scenario has no block.

    A block is scenarios of a built-in model with family numbers
    (:func:`roverimpact.models.family.has_family`), without terrain or declared loops,
    that are the same but for the numbers of ``model.params`` (which parameters are set
    is part of the key, their values are not when they are numbers), ``velocity.u`` and
    ``obstacle.beta_deg``.
    """
    from ..models.family import has_family

    if (scenario.model.name is None or not has_family(scenario.model.name)
            or scenario.terrain is not None or scenario.contacts.loops):
        return None
    data = scenario.model_dump(include=_SETUP_TABLES)
    data["model"]["params"] = sorted((k, None if is_number(v) else v)
                                     for k, v in data["model"]["params"].items())
    data["velocity"]["u"] = None
    if data["obstacle"]["beta_deg"] is not None:
        data["obstacle"]["beta_deg"] = None
    return repr(data)


def is_number(v) -> bool:
    """Whether an override value is a number (not a bool): numbers of ``model.params``,
    ``velocity.u`` and ``obstacle.beta_deg`` may differ within a block."""
    return isinstance(v, (int, float)) and not isinstance(v, bool)


@dataclass(frozen=True)
class ImpactBlock:
    """The impact setups of a block of scenarios (member ``i``: ``scenarios[i]``).

    Attributes
    ----------
    M : (k, n, n) ndarray
        Mass matrices.
    A : (k, m, n) ndarray
        All candidate rows (the obstacle row last), in the order of ``labels``.
    v : (k, n) ndarray
        Velocities before impact.
    q : (k, nq) ndarray
        Configurations.
    active : (k, m) bool ndarray
        The active rows of each member
        (:func:`~roverimpact.scenario.build.active_mask`).
    labels : tuple of str
        Candidate row labels (the same for every member).
    obstacle_row : int
        Index of the obstacle row among the candidates.
    total_mass : (k,) ndarray
        Mass of each member's whole model [kg].
    vehicle : bool
        A floating or planar base (the held-rows check of
        :func:`~roverimpact.scenario.build.warn_if_jammed` applies).
    """

    M: np.ndarray
    A: np.ndarray
    v: np.ndarray
    q: np.ndarray
    active: np.ndarray
    labels: tuple[str, ...]
    obstacle_row: int
    total_mass: np.ndarray
    vehicle: bool


def impact_block(scenarios: Sequence[Scenario], *, base_dir: str | Path | None = None,
                 key: str | None = None) -> ImpactBlock:
    """The impact setups of scenarios with one :func:`block_key`, computed together.

    ``key``: that key, when the caller has grouped the scenarios by it (then it is not
    computed again for each); ``base_dir`` as for
    :meth:`~roverimpact.scenario.ImpactSetup.from_scenario`.

    Raises
    ------
    InputError
        Scenarios of different blocks; otherwise what
        :meth:`~roverimpact.scenario.ImpactSetup.from_scenario` raises for one of them
        (a bad parameter set, an impact problem without solution, ...).
    """
    scenarios = list(scenarios)
    if not scenarios:
        raise InputError("impact_block needs at least one scenario")
    sc0 = scenarios[0]
    if key is None:
        key = block_key(sc0)
        if key is not None and any(block_key(sc) != key for sc in scenarios[1:]):
            key = None
    if key is None:
        raise InputError("impact_block: the scenarios are not one block (block_key)")
    beta = (None if sc0.obstacle.normal is not None
            else [sc.obstacle.beta_deg for sc in scenarios])
    return member_block(sc0, [sc.model.params for sc in scenarios],
                        [sc.velocity.u for sc in scenarios], beta, base_dir=base_dir)


def member_block(first: Scenario, params: Sequence[Mapping], u: Sequence[float],
                 beta_deg: Sequence[float] | None = None, *,
                 base_dir: str | Path | None = None) -> ImpactBlock:
    """:func:`impact_block` of the scenarios that are ``first`` but for their numbers:
    member ``i`` has ``model.params = params[i]``, ``velocity.u = u[i]`` and, unless
    ``beta_deg`` is None (``first``'s obstacle for all), ``obstacle.beta_deg =
    beta_deg[i]``; no scenario object is made for them (a study's model-changing cases:
    :class:`roverimpact.studies.ScenarioEvaluator`). The numbers must be what a scenario
    takes (a ``beta_deg`` in [0, 90], the parameters ``first`` sets); a parameter set
    the model refuses raises as :func:`impact_block` does.
    """
    from ..models.family import ModelFamily, family_numbers

    sc0 = first
    numbers = family_numbers(sc0.model.name, sc0.model.preset, params)
    mbm = scenario_model(sc0, base_dir)  # a member: the family's model, rewritten below
    family = ModelFamily(mbm, numbers)
    Q = configuration(mbm, sc0.configuration, q_nominal=numbers.q_nominal)
    kind, iq, _ = base_slices(mbm)
    if kind == "floating":  # one base orientation: one heading, one base rotation
        rot = Q[:, iq[0] + 3:iq[0] + 7]
        if not (rot == rot[:1]).all():  # pragma: no cover - configuration() sets it
            raise InputError("impact_block: the members' base orientations differ")
    q0 = Q[0]
    u = np.array(u, dtype=float)
    v = velocity(mbm, q0, sc0.velocity, u=u, wheel_radius=numbers.wheel_radius)
    normals = _normals(sc0.obstacle, base_heading(mbm, q0), len(u), beta_deg)
    cs, M, A = _rows(mbm, sc0, family, Q, normals)
    return _block(sc0, cs, M, A, v, Q, numbers.total_mass(), kind)


def _normals(obs, heading, k: int, beta_deg) -> np.ndarray:
    """The obstacle normals (k, 3) of a block's members: ``obs.normal`` for all, or the
    face at ``beta_deg[i]`` (``obs.beta_deg`` for all if None) ahead of ``heading``."""
    if obs.normal is not None:
        normal = np.asarray(obs.normal, float)
        return np.broadcast_to(normal / np.linalg.norm(normal), (k, 3))
    beta = np.full(k, obs.beta_deg, dtype=float) if beta_deg is None else \
        np.asarray(beta_deg, dtype=float)
    return normal_from_beta(np.deg2rad(beta), heading)


def _rows(mbm, sc0: Scenario, family, Q, normals):
    """``(constraint set, M (k, nv, nv), A (k, m, nv))`` of a block's members: ``sc0``'s
    candidate rows, the obstacle's with each member's normal, at ``Q[i]`` (of the
    family's member ``i``, or of ``mbm`` itself for ``family`` None)."""
    from ..models.kinematics import ConstraintSet

    cons = candidate_constraints(mbm, sc0.obstacle, sc0.contacts, normals[0])
    cs = ConstraintSet(mbm, cons)
    M, A = cs.evaluate_members(family, Q, normals={len(cons) - 1: normals})
    return cs, M, A


def _block(sc0: Scenario, cs, M, A, v, Q, total_mass, kind: str) -> ImpactBlock:
    """The :class:`ImpactBlock` of the rows ``M``, ``A`` of ``cs``: their active rows as
    ``sc0`` chooses them (the obstacle row last)."""
    labels = tuple(cs.labels)
    obstacle = len(labels) - 1
    active = active_mask(sc0.constraints, labels, M, A, v, obstacle_row=obstacle,
                         **friction_of(sc0.contacts))
    return ImpactBlock(M=M, A=A, v=v, q=Q, active=active, labels=labels,
                       obstacle_row=obstacle, total_mass=total_mass,
                       vehicle=kind in ("floating", "planar"))


#: The override names whose numbers may differ between the scenarios of a state block: a
#: 1-DoF joint's value or rate, the speed and the impact angle.
STATE_PREFIXES = ("configuration.joints.", "velocity.joints.")
STATE_NUMBERS = ("velocity.u", "obstacle.beta_deg")


def state_key(scenario: Scenario) -> str | None:
    """What the scenarios of a state block share; None if the scenario has none.

    A state block is scenarios of one model (any: a robot file, the rigid body, a built-in
    rover), without terrain, declared loops or a band, that are the same but for the
    numbers of their joint values (``configuration.joints``), joint rates
    (``velocity.joints``), ``velocity.u`` and ``obstacle.beta_deg``
    (:func:`state_block`). The key is the scenario's setup tables with those numbers
    left out.
    """
    if (scenario.terrain is not None or scenario.contacts.loops
            or scenario.band is not None):
        return None
    data = scenario.model_dump(include=_SETUP_TABLES)
    for table in ("configuration", "velocity"):
        joints = data[table]["joints"]
        data[table]["joints"] = sorted((k, None if is_number(v) else v)
                                       for k, v in joints.items())
    data["velocity"]["u"] = None
    if data["obstacle"]["beta_deg"] is not None:
        data["obstacle"]["beta_deg"] = None
    return repr(data)


def state_block(first: Scenario, joints: Mapping[str, np.ndarray],
                rates: Mapping[str, np.ndarray], u, beta_deg=None, *, model=None,
                base_dir: str | Path | None = None) -> ImpactBlock:
    """The impact setups of k scenarios that are ``first`` but for numbers: member ``i``
    has the joint values ``{name: joints[name][i]}`` (in place of ``first``'s values of
    those joints in ``[configuration.joints]``), the joint rates ``{name:
    rates[name][i]}``, ``velocity.u = u[i]`` and, unless ``beta_deg`` is None
    (``first``'s obstacle for all), ``obstacle.beta_deg = beta_deg[i]``.

    One model (``model``: ``first``'s :func:`~roverimpact.scenario.build.scenario_model`,
    built if None) and one constraint set for all; the configurations, velocities, normals
    and active rows as arrays over the block, the Pinocchio passes in one batched call.
    Member ``i`` is what :meth:`~roverimpact.scenario.ImpactSetup.from_scenario` gives for
    its scenario (the same candidate rows, ``M``, ``A``, ``v`` and active set; tested to
    1e-12), with the same checks; a member that fails one raises its error.
    ``first`` must have a :func:`state_key`, the numbers must be finite and ``beta_deg``
    in [0, 90].
    """
    if state_key(first) is None:
        raise InputError("state_block: the scenario has terrain, declared loops or a band")
    u = np.asarray(u, dtype=float).reshape(-1)
    k = len(u)
    sc0 = first
    mbm = scenario_model(sc0, base_dir) if model is None else model
    values = dict(sc0.configuration.joints)
    values.update((name, np.asarray(x, dtype=float)) for name, x in joints.items())
    speeds = dict(sc0.velocity.joints)
    speeds.update((name, np.asarray(x, dtype=float)) for name, x in rates.items())
    for name, x in (*joints.items(), *rates.items()):
        if np.shape(x) != (k,):
            raise InputError(f"state_block: {name!r} needs {k} numbers, got {np.shape(x)}")
    Q = configuration(mbm, sc0.configuration, joints=values)
    if Q.ndim == 1:
        Q = np.array(np.broadcast_to(Q, (k, Q.shape[0])))
    q0 = Q[0]
    V = velocity(mbm, q0, sc0.velocity, u=u, joints=speeds)
    # the joints do not turn the base: one heading
    normals = _normals(sc0.obstacle, base_heading(mbm, q0), k, beta_deg)
    cs, M, A = _rows(mbm, sc0, None, Q, normals)
    check_states(mbm, sc0, Q, V, A, tuple(cs.labels), cs.data)
    return _block(sc0, cs, M, A, V, Q, np.full(k, total_mass(mbm)), base_slices(mbm)[0])
