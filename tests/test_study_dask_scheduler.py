"""--scheduler: a running Dask cluster started by the user (``dask scheduler``, ``dask
worker``): what the command says when the address is not a usable scheduler's."""

from __future__ import annotations

import contextlib
import http.server
import os
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from roverimpact.exceptions import ConfigError
from roverimpact.studies import ScenarioEvaluator, run_study
from roverimpact.studies.executors import check_scheduler

pytest.importorskip("dask.distributed")

STUDY = {
    "name": "rb",
    "base": {"model": {"name": "rigid_body", "params": {"mass": 20.0, "inertia": 1.2,
                                                         "com_height": 0.3, "lever": 0.4}},
             "velocity": {"u": 0.5}, "obstacle": {"frame": "contact", "beta_deg": 90.0}},
    "grid": {"obstacle.beta_deg": [30.0, 60.0]},
}


@pytest.fixture
def http_port():
    """An HTTP server (as a scheduler's dashboard is) on a free local port: it accepts the
    connection and waits for a request that Dask never sends."""
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0),
                                             http.server.SimpleHTTPRequestHandler)
    t = threading.Thread(target=server.serve_forever, daemon=True)
    t.start()
    yield server.server_address[1]
    server.shutdown()
    server.server_close()


EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _two_rovers(mine, theirs):
    """Folders ``mine`` and ``theirs``, each with an ``mjcf_rover.xml``: the example's
    (a 20 kg chassis) in ``mine``, a 60 kg chassis in ``theirs`` (a worker reading its own
    folder's file gives another T_c^-)."""
    xml = (EXAMPLES / "mjcf_rover.xml").read_text()
    assert 'mass="20"' in xml
    for folder, text in ((mine, xml), (theirs, xml.replace('mass="20"', 'mass="60"'))):
        folder.mkdir()
        (folder / "mjcf_rover.xml").write_text(text)
    return mine, theirs


def test_a_port_that_is_not_a_schedulers_is_refused_before_any_work(tmp_path, http_port):
    """The dashboard's port (or any server's) was taken for the scheduler: the TCP check
    passed and Dask's client then waited for its handshake for ever (a traverse or sweep
    hung with 0 cases done; another server's bytes ended in a MemoryError traceback)."""
    address = f"tcp://127.0.0.1:{http_port}"
    t = time.perf_counter()
    with pytest.raises(ConfigError, match="not a Dask scheduler"):
        check_scheduler(address, timeout=1.0)
    assert time.perf_counter() - t < 6.0
    with pytest.raises(ConfigError, match="not a Dask scheduler"):
        run_study(STUDY, tmp_path / "out", scheduler=address)
    assert not (tmp_path / "out").exists()


def test_a_workers_address_is_named_as_such():
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp",
                      dashboard_address=None) as cluster:
        worker = next(iter(cluster.workers.values())).address
        with pytest.raises(ConfigError, match="is a Dask worker"):
            check_scheduler(worker, timeout=2.0)
        assert check_scheduler(cluster.scheduler_address) == cluster.scheduler_address


def test_a_scheduler_without_workers_is_waited_for_a_bounded_time_and_said(tmp_path):
    """A scheduler with no worker held the tasks for ever: the command hung at 0 cases
    with nothing said."""
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=0, processes=False, protocol="tcp", dashboard_address=None) as cluster:
        notes: list[str] = []
        t = time.perf_counter()
        with pytest.raises(ConfigError, match="no worker joined"):
            check_scheduler(cluster.scheduler_address, workers_wait=1.0, note=notes.append)
        assert time.perf_counter() - t < 6.0
        assert len(notes) == 1 and "waiting up to 1 s" in notes[0]
        assert f"dask worker {cluster.scheduler_address}" in notes[0]

        # a worker that joins while the command waits: it goes on
        def join():
            time.sleep(0.5)
            cluster.scale(1)

        threading.Thread(target=join, daemon=True).start()
        assert check_scheduler(cluster.scheduler_address, workers_wait=20.0,
                               note=notes.append) == cluster.scheduler_address


def test_a_dict_studys_relative_robot_file_is_the_one_beside_the_caller(tmp_path,
                                                                          monkeypatch):
    """A study given as a dict names ``model.file = "mjcf_rover.xml"``: serially it is the
    file of the working folder; workers started in another folder read theirs (a 60 kg
    chassis instead of 20 kg: T_c^- 1.279 J instead of 0.483 J at beta = 30 deg, no
    error). The file is now made absolute where the study is given."""
    import dask
    import tomllib
    from dask.distributed import LocalCluster

    user, other = _two_rovers(tmp_path / "user", tmp_path / "workers")
    base = tomllib.loads((EXAMPLES / "mjcf_rover_beta.toml").read_text())
    assert base["model"]["file"] == "mjcf_rover.xml"
    study = {"name": "rel", "base": base, "grid": {"obstacle.beta_deg": [30.0, 60.0]}}

    monkeypatch.chdir(user)
    serial = run_study(study, user / "s").table  # also loads what a forked worker inherits
    monkeypatch.chdir(other)  # the workers' folder
    with dask.config.set({"distributed.worker.multiprocessing-method": "fork"}), \
            LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                         dashboard_address=None) as cluster:
        monkeypatch.chdir(user)
        dist = run_study(study, user / "d", scheduler=cluster.scheduler_address).table
    assert np.array_equal(dist["T_c_minus"].to_numpy(), serial["T_c_minus"].to_numpy())
    assert serial["model.file"].iloc[0] == str(user / "mjcf_rover.xml")


def test_a_study_files_cases_read_their_robot_files_beside_the_study(tmp_path, monkeypatch):
    """``[[cases]] "model.file" = "mjcf_rover.xml"`` in a study file was read from the
    working folder of each process (the command's, each Dask worker's), not from the
    study file's folder as the base's file is: run from another folder, the study failed
    or took that folder's file (T_c^- of the 60 kg chassis)."""
    here, other = _two_rovers(tmp_path / "study", tmp_path / "elsewhere")
    scenario = (EXAMPLES / "mjcf_rover_beta.toml").read_text()
    (here / "scenario.toml").write_text(scenario)
    (here / "by_case.toml").write_text(
        'name = "c"\nbase = "scenario.toml"\n[[cases]]\n"model.file" = "mjcf_rover.xml"\n')
    (here / "by_base.toml").write_text(
        'name = "b"\nbase = "scenario.toml"\n[[cases]]\n"obstacle.beta_deg" = 45.0\n')
    monkeypatch.chdir(other)
    by_case = run_study(here / "by_case.toml", tmp_path / "c").table
    by_base = run_study(here / "by_base.toml", tmp_path / "b").table
    assert by_case["T_c_minus"].iloc[0] == by_base["T_c_minus"].iloc[0]
    assert by_case["model.file"].iloc[0] == str(here / "mjcf_rover.xml")


def test_a_study_objects_swept_robot_files_are_the_ones_beside_the_caller(tmp_path,
                                                                          monkeypatch):
    """A :class:`Study` built in Python whose grid (or cases) names ``"model.file" =
    ["mjcf_rover.xml"]``: only its base's files were made absolute (a dict's grid and
    cases were), and workers started in another folder read their own file (T_c^- of the
    60 kg chassis, 1.279 J instead of 0.483 J at beta = 30 deg, no error). Reference: the
    serial run in the caller's folder. A study file's random choices of a robot file are
    read beside the study file, as its grid's are."""
    import dask
    import tomllib
    from dask.distributed import LocalCluster

    from roverimpact.studies.config import Study, load_study

    user, other = _two_rovers(tmp_path / "user", tmp_path / "workers")
    base = tomllib.loads((EXAMPLES / "mjcf_rover_beta.toml").read_text())
    base["model"]["file"] = str(user / "mjcf_rover.xml")
    by_grid = Study(name="g", base=base, grid={"obstacle.beta_deg": [30.0, 60.0],
                                               "model.file": ["mjcf_rover.xml"]})
    by_case = Study(name="c", base=base, cases=[{"obstacle.beta_deg": b,
                                                 "model.file": "mjcf_rover.xml"}
                                                for b in (30.0, 60.0)])
    monkeypatch.chdir(other)  # the workers' folder
    with dask.config.set({"distributed.worker.multiprocessing-method": "fork"}), \
            LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                         dashboard_address=None) as cluster:
        monkeypatch.chdir(user)
        serial = run_study(by_grid, user / "s").table
        assert serial["T_c_minus"].iloc[0] == pytest.approx(0.4831, abs=1e-4)
        for i, study in enumerate((by_grid, by_case)):
            dist = run_study(study, user / f"d{i}", scheduler=cluster.scheduler_address).table
            assert np.array_equal(dist["T_c_minus"].to_numpy(),
                                  serial["T_c_minus"].to_numpy()), study.name
            assert set(dist["model.file"]) == {str(user / "mjcf_rover.xml")}
    (user / "st.toml").write_text(
        'name = "r"\nbase = "scenario.toml"\n[random]\nn = 2\nseed = 0\n'
        '[random.params]\n"model.file" = { choices = ["mjcf_rover.xml"] }\n')
    (user / "scenario.toml").write_text((EXAMPLES / "mjcf_rover_beta.toml").read_text())
    study, _ = load_study(user / "st.toml")
    assert study.random.params["model.file"].choices == [str(user / "mjcf_rover.xml")]


class CountingEvaluator(ScenarioEvaluator):
    """The scenario evaluator, counting the cases it is asked to compute."""

    name = "counting"

    def __init__(self):
        self.n = 0

    def evaluate(self, base, overrides, *, simulate=False):
        self.n += len(overrides)
        return super().evaluate(base, overrides, simulate=simulate)


class MissingFileOnWorker:
    """An evaluator that fails as a worker that does not see the study's robot file does."""

    name = "missing_file"

    def evaluate(self, base, overrides, *, simulate=False):
        raise ConfigError("/data/rover.urdf: no such URDF/MJCF file")


def test_an_input_error_on_a_worker_says_it_was_on_a_worker():
    """A robot file this machine has but a worker does not see: the error read "no such
    URDF/MJCF file" for a file the user could see, with no word of where it was read."""
    from dask.distributed import LocalCluster

    from roverimpact.studies.config import study_from_dict
    from roverimpact.studies.executors import run_dask
    from roverimpact.studies.sweep import Chunks, prepare_study

    prep = prepare_study(study_from_dict(STUDY))
    chunks = Chunks(prep.cases, 1)
    args = (MissingFileOnWorker(), prep.study.base, prep.base)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp",
                      dashboard_address=None) as cluster:
        address = cluster.scheduler_address
        with pytest.raises(ConfigError) as err:
            run_dask([0, 1], chunks, args, prep.study.parameters(), False, address, 0,
                     lambda k, df: None)
    msg = str(err.value)
    # (the case that raised is named: the chunk's cases are tried one by one)
    assert msg.startswith(f"on a Dask worker of the scheduler at {address}: case 0 (")
    assert "/data/rover.urdf: no such URDF/MJCF file" in msg
    assert "must see them" in msg


class SlowRigidBody(ScenarioEvaluator):
    """The scenario evaluator, slowed down so the scheduler can go away mid-study."""

    name = "slow_rigid_body"

    def evaluate(self, base, overrides, *, simulate=False):
        time.sleep(0.2)
        return super().evaluate(base, overrides, simulate=simulate)


def test_a_scheduler_gone_mid_study_is_one_line_and_the_study_resumes(tmp_path):
    """The scheduler stopped mid-study: Dask's FutureCancelledError traceback, after its
    client logged a traceback of its failed reconnection. Now one error that says what is
    kept, and --resume finishes the study."""
    from dask.distributed import LocalCluster

    from roverimpact.exceptions import RoverImpactError

    study = dict(STUDY, grid={"obstacle.beta_deg": [10.0, 20.0, 30.0, 40.0, 50.0, 60.0]},
                 chunk_size=1)
    serial = run_study(study, tmp_path / "s").table
    cluster = LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp",
                           dashboard_address=None)

    def stop_scheduler(done, total):
        if done >= 2 and cluster.scheduler.status.name == "running":
            cluster.sync(cluster.scheduler.close)

    t = time.perf_counter()
    try:
        with pytest.raises(RoverImpactError, match=r"lost the Dask scheduler at .*--resume"):
            run_study(study, tmp_path / "d", evaluator=SlowRigidBody(),
                      scheduler=cluster.scheduler_address, progress=stop_scheduler)
        assert time.perf_counter() - t < 10.0
    finally:
        with contextlib.suppress(TimeoutError):  # its scheduler is gone: nothing to wait for
            cluster.close(timeout=1)
    res = run_study(study, tmp_path / "d", resume=True)
    assert 2 <= res.n_reused < 6
    assert np.array_equal(res.table["T_c_minus"].to_numpy(), serial["T_c_minus"].to_numpy())


def test_every_worker_lost_mid_study_is_waited_for_a_bounded_time_and_resumes(
        tmp_path, monkeypatch):
    """Every worker of the scheduler killed mid-study (``kill -9`` of the ``dask worker``
    processes): Dask holds the tasks until a worker joins, and the command waited for
    ever at the chunks done (6 of 60 cases after 2 min). It now waits up to
    WORKERS_WAIT_S for a worker, says so, then stops with one error; the manifest says
    "failed" and --resume gives the serial table."""
    import json

    from dask.distributed import LocalCluster

    from roverimpact.exceptions import RoverImpactError
    from roverimpact.studies import executors

    monkeypatch.setattr(executors, "WORKERS_WAIT_S", 1.0)
    monkeypatch.setattr(executors, "WORKERS_CHECK_S", 0.2)
    study = dict(STUDY, grid={"obstacle.beta_deg": [10.0, 20.0, 30.0, 40.0, 50.0, 60.0]},
                 chunk_size=1)
    serial = run_study(study, tmp_path / "s").table
    notes: list[str] = []
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp",
                      dashboard_address=None) as cluster:

        def lose_the_workers(done, total):
            if done >= 2 and cluster.workers:
                cluster.scale(0)

        with pytest.raises(RoverImpactError) as err:
            run_study(study, tmp_path / "d", evaluator=SlowRigidBody(),
                      scheduler=cluster.scheduler_address, progress=lose_the_workers,
                      note=notes.append)
    msg = str(err.value)
    assert msg.startswith(f"lost every Dask worker of the scheduler at {cluster.scheduler_address}"
                          ", and none joined in 1 s: the finished chunks are kept: rerun with "
                          "--resume"), msg
    assert [n for n in notes if "every Dask worker" in n and "waiting up to 1 s" in n]
    manifest = json.loads((tmp_path / "d" / "manifest.json").read_text())
    assert manifest["status"] == "failed"
    res = run_study(study, tmp_path / "d", resume=True)
    assert 2 <= res.n_reused < 6
    assert np.array_equal(res.table["T_c_minus"].to_numpy(), serial["T_c_minus"].to_numpy())


def _other_code_on_workers(monkeypatch, after: int = 0):
    """Workers of this process's in-process cluster answer another roverimpact source
    than the command (after their first ``after`` answers): as a worker started from
    another checkout or install does (the version string, 0.1.0, is the same)."""
    from distributed import get_worker

    from roverimpact.studies import executors, store

    answers = []

    def code_identity(dask_worker=None):  # (Client.run gives its worker as dask_worker)
        try:
            dask_worker or get_worker()
        except ValueError:  # the command
            return store.code_identity()
        answers.append(1)
        if len(answers) <= after:
            return store.code_identity()
        return store.code_identity() | {"roverimpact source": "0123456789abcdef"}

    monkeypatch.setattr(executors, "code_identity", code_identity)


def test_workers_of_other_code_are_refused_before_any_case(tmp_path, monkeypatch):
    """A worker of another roverimpact (another checkout: the same version string) or
    another numpy or Pinocchio major version computed its share of the chunks with no
    word (4 of 40 rows 1 % off, a worker whose T_c^- differs by 1 %). Now the cluster is
    refused with one line before the output folder is touched."""
    from dask.distributed import LocalCluster

    from roverimpact.studies.store import code_identity

    ident = code_identity()
    assert len(ident["roverimpact source"]) == 16
    assert {"roverimpact", "numpy major version", "pinocchio major version"} <= set(ident)
    _other_code_on_workers(monkeypatch)
    ev = CountingEvaluator()
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp",
                      dashboard_address=None) as cluster:
        with pytest.raises(ConfigError) as err:
            run_study(STUDY, tmp_path / "out", evaluator=ev,
                      scheduler=cluster.scheduler_address)
    assert str(err.value).startswith("the Dask worker at tcp://")
    assert (f"runs other code than this command (roverimpact source 0123456789abcdef there, "
            f"{ident['roverimpact source']} here)") in str(err.value)
    assert str(err.value).endswith("(nothing was computed)")
    assert ev.n == 0 and not (tmp_path / "out").exists()


def test_a_worker_of_other_code_that_joins_mid_study_stops_it(tmp_path, monkeypatch):
    """A worker of other code that joins after the check (the first answer is the
    check's): its chunk is refused on the worker, the study stops with one line, the
    finished chunks are kept."""
    import json

    from dask.distributed import LocalCluster

    from roverimpact.exceptions import RoverImpactError

    _other_code_on_workers(monkeypatch, after=1)
    study = dict(STUDY, chunk_size=1)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp",
                      dashboard_address=None) as cluster:
        with pytest.raises(RoverImpactError, match=r"runs other code than this command "
                           r"\(roverimpact source 0123456789abcdef there.*it joined while "
                           r"the study ran: the finished chunks are kept, rerun with --resume"):
            run_study(study, tmp_path / "out", scheduler=cluster.scheduler_address)
    assert json.loads((tmp_path / "out" / "manifest.json").read_text())["status"] == "failed"


def test_a_worker_that_does_not_answer_the_check_is_refused_in_bounded_time(tmp_path,
                                                                           monkeypatch):
    """A worker that does not answer (a stopped process, ``kill -STOP``): Dask's
    ``Client.run`` waits for ever, and the check hung the command before any work."""
    from dask.distributed import LocalCluster

    from roverimpact.studies import executors, store

    monkeypatch.setattr(executors, "WORKERS_ANSWER_S", 0.5)

    def slow_identity(dask_worker=None):
        if dask_worker is not None:
            time.sleep(2.0)
        return store.code_identity()

    monkeypatch.setattr(executors, "code_identity", slow_identity)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp",
                      dashboard_address=None) as cluster:
        with pytest.raises(ConfigError, match=r"did not answer in 0.5 s \(a stopped or stuck "
                           r"process\).*\(nothing was computed\)$"):
            run_study(STUDY, tmp_path / "out", scheduler=cluster.scheduler_address)
    assert not (tmp_path / "out").exists()


def test_the_source_hash_tells_two_sources_apart(tmp_path):
    """What identifies roverimpact's code: a hash of its files (paths and bytes), not of
    the compiled caches beside them."""
    from roverimpact.studies.store import tree_hash

    (tmp_path / "pkg" / "__pycache__").mkdir(parents=True)
    (tmp_path / "pkg" / "a.py").write_text("x = 1\n")
    (tmp_path / "pkg" / "b.toml").write_text("y = 2\n")
    first = tree_hash(tmp_path / "pkg")
    (tmp_path / "pkg" / "__pycache__" / "a.cpython-312.pyc").write_bytes(b"\0")
    (tmp_path / "pkg" / "k.nbi").write_bytes(b"\0")
    assert tree_hash(tmp_path / "pkg") == first
    (tmp_path / "pkg" / "a.py").write_text("x = 2\n")
    assert tree_hash(tmp_path / "pkg") != first
    (tmp_path / "pkg" / "a.py").write_text("x = 1\n")
    (tmp_path / "pkg" / "b.toml").rename(tmp_path / "pkg" / "c.toml")
    assert tree_hash(tmp_path / "pkg") != first


class _FakeKernel:
    """A compiled kernel as :func:`kernels_to_compile` sees it."""

    def __init__(self, cached: bool):
        self.compiled, self._cached = False, cached

    def cached(self) -> bool:
        return self._cached


def test_workers_with_a_cold_kernel_cache_are_said_to_compile(tmp_path, monkeypatch):
    """Workers whose numba cache lacks the kernels (a fresh install) compiled for 30-70 s
    before their first chunk, the progress bar at 0 and no word. The command now asks
    them (numba's cache index on each worker) and says why the first chunks wait; with a
    warm cache it says nothing."""
    import sys
    import types

    from dask.distributed import LocalCluster

    from roverimpact._kernels._jit import Kernel
    from roverimpact.studies import sweep

    for home in sweep.STUDY_KERNELS + sweep.SIMULATOR_KERNELS:  # the real ones resolve
        module, _, name = home.partition(":")
        assert isinstance(getattr(__import__(module, fromlist=[name]), name), Kernel)
    fake = types.ModuleType("fake_kernels")
    fake.cold, fake.warm = _FakeKernel(cached=False), _FakeKernel(cached=True)
    monkeypatch.setitem(sys.modules, "fake_kernels", fake)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp",
                      dashboard_address=None) as cluster:
        for kernels, said in ((("fake_kernels:warm",), False), (("fake_kernels:warm",
                                                                  "fake_kernels:cold"), True)):
            monkeypatch.setattr(sweep, "STUDY_KERNELS", kernels)
            notes: list[str] = []
            run_study(STUDY, tmp_path / f"o{said}", scheduler=cluster.scheduler_address,
                      note=notes.append)
            compiling = [n for n in notes if "compile roverimpact's kernels" in n]
            assert bool(compiling) is said
            if said:
                assert "numba's cache there lacks cold)" in compiling[0]


class CrashingAt40(ScenarioEvaluator):
    """The scenario evaluator, whose process dies at beta = 40 deg (as a crash of a
    compiled library, or the out-of-memory killer, ends it)."""

    name = "crashing"

    def evaluate(self, base, overrides, *, simulate=False):
        if any(o.get("obstacle.beta_deg") == 40.0 for o in overrides):
            os._exit(1)
        return super().evaluate(base, overrides, simulate=simulate)


def test_a_chunk_that_kills_its_workers_is_one_line_naming_it(tmp_path):
    """A chunk whose every worker died computing it: the scheduler gives up on it and
    Dask's KilledWorker ended the command in a traceback. Now one line names the chunk
    and its cases; the finished chunks are kept."""
    import json
    import sys

    import cloudpickle
    import dask
    from dask.distributed import LocalCluster

    from roverimpact.exceptions import RoverImpactError

    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    study = dict(STUDY, grid={"obstacle.beta_deg": [10.0, 20.0, 30.0, 40.0]}, chunk_size=1)
    with dask.config.set({"distributed.worker.multiprocessing-method": "fork",
                          "distributed.scheduler.allowed-failures": 0}), \
            LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                         dashboard_address=None) as cluster:
        with pytest.raises(RoverImpactError, match=r"^chunk (\d) \(cases \1-\1\) killed every "
                           r"Dask worker that computed it .*The finished chunks are kept"):
            run_study(study, tmp_path / "out", evaluator=CrashingAt40(),
                      scheduler=cluster.scheduler_address)
    assert json.loads((tmp_path / "out" / "manifest.json").read_text())["status"] == "failed"


def test_a_traverse_given_as_a_dict_names_its_files_absolute(tmp_path, monkeypatch):
    """``run_traverse(dict)`` with ``terrain.file = "dem.npy"`` kept the name relative, and
    its chunks (shipped as the config's dict) were read from each Dask worker's working
    folder. The config the run goes on with names the file beside the caller."""
    import tomllib

    from roverimpact.traverse import run as trun

    raw = tomllib.loads((EXAMPLES / "traverse_sparse.toml").read_text())
    raw["terrain"] = {"kind": "file", "file": "dem.npy", "spacing": 0.05}
    seen = []

    class Seen(Exception):
        pass

    def check_inputs(cfg, where):
        seen.append(cfg)
        raise Seen

    monkeypatch.setattr(trun, "_check_inputs", check_inputs)
    monkeypatch.chdir(tmp_path)
    with pytest.raises(Seen):
        trun.run_traverse(raw)
    assert seen[0].terrain.file == str(tmp_path / "dem.npy")
