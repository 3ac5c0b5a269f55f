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
import warnings
from collections.abc import Callable, Sequence
from typing import Any

from ..exceptions import RoverImpactError
from .executors import one_blas_thread, worker_start_method

__all__ = ["STOP_GRACE_S", "ProcessDied", "map_forked", "side_by_side", "usable_cores"]


class ProcessDied(RoverImpactError, RuntimeError):
    """A process of :func:`map_forked` died (killed, out of memory) computing item
    ``item`` (its index; None if not known); ``how``: ``killed by SIGKILL``,
    ``exit code 3`` (:func:`how_it_died`)."""

    def __init__(self, message: str, item: int | None = None, how: str = ""):
        super().__init__(message)
        self.item, self.how = item, how


def how_it_died(exitcode: int | None) -> str:
    """``killed by SIGKILL`` for a negative exit code (the signal), else ``exit code N``."""
    if exitcode is not None and exitcode < 0:
        try:
            return f"killed by {signal.Signals(-exitcode).name}"
        except ValueError:  # pragma: no cover - a signal Python does not name
            return f"killed by signal {-exitcode}"
    return f"exit code {exitcode}"

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
    one (progress, notes); the event must be picklable, as the results must. What a
    process prints (``sys.stdout``, ``sys.stderr``: whole lines) and its warnings are
    written and shown here, where a progress bar may be drawn (a process writing to the
    terminal itself wrote into the bar's line), and a warning shown here once
    (``warnings.showwarning`` of this process) is not shown again by another process.

    Errors: the first item's exception is raised here once the processes have finished
    the items they had begun (no further item is begun). A Ctrl-C (or a SIGTERM turned
    into ``KeyboardInterrupt``) here lets every process end its item as a Ctrl-C does
    (:data:`STOP_GRACE_S`), then raises ``KeyboardInterrupt``. A process that dies
    (killed, out of memory) raises :class:`ProcessDied` naming how, and the item it
    computed. With
    ``processes`` <= 1, or one item, the items run here, one after the other."""
    items = list(items)
    events = events or _ignore
    n = min(processes, len(items))
    if n <= 1:
        return [func(item, events) for item in items]
    ctx = multiprocessing.get_context("fork")
    messages = ctx.Queue()
    following = ctx.Value("i", 0)   # the next item to begin
    current = ctx.Array("i", [-1] * n)  # the item each process computes (shared memory:
    # a message sent just before the process is killed may be lost)
    procs = [ctx.Process(target=_work, args=(func, items, following, current, messages),
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
        elif kind == "write":
            _write(msg[1], msg[2])
        elif kind == "warning":
            warnings.showwarning(*msg[1])
        elif kind == "result":
            results[msg[1]] = pickle.loads(msg[2])  # (the process pickled it)
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
                            i, how = current[k], how_it_died(p.exitcode)
                            i = None if i < 0 else i
                            errors.append(ProcessDied(
                                f"a worker process died ({how}) "
                                + (f"computing item {i}" if i is not None else
                                   "computing the work")
                                + "; it may have run out of memory", i, how))
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


def _write(name: str, text: str) -> None:
    """What a process printed, to this process's stream (a progress bar's redirect)."""
    stream = getattr(sys, name, None)
    if stream is None:  # pragma: no cover - no such stream here
        return
    try:
        stream.write(text)
        stream.flush()
    except (OSError, ValueError):  # a closed pipe: nothing to say it on
        pass


class _Lines:
    """A process's ``sys.stdout`` or ``sys.stderr``: whole lines sent to the parent
    (:func:`map_forked` writes them to its own stream); anything else of a text stream
    (``isatty``, ``encoding``, ``fileno``) is that of ``stream``, the file's own, which
    also takes the text once the messages are closed."""

    def __init__(self, name: str, messages, stream):
        self._name, self._messages, self._stream = name, messages, stream
        self._pending = ""
        self.closed_messages = False

    def write(self, text: str) -> int:
        self._pending += text
        if "\n" in self._pending:
            head, _, self._pending = self._pending.rpartition("\n")
            self._send(head + "\n")
        return len(text)

    def flush(self) -> None:
        if self._pending:
            text, self._pending = self._pending, ""
            self._send(text)

    def _send(self, text: str) -> None:
        if not self.closed_messages:
            try:
                self._messages.put(("write", self._name, text))
                return
            except (OSError, ValueError):  # pragma: no cover - the queue is closed
                pass
        self._stream.write(text)
        self._stream.flush()

    def writable(self) -> bool:
        return True

    def __getattr__(self, name):
        return getattr(self._stream, name)


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
        return _unsent(obj, what, exc)
    return None


def _unsent(obj, what: str, exc: Exception) -> RuntimeError:
    """The error sent instead of ``obj``, which pickling refused with ``exc``."""
    return RuntimeError(f"{what} could not be sent back from its process ({exc}): "
                        f"{obj!r}"[:2000])


def _work(func, items, following, current, messages) -> None:
    """A forked process: items in turn until none is left or one fails."""
    # the parent's streams may have been locked by one of its threads (a progress bar's)
    # at the fork: this process writes through streams of its own on the same files,
    # and sends its lines to the parent, which writes them (above its progress bar)
    lines = []
    for name, fd in (("stdout", 1), ("stderr", 2)):
        stream = getattr(sys, name)
        if stream is not None:
            try:
                own = open(fd, "w", buffering=1, closefd=False,
                           encoding=stream.encoding, errors=stream.errors)
            except (OSError, AttributeError, ValueError):  # pragma: no cover - no such fd
                continue
            lines.append(_Lines(name, messages, own))
            setattr(sys, name, lines[-1])
    me = int(multiprocessing.current_process().name.rsplit("-", 1)[1])

    def emit(*event) -> None:
        messages.put(("event", event))

    def show(message, category, filename, lineno, file=None, line=None) -> None:
        if file is not None:  # asked for a file of its own: shown there, as usual
            try:
                file.write(warnings.formatwarning(message, category, filename, lineno, line))
            except OSError:  # pragma: no cover - as Python's own: a warning is lost
                pass
            return
        if _unpicklable(category, "a warning") is not None:
            category = UserWarning
        messages.put(("warning", (str(message), category, str(filename), int(lineno))))

    warnings.showwarning = show

    try:
        while True:
            with following.get_lock():
                i = following.value
                following.value += 1
            if i >= len(items):
                break
            current[me] = i
            try:
                result = func(items[i], emit)
            except BaseException as exc:  # Ctrl-C included: the parent decides
                messages.put(("error", i, _unpicklable(exc, "an error") or exc))
                break
            try:  # pickled once, here: the queue then sends the bytes as they are
                payload = pickle.dumps(result)
            except Exception as exc:
                messages.put(("error", i, _unsent(result, "a result", exc)))
                break
            messages.put(("result", i, payload))
    finally:
        for stream in lines:
            stream.flush()
        messages.put(("end", me))
        for stream in lines:
            stream.closed_messages = True
        messages.close()
        messages.join_thread()
