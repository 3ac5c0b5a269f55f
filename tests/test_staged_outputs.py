"""Output folders of simulate, experiment and traverse are written beside the target and
put in place whole (roverimpact._io.staged_folder): a re-run replaces the previous run's
files (none is left beside the new ones), a failed or interrupted run leaves the folder as
it was, and a folder of the user's own files is refused before any work."""

from __future__ import annotations

from pathlib import Path

import pytest

from roverimpact._io import staged_folder
from roverimpact.cli import main
from roverimpact.exceptions import ConfigError

EX = Path(__file__).resolve().parents[1] / "examples"
OWNED = ("table.parquet", "table.csv", "summary.json", "*.toml")
SIGNATURE = ("summary.json",)


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def test_replaced_whole_or_left_as_it_was(tmp_path):
    out = tmp_path / "a" / "b"
    with staged_folder(out, OWNED, SIGNATURE, "test") as work:
        assert not out.exists() and work.parent == tmp_path  # nothing made on the way
        (work / "table.csv").write_text("1")
        (work / "summary.json").write_text("{}")
    assert _snapshot(out) == {"summary.json": b"{}", "table.csv": b"1"}
    before = _snapshot(out)
    for exc in (KeyboardInterrupt, ValueError):
        with pytest.raises(exc), staged_folder(out, OWNED, SIGNATURE, "test") as work:
            (work / "table.parquet").write_text("new")
            (work / "summary.json").write_text('{"new": 1}')
            raise exc
        assert _snapshot(out) == before
    with staged_folder(out, OWNED, SIGNATURE, "test") as work:
        (work / "table.parquet").write_text("2")
        (work / "summary.json").write_text("{}")
    assert _snapshot(out) == {"summary.json": b"{}", "table.parquet": b"2"}  # no table.csv
    assert [p.name for p in tmp_path.iterdir() if "partial" in p.name] == []
    (out / "notes.txt").write_text("mine")
    with pytest.raises(ConfigError, match=r"not the outputs of a previous test run "
                                          r"\(notes\.txt\)"), \
            staged_folder(out, OWNED, SIGNATURE, "test"):
        pass
    theirs = tmp_path / "theirs"
    theirs.mkdir()
    (theirs / "scenario.toml").write_text("x")  # owned by name, but no signature
    with pytest.raises(ConfigError, match=r"scenario\.toml"), \
            staged_folder(theirs, OWNED, SIGNATURE, "test"):
        pass
    (theirs / ".hidden").write_text("")  # dot files are not looked at
    (theirs / "scenario.toml").unlink()
    with staged_folder(theirs, OWNED, SIGNATURE, "test") as work:
        (work / "summary.json").write_text("{}")
    assert sorted(p.name for p in theirs.iterdir()) == [".hidden", "summary.json"]


def _trials_without_model(folder, recordings):
    """The example trials file without its [model] table, in ``folder`` with copies of the
    example recordings matching ``recordings``: an experiment with no model comparison."""
    text = (EX / "experiment" / "trials.toml").read_text()
    i = text.index("[model]")
    j = text.find("\n[", i + 1)
    bare = folder / "trials.toml"
    bare.write_text(text[:i] + (text[j + 1:] if j > 0 else ""))
    for f in (EX / "experiment").glob(recordings):
        (folder / f.name).write_bytes(f.read_bytes())
    return bare


def test_experiment_rerun_replaces_its_outputs(tmp_path, capsys):
    """The second run, without a model and without a plot, leaves no comparison.csv,
    overlay.png or inputs of the first beside its own files (they were left before). (The
    first compares with T_c^- alone: the same files, without 14 simulations.)"""
    out = tmp_path / "eo"
    assert main(["experiment", str(EX / "experiment" / "trials.toml"), "-o", str(out),
                 "--no-simulate"]) == 0
    first = {p.name for p in out.iterdir()}
    assert {"comparison.csv", "overlay.png", "inputs_scenario.toml"} <= first
    bare = _trials_without_model(tmp_path, "*.csv")
    assert main(["experiment", str(bare), "-o", str(out), "--no-plot"]) == 0
    second = {p.name for p in out.iterdir()}
    assert "comparison.csv" not in second and "overlay.png" not in second
    assert "inputs_scenario.toml" not in second and "trials.csv" in second
    capsys.readouterr()


def test_a_users_folder_or_file_beside_the_outputs_is_never_deleted(tmp_path, capsys):
    """A file matching an owned pattern is replaced, but a folder never is: an 'inputs_raw/'
    folder holding a recording made the experiment's 'inputs_*' pattern rmtree it, and
    'inputs_notes.txt' was deleted too. Now the experiment names its files exactly, and
    the second run refuses the folder (exit 2) leaving both in place."""
    out = tmp_path / "o"
    with staged_folder(out, OWNED, SIGNATURE, "test") as work:
        (work / "summary.json").write_text("{}")
    (out / "x.toml").mkdir()
    (out / "x.toml" / "keep.csv").write_text("1")
    with pytest.raises(ConfigError, match=r"x\.toml"):
        with staged_folder(out, OWNED, SIGNATURE, "test") as work:
            (work / "summary.json").write_text("{}")
    assert (out / "x.toml" / "keep.csv").read_text() == "1"

    exp = tmp_path / "eo"
    bare = _trials_without_model(tmp_path, "trial_0*.csv")
    bare.write_text(bare.read_text().split("[[trial]]")[0] + "[[trial]]"
                    + bare.read_text().split("[[trial]]")[1])
    assert main(["experiment", str(bare), "-o", str(exp), "--no-plot"]) == 0
    (exp / "inputs_notes.txt").write_text("my notes")
    (exp / "inputs_raw").mkdir()
    (exp / "inputs_raw" / "a.csv").write_text("1")
    assert main(["experiment", str(bare), "-o", str(exp), "--no-plot"]) == 2
    assert "inputs_notes.txt" in capsys.readouterr().err
    assert (exp / "inputs_notes.txt").read_text() == "my notes"
    assert (exp / "inputs_raw" / "a.csv").read_text() == "1"


def test_experiment_files_name_the_input_copies():
    from roverimpact.cli._experiment import EXPERIMENT_FILES
    from roverimpact.experiments.pipeline import INPUT_COPIES

    assert set(INPUT_COPIES.values()) <= set(EXPERIMENT_FILES)
    assert not any("*" in f or "?" in f for f in EXPERIMENT_FILES)


def test_outputs_without_their_summary_are_not_called_foreign(tmp_path):
    """After summary.json of a run was deleted, the refusal said the run's own files
    'are not the outputs of a previous run'; it now says what is missing."""
    out = tmp_path / "o"
    with staged_folder(out, OWNED, SIGNATURE, "test") as work:
        (work / "summary.json").write_text("{}")
        (work / "table.csv").write_text("1")
    (out / "summary.json").unlink()
    with pytest.raises(ConfigError, match=r"has no summary\.json, so its files \(table\.csv\) "
                                          r"are not taken for the outputs of a previous test"), \
            staged_folder(out, OWNED, SIGNATURE, "test"):
        pass
    assert (out / "table.csv").read_text() == "1"


def test_sigterm_leaves_the_output_folder_as_it_was(tmp_path):
    """SIGTERM (`kill`, `timeout`) while `simulate` works: the process died where it stood
    (exit -15, nothing said) and its staging folder `.out.partial-*` stayed beside the
    output for good; now it ends as interrupted ("terminated", exit 143), the staging
    folder is removed and the previous output is left as it was."""
    import signal
    import subprocess
    import sys
    import textwrap
    import time

    out = tmp_path / "out"
    out.mkdir()
    for name in ("summary.json", "config.json"):  # a previous run's output
        (out / name).write_text("{}")
    marker = tmp_path / "working"
    code = textwrap.dedent(f"""
        import pathlib, sys, time
        import roverimpact.simulate as sim
        def slow(*a, **kw):
            pathlib.Path({str(marker)!r}).touch()
            time.sleep(60)
        sim.simulate_scenario = slow
        from roverimpact.cli import main
        sys.exit(main(["simulate", {str(EX / "simulate_rover2d.toml")!r}, "-o", {str(out)!r},
                       "--no-plot"]))
    """)
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    t_end = time.time() + 60
    while time.time() < t_end and not marker.exists() and proc.poll() is None:
        time.sleep(0.05)
    proc.send_signal(signal.SIGTERM)
    _out, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    assert "terminated" in err and "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out", "working"]
    assert _snapshot(out) == {"config.json": b"{}", "summary.json": b"{}"}


def test_a_ctrl_c_while_the_outputs_are_put_in_place_loses_none(tmp_path, monkeypatch):
    """Ctrl-C while the new outputs replace the old ones (a few moves): the old files
    were removed first and the new ones moved one by one, so a Ctrl-C between two moves
    left a folder with neither run's outputs (the rest went with the staging folder).
    The signal is now held until every file is in place; then the command stops."""
    import os
    import signal

    from roverimpact import _io

    out = tmp_path / "out"
    with staged_folder(out, OWNED, SIGNATURE, "test") as work:
        for name in ("summary.json", "table.csv"):
            (work / name).write_text("old")
    real, calls = os.replace, []

    def replace(src, dst):
        calls.append(dst)
        if len(calls) == 1:  # Ctrl-C after the first file is in place
            os.kill(os.getpid(), signal.SIGINT)
        real(src, dst)

    monkeypatch.setattr(_io.os, "replace", replace)
    with pytest.raises(KeyboardInterrupt), staged_folder(out, OWNED, SIGNATURE, "test") as work:
        for name in ("summary.json", "table.parquet"):
            (work / name).write_text("new")
    assert len(calls) == 2
    assert _snapshot(out) == {"summary.json": b"new", "table.parquet": b"new"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_ctrl_c_says_the_output_folder_is_as_it_was(tmp_path, monkeypatch, capsys):
    """A Ctrl-C in `simulate` (its outputs staged): the message was a bare "interrupted";
    it says that nothing was written and the folder is as it was."""
    import roverimpact.simulate as sim

    def interrupted(*a, **kw):
        raise KeyboardInterrupt

    monkeypatch.setattr(sim, "simulate_scenario", interrupted)
    out = tmp_path / "out"
    args = ["simulate", str(EX / "simulate_rover2d.toml"), "-o", str(out), "--no-plot"]
    assert main(args) == 130
    err = " ".join(capsys.readouterr().err.split())
    assert f"interrupted: nothing was written ({out} was not made)" in err
    out.mkdir()
    for name in ("summary.json", "config.json"):  # a previous run's output
        (out / name).write_text("{}")
    assert main(args) == 130
    err = " ".join(capsys.readouterr().err.split())
    assert f"interrupted: nothing was written; {out} is as it was" in err
    assert _snapshot(out) == {"config.json": b"{}", "summary.json": b"{}"}
