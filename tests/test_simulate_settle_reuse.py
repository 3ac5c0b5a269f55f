"""``reuse_settled_states``: runs of one model that settle to one configuration on the
ground settle once, and give the results of runs that settle each on their own, to the bit.

Every run here is compared with the same run outside the context (its own settling), not
with a number of this file: what is checked is that reusing changes nothing, and that
what settling reads (gravity, the laws, q0, the model) is never taken from another run.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import roverimpact.simulate.run as run
from roverimpact.contact import get_law
from roverimpact.models import rover2d
from roverimpact.simulate import (
    SimulationConfig,
    initial_state,
    reuse_settled_states,
    simulate_impact,
)
from roverimpact.studies.config import apply_overrides
from roverimpact.studies.evaluate import ScenarioEvaluator, evaluate_case


@pytest.fixture
def settles(monkeypatch):
    """The configurations the rover was settled for, in order."""
    calls: list[SimulationConfig] = []
    real = run._settled_on_ground

    def counting(sys, mbm, config, q):
        calls.append(config)
        return real(sys, mbm, config, q)

    monkeypatch.setattr(run, "_settled_on_ground", counting)
    return calls


def _cfg(**kw) -> SimulationConfig:
    return SimulationConfig(**{"t_after": 0.05, **kw})


def _same_run(a, b) -> None:
    assert a.F_max_total == b.F_max_total
    assert a.T_c_minus == b.T_c_minus
    np.testing.assert_array_equal(a.q_minus, b.q_minus)
    np.testing.assert_array_equal(a.v_minus, b.v_minus)
    pd.testing.assert_frame_equal(a.history, b.history, check_exact=True)


def test_an_angle_sweep_settles_once_and_gives_the_same_bits(settles):
    mbm = rover2d()
    cfgs = [_cfg(beta_deg=b, distance=d, speed=u)
            for b, d, u in ((30.0, 1e-3, 0.1), (60.0, 2e-3, 0.3), (90.0, 1e-3, 0.1))]
    alone = [simulate_impact(mbm, c) for c in cfgs]
    starts_alone = [initial_state(mbm, c) for c in cfgs]
    assert len(settles) == 6
    settles.clear()
    with reuse_settled_states():
        shared = [simulate_impact(mbm, c) for c in cfgs]
        starts = [initial_state(mbm, c) for c in cfgs]
        # a start handed out is the caller's: writing into it changes no later start
        starts[0][0][:] = 0.0
        again = initial_state(mbm, cfgs[0])
    # once for the own engine's runs, once for initial_state (the MuJoCo engine's start)
    assert len(settles) == 2
    for a, b in zip(alone, shared, strict=True):
        _same_run(a, b)
    for (qa, va), (qb, vb) in zip(starts_alone[1:], starts[1:], strict=True):
        np.testing.assert_array_equal(qa, qb)
        np.testing.assert_array_equal(va, vb)
    np.testing.assert_array_equal(again[0], starts_alone[0][0])
    initial_state(mbm, cfgs[0])  # after the context: settled again
    assert len(settles) == 3


def test_what_the_start_reads_is_not_reused(settles):
    mbm = rover2d()
    base = _cfg(beta_deg=60.0)
    q_up = run.reference_configuration(mbm).copy()
    q_up[1] += 0.01  # the base raised by 1 cm: another q0
    with reuse_settled_states():
        starts = {
            "base": initial_state(mbm, base),
            "gravity": initial_state(mbm, _cfg(beta_deg=60.0, gravity="mars")),
            "ground law": initial_state(mbm, _cfg(beta_deg=60.0,
                                                  ground_contact={"k": 2e6, "e": 0.2})),
            "obstacle law": initial_state(mbm, _cfg(beta_deg=60.0,
                                                    obstacle={"name": "hertz", "k": 1e7})),
            "q0": initial_state(mbm, base, q0=q_up),
            "model": initial_state(rover2d(), base),
            "law object": initial_state(mbm, base,
                                        ground_law=get_law("hunt-crossley", k=1e6, e=0.2)),
        }
        with reuse_settled_states():  # a context within starts empty
            initial_state(mbm, base)
        n_inside = len(settles)
        reused = initial_state(mbm, base)
        faster = initial_state(mbm, _cfg(beta_deg=30.0, speed=0.2))  # settles as base
    assert n_inside == len(starts) + 1
    assert len(settles) == n_inside  # the last two were reused
    np.testing.assert_array_equal(reused[0], starts["base"][0])
    np.testing.assert_array_equal(reused[1], starts["base"][1])
    np.testing.assert_array_equal(faster[0], starts["base"][0])
    assert faster[1] == pytest.approx(2 * starts["base"][1], rel=1e-12)  # its own speed
    # each start is the one computed outside any context
    settles.clear()
    q, v = initial_state(mbm, _cfg(beta_deg=30.0, speed=0.2))
    np.testing.assert_array_equal(faster[0], q)
    np.testing.assert_array_equal(faster[1], v)
    for what, kw in (("gravity", {"gravity": "mars"}), ("ground law", {"ground_contact": {
            "k": 2e6, "e": 0.2}})):
        q, v = initial_state(mbm, _cfg(beta_deg=60.0, **kw))
        np.testing.assert_array_equal(starts[what][0], q)
        np.testing.assert_array_equal(starts[what][1], v)


def test_a_study_of_angles_settles_once_per_engine_with_the_cases_results(settles):
    base = {"model": {"name": "rover2d"}, "velocity": {"u": 0.2},
            "obstacle": {"wheel": "front", "beta_deg": 60.0},
            "contact_law": {"name": "hunt-crossley", "k": 1e7, "e": 0.5},
            "simulation": {"t_after": 0.05}}
    overrides = [{"obstacle.beta_deg": b, "velocity.u": u}
                 for b, u in ((35.0, 0.2), (55.0, 0.3), (80.0, 0.2))]
    got = ScenarioEvaluator().evaluate(base, overrides, simulate=["own", "mujoco"])
    assert len(settles) == 2  # one start for the three cases, in each engine
    settles.clear()
    for i, ov in enumerate(overrides):
        one = evaluate_case(apply_overrides(base, ov), simulate=["own", "mujoco"])
        for col in ("F_max", "F_max_mujoco", "T_c_minus_sim", "contact_duration_mujoco"):
            assert got[col][i] == one[col], (i, col)
    assert len(settles) == 2 * len(overrides)


def test_the_oldest_settled_state_goes_when_the_store_is_full(settles, monkeypatch):
    """A design that changes the model in every case keeps no more than _SETTLED_KEPT
    models alive: the oldest settled state is dropped (and settled again if asked for)."""
    monkeypatch.setattr(run, "_SETTLED_KEPT", 2)
    mbm = rover2d()
    cfgs = [_cfg(gravity=g) for g in ("earth", "mars", "moon")]
    with reuse_settled_states():
        for c in cfgs:
            initial_state(mbm, c)
        initial_state(mbm, cfgs[2])  # kept
        initial_state(mbm, cfgs[0])  # dropped: settled again
        assert len(run._SETTLED.get()) == 2
    assert [c.gravity for c in settles] == ["earth", "mars", "moon", "earth"]
