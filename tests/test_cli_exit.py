"""The console script's end (``roverimpact.cli.run``) and the compile plan of ``energy``.

``run`` ends the process with ``os._exit`` once the command is done (Python's teardown of
every module costs 0.3 s after compiled kernels were loaded; benchmarks/bench_startup.py).
What a normal exit guarantees must still hold: the exit code, every byte written to
stdout (a file: block-buffered) by Python and by C code, the ``atexit`` handlers, and a
running non-daemon thread is waited for.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = str(ROOT / "src")
EXAMPLE = ROOT / "examples" / "rover2d_beta45.toml"


def _run(code: str, tmp_path: Path, *args: str) -> tuple[int, str]:
    """Run ``code`` with stdout to a file (block-buffered, as in ``> out.txt``: without
    PYTHONUNBUFFERED, which would make Python's and C's stdout unbuffered)."""
    out = tmp_path / "stdout.txt"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        p for p in (SRC, os.environ.get("PYTHONPATH")) if p))
    env.pop("PYTHONUNBUFFERED", None)
    with open(out, "wb") as f:
        rc = subprocess.run([sys.executable, "-c", code, *args], stdout=f,
                            stderr=subprocess.PIPE, env=env, cwd=tmp_path, timeout=300).returncode
    return rc, out.read_text()


def test_run_keeps_exit_code_output_and_exit_handlers(tmp_path):
    marker = tmp_path / "atexit.txt"
    code = f"""
import atexit, ctypes, sys
from pathlib import Path

import pytest
atexit.register(lambda: Path({str(marker)!r}).write_text("ran"))
print("python line")
ctypes.CDLL(None).printf(b"C line\\n")        # C stdio, buffered when stdout is a file
sys.argv = ["roverimpact", "energy", sys.argv[1]]
from roverimpact.cli import run
run()
"""
    rc, out = _run(code, tmp_path, str(EXAMPLE))
    assert rc == 0
    assert "python line" in out and "C line" in out
    assert "T_c^- (effective)" in out and "active rows / rank" in out  # the whole table
    assert marker.read_text() == "ran"
    # a failing command keeps its code (2: bad input) and its message
    rc, out = _run(code, tmp_path, str(tmp_path / "missing.toml"))
    assert rc == 2 and "python line" in out


def test_run_waits_for_a_running_thread(tmp_path):
    """A non-daemon thread still working when the command returns is waited for (the
    usual exit), not killed."""
    marker = tmp_path / "thread.txt"
    code = f"""
import sys, threading, time
from pathlib import Path

import pytest
def work():
    time.sleep(0.5)
    Path({str(marker)!r}).write_text("done")
threading.Thread(target=work).start()
sys.argv = ["roverimpact", "--version"]
from roverimpact.cli import run
run()
"""
    rc, out = _run(code, tmp_path)
    assert rc == 0 and out.strip()
    assert marker.read_text() == "done"


def test_python_m_runs_the_cli(tmp_path):
    rc, out = _run("import runpy, sys; sys.argv = ['roverimpact', '--version']; "
                   "runpy.run_module('roverimpact.cli', run_name='__main__')", tmp_path)
    assert rc == 0 and out.strip()


def test_python_m_roverimpact_runs_the_cli(tmp_path):
    """``python -m roverimpact`` is the command too (it was "No module named
    roverimpact.__main__", exit 1); importing the module runs nothing."""
    from roverimpact import __version__

    rc, out = _run("import runpy, sys; sys.argv = ['roverimpact', '--version']; "
                   "runpy.run_module('roverimpact', run_name='__main__', alter_sys=True)",
                   tmp_path)
    assert (rc, out.strip()) == (0, f"roverimpact {__version__}")
    rc, out = _run("import sys; sys.argv = ['roverimpact', '--version']; "
                   "import roverimpact.__main__", tmp_path)
    assert (rc, out) == (0, "")


def test_energy_compiles_the_partition_here_and_the_rows_in_the_background(compile_plan):
    """On a fresh install ``energy`` sends the row assembly (needed first, the shorter
    compile) to a second process and compiles the partition kernel itself meanwhile, after
    the scenario file has been read: a bad file fails before any compile."""
    from roverimpact.cli import main

    assert main(["energy", str(EXAMPLE)]) == 0
    assert compile_plan.sent == ["_evaluate_one"]
    assert compile_plan.got.index("partition_kernel") < compile_plan.got.index("_evaluate_one")

    compile_plan.got.clear()
    assert main(["energy", str(ROOT / "no-such-file.toml")]) == 2
    assert "partition_kernel" not in compile_plan.got


@pytest.mark.parametrize("text, word", [
    ('[model]\nname = "rover2d"\nparams = { h = "0.35 m" }\n[obstacle]\nwheel = "front"\n'
     'beta_deg = 45\n', "plain number"),
    ('[model]\nfile = "missing.urdf"\n[obstacle]\nframe = "a"\nnormal = [0, 0, 1]\n', "no such"),
])
def test_energy_refuses_a_model_that_does_not_build_before_compiling(compile_plan, tmp_path,
                                                                      capfd, text, word):
    """``energy`` compiled the partition kernel (2-6 s on a fresh install) before building
    the model: a parameter with a unit or a missing URDF got its one-line error after that
    compile. The model is built first (milliseconds); only the background compile of the
    row assembly, which overlaps the loading, has started."""
    from roverimpact.cli import main

    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    capfd.readouterr()
    assert main(["energy", str(bad)]) == 2
    assert word in capfd.readouterr().err
    assert compile_plan.got == []


def test_console_script_entry_is_run():
    """pyproject's script is ``roverimpact.cli:run`` (the fast end), not ``main``."""
    import tomllib

    with open(ROOT / "pyproject.toml", "rb") as f:
        scripts = tomllib.load(f)["project"]["scripts"]
    assert scripts["roverimpact"] == "roverimpact.cli:run"


def test_simulate_sends_lemke_to_the_background_and_compiles_the_partition_here(
        compile_plan, tmp_path):
    from roverimpact.cli import main

    example = ROOT / "examples" / "simulate_rover2d.toml"
    assert main(["simulate", str(example), "-o", str(tmp_path / "o"), "--no-plot"]) == 0
    assert compile_plan.sent == ["impact_kernel"]
    assert compile_plan.got[0] == "partition_kernel" and "impact_kernel" in compile_plan.got


@pytest.mark.parametrize("old, new, word", [
    ("u = 0.3 ", "u = 0.0 ", "velocity.u > 0"),
    ("h = 0.4 }", 'h = "0.4 m" }', "plain number"),
    ('wheel = "front"', 'wheel = "nose"', "unknown or empty wheel list ['nose']"),
])
def test_simulate_refuses_a_scenario_it_cannot_run_before_any_compile(compile_plan, tmp_path,
                                                                       capfd, old, new, word):
    """``simulate`` sent Lemke's kernel to a second process and compiled the partition
    kernel (2-6 s on a fresh install) before building the model and reading the
    [simulation] settings: a scenario with no driving speed, a parameter with a unit or an
    unknown wheel got its one-line error after that compile. They are checked first (20 ms
    for the example)."""
    from roverimpact.cli import main

    text = (ROOT / "examples" / "simulate_rover2d.toml").read_text()
    assert old in text
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace(old, new, 1))
    capfd.readouterr()
    assert main(["simulate", str(bad), "-o", str(tmp_path / "o"), "--no-plot"]) == 2
    assert word in capfd.readouterr().err
    assert (compile_plan.sent, compile_plan.got) == ([], [])


def test_ctrl_c_swallowed_by_the_compiler_is_an_interruption(monkeypatch, capsys):
    """A Ctrl-C while numba's compiler is in a C callback: Python reports that
    KeyboardInterrupt as an unraisable exception and numba then fails with a RuntimeError
    ("no compiled object yet", a traceback at 10-16 s of a first `roverimpact energy`).
    The command ends as interrupted, exit 130, without a traceback; a RuntimeError with
    no Ctrl-C before it still propagates."""
    import types

    import pytest

    import roverimpact.cli as cli

    def compile_interrupted(argv):
        sys.unraisablehook(types.SimpleNamespace(
            exc_type=KeyboardInterrupt, exc_value=KeyboardInterrupt(), exc_traceback=None,
            err_msg="Exception ignored on calling ctypes callback function", object=None))
        raise RuntimeError("no compiled object yet for <Library 'partition_kernel'>")

    monkeypatch.setattr(cli, "_main", compile_interrupted)
    hook = sys.unraisablehook
    assert cli.main(["energy", "x.toml"]) == 130
    err = capsys.readouterr().err
    assert "interrupted" in err and "Exception ignored" not in err
    assert sys.unraisablehook is hook  # restored

    def plain_failure(argv):
        raise RuntimeError("a bug")

    monkeypatch.setattr(cli, "_main", plain_failure)
    with pytest.raises(RuntimeError, match="a bug"):
        cli.main(["energy", "x.toml"])


def test_ctrl_c_in_a_finalizer_stops_the_command(monkeypatch, capsys):
    """A Ctrl-C that lands in a finalizer (Dask's Future.__del__, run as a study drops a
    finished chunk's future): Python cannot raise it there and reports it as unraisable,
    and the command went on to its end and exited 0 (test_study_sweep's SIGINT test failed
    so, now and then: "assert 0 == 130", nothing on stderr). It is delivered again and
    stops the command where it goes on: exit 130, "interrupted", no traceback."""
    import roverimpact.cli as cli

    went_on = []

    class Dropped:
        def __del__(self):
            raise KeyboardInterrupt  # as the command's SIGINT handler raises it there

    def command(argv):
        Dropped()  # dropped at once: its finalizer runs
        end = time.monotonic() + 5.0
        while time.monotonic() < end:  # the command goes on
            went_on.append(1)
        return 0

    monkeypatch.setattr(cli, "_main", command)
    t0 = time.monotonic()
    assert cli.main(["sweep", "x.toml"]) == 130
    assert time.monotonic() - t0 < 2.0 and went_on  # stopped where it went on
    err = capsys.readouterr().err
    assert "interrupted" in err and "Traceback" not in err and "Exception ignored" not in err
    # a command that ends before the interruption comes again: nothing is delivered later
    went_on.clear()

    def short(argv):
        Dropped()
        return 0

    monkeypatch.setattr(cli, "_main", short)
    cli.main(["sweep", "x.toml"])
    time.sleep(5 * cli.REDELIVER_S)  # a KeyboardInterrupt here would fail the test
