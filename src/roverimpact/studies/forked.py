"""Independent tasks side by side on this machine's cores, in processes forked from this one.

``roverimpact reproduce`` runs its four studies, and draws their figures, this way: each
study is a few seconds of work, too little for a Dask cluster's start and per-study probe
(:func:`~roverimpact.studies.executors.why_serial`), but the studies need nothing from
each other. A forked process inherits what this one has imported, loaded and compiled, so
it starts in milliseconds and computes its first case at full speed.

Where processes are not forked (macOS, Windows, ``ROVERIMPACT_WORKER_START=spawn``), or on
one core, the tasks run one after the other in this process.
"""

from __future__ import annotations

import multiprocessing
import os
import pickle
import queue as queue_module
import signal
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any

from .executors import one_blas_thread, worker_start_method

__all__ = ["STOP_GRACE_S", "map_forked", "side_by_side", "usable_cores"]

#: Seconds a process is given to end its task after an interruption before it is sent
#: SIGINT itself (a Ctrl-C at the terminal reaches every process of the command at once;
#: a SIGTERM reaches this one alone), then as long again before it is terminated.
STOP_GRACE_S = 2.0


def usable_cores() -> int:
    """The cores this process may run on (its CPU affinity where the system tells it)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # pragma: no cover - macOS, Windows
        return max(1, os.cpu_count() or 1)


def side_by_side(n_tasks: int) -> int:
    """How many processes :func:`map_forked` uses for ``n_tasks`` tasks by default: one per
    usable core, at most one per task; 1 where workers are not forked
    (:func:`~roverimpact.studies.executors.worker_start_method`)."""
    if worker_start_method() != "fork":
        return 1
    return max(1, min(usable_cores(), n_tasks))


def _ignore(*event) -> None:
    pass


def map_forked(func: Callable[[Any, Callable[..., None]], Any], items: Sequence, *,
               processes: int, events: Callable[..., None] | None = None) -> list:
    """``[func(item, emit) for item in items]``, the items computed in up to ``processes``
    processes forked from this one, each taking the next item when it finishes one (give
    the longest first).

    ``emit(*event)``, called by ``func`` in a process, calls ``events(*event)`` in this
    one (progress, notes); the event must be picklable, as the results must.

    Errors: the first item's exception is raised here once the processes have finished
    the items they had begun (no further item is begun). A Ctrl-C (or a SIGTERM turned
    into ``KeyboardInterrupt``) here lets every process end its item as a Ctrl-C does
    (:data:`STOP_GRACE_S`), then raises ``KeyboardInterrupt``. A process that dies
    (killed, out of memory) raises :class:`RuntimeError` naming its exit code. With
    ``processes`` <= 1, or one item, the items run here, one after the other."""
    items = list(items)
    events = events or _ignore
    n = min(processes, len(items))
    if n <= 1:
        return [func(item, events) for item in items]
    ctx = multiprocessing.get_context("fork")
    messages = ctx.Queue()
    following = ctx.Value("i", 0)   # the next item to begin
    procs = [ctx.Process(target=_work, args=(func, items, following, messages),
                         daemon=True, name=f"roverimpact-{k}") for k in range(n)]
    results: list = [None] * len(items)
    errors: list[BaseException] = []
    ended: set[int] = set()

    def begin_no_more() -> None:
        with following.get_lock():
            following.value = len(items)

    def handle(msg) -> None:
        kind = msg[0]
        if kind == "event":
            events(*msg[1])
        elif kind == "result":
            results[msg[1]] = msg[2]
        elif kind == "error":
            errors.append(msg[2])
            begin_no_more()
        else:  # "end"
            ended.add(msg[1])

    try:
        with one_blas_thread("fork"):
            for p in procs:
                p.start()
        while len(ended) < n:
            try:
                handle(messages.get(timeout=0.2))
            except queue_module.Empty:
                for k, p in enumerate(procs):
                    if k not in ended and p.exitcode is not None:
                        _drain(messages, handle)  # what it sent before it ended
                        if k not in ended:  # it died without a word
                            ended.add(k)
                            errors.append(RuntimeError(
                                f"a worker process died (exit code {p.exitcode}) "
                                "computing the work; it may have run out of memory"))
                            begin_no_more()
    except KeyboardInterrupt:
        _stop(procs, messages)
        raise
    finally:
        for p in procs:
            p.join(timeout=STOP_GRACE_S)
            if p.is_alive():  # pragma: no cover - stopped above
                p.terminate()
                p.join()
        messages.close()
    if errors:
        raise errors[0]
    return results


def _drain(messages, handle) -> None:
    """Every message waiting in ``messages``, to ``handle``."""
    while True:
        try:
            msg = messages.get(timeout=0.05)
        except queue_module.Empty:
            return
        handle(msg)


def _stop(procs, messages) -> None:
    """Ctrl-C here: each process ends the item it computes as on a Ctrl-C of its own
    (the study marks its manifest ``interrupted``), then is terminated. Their messages
    are read meanwhile (and dropped), so that none waits to send one."""
    for signalled in (False, True):
        if signalled:
            for p in procs:
                if p.is_alive():
                    try:
                        os.kill(p.pid, signal.SIGINT)
                    except OSError:  # pragma: no cover - ended meanwhile
                        pass
        deadline = time.monotonic() + STOP_GRACE_S
        while any(p.is_alive() for p in procs) and time.monotonic() < deadline:
            try:
                messages.get(timeout=0.05)
            except queue_module.Empty:
                pass
    for p in procs:
        if p.is_alive():
            p.terminate()


def _unpicklable(obj, what: str) -> RuntimeError | None:
    """The error to send instead of ``obj`` if it cannot be sent (pickled), else None."""
    try:
        pickle.dumps(obj)
    except Exception as exc:
        return RuntimeError(f"{what} could not be sent back from its process ({exc}): "
                            f"{obj!r}"[:2000])
    return None


def _work(func, items, following, messages) -> None:
    """A forked process: items in turn until none is left or one fails."""
    # the parent's streams may have been locked by one of its threads (a progress bar's)
    # at the fork: this process writes through streams of its own on the same files
    for name, fd in (("stdout", 1), ("stderr", 2)):
        stream = getattr(sys, name)
        if stream is not None:
            try:
                setattr(sys, name, open(fd, "w", buffering=1, closefd=False,
                                        encoding=stream.encoding, errors=stream.errors))
            except (OSError, AttributeError, ValueError):  # pragma: no cover - no such fd
                pass
    me = int(multiprocessing.current_process().name.rsplit("-", 1)[1])

    def emit(*event) -> None:
        messages.put(("event", event))

    try:
        while True:
            with following.get_lock():
                i = following.value
                following.value += 1
            if i >= len(items):
                break
            try:
                result = func(items[i], emit)
            except BaseException as exc:  # Ctrl-C included: the parent decides
                messages.put(("error", i, _unpicklable(exc, "an error") or exc))
                break
            bad = _unpicklable(result, "a result")
            if bad is not None:
                messages.put(("error", i, bad))
                break
            messages.put(("result", i, result))
    finally:
        messages.put(("end", me))
        messages.close()
        messages.join_thread()
