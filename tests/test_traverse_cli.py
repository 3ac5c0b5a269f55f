"""``roverimpact traverse`` end to end on a short path, the traverse file's schema, the
report; bad input is in tests/test_cli_bad_input.py. The numbers are those of
tests/test_traverse_compute.py's pipeline: this proves the wiring (files, tables, the
progress bar, Dask), not the physics."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from roverimpact.cli import main
from roverimpact.exceptions import ConfigError
from roverimpact.traverse.path import stations
from roverimpact.traverse.run import run_traverse
from roverimpact.traverse.schema import load_traverse, traverse_from_dict

ROOT = Path(__file__).resolve().parents[1]

SHORT = """
name = "short"
[terrain]
size = [8.0, 4.0]
spacing = 0.05
origin = [-1.0, -2.0]
seed = 3
rock_abundance = 0.2
[path]
name = "a"
waypoints = [[0.5, 0.0], [3.0, 0.3], [5.5, 0.0]]
[model]
name = "rocker_bogie"
[drive]
speed = 0.1
v_max = 0.3
[limits]
F_allow = 100.0
[contact_law]
name = "hunt-crossley"
k = 1.0e7
e = 0.5
[band]
k = [3.0e6, 3.0e7]
[run]
chunk = 40
"""


@pytest.fixture(scope="module")
def short(tmp_path_factory):
    d = tmp_path_factory.mktemp("trav")
    f = d / "short.toml"
    f.write_text(SHORT)
    out = d / "out"
    assert main(["traverse", str(f), "-o", str(out), "--csv"]) == 0
    return f, out


@pytest.fixture(scope="module")
def serial(short):
    """The short traverse (chunks of 40 stations) run serially in this process, once: the
    reference of the tests that run it otherwise."""
    return run_traverse(load_traverse(short[0]))


def test_traverse_writes_tables_figures_report(short, capfd):
    f, out = short
    for name in ("poses.parquet", "wheels.parquet", "segments.parquet", "poses.csv",
                 "map.png", "map.svg", "speed.png", "report.html", "traverse.toml",
                 "manifest.json"):
        assert (out / name).is_file(), name
    P = pd.read_parquet(out / "poses.parquet")
    W = pd.read_parquet(out / "wheels.parquet")
    S = pd.read_parquet(out / "segments.parquet")
    st = stations([[0.5, 0.0], [3.0, 0.3], [5.5, 0.0]], 0.05)
    assert len(P) == len(st) and len(W) == 6 * len(st)
    assert P["s"].to_numpy() == pytest.approx(st.s)
    assert (P["status"] == "ok").mean() > 0.95
    hit = W[W["T_c_minus"] > 0]
    assert len(hit) > 20
    # the station's limit is the least of its wheels', capped by v_max
    lim = W.groupby("station")["v_lim"].min().clip(upper=0.3).to_numpy()
    assert P["v_lim"].to_numpy() == pytest.approx(lim, nan_ok=True)
    # the weight model (the default): its force within its band over k, its limit the
    # band's largest, at most the top speed
    assert (hit["F_lo"] <= hit["F_model"] * (1 + 1e-6)).all()
    assert (hit["F_model"] <= hit["F_hi"] * (1 + 1e-6)).all()
    assert (hit["v_lim_band"] <= hit["v_lim"] * (1 + 1e-6)).all()
    assert (hit["v_lim"] <= 0.3 * (1 + 1e-9)).all() and np.isfinite(hit["v_lim_closed"]).all()
    assert S["v_lim"].min() == pytest.approx(P["v_lim"].min())
    man = json.loads((out / "manifest.json").read_text())
    assert man["stations"] == len(P) and man["executor"] == "serial"
    html = (out / "report.html").read_text()
    assert "data:image/png;base64" in html and "Strongest impacts" in html
    # its redraw command names the output folder, not the staging folder it was drawn in
    # (it said "roverimpact traverse-report .out.partial-f8m0jc8v", a folder gone)
    assert f"<code>roverimpact traverse-report {out}</code>" in html
    assert ".partial" not in html
    # every number column of its tables has its unit ("distance" and "v_lim" had none)
    for head in ("distance [m]", "beta_deg [deg]", "T_c_minus [J]", "m_eff [kg]",
                 "v_n [m/s]", "F_model [N]", "v_lim [m/s]", "s0 [m]", "T_c_max [J]"):
        assert f"<th>{head}</th>" in html, head
    # the copy of the file reads back as the same traverse
    assert load_traverse(out / "traverse.toml") == load_traverse(f)


def test_json_and_report_regeneration(short, tmp_path, capfd):
    f, _ = short
    capfd.readouterr()
    assert main(["traverse", str(f), "-o", str(tmp_path / "j"), "--json", "--no-report"]) == 0
    captured = capfd.readouterr()
    data = json.loads(captured.out)
    assert data["summary"][0]["stations"] == len(stations([[0.5, 0.0], [3.0, 0.3],
                                                          [5.5, 0.0]], 0.05))
    # the progress bar is drawn on a terminal's stderr only: a pipe or a log gets neither
    # its last state nor anything in the JSON
    assert "ETA" not in captured.err and "ETA" not in captured.out
    assert not (tmp_path / "j" / "report.html").exists()
    assert main(["traverse-report", str(tmp_path / "j")]) == 0
    assert (tmp_path / "j" / "report.html").is_file()
    assert (tmp_path / "j" / "map.png").is_file()
    # an edited copy of the traverse file that no longer parses: one error, exit 2 (a
    # TOMLDecodeError traceback before)
    (tmp_path / "j" / "traverse.toml").write_text("[terrain\n")
    capfd.readouterr()
    assert main(["traverse-report", str(tmp_path / "j")]) == 2
    err = capfd.readouterr().err
    assert "traverse.toml: malformed TOML" in err and "Traceback" not in err


def test_report_refuses_an_edited_traverse_file(short, tmp_path, capfd):
    """traverse-report after the folder's traverse.toml was edited (F_allow 100 -> 500)
    wrote a report stating 500 N above tables computed for 100 N. The run stores the
    copy's SHA-256 in manifest.json; an edited copy is refused (exit 2, one line), the
    unedited one still reports."""
    import hashlib
    import shutil

    _, out = short
    d = tmp_path / "e"
    shutil.copytree(out, d)
    text = (d / "traverse.toml").read_text()
    man = json.loads((d / "manifest.json").read_text())
    assert man["config_sha256"] == hashlib.sha256(text.encode()).hexdigest()
    (d / "traverse.toml").write_text(text.replace("F_allow = 100.0", "F_allow = 500.0"))
    assert "F_allow = 500.0" in (d / "traverse.toml").read_text()
    capfd.readouterr()
    assert main(["traverse-report", str(d)]) == 2
    err = capfd.readouterr().err
    assert "traverse.toml was edited after the traverse ran" in err and "Traceback" not in err
    (d / "traverse.toml").write_text(text)
    assert main(["traverse-report", str(d)]) == 0


def test_dask_equals_serial(short, serial, monkeypatch):
    """Chunks of 40 stations on 2 forked workers (the cluster forced on: this traverse
    alone would not pay for one): the same tables as serially."""
    pytest.importorskip("dask.distributed")
    from roverimpact.studies import executors

    f, _ = short
    cfg = load_traverse(f)
    assert cfg.run.chunk == 40
    a = serial
    monkeypatch.setattr(executors, "worth_a_cluster", lambda *a, **k: True)
    b = run_traverse(cfg, workers=2)
    assert (a.executor, b.executor) == ("serial", "dask local 2 workers")
    pd.testing.assert_frame_equal(a.wheels, b.wheels)
    pd.testing.assert_frame_equal(a.poses, b.poses)


def test_bad_worker_start_method_fails_before_any_station(short, monkeypatch):
    pytest.importorskip("dask.distributed")
    from roverimpact.traverse import run as trun

    f, _ = short
    called = []
    monkeypatch.setattr(trun, "traverse_chunk", lambda *a: called.append(a))
    monkeypatch.setenv("ROVERIMPACT_WORKER_START", "threads")
    with pytest.raises(ConfigError, match="ROVERIMPACT_WORKER_START must be one of"):
        run_traverse(load_traverse(f), workers=2)
    assert not called


@pytest.mark.parametrize("workers, chunk, why", [
    (2, 40, "too small to pay for a 2-worker cluster"),
    (2, 500, "a single chunk"),
    (1, 40, "one worker is no faster"),
])
def test_small_traverse_runs_serially_and_says_so(short, serial, tmp_path, workers, chunk,
                                                  why, monkeypatch):
    """--workers on less work than a cluster's start-up (timed on a probe of a few
    stations), on one chunk, or with one worker: serial, no cluster started, the same
    tables; the note and the manifest say why. The start-up is taken as a minute: the
    short traverse's 2-3 s of work is near the real 1.5 s threshold on a slow machine
    (the probe's own estimate is tested in test_study_sweep.py)."""
    from roverimpact.studies import executors

    for method in executors.CLUSTER_START_S:
        monkeypatch.setitem(executors.CLUSTER_START_S, method, 60.0)
    f, _ = short
    cfg = load_traverse(f)
    cfg = cfg.model_copy(update={"run": cfg.run.model_copy(update={"chunk": chunk})})
    a = serial if chunk == 40 else run_traverse(cfg)     # SHORT's chunk is 40
    notes = []
    b = run_traverse(cfg, tmp_path / "w", workers=workers, note=notes.append)
    assert len(notes) == 1 and why in notes[0] and b.executor == notes[0]
    assert json.loads((tmp_path / "w" / "manifest.json").read_text())["executor"] == notes[0]
    pd.testing.assert_frame_equal(a.wheels, b.wheels)
    pd.testing.assert_frame_equal(a.poses, b.poses)


def test_schema_refusals():
    import tomllib

    base = tomllib.loads(SHORT)

    def bad(update, word):
        raw = json.loads(json.dumps(base))
        for k, v in update.items():
            tab, _, key = k.rpartition(".")
            (raw[tab] if tab else raw)[key] = v
        with pytest.raises(ConfigError, match=word):
            traverse_from_dict(raw)

    bad({"drive.warp": 2}, "unknown key")
    bad({"limits.T_allow": 0.1}, "exactly one of limits")
    bad({"path.start": [0, 0]}, "waypoints")
    bad({"path.waypoints": [[0, 0], [0, 0]]}, "coincide")
    bad({"terrain.seed": None}, "seed")
    bad({"terrain.kind": "file"}, "terrain.file")
    bad({"contact_law.e": 1.5}, "e")
    bad({"drive.speed": "0.1 m/s"}, "plain number")
    bad({"limits.gravity": "venus"}, "gravity preset")
    bad({"limits.model": "exact"}, "weight")
    bad({"limits.window": 0.0}, "window")
    # keys that would be ignored (they were, with no word)
    bad({"limits.F_allow": None, "limits.T_allow": 0.1, "limits.gravity": "mars"},
        r"limits.gravity: for limits.F_allow .* with limits.T_allow they would be ignored")
    bad({"limits.F_allow": None, "limits.T_allow": 0.1, "limits.model": "closed-form"},
        r"limits.model: for limits.F_allow")
    bad({"limits.model": "closed-form", "limits.window": 0.01, "limits.gravity": "moon"},
        r"limits.gravity, limits.window: for the weight model .* would be ignored")
    # the copy of a traverse file written before this check holds every default (and
    # traverse-report reads it): taken
    traverse_from_dict(dict(base, limits={"T_allow": 0.1, "model": "weight", "gravity":
                                          "earth", "window": 0.05,
                                          "ground_law": {"name": "hunt-crossley",
                                                         "k": 1.0e7, "e": 0.2}}))
    bad({"terrain.seed": -1}, "terrain.seed")
    bad({"terrain.rock_abundance": 1.0}, "rock_abundance")
    bad({"terrain.hurst": 1.2}, "hurst")
    bad({"drive.look_ahead": 0.04}, "look_ahead = 0.04 m is shorter than path 'a''s spacing")
    bad({"contacts": {"ground": "coulomb"}}, "needs contacts.mu")
    bad({"contacts": {"ground": "coulomb", "mu": -0.5}}, "mu must be >= 0")
    bad({"contacts": {"mu": 0.5}}, "mu is for ground")
    bad({"contacts": {"ground": "coulomb", "mu": 0.5}, "constraints": "all"},
        'needs constraints = "auto"')
    bad({"contacts": {"ground": "noslip", "mu": 0.5}}, "held")
    bad({"suspension": {"variables": {"chasis_com_above_pivot": [0.0, 0.2]}}},
        "'chasis_com_above_pivot': not a numeric parameter of rocker_bogie; choose from")
    bad({"suspension": {"variables": {"chassis_com_above_pivot": [0.2, 0.0]}}}, "lo < hi")
    # one beta would be the lower end of each segment's range (the optimiser refuses it,
    # and the refusal ended in segments.parquet's setting_note)
    bad({"suspension": {"variables": {"chassis_com_above_pivot": [0.0, 0.2]}, "n_beta": 1}},
        "n_beta")
    # a negative seed: numpy's ValueError in the middle of the run (a traceback), then the
    # optimiser's refusal in every segment's setting_note
    bad({"suspension": {"variables": {"chassis_com_above_pivot": [0.0, 0.2]}, "seed": -1}},
        "suspension.seed")
    for key, value in (("hurst", 0.5), ("rock_abundance", 0.3), ("seed", 1)):
        raw = json.loads(json.dumps(base))
        raw["terrain"] = {"kind": "file", "file": "dem.npy", "spacing": 0.05, key: value}
        with pytest.raises(ConfigError, match=f"terrain.{key}: for a synthetic terrain only"):
            traverse_from_dict(raw)
    for key, value in (("spacing", 0.05), ("origin", [0.0, 0.0])):
        raw = json.loads(json.dumps(base))
        raw["terrain"] = {"kind": "file", "file": "dem.tif", key: value}
        with pytest.raises(ConfigError, match=f"terrain.{key}: a GeoTIFF"):
            traverse_from_dict(raw)
    # accepted: what synthetic_mars accepts (hurst up to 1, no rocks), a look-ahead of one
    # spacing, mu with Coulomb friction
    raw = json.loads(json.dumps(base))
    raw["terrain"].update(hurst=1.0, rock_abundance=0.0)
    raw["drive"]["look_ahead"] = 0.05
    raw["contacts"] = {"ground": "coulomb", "mu": 0.5}
    cfg = traverse_from_dict(raw)
    assert cfg.terrain.synthetic_params()["rock_abundance"] == 0.0
    assert traverse_from_dict(base).terrain.synthetic_params()["hurst"] == 0.8
    raw = json.loads(json.dumps(base))
    del raw["contact_law"]
    del raw["band"]
    with pytest.raises(ConfigError, match="contact_law"):
        traverse_from_dict(raw)
    raw["paths"] = [raw["path"], raw["path"]]
    del raw["path"]
    raw["limits"] = {"T_allow": 0.01}
    with pytest.raises(ConfigError, match="names must differ"):
        traverse_from_dict(raw)
    # names that are different but give the same file names (map-<name>.png)
    raw["paths"] = [{**raw["paths"][0], "name": n} for n in ("route 1/a", "Route_1_A")]
    with pytest.raises(ConfigError, match=r"share the figure files map-route_1_a\.png"):
        traverse_from_dict(raw)


def test_path_names_with_a_slash(tmp_path, capfd):
    """Two [[paths]] named "route 1/a" and "route 1.5": the figures are map-route_1_a.png
    and map-route_1.5.png ..., the tables keep the names, and traverse-report redraws them
    (the traverse failed writing "map-route 1/a.png" after all its work, keeping nothing;
    "route 1.5" was drawn to map-route_1.png, and routes 1.5 and 1.7 to the same file)."""
    import tomllib

    raw = tomllib.loads(SHORT)
    del raw["path"], raw["band"], raw["contact_law"]
    raw["limits"] = {"T_allow": 0.01}
    raw["paths"] = [{"name": "route 1/a", "start": [0.5, 0.0], "end": [1.0, 0.0],
                     "spacing": 0.1},
                    {"name": "route 1.5", "start": [0.5, 0.5], "end": [1.0, 0.5],
                     "spacing": 0.1}]
    f = tmp_path / "t.toml"
    from roverimpact.traverse.run import _toml

    f.write_text(_toml(raw))
    out = tmp_path / "out"
    assert main(["traverse", str(f), "-o", str(out)]) == 0
    stems = ("map-route_1_a", "map-route_1.5", "speed-route_1_a", "speed-route_1.5")
    assert sorted(f.name for f in out.glob("*.svg")) == sorted(f"{s}.svg" for s in stems)
    assert sorted(f.name for f in out.glob("*.png")) == sorted(f"{s}.png" for s in stems)
    assert set(pd.read_parquet(out / "poses.parquet")["path"]) == {"route 1/a", "route 1.5"}
    assert "route 1/a" in (out / "report.html").read_text()
    for stem in stems:  # traverse-report draws them again from the tables
        (out / f"{stem}.png").unlink()
    assert main(["traverse-report", str(out)]) == 0
    assert sorted(f.name for f in out.glob("*.png")) == sorted(f"{s}.png" for s in stems)


def test_summary_table_at_80_columns():
    """At 80 columns (a terminal, a pipe, a log) no number is split over two lines and the
    path's name stays; the columns that do not fit are left out, and the caption says so.
    (Numbers were cut as "0.00521" + "1", the path column shrank to nothing.)"""
    import io

    from rich.console import Console

    from roverimpact.cli._traverse import _print_summary

    rows = [{"path": "straight", "length [m]": 0.8, "stations": 17, "failed poses": 0,
             "impacts": 18, "max T_c^- [J]": 0.005211, "max F_pred [N]": 42.15,
             "max F_model [N]": 59.39, "lowest limit [m/s]": 0.1764, "at s [m]": 0.65},
            {"path": "route 1/a rather long name", "length [m]": 1234.5, "stations": 24691,
             "failed poses": 3, "impacts": 12345, "max T_c^- [J]": 0.0123456,
             "max F_pred [N]": 1234.5, "max F_model [N]": 2345.6,
             "lowest limit [m/s]": float("inf"), "at s [m]": float("nan")}]
    table = pd.DataFrame(rows)
    for width in (80, 60):
        buf = io.StringIO()
        _print_summary(table, Console(width=width, file=buf, markup=False, emoji=False))
        text = buf.getvalue()
        assert max(len(line) for line in text.splitlines()) <= width
        lines = text.splitlines()
        body = [ln for ln in lines if ln.startswith((" straight", " route"))]
        assert body[0].split()[0] == "straight" and body[1].split()[:2] == ["route", "1/a"]
        for number in ("0.005211", "59.39", "0.1764", "12345", "2346"):
            assert any(number in ln.split() for ln in body), (width, number, text)
        assert "no limit" in body[1], (width, text)      # inf: not split either
        assert "left out at" in text
    buf = io.StringIO()
    _print_summary(table, Console(width=160, file=buf, markup=False, emoji=False))
    assert "left out" not in buf.getvalue() and "24691" in buf.getvalue()


def test_path_leaving_the_terrain_is_refused_before_work(tmp_path):
    raw = SHORT.replace("[5.5, 0.0]]", "[6.9, 0.0]]")
    f = tmp_path / "t.toml"
    f.write_text(raw)
    with pytest.raises(ConfigError, match="leaves the terrain"):
        run_traverse(f, tmp_path / "o")
    assert not (tmp_path / "o").exists()


def test_window_too_long_is_refused_and_too_short_is_flagged(short, tmp_path):
    """limits.window: a window whose frozen-pose range (half the smallest wheel radius in
    it: 0.05 m/s at 1 s) does not reach drive.speed is refused before any work (every
    limit was that range, 0.05 m/s, below the reference 0.1 m/s at which F_model was
    under F_allow); a window that ends while the force still rises flags those impacts
    (F_model_rising) and says so, their F_model being below the default window's."""
    import tomllib

    raw = tomllib.loads(SHORT)
    raw["limits"]["window"] = 1.0
    with pytest.raises(ConfigError, match=r"limits.window = 1 s.*up to 0.05 m/s"):
        run_traverse(raw, tmp_path / "o")
    assert not (tmp_path / "o").exists()
    _, out = short
    W0 = pd.read_parquet(out / "wheels.parquet")
    assert not W0["F_model_rising"].any()  # the default window holds every peak
    raw["limits"]["window"] = 0.001
    raw.pop("band")
    with pytest.warns(UserWarning, match=r"impact\(s\) still loading when limits.window"):
        res = run_traverse(raw)
    rising = res.wheels["F_model_rising"].to_numpy()
    assert rising.any()
    assert np.all(res.wheels["F_model"].to_numpy()[rising]
                  < W0["F_model"].to_numpy()[rising])


def test_closed_form_model_is_the_rigid_1dof_limit(short):
    """limits.model = "closed-form": the limits are the closed form's (the weight model's
    column v_lim_closed of the default run), no F_model column."""
    import tomllib

    _, out = short
    raw = tomllib.loads(SHORT)
    raw["limits"]["model"] = "closed-form"
    res = run_traverse(raw)
    W0 = pd.read_parquet(out / "wheels.parquet")
    assert "F_model" not in res.wheels and "v_lim_closed" not in res.wheels
    assert res.wheels["v_lim"].to_numpy() == pytest.approx(W0["v_lim_closed"].to_numpy(),
                                                           nan_ok=True)
    assert res.wheels["F_pred"].to_numpy() == pytest.approx(W0["F_pred"].to_numpy(),
                                                            nan_ok=True)


def test_examples_parse():
    for name in ("traverse_rocky.toml", "traverse_sparse.toml"):
        cfg = load_traverse(ROOT / "examples" / name)
        assert cfg.terrain.kind == "synthetic" and cfg.model.name == "rocker_bogie"


def test_height_field_file_terrain(tmp_path):
    """A .npy height field (a flat plane with one step) gives the step's impact."""
    x = np.arange(0, 6.0001, 0.02)
    y = np.arange(-1.5, 1.5001, 0.02)
    X, _ = np.meshgrid(x, y)
    z = np.where(X >= 3.4, 0.03, 0.0)
    np.save(tmp_path / "dem.npy", z)
    f = tmp_path / "t.toml"
    f.write_text(SHORT.split("[terrain]")[0] + '[terrain]\nkind = "file"\nfile = "dem.npy"\n'
                 "spacing = 0.02\norigin = [0.0, -1.5]\n" + "[path]" +
                 SHORT.split("[path]")[1].replace("[[0.5, 0.0], [3.0, 0.3], [5.5, 0.0]]",
                                                  "[[1.0, 0.0], [3.0, 0.0]]"))
    res = run_traverse(f)
    W = res.wheels
    front = W[(W["wheel"] == "left_front") & (W["T_c_minus"] > 0)]
    assert len(front) > 0
    # the step's edge at x = 3.4, met by the front wheels
    assert front["x_c"].to_numpy() == pytest.approx(3.4, abs=0.03)


def test_least_risk_suspension_per_segment(tmp_path):
    """[suspension]: every segment with an impact gets a setting within the bounds whose
    level-ground objective (the optimiser's own, re-evaluated) is not above the nominal's;
    a dict config's copy (traverse.toml) reads back as the same traverse."""
    import tomllib

    from roverimpact.studies.optimize import evaluate_setting, load_optimization
    from roverimpact.traverse.suspension import optimization_problem

    raw = tomllib.loads(SHORT)
    raw["path"]["waypoints"] = [[0.5, 0.0], [2.5, 0.0]]
    raw["drive"]["segment"] = 1.0
    raw["suspension"] = {"variables": {"chassis_com_above_pivot": [0.0, 0.2]},
                         "n_starts": 1, "n_beta": 3}
    res = run_traverse(raw, tmp_path / "o")
    S = res.segments
    done = S[S["setting_note"] == ""]
    assert len(done) >= 1
    v = done["set_chassis_com_above_pivot"].to_numpy()
    assert ((v >= 0.0) & (v <= 0.2)).all()
    assert (done["T_c_flat_best"] <= done["T_c_flat_nominal"] * (1 + 1e-9)).all()
    row = done.iloc[0]
    cfg = traverse_from_dict(raw)
    beta = (round(float(np.clip(row["beta_min_deg"], 1, 90)), 1),
            round(float(np.clip(row["beta_max_deg"], 1, 90)), 1))
    prob = load_optimization(optimization_problem(cfg, row["worst_wheel"], beta))
    rep = evaluate_setting(prob, {"chassis_com_above_pivot": row["set_chassis_com_above_pivot"]})
    assert rep.objective == pytest.approx(row["T_c_flat_best"], rel=1e-9)
    assert load_traverse(tmp_path / "o" / "traverse.toml") == cfg


@pytest.mark.parametrize("model, workers, scheduler, start, sent, here", [
    ("weight", None, None, "fork", ["impact_kernel", "stiff_peaks"],
     ["LANES", "masses_kernel", "rk4_peaks"]),
    ("closed-form", None, None, "fork", ["impact_kernel"], ["LANES", "masses_kernel"]),
    ("closed-form", 2, None, "fork", ["impact_kernel"],
     ["LANES", "masses_kernel", "impact_kernel"]),
    ("weight", 2, None, "spawn", [], []),
    ("weight", None, "tcp://127.0.0.1:1", "fork", [], []),
])
def test_traverse_compile_plan(tmp_path, monkeypatch, compile_plan, model, workers, scheduler,
                               start, sent, here):
    """On a fresh install the command compiles on two cores: Lemke's kernel (and the stiff
    pair when the weight model needs forces) in a second process, the lane partition, the
    effective masses (and the Runge-Kutta kernel) here, also before forking local workers
    (they inherit them);
    nothing for spawned workers or a scheduler's; a bad file fails before any of it."""
    from roverimpact.cli import _traverse

    monkeypatch.setenv("ROVERIMPACT_WORKER_START", start)

    example = Path(__file__).resolve().parents[1] / "examples" / "traverse_rocky.toml"
    text = example.read_text().replace("[limits]", f'[limits]\nmodel = "{model}"', 1)
    cfg = tmp_path / "t.toml"
    cfg.write_text(text)
    got = compile_plan.sent
    now = _traverse._compile_plan(cfg, workers, scheduler)
    assert got == sent
    assert [k.home.split(":")[1] for k in now] == here
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("[limits]", "[limits]\nspeedy = 1", 1))
    got.clear()
    with pytest.raises(ConfigError):
        _traverse._compile_plan(bad, None, None)
    assert got == []


def test_a_path_off_the_terrain_is_refused_before_any_compile(tmp_path, compile_plan, capfd):
    """A traverse whose path leaves the terrain compiled the lane partition, the effective
    masses and the Runge-Kutta kernel before checking it: on a fresh install the one-line
    error came after 45 s of compile. The inputs are checked first; the kernels are
    compiled once they pass (and still before any station)."""
    example = Path(__file__).resolve().parents[1] / "examples" / "traverse_rocky.toml"
    bad = tmp_path / "off.toml"
    bad.write_text(example.read_text().replace("[40.0, 0.0]]", "[41.5, 0.0]]"))
    capfd.readouterr()
    assert main(["traverse", str(bad), "-o", str(tmp_path / "o")]) == 2
    assert "leaves the terrain" in capfd.readouterr().err
    assert compile_plan.got == []
    f = _flat_traverse(tmp_path)          # a good one: compiled, then the stations
    assert main(["traverse", str(f), "-o", str(tmp_path / "ok"), "--no-report"]) == 0
    assert compile_plan.got[:2] == ["LANES", "masses_kernel"]


@pytest.mark.parametrize("end, n_seg, last", [(1.7, 2, (1.0, 1.7)), (2.0, 2, (1.0, 2.0)),
                                              (0.6, 1, (0.0, 0.6))])
def test_segments_end_at_the_end_of_the_path(end, n_seg, last):
    """The last segment ends where the path does: a 1.7 m path has the segments [0, 1] and
    [1, 1.7] (the last was [1, 2], past the end, and the speed figure drew its limit there),
    and the station at the very end of a 2 m path belongs to [1, 2] (it made a segment
    [2, 3] of its own)."""
    import tomllib

    from roverimpact.traverse.run import segments_table

    raw = traverse_from_dict(tomllib.loads(SHORT.replace("[[0.5, 0.0], [3.0, 0.3], [5.5, 0.0]]",
                                           f"[[0.5, 0.0], [{0.5 + end}, 0.0]]")))
    st = stations([[0.5, 0.0], [0.5 + end, 0.0]], 0.1)
    assert st.s[-1] == pytest.approx(end)
    k = len(st)
    v = np.full(k, 0.3)
    v[-1] = 0.05                                     # the end station limits its segment
    P = pd.DataFrame({"path": "a", "station": np.arange(k), "s": st.s, "status": "ok",
                      "v_lim": v})
    W = pd.DataFrame({"path": "a", "station": np.arange(k), "s": st.s, "wheel": "left_front",
                      "T_c_minus": 0.0, "beta_deg": np.nan})
    S = segments_table(raw, P, W)
    assert len(S) == n_seg
    assert (S["s0"].iloc[-1], S["s1"].iloc[-1]) == pytest.approx(last)
    assert S["s1"].max() == pytest.approx(end)
    assert S["stations"].sum() == k
    assert S["v_lim"].iloc[-1] == 0.05


def test_summary_lowest_limit_without_any_pose_is_not_infinite():
    """A path where no station found a pose has no known limit: the summary said "inf" (no
    impact, drive at any speed) while its segments' v_lim was NaN; it is now NaN (n/a).
    A path whose stations with a pose meet no impact keeps inf."""
    from roverimpact.report.traverse import summary

    P = pd.DataFrame({"path": ["a"] * 3 + ["b"] * 3, "s": [0.0, 0.1, 0.2] * 2,
                      "status": ["stalled"] * 3 + ["ok", "stalled", "ok"],
                      "v_lim": [np.nan] * 3 + [np.inf, np.nan, np.inf]})
    W = pd.DataFrame({"path": ["a", "b"], "s": [0.0, 0.0], "T_c_minus": [np.nan, 0.0]})
    S = summary(P, W).set_index("path")
    assert np.isnan(S.loc["a", "lowest limit [m/s]"]) and S.loc["a", "failed poses"] == 3
    assert S.loc["b", "lowest limit [m/s]"] == np.inf


def test_speed_figure_does_not_draw_stations_without_pose_as_unlimited():
    """A station without a pose (v_lim NaN) was drawn at the top speed, as a station with no
    impact (inf): the figure read "any speed" where nothing is known. It is now left out of
    the limits and marked "no pose found"; a segment without any pose is a gap."""
    from roverimpact.report.traverse import plot_speed

    P = pd.DataFrame({"path": "a", "station": [0, 1, 2, 3], "s": [0.0, 0.5, 1.0, 1.5], "status":
                      ["ok", "stalled", "ok", "stalled"],
                      "v_lim": [0.05, np.nan, np.inf, np.nan]})
    S = pd.DataFrame({"path": "a", "s0": [0.0, 1.0], "s1": [1.0, 1.5],
                      "v_lim": [0.05, np.nan]})
    W = pd.DataFrame({"path": "a", "s": [0.0], "station": [0], "wheel": ["w"],
                      "T_c_minus": [0.01], "F_pred": [10.0]})
    fig = plot_speed(P, S, W, v_ref=0.1, v_max=0.3)
    ax = fig.axes[0]
    y = ax.lines[0].get_ydata()
    assert y[0] == 0.05 and y[2] == 0.3
    assert np.isnan(y[1]) and np.isnan(y[3])
    assert any("no pose found (2)" in t.get_text() for t in ax.get_legend().get_texts())
    stairs = [p for p in ax.patches if p.get_label() == "limit per segment"]
    assert np.isnan(stairs[0].get_data().values[1])


def test_speed_figure_without_top_speed_says_what_its_top_is():
    """Without drive.v_max, stations with no impact (v_lim inf) and limits above the axis
    were drawn at its top, 2 u_ref, as if the limit were 0.2 m/s: a flat path's figure
    read "speed limit 0.2 m/s" where its tables say no limit. The top line is now labelled
    "no limit, or one above 0.2 m/s"; where every limit is on the axis, there is no such
    line (the axis' top: 2 u_ref, or up to 4 u_ref for the 95th percentile)."""
    from roverimpact.report.traverse import plot_speed

    W = pd.DataFrame({"path": "a", "s": [0.0], "station": [0], "wheel": ["w"],
                      "T_c_minus": [0.01], "F_pred": [10.0]})
    for v, said in (([np.inf, np.inf, np.inf], "0.2"), ([0.05, 0.9, 0.08], "0.4"),
                    ([0.05, 0.12, 0.08], None)):
        P = pd.DataFrame({"path": "a", "station": [0, 1, 2], "s": [0.0, 0.5, 1.0],
                          "status": "ok", "v_lim": v})
        S = pd.DataFrame({"path": "a", "s0": [0.0], "s1": [1.0], "v_lim": [min(v)]})
        ax = plot_speed(P, S, W, v_ref=0.1).axes[0]
        texts = [t.get_text() for t in ax.get_legend().get_texts()]
        top = [t for t in texts if t.startswith("no limit")]
        assert top == ([] if said is None else
                       [f"no limit, or one above {said} m/s (drawn here)"]), (v, texts)


def _flat_traverse(folder):
    """``folder/t.toml``: a 0.33 m path of the 2-D rover over ``folder/flat.npy`` (flat,
    1 cm cells), the height field named relative to the traverse file."""
    np.save(folder / "flat.npy", np.zeros((201, 301)))
    f = folder / "t.toml"
    f.write_text('[terrain]\nkind = "file"\nfile = "flat.npy"\nspacing = 0.01\n'
                 'origin = [-1.0, -1.0]\n[path]\nname = "p"\n'
                 'waypoints = [[0.0, 0.0], [0.33, 0.0]]\nspacing = 0.1\n'
                 '[model]\nname = "rover2d"\n[drive]\nspeed = 0.1\n[limits]\nT_allow = 0.01\n')
    return f


def test_summary_length_is_the_path_length(tmp_path, capfd):
    """The summary's "length [m]" was the last station's s: 0.3 m for a 0.33 m path at
    0.1 m spacing (the segments end at 0.33 m). It is the polyline's length. No impact:
    the lowest limit is none (JSON null), not inf."""
    f = _flat_traverse(tmp_path)
    capfd.readouterr()
    # the summary and the tables only: the report of this folder is drawn by
    # test_copy_of_the_traverse_file_runs_from_the_output_folder
    assert main(["traverse", str(f), "-o", str(tmp_path / "out"), "--json",
                 "--no-report"]) == 0
    out = json.loads(capfd.readouterr().out)
    row = out["summary"][0]
    assert row["stations"] == 4 and row["length [m]"] == pytest.approx(0.33)
    assert row["lowest limit [m/s]"] is None and row["impacts"] == 0   # inf: no impact
    # report.html said "inf" in its summary and every segment's v_lim: now "no limit" (the
    # tables keep inf; the terminal's summary: test_summary_table_at_80_columns)
    # report.html: test_copy_of_the_traverse_file_runs_from_the_output_folder
    assert np.isinf(pd.read_parquet(tmp_path / "out" / "segments.parquet")["v_lim"]).all()
    S = pd.read_parquet(tmp_path / "out" / "segments.parquet")
    assert S["s1"].iloc[-1] == pytest.approx(0.33)
    # with a top speed every station's limit is it: no station to name (it said s = 0)
    f.write_text(f.read_text().replace("speed = 0.1\n", "speed = 0.1\nv_max = 0.3\n"))
    assert main(["traverse", str(f), "-o", str(tmp_path / "out"), "--json",
                 "--no-report"]) == 0
    row = json.loads(capfd.readouterr().out)["summary"][0]
    assert row["lowest limit [m/s]"] == 0.3 and row["at s [m]"] is None


def test_height_field_file_read_alike_by_scenario_and_traverse(tmp_path, capsys):
    """One loader (HeightField.from_file) behind [terrain] file = ... of a scenario and of
    a traverse: a DEM with a -9999 hole (a GDAL export's no-data) is refused by both with
    the same message naming the cell (before: a 10 km pit, then 'cannot be placed' or
    'outside the height field' far from it); ``nodata`` names another marker; the
    traverse takes a spacing [dx, dy] as the scenario does (the plane z = 0.1 x + 0.05 y
    read back at a point between nodes)."""
    import roverimpact as ri
    from roverimpact.scenario.ground import make_terrain
    from roverimpact.traverse.run import build_terrain
    from roverimpact.traverse.schema import traverse_from_dict

    x0, y0, dx, dy = -4.0, -3.0, 0.1, 0.05
    z = np.fromfunction(lambda i, j: 0.1 * (x0 + j * dx) + 0.05 * (y0 + i * dy), (121, 81))
    z[65, 40] = -9999.0                            # under the left middle wheel (0, 0.25)
    np.save(tmp_path / "dem.npy", z)
    terrain = {"file": "dem.npy", "spacing": [dx, dy], "origin": [x0, y0]}
    want = (r"dem.npy has 1 no-data cell\(s\), the first at row 65, column 40, "
            r"\(x, y\) = \(0, 0.25\) m, holding -9999")
    sc = tmp_path / "sc.toml"
    sc.write_text('[model]\nname = "rocker_bogie"\n[velocity]\nu = 0.3\n[obstacle]\n'
                  'wheel = "left_front"\nbeta_deg = 45.0\n[terrain]\nfile = "dem.npy"\n'
                  f"spacing = [{dx}, {dy}]\norigin = [{x0}, {y0}]\n")
    assert main(["energy", str(sc)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert re.search(want, err)
    raw = json.loads(json.dumps(TRAV_FILE))
    raw["terrain"] = {"kind": "file", **terrain}
    with pytest.raises(ConfigError, match=want):
        build_terrain(traverse_from_dict(raw, base_dir=tmp_path).terrain)
    z[65, 40] = -1.0e6                             # a marker of the user's own
    np.save(tmp_path / "dem.npy", z)
    for where, extra in (("scenario", {}), ("traverse", {"kind": "file"})):
        spec = {**terrain, "nodata": -1.0e6, **extra}
        with pytest.raises(ConfigError, match=r"holding -1000000 \(the no-data value given"):
            if where == "scenario":
                sc_raw = ri.load_scenario(sc).model_dump()
                sc_raw["terrain"] = {**spec, "file": str(tmp_path / "dem.npy")}
                make_terrain(ri.Scenario.model_validate(sc_raw).terrain, None, None)
            else:
                build_terrain(traverse_from_dict({**raw, "terrain": spec},
                                                 base_dir=tmp_path).terrain)
    z[65, 40] = 0.1 * 0.0 + 0.05 * 0.25
    np.save(tmp_path / "dem.npy", z)
    hf = build_terrain(traverse_from_dict(raw, base_dir=tmp_path).terrain)
    assert (hf.dx, hf.dy) == (dx, dy)
    assert float(hf.height(0.33, 0.17)) == pytest.approx(0.1 * 0.33 + 0.05 * 0.17, abs=1e-12)


TRAV_FILE = {"path": {"name": "a", "start": [-1.0, 0.0], "end": [1.0, 0.0]},
             "model": {"name": "rocker_bogie"}, "drive": {"speed": 0.1},
             "limits": {"T_allow": 0.01}}


def test_height_field_file_written_again_is_read_again(tmp_path):
    """In one Python session (a notebook), a DEM file saved again with other heights gives
    the new terrain: before, build_terrain's per-process cache (keyed by the file's name)
    kept the first heights, and run_traverse computed on them with no word of it. The
    plane z = 0.2 x, then z = 0.2 x + 1, read back at x = 0.37."""
    import os

    from roverimpact.traverse.run import build_terrain
    from roverimpact.traverse.schema import traverse_from_dict

    x = np.arange(0.0, 2.01, 0.1)
    raw = {**TRAV_FILE, "terrain": {"kind": "file", "file": "dem.npy", "spacing": 0.1}}
    for k, lift in enumerate((0.0, 1.0)):
        np.save(tmp_path / "dem.npy", np.tile(0.2 * x + lift, (5, 1)))
        os.utime(tmp_path / "dem.npy", ns=(10**18 + k, 10**18 + k))  # mtime granularity
        hf = build_terrain(traverse_from_dict(raw, base_dir=tmp_path).terrain)
        assert float(hf.height(0.37, 0.2)) == pytest.approx(0.2 * 0.37 + lift, abs=1e-12)


def test_report_redraws_on_the_height_field_of_the_run(tmp_path, monkeypatch, capsys):
    """The copy traverse.toml says file = "dem.npy", relative to the traverse file; the
    report read it from the working folder: 'height field dem.npy: no such file' from
    anywhere else (or another dem.npy of that name). The manifest now keeps the file's
    absolute path and SHA-256: the report works from any folder, and refuses a DEM
    changed since the run."""
    src = tmp_path / "in"
    src.mkdir()
    np.save(src / "dem.npy", np.zeros((61, 81)))
    (src / "t.toml").write_text(
        '[terrain]\nkind = "file"\nfile = "dem.npy"\nspacing = 0.05\norigin = [-2.0, -1.5]\n'
        '[path]\nstart = [-0.2, 0.0]\nend = [0.0, 0.0]\nspacing = 0.1\n'
        '[model]\nname = "rocker_bogie"\n[drive]\nspeed = 0.1\n[limits]\nT_allow = 0.01\n')
    out = tmp_path / "out"
    assert main(["traverse", str(src / "t.toml"), "-o", str(out), "--no-report"]) == 0
    man = json.loads((out / "manifest.json").read_text())
    assert man["terrain_file"]["path"] == str((src / "dem.npy").resolve())
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    assert not (out / "report.html").exists()
    capsys.readouterr()
    assert main(["traverse-report", str(out)]) == 0
    assert (out / "report.html").is_file()
    np.save(src / "dem.npy", np.full((61, 81), 0.1))
    assert main(["traverse-report", str(out)]) == 2
    assert "dem.npy changed since the traverse ran" in capsys.readouterr().err


def test_model_file_written_again_is_read_again(tmp_path):
    """As the terrain: build_model's per-process cache was keyed by the [model] table, so a
    URDF saved again (a heavier chassis) in the same Python session kept the first model.
    The total mass read back: the file's masses summed, then with the chassis + 5 kg."""
    import os

    import tomllib

    from roverimpact.traverse.run import build_model
    from roverimpact.traverse.schema import traverse_from_dict

    ex = Path(__file__).resolve().parents[1] / "examples"
    urdf = (ex / "models" / "sawppy_like.urdf").read_text()
    model = tomllib.loads((ex / "sawppy_like_beta.toml").read_text())["model"]
    model["file"] = "rover.urdf"
    raw = {**TRAV_FILE, "model": model, "terrain": {"kind": "file", "file": "dem.npy",
                                                    "spacing": 0.1}}
    masses = [float(m) for m in re.findall(r'<mass value="([^"]+)"', urdf)]
    first = re.search(r'<mass value="([^"]+)"', urdf)
    heavier = urdf.replace(first.group(0), f'<mass value="{float(first.group(1)) + 5.0}"', 1)
    for k, (text, total) in enumerate(((urdf, sum(masses)), (heavier, sum(masses) + 5.0))):
        (tmp_path / "rover.urdf").write_text(text)
        os.utime(tmp_path / "rover.urdf", ns=(10**18 + k, 10**18 + k))
        mbm = build_model(traverse_from_dict(raw, base_dir=tmp_path))
        got = sum(i.mass for i in mbm.model.inertias)
        assert got == pytest.approx(total, rel=1e-12)


def test_copy_of_the_traverse_file_runs_from_the_output_folder(tmp_path, monkeypatch, capfd):
    """The copy of a traverse file next to its results kept ``file = "flat.npy"``, a name
    relative to the traverse file: run from the output folder it read <out>/flat.npy, "no
    such file". The copy now names the file by absolute path: the same traverse, wherever
    it is read from, and the report of the folder is still drawn."""
    src = tmp_path / "in"
    src.mkdir()
    f = _flat_traverse(src)
    monkeypatch.chdir(src)
    assert main(["traverse", "t.toml", "-o", "../out", "--json", "--no-report"]) == 0
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    copy = tmp_path / "out" / "traverse.toml"
    assert load_traverse(copy) == load_traverse(f)
    assert load_traverse(copy).terrain.file == str(src / "flat.npy")
    capfd.readouterr()
    assert main(["traverse", str(copy), "-o", str(tmp_path / "again"), "--json",
                 "--no-report"]) == 0, capfd.readouterr().err
    assert main(["traverse-report", str(tmp_path / "out")]) == 0, capfd.readouterr().err
    # no impact on the flat path: report.html said "inf" in its summary and in every
    # segment's v_lim; now "no limit" (the tables keep inf: test_summary_length_is_...)
    cells = re.findall(r"<td>([^<]*)</td>", (tmp_path / "out" / "report.html").read_text())
    assert "inf" not in cells and cells.count("no limit") == 2   # summary, one segment


def _other_code_in_tasks(monkeypatch):
    """Dask workers of this process's in-process cluster answer the command's code identity
    to the command's check (``Client.run``) and another roverimpact source in tasks: as a
    worker started from another checkout (the same version string) that joined after the
    check does."""
    from distributed import get_worker

    from roverimpact.studies import executors, store

    def code_identity(dask_worker=None):  # (Client.run gives its worker as dask_worker)
        if dask_worker is not None:
            return store.code_identity()
        try:
            get_worker()
        except ValueError:  # the command
            return store.code_identity()
        return store.code_identity() | {"roverimpact source": "0123456789abcdef"}

    monkeypatch.setattr(executors, "code_identity", code_identity)


def test_traverse_worker_of_other_code_that_joins_is_refused(tmp_path, monkeypatch):
    """On a running scheduler, a worker of other code that joins after the command's check
    computed its chunks with no word: the traverse's
    chunks carried no code identity, as a study's do. Now its chunk is refused on the
    worker and the command stops with one line, the output folder not made. Reference: the
    study's check (tests/test_study_dask_scheduler.py)."""
    pytest.importorskip("dask.distributed")
    from dask.distributed import LocalCluster

    from roverimpact.exceptions import RoverImpactError

    f = _flat_traverse(tmp_path)
    _other_code_in_tasks(monkeypatch)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp",
                      dashboard_address=None) as cluster:
        with pytest.raises(RoverImpactError, match=r"runs other code than this command "
                           r"\(roverimpact source 0123456789abcdef there.*it joined while "
                           r"the traverse ran: nothing was written"):
            run_traverse(f, tmp_path / "out", scheduler=cluster.scheduler_address)
    assert not (tmp_path / "out").exists()


def test_traverse_workers_with_a_cold_kernel_cache_are_said_to_compile(tmp_path, monkeypatch):
    """Workers of a running scheduler whose numba cache lacks the traverse's kernels
    compile them before their first chunk (30-70 s) with no word: a study says so, a
    traverse did not ask. Now it asks them (the kernels of the stations, and the weight
    model's with it) and says it; with a warm cache it says nothing."""
    pytest.importorskip("dask.distributed")
    import sys
    import types

    from dask.distributed import LocalCluster

    from roverimpact._kernels._jit import Kernel
    from roverimpact.traverse import run

    cfg = load_traverse(_flat_traverse(tmp_path))
    assert run.traverse_kernels(cfg) == run.TRAVERSE_KERNELS   # T_allow: no weight model
    weight = cfg.model_copy(update={"limits": cfg.limits.model_copy(
        update={"T_allow": None, "F_allow": 100.0})})
    assert run.traverse_kernels(weight) == run.TRAVERSE_KERNELS + run.WEIGHT_MODEL_KERNELS
    for home in run.TRAVERSE_KERNELS + run.WEIGHT_MODEL_KERNELS:   # the real ones resolve
        module, _, name = home.partition(":")
        assert isinstance(getattr(__import__(module, fromlist=[name]), name), Kernel)

    class Fake:
        def __init__(self, cached):
            self.compiled, self._cached = False, cached

        def cached(self):
            return self._cached

    fake = types.ModuleType("fake_kernels")
    fake.cold, fake.warm = Fake(cached=False), Fake(cached=True)
    monkeypatch.setitem(sys.modules, "fake_kernels", fake)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp",
                      dashboard_address=None) as cluster:
        for kernels, said in ((("fake_kernels:warm",), False),
                              (("fake_kernels:warm", "fake_kernels:cold"), True)):
            monkeypatch.setattr(run, "TRAVERSE_KERNELS", kernels)
            notes: list[str] = []
            run_traverse(cfg, scheduler=cluster.scheduler_address, note=notes.append)
            compiling = [n for n in notes if "compile roverimpact's kernels" in n]
            assert bool(compiling) is said
            if said:
                assert "numba's cache there lacks cold)" in compiling[0]


def test_a_planar_rover_runs_on_a_strip_of_terrain(tmp_path):
    """The 2-D rover on a profile extruded over a 4 cm strip (y in [-0.02, 0.02] m) was
    refused: "path 'p' leaves the terrain ... within 0.762 m (the rover's reach and
    look-ahead) of the edge", the reach taken from q[:2] of a planar base, which is (x, z)
    (0.65 m for wheels 0.3 m from the base and 0.15 m in radius), and applied across the
    plane the rover cannot leave. Now the reach is the wheels' horizontal 0.45 m and, across
    the plane, two cells beside the wheels' own y: the strip gives the impact of the same
    profile on a 4 m wide grid."""
    dx, gamma = 0.005, np.radians(30.0)
    x = -1.0 + dx * np.arange(801)
    z = np.clip((x - 1.0) * np.tan(gamma), 0.0, 0.05)
    out = {}
    for name, rows in (("wide", 801), ("strip", 9)):
        np.save(tmp_path / f"{name}.npy", np.tile(z, (rows, 1)))
        cfg = {"terrain": {"kind": "file", "file": str(tmp_path / f"{name}.npy"),
                           "spacing": dx, "origin": [-1.0, -(rows // 2) * dx]},
               "path": {"name": "p", "waypoints": [[0.62, 0.0], [0.63, 0.0]],
                        "spacing": 0.02},
               "model": {"name": "rover2d"}, "drive": {"speed": 0.1, "look_ahead": 0.1},
               "limits": {"T_allow": 0.01}}
        out[name] = run_traverse(cfg).wheels
    assert (out["wide"]["T_c_minus"] > 0).sum() == 1
    pd.testing.assert_frame_equal(out["strip"], out["wide"])
    # still refused where the path itself comes too close to the ends of the profile
    cfg["path"]["waypoints"] = [[-0.6, 0.0], [0.63, 0.0]]
    with pytest.raises(ConfigError, match=r"within 0\.560 m .*, 0\.010 m across its plane"):
        run_traverse(cfg)


def test_impacts_that_allow_no_speed_are_said(tmp_path):
    """F_allow below the wheel's weight share (1 mN): the weight model's limit is 0 at the
    2-D rover's front wheel before a 30 degree ramp, and the command said nothing (the
    summary's lowest limit 0, the reason only in docs/traverse.md). Now a note says how
    many, where and why. Reference: the preloaded support's static force m g / 2 = 118 N
    is far above F_allow, so no speed keeps the force under it."""
    dx, gamma = 0.005, np.radians(30.0)
    x = -1.0 + dx * np.arange(801)
    np.save(tmp_path / "ramp.npy", np.tile(np.clip((x - 1.0) * np.tan(gamma), 0.0, 0.05),
                                           (9, 1)))
    cfg = {"terrain": {"kind": "file", "file": str(tmp_path / "ramp.npy"), "spacing": dx,
                       "origin": [-1.0, -4 * dx]},
           "path": {"name": "p", "waypoints": [[0.62, 0.0], [0.63, 0.0]], "spacing": 0.02},
           "model": {"name": "rover2d"}, "drive": {"speed": 0.1, "look_ahead": 0.1},
           "limits": {"F_allow": 1e-3}, "contact_law": {"name": "hertz", "k": 1e7}}
    notes = []
    W = run_traverse(cfg, note=notes.append).wheels
    assert (W["v_lim"] == 0).sum() == 1
    assert notes == ["1 impact(s) at 1 station(s) allow no speed (v_lim = 0, the first at "
                     "s = 0 m of path 'p'): the weight model's force exceeds limits.F_allow "
                     "even at 1 % of drive.speed (the wheel's weight share), or the wheel is "
                     "locked against the feature (m_eff infinite); drive round them, or check "
                     "limits.F_allow"]
    cfg["limits"]["F_allow"] = 150.0
    notes.clear()
    assert (run_traverse(cfg, note=notes.append).wheels["v_lim"] > 0).all() and not notes


@pytest.mark.parametrize("h, impact", [(4e-10, False), (0.01, True)])
def test_touching_is_no_impact_in_the_tables_and_the_limit(tmp_path, capfd, h, impact):
    """A wheel that meets ground a fraction of a nanometre above its rolling line
    (docs/traverse.md: below the pose solver's tolerance, touching) counted as an impact
    of ~1e-11 J in every table: n_impacts, T_c_max, the segment's worst wheel, a finite
    v_lim. The 2-D rover on a step of h in a height field (5 mm cells): for h below the
    tolerance the wheels table keeps v_n > 0 and T_c^- = 0, the stations and segments count
    no impact and the limit is the top speed; a step of 1 cm is still an impact, with its
    T_allow limit u sqrt(T_allow / T_c^-)."""
    dx = 0.005
    x = -1.0 + dx * np.arange(801)
    np.save(tmp_path / "step.npy", np.tile(np.where(x >= 1.0, h, 0.0), (9, 1)))
    f = tmp_path / "t.toml"
    f.write_text(f'[terrain]\nkind = "file"\nfile = "step.npy"\nspacing = {dx}\n'
                 f'origin = [-1.0, {-4 * dx}]\n[path]\nname = "p"\n'
                 'waypoints = [[0.62, 0.0], [0.63, 0.0]]\nspacing = 0.02\n'
                 '[model]\nname = "rover2d"\n[drive]\nspeed = 0.1\nv_max = 0.3\n'
                 'look_ahead = 0.1\n[limits]\nT_allow = 0.01\n')
    capfd.readouterr()
    assert main(["traverse", str(f), "-o", str(tmp_path / "out"), "--json",
                 "--no-report"]) == 0, capfd.readouterr().err
    out = tmp_path / "out"
    P, W, S = (pd.read_parquet(out / f"{t}.parquet") for t in ("poses", "wheels", "segments"))
    met = W[W["found"] & (W["v_n"] > 0)]
    assert len(met) == 1                                   # the front wheel, at one station
    T = float(met["T_c_minus"].iloc[0])
    assert (T > 0) == impact
    assert P["n_impacts"].sum() == S["n_impacts"].sum() == int(impact)
    assert (P["T_c_max"].max() > 0) == impact and (S["worst_wheel"] != "").sum() == impact
    lim = 0.1 * np.sqrt(0.01 / T) if impact else np.inf
    assert float(met["v_lim"].iloc[0]) == pytest.approx(lim, rel=1e-12)
    assert P["v_lim"].min() == pytest.approx(min(lim, 0.3), rel=1e-12)
