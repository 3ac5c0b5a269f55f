"""Real robot descriptions from the example-robot-data wheel load through Pinocchio."""

import numpy as np
import pinocchio as pin
import pytest

import roverimpact as ri
from roverimpact.models.robot_data import ROBOTS, example_robot_urdf


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


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_every_short_name_loads_with_pinocchios_mass_matrix(name):
    """Each short name of ROBOTS loads through load_robot ("erd:ur3" named ur3.urdf, an
    empty <robot> without a name: 'Pinocchio cannot build a model from it'), and its M is
    plain Pinocchio's of the same file."""
    mbm = ri.load_robot(f"erd:{name}")
    ref = pin.buildModelFromUrdf(str(example_robot_urdf(name)))
    assert mbm.model.nv == ref.nv >= 6
    q = pin.neutral(ref) + 0.3
    np.testing.assert_allclose(pin.crba(mbm.model, mbm.model.createData(), q),
                               pin.crba(ref, ref.createData(), q), rtol=1e-14, atol=0)


def test_unknown_robot():
    with pytest.raises(ri.ModelError, match="no robot 'nope'"):
        example_robot_urdf("nope")
    # a family name without a URDF of that stem lists the package's files that contain it
    with pytest.raises(ri.ModelError, match=r"no robot 'talos' .*URDFs whose name contains "
                                            r"it: \[.*'talos_reduced'"):
        example_robot_urdf("talos")


def test_both_spellings_name_the_same_file():
    """``erd:<name>`` (CLI, README) and ``example-robot-data:<name or path>`` (scenario
    files) resolve to the same URDF, by short name or by path inside the package."""
    from roverimpact.models.robot_data import example_robot_file, is_example_robot

    path = example_robot_urdf("panda")
    for spec in ("erd:panda", "example-robot-data:panda",
                 "example-robot-data:panda_description/urdf/panda.urdf",
                 "erd:panda_description/urdf/panda.urdf"):
        assert is_example_robot(spec)
        assert example_robot_file(spec) == path
    assert not is_example_robot("panda.urdf")
    assert not is_example_robot("examples/erd:panda")


def test_load_robot_takes_both_spellings():
    a = ri.load_robot("erd:ur5").model
    b = ri.load_robot("example-robot-data:ur_description/urdf/ur5_robot.urdf").model
    q = pin.neutral(a) + 0.3
    Ma = pin.crba(a, a.createData(), q)
    assert a.nv == b.nv == 6
    np.testing.assert_array_equal(Ma, pin.crba(b, b.createData(), q))
    with pytest.raises(ri.ModelError, match="no such URDF/MJCF file"):
        ri.load_robot("/nonexistent.urdf")


def test_stems_of_urdfs_kept_under_robots_folders():
    """The docstring's own example, "solo", and the other URDFs the package keeps under
    ``<robot>_description/robots/`` (solo12, tiago, kinova, talos_*) are found by stem (only
    ``*/urdf/`` was searched)."""
    for name in ("solo", "solo12", "kinova"):
        path = example_robot_urdf(name)
        assert path.name == f"{name}.urdf" and path.parent.name == "robots"
    model = ri.load_robot("erd:solo").model
    assert model.nv >= 8
