"""Predicted risk along a traverse against a compliant-contact simulation of each impact.

What is simulated (roverimpact.traverse.validate): each sampled impact from the rover's
terrain pose and driving velocity, with the simulator's own dynamics (``ContactSystem``:
Pinocchio, compliant Hunt-Crossley contacts, the differential enforced as a constraint),
gravity, every wheel on the terrain's tangent plane at its support preloaded by its static
load, the hitting wheel against the tangent plane of the terrain feature at the contact
found ahead (point and normal from the height field), thin-disc wheels (the rim point facing
each plane, as the indicator's geometry). Without gravity: the impact forces only, the
supports just touching.

It checks the weight model (roverimpact.traverse.refine: contact-space ODE at the frozen
pose) and its speed limit, and, without gravity, the indicator T_c^- (rigid impact,
automatic active set), against compliant multibody dynamics at the terrain's own poses,
normals and velocities. The harness is the project's own simulator and takes its initial
support loads from the model: it proves the model against the dynamics it reduces, not
against another engine or the terrain beyond the contact's tangent plane (a rock's
curvature during the contact), nor ground that gives way.

References: the harness equals the project's simulator (simulate_impact) where both apply
(level ground, a face across the path); Spearman and the speed-limit claim are measured on
seeded samples (50 in the slow test, 12 in the default run).
"""

from __future__ import annotations

import numpy as np
import pytest

from roverimpact.contact import get_law
from roverimpact.models import rover2d
from roverimpact.simulate import SimulationConfig, simulate_impact
from roverimpact.simulate.run import initial_state
from roverimpact.traverse.validate import check_against_simulation, simulate_station_impact


@pytest.mark.parametrize("gravity", ["none", "earth"])
def test_harness_equals_the_simulator_on_level_ground(gravity):
    """rover2d rolling at 0.3 m/s into a 60 degree face: the harness (one support plane per
    wheel, the face through the front wheel's contact) and simulate_impact (the ground
    z = 0, the face 1e-9 m ahead) give the same peak force, without gravity and with it
    (the simulator settled on the ground by integrating to rest, the harness preloading
    its supports by their static loads)."""
    rv = rover2d(suspension="rocker")
    hc = {"name": "hunt-crossley", "k": 1e7, "e": 0.5}
    cfg = SimulationConfig(speed=0.3, beta_deg=60.0, obstacle=hc, gravity=gravity,
                           settle=gravity != "none", distance=1e-9,
                           obstacle_wheels=["front"], t_after=0.05)
    q0, v0 = initial_state(rv, cfg)
    ref = simulate_impact(rv, cfg, q0=q0, v0=v0)
    b = np.radians(60.0)
    n = np.array([-np.sin(b), 0.0, np.cos(b)])
    up = np.tile([0.0, 0.0, 1.0], (2, 1))
    import pinocchio as pin

    data = rv.model.createData()
    pin.framesForwardKinematics(rv.model, data, q0)
    sup = np.array([data.oMf[rv.model.getFrameId(w.frame)].translation - [0, 0, w.radius]
                    for w in rv.wheels])
    mine = simulate_station_impact(rv, q0, v0, sup, up, 0, sup[0], n,
                                   law=get_law(**hc), ground_law=get_law("hunt-crossley",
                                                                        k=1e7, e=0.2),
                                   gravity=[0.0, 0.0, -cfg.g])
    assert mine.v_n == pytest.approx(ref.v_n, rel=1e-6)
    assert mine.F_max == pytest.approx(ref.F_max_total, rel=2e-3)


def _check(c, n_ok):
    # the model ranks (and predicts) the simulated peak force
    assert c.spearman_model >= 0.9
    assert np.median(c.F_model / c.F_sim) == pytest.approx(1.0, abs=0.02)
    # at the speed limit the simulated peak force is within 10 % of the allowable force
    # (where there is none, over 0.9 F_allow at 1 % of u; at the cap, under 1.1 F_allow)
    assert c.within.sum() >= n_ok


#: Impacts of the 12-impact quick checks that must hold within 10 %. The claim (>= 95 %)
#: is the slow check's, on 50 impacts; of 12 drawn from a rate of 95 %, 10 or more hold
#: with probability 0.98 (11 or more only 0.88). The sample is the path's impacts
#: stratified over T_c^-: when the pose solver's restarts found the 20 stations it had
#: missed (a rock under a wheel), every pick moved and two of the 12 fell outside 10 %
#: (one 11 % over F_allow at the limit, one conservative: the model 27 % above the
#: simulation); the slow check stayed at 49 of 50.
QUICK_WITHIN = 10


def test_risk_ranks_simulated_force_and_limit_holds_quick():
    c = check_against_simulation(12, seed=1)
    _check(c, QUICK_WITHIN)
    # with the weight, the closed form's limit (no weight, rigid supports) is not safe
    assert np.median(c.ratio_at_closed) > 1.1


def test_indicator_ranks_the_impact_force_without_weight_quick():
    """Without gravity (the impact forces only, the rigid-impact model T_c^- comes from):
    T_c^- ranks the simulated peak force, and the model's limits hold."""
    c = check_against_simulation(12, seed=1, gravity=0.0)
    assert c.spearman >= 0.9
    _check(c, QUICK_WITHIN)


@pytest.mark.slow
def test_risk_ranks_simulated_force_and_limit_holds():
    """The brief's check: 50 seeded impacts, Spearman >= 0.9, and at the speed limit the
    simulated F_max within 10 % of the allowable force in >= 95 % of them."""
    c = check_against_simulation(50, seed=0)
    _check(c, 48)
