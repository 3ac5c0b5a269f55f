"""CLI ``roverimpact simulate`` and the scenario-file layer of the simulator."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from roverimpact.cli import main
from roverimpact.exceptions import ConfigError
from roverimpact.scenario import make_model, scenario_from_dict
from roverimpact.simulate import SimulationConfig


def simulation_from_dict(raw):
    """What ``roverimpact simulate`` does with a scenario file."""
    sc = scenario_from_dict(raw)
    return make_model(sc.model), SimulationConfig.from_scenario(sc)

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "simulate_rover2d.toml"


def test_cli_writes_table_summary_and_plot(tmp_path, capsys):
    assert main(["simulate", str(EXAMPLE), "-o", str(tmp_path), "--format", "csv"]) == 0
    out = capsys.readouterr().out
    assert "F_max" in out and "T_c^-" in out
    # the closing line names every file the run wrote (config.json and scenario.toml
    # were left out of it), on one line: rich wrapped it at the terminal's width, inside
    # a path, and a path copied from two lines does not exist
    wrote = next(ln for ln in out.splitlines() if ln.startswith("wrote: "))
    assert sorted(wrote.removeprefix("wrote: ").split(", ")) == sorted(
        str(p) for p in tmp_path.iterdir())
    table = pd.read_csv(tmp_path / "history.csv")
    summary = json.loads((tmp_path / "summary.json").read_text())
    # the summary peak is the refined maximum of the tabulated force (never below it)
    assert summary["F_max_total"] >= table["obstacle_front_fn"].max() * (1 - 1e-12)
    assert summary["F_max_total"] <= table["obstacle_front_fn"].max() * 1.01
    assert (tmp_path / "force_vs_time.png").stat().st_size > 1000
    # the input next to the outputs, by a fixed name, its path in the summary
    assert (tmp_path / "scenario.toml").read_text() == EXAMPLE.read_text()
    assert summary["scenario"] == str(EXAMPLE)
    # a user's own .toml in the folder is not an output: the next run refuses the folder
    # and keeps it (a "*.toml" pattern took it for the previous run's copy and deleted it)
    (tmp_path / "notes.toml").write_text("mine = 1\n")
    assert main(["simulate", str(EXAMPLE), "-o", str(tmp_path), "--format", "csv"]) == 2
    assert "notes.toml" in capsys.readouterr().err
    assert (tmp_path / "notes.toml").read_text() == "mine = 1\n"
    assert (tmp_path / "history.csv").is_file()


def test_cli_names_which_effective_mass_it_prints(tmp_path, capsys):
    """The table said "m_eff (obstacle normal) 14.2446 kg" beside T_c^- = 0.505938 J and
    v_n = 0.259808 m/s, and SimulationResult.m_eff's docstring "with the same
    constraints"; but 1/2 m v_n^2 of that mass is 0.481 J: it is the obstacle row's mass
    alone (others free), as `energy` labels it. Reference: numpy, 1 / (a M^-1 a^T) and
    2 T_c^- / v_n^2 from M and the rows at the simulator's pre-impact state."""
    from roverimpact.scenario import ImpactSetup, load_scenario
    from roverimpact.scenario.schema import ObstacleSpec
    from roverimpact.simulate import simulate_impact

    assert main(["simulate", str(EXAMPLE), "-o", str(tmp_path / "o"), "--no-plot"]) == 0
    out = capsys.readouterr().out
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert f"m_eff along n (obstacle row alone) {summary['m_eff']:.6g} kg" in " ".join(
        out.split())
    sc = load_scenario(EXAMPLE)
    mbm, cfg = make_model(sc.model), SimulationConfig.from_scenario(sc)
    r = simulate_impact(mbm, cfg)
    b = np.radians(sc.obstacle.beta_deg)
    n = (-np.sin(b), 0.0, np.cos(b))
    setup = ImpactSetup.from_state(mbm, r.q_minus, r.v_minus,
                                   obstacle=ObstacleSpec(wheel="front", normal=n),
                                   contacts=cfg.contacts.model_copy(
                                       update={"ground_wheels": ["rear"]}),
                                   constraints=cfg.constraints)
    assert list(setup.labels) == list(r.A_rows)
    a = setup.A[setup.obstacle_row]
    m_free = 1.0 / (a @ np.linalg.solve(setup.M, a))
    assert r.m_eff == pytest.approx(m_free, rel=1e-9)
    assert r.m_eff == pytest.approx(summary["m_eff"], rel=1e-6)
    m_held = 2.0 * r.T_c_minus / r.v_n**2
    assert abs(m_held / m_free - 1) > 0.03          # the two differ here (14.99 vs 14.24)


def test_cli_bad_value_is_one_line_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text(EXAMPLE.read_text().replace("k = 1.0e7               # N/m^1.5",
                                               "k = -5.0"))
    assert main(["simulate", str(bad), "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "error" in err and "Traceback" not in err


def test_scenario_tables_feed_the_config():
    raw = {"model": {"name": "rover2d"}, "obstacle": {"wheel": "front", "beta_deg": 30.0},
           "contact_law": {"name": "hertz", "k": 2e6}, "velocity": {"u": 0.7},
           "contacts": {"ground": "noslip", "locked": ["base_pitch"]}, "constraints": "all",
           "simulation": {"gravity": "moon"}}
    model, cfg = simulation_from_dict(raw)
    assert model.name == "rover2d"
    assert (cfg.beta_deg, cfg.speed, cfg.obstacle.name, cfg.obstacle.k, cfg.g) == (
        30.0, 0.7, "hertz", 2e6, 1.62)
    assert cfg.obstacle_wheels == ["front"] and cfg.constraints == "all"
    assert (cfg.contacts.ground, cfg.contacts.locked) == ("noslip", ["base_pitch"])


def test_a_simulation_file_is_a_scenario(tmp_path, capsys):
    """Every command reads the same file: `energy` on the simulation example."""
    assert main(["energy", str(EXAMPLE)]) == 0
    assert "T_c^-" in capsys.readouterr().out


_OBS = {"wheel": "front", "beta_deg": 60.0}
_U = {"u": 0.3}


@pytest.mark.parametrize("raw,match", [
    ({"obstacle": _OBS, "velocity": _U, "simulation": {}}, "model: Field required"),
    ({"model": {"name": "rover2d"}, "obstacle": _OBS, "simulaton": {}},
     "simulaton: unknown key"),
    ({"model": {"name": "rover2d"}, "obstacle": _OBS, "velocity": _U,
      "simulation": {"t_max": -1}}, "t_max"),
    ({"model": {"name": "tank"}, "obstacle": _OBS}, "model.name"),
    ({"model": {"name": "rover2d"}, "obstacle": _OBS, "simulation": {"speed": 0.3}},
     r"simulation.speed: the driving speed is \[velocity\] u"),
    ({"model": {"name": "rover2d"}, "obstacle": _OBS}, "velocity.u > 0"),
    ({"model": {"name": "rover2d"}, "obstacle": {"wheel": "front", "normal": [-1, 0, 0]},
      "velocity": _U}, "needs obstacle.beta_deg"),
    ({"model": {"name": "rover2d"}, "obstacle": {"frame": "chassis", "beta_deg": 60.0},
      "velocity": _U}, "needs obstacle.wheel"),
])
def test_bad_simulation_files(raw, match):
    with pytest.raises(ConfigError, match=match):
        simulation_from_dict(raw)


def test_scenario_constraint_choice_reaches_the_indicator():
    """contacts.ground = "noslip" adds tangential ground rows to T_c^-'s A, as the
    scenario layer does; more constraints can only raise T_c (a larger SCM)."""
    from roverimpact.simulate import simulate_impact

    base = {"model": {"name": "rover2d", "params": {"suspension": "rocker"}},
            "velocity": {"u": 0.3}, "obstacle": {"wheel": "front", "beta_deg": 90.0},
            "constraints": "all", "simulation": {"t_after": 0.05}}
    m1, c1 = simulation_from_dict(base)
    m2, c2 = simulation_from_dict({**base, "contacts": {"ground": "noslip"}})
    assert (c1.contacts.ground, c2.contacts.ground) == ("normal", "noslip")
    r1, r2 = simulate_impact(m1, c1), simulate_impact(m2, c2)
    assert "ground:rear:long" in r2.A_rows and "ground:rear:long" not in r1.A_rows
    assert r2.T_c_minus >= r1.T_c_minus - 1e-12
    assert r1.F_max_total == pytest.approx(r2.F_max_total, rel=1e-12)  # same run


def test_indicator_rows_match_the_scenario_constraint_set():
    """T_c^- of the run equals partition(M, A) with A from the models' ConstraintSet (the
    scenario layer's own row builder) at the recorded pre-impact state."""
    from roverimpact import partition
    from roverimpact.models.constraints import GroundContact, PointContact
    from roverimpact.models.kinematics import ConstraintSet
    from roverimpact.simulate import simulate_impact

    model, cfg = simulation_from_dict(
        {"model": {"name": "rover2d", "params": {"suspension": "rocker"}},
         "contacts": {"ground": "noslip"}, "obstacle": {"wheel": "front", "beta_deg": 70.0},
         "constraints": "all", "velocity": {"u": 0.3}, "simulation": {"t_after": 0.05}})
    r = simulate_impact(model, cfg)
    wheels = {w.name: w for w in model.wheels}
    front, rear = wheels["front"], wheels["rear"]
    assert r.contact_wheel == "front"
    n = (-np.sin(np.radians(70.0)), 0.0, np.cos(np.radians(70.0)))
    cset = ConstraintSet(model, [GroundContact(rear, noslip=True, planar=True),
                                 PointContact(front.name, front.frame, n, wheel=front)])
    assert list(cset.labels) == r.A_rows
    M, A = cset.evaluate(r.q_minus)
    assert r.T_c_minus == pytest.approx(float(partition(M, A, r.v_minus).T_c), rel=1e-9)


ROCKER = {"model": {"name": "rover2d", "params": {"suspension": "rocker"}},
          "velocity": {"u": 0.3}, "obstacle": {"wheel": "front", "beta_deg": 60.0},
          "simulation": {"t_after": 0.03}}


def _rocker_angle(result, model):
    j = model.model.joints[model.model.getJointId("rocker")]
    return result.history[f"q_{j.idx_q}"].to_numpy()


def test_locked_joint_is_held_by_the_simulator():
    """contacts.locked holds the rocker in the run as in the indicator's rows."""
    from roverimpact.simulate import simulate_scenario

    free = simulate_scenario(scenario_from_dict(ROCKER))
    sc = scenario_from_dict({**ROCKER, "contacts": {"locked": ["rocker"]}})
    locked = simulate_scenario(sc)
    model = make_model(sc.model)
    a_free, a_locked = _rocker_angle(free, model), _rocker_angle(locked, model)
    assert np.ptp(a_free) > 1e-3                      # the free rocker swings in the impact
    assert np.ptp(a_locked) < 1e-6                    # the locked one does not
    assert "lock:rocker" in locked.A_rows and "lock:rocker" not in free.A_rows


def test_simulate_starts_from_the_scenario_configuration():
    from roverimpact.simulate import simulate_scenario

    nominal = make_model(scenario_from_dict(ROCKER).model).params["q_nominal"]
    z0 = nominal[1] + 0.01  # the chassis 1 cm above its nominal height (wheels on z = 0)
    sc = scenario_from_dict({**ROCKER, "configuration": {"base": {"z": z0}},
                             "simulation": {"t_after": 0.03, "settle": False}})
    r = simulate_scenario(sc)
    assert r.history["q_1"].iloc[0] == pytest.approx(z0, abs=1e-12)


def test_a_start_inside_the_ground_is_refused():
    from roverimpact.exceptions import InputError
    from roverimpact.simulate import simulate_scenario

    nominal = make_model(scenario_from_dict(ROCKER).model).params["q_nominal"]
    sc = scenario_from_dict({**ROCKER, "configuration": {"base": {"z": nominal[1] - 0.2}},
                             "simulation": {"settle": False}})
    with pytest.raises(InputError, match=r"wheel '(front|rear)' starts 0.2\d* m inside the ground"):
        simulate_scenario(sc)
