"""What a person reads: help texts and tables keep their units, tables stay readable in an
80-column terminal, ``--json`` is strict JSON and ``--csv`` is CSV.

Rich reads ``[kg]`` as a style tag and drops it; these tests fail on a lost unit. The
references are the source texts themselves (help strings read by ``ast`` from
``src/roverimpact/cli/*.py``, the headers and row labels each command is known to print),
not the output of the code under test.
"""

from __future__ import annotations

import ast
import csv
import io
import json
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import typer

from roverimpact.cli import _app, app, main

from .textlines import fitted_lines

ROOT = Path(__file__).resolve().parents[1]
EX = ROOT / "examples"
CLI = ROOT / "src" / "roverimpact" / "cli"
WIDTH = 80

#: a unit (or any bracketed token) as written in a help string or a header
UNIT = re.compile(r"\[[^\[\]\n]+\]")


@pytest.fixture(autouse=True)
def _80_columns(monkeypatch):
    """Typer's help console and the commands' consoles, 80 columns wide."""
    monkeypatch.setenv("COLUMNS", str(WIDTH))
    monkeypatch.setenv("TERMINAL_WIDTH", str(WIDTH))
    monkeypatch.setattr(_app.console, "width", WIDTH)
    monkeypatch.setattr(_app.err_console, "width", WIDTH)


def _flat(text: str) -> str:
    """Help output without box drawing and line breaks: one space between words."""
    return " ".join(re.sub(r"[│╭╮╰╯─┃━]", " ", text).split())


def _strict_json(text: str):
    def refuse(name):
        raise ValueError(f"not JSON: {name}")

    return json.loads(text, parse_constant=refuse)


# ---------------------------------------------------------------------------------------
# help
# ---------------------------------------------------------------------------------------


def _commands(group, path=()):
    """(command path, click command) of every command and sub-command."""
    yield path, group
    for name, cmd in getattr(group, "commands", {}).items():
        yield from _commands(cmd, (*path, name))


def _source_help_texts() -> list[str]:
    """Every ``help=`` string and every command docstring written in the CLI's source."""
    texts = []
    for f in sorted(CLI.glob("*.py")):
        tree = ast.parse(f.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.keyword) and node.arg == "help":
                if isinstance(node.value, ast.Constant) and isinstance(node.value.value, str):
                    texts.append(node.value.value)
            if isinstance(node, ast.FunctionDef) and node.name.endswith("_cmd"):
                texts.append(ast.get_docstring(node) or "")
    return texts


HELP_COMMANDS = [" ".join(p) for p, _ in _commands(typer.main.get_command(app))]


def _help(capsys, path: str) -> str:
    argv = [*path.split(), "--help"] if path else ["--help"]
    assert main(argv) == 0
    return capsys.readouterr().out


@pytest.mark.parametrize("path", HELP_COMMANDS, ids=lambda p: p or "roverimpact")
def test_help_keeps_every_unit(capsys, path):
    cmd = typer.main.get_command(app)
    for part in path.split():
        cmd = cmd.commands[part]
    source = [cmd.help or ""] + [p.help or "" for p in cmd.params]
    units = {u.replace("\\[", "[") for text in source for u in UNIT.findall(
        text.replace("\\[", "["))}
    out = _help(capsys, path)
    assert max(len(line) for line in out.splitlines()) <= WIDTH
    flat = _flat(out)
    lost = sorted(u for u in units if u not in flat)
    assert not lost, f"{path or 'roverimpact'} --help lost {lost}"


def test_every_unit_written_in_the_source_reaches_some_help(capsys):
    units = {u for text in _source_help_texts() for u in UNIT.findall(text)}
    assert {"[kg]", "[m/s]", "[N/m^n]", "[J]", "[N s/m]"} <= units  # the walk sees them
    shown = " ".join(_flat(_help(capsys, p)) for p in HELP_COMMANDS)
    lost = sorted(u for u in units if u not in shown)
    assert not lost, f"units lost in --help: {lost}"


@pytest.mark.parametrize("path", ["simulate", "trust"])
def test_engine_help_names_every_engine(capsys, path):
    """``trust --help`` offered "own, mujoco or own,mujoco", but the command also runs
    ``mujoco_laws`` (simulate.engines.ENGINE_NAMES is the list both commands accept)."""
    from roverimpact.simulate.engines import ENGINE_NAMES

    flat = _flat(_help(capsys, path))
    assert [e for e in ENGINE_NAMES if e not in flat] == []


def test_command_list_breaks_no_summary_mid_sentence(capsys):
    """`roverimpact --help` shows each command's first docstring paragraph with its line
    breaks kept: traverse's, written over two source lines, read "... its T_c^- at the" /
    "reference speed, ..." in the list. Each summary is one source line."""
    for path, cmd in _commands(typer.main.get_command(app)):
        if path:
            first = (cmd.help or "").strip().split("\n\n")[0]
            assert "\n" not in first, f"{' '.join(path)}: {first!r}"


def test_issue_13_examples_of_lost_units(capsys):
    assert "Effective mass m_eff [kg]." in _flat(_help(capsys, "contact"))
    assert "Normal approach speed v_n [m/s]." in _flat(_help(capsys, "contact"))
    assert "Scenario TOML (its [simulation] table is optional)." in _flat(
        _help(capsys, "simulate"))


# ---------------------------------------------------------------------------------------
# tables at 80 columns
# ---------------------------------------------------------------------------------------

OPT = ('[scenario]\nmodel = { name = "rover2d" }\nvelocity = { u = 0.3 }\n'
       'obstacle = { wheel = "front", beta_deg = 45 }\n[optimize]\n'
       'variables = { h = [0.3, 0.45] }\nbeta_deg = [30, 90]\nn_beta = 4\n'
       'n_starts = 2\nstability_margin = 0.2\n')


def _fake_study(folder: Path, name: str, *, whole_window=(True, False, False, False, False)):
    """A results folder as a simulated beta sweep writes it (5 cases)."""
    folder.mkdir(parents=True)
    beta = np.array([10.0, 30.0, 50.0, 70.0, 90.0])
    t = pd.DataFrame({
        "case": np.arange(5), "case_id": [f"c{i}" for i in range(5)],
        "obstacle.beta_deg": beta, "T_c_minus": [0.03, 0.34, 1.10, 2.15, 1.93],
        "F_max": [203.0, 634.0, 1234.0, 1766.0, 1773.0],
        "contact_duration": [0.2, 0.021, 0.020, 0.020, 0.019],
        "simulation.t_after": 0.2, "contact_whole_window": list(whole_window),
    })
    t.to_parquet(folder / "results.parquet", index=False)
    (folder / "manifest.json").write_text(json.dumps({
        "name": name, "parameters": ["obstacle.beta_deg"], "x": "obstacle.beta_deg",
        "simulate": True, "status": "complete"}))


@pytest.fixture(scope="module")
def studies(tmp_path_factory):
    """Three study folders named like the built-in ones, and a sweep without F_max."""
    root = tmp_path_factory.mktemp("studies")
    for stem in ("detc2014_fig2_beta", "detc2014_fig3_com_height", "detc2015_fig2_beta"):
        _fake_study(root / "repro" / stem, f"{stem}: F_max and T_c^- vs beta")
    assert main(["sweep", str(EX / "study_rigid_body.toml"), "-o", str(root / "rb"),
                 "--no-report"]) == 0
    return root


#: command -> (argv, units the headers must show, row labels printed whole)
TABLES = {
    "partition": (["partition", str(EX / "rod_on_ledge.toml")], [],
                  ["T_c (constrained, effective)", "energy lost in impact", "theta"]),
    "energy": (["energy", str(EX / "rover2d_beta45.toml")], [],
               ["m_eff along n (obstacle row alone)", "v_n (normal approach speed)"]),
    "contact": (["contact", "--k", "1e6", "--e", "0.8", "--mass", "12", "--speed", "0.5",
                 "--check"], ["[N]", "[mm]", "[ms]", "[J]"],
                ["max indentation [mm]", "contact duration [ms]", "achieved restitution e*"]),
    "contact --list": (["contact", "--list"], [], ["hunt-crossley", "carvalho-martins"]),
    "safety regions": (["safety", "regions", "--robot-mass", "20", "--payload", "1"],
                       ["[kg]", "[N/mm]", "[N]", "[m/s]"],
                       ["upper_arms_elbows", "lower_arms_wrists", "skull_forehead"]),
    "safety arm": (["safety", "arm", "erd:panda", "--payload", "1"], ["[kg]", "[m/s]"],
                   ["panda_link1", "panda_link7"]),
    "safety point": (["safety", "point", "erd:panda", "--frame", "panda_hand_tcp", "--direction", "1,0,0",
                     "--direction", "0,0,1", "--payload", "1"],
                     ["[kg]", "[m/s]"], []),
    "experiment": (["experiment", str(EX / "experiment" / "trials.toml"), "-o", "{tmp}/exp",
                    "--no-plot"], ["[deg]", "[m/s]", "[N]", "[N s]", "[ms]", "[J]"], []),
    "simulate": (["simulate", str(EX / "simulate_rover2d.toml"), "-o", "{tmp}/sim",
                  "--no-plot"], [], ["F_max (sum of obstacle contacts)",
                                     "T_c^- (effective kinetic energy)"]),
    "report": (["report", "{studies}/repro", "--n-boot", "100"], [],
               ["DETC2014 Fig. 2", "DETC2014 Fig. 3", "DETC2015 Fig. 2", "concordant"]),
    "report (no F_max)": (["report", "{studies}/rb", "--n-boot", "0"], [],
                          ["rb", "F_max n/a"]),
    "optimize": (["optimize", "{tmp}/opt.toml", "--no-simulate"], ["[J]", "[deg]", "[N]",
                                                                   "[m]"],
                 ["worst beta [deg]", "stability margin [m]"]),
}


def _run(capsys, argv, tmp_path, studies):
    (tmp_path / "opt.toml").write_text(OPT)
    argv = [a.format(tmp=tmp_path, studies=studies) for a in argv]
    rc = main(argv)
    out = capsys.readouterr()
    assert rc == 0, out.err
    return out.out, argv


@pytest.mark.parametrize("name", list(TABLES))
def test_tables_read_at_80_columns(capsys, tmp_path, studies, name):
    argv, units, labels = TABLES[name]
    out, _ = _run(capsys, argv, tmp_path, studies)
    lines = out.splitlines()
    assert max(len(line) for line in fitted_lines(out)) <= WIDTH, name
    assert "…" not in out, f"{name}: a truncated cell"
    for u in units:
        assert u in out, f"{name}: unit {u} lost"
    for label in labels:  # on one line: not cut, not folded
        assert any(label in line for line in lines), f"{name}: row label {label!r} broken"


def test_paths_are_printed_whole(capsys, tmp_path, studies):
    """A path longer than the terminal is printed on one line, not broken inside a name
    ("res" / "ults.parquet") as rich wraps text at the console's width."""
    deep = tmp_path / ("a_long_folder_name_" * 4) / "rb"
    shutil.copytree(studies / "rb", deep)
    assert main(["report", str(deep), "--n-boot", "0"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert f"report: {deep / 'report.html'}" in lines
    assert main(["sweep", str(EX / "study_rigid_body.toml"), "-o", str(deep.parent / "sw"),
                 "--no-report", "--overwrite"]) == 0
    out = capsys.readouterr().out
    assert f"results: {deep.parent / 'sw' / 'results.parquet'}" in out.splitlines(), out
    assert all(len(ln) <= WIDTH for ln in fitted_lines(out))


def test_a_table_title_that_fits_the_terminal_is_one_line(capsys):
    """contact's table (two narrow columns) wrapped its title at the table's width, inside
    "v_n = 0.5 m/s"; a table now widens to its title, up to the terminal's width."""
    assert main(["contact", "--k", "1e6", "--e", "0.8", "--mass", "12", "--speed",
                 "0.5"]) == 0
    out = capsys.readouterr().out
    assert any(ln.startswith("hunt-crossley: m_eff = 12 kg, v_n = 0.5 m/s, T_c^- = 1.5 J")
               for ln in out.splitlines()), out
    assert max(map(len, out.splitlines())) <= WIDTH


def test_agreement_table_says_whole_window_cases_are_excluded(capsys, studies):
    assert main(["report", str(studies / "repro"), "--n-boot", "100"]) == 0
    out = capsys.readouterr().out
    rows = [ln.split() for ln in out.splitlines() if "Spearman" in ln]
    # study label, cases, n, excl.: 5 cases, 4 used, 1 whole-window case excluded
    assert [r[-7:-4] for r in rows] == [["5", "4", "1"]] * 3  # then statistic, value, CI
    assert "whole-window cases excluded" in _flat(out)


def test_experiment_rows_wrap_file_names_but_keep_their_trial_index(capsys, tmp_path,
                                                                    studies):
    out, _ = _run(capsys, [*TABLES["experiment"][0], "--no-simulate"], tmp_path, studies)
    flat = _flat(out)   # (the per-trial table: the model's T_c^- alone is enough)
    for h in ("beta [deg]", "speed [m/s]", "F_peak [N]", "duration [ms]", "T_c^- [J]"):
        words = h.split()  # a header may wrap between its words
        assert all(w in flat for w in words), h
    # 14 trials: each row starts with its whole index and the start of its file name
    # (at 80 columns the 27-character names wrap onto a second line, whole)
    starts = [ln.split()[:2] for ln in out.splitlines()
              if re.match(r"^\s*\d+\s+trial_", ln)]
    assert [int(i) for i, _ in starts] == list(range(14))
    assert all(f.startswith(f"trial_{i:02d}") for (i, f) in
               ((int(a), b) for a, b in starts))


# ---------------------------------------------------------------------------------------
# --json and --csv
# ---------------------------------------------------------------------------------------

JSON = {
    "partition": ["partition", str(EX / "rod_on_ledge.toml"), "--json"],
    "energy": ["energy", str(EX / "rover2d_beta45.toml"), "--json"],
    "contact": ["contact", "--k", "1e6", "--e", "0.8", "--mass", "12", "--speed", "0.5",
                "--check", "--json"],
    "contact --list": ["contact", "--list", "--json"],
    "safety regions": ["safety", "regions", "--robot-mass", "20", "--json"],
    "safety arm": ["safety", "arm", "erd:panda", "--json"],
    "safety point": ["safety", "point", "erd:panda", "--frame", "panda_hand_tcp", "--direction", "1,0,0",
                   "--direction", "0,0,1", "--json"],
    "experiment": ["experiment", str(EX / "experiment" / "trials.toml"), "-o", "{tmp}/e",
                   "--no-plot", "--json"],
    "simulate": ["simulate", str(EX / "simulate_rover2d.toml"), "-o", "{tmp}/s",
                 "--no-plot", "--json"],
    "report": ["report", "{studies}/repro", "--n-boot", "100", "--json"],
    "sweep": ["sweep", str(EX / "study_rigid_body.toml"), "-o", "{tmp}/sw", "--json"],
    "optimize": ["optimize", "{tmp}/opt.toml", "--no-simulate", "--json"],
}


@pytest.mark.parametrize("name", list(JSON))
def test_json_is_strict_json(capsys, tmp_path, studies, name):
    out, _ = _run(capsys, JSON[name], tmp_path, studies)
    data = _strict_json(out)
    assert isinstance(data, dict) and data


def test_json_values(capsys, tmp_path, studies):
    out, _ = _run(capsys, JSON["contact"], tmp_path, studies)
    d = _strict_json(out)
    assert d["m_eff"] == 12 and d["v_n"] == 0.5 and d["T_c_minus"] == pytest.approx(1.5)
    out, _ = _run(capsys, JSON["report"], tmp_path, studies)
    s = _strict_json(out)["studies"]
    assert [x["n"] for x in s] == [4, 4, 4] and [x["n_whole_window"] for x in s] == [1, 1, 1]
    assert all(x["whole_window"] == "excluded" for x in s)
    # the regions where a transient contact is not permitted have no speed: null, not NaN
    out, _ = _run(capsys, JSON["safety regions"], tmp_path, studies)
    regions = {r["region"]: r for r in _strict_json(out)["regions"]}
    assert regions["face"]["v_max"] is None and regions["chest"]["v_max"] > 0


def test_json_writer_never_writes_nan_or_infinity():
    text = _app.json_text({"a": float("nan"), "b": [np.inf, -np.inf, 1.5], "c": np.float64(2),
                           "d": np.array([1, 2]), "e": np.bool_(True), "p": Path("x")})
    assert _strict_json(text) == {"a": None, "b": [None, None, 1.5], "c": 2.0, "d": [1, 2],
                                  "e": True, "p": "x"}


CSV = {
    "partition": (["partition", str(EX / "rod_on_ledge.toml"), "--csv"],
                  ["coordinate", "v", "v_c", "v_a", "v_plus"], 3),
    "safety regions": (["safety", "regions", "--csv"],
                       ["region", "m_H", "K", "F_qs", "F_transient"], 12),
    "safety arm": (["safety", "arm", "erd:panda", "--csv"], None, None),
    "safety point": (["safety", "point", "erd:panda", "--frame", "panda_hand_tcp", "--direction", "1,0,0",
                     "--direction", "0,0,1", "--csv"],
                     ["ux", "uy", "uz", "m_u", "v_max", "m_R_iso", "v_iso"], 2),
    "experiment": (["experiment", str(EX / "experiment" / "trials.toml"), "-o", "{tmp}/e",
                    "--no-plot", "--csv", "--no-simulate"],  # the per-trial table only
                   ["trial", "file", "beta_deg", "speed", "F_peak", "impulse", "duration",
                    "n_impacts"], 14),
}


@pytest.mark.parametrize("name", list(CSV))
def test_csv(capsys, tmp_path, studies, name):
    argv, header, n_rows = CSV[name]
    out, _ = _run(capsys, argv, tmp_path, studies)
    rows = list(csv.reader(io.StringIO(out)))
    if header is not None:
        assert rows[0] == header
    if n_rows is not None:
        assert len(rows) == 1 + n_rows
    assert all(len(r) == len(rows[0]) for r in rows)


def test_rod_csv_matches_the_closed_form(capsys, tmp_path, studies):
    # the rod of README: v_c = P_c v with v_n = -1.25 m/s at the end, m_eff = m/4
    out, _ = _run(capsys, CSV["partition"][0], tmp_path, studies)
    rows = {r[0]: [float(x) for x in r[1:]] for r in list(csv.reader(io.StringIO(out)))[1:]}
    # the impulse acts along a = [0, 1, -0.5]: dv = M^-1 a^T lambda, lambda = m_eff * 1.25
    lam = 0.5 * 1.25
    assert rows["z"][1] == pytest.approx(-lam / 2.0)
    assert rows["theta"][1] == pytest.approx(0.5 * lam / (2.0 / 12))


def test_trust_json_and_csv(capsys, tmp_path):
    out = tmp_path / "tm"
    assert main(["trust", "--quick", "--k", "1e6", "--e", "0.8", "-o", str(out), "--json"]) == 0
    d = _strict_json(capsys.readouterr().out)
    assert d["table"][0]["law"] == "hunt-crossley" and d["table"][0]["k"] == 1e6
    shutil.rmtree(out)
    assert main(["trust", "--quick", "--k", "1e6", "--e", "0.8", "-o", str(out), "--csv"]) == 0
    rows = list(csv.reader(io.StringIO(capsys.readouterr().out)))
    assert rows[0][:7] == ["law", "k", "e", "tau", "spearman", "n", "n_failed"]
    assert len(rows) == 2


def test_cli_prints_a_repeated_warning_once():
    """A command that loads the same file twice (a study checks its scenarios, then runs
    them) printed its warning twice."""
    import warnings

    from typer.testing import CliRunner

    from roverimpact.cli._app import _Typer

    app = _Typer()

    @app.command()
    def twice() -> None:
        for _ in range(2):
            warnings.warn("x.xml: equality constraints ['e'] are ignored", UserWarning,
                          stacklevel=1)
            warnings.resetwarnings()  # what a filter change does to Python's registry

    @app.command()
    def other() -> None:  # a second command, so that typer keeps the command names
        pass

    res = CliRunner().invoke(app, ["twice"])
    assert res.exit_code == 0, res.output
    assert res.output.count("equality constraints") == 1, res.output  # stdout + stderr


def test_a_warning_during_the_progress_bar_is_written_above_it(monkeypatch):
    """On a terminal a warning printed while the progress bar runs landed at the end of
    the bar's line ("... ETA 0:00:01warning: ..."): the bar was drawn by the stdout
    console, the warning by the stderr one. Both are the stderr console's now, which
    writes the warning on a line of its own above the bar; stdout gets neither."""
    import io
    import re
    import warnings

    from rich.console import Console

    from roverimpact.cli import _app

    err, out = io.StringIO(), io.StringIO()
    monkeypatch.setattr(_app, "err_console", Console(file=err, force_terminal=True,
                                                     width=100, markup=False))
    monkeypatch.setattr(_app, "console", Console(file=out, force_terminal=True, width=100))
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        warnings.showwarning = _app._show_once()
        with _app.progress_bar("demo") as update:
            update(1, 3)
            warnings.warn("a warning mid-run", stacklevel=1)
            update(3, 3)
    text = err.getvalue()
    assert "warning: a warning mid-run" in text and "demo" in text
    assert not re.search(r"ETA[^\r\n]*warning", text)  # not appended to the bar's line
    assert out.getvalue() == ""
