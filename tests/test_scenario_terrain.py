"""``[terrain]`` in a scenario: the rover posed on it, ground rows along its normals, the
velocity following it.

Independent checks:

- rotation invariance: a rover driving up a uniform 10 deg slope into a face at
  beta = 45 deg (beta from the horizontal, as always) is the flat-ground impact at
  beta = 35 deg seen in a rotated frame: same T_c^- (M is invariant, every row and the
  velocity rotate together). The sloped scenario is posed by the pose solver, its
  velocity from the driven poses; the flat one by the built-in model's own nominal pose.
- the same terrain three ways (a plane, a height-field file sampled from it, a Python
  function) and per-wheel planes equal to it give the same T_c^-;
- on a bumpy height field every touching wheel's contact point moves along the terrain
  (n^T J_p v = 0 to the finite-difference error), and the rover moves at u.
"""

from __future__ import annotations

import numpy as np
import pytest

import roverimpact as ri
from roverimpact.cli import main
from roverimpact.exceptions import ConfigError
from roverimpact.models.constraints import point_jacobian
from roverimpact.models.pose import wheel_contacts
from roverimpact.models.terrain import HeightField
from roverimpact.scenario.build import configuration, velocity

SLOPE = np.radians(10.0)
UP = [-np.sin(SLOPE), 0.0, np.cos(SLOPE)]     # ground rising forward (+x)

RB = {"model": {"name": "rocker_bogie"}, "velocity": {"u": 0.3},
      "obstacle": {"wheel": "left_front", "beta_deg": 45.0}}
RV = {"model": {"name": "rover2d"}, "velocity": {"u": 0.3},
      "obstacle": {"wheel": "front", "beta_deg": 45.0}}


def _T(raw) -> float:
    return float(ri.energy_of(ri.Scenario.model_validate(raw)).T_c_minus)


@pytest.mark.parametrize("base", [RB, RV], ids=["rocker_bogie", "rover2d"])
def test_uniform_slope_is_the_flat_impact_rotated(base):
    flat = {**base, "obstacle": {**base["obstacle"], "beta_deg": 35.0}}
    sloped = {**base, "terrain": {"plane": {"normal": UP}}}
    assert _T(sloped) == pytest.approx(_T(flat), rel=1e-9)
    # and on an empty [terrain] (the plane z = 0) nothing changes
    assert _T({**base, "terrain": {}}) == pytest.approx(_T(base), rel=1e-12)


def test_uniform_slope_velocity_is_a_translation_along_it():
    setup = ri.ImpactSetup.from_scenario(ri.Scenario.model_validate(
        {**RV, "terrain": {"plane": {"normal": UP}}}))
    vx, vz, pitch_rate = setup.v[:3]
    assert vx == pytest.approx(0.3 * np.cos(SLOPE), rel=1e-6)
    assert vz == pytest.approx(0.3 * np.sin(SLOPE), rel=1e-6)
    assert abs(pitch_rate) < 1e-9
    assert float(setup.partition().T) == pytest.approx(
        float(ri.energy_of(ri.Scenario.model_validate(RV)).T), rel=1e-9)


@pytest.mark.parametrize("base", [RB, RV], ids=["rocker_bogie", "rover2d"])
def test_terrain_at_an_absolute_elevation_is_the_same_impact(base, tmp_path):
    """Ground raised by 1500 m (a DEM in absolute elevations, as a .npy file) or a plane
    20 m up: the same impact as on the ground at 0 (translation invariance: M, the rows
    and the velocity do not change). Before, the rover was not placed ("did not converge
    in 50 steps") since its nominal pose was 20 m or 1500 m off the ground."""
    want = _T(base)
    assert _T({**base, "terrain": {"plane": {"point": [0.0, 0.0, 20.0]}}}) == pytest.approx(
        want, rel=1e-9)
    x = np.arange(-3.0, 3.0 + 1e-9, 0.1)
    np.save(tmp_path / "dem.npy", np.full((41, x.size), 1500.0))
    path = tmp_path / "sc.toml"
    _write(path, {**base, "terrain": {"file": "dem.npy", "spacing": 0.1,
                                      "origin": [-3.0, -2.0]}})
    assert float(ri.energy_of(ri.load_scenario(path)).T_c_minus) == pytest.approx(
        want, rel=1e-9)


def _plane_h(x, y):
    return np.tan(SLOPE) * np.asarray(x) + 0.0 * np.asarray(y)


def test_same_terrain_as_plane_file_function_and_per_wheel_planes(tmp_path):
    want = _T({**RB, "terrain": {"plane": {"normal": UP}}})
    x = np.arange(-3.0, 3.0 + 1e-9, 0.1)
    y = np.arange(-2.0, 2.0 + 1e-9, 0.1)
    Z = _plane_h(x[None, :], y[:, None])
    np.save(tmp_path / "slope.npy", Z)
    np.savetxt(tmp_path / "slope.csv", Z, delimiter=",")
    (tmp_path / "my_ground.py").write_text(
        "import numpy as np\n"
        f"def h(x, y):\n    return {np.tan(SLOPE)!r} * np.asarray(x) + 0.0 * np.asarray(y)\n")
    for terrain in ({"file": "slope.npy", "spacing": 0.1, "origin": [-3.0, -2.0]},
                    {"file": "slope.csv", "spacing": [0.1, 0.1], "origin": [-3.0, -2.0]},
                    {"function": "my_ground.py:h"}):
        path = tmp_path / "sc.toml"
        _write(path, {**RB, "terrain": terrain})
        assert float(ri.energy_of(ri.load_scenario(path)).T_c_minus) == pytest.approx(
            want, rel=1e-7), terrain
    # one plane under each wheel, the same plane: heights at each wheel's x
    mbm = ri.models.rocker_bogie()
    q = configuration(mbm, ri.Scenario.model_validate(RB).configuration)
    # each wheel's plane passes through `height` below its centre at the guess
    import pinocchio as pin

    data = mbm.model.createData()
    pin.framesForwardKinematics(mbm.model, data, q)
    wheels = {w.name: {"height": float(np.tan(SLOPE) * data.oMf[mbm.model.getFrameId(
        w.frame)].translation[0]), "normal": UP} for w in mbm.wheels}
    assert _T({**RB, "terrain": {"wheels": wheels}}) == pytest.approx(want, rel=1e-9)


def test_north_up_geotiff_in_projected_coordinates(tmp_path):
    """A north-up GeoTIFF of the plane z = 1500 + 0.1 (x - X0) + 0.05 (y - Y0) in UTM-like
    coordinates (rows from north to south) gives the T_c^- of the same plane as a
    PlaneTerrain (the y slope flipped would give 0.109 J, not 0.098 J: the row order is
    checked); with the rover left at its nominal (0, 0) the error says to place it by
    [configuration.base] x, y (before, only 'outside the height field (... y in
    [4.19999e+06, 4.2e+06] m)', the extent rounded to 6 digits)."""
    tifffile = pytest.importorskip("tifffile")
    X0, Ytop, s, nx, ny = 500000.0, 4200000.0, 0.05, 200, 160
    xc = X0 + (np.arange(nx) + 0.5) * s
    yc = Ytop - (np.arange(ny) + 0.5) * s            # row 0 = north
    Z = 1500.0 + 0.1 * (xc[None, :] - X0) + 0.05 * (yc[:, None] - Ytop)
    tifffile.imwrite(tmp_path / "dem.tif", Z, extratags=[
        (33550, "d", 3, (s, s, 0.0), False), (33922, "d", 6, (0, 0, 0, X0, Ytop, 0), False),
        (34735, "H", 8, (1, 1, 0, 1, 1025, 0, 1, 1), False)])
    with pytest.raises(ConfigError, match=r"y in \[4199992.025, 4199999.975\] m.*give x and "
                                          r"y inside the terrain"):
        _T({**RB, "terrain": {"file": str(tmp_path / "dem.tif")}})
    at = {"base": {"x": X0 + 5.0, "y": Ytop - 4.0}}
    got = _T({**RB, "configuration": at, "terrain": {"file": str(tmp_path / "dem.tif")}})
    plane = {"point": [X0, Ytop, 1500.0], "normal": [-0.1, -0.05, 1.0]}
    assert got == pytest.approx(_T({**RB, "configuration": at, "terrain": {"plane": plane}}),
                                rel=1e-7)


def _write(path, raw):
    import tomli_w

    path.write_bytes(tomli_w.dumps(raw).encode())


def test_bumpy_height_field_wheels_roll_along_it():
    """A seeded rough height field: the posed rover's wheels touch (gap < 1e-9 m) and
    their contact points move along the terrain (n^T v_p = 0 to the central difference's
    O(h^2)), the base at u."""
    rng = np.random.default_rng(3)
    Z = 0.03 * rng.standard_normal((41, 61))
    hf = HeightField(Z, 0.1, origin=(-3.0, -2.0))
    sc = ri.Scenario.model_validate({**RB, "obstacle": {"wheel": "left_front",
                                                         "beta_deg": 60.0}})
    mbm = ri.models.rocker_bogie()
    from roverimpact.scenario.ground import driving_velocity, pose_scenario
    from roverimpact.scenario.schema import TerrainSpec

    spec = TerrainSpec()
    q0 = configuration(mbm, sc.configuration)
    q = pose_scenario(mbm, hf, q0, spec)
    v0 = velocity(mbm, q, sc.velocity)
    v = driving_velocity(mbm, hf, q, v0, 0.3, spec)
    wc = wheel_contacts(mbm, hf, q)
    assert np.abs(wc.gap).max() < 1e-9
    import pinocchio as pin

    data = mbm.model.createData()
    pin.computeJointJacobians(mbm.model, data, q)
    pin.updateFramePlacements(mbm.model, data)
    for k, w in enumerate(mbm.wheels):
        fid = mbm.model.getFrameId(w.frame)
        Jp = point_jacobian(mbm.model, data, fid, wc.point[k] - data.oMf[fid].translation)
        # error budget: O(h^2) curvature terms and the pose tolerance over the step
        # (1e-9 m / 1e-4 m per metre of travel)
        assert abs(wc.normal[k] @ Jp @ v) < 1e-5 * 0.3, w.name
    assert np.linalg.norm(v[:3]) == pytest.approx(0.3, rel=1e-12)   # body-frame linear


def test_terrain_errors_are_named(tmp_path):
    with pytest.raises(ConfigError, match="left_fornt"):
        _T({**RB, "terrain": {"wheels": {"left_fornt": {"height": 0.1}}}})
    with pytest.raises(ConfigError, match=r"'left_middle' is .* above the terrain"):
        _T({**RB, "terrain": {"pose": False, "wheels": {"left_middle": {"height": -0.05}}}})
    with pytest.raises(ConfigError, match="no such file"):
        _T({**RB, "terrain": {"file": str(tmp_path / "none.npy"), "spacing": 0.1}})
    with pytest.raises(ValueError, match="spacing"):
        ri.Scenario.model_validate({**RB, "terrain": {"file": "x.npy"}})
    with pytest.raises(ValueError, match="one of"):
        ri.Scenario.model_validate({**RB, "terrain": {"file": "x.npy", "spacing": 0.1,
                                                       "function": "m:h"}})
    # keys that would be ignored: a GeoTIFF's own spacing and origin, an origin without a
    # height-field file (before, silently: the terrain was not where the user put it)
    for terrain, word in (({"file": "dem.tif", "spacing": 0.5}, "terrain.spacing: a GeoTIFF"),
                          ({"file": "dem.TIFF", "origin": [100.0, 0.0]},
                           "terrain.origin: a GeoTIFF"),
                          ({"function": "m:h", "origin": [1.0, 2.0]},
                           "terrain.origin applies to a height-field file only"),
                          ({"plane": {"normal": UP}, "origin": [1.0, 2.0]},
                           "terrain.origin applies")):
        with pytest.raises(ValueError, match=word):
            ri.Scenario.model_validate({**RB, "terrain": terrain})
    with pytest.raises(ConfigError, match="cannot import 'no_such_module_here'"):
        _T({**RB, "terrain": {"function": "no_such_module_here:h"}})
    # a rigid 2-D rover (wheelbase 0.6 m) cannot stand on planes 2 m apart in height
    with pytest.raises(ConfigError, match="cannot be placed"):
        _T({**RV, "terrain": {"wheels": {"front": {"height": 1.0},
                                         "rear": {"height": -1.0}}}})


def test_cli_energy_and_simulate_with_terrain(tmp_path, capsys):
    np.save(tmp_path / "slope.npy", _plane_h(np.arange(-3, 3.01, 0.1)[None, :],
                                             np.arange(-2, 2.01, 0.1)[:, None]))
    path = tmp_path / "sc.toml"
    _write(path, {**RB, "terrain": {"file": "slope.npy", "spacing": 0.1,
                                    "origin": [-3.0, -2.0]},
                  "simulation": {"t_after": 0.01}})
    assert main(["energy", str(path), "--json"]) == 0
    capsys.readouterr()
    # the simulator drives on the terrain too (tests/test_simulate_terrain.py)
    assert main(["simulate", str(path), "-o", str(tmp_path / "sim"), "--no-plot"]) == 0
    assert (tmp_path / "sim" / "summary.json").exists()


def test_given_pose_velocity_is_the_admissible_part_scaled_to_u():
    """pose = false with the configuration of the posed rover (written as [configuration]
    base z and pitch): the velocity is projected on the motions that keep the wheels on
    the slope and scaled to u: on a uniform slope the same translation, so the same
    T_c^- as the flat impact at beta - 10 deg."""
    sloped = {**RV, "terrain": {"plane": {"normal": UP}}}
    q = ri.ImpactSetup.from_scenario(ri.Scenario.model_validate(sloped)).q
    given = {**RV, "terrain": {"plane": {"normal": UP}, "pose": False},
             "configuration": {"base": {"x": 0.0, "z": float(q[1]),
                                        "pitch_deg": float(np.degrees(q[2]))}}}
    flat = {**RV, "obstacle": {**RV["obstacle"], "beta_deg": 35.0}}
    assert _T(given) == pytest.approx(_T(flat), rel=1e-9)


def test_a_driven_pose_that_fails_is_named_as_a_pose_of_its_own(monkeypatch):
    """The driving velocity places its two moved poses in one solve; when that solve
    fails, the pose is named as on its own (the message of one pose, no "pose 1 of 2"
    of an internal batch), and a batch that fails where each pose alone succeeds still
    gives the velocity."""
    import roverimpact.models.pose as pose_mod
    from roverimpact.models.pose import PoseError

    sloped = {**RB, "terrain": {"plane": {"normal": UP}}}
    want = ri.ImpactSetup.from_scenario(ri.Scenario.model_validate(sloped)).v
    real = pose_mod.pose_on_terrain

    def batch_fails(mbm, terrain, q_guess=None, **kw):
        if np.ndim(q_guess) == 2:
            raise PoseError("pose 1 of 2 (1 failed; check=False returns them all): no", None)
        return real(mbm, terrain, q_guess, **kw)

    monkeypatch.setattr(pose_mod, "pose_on_terrain", batch_fails)
    got = ri.ImpactSetup.from_scenario(ri.Scenario.model_validate(sloped)).v
    np.testing.assert_array_equal(got, want)

    calls = []

    def second_fails(mbm, terrain, q_guess=None, **kw):
        calls.append(np.ndim(q_guess))
        if np.ndim(q_guess) == 2 or len(calls) == 4:  # the pose, the batch, then one by one
            raise PoseError("pose 1 of 2 (1 failed; check=False returns them all): no"
                            if np.ndim(q_guess) == 2 else "the wheels cannot all touch", None)
        return real(mbm, terrain, q_guess, **kw)

    monkeypatch.setattr(pose_mod, "pose_on_terrain", second_fails)
    with pytest.raises(ConfigError, match="cannot be placed") as err:
        ri.ImpactSetup.from_scenario(ri.Scenario.model_validate(sloped))
    assert "pose 1 of 2" not in str(err.value) and "cannot all touch" in str(err.value)
