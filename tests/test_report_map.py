"""A study over a grid of two numeric parameters is also drawn as a map (report.plots:
grid_map, plot_study_map; report.html writes map.png and map.svg and shows the map):
T_c^- (and the peak force) over the grid, the largest value marked. A study that is not
such a grid (one parameter, three, too few values, a random design, pairs repeated)
has none."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from roverimpact.report import html as report_html
from roverimpact.report.plots import MAP_MIN_VALUES, grid_map, label, plot_study_map
from roverimpact.studies import run_study

RIGID = {
    "model": {"name": "rigid_body",
              "params": {"mass": 20.0, "inertia": 1.2, "com_height": 0.3, "lever": 0.4}},
    "velocity": {"u": 0.5},
    "obstacle": {"frame": "contact", "beta_deg": 90.0},
    "contact_law": {"name": "hunt-crossley", "k": 1.0e7, "e": 0.8},
}


def _grid_table(nx=6, ny=5, seed=0):
    rng = np.random.default_rng(seed)
    xs, ys = np.linspace(10.0, 80.0, nx), np.linspace(0.1, 0.9, ny)
    X, Y = np.meshgrid(xs, ys)
    t = pd.DataFrame({"a": X.ravel(), "b": Y.ravel(), "T_c_minus": rng.random(nx * ny)})
    return t.sample(frac=1.0, random_state=seed).reset_index(drop=True)  # any row order


def test_grid_map_puts_each_case_in_its_cell():
    t = _grid_table()
    t.loc[3, "T_c_minus"] = np.nan  # a case without output: a blank cell
    t = t.drop(index=7)  # a case missing from the grid: a blank cell
    xs, ys, Z = grid_map(t, "a", "b", "T_c_minus")
    assert Z.shape == (len(ys), len(xs)) == (5, 6)
    for _, row in t.iterrows():
        i, j = np.searchsorted(xs, row["a"]), np.searchsorted(ys, row["b"])
        np.testing.assert_equal(Z[j, i], row["T_c_minus"])
    assert np.isnan(Z).sum() == 2


def test_what_is_not_a_grid_has_no_map():
    t = _grid_table()
    assert grid_map(t, "a", "a", "T_c_minus") is None
    assert grid_map(_grid_table(nx=MAP_MIN_VALUES - 1), "a", "b", "T_c_minus") is None
    assert grid_map(pd.concat([t, t]), "a", "b", "T_c_minus") is None  # pairs repeated
    rng = np.random.default_rng(1)
    random = pd.DataFrame({"a": rng.random(40), "b": rng.random(40),
                           "T_c_minus": rng.random(40)})
    assert grid_map(random, "a", "b", "T_c_minus") is None  # 40 of 1600 cells
    assert grid_map(t.assign(a=t["a"].astype(str)), "a", "b", "T_c_minus") is None
    assert grid_map(t.assign(a=t["a"] > 40), "a", "b", "T_c_minus") is None
    assert plot_study_map(t.assign(T_c_minus=np.nan), "a", "b") is None


def test_map_marks_the_largest_value():
    t = _grid_table()
    fig = plot_study_map(t, "a", "b", title="T_c^- map")
    k = int(t["T_c_minus"].idxmax())
    title = fig.axes[0].get_title()
    assert f"{t['T_c_minus'][k]:.4g}" in title and f"{t['a'][k]:.4g}" in title
    star = next(ln for ln in fig.axes[0].lines if ln.get_marker() == "*")
    assert star.get_xdata()[0] == t["a"][k] and star.get_ydata()[0] == t["b"][k]
    assert label("configuration.joints.panda_joint2") == "joint panda_joint2 [rad or m]"


def test_a_grid_study_s_report_has_its_map(tmp_path):
    """A 6 x 5 grid of angle and speed: map.png/svg beside figure.png, in the HTML and the
    JSON of `roverimpact report`; the map's numbers are the table's. The same folder
    reported again as a study of one parameter loses its stale map."""
    from typer.testing import CliRunner

    from roverimpact.cli import app

    study = {"name": "grid", "base": RIGID, "grid": {
        "obstacle.beta_deg": {"start": 10.0, "stop": 90.0, "num": 6},
        "velocity.u": {"start": 0.1, "stop": 0.5, "num": 5}}}
    res = run_study(study, tmp_path / "g")
    sec = report_html.analyse_folder(tmp_path / "g", n_boot=0)
    assert set(sec.maps) == {"png", "svg"} and all(p.is_file() for p in sec.maps.values())
    xs, ys, Z = grid_map(res.table, "obstacle.beta_deg", "velocity.u", "T_c_minus")
    t = res.table.set_index(["obstacle.beta_deg", "velocity.u"])["T_c_minus"]
    assert Z[2, 3] == t[(xs[3], ys[2])]
    out = CliRunner().invoke(app, ["report", str(tmp_path / "g"), "--json"])
    assert out.exit_code == 0, out.output
    (entry,) = json.loads(out.output)["studies"]
    assert entry["maps"]["png"].endswith("map.png")
    page = (tmp_path / "g" / "report.html").read_text()
    assert page.count("<img class='fig'") == 2 and "map of T_c^-" in page
    # the same folder, its manifest now saying one parameter: the map is removed
    manifest = json.loads((tmp_path / "g" / "manifest.json").read_text())
    manifest["parameters"] = ["obstacle.beta_deg"]
    (tmp_path / "g" / "manifest.json").write_text(json.dumps(manifest))
    sec = report_html.analyse_folder(tmp_path / "g", n_boot=0)
    assert sec.maps == {} and not (tmp_path / "g" / "map.png").exists()


@pytest.mark.parametrize("design", ["grid", "random"])
def test_a_large_grid_study_s_map_reads_its_columns_only(tmp_path, monkeypatch, design):
    """Above LARGE_TABLE rows the table is not read whole: the map of a [grid] design reads
    the four columns it needs (pyarrow), the same map as the full path; a random design
    has none (and nothing is read for it)."""
    import pyarrow.parquet as pq

    cases = ({"grid": {"obstacle.beta_deg": {"start": 10.0, "stop": 90.0, "num": 12},
                       "velocity.u": {"start": 0.1, "stop": 0.5, "num": 10}}}
             if design == "grid" else
             {"random": {"n": 120, "seed": 3, "params": {
                 "obstacle.beta_deg": {"low": 10.0, "high": 90.0},
                 "velocity.u": {"low": 0.1, "high": 0.5}}}})
    run_study({"name": design, "base": RIGID, **cases}, tmp_path / "s")
    full = report_html.analyse_folder(tmp_path / "s", n_boot=0)
    ref = (tmp_path / "s" / "map.png").read_bytes() if full.maps else None
    read = []
    real = pq.read_table
    monkeypatch.setattr(pq, "read_table",
                        lambda path, columns=None, **kw: read.append(columns)
                        or real(path, columns=columns, **kw))
    monkeypatch.setattr(report_html, "LARGE_TABLE", 50)
    monkeypatch.setattr(pd, "read_parquet", lambda *a, **k: pytest.fail("table read whole"))
    big = report_html.analyse_folder(tmp_path / "s", n_boot=0)
    monkeypatch.undo()
    if design == "grid":
        assert set(big.maps) == {"png", "svg"} and ref is not None
        assert ["obstacle.beta_deg", "velocity.u", "T_c_minus", "F_pred"] in read
        assert (tmp_path / "s" / "map.png").read_bytes() == ref
    else:
        assert big.maps == {} and ref is None
        assert not [c for c in read if c and "T_c_minus" in c and len(c) <= 4]
