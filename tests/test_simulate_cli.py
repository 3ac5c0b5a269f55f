"""CLI ``roverimpact simulate`` and the scenario-file layer of the simulator."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest

from roverimpact.cli import main
from roverimpact.exceptions import ConfigError
from roverimpact.simulate._files import simulation_from_dict

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "simulate_rover2d.toml"


def test_cli_writes_table_summary_and_plot(tmp_path, capsys):
    assert main(["simulate", str(EXAMPLE), "-o", str(tmp_path), "--format", "csv"]) == 0
    out = capsys.readouterr().out
    assert "F_max" in out and "T_c^-" in out
    table = pd.read_csv(tmp_path / "history.csv")
    summary = json.loads((tmp_path / "summary.json").read_text())
    # the summary peak is the refined maximum of the tabulated force (never below it)
    assert summary["F_max_total"] >= table["obstacle_front_fn"].max() * (1 - 1e-12)
    assert summary["F_max_total"] <= table["obstacle_front_fn"].max() * 1.01
    assert (tmp_path / "force_vs_time.png").stat().st_size > 1000
    assert (tmp_path / EXAMPLE.name).is_file()          # inputs next to outputs


def test_cli_bad_value_is_one_line_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text(EXAMPLE.read_text().replace("k = 1.0e7               # N/m^1.5",
                                               "k = -5.0"))
    assert main(["simulate", str(bad), "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "error" in err and "Traceback" not in err


def test_scenario_tables_feed_the_config():
    raw = {"model": {"name": "rover2d"}, "obstacle": {"beta_deg": 30.0},
           "contact_law": {"name": "hertz", "k": 2e6}, "velocity": {"u": 0.7},
           "simulation": {"gravity": "moon"}}
    model, cfg = simulation_from_dict(raw)
    assert model.name == "rover2d"
    assert (cfg.beta_deg, cfg.speed, cfg.obstacle.law, cfg.obstacle.k, cfg.g) == (
        30.0, 0.7, "hertz", 2e6, 1.62)


@pytest.mark.parametrize("raw,match", [
    ({"simulation": {}}, "missing \\[model\\]"),
    ({"model": {"name": "rover2d"}, "simulaton": {}}, "unknown table"),
    ({"model": {"name": "rover2d"}, "simulation": {"t_max": -1}}, "t_max"),
    ({"model": {"name": "tank"}}, "unknown model.name"),
])
def test_bad_simulation_files(raw, match):
    with pytest.raises(ConfigError, match=match):
        simulation_from_dict(raw)
