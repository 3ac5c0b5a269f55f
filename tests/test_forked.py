"""Independent tasks side by side in forked processes (``studies.forked``), and
``reproduce``'s studies run that way."""

from __future__ import annotations

import os
import signal
import sys
import threading
import time

import pytest

from roverimpact.exceptions import ConfigError, StudyInterrupted
from roverimpact.studies import forked
from roverimpact.studies import reproduce as repro
from roverimpact.studies.forked import map_forked, side_by_side

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="no fork on this system")


def _square(x, emit):
    emit("began", x, os.getpid())
    return x * x, os.getpid()


def test_results_come_back_in_order_from_other_processes():
    events = []
    out = map_forked(_square, range(7), processes=2, events=lambda *e: events.append(e))
    assert [r for r, _ in out] == [x * x for x in range(7)]
    pids = {pid for _, pid in out}
    assert os.getpid() not in pids and 1 <= len(pids) <= 2
    assert sorted(x for _, x, _ in events) == list(range(7))  # every event reached here
    assert {pid for _, _, pid in events} == pids


def test_one_process_or_one_item_runs_here():
    assert map_forked(_square, range(3), processes=1) == [(x * x, os.getpid())
                                                          for x in range(3)]
    assert map_forked(_square, [4], processes=4) == [(16, os.getpid())]
    assert map_forked(_square, [], processes=4) == []


def test_the_first_error_is_raised_once_the_begun_items_end(tmp_path):
    """Item 0 fails once item 1 has begun in the other process; item 1 runs to its end;
    no item after them is begun."""
    begun = tmp_path / "begun-1"

    def work(x, emit):
        if x == 0:
            t = time.monotonic()
            while not begun.exists() and time.monotonic() - t < 10:
                time.sleep(0.01)
            raise ConfigError("case 0 cannot be posed")
        if x == 1:
            begun.write_text("")
        time.sleep(0.3)
        (tmp_path / f"done-{x}").write_text("")
        return x

    with pytest.raises(ConfigError, match="case 0 cannot be posed"):
        map_forked(work, range(6), processes=2)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["begun-1", "done-1"]


def test_a_result_that_cannot_be_sent_back_is_an_error():
    with pytest.raises(RuntimeError, match="a result could not be sent back"):
        map_forked(lambda x, emit: (lambda: x), range(2), processes=2)


def test_a_process_that_dies_is_an_error_naming_its_exit_code():
    def work(x, emit):
        if x == 1:
            os._exit(3)
        return x

    with pytest.raises(RuntimeError, match=r"died \(exit code 3\)"):
        map_forked(work, range(2), processes=2)


def test_ctrl_c_here_lets_each_process_end_its_item_as_a_ctrl_c_does(tmp_path,
                                                                     monkeypatch):
    """A SIGTERM turned into KeyboardInterrupt reaches this process alone: after
    STOP_GRACE_S each process is sent SIGINT, and ends its item as on a Ctrl-C of its own
    (a study marks its manifest "interrupted")."""
    monkeypatch.setattr(forked, "STOP_GRACE_S", 0.3)

    def work(x, emit):
        try:
            emit("running", x)
            time.sleep(30)
        except KeyboardInterrupt:
            (tmp_path / f"interrupted-{x}").write_text("")
            raise
        return x

    running = []

    def events(kind, x):
        running.append(x)
        if len(running) == 2:  # both items have begun: interrupt this process
            threading.Timer(0.1, os.kill, (os.getpid(), signal.SIGINT)).start()

    t = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        map_forked(work, range(2), processes=2, events=events)
    assert time.perf_counter() - t < 10
    assert sorted(p.name for p in tmp_path.iterdir()) == ["interrupted-0", "interrupted-1"]


def test_side_by_side_is_one_process_per_core_and_task_and_one_without_fork(monkeypatch):
    monkeypatch.setattr(forked, "usable_cores", lambda: 2)
    monkeypatch.delenv("ROVERIMPACT_WORKER_START", raising=False)
    if forked.worker_start_method() == "fork":
        assert side_by_side(4) == 2 and side_by_side(1) == 1
    monkeypatch.setenv("ROVERIMPACT_WORKER_START", "spawn")
    assert side_by_side(4) == 1


# --- reproduce's studies side by side ----------------------------------------------------


@pytest.fixture
def fake_studies(monkeypatch, tmp_path):
    """``run_study`` replaced by a fake that writes which process ran each study."""
    def fake(study, out_dir, *, overwrite, progress=None, note=None, **kw):
        assert overwrite
        n = study.n_cases()
        out_dir.mkdir(parents=True, exist_ok=True)
        (out_dir / "pid").write_text(str(os.getpid()))
        time.sleep(0.2)  # long enough for both processes to take a study
        if out_dir.name == "detc2014_fig3_com_height" and os.environ.get("FAKE_INTERRUPT"):
            raise StudyInterrupted("interrupted; rerun with --resume")
        for d in range(1, n + 1):
            if progress is not None:
                progress(d, n)
        if note is not None:
            note(f"{out_dir.name} ran")

    monkeypatch.setattr(repro, "run_study", fake)
    monkeypatch.setattr(forked, "usable_cores", lambda: 2)
    monkeypatch.delenv("ROVERIMPACT_WORKER_START", raising=False)
    return tmp_path / "out"


def test_reproduce_runs_its_studies_side_by_side_with_one_progress(fake_studies):
    if forked.worker_start_method() != "fork":
        pytest.skip("studies run side by side only where processes fork")
    seen, notes, prepared = [], [], []
    repro.run_builtin_studies(fake_studies, quick=True, note=notes.append,
                              progress=lambda *p: seen.append(p),
                              prepare=lambda: prepared.append(os.getpid()))
    assert prepared == [os.getpid()]  # once, here: the processes inherit what it compiled
    pids = {(fake_studies / s / "pid").read_text() for s in repro.BUILTIN_STUDIES}
    assert len(pids) == 2 and str(os.getpid()) not in pids
    # every study's size first, before any work: the command draws one bar for them all
    first = seen[:len(repro.BUILTIN_STUDIES)]
    assert {s for s, _, _ in first} == set(repro.BUILTIN_STUDIES)
    assert all(d == 0 for _, d, _ in first)
    last = {s: (d, t) for s, d, t in seen}
    assert all(d == t > 0 for d, t in last.values())
    assert sorted(notes) == sorted(f"{s} ran" for s in repro.BUILTIN_STUDIES)


def test_reproduce_side_by_side_names_the_interrupted_study(fake_studies, monkeypatch):
    monkeypatch.setenv("FAKE_INTERRUPT", "1")
    with pytest.raises(StudyInterrupted, match=r"interrupted in study "
                       r"detc2014_fig3_com_height; .* run the same `roverimpact reproduce`"):
        repro.run_builtin_studies(fake_studies, quick=True)


def test_reproduce_with_one_process_runs_the_studies_here(fake_studies):
    repro.run_builtin_studies(fake_studies, quick=True, processes=1)
    assert {(fake_studies / s / "pid").read_text()
            for s in repro.BUILTIN_STUDIES} == {str(os.getpid())}


def test_a_process_killed_names_the_signal_and_its_item():
    def work(x, emit):
        if x == 1:
            os.kill(os.getpid(), signal.SIGKILL)
        return x

    with pytest.raises(forked.ProcessDied, match=r"died \(killed by SIGKILL\) computing "
                       r"item 1") as info:
        map_forked(work, range(2), processes=2)
    assert info.value.item == 1 and info.value.how == "killed by SIGKILL"


def test_what_a_process_prints_and_warns_is_written_here_once(capsys, monkeypatch):
    """A process's lines went to the terminal itself, into the progress bar's line; each
    process showed a warning the other had shown (the command shows each once)."""
    import warnings

    shown = []
    monkeypatch.setattr(warnings, "showwarning",
                        lambda message, category, *a, **k: shown.append(
                            (str(message), category)))

    def work(x, emit):
        print(f"line of {x}", end="")
        print(" ends here")
        sys.stderr.write(f"error text of {x}\n")
        warnings.warn("the same warning", RuntimeWarning, stacklevel=1)
        time.sleep(0.1)
        return x

    assert map_forked(work, range(2), processes=2) == [0, 1]
    out, err = capsys.readouterr()
    assert sorted(out.splitlines()) == ["line of 0 ends here", "line of 1 ends here"]
    assert sorted(err.splitlines()) == ["error text of 0", "error text of 1"]
    assert shown == [("the same warning", RuntimeWarning)] * 2  # here: the command's
    # own showwarning (the command line's shows each message once)


def test_reproduce_names_a_study_whose_process_was_killed(fake_studies, monkeypatch):
    """The killed study's manifest said "running" for ever, and the command ended with a
    traceback of a RuntimeError."""
    from roverimpact.studies.store import read_manifest, write_manifest

    real = repro.run_study

    def fake(study, out_dir, **kw):
        if out_dir.name == "detc2015_fig2_beta":
            out_dir.mkdir(parents=True, exist_ok=True)
            write_manifest(out_dir, {"status": "running", "n_cases": 5})
            os.kill(os.getpid(), signal.SIGKILL)
        return real(study, out_dir, **kw)

    monkeypatch.setattr(repro, "run_study", fake)
    with pytest.raises(forked.ProcessDied, match=r"the process running study "
                       r"detc2015_fig2_beta died \(killed by SIGKILL; .* run the same "
                       r"`roverimpact reproduce` command again"):
        repro.run_builtin_studies(fake_studies, quick=True)
    manifest = read_manifest(fake_studies / "detc2015_fig2_beta")
    assert manifest["status"] == "failed" and "SIGKILL" in manifest["error"]


def test_reproduce_with_workers_1_draws_the_figures_here_too(monkeypatch, tmp_path):
    """``--workers 1`` ("the studies one after the other, here") drew the figures and
    statistics side by side all the same; both now run in this process."""
    from roverimpact.report import reproduce as report_reproduce

    seen = {}
    monkeypatch.setattr(report_reproduce, "run_builtin_studies",
                        lambda out, **kw: seen.setdefault("studies", kw["processes"]))
    monkeypatch.setattr(report_reproduce, "build_report",
                        lambda out, **kw: (seen.setdefault("report", kw["processes"]), []))
    report_reproduce.reproduce(tmp_path, workers=1)
    assert seen == {"studies": 1, "report": 1}
    seen.clear()
    report_reproduce.reproduce(tmp_path)  # default: one per core, decided below
    assert seen == {"studies": None, "report": None}
