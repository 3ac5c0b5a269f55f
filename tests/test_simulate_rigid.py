"""Compliant impact of single rigid bodies on a plane vs the 1-D closed forms.

Reference (elastic Hertz, derived here, independent of roverimpact.contact): a body whose
contact point approaches a plane with normal speed v_n and effective mass m_eff, under
f = k delta^n, stores all of 1/2 m_eff v_n^2 as elastic energy k delta^(n+1)/(n+1) at
maximum indentation (short contact: the configuration, hence m_eff, does not change), so

    delta_max = ((n + 1) m_eff v_n^2 / (2 k))^(1/(n+1)),   F_max = k delta_max^n.

For damped laws the reference is ``roverimpact.contact.predict`` (its own tests check it
against a 1-D quadrature).
"""

from __future__ import annotations

import numpy as np
import pytest

from roverimpact import effective_mass
from roverimpact.contact import get_law, predict
from roverimpact.exceptions import ConfigError, InputError, SolverError
from roverimpact.simulate import SimulationConfig, build_system, simulate_impact
from tests.reference.sim_models import HuntCrossleyLocal, free_sphere, pendulum, planar_box


def hertz_peak(m_eff, v_n, k, n=1.5):
    d = ((n + 1) * m_eff * v_n**2 / (2 * k)) ** (1 / (n + 1))
    return k * d**n


FREE = dict(gravity="none", ground=False, distance=1e-3, t_after=0.05)


@pytest.mark.parametrize("beta_deg", [90.0, 40.0])
def test_sphere_elastic_peak_matches_energy_balance(beta_deg):
    m, k, u = 2.0, 1e7, 1.0
    cfg = SimulationConfig(**FREE, beta_deg=beta_deg, obstacle={"name": "hertz", "k": k, "e": 1})
    v0 = np.zeros(6)
    v0[0] = u                       # free-flyer v = (linear, angular) in the body frame
    r = simulate_impact(free_sphere(mass=m), cfg, v0=v0)
    v_n = u * np.sin(np.radians(beta_deg))
    assert r.v_n == pytest.approx(v_n, rel=1e-9)
    assert r.m_eff == pytest.approx(m, rel=1e-9)          # centred hit of a ball
    assert r.F_max_total == pytest.approx(hertz_peak(m, v_n, k), rel=1e-3)
    # elastic and frictionless: normal velocity reversed, tangential kept
    n = np.array([-np.sin(np.radians(beta_deg)), 0.0, np.cos(np.radians(beta_deg))])
    vp = r.v_plus[:3]
    assert vp @ n == pytest.approx(v_n, rel=1e-4)
    assert r.separated
    assert r.T_c_minus == pytest.approx(0.5 * m * v_n**2, rel=1e-9)


@pytest.mark.parametrize("law_name,e", [("hunt-crossley", 0.5), ("lankarani-nikravesh", 0.8)])
def test_sphere_damped_peak_matches_contact_closed_form(law_name, e):
    m, k, u = 2.0, 1e7, 0.5
    law = get_law(law_name, k=k, e=e)
    cfg = SimulationConfig(**FREE, obstacle={"name": law_name, "k": k, "e": e})
    v0 = np.zeros(6)
    v0[0] = u
    r = simulate_impact(free_sphere(mass=m), cfg, v0=v0)
    pred = predict(law, m, u)
    assert r.F_max_total == pytest.approx(float(pred.peak_force), rel=1e-2)
    assert -r.v_plus[0] == pytest.approx(u * float(pred.restitution_achieved), rel=1e-2)
    assert r.impulse["obstacle_ball"] == pytest.approx(m * (u - r.v_plus[0]), rel=1e-3)


def test_offcentre_hit_of_rotating_box_uses_effective_mass():
    """The disc sits 0.3 m ahead and 0.1 m above the COM of a spinning, moving box: the
    wall sees m_eff = 1 / (a M^-1 a^T) < m, with a the wall-normal row of the disc."""
    mb = planar_box(mass=5.0)
    k = 1e7
    cfg = SimulationConfig(**FREE, obstacle={"name": "hertz", "k": k, "e": 1})
    v0 = np.array([0.8, 0.1, 0.7])                  # planar joint: (vx, vz, spin) in joint axes
    r = simulate_impact(mb, cfg, v0=v0)
    sys = build_system(mb, cfg)
    cs = sys.contacts(r.q_minus, r.v_minus)
    a = sys.planes[-1].n @ cs.Jp[-1, 0]
    M = sys.mass_matrix(r.q_minus)
    m_eff = float(effective_mass(M, a))
    assert m_eff < 5.0 * 0.9                        # the rotation matters
    v_n = -float(a @ r.v_minus)
    assert v_n > 0
    assert r.F_max_total == pytest.approx(hertz_peak(m_eff, v_n, k), rel=1e-2)


def test_local_law_object_can_replace_the_registry():
    m, k = 2.0, 1e6
    v0 = np.zeros(6)
    v0[0] = 0.5
    r = simulate_impact(free_sphere(mass=m), SimulationConfig(**FREE), v0=v0,
                        law=HuntCrossleyLocal(k, e=1.0))
    assert r.F_max_total == pytest.approx(hertz_peak(m, 0.5, k), rel=1e-3)


def test_pendulum_hits_wall():
    """A pendulum swinging at rate w into a wall at its tip: m_eff = I_O / L^2."""
    mp = pendulum(mass=1.0, length=0.5)
    k = 1e6
    cfg = SimulationConfig(**FREE, obstacle={"name": "hertz", "k": k, "e": 1})
    r = simulate_impact(mp, cfg, q0=[0.0], v0=[-2.0])  # RY: +theta swings the tip to -x
    I_O = 1.0 * (0.5**2 + 0.02**2) / 12 + 1.0 * 0.25**2
    assert r.m_eff == pytest.approx(I_O / 0.5**2, rel=1e-3)
    assert r.F_max_total == pytest.approx(hertz_peak(r.m_eff, r.v_n, k), rel=1e-2)


# ---------------------------------------------------------------------- bad input
@pytest.mark.parametrize("bad", [
    {"obstacle": {"k": 0.0}},
    {"obstacle": {"k": -1.0}},
    {"speed": 0.0},
    {"t_max": 0.0},
    {"integrator": {"max_step": 0.0}},
    {"beta_deg": 0.0},
    {"distance": -0.1},
    {"gravity": "jupiter"},
    {"obstacle_x": float("nan")},
    {"obstacle_x": float("inf")},
    {"unknown_option": 1.0},
])
def test_bad_config_is_one_config_error(bad):
    with pytest.raises(ConfigError, match="simulation config"):
        SimulationConfig.from_dict(bad)
    # keyword construction, as the docs write it: the same ConfigError (was pydantic's
    # ValidationError, which `except RoverImpactError` did not catch); obstacle_x = nan was
    # explained as "the obstacle (height inf m) is lower than ... every wheel"
    with pytest.raises(ConfigError, match="SimulationConfig: "):
        SimulationConfig(**bad)


def test_obstacle_behind_rover_is_input_error():
    cfg = SimulationConfig(**{**FREE, "distance": 0.0}, obstacle_x=-1.0)
    with pytest.raises(InputError, match="behind or inside"):
        simulate_impact(free_sphere(), cfg, v0=np.r_[1.0, 0, 0, 0, 0, 0])


def test_no_contact_within_time_limit_is_solver_error():
    cfg = SimulationConfig(**{**FREE, "distance": 1.0}, t_max=0.1)
    with pytest.raises(SolverError, match="no obstacle contact within t_max"):
        simulate_impact(free_sphere(), cfg, v0=np.r_[1.0, 0, 0, 0, 0, 0])


def test_moving_away_never_hits():
    cfg = SimulationConfig(**FREE, t_max=0.05)
    with pytest.raises(SolverError, match="no obstacle contact"):
        simulate_impact(free_sphere(), cfg, v0=np.r_[-1.0, 0, 0, 0, 0, 0])


def test_sliding_sphere_reaches_rolling_by_friction():
    """A solid sphere set sliding without spin on the ground rolls after friction has
    acted: v_roll = 5/7 v0 (angular momentum about the contact point is conserved), so its
    kinetic energy is T = 7/10 m v_roll^2 = 5/14 m v0^2 when it reaches the wall."""
    m, v0 = 2.0, 1.0
    cfg = SimulationConfig(gravity="earth", speed=v0, mu=0.5, distance=0.1, t_max=0.5,
                           ground_contact={"k": 1e7, "e": 0.3},
                           obstacle={"name": "hertz", "k": 1e7, "e": 1})
    r = simulate_impact(free_sphere(mass=m), cfg)
    assert r.T_minus == pytest.approx(5 / 14 * m * v0**2, rel=1e-2)
    assert r.history["ground_ball_ft"].max() == pytest.approx(0.5 * m * 9.81, rel=2e-2)


def test_obstacle_lower_than_the_wheels_is_input_error():
    cfg = SimulationConfig(**FREE, obstacle_height=0.5)     # ball centre at z = 1 m
    with pytest.raises(InputError, match="lower than the contact points"):
        simulate_impact(free_sphere(), cfg, v0=np.r_[1.0, 0, 0, 0, 0, 0])
