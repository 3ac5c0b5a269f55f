"""CLI: `roverimpact energy` and `roverimpact draw` on the shipped examples and bad input."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from roverimpact.cli import main
from roverimpact.scenario import energy_of, load_scenario

EX = Path(__file__).resolve().parents[1] / "examples"


def test_energy_json_matches_library(capsys):
    f = EX / "rocker_bogie_beta30.toml"
    assert main(["energy", str(f), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    e = energy_of(load_scenario(f))
    assert out["T_c_minus"] == pytest.approx(float(e.T_c_minus))
    assert out["labels"][-1] == "obstacle:left_front:normal"
    assert out["v_n"] == pytest.approx(0.2 * 0.5)


def test_energy_table_and_peak_force(capsys):
    assert main(["energy", str(EX / "rover2d_beta45.toml")]) == 0
    out = capsys.readouterr().out
    assert "T_c^-" in out and "m_eff" in out and "peak force" in out
    # the file says name = "hunt_crossley"; the table names the law as the registry does
    # (it printed the file's spelling, "peak force (hunt_crossley)")
    assert "peak force (hunt-crossley)" in out


def test_horizontal_face_prints_zero_not_minus_zero(capsys, tmp_path):
    """beta = 0: the rolling wheel does not approach the face (v_n = u sin 0 = 0). The
    table and the "no impact" line said "v_n = -0 m/s" and the JSON -0.0 (v_n = -(a v) of
    a v = +0.0); energy_of, sweep_energy and a study give +0.0."""
    import numpy as np

    from roverimpact.scenario import sweep_energy
    from roverimpact.studies import run_study

    f = tmp_path / "beta0.toml"
    f.write_text((EX / "rover2d_beta45.toml").read_text().replace("beta_deg = 45.0",
                                                                   "beta_deg = 0.0"))
    assert main(["energy", str(f)]) == 0
    out = capsys.readouterr().out
    assert "-0 m/s" not in out and "v_n = 0 m/s" in out
    assert main(["energy", str(f), "--json"]) == 0
    v_n = json.loads(capsys.readouterr().out)["v_n"]
    assert v_n == 0.0 and not np.signbit(v_n)
    sc = load_scenario(f)
    assert not np.signbit(float(energy_of(sc).v_n))
    assert not np.signbit(sweep_energy(sc, [0.0]).v_n).any()
    study = {"name": "flat face", "base": sc.model_dump(exclude_none=True),
             "grid": {"obstacle.beta_deg": [0.0, 30.0]}}
    table = run_study(study, tmp_path / "out").table
    assert not np.signbit(table["v_n"].to_numpy()).any()
    rb = {"name": "rocker-bogie block", "base": {
        "model": {"name": "rocker_bogie"}, "velocity": {"u": 0.2},
        "obstacle": {"wheel": "left_front", "beta_deg": 0.0}},     # model-changing block
        "grid": {"model.params.chassis_com_above_pivot": [0.05, 0.1, 0.15]}}
    table = run_study(rb, tmp_path / "rb").table
    assert (table["v_n"] == 0.0).all() and not np.signbit(table["v_n"].to_numpy()).any()


def test_draw_writes_png(tmp_path, capsys):
    deep = tmp_path / ("a_long_folder_name_" * 4)
    deep.mkdir()
    for name in ("rover2d_beta45", "rocker_bogie_beta30"):
        out = deep / f"{name}.png"
        assert main(["draw", str(EX / f"{name}.toml"), "-o", str(out)]) == 0
        assert out.stat().st_size > 10_000
        # the path on one line, never broken by the console's wrap
        assert f"wrote: {out}" in capsys.readouterr().out.splitlines()


@pytest.mark.parametrize("body,match", [
    ("[model]\nname='rover2d'\n[obstacle]\nwheel='front'\nbeta_deg=120\n", "beta_deg"),
    ("[model]\nname='rover2d'\n[obstacle]\nwheel='front'\nnormal=[0,0,0]\n", "non-zero"),
    ("[model]\nname='rover2d'\n[obstacle]\nwheel='nose'\nbeta_deg=10\n", "unknown wheel"),
    ("[model]\nname='rover2d'\nparams={wheel_radius=-0.1}\n[obstacle]\nwheel='front'\n"
     "beta_deg=10\n", "wheel_radius"),
    ("[model]\nname='rover2d'\n[obstacle\n", "malformed TOML"),
    ("[model]\nfile='missing.urdf'\n[obstacle]\nframe='a'\nnormal=[0,0,1]\n", "no such"),
])
def test_bad_input_exit_2_one_line(tmp_path, capsys, body, match):
    f = tmp_path / "s.toml"
    f.write_text(body)
    assert main(["energy", str(f)]) == 2
    err = capsys.readouterr().err
    assert match in err and "Traceback" not in err
