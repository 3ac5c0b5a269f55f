"""Kernels compiled for exactly one signature, on first use.

A kernel called from Python with ``@njit`` alone is compiled once per distinct set of
argument types: a read-only index array (a shared zero index, a broadcast view, a user's
read-only input) and a writable one are different types, and each costs a full compile of
the kernel and of everything it calls (the unilateral impact kernel was compiled four
times by ``roverimpact reproduce`` on a fresh install, 2.5-3.3 s each). A :class:`Kernel`
has one explicit signature: inputs typed read-only C arrays (a writable array converts to
them at no cost), outputs writable C arrays. It is compiled (or loaded from numba's on-disk
cache) the first time it is needed, never at import, and has one cache entry.

Functions that kernels call stay ``@njit``: they are compiled for the types their callers
pass, which the explicit signatures fix. Those that several kernels call are :func:`shared`:
compiled with LLVM's vectorisers off whichever kernel needs them first, so that every
process (and numba's on-disk cache, whose entries do not record these settings) has the
same code for them.

numba compiles one function at a time per process. On a fresh install a command that will
need a kernel later can have it compiled meanwhile on another core:
:func:`compile_in_background` starts a separate Python process that builds the kernels
into numba's on-disk cache (only those whose cache entry is missing), and :meth:`Kernel.get`
waits for that process and loads the result instead of compiling it a second time.

Until then, small work runs the kernel's own Python code instead (:meth:`Kernel.get` with
``items``): on a fresh install a kernel's compile costs seconds (1.4-34 s each on a
2-core machine, ``benchmarks/bench_startup.py --kernels``) where its Python code takes a
few milliseconds an item, so a command that evaluates one scenario, or a few hundred,
does not wait for the compiler. The kernel compiles meanwhile in the background process
and is loaded from numba's cache once that process has finished; a kernel whose Python
code has run :data:`PYTHON_ITEMS` items in a process compiles (or waits for the
background process) for the rest. The Python code is the kernel's own source with every
compiled function it calls replaced by its Python source (:func:`python_version`); its
results equal the compiled kernel's to rounding, not to the bit (LLVM contracts and
reorders floating-point operations). ``ROVERIMPACT_KERNELS=compiled`` always compiles
(the test suite's setting, so that its results do not depend on the cache's state),
``=python`` always runs the Python code (slow; to debug a kernel).

A kernel in the cache loads in milliseconds, except the first of a process: that load sets
up numba's compiler (about 0.25 s). A process whose work is small
(:func:`declare_small_work`: the command line's ``energy``, ``simulate``, a small
``sweep``) therefore runs a cached kernel's Python code too, for a tenth of its budget,
until a kernel has been loaded.

Every compiled function of the package takes :data:`NJIT_OPTIONS`. numba caches a function
beside its source, else in ``NUMBA_CACHE_DIR``, else in the user's cache folder, and with
``cache=True`` refuses to compile one when none of them can be written (a read-only install
used with an unwritable or unset home). Importing this module checks that once
(:func:`ensure_cache_folder`) and falls back to a temporary folder for the run, or to no
cache.
"""

from __future__ import annotations

import atexit
import math
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import types as pytypes
import warnings
from contextlib import contextmanager, nullcontext
from pathlib import Path

import numpy as np
from numba import njit, types
from numba.core import config as numba_config
from numba.core.compiler_lock import global_compiler_lock
from numba.core.dispatcher import Dispatcher

from .. import _kernels
from ..exceptions import ConfigError

f8, i8, b1, boolean = types.float64, types.int64, types.bool_, types.boolean

#: numba options of every compiled function of the package (a kernel's or a :func:`shared`
#: function's own options go on top); ``cache`` is False when no folder can hold numba's
#: cache (:func:`ensure_cache_folder`).
NJIT_OPTIONS = {"cache": True, "nogil": True}


def _cache_probe():  # pragma: no cover - never called: numba locates its cache by its file
    pass


def cache_writable() -> bool:
    """Whether numba finds a writable folder for the cache of this package's kernels
    (beside their sources, in ``NUMBA_CACHE_DIR`` or in the user's cache folder)."""
    from numba.core.caching import FunctionCache

    try:
        FunctionCache(_cache_probe)
    except RuntimeError:  # numba: "cannot cache function ...: no locator available"
        return False
    return True


def ensure_cache_folder() -> str | None:
    """Make ``cache=True`` usable when numba can write its cache nowhere.

    Then the compiled kernels are cached, for this run only, in a new temporary folder
    removed at exit: ``NUMBA_CACHE_DIR`` is set to it, in numba's settings and in the
    environment, so that the background compile (:func:`compile_in_background`) and Dask
    workers started by this process use it too. If numba cannot use a temporary folder
    either, :data:`NJIT_OPTIONS` turns the cache off. Either way a warning says how to keep the
    kernels between runs. Returns the temporary folder, or None.
    """
    if cache_writable():
        return None
    tried = [f"roverimpact's folder {Path(__file__).resolve().parents[1]}",
             "the user's cache folder"]
    if numba_config.CACHE_DIR:
        tried.insert(0, f"NUMBA_CACHE_DIR={numba_config.CACHE_DIR}")
    keep = (f"set NUMBA_CACHE_DIR to a writable folder to keep them ({', '.join(tried)}: "
            "not writable)")
    try:
        folder = tempfile.mkdtemp(prefix="roverimpact-numba-")
    except OSError:
        folder = None
    if folder is not None:
        before = os.environ.get("NUMBA_CACHE_DIR"), numba_config.CACHE_DIR
        os.environ["NUMBA_CACHE_DIR"] = numba_config.CACHE_DIR = folder
        if cache_writable():
            atexit.register(shutil.rmtree, folder, ignore_errors=True)
            warnings.warn(f"numba can write its cache of compiled kernels only to the "
                          f"temporary folder {folder}, removed at exit: every run compiles "
                          f"them again; {keep}", UserWarning, stacklevel=2)
            return folder
        shutil.rmtree(folder, ignore_errors=True)
        if before[0] is None:
            del os.environ["NUMBA_CACHE_DIR"]
        else:
            os.environ["NUMBA_CACHE_DIR"] = before[0]
        numba_config.CACHE_DIR = before[1]
    NJIT_OPTIONS["cache"] = False
    warnings.warn(f"numba can write its cache of compiled kernels nowhere: every run "
                  f"compiles them again; {keep}", UserWarning, stacklevel=2)
    return None


ensure_cache_folder()


def ro(dtype, ndim: int):
    """Read-only C-contiguous array type (writable arrays convert to it)."""
    return types.Array(dtype, ndim, "C", readonly=True)


def rw(dtype, ndim: int):
    """Writable C-contiguous array type."""
    return types.Array(dtype, ndim, "C")


def partition_signature():
    """``(M, A, v, iM, iA, iv, rtol, want_vc, T, Tc, Ta, vc, va, rank, status)`` of the
    lane-parallel partition kernel."""
    return types.void(ro(f8, 3), ro(f8, 3), ro(f8, 2), ro(i8, 1), ro(i8, 1), ro(i8, 1), f8,
                      boolean, rw(f8, 1), rw(f8, 1), rw(f8, 1), rw(f8, 2), rw(f8, 2),
                      rw(i8, 1), rw(i8, 1))


def _entry_point(dispatcher):
    """The C entry point of a dispatcher compiled for one signature (numba's
    ``CompileResult.entry_point``), or the dispatcher itself if numba lays it out
    otherwise."""
    try:
        (result,) = dispatcher.overloads.values()
        return result.entry_point
    except (AttributeError, ValueError):
        return dispatcher


class Kernel:
    """``njit(signature, cache=True, nogil=True, **options)(py_func)``, built on first use.

    ``kernel.get()`` returns the compiled dispatcher (hot paths call it directly);
    ``kernel(*args)`` calls it. ``slp=True`` compiles with LLVM's SLP vectoriser switched
    on for this function only (numba leaves it off), ``loop_vectorize=False`` with its
    loop vectoriser off (numba leaves it on); the previous settings are restored. They
    apply to the kernel and to the code of the functions it calls as LLVM inlines or
    links it into the kernel; :func:`shared` functions are themselves always compiled
    with both off.
    Thread-safe: a kernel is compiled once even if two threads ask for it together.
    """

    def __init__(self, py_func, signature, *, slp: bool = False, loop_vectorize: bool = True,
                 home: str | None = None, python_budget: int | None = None, **options):
        self.py_func = py_func
        #: ``module:attribute`` where this object lives (for :func:`compile_in_background`)
        self.home = home or f"{py_func.__module__}:{py_func.__name__}"
        self.signature = signature
        self._options = {**NJIT_OPTIONS, **options}
        self._slp = slp
        self._loop_vectorize = loop_vectorize
        self._dispatcher = None
        #: the compiled overload's entry point once :meth:`unchecked` has returned it, else
        #: None (hot paths read it first: an attribute costs less than the method call)
        self.entry = None
        self._background = None  # a process compiling this kernel into the cache
        self._lock = threading.Lock()
        self._python = None  # the Python stand-in (python_version), made on first use
        self._cold = None  # whether numba's cache lacked this kernel when first asked
        self._polled = -math.inf  # when _cache_written last read the cache
        #: items this process has run through the Python code (:meth:`get`), and at most
        #: how many (:data:`PYTHON_ITEMS` unless the kernel's items cost more in Python)
        self.python_items = 0
        self.python_budget = python_budget
        self.__doc__ = py_func.__doc__
        self.__name__ = py_func.__name__

    def get(self, items: int | None = None):
        """The compiled dispatcher (compiled or loaded from the cache on the first call).

        ``items``: how many items the call about to be made computes. Given, and while
        numba's cache lacks the kernel, the kernel's Python code is returned instead (the
        same arguments and results, to rounding) until :data:`PYTHON_ITEMS` items have run
        through it in this process; the compile is sent to a background process
        (:func:`compile_in_background`) if none is under way, and the compiled kernel is
        loaded once that process has finished. In a process whose work is declared small
        (:func:`declare_small_work`), a kernel the cache holds also runs its Python code,
        for ``PYTHON_ITEMS // WARM_SHARE`` items, while numba has not set up its compiler.
        Not given: compiled (hot paths of large batches, and callers that need numba's
        argument checks).

        A compile that numba's cache cannot serve runs inside
        ``roverimpact._kernels.compile_notice(self)`` when one is set (the command line's
        says what is compiling)."""
        d = self._dispatcher
        if d is None and items is not None and self._python_for(items):
            return self.python()
        if d is None:
            with self._lock:
                if self._dispatcher is None:
                    notice = _kernels.compile_notice
                    with (notice(self) if notice is not None and not self.cached()
                          else nullcontext()):
                        self._wait_background()
                        self._dispatcher = self._build()
                d = self._dispatcher
        return d

    def unchecked(self, items: int | None = None):
        """:meth:`get`, with the compiled kernel as the entry point of its one signature:
        it converts the arguments to that signature's types without numba's type
        resolution, a good part of what a call of a one-item kernel costs beyond its work.
        For callers that have made sure of every array argument's dtype, dimensions, C
        layout and alignment themselves: the entry point takes an array's memory as the
        signature says it is. Where numba does not expose it, the dispatcher."""
        e = self.entry
        if e is None:
            d = self.get(items)
            if d is not self._dispatcher:  # the Python code, until the compile lands
                return d
            e = self.entry = _entry_point(d)
        return e

    @property
    def compiled(self) -> bool:
        """Whether :meth:`get` has built the dispatcher in this process."""
        return self._dispatcher is not None

    def python(self):
        """The kernel as plain Python (:func:`python_version`), run with numpy's
        floating-point warnings off (the compiled kernel raises none)."""
        f = self._python
        if f is None:
            code = python_version(self.py_func)

            def f(*args):
                with np.errstate(all="ignore"):
                    return code(*args)

            f.__name__ = f.__qualname__ = self.__name__
            f.__doc__ = self.__doc__
            self._python = f
        return f

    def _python_for(self, items: int) -> bool:
        """Whether a call of ``items`` items runs the Python code (:meth:`get`)."""
        mode = kernel_mode()
        if mode != "auto":
            return mode == "python"
        with self._lock:
            budget = PYTHON_ITEMS if self.python_budget is None else self.python_budget
            if self._dispatcher is not None or self.python_items + items > budget:
                return False
            proc = self._background
            if proc is not None and proc.foreign():
                # sent by the process this one was forked from (a study side by side, a
                # forked Dask worker): loaded once that process's compile has written it
                if self._cache_written():
                    return False
            elif proc is not None:
                if proc.poll() is not None:  # finished: load (or compile) it
                    return False
            else:
                if self._cold is None:
                    self._cold = not self.cached()
                if not self._cold:  # in the cache: loads in milliseconds, once numba is set up
                    warm_budget = budget // WARM_SHARE
                    if not (_kernels.small_work and self.python_items + items <= warm_budget
                            and not numba_set_up()):
                        return False
                    self.python_items += items
                    return True
                if os.environ.get("ROVERIMPACT_BACKGROUND_COMPILE") == "0":
                    return False  # compiled here, as asked
                compile_in_background(self)
            self.python_items += items
            return True

    def _cache_written(self) -> bool:
        """Whether numba's cache holds this kernel now, read at most every
        :data:`CACHE_POLL_S` (a read costs about a millisecond)."""
        now = time.monotonic()
        if now - self._polled < CACHE_POLL_S:
            return False
        self._polled = now
        return self.cached()

    def _wait_background(self) -> None:
        proc, self._background = self._background, None
        if proc is not None:
            try:  # then numba loads what it wrote; if it failed, the kernel compiles here
                proc.wait(timeout=BACKGROUND_TIMEOUT)
            except subprocess.TimeoutExpired:  # pragma: no cover - a stalled machine
                pass

    def cached(self) -> bool:
        """Whether numba's on-disk cache holds an entry for this kernel (of this source).

        Reads numba's cache index; any failure to read it counts as "cached" (nothing is
        started in the background on a guess)."""
        try:
            from numba.core.caching import FunctionCache

            return bool(FunctionCache(self.py_func)._cache_file._load_index())
        except Exception:  # pragma: no cover - a numba without these internals
            return True

    def _build(self):
        slp = 1 if self._slp else None
        loop = None if self._loop_vectorize else 0
        with vectorisers(slp=slp, loop=loop):
            return njit(self.signature, **self._options)(self.py_func)

    def __call__(self, *args):
        return self.get()(*args)

    def __repr__(self) -> str:
        state = "compiled" if self.compiled else "not compiled yet"
        return f"<Kernel {self.py_func.__module__}.{self.__name__}{self.signature} ({state})>"


#: Items a kernel computes through its Python code in one process while numba's cache
#: lacks it (:meth:`Kernel.get`): about the compile time of the smaller kernels at a few
#: milliseconds an item; past it the process compiles the kernel or waits for the
#: background process (which has then had that long).
PYTHON_ITEMS = 1000

#: In a process whose work is small, the share of a kernel's Python budget it runs although
#: numba's cache holds the kernel, until numba has set up its compiler in the process
#: (:func:`numba_set_up`): 100 items of about a millisecond against the set-up's
#: about 0.25 s (:func:`declare_small_work`).
WARM_SHARE = 10


def declare_small_work() -> None:
    """Say that this process's work is small: one scenario, or a few hundred items (the
    command line's ``energy``, ``simulate``, a small ``sweep``; ``cli._app.compile_ahead``
    with ``small``).

    Then a kernel that numba's cache holds also runs its Python code for its first
    ``budget // WARM_SHARE`` items (100; none for the integrators) while no compiled
    kernel has been loaded in this process: numba's first load in a process sets up its
    compiler (its registries of implementations, about 0.25 s on 2 cores), and an item of a
    kernel's Python code costs about a millisecond. A warm ``roverimpact energy`` paid
    that set-up for two kernels loaded in milliseconds each; it now runs as a cold one
    (``benchmarks/bench_startup.py``), with the same results as a cold one: the Python
    code's, equal to the compiled kernel's to rounding. Once a kernel is loaded (past its
    items, or a kernel with no Python budget), every kernel loads from the cache.
    """
    _kernels.small_work = True


def numba_set_up() -> bool:
    """Whether numba has set up its compiler in this process (its CPU target's
    registries of implementations, loaded by the first compile or cache load). Any doubt
    (a numba without these internals) counts as set up."""
    try:
        from numba.core.registry import cpu_target

        return bool(cpu_target.target_context._registries)
    except Exception:  # pragma: no cover - a numba without these internals
        return True


#: ``ROVERIMPACT_KERNELS`` values: ``auto`` (default; Python code for small work while a
#: kernel is not in numba's cache), ``compiled``, ``python``.
KERNEL_MODES = ("auto", "compiled", "python")


def kernel_mode() -> str:
    """``ROVERIMPACT_KERNELS`` (:data:`KERNEL_MODES`; unset: ``auto``).

    Raises
    ------
    ConfigError
        Another value."""
    mode = os.environ.get("ROVERIMPACT_KERNELS", "auto").strip().lower() or "auto"
    if mode not in KERNEL_MODES:
        raise ConfigError(f"ROVERIMPACT_KERNELS={os.environ['ROVERIMPACT_KERNELS']!r} is not "
                          f"one of {', '.join(KERNEL_MODES)}")
    return mode


#: Python stand-ins of compiled functions that have no Python source to run (numba
#: intrinsics): ``{compiled function: Python function}``, filled where they are defined.
PYTHON_EQUIVALENTS: dict = {}

_PYTHON: dict = {}   # compiled function (or its source) -> its Python stand-in
_MODULES: dict = {}  # id(a module's globals) -> the copy its stand-ins run in


def python_version(func):
    """``func`` (a :class:`Kernel`, a numba dispatcher or a plain function) as plain
    Python: its source, run in a copy of its module's globals in which every compiled
    function (dispatcher, :class:`Kernel`, :data:`PYTHON_EQUIVALENTS` entry) is replaced by
    its own Python stand-in, recursively. What ``NUMBA_DISABLE_JIT=1`` would run, for
    this call tree only and without re-importing anything. Cached."""
    try:
        hit = _PYTHON.get(func)
    except TypeError:  # unhashable: not a function
        return func
    if hit is not None:
        return hit
    try:
        if func in PYTHON_EQUIVALENTS:
            return PYTHON_EQUIVALENTS[func]
    except TypeError:  # pragma: no cover - an object whose __eq__ refuses
        return func
    if isinstance(func, (Kernel, Dispatcher)):
        new = python_version(func.py_func)
    elif isinstance(func, pytypes.FunctionType):
        g = _module_copy(func.__globals__)
        closure = func.__closure__
        if closure is not None:
            closure = tuple(pytypes.CellType(_stand_in(c.cell_contents)) for c in closure)
        new = pytypes.FunctionType(func.__code__, g, func.__name__, func.__defaults__,
                                   closure)
        new.__kwdefaults__ = func.__kwdefaults__
        new.__doc__ = func.__doc__
    else:
        return func
    _PYTHON[func] = new
    return new


def _compiled(obj) -> bool:
    if isinstance(obj, (Kernel, Dispatcher)):
        return True
    try:
        return obj in PYTHON_EQUIVALENTS
    except TypeError:
        return False


def _stand_in(obj):
    return python_version(obj) if _compiled(obj) else obj


def _module_copy(g0: dict) -> dict:
    g = _MODULES.get(id(g0))
    if g is None:
        g = _MODULES[id(g0)] = dict(g0)  # registered first: functions that call each other
        for name, value in g0.items():
            if _compiled(value):
                g[name] = python_version(value)
    return g


@contextmanager
def vectorisers(*, slp: int | None = None, loop: int | None = None):
    """numba's ``SLP_VECTORIZE`` / ``LOOP_VECTORIZE`` set (``None``: left as they are)
    while the block compiles; the previous values are restored. numba reads them when it
    optimises a compiled function's LLVM module.

    The settings are numba's global ones: the block holds numba's compiler lock (reentrant;
    every numba compile takes it), so that a compile in another thread neither sees them
    nor is under way while they change."""
    with global_compiler_lock:
        previous = (getattr(numba_config, "SLP_VECTORIZE", 0),
                    getattr(numba_config, "LOOP_VECTORIZE", 1))
        if slp is not None:
            numba_config.SLP_VECTORIZE = slp
        if loop is not None:
            numba_config.LOOP_VECTORIZE = loop
        try:
            yield
        finally:
            numba_config.SLP_VECTORIZE, numba_config.LOOP_VECTORIZE = previous


def shared(**options):
    """Decorator: ``@njit(cache=True, nogil=True, **options)`` for a function several
    kernels call, compiled with LLVM's loop and SLP vectorisers off whatever the settings
    of the kernel that needs it first (:class:`Kernel` ``slp`` / ``loop_vectorize``).

    Without this, its code would depend on which kernel a process (or the first process
    to fill numba's on-disk cache, whose entries do not record these settings) compiled
    first. Off, not on: the loop vectoriser makes the short loops of one item's
    factorisations slower (``benchmarks/bench_single.py``)."""
    def wrap(py_func):
        dispatcher = njit(**{**NJIT_OPTIONS, **options})(py_func)
        compile_ = dispatcher.compile

        def compile(sig):  # what numba calls to compile it for a caller's argument types
            with vectorisers(slp=0, loop=0):
                return compile_(sig)

        dispatcher.compile = compile
        return dispatcher
    return wrap


def kernel(signature, **options):
    """Decorator: ``@kernel(sig, fastmath=...)`` makes a :class:`Kernel`."""
    def wrap(py_func):
        return Kernel(py_func, signature, **options)
    return wrap


#: Longest wait [s] for a background compile before compiling in this process instead.
BACKGROUND_TIMEOUT = 300.0

#: How often [s] a process forked from the one that sent a kernel to the background
#: looks in numba's cache for it (:meth:`Kernel.get`).
CACHE_POLL_S = 0.25

#: The background compile's niceness: on a machine whose cores all compute (``reproduce``'s
#: studies side by side, one per core) it takes what they leave, and runs at full speed
#: once they are done or wait for it.
BACKGROUND_NICE = 10

_BACKGROUND_CODE = (
    "import importlib, os, sys\n"
    f"try:\n    os.nice({BACKGROUND_NICE})\nexcept (AttributeError, OSError):\n    pass\n"
    "for spec in sys.argv[1:]:\n"
    "    module, name = spec.split(':')\n"
    "    getattr(importlib.import_module(module), name).get()\n"
)


def _spare_core() -> bool:
    try:
        return os.getloadavg()[0] < (os.cpu_count() or 1)
    except (AttributeError, OSError):  # pragma: no cover - no load average (Windows)
        return False


class _Job:
    """A background compile of some kernels: a process started at once, or when the
    previous job (``after``) has finished, so that one compiles at a time (a command that
    sends kernels twice keeps to two processes on two cores, its own and one compiling).
    ``poll()`` and ``wait(timeout)`` as a :class:`subprocess.Popen`'s. In a process forked
    from the one that made it (a forked Dask worker), where its thread and process are not
    the child's, it counts as finished: the child loads the kernel or compiles it."""

    def __init__(self, args, env, after=None):
        self._args, self._env = args, env
        self._pid = os.getpid()
        self.proc = None
        self._failed = False
        self._started = threading.Event()
        if after is None:
            self._start()
        else:  # a daemon: a command that ends first leaves the rest to its next run
            threading.Thread(target=self._start, args=(after,), daemon=True).start()

    def _start(self, after=None) -> None:
        if after is not None:
            try:
                after.wait(timeout=BACKGROUND_TIMEOUT)
            except subprocess.TimeoutExpired:  # pragma: no cover - a stalled machine
                pass
        try:
            self.proc = subprocess.Popen(self._args, stdin=subprocess.DEVNULL,
                                         stdout=subprocess.DEVNULL,
                                         stderr=subprocess.DEVNULL, env=self._env)
        except OSError:  # pragma: no cover - cannot start a process: compiled where needed
            self._failed = True
        self._started.set()

    def foreign(self) -> bool:
        """Whether this process is not the one that made the job (forked from it)."""
        return os.getpid() != self._pid

    def poll(self):
        """None while queued or compiling, else the exit code."""
        if self.foreign():
            return 0
        if not self._started.is_set():
            return None
        return 1 if self._failed else self.proc.poll()

    def wait(self, timeout=None):
        if self.foreign():
            return 0
        if not self._started.wait(timeout):
            raise subprocess.TimeoutExpired(self._args, timeout)
        return 1 if self._failed else self.proc.wait(timeout)


_last_job: _Job | None = None

#: The process that imported this module: a process forked from it (a study of
#: ``reproduce`` side by side, a forked Dask worker) starts no background compile
#: (:func:`compile_in_background`).
_IMPORTED_IN = os.getpid()


def compile_in_background(*kernels: Kernel) -> list[Kernel]:
    """Compile ``kernels`` into numba's on-disk cache in a separate process.

    Only kernels not yet built in this process and missing from the cache are sent (a
    warm cache starts nothing), and only when the machine has capacity left (1-minute
    load average below the number of cores): on 2 cores at a load of 1.5-1.7 it took
    ``roverimpact energy`` from 3.9-4.1 s to 3.2-3.5 s, at a load of 4-5 it made it
    slower, the second process only competing with the first. While an earlier call's
    process compiles, the kernels wait for it and follow in a process of their own (the
    load it causes does not count). :meth:`Kernel.get` waits for the process, then loads
    them from the cache. ``ROVERIMPACT_BACKGROUND_COMPILE=0`` compiles everything in the
    calling process, ``=1`` starts the process whatever the load. Returns the kernels
    sent.

    A process forked from the one that imported this module sends nothing: its siblings
    need the same kernels, and each started a compile of its own (``reproduce``'s two
    study processes each compiled the rover's assembly kernel beside the command's
    compile of Lemke's: three compiles on two cores, left running after the command).
    It runs the kernel's Python code, then compiles it, as a process that sends nothing.
    """
    global _last_job
    if os.getpid() != _IMPORTED_IN:
        return []
    mode = os.environ.get("ROVERIMPACT_BACKGROUND_COMPILE", "auto")
    busy = _last_job if _last_job is not None and _last_job.poll() is None else None
    if mode == "0" or (mode != "1" and busy is None and not _spare_core()):
        return []
    todo = [k for k in kernels
            if k._dispatcher is None and k._background is None and not k.cached()]
    if not todo:
        return []
    env = dict(os.environ)  # the same numba cache folder; this package first on the path
    here = str(Path(__file__).resolve().parents[2])
    env["PYTHONPATH"] = os.pathsep.join(p for p in (here, env.get("PYTHONPATH")) if p)
    job = _Job([sys.executable, "-c", _BACKGROUND_CODE, *(k.home for k in todo)], env,
               after=busy)
    if job._failed:  # pragma: no cover - no process started: compiled where needed later
        return []
    _last_job = job
    for k in todo:
        k._background = job
    return todo
