"""Where the chunks of a study run: on the client (serial) or on a Dask cluster.

On Dask the client writes the chunks as the tasks return; a task lost with a dead worker
is recomputed by the scheduler (and retried on errors), and the chunk is written once.
"""

from __future__ import annotations

import inspect
import io
import json
import logging
import os
import re
import signal
import socket
import sys
import threading
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass
from typing import Any
from urllib.parse import urlparse

import numpy as np
import pandas as pd

from ..exceptions import ConfigError, InputError, RoverImpactError
from .config import Case, flatten
from .store import ERROR_COLUMN, PARQUET_WRITE, code_identity

__all__ = [
    "CLUSTER_CONFIG",
    "CLUSTER_START_S",
    "ON_ERROR",
    "START_METHODS",
    "WORKERS_CHECK_S",
    "WORKERS_WAIT_S",
    "WORKER_ENVIRON",
    "ChunkFile",
    "LazyCluster",
    "as_finished",
    "check_on_error",
    "check_scheduler",
    "check_workers",
    "compile_note",
    "compute_chunk",
    "compute_chunk_file",
    "kernels_to_compile",
    "local_cluster",
    "need_dask",
    "one_blas_thread",
    "other_code_error",
    "other_code_message",
    "reworded",
    "run_dask",
    "run_serial",
    "scheduler_workers",
    "why_serial",
    "worker_result",
    "worker_start_method",
    "worth_a_cluster",
]

#: Wall time [s] a local cluster costs before and after the work (start, the workers'
#: first import of roverimpact and its kernels, close), by how its workers start
#: (:func:`worker_start_method`). Measured on the 2-core machine, 2 workers
#: (benchmarks/bench_dask.py): spawned 2.0-6.0 s, forked 0.14-0.27 s (idle machine, and
#: at a load of 2.3); rounded up for a loaded machine.
CLUSTER_START_S = {"fork": 1.5, "forkserver": 6.0, "spawn": 6.0}
#: the same once a shared cluster runs (tasks shipped, results gathered)
CLUSTER_RUNNING_S = 0.5


#: How long [s] a command waits for a first worker to join a running scheduler that has
#: none (a batch job may start the scheduler, the workers and the command together)
WORKERS_WAIT_S = 60.0


def check_scheduler(address: str, timeout: float = 3.0, *, workers_wait: float = WORKERS_WAIT_S,
                    note: Callable[[str], None] | None = None) -> str:
    """Check that ``tcp://HOST:PORT`` is a well-formed address where a Dask scheduler
    answers, with at least one worker; return it normalised.

    The scheduler is asked who it is (Dask's ``identity``), each step within ``timeout``:
    a port that accepts connections but is not a scheduler's (its dashboard's HTTP port,
    a worker's, another server's) otherwise hung Dask's client for ever, or ended in a
    MemoryError (it read the server's bytes as a frame length). A scheduler without
    workers would hold the tasks for ever: ``note`` says the command waits, and after
    ``workers_wait`` seconds without a worker it stops.

    Raises
    ------
    ConfigError
        Malformed address, nothing listening, not a Dask scheduler, no worker.
    """
    url = urlparse(address if "://" in address else f"tcp://{address}")
    if url.scheme not in ("tcp", "tls") or not url.hostname or not url.port:
        raise ConfigError(
            f"scheduler address {address!r} is not of the form tcp://HOST:PORT "
            "(the address `dask scheduler` prints)"
        )
    try:
        with socket.create_connection((url.hostname, url.port), timeout=timeout):
            pass
    except OSError as exc:
        raise ConfigError(
            f"cannot reach the Dask scheduler at {address} ({exc.strerror or exc}); start "
            "one with `dask scheduler` and check host, port and firewall"
        ) from None
    norm = f"{url.scheme}://{url.hostname}:{url.port}"
    who = _identity(norm, timeout)
    if who.get("type") != "Scheduler":
        what = ("a Dask worker (its scheduler is "
                f"{who.get('scheduler')})" if who.get("type") == "Worker"
                else "not a Dask scheduler: no answer to Dask's handshake")
        raise ConfigError(
            f"{address} is {what}; give the address `dask scheduler` prints "
            "(tcp://HOST:PORT, usually port 8786, not the dashboard's)")
    if not who.get("workers"):
        if note is not None:
            note(f"the Dask scheduler at {norm} has no worker yet: waiting up to "
                 f"{workers_wait:.0f} s for one (start them with `dask worker {norm}`)")
        end = time.monotonic() + workers_wait
        while not who.get("workers"):
            if time.monotonic() >= end:
                raise ConfigError(
                    f"no worker joined the Dask scheduler at {norm} in {workers_wait:.0f} s: "
                    f"start them with `dask worker {norm}` (nothing was computed)")
            time.sleep(min(0.5, max(end - time.monotonic(), 0.0)))
            who = _identity(norm, timeout)
    return norm


def _identity(address: str, timeout: float) -> dict:
    """The answer of the Dask server at ``address`` to ``identity``, each step within
    ``timeout`` seconds; ``{}`` when it does not answer as a Dask server. Run on a thread
    of its own (its own event loop: the caller may be in one, a notebook's)."""
    import asyncio

    from distributed.comm import connect
    from distributed.security import Security

    args = Security().get_connection_args("client")  # tls:// as Dask's config sets it

    async def ask() -> dict:
        comm = await asyncio.wait_for(connect(address, timeout=timeout, **args), timeout)
        try:
            await asyncio.wait_for(comm.write({"op": "identity", "reply": True}), timeout)
            return await asyncio.wait_for(comm.read(), timeout)
        finally:
            comm.abort()

    out: dict = {}

    def run() -> None:
        try:
            reply = asyncio.run(ask())
        except BaseException:  # any failure means: not a Dask server
            return
        if isinstance(reply, dict):
            out.update(reply)

    t = threading.Thread(target=run, daemon=True, name="roverimpact-dask-identity")
    t.start()
    t.join(4 * timeout + 1.0)
    return out


def need_dask() -> None:
    try:
        import dask.distributed  # noqa: F401
    except ImportError:
        raise ConfigError(
            "distributed runs need Dask: pip install 'roverimpact[dask]'"
        ) from None


def _cell(v):
    if isinstance(v, (list, tuple, dict)):
        return json.dumps(v)
    return v


#: What a study does with a case that cannot be posed: stop (the default), or record it
#: and go on (its row's outputs missing, column :data:`~.store.ERROR_COLUMN` saying why)
ON_ERROR = ("stop", "record")


def check_on_error(on_error) -> str:
    """``on_error`` if it is one of :data:`ON_ERROR`, else a ConfigError naming them."""
    if on_error not in ON_ERROR:
        raise ConfigError(f"--on-error must be one of {', '.join(ON_ERROR)}, got "
                          f"{on_error!r}")
    return on_error


def compute_chunk(evaluator, base: Mapping, normalized_base: Mapping, cases: Sequence[Case],
                  params: Sequence[str], simulate: bool, *, on_error: str = "stop"
                  ) -> pd.DataFrame:
    """Evaluate ``cases`` and return their rows: ids, inputs, outputs.

    ``on_error="record"``: a case that cannot be posed gets a row too, its outputs missing
    (NaN; False, "" for flags and texts) and :data:`~.store.ERROR_COLUMN` saying why (""
    in the others' rows). An evaluator whose ``evaluate`` takes ``errors`` (a list of one
    string per case, :meth:`.evaluate.ScenarioEvaluator.evaluate`) records them itself in
    one call; where it raises all the same, or for any other evaluator, such cases are
    found by evaluating halves of the chunk, then halves of those that fail (a chunk of
    c cases with one such case: about 2 log2(c) evaluations of fewer cases, not c of
    one).

    Raises
    ------
    InputError
        ``on_error="stop"``: a case that cannot be posed (a model of impossible
        parameters): the message names the case (its index and parameter values), found
        by evaluating the chunk's cases one by one.
    """
    cases = list(cases)  # a chunk's view makes its cases here (on the worker), once
    overrides = [c.overrides for c in cases]
    errors = None
    try:
        if on_error == "record" and _takes_errors(evaluator):
            errors = [""] * len(cases)
            outputs = evaluator.evaluate(base, overrides, simulate=simulate, errors=errors)
            if errors and all(errors):  # no case posed: the columns' types from the base
                outputs = _filled(evaluator, base, simulate, [], len(cases))
        else:
            outputs = evaluator.evaluate(base, overrides, simulate=simulate)
    except InputError as exc:
        if on_error != "record":
            raise _failing_case(evaluator, base, cases, simulate, exc) from None
        outputs, errors = _posed_outputs(evaluator, base, overrides, simulate, exc)
    n = len(cases)
    cols: dict[str, Any] = {
        "case": np.array([c.index for c in cases], dtype=np.int64),
        "case_id": [c.case_id for c in cases],
    }
    flat = flatten(normalized_base)
    for p in params:
        default = flat.get(p)
        cols[p] = [_cell(ov.get(p, default)) for ov in overrides]
    for k, v in flat.items():
        if k not in cols:
            v = _cell(v)
            cols[k] = (np.full(n, v) if isinstance(v, (bool, int, float)) and v is not None
                       else [v] * n)
    for k, v in outputs.items():
        arr = np.asarray(v)
        if arr.shape != (n,):
            raise RoverImpactError(
                f"evaluator {getattr(evaluator, 'name', evaluator)!r} returned {k!r} with "
                f"shape {arr.shape}, expected ({n},)"
            )
        cols[k] = arr
    if on_error == "record":
        cols[ERROR_COLUMN] = errors if errors is not None else [""] * n
    return pd.DataFrame(cols)


def _posed_outputs(evaluator, base, overrides: list, simulate, exc: InputError
                   ) -> tuple[dict[str, np.ndarray], list[str]]:
    """The outputs of the cases ``overrides`` whose evaluation raised ``exc``: those of
    the cases that can be posed, found by halving (a run of cases that evaluates is kept
    whole), the others missing; and each case's error ("" if posed)."""
    n = len(overrides)
    errors = [""] * n
    runs: list[tuple[int, int, dict]] = []  # (first, end, outputs) of runs that evaluated
    todo: list[tuple[int, int, InputError | None]] = [(0, n, exc)]
    while todo:
        lo, hi, err = todo.pop()
        if err is None:
            try:
                runs.append((lo, hi, evaluator.evaluate(base, overrides[lo:hi],
                                                        simulate=simulate)))
                continue
            except InputError as e:
                err = e
        if hi - lo == 1:
            errors[lo] = f"{type(err).__name__}: {err}"
        else:
            mid = (lo + hi) // 2
            todo += [(mid, hi, None), (lo, mid, None)]
    return _filled(evaluator, base, simulate, runs, n), errors


def _takes_errors(evaluator) -> bool:
    """Whether ``evaluator.evaluate`` takes ``errors`` (records the cases that cannot be
    posed itself)."""
    try:
        return "errors" in inspect.signature(evaluator.evaluate).parameters
    except (TypeError, ValueError):  # pragma: no cover - a builtin's evaluate
        return False


def _filled(evaluator, base, simulate, runs: list[tuple[int, int, dict]], n: int
            ) -> dict[str, np.ndarray]:
    """The outputs of ``n`` cases from the ``runs`` ``(first, end, outputs)`` that
    evaluated, the other cases' missing (NaN; False and "" for flags and texts; an
    integer column becomes float); with no run, the columns and their types are the base
    scenario's."""
    if not runs:
        try:
            template = evaluator.evaluate(base, [{}], simulate=simulate)
        except InputError:  # (an evaluator's base that cannot be posed: the errors alone)
            template = {}
        runs = [(0, 0, {k: np.asarray(v)[:0] for k, v in template.items()})]
    outputs = {}
    for k in runs[0][2]:
        parts = [(lo, hi, np.asarray(out[k])) for lo, hi, out in runs]
        kind = parts[0][2].dtype.kind
        if kind == "b":
            col = np.zeros(n, dtype=bool)
        elif kind in "fc":
            col = np.full(n, np.nan, dtype=parts[0][2].dtype)
        elif kind in "iu":  # an evaluator's counts: float, to hold the missing ones
            col = np.full(n, np.nan)
        else:  # texts (and anything else): "" where missing
            col = np.full(n, "", dtype=object)
        for lo, hi, v in parts:
            if v.shape != (hi - lo,):
                raise RoverImpactError(
                    f"evaluator {getattr(evaluator, 'name', evaluator)!r} returned {k!r} "
                    f"with shape {v.shape}, expected ({hi - lo},)")
            col[lo:hi] = v
        outputs[k] = col
    return outputs


def _failing_case(evaluator, base, cases: list[Case], simulate, exc: InputError
                  ) -> InputError:
    """``exc`` (raised by a chunk of ``cases``) with the first case that raises alone
    named in front: "case 8 (model.params.h = 0.1, ...): ..."; the study's message
    before named no case, and a grid of two parameters shows only the combination."""
    bad = cases[0] if len(cases) == 1 else None
    for c in cases if bad is None else ():
        try:
            evaluator.evaluate(base, [c.overrides], simulate=simulate)
        except InputError as e:
            bad, exc = c, e
            break
    if bad is None:  # pragma: no cover - only the chunk as a whole fails
        return exc
    where = ", ".join(f"{k} = {v!r}" for k, v in bad.overrides.items())
    return reworded(exc, f"case {bad.index}" + (f" ({where})" if where else "") + f": {exc}")


def reworded(exc: InputError, message: str) -> InputError:
    """An error of ``exc``'s type with ``message`` (an ``InputError`` if that type takes
    other arguments: an evaluator's own error class)."""
    try:
        return type(exc)(message)
    except TypeError:
        return InputError(message)


@dataclass(frozen=True)
class ChunkFile:
    """A chunk's rows as the bytes of its Parquet file (what a Dask worker returns: the
    encoding is done on the worker, the client only writes the bytes)."""

    n_rows: int
    data: bytes


def compute_chunk_file(evaluator, base, normalized_base, cases, params, simulate, *,
                       code: Mapping[str, str] | None = None, on_error: str = "stop"
                       ) -> ChunkFile | RoverImpactError:
    """:func:`compute_chunk`, returned as the Parquet file's bytes (the same bytes
    :func:`~.store.atomic_parquet` writes); a case that cannot be posed is returned as its
    error (:func:`run_dask` raises it): raised on the worker, Dask retried the chunk
    (``retries``) three more times for the same error, each time finding the case again
    one by one (a chunk of 3 cases, the second failing: 12 evaluator calls instead of
    3).

    ``code``: the submitting command's :func:`~.store.code_identity`; a worker of another
    (one that joined after :func:`check_workers`) returns an error instead of rows."""
    wrong = other_code_error(code, "it joined while the study ran: the finished chunks are "
                                   "kept, rerun with --resume once it is stopped")
    if wrong is not None:
        return wrong
    try:
        df = compute_chunk(evaluator, base, normalized_base, cases, params, simulate,
                           on_error=on_error)
    except InputError as exc:
        return exc
    buf = io.BytesIO()
    df.to_parquet(buf, index=False, **PARQUET_WRITE)
    return ChunkFile(len(df), buf.getvalue())


def other_code_error(code: Mapping[str, str] | None, then: str) -> RoverImpactError | None:
    """On a Dask worker, running a chunk: the error to return instead of its rows where
    this worker runs other code than the command that submitted the chunk (``code``: the
    command's :func:`~.store.code_identity`; a worker that joined after
    :func:`check_workers`), ``then`` saying what is kept and what to do; None if the same
    (or no ``code``)."""
    if code is None or code_identity() == dict(code):
        return None
    return RoverImpactError(other_code_message(_this_worker(), code_identity(), code)
                            + "; " + then)


def compile_note(cold: Sequence[str]) -> str:
    """What the command says when :func:`check_workers` found workers that compile the
    kernels ``cold`` (homes) before their first chunk."""
    return (f"the Dask workers compile roverimpact's kernels before their first chunk "
            f"(numba's cache there lacks {', '.join(k.rpartition(':')[2] for k in cold)}): "
            "the first chunks wait for it (30-70 s on a 2-core machine)")


def _this_worker() -> str:
    """The address of the Dask worker this runs on (``"?"`` outside one)."""
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):
        return "?"


def other_code_message(worker: str, there: Mapping[str, str], here: Mapping[str, str],
                       n_more: int = 0) -> str:
    """One line: the Dask worker at ``worker`` (and ``n_more`` others) runs other code
    (:func:`~.store.code_identity` ``there``) than this command (``here``)."""
    diff = ", ".join(f"{k} {there.get(k, 'none')} there, {v} here"
                     for k, v in here.items() if there.get(k) != v)
    who = f"the Dask worker at {worker}" + (f" (and {n_more} more)" if n_more else "")
    return (f"{who} runs other code than this command ({diff}): its rows could differ "
            "from this machine's. Install the same roverimpact, numpy and pinocchio on "
            "every worker, or stop the workers that differ")


def kernels_to_compile(homes: Sequence[str]) -> list[str]:
    """The names of the compiled kernels (``module:attribute`` of each
    :class:`~roverimpact._kernels._jit.Kernel`) that this process has not built and
    numba's on-disk cache here does not hold: it compiles them when a case first needs
    them (imported here, as the first chunk would)."""
    import importlib

    out = []
    for home in homes:
        module, _, name = home.partition(":")
        k = getattr(importlib.import_module(module), name)
        if not k.compiled and not k.cached():
            out.append(name)
    return out


#: Longest wait [s] for the workers' answers to :func:`check_workers` (a worker's first
#: answer imports roverimpact and its kernels' modules: 7 s on the loaded 2-core machine)
WORKERS_ANSWER_S = 60.0


def _run_on_workers(client, scheduler: str, fn, *args) -> dict:
    """``client.run(fn, *args)``, within :data:`WORKERS_ANSWER_S`: Dask waits for ever for
    a worker that does not answer (a stopped process: ``kill -STOP``)."""
    box: dict = {}

    def run() -> None:
        try:
            box["out"] = client.run(fn, *args)
        except BaseException as exc:  # raised in the caller's thread
            box["exc"] = exc

    t = threading.Thread(target=run, daemon=True, name="roverimpact-check-workers")
    t.start()
    t.join(WORKERS_ANSWER_S)
    if t.is_alive():
        raise ConfigError(
            f"a Dask worker of the scheduler at {scheduler} did not answer in "
            f"{WORKERS_ANSWER_S:g} s (a stopped or stuck process): restart it, or stop it "
            "(nothing was computed)")
    if "exc" in box:
        raise box["exc"]
    return box["out"]


def check_workers(scheduler: str, kernels: Sequence[str] = ()) -> list[str]:
    """Refuse, before any case runs, a cluster whose workers run other code than this
    command: another roverimpact (:func:`~.store.source_hash`: the version string is the
    same for every change of the source) or another major version of numpy or Pinocchio
    (:func:`~.store.code_identity`, run on each worker). Dask's own check
    (``Client.get_versions(check=True)``) compares full versions of Dask's list of
    packages and cannot tell two roverimpact sources apart. It costs a client's
    connection and one call on the workers: 0.03-0.08 s on the 2-core machine (loaded),
    plus 20-75 ms of hashing the first time a worker process is asked, then cached. A
    worker that cannot import roverimpact says so. Workers that join later are checked by
    each task (:func:`compute_chunk_file`).

    Returns the names of the ``kernels`` (homes, :func:`kernels_to_compile`) that some
    worker will compile before its first chunk (numba's cache there is cold: a fresh
    install, another checkout), so that the command can say why its first chunks wait.

    Raises
    ------
    ConfigError
    """
    from dask.distributed import Client

    here = code_identity()
    with _LoggerAtLeast("distributed.client", logging.CRITICAL), \
            Client(scheduler, timeout="10s") as client:
        try:
            there = _run_on_workers(client, scheduler, code_identity)
        except ImportError as exc:
            raise ConfigError(f"on a Dask worker of the scheduler at {scheduler}: {exc}; "
                              "the workers need the same Python packages as this machine "
                              "(nothing was computed)") from None
        except RoverImpactError:  # (no answer)
            raise
        except Exception as exc:  # a roverimpact without code_identity: another version
            raise ConfigError(
                f"a Dask worker of the scheduler at {scheduler} cannot say which "
                f"roverimpact it runs ({type(exc).__name__}: {exc}): another version. "
                "Install the same roverimpact, numpy and pinocchio on every worker, or "
                "stop the workers that differ (nothing was computed)") from None
        bad = {w: d for w, d in there.items() if d != here}
        if bad:
            worker, ident = min(bad.items())
            raise ConfigError(other_code_message(worker, ident, here, len(bad) - 1)
                              + " (nothing was computed)")
        if not kernels:
            return []
        cold = _run_on_workers(client, scheduler, kernels_to_compile, list(kernels))
    return [k for k in kernels if any(k.rpartition(":")[2] in c for c in cold.values())]


#: Dask configuration of the local clusters' worker processes: Dask's default
#: ``MALLOC_TRIM_THRESHOLD_`` unset (None unsets a pre-spawn variable), the one-thread
#: numpy settings kept
WORKER_ENVIRON = {"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}

#: Dask configuration of the local clusters' own background work, which competes with the
#: chunks for the cores: the workers' statistical profiler off (it samples the task's
#: stack every 10 ms for a dashboard these clusters do not serve), the event-loop health
#: tick every second instead of 20 ms, the dashboard's system monitor every 5 s instead
#: of 0.5 s and the memory monitor every 0.5 s instead of 0.1 s (still well inside a
#: chunk's seconds). With Dask's defaults a worker's other threads took 4.2-5.4 % of the
#: CPU its chunk took, and the command (scheduler, nannies, client) 0.36-0.68 s of CPU
#: while two workers computed 8 chunks of 2 s; with these, 0.4 % and 0.08-0.13 s
#: (``benchmarks/bench_dask.py`` prints the comparison; docs/studies.md).
CLUSTER_CONFIG = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.worker.memory.monitor-interval": "500ms",
}

#: Start methods of local workers (:func:`worker_start_method`).
START_METHODS = ("fork", "forkserver", "spawn")


def worker_start_method() -> str:
    """How local clusters start their worker processes: ``"fork"`` on Linux, ``"spawn"``
    elsewhere; ``ROVERIMPACT_WORKER_START=spawn`` (or ``forkserver``, ``fork``) overrides.

    Dask spawns by default: every worker starts a fresh Python that imports numpy,
    Pinocchio, Dask and roverimpact and loads numba's cached kernels: 2.0-6.0 s for a
    cluster of two on 2 cores. A forked worker inherits all of that from the command,
    which has loaded it for the probe that sized the work: 0.14-0.27 s
    (benchmarks/bench_dask.py).
    ``fork`` is Python's own default on Linux before 3.14; macOS (where system libraries
    are not fork-safe) and Windows spawn.

    Raises
    ------
    ConfigError
        ``ROVERIMPACT_WORKER_START`` names another method.
    """
    env = os.environ.get("ROVERIMPACT_WORKER_START", "").strip().lower()
    if env:
        if env not in START_METHODS:
            raise ConfigError(f"ROVERIMPACT_WORKER_START must be one of "
                              f"{', '.join(START_METHODS)}, got {env!r}")
        return env
    return "fork" if sys.platform.startswith("linux") else "spawn"


@contextmanager
def local_cluster(workers: int):
    """A local Dask cluster of ``workers`` processes (1 thread each); yields its address.

    One cluster serves several studies (``reproduce``) instead of one per study.

    The workers start without Dask's default ``MALLOC_TRIM_THRESHOLD_=65536``
    (:data:`WORKER_ENVIRON`): setting it turns off glibc's adaptive mmap threshold, and
    this package's many short-lived numpy arrays then cost page faults: a traverse path
    took 1.2-1.4x the CPU time in a process with that setting
    (``benchmarks/bench_traverse.py`` prints the comparison). On Linux they are forked
    from this process (:func:`worker_start_method`: 0.14-0.27 s against 2.0-6.0 s to spawn),
    with numpy's BLAS at one thread.
    """
    if workers < 1:
        raise ConfigError(f"--workers must be >= 1, got {workers}")
    need_dask()
    import dask
    from dask.distributed import LocalCluster

    method = worker_start_method()
    with _dask_logs_at_warning():
        with dask.config.set({**WORKER_ENVIRON, **CLUSTER_CONFIG,
                              "distributed.worker.multiprocessing-method": method}), \
                one_blas_thread(method), _workers_ignore_ctrl_c(method) as ctrl_c, \
                warnings.catch_warnings():
            # the scheduler's HTTP server (no dashboard here: health checks) takes another
            # port when 8787 is in use, by any other Dask cluster on the machine: Dask's
            # warning ("Port 8787 is already in use. Perhaps you already have a cluster
            # running?") on every run then told the user of a problem that is none
            warnings.filterwarnings("ignore", message=r"Port \d+ is already in use",
                                    category=UserWarning)
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                   dashboard_address=None)
        if ctrl_c:  # while the workers started: the command's, now
            _close(cluster, quiet=True)
            raise KeyboardInterrupt
        interrupted = False
        try:
            yield cluster.scheduler_address
        except KeyboardInterrupt:
            interrupted = True
            raise
        finally:
            _close(cluster, quiet=interrupted)


class _LoggerAtLeast:
    """A logger's level raised to at least ``level`` while in the context."""

    def __init__(self, name: str, level: int):
        self.log, self.level, self.old = logging.getLogger(name), level, None

    def __enter__(self):
        self.old = self.log.level
        if self.log.getEffectiveLevel() < self.level:
            self.log.setLevel(self.level)

    def __exit__(self, *exc):
        self.log.setLevel(self.old)


@contextmanager
def _dask_logs_at_warning():
    """Dask's ``distributed`` loggers at WARNING (at least) while a local cluster lives.

    Its workers are forked (:func:`worker_start_method`) by one of Dask's threads while
    another, the event loop's, logs the cluster's start at INFO ("Register worker ...").
    Dask's own handler drops those records (``silence_logs``), but a handler of the
    process's root logger writes them (pytest's, an application's ``basicConfig``): a
    fork while that thread held the stream's lock left the worker a copy of the lock held
    for ever, and the worker hung at its first log line of its own, with the command
    waiting for it (12 cluster starts in a row under pytest hung at the 12th). Records
    below WARNING are now not made at all, in the command or in the workers (a forked
    process keeps its parent's logger levels), so nothing writes while a worker forks;
    the level is restored afterwards."""
    # a worker closed while it computes a chunk (the cluster closed after a Ctrl-C or a
    # SIGTERM) logs "Async instruction for <Task cancelled name=execute(...)> ended with
    # CancelledError", a line of Dask's internals per busy worker before the command's
    # "interrupted: ... --resume"; forked workers inherit this filter and drop it
    machine = logging.getLogger("distributed.worker.state_machine")
    machine.addFilter(_not_cancelled_at_close)
    try:
        with _LoggerAtLeast("distributed", logging.WARNING):
            yield
    finally:
        machine.removeFilter(_not_cancelled_at_close)


def _not_cancelled_at_close(record: logging.LogRecord) -> bool:
    """False for the worker's "... ended with CancelledError" record of a closing worker
    (:func:`_dask_logs_at_warning`)."""
    return not str(record.msg).endswith("ended with CancelledError")


def _close(cluster, *, quiet: bool) -> None:
    """Close a local cluster; ``quiet`` (after a Ctrl-C or a SIGTERM, which the command
    reports): without Dask's shutdown warnings (cancelled tasks, workers killed), nor the
    traceback its event loop (tornado) once logged for a call into the loop cancelled by
    the close ("Exception in callback functools.partial(<function sync...>)", then
    CancelledError)."""
    if not quiet:
        cluster.close()
        return
    with _LoggerAtLeast("distributed", logging.CRITICAL), \
            _LoggerAtLeast("tornado.application", logging.CRITICAL):
        cluster.close()


@contextmanager
def _workers_ignore_ctrl_c(method: str):
    """Forked workers inherit a SIGINT handler that only notes the signal (in the list
    this yields: a Ctrl-C while they start is the caller's to raise). A Ctrl-C then stops
    the command, which cancels the work and closes the cluster, instead of killing every
    worker mid-task (Dask's "CancelledError" and "still alive after 4 s, killing" lines).
    Spawned workers start Python afresh and are left as they are."""
    seen: list = []
    if method != "fork" or threading.current_thread() is not threading.main_thread():
        yield seen
        return
    previous = signal.signal(signal.SIGINT, lambda signum, frame: seen.append(signum))
    try:
        yield seen
    finally:
        signal.signal(signal.SIGINT, previous)


def one_blas_thread(method: str):
    """While forking workers (Dask's, :func:`~roverimpact.studies.forked.map_forked`'s):
    numpy's BLAS limited to one thread, as a spawned worker's
    ``OMP_NUM_THREADS=1`` does (a forked worker keeps the pool its parent has, and the
    variable is read only when the library loads). The command's own pool is restored
    after. threadpoolctl comes with the ``dask`` extra; without it, nothing is limited."""
    if method != "fork":
        return nullcontext()
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - dask installed without the extra
        return nullcontext()
    return threadpool_limits(limits=1)


class LazyCluster:
    """A local Dask cluster of ``workers`` processes started on first :meth:`address`
    (several studies share it: ``reproduce``); :meth:`close` stops it if it started."""

    def __init__(self, workers: int):
        if workers < 1:
            raise ConfigError(f"--workers must be >= 1, got {workers}")
        worker_start_method()  # a bad ROVERIMPACT_WORKER_START fails before any work
        self.workers = workers
        self._cm = None
        self._address = None

    @property
    def running(self) -> bool:
        return self._address is not None

    def address(self) -> str:
        if self._address is None:
            self._cm = local_cluster(self.workers)
            self._address = self._cm.__enter__()
        return self._address

    def close(self) -> None:
        if self._cm is not None:
            self._cm.__exit__(None, None, None)
            self._cm, self._address = None, None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def worth_a_cluster(serial_s: float, workers: int, running: bool) -> bool:
    """Whether ``workers`` processes finish work of ``serial_s`` seconds (serial
    estimate) sooner than this process: ``overhead + serial_s / workers < serial_s``,
    overhead :data:`CLUSTER_START_S` of the :func:`worker_start_method` (or
    :data:`CLUSTER_RUNNING_S` for a running one).

    >>> worth_a_cluster(3.0, 2, running=False), worth_a_cluster(60.0, 2, running=False)
    (False, True)
    """
    if workers < 2:
        return False
    overhead = CLUSTER_RUNNING_S if running else CLUSTER_START_S[worker_start_method()]
    return overhead + serial_s / workers < serial_s


def why_serial(workers: int, n_chunks: int, probe, n_probe: int, n_total: int, *,
               running: bool = False, unit: str = "cases") -> str | None:
    """Whether work of ``n_chunks`` chunks goes to a local cluster of ``workers``: None if
    so, else why it runs in this process (for the user and the manifest).

    ``probe(k)`` computes the first ``k`` items of the first chunk as a chunk of its own;
    the callers discard its results. It runs three times:

    1. ``probe(1)``, untimed: it loads or compiles what the work needs, which forked
       workers then inherit instead of each compiling it themselves;
    2. ``probe(1)`` and ``probe(n_probe)``, timed. A chunk costs ``c0 + c1 k`` for ``k``
       items: what every chunk pays once (a traverse chunk's vectorised look-ahead and
       limits) and what every item costs. The two times give both, and the work is
       estimated at ``n_chunks c0 + n_total c1`` for :func:`worth_a_cluster`. (One
       probe's time per item charged the chunk's cost to every item: it overestimated a
       short traverse 2.5-fold and started a cluster that made it slower;
       tests/test_traverse_cli.py.)

    A whole first chunk timed here instead leaves the second core idle for that chunk."""
    if workers < 2:
        return "serial: one worker is no faster than this process"
    if n_chunks < 2:
        return "serial: a single chunk"
    probe(1)
    t = time.perf_counter()
    probe(1)
    t1 = time.perf_counter() - t
    if n_probe > 1:
        t = time.perf_counter()
        probe(n_probe)
        per_item = max(time.perf_counter() - t - t1, 0.0) / (n_probe - 1)
        per_chunk = max(t1 - per_item, 0.0)
    else:
        per_item, per_chunk = t1, 0.0
    estimate = n_chunks * per_chunk + n_total * per_item
    if not worth_a_cluster(estimate, workers, running):
        return (f"serial: the work (about {estimate:.1f} s here for {n_total} {unit}) is "
                f"too small to pay for a {workers}-worker cluster")
    return None


def run_serial(pending, chunks, args, params, simulate, store, *, on_error: str = "stop"
               ) -> None:
    """Compute the ``pending`` chunks one after the other on this process."""
    for k in pending:
        store(k, compute_chunk(*args, chunks[k], params, simulate, on_error=on_error))


def worker_result(fut, scheduler: str, then: str = "rerun once it runs again",
                  what: str = "a chunk", killed: str = ""):
    """``fut.result()``, a chunk's rows; a case that cannot be posed, returned as its error
    (:func:`compute_chunk_file`), is raised. An error of the workers' environment says so:
    a robot file this machine has but the worker does not see read "no such URDF/MJCF
    file" with no hint where it was read, a package the worker lacks an ImportError. A
    scheduler gone away is one line ending with ``then`` (what to do), not Dask's
    ``FutureCancelledError`` traceback; so is a chunk (``what``) whose workers died while
    computing it, one after the other (a crash or the memory limit: Dask's
    ``KilledWorker`` traceback), with ``killed`` (what is kept) before the advice."""
    from concurrent.futures import CancelledError

    from distributed import KilledWorker

    try:
        out = fut.result()
    except KilledWorker:
        raise RoverImpactError(
            f"{what} killed every Dask worker that computed it (the scheduler at "
            f"{scheduler} gave up after a few): a crash, or the workers' memory limit. "
            f"{killed}run them without Dask to see why, or give the workers more memory"
            ) from None
    except ImportError as exc:
        raise ConfigError(f"on a Dask worker of the scheduler at {scheduler}: {exc}; the "
                          "workers need the same Python packages as this machine") from None
    except InputError as exc:
        out = exc
    except CancelledError:
        raise RoverImpactError(
            f"lost the Dask scheduler at {scheduler} (it stopped, or the connection to it "
            f"was cut): {then}") from None
    if isinstance(out, RoverImpactError) and not isinstance(out, InputError):
        raise out  # (a worker of other code: compute_chunk_file)
    if isinstance(out, InputError):
        if MISSING_FILE.search(str(out)):
            raise reworded(out, (
                f"on a Dask worker of the scheduler at {scheduler}: {out}; the workers read "
                "the study's files at the paths given here, so they must see them (a shared "
                "or copied folder)")) from None
        raise out  # (a case's own error: its message names the case)
    return out


#: How the loaders say that a file is missing (:func:`worker_result`'s hint).
MISSING_FILE = re.compile(r"no such|not found|does not exist|No such file", re.IGNORECASE)


#: How often [s] a command waiting for its tasks asks the scheduler how many workers it has
#: (:func:`as_finished`)
WORKERS_CHECK_S = 1.0


def scheduler_workers(client, timeout: float = 5.0) -> int | None:
    """The number of workers of ``client``'s scheduler; None if it does not answer within
    ``timeout`` seconds (gone: the client's futures say so)."""
    try:
        info = client.sync(client.scheduler.identity, n_workers=0, callback_timeout=timeout)
    except Exception:  # the scheduler gone, or too busy to answer now
        return None
    n = info.get("n_workers") if isinstance(info, dict) else None
    return n if isinstance(n, int) else None


def as_finished(queue, client, scheduler: str, *, then: str,
                note: Callable[[str], None] | None = None,
                workers_wait: float | None = None):
    """The futures of ``queue`` (Dask's ``as_completed``, to which the caller may add while
    iterating) as they finish. While none is ready the scheduler is asked every
    :data:`WORKERS_CHECK_S` seconds how many workers it has: with every worker gone (killed,
    its machine down), Dask holds the tasks until one joins, and the command waited for
    ever at the chunks done so far. ``note`` says that it waits, and after ``workers_wait``
    seconds (default :data:`WORKERS_WAIT_S`, as for a scheduler that has no worker at the
    start) without a worker it stops with an error ending with ``then`` (what to do).

    Raises
    ------
    RoverImpactError
        No worker for ``workers_wait`` seconds.
    """
    wait = WORKERS_WAIT_S if workers_wait is None else workers_wait
    gone_since = None  # when no worker was first seen
    next_check = time.monotonic() + WORKERS_CHECK_S
    while not queue.is_empty():
        if queue.has_ready():
            yield next(queue)
            continue
        now = time.monotonic()
        if now >= next_check:
            n = scheduler_workers(client)
            now = time.monotonic()
            next_check = now + WORKERS_CHECK_S
            if n:
                gone_since = None
            elif n == 0 and gone_since is None:
                gone_since = now
                if note is not None:
                    note(f"every Dask worker of the scheduler at {scheduler} is gone: waiting "
                         f"up to {wait:.0f} s for one (start them with `dask worker "
                         f"{scheduler}`)")
            if n == 0 and now - gone_since >= wait:
                raise RoverImpactError(
                    f"lost every Dask worker of the scheduler at {scheduler}, and none "
                    f"joined in {wait:.0f} s: {then}")
        with queue.thread_condition:  # notified as a future finishes
            queue.thread_condition.wait(timeout=0.1)


def run_dask(pending, chunks, args, params, simulate, scheduler, retries, store, *,
             note: Callable[[str], None] | None = None, on_error: str = "stop") -> None:
    """Compute the ``pending`` chunks on the Dask scheduler at ``scheduler``; ``store`` each
    as it returns (once, whatever happens to the workers). Every worker gone for
    :data:`WORKERS_WAIT_S` seconds stops it (:func:`as_finished`; ``note`` says that it
    waits)."""
    from dask.distributed import Client, as_completed, default_client

    try:  # a client of this process already connected to that scheduler (a notebook's)
        client = default_client()
        own = client.scheduler.address != scheduler
    except ValueError:
        own = True
    if own:
        client = Client(scheduler, timeout="10s")
    # a scheduler gone away is said once, by worker_result; Dask's client would log each
    # failed reconnection with a traceback first
    quiet = _LoggerAtLeast("distributed.client", logging.CRITICAL) if own else nullcontext()
    try:
        with quiet:
            code = code_identity()
            # at most a few chunks per worker in flight: the chunks' cases are made as they
            # are submitted and results are written as they return, so memory does not grow
            # with the number of chunks
            n_workers = max(len(client.scheduler_info().get("workers", {})), 1)
            window = max(4 * n_workers, 8)
            todo = iter(pending)
            futures = {}

            def submit() -> bool:
                k = next(todo, None)
                if k is None:
                    return False
                # arguments are small: shipped with each task, so a lost worker loses nothing
                fut = client.submit(compute_chunk_file, *args, chunks[k], params, simulate,
                                    code=code, on_error=on_error, retries=retries,
                                    pure=False)
                futures[fut] = k
                return True

            for _ in range(window):
                if not submit():
                    break
            written = set()
            queue = as_completed(list(futures))
            then = "the finished chunks are kept: rerun with --resume once it runs again"
            for fut in as_finished(queue, client, scheduler, note=note,
                                   then=then.replace("it runs", "workers run")):
                k = futures.pop(fut)
                first = k * chunks.size if hasattr(chunks, "size") else None
                df = worker_result(fut, scheduler, then, what=(
                    f"chunk {k}" if first is None else
                    f"chunk {k} (cases {first}-{first + len(chunks[k]) - 1})"),
                    killed="The finished chunks are kept; ")
                if k not in written:  # a chunk is stored once, whatever happened to workers
                    store(k, df)
                    written.add(k)
                fut.release()
                del df
                if submit():
                    queue.add(next(reversed(futures)))
    finally:
        if own:
            with quiet:  # closing cancels the client's reconnection, which Dask logs
                client.close()
