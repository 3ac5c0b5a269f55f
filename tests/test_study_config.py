"""Study files and the `sweep` command: bad input fails early with one clear error (exit 2)."""

from __future__ import annotations

import os
import socket
import textwrap
from pathlib import Path

import pandas as pd
import pytest

from roverimpact.cli import main
from roverimpact.exceptions import ConfigError
from roverimpact.studies import run_study

GOOD = """
name = "rigid body"
[base.model]
name = "rigid_body"
params = { mass = 20.0, inertia = 1.0, com_height = 0.3, lever = 0.4 }
[base.velocity]
u = 0.5
[base.obstacle]
frame = "contact"
beta_deg = 90.0
[grid]
"obstacle.beta_deg" = { start = 30, stop = 90, num = 4 }
"""


def _write(tmp_path: Path, text: str, name: str = "study.toml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def _fails(capsys, argv, *patterns):
    assert main(argv) == 2
    err = capsys.readouterr().err
    lines = [ln for ln in err.strip().splitlines() if ln.strip()]
    assert lines and lines[0].startswith("error:"), err
    assert "Traceback" not in err
    text = " ".join(err.split())
    for pat in patterns:
        assert pat in text, (pat, err)
    return text


def test_sweep_command_writes_table_report_and_csv(tmp_path, capsys):
    study = _write(tmp_path, GOOD)
    out = tmp_path / "res"
    assert main(["sweep", str(study), "-o", str(out), "--csv"]) == 0
    text = capsys.readouterr().out
    assert "4 cases (4 computed, 0 reused)" in text and "report.html" in text
    t = pd.read_parquet(out / "results.parquet")
    assert len(t) == 4 and (out / "results.csv").is_file() and (out / "figure.png").is_file()
    assert (out / "study.toml").read_text() == GOOD  # the study file, copied as given
    assert main(["sweep", str(study), "-o", str(out), "--resume"]) == 0
    assert "(0 computed, 4 reused)" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("text", "patterns"),
    [
        (GOOD.replace('"obstacle.beta_deg"', '"obstacle.betta_deg"'),
         ["unknown parameter 'obstacle.betta_deg'", "did you mean 'obstacle.beta_deg'"]),
        (GOOD.split("[grid]")[0] + "[grid]\n", ["the grid table is empty"]),
        (GOOD.replace('{ start = 30, stop = 90, num = 4 }', "[]"), ["empty list of values"]),
        (GOOD.replace('{ start = 30, stop = 90, num = 4 }', '["30 deg", "60 deg"]'),
         ["obstacle.beta_deg", "plain number", "*_deg in degrees"]),
        (GOOD.replace('{ start = 30, stop = 90, num = 4 }', '{ start = 30, stop = "ninety", num = 4 }'),
         ["grid.obstacle.beta_deg", "stop"]),
        (GOOD.replace('{ start = 30, stop = 90, num = 4 }', "[30, 120]"),
         ["obstacle.beta_deg = 120", "must be in [0, 90] degrees"]),
        (GOOD.replace("mass = 20.0", "mass = -1.0"), ["base scenario", "mass", "> 0"]),
        (GOOD.replace('name = "rigid body"', 'name = "x"\nsimulat = true'), ["simulat"]),
        (GOOD + "[random]\nn = 3\nseed = 1\nparams = { 'velocity.u' = { low = 0.1, high = 1 } }\n",
         ["exactly one of: a grid table, a cases list or a random table"]),
        ("name = 'x'\n[base\n", ["malformed TOML"]),
    ],
    ids=["unknown-param", "empty-grid", "empty-list", "units-in-value", "wrong-type",
         "out-of-range", "bad-base", "unknown-key", "two-designs", "bad-toml"],
)
def test_bad_study_files_fail_before_any_work(tmp_path, capsys, text, patterns):
    study = _write(tmp_path, text)
    out = tmp_path / "never"
    _fails(capsys, ["sweep", str(study), "-o", str(out)], *patterns)
    assert not out.exists()  # nothing was started


def test_unknown_rover_parameter_is_named(tmp_path, capsys):
    text = """
name = "rover"
[base]
model = { name = "rover2d" }
velocity = { u = 0.5 }
obstacle = { wheel = "front", beta_deg = 60.0 }
[grid]
"model.params.com_height" = [0.3, 0.4]
"""
    _fails(capsys, ["sweep", str(_write(tmp_path, text)), "-o", str(tmp_path / "o")],
           "unknown parameter 'model.params.com_height'")


@pytest.mark.skipif(os.geteuid() == 0, reason="root can write anywhere it has a path")
def test_unwritable_output_folder_nonroot(tmp_path, capsys):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        _fails(capsys, ["sweep", str(_write(tmp_path, GOOD)), "-o", str(ro / "out")],
               "not writable")
    finally:
        ro.chmod(0o700)


def test_unwritable_output_folder(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("a file, not a folder")
    # checked before the study (nothing created): the message names the file in the way
    _fails(capsys, ["sweep", str(_write(tmp_path, GOOD)), "-o", str(blocker / "out")],
           "output folder", f"{blocker} is a file, not a folder")


def test_unreachable_or_malformed_scheduler(tmp_path, capsys):
    pytest.importorskip("dask.distributed")
    with socket.socket() as s:  # a free port that nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    study = str(_write(tmp_path, GOOD))
    out = tmp_path / "o"
    _fails(capsys, ["sweep", study, "-o", str(out), "--scheduler", f"tcp://127.0.0.1:{port}"],
           "cannot reach the Dask scheduler", "dask scheduler")
    _fails(capsys, ["sweep", study, "-o", str(out), "--scheduler", "http://host"],
           "tcp://HOST:PORT")
    _fails(capsys, ["sweep", study, "-o", str(out), "--workers", "2", "--scheduler",
                    f"tcp://127.0.0.1:{port}"], "either --workers or --scheduler")
    assert not out.exists()


def test_report_of_a_folder_without_results(tmp_path, capsys):
    _fails(capsys, ["report", str(tmp_path)], "no study results")


def test_library_raises_config_error(tmp_path):
    with pytest.raises(ConfigError, match="unknown parameter"):
        run_study({"name": "x", "base": {"model": {"name": "rigid_body"},
                                         "obstacle": {"frame": "contact", "beta_deg": 90.0}},
                   "grid": {"velocity.uu": [1.0]}}, tmp_path / "o")


def test_example_study_files_are_valid():
    from roverimpact.studies import prepare_study

    root = Path(__file__).resolve().parents[1] / "examples"
    files = sorted(root.glob("study_*.toml"))
    assert len(files) >= 2
    for f in files:
        prep = prepare_study(f)
        assert prep.cases and prep.study.n_cases() == len(prep.cases)


@pytest.mark.parametrize("simulate, workers, start, here", [
    (True, None, "fork", ["partition_kernel", "rk4_peaks"]),
    (False, None, "fork", ["partition_kernel"]),
    (True, 2, "fork", ["partition_kernel", "rk4_peaks"]),     # forked workers inherit them
    (True, 2, "spawn", None),
])
def test_sweep_compile_plan(tmp_path, monkeypatch, compile_plan, simulate, workers, start,
                            here):
    """On a fresh install ``sweep`` sends Lemke's impact kernel to a second process and
    compiles the partition (and, when the study simulates, the Runge-Kutta kernel of the
    refined prediction) here, also before forking local workers; nothing for spawned
    workers; a bad file fails before any of it."""
    from roverimpact.cli import _study

    monkeypatch.setenv("ROVERIMPACT_WORKER_START", start)

    text = textwrap.dedent(f"""
        name = "plan"
        simulate = {str(simulate).lower()}
        [base]
        model = {{ name = "rover2d" }}
        velocity = {{ u = 0.3 }}
        obstacle = {{ wheel = "front", beta_deg = 60.0 }}
        [grid]
        "obstacle.beta_deg" = [30.0, 60.0]
    """)
    study = tmp_path / "s.toml"
    study.write_text(text)
    sent = compile_plan.sent
    now, small = _study._compile_plan(study, workers, None)
    if here is None:
        assert now == () and sent == [] and not small
    else:
        assert sent == ["impact_kernel"]
        assert [k.home.split(":")[1] for k in now] == here
        assert small  # 2 cases: their Python code while the kernels compile elsewhere
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace('name = "plan"', 'name = "plan"\nspeedy = 1'))
    sent.clear()
    with pytest.raises(ConfigError):
        _study._compile_plan(bad, None, None)
    assert sent == []


def test_a_unit_in_a_swept_value_is_explained_once(tmp_path, capsys):
    """'0.2 m' in a grid: the message says once to write a plain number (it said it twice,
    once from the scenario's schema and once from the study's check)."""
    text = (Path(__file__).parents[1] / "examples" / "study_rigid_body.toml").read_text()
    f = tmp_path / "s.toml"
    f.write_text(text.replace("[0.2, 0.4]", '["0.2 m", 0.4]'))
    assert main(["sweep", str(f), "-o", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert err.count("write a plain number") == 1 and "'0.2 m'" in err


def test_study_copy_names_its_files_by_absolute_path(tmp_path, monkeypatch):
    """A study file with a [base] table naming its model relative to its folder was copied
    as given into the output folder: run from there (``--resume``, or the copy as a study
    file elsewhere) it read <out>/mjcf_rover.xml, "no such URDF/MJCF file". The copy now
    names the file by absolute path: read from another folder, it is the same study (the
    manifest's fingerprint) and resumes."""
    import json
    import shutil

    from roverimpact.studies.config import load_study

    src = tmp_path / "in"
    src.mkdir()
    shutil.copy(Path(__file__).parents[1] / "examples" / "mjcf_rover.xml", src)
    (src / "study.toml").write_text(textwrap.dedent("""\
        name = "relative model file"
        x = "obstacle.beta_deg"
        [base]
        velocity = { u = 0.5 }
        obstacle = { wheel = "front", beta_deg = 45.0 }
        [base.model]
        file = "mjcf_rover.xml"
        base = { kind = "planar" }
        wheels = { front = { frame = "front_tire" }, rear = { frame = "rear_wheel" } }
        [grid]
        "obstacle.beta_deg" = [30.0, 60.0]
        """))
    out = tmp_path / "out"
    first = run_study(src / "study.toml", out)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    study, _ = load_study(out / "study.toml")
    assert study.base["model"]["file"] == str((src / "mjcf_rover.xml").resolve())
    assert study.fingerprint() == json.loads((out / "manifest.json").read_text())["fingerprint"]
    again = run_study(out / "study.toml", out, resume=True)
    pd.testing.assert_frame_equal(again.table, first.table)


def _validated(study: dict) -> tuple[list, list]:
    """The values of ``obstacle.beta_deg`` / ``model.params.mass`` that
    ``validate_scenarios`` gave the schema check and the deep check, in order."""
    from roverimpact.studies.config import Study, validate_scenarios
    from roverimpact.studies.evaluate import ScenarioEvaluator

    ev = ScenarioEvaluator()
    seen: tuple[list, list] = ([], [])

    def value(scn):
        return scn["obstacle"]["beta_deg"], scn["model"]["params"]["mass"]

    def validate(scn):
        seen[0].append(value(scn))
        return ev.validate(scn)

    def check(scn):
        seen[1].append(value(scn))
        return ev.check(scn)

    validate_scenarios(Study.model_validate(study), validate, check)
    return seen


def _rigid_study(grid: dict) -> dict:
    import tomllib

    return {**tomllib.loads(GOOD), "grid": grid}


def test_a_fine_grid_is_validated_at_its_ends_and_every_other_value_on_its_own():
    """Numbers: the smallest and largest of each type are validated and checked (the rules
    on a number are ranges), not each of 20 000; texts, booleans and non-finite numbers
    each; 1, 1.0 and true are three values (they were one: true went unchecked)."""
    schema, deep = _validated(_rigid_study(
        {"obstacle.beta_deg": {"start": 1.0, "stop": 90.0, "num": 20_000}}))
    assert schema == deep == [(90.0, 20.0), (1.0, 20.0), (90.0, 20.0)]  # base, then ends
    schema, deep = _validated(_rigid_study({"model.params.mass": [30.0, 12, 5, 18.5, 7.0,
                                                                  40]}))
    assert [m for _, m in schema[1:]] == [m for _, m in deep[1:]] == [30.0, 5, 7.0, 40]
    with pytest.raises(ConfigError, match=r"beta_deg = True.*boolean"):
        _validated(_rigid_study({"obstacle.beta_deg": [30.0, 1, True]}))
    with pytest.raises(ConfigError, match=r"mass = nan"):  # the deep check (the builder)
        _validated(_rigid_study({"model.params.mass": [10.0, float("nan"), 20.0]}))
    with pytest.raises(ConfigError, match=r"beta_deg = 95.0"):
        _validated(_rigid_study({"obstacle.beta_deg": [30.0, 95.0, 60.0]}))
