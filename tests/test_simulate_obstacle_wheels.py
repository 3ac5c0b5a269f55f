"""An obstacle in the path of chosen wheels only (DETC2015-47747, Fig. 1: one front wheel)."""

import pytest

import roverimpact as ri
from roverimpact import simulate_impact
from roverimpact.models import rocker_bogie


@pytest.fixture(scope="module")
def rover():
    return rocker_bogie("prototype")


def test_only_the_chosen_wheel_touches(rover):
    both = simulate_impact(rover, {"speed": 0.3, "beta_deg": 60.0})
    one = simulate_impact(rover, {"speed": 0.3, "beta_deg": 60.0,
                                  "obstacle_wheels": ["left_front"]})
    # a face across the path: both front wheels hit (symmetric rover)
    assert both.F_max["obstacle_left_front"] > 0 and both.F_max["obstacle_right_front"] > 0
    # a rock in front of the left front wheel: only that wheel is loaded
    assert one.F_max["obstacle_left_front"] > 0
    assert all(v == 0.0 for k, v in one.F_max.items() if k != "obstacle_left_front")
    # one wheel carries less effective energy than two wheels hitting together
    assert one.T_c_minus < both.T_c_minus


def test_unknown_obstacle_wheel(rover):
    with pytest.raises(ri.ConfigError, match="obstacle_wheels: unknown or empty wheel list"):
        simulate_impact(rover, {"speed": 0.3, "beta_deg": 60.0, "obstacle_wheels": ["nose"]})
