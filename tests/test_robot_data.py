"""Real robot descriptions from the example-robot-data wheel load through Pinocchio."""

import numpy as np
import pinocchio as pin
import pytest

import roverimpact as ri
from roverimpact.models.robot_data import example_robot_urdf


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_example_robot_loads_and_has_spd_mass_matrix(name):
    model = pin.buildModelFromUrdf(str(example_robot_urdf(name)))
    data = model.createData()
    q = pin.neutral(model)
    M = pin.crba(model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    assert model.nv >= 6
    # the partition accepts the real mass matrix; a joint-space row gives m_eff = 1/(M^-1)_ii
    a = np.zeros(model.nv)
    a[0] = 1.0
    assert ri.effective_mass(M, a) == pytest.approx(1.0 / np.linalg.inv(M)[0, 0], rel=1e-10)


def test_unknown_robot():
    with pytest.raises(ri.ModelError, match="no robot 'nope'"):
        example_robot_urdf("nope")
