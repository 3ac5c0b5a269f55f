"""Kernels compiled for one explicit signature, on first use (``roverimpact._kernels._jit``).

What matters for start-up: importing a kernel compiles nothing, read-only and writable
inputs share one compiled version (a second one costs seconds on a fresh install), and a
kernel compiled in a background process is loaded from the cache, not compiled again. No
timings here (benchmarks/bench_startup.py measures them).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import roverimpact as ri
from roverimpact._kernels.friction import friction_kernel
from roverimpact._kernels.lemke import impact_kernel
from roverimpact._kernels.partition import partition_kernel
from roverimpact.frictional import frictional_impact

SRC = str(Path(__file__).resolve().parents[1] / "src")


def _readonly(a):
    a = np.array(a, dtype=float)
    a.flags.writeable = False
    return a


def test_readonly_and_writable_inputs_share_one_compiled_kernel():
    rng = np.random.default_rng(3)
    X = rng.standard_normal((4, 4))
    M = X @ X.T + 4 * np.eye(4)
    A = rng.standard_normal((2, 4))
    v = rng.standard_normal(4)
    ref = ri.partition(M, A, v)
    for args in ((_readonly(M), _readonly(A), _readonly(v)),
                 (M, np.broadcast_to(A, (3, 2, 4)), v),            # broadcast (read-only)
                 (np.stack([M] * 3), A, _readonly(np.stack([v] * 3)))):
        p = ri.partition(*args)
        np.testing.assert_array_equal(np.broadcast_to(p.T_c, (3,))[0], ref.T_c)
    assert len(partition_kernel.get().signatures) == 1
    N = _readonly([[0.0, 0.0, 1.0, 0.0]])
    for Mi, Ni in ((M, N), (_readonly(M), np.array(N)), (np.stack([M] * 2), N)):
        ri.active_set(Mi, v * 0 - 1.0, Ni)
    assert len(impact_kernel.get().signatures) == 1
    # the frictional kernel: read-only and writable inputs, broadcast and stacked (as a
    # plain @njit it compiled once per mix, the longest compile of the package's kernels)
    T = _readonly([[[1.0, 0.0, 0.0, 0.0]]])
    for Mi, vi, Ni, Ti in ((M, -v, N, T), (_readonly(M), np.array(-v), np.array(N), T),
                           (np.stack([M] * 2), _readonly(np.stack([-v] * 2)), N,
                            np.broadcast_to(T, (2, 1, 1, 4)))):
        frictional_impact(Mi, vi, Ni, Ti, 0.5)
    assert len(friction_kernel.get().signatures) == 1


def test_kernel_helpers_are_compiled_once(prewarm_helpers):
    """numba compiles a helper once more for each literal argument type: a variable that
    starts as a literal (``r = 0``) and is passed on compiles it for ``Literal[int](0)``
    as well as for ``int64``. Found and removed: five helpers of the frictional kernel
    (the longest compile of the package's kernels), ``partition_factored``
    for the literal ``False`` of ``T_c_at``'s kernel, the height-field contact's
    ``_refine`` for a literal -1. And once more for a writable array where its other
    callers pass a read-only one: ``factor`` and ``partition_factored``, called by the
    one-item, lane, impact, frictional, effective-mass and ``T_c_at`` kernels, have one
    compiled version (``T_c_at``'s and the effective-mass kernel pass their writable arrays
    through ``partition.readonly``). Checked on the helpers this process compiled and on
    those the session's prewarm process compiled (tests/prewarm.py: the same calls); none
    when the kernels came from numba's cache, as after a first run; CI starts from an
    empty one."""
    from .prewarm import compile_helpers, compiled_helpers

    compile_helpers()
    for where, compiled in (("here", compiled_helpers()), ("prewarm", prewarm_helpers)):
        literal = sorted(name for name, sigs in compiled.items() for sig in sigs
                         if "Literal" in sig)
        assert literal == [], where
        shared = {name: len(compiled[name]) for name in ("factor", "partition_factored")
                  if name in compiled}
        assert set(shared.values()) <= {1}, (where, shared)
    if not compiled_helpers() and not prewarm_helpers:
        pytest.skip("the kernels came from numba's cache: no helper compiled here")


def _python(code: str, cache: Path, **env) -> str:
    e = dict(os.environ, NUMBA_CACHE_DIR=str(cache), **env)
    e["PYTHONPATH"] = os.pathsep.join(p for p in (SRC, e.get("PYTHONPATH")) if p)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True, env=e).stdout.strip()


def test_import_compiles_nothing(tmp_path):
    code = ("import roverimpact.scenario, roverimpact.unilateral, roverimpact.models._assemble"
            " as a; from roverimpact._kernels import partition, lemke, lanes_jit; "
            "print([k.compiled for k in (partition.partition_kernel, lemke.impact_kernel, "
            "lanes_jit.LANES, a._evaluate_one, a._evaluate_many)])")
    assert _python(code, tmp_path) == "[False, False, False, False, False]"
    assert not any(tmp_path.rglob("*.nbi"))


def test_background_compile_fills_the_cache_and_is_loaded(tmp_path):
    """On an empty cache the kernel is compiled by another process; the caller's ``get``
    waits for it and loads the result (numba reports a cache hit); a warm cache starts
    nothing. The effective-mass kernel: a Kernel as any other, the quickest to compile
    (2 s of compile against the one-item partition kernel's 7 s)."""
    code = """
import json
from roverimpact._kernels._jit import compile_in_background
from roverimpact._kernels.masses import masses_kernel as k
before = k.cached()
sent = [x.home for x in compile_in_background(k)]
d = k.get()
print(json.dumps([before, sent, k.cached(), sum(d.stats.cache_hits.values()),
                  sum(d.stats.cache_misses.values())]))
"""
    force = {"ROVERIMPACT_BACKGROUND_COMPILE": "1"}  # whatever the machine's load
    before, sent, after, hits, misses = json.loads(_python(code, tmp_path, **force))
    assert (before, sent, after) == (False, ["roverimpact._kernels.masses:masses_kernel"], True)
    assert (hits, misses) == (1, 0)
    before, sent, after, hits, misses = json.loads(_python(code, tmp_path, **force))
    assert (before, sent, after, hits) == (True, [], True, 1)
    # switched off: nothing is sent
    code_off = ("from roverimpact._kernels._jit import compile_in_background as c; "
                "from roverimpact._kernels.lemke import impact_kernel as k; print(c(k))")
    assert _python(code_off, tmp_path, ROVERIMPACT_BACKGROUND_COMPILE="0") == "[]"


# numba caches a kernel beside its source, else in NUMBA_CACHE_DIR, else in the user's cache
# folder; with none writable (a read-only install and an unwritable or unset HOME, as on a
# shared cluster or in a container run as another user) its ``cache=True`` raised
# "cannot cache function ...: no locator available" when a kernel module was imported. The
# tests run as root, who can write anywhere: this stands in for the file permissions,
# refusing every cache folder but the one of ``config.CACHE_DIR`` when ``allow_set``.
_NO_CACHE_FOLDER = """
import errno, json, os, warnings
from numba.core import caching, config
_ensure = caching._CacheLocator.ensure_cache_path
def ensure(self, allow_set={allow_set}):
    path = self.get_cache_path()
    if not (allow_set and config.CACHE_DIR and path.startswith(config.CACHE_DIR)):
        raise OSError(errno.EACCES, "Permission denied", path)
    _ensure(self)
caching._CacheLocator.ensure_cache_path = ensure
import numpy as np
with warnings.catch_warnings(record=True) as seen:
    warnings.simplefilter("always")
    from roverimpact._kernels.partition import factor
M = np.array([[4.0, 2.0], [2.0, 3.0]])
L, invd = np.zeros((2, 2)), np.zeros(2)
status = factor(M, L, invd)
folder = os.environ.get("NUMBA_CACHE_DIR")
print(json.dumps([status, L.tolist(), [str(w.message) for w in seen], folder,
                  bool(folder) and any(n.endswith(".nbi") for _, _, f in os.walk(folder)
                                       for n in f)]))
"""


@pytest.mark.parametrize("allow_set", [True, False])
def test_kernels_run_when_no_cache_folder_is_writable(allow_set):
    """No writable cache folder: the kernels are cached for this run in a temporary folder
    (removed at exit; the background compile and Dask workers share it), or, when not even
    that can be written, not cached; a warning says how to keep them (NUMBA_CACHE_DIR)."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = os.pathsep.join(p for p in (SRC, env.get("PYTHONPATH")) if p)
    run = subprocess.run([sys.executable, "-c", _NO_CACHE_FOLDER.format(allow_set=allow_set)],
                         capture_output=True, text=True, env=env)
    assert run.returncode == 0, run.stderr
    status, L, warned, folder, cached = json.loads(run.stdout)
    assert status == 0
    np.testing.assert_allclose(L, np.linalg.cholesky([[4.0, 2.0], [2.0, 3.0]]), rtol=1e-15)
    assert len(warned) == 1 and "NUMBA_CACHE_DIR" in warned[0], warned
    if allow_set:
        assert cached and folder in warned[0]
        assert not Path(folder).exists()  # removed at exit
    else:
        assert folder is None and not cached


def test_build_settings_are_scoped_to_the_kernel(monkeypatch):
    """``slp`` / ``loop_vectorize`` hold only while this kernel compiles (the lane kernel:
    SLP on, loop vectoriser off; the one-item kernel: loop vectoriser off)."""
    from numba import types
    from numba.core import config as numba_config

    from roverimpact._kernels import _jit
    from roverimpact._kernels.lanes_jit import LANES

    seen = []

    def fake_njit(signature, **options):
        seen.append((numba_config.SLP_VECTORIZE, numba_config.LOOP_VECTORIZE))
        return lambda f: f

    monkeypatch.setattr(_jit, "njit", fake_njit)
    before = (numba_config.SLP_VECTORIZE, numba_config.LOOP_VECTORIZE)
    sig = types.void()
    plain = _jit.Kernel(lambda: None, sig)
    lanes_like = _jit.Kernel(lambda: None, sig, slp=True, loop_vectorize=False)
    plain.get()
    lanes_like.get()
    assert seen == [before, (1, 0)]
    assert (numba_config.SLP_VECTORIZE, numba_config.LOOP_VECTORIZE) == before
    assert plain.compiled and lanes_like.compiled
    # the real kernels are declared that way
    assert LANES._slp and not LANES._loop_vectorize
    assert not partition_kernel._slp and not partition_kernel._loop_vectorize


def test_vectoriser_settings_are_invisible_to_compiles_in_other_threads():
    """numba's vectoriser settings are global: while :func:`._jit.vectorisers` has them
    changed, a compile in another thread (which takes numba's compiler lock) waits, and
    then sees the settings as they were. The other thread here only takes the lock and
    reads the settings; without the lock it would read them changed."""
    import threading
    import time

    from numba.core import config as numba_config
    from numba.core.compiler_lock import global_compiler_lock

    from roverimpact._kernels._jit import vectorisers

    before = (numba_config.SLP_VECTORIZE, numba_config.LOOP_VECTORIZE)
    started, seen = threading.Event(), []

    def other_compile():
        started.set()
        with global_compiler_lock:
            seen.append((numba_config.SLP_VECTORIZE, numba_config.LOOP_VECTORIZE))

    with vectorisers(slp=1 - before[0], loop=1 - before[1]):
        with vectorisers(loop=before[1]):  # nested (a shared function inside a kernel)
            assert numba_config.LOOP_VECTORIZE == before[1]
        thread = threading.Thread(target=other_compile)
        thread.start()
        assert started.wait(10)
        time.sleep(0.2)  # time for the thread to get the lock, were it free
        assert seen == []
        assert (numba_config.SLP_VECTORIZE, numba_config.LOOP_VECTORIZE) != before
    thread.join(10)
    assert seen == [before]


_SHARED_CODE = """
import json, re, warnings
import numpy as np
from numba import njit
from roverimpact._kernels import partition as part
from roverimpact._kernels._jit import vectorisers
warnings.simplefilter("error")  # numba warns when asked for the code of a cached function
M = 2.0 * np.eye(5)
L, invd = np.zeros((5, 5)), np.empty(5)

@njit
def caller(M, L, invd):
    return part.factor(M, L, invd)

with vectorisers(slp=1, loop=1):
    codes = [int(caller(M, L, invd))]
    control = njit(fastmath=part.FASTMATH)(part.factor.py_func)
    codes.append(int(control(M, L, invd)))
vector = re.compile(r"<[0-9]+ x double>")
irs = ["".join(f.inspect_llvm().values()) for f in (part.factor, control)]
print(json.dumps([codes, [len(vector.findall(ir)) for ir in irs], [len(ir) for ir in irs],
                  float(L[4, 4]), ["compile" in vars(f)
                                   for f in (part.factor, part.partition_factored)]]))
"""


def test_shared_functions_get_the_same_code_whichever_kernel_compiles_them_first(tmp_path):
    """``factor`` and ``partition_factored`` are called by the one-item, lane, impact and
    ``T_c_at`` kernels, whose vectoriser settings differ, and numba's on-disk cache does not
    record those settings: :func:`._jit.shared` compiles them with both vectorisers off
    even when the kernel that needs them first has them on. Run in a new process with an
    empty cache (numba cannot show the code of a function it loaded from the cache). The
    control, the same Python function compiled as a plain ``@njit`` under the same
    settings, does get vector code (so the check can fail)."""
    codes, vectors, sizes, l44, wrapped = json.loads(_python(_SHARED_CODE, tmp_path))
    assert codes == [0, 0] and l44 == pytest.approx(np.sqrt(2.0))
    assert min(sizes) > 10_000  # the real code, not numba's placeholder for cached code
    assert vectors[0] == 0 and vectors[1] > 0
    assert wrapped == [True, True]  # the wrapped compile of _jit.shared


def test_every_kernel_can_be_found_from_its_home():
    """:func:`compile_in_background` imports ``Kernel.home`` in another process and calls
    ``.get()`` on it: every kernel's home must name the kernel object itself (not its
    Python function, which has no ``get``)."""
    import importlib
    import pkgutil

    import roverimpact
    from roverimpact._kernels._jit import Kernel

    found = []
    for info in pkgutil.walk_packages(roverimpact.__path__, "roverimpact."):
        if ".cli" in info.name or info.name.endswith("__main__"):
            continue
        mod = importlib.import_module(info.name)
        for name, obj in vars(mod).items():
            if isinstance(obj, Kernel) and obj.py_func.__module__ == mod.__name__:
                module, attr = obj.home.split(":")
                assert getattr(importlib.import_module(module), attr) is obj, (name, obj.home)
                found.append(obj.home)
    assert {"roverimpact._kernels.partition:partition_kernel",
            "roverimpact._kernels.lemke:impact_kernel",
            "roverimpact._kernels.reduced:rk4_peaks",
            "roverimpact._kernels.reduced:stiff_peaks",
            "roverimpact.models._assemble:_evaluate_one"} <= set(found)



def test_a_first_compile_says_what_it_compiles_and_a_cached_one_does_not(monkeypatch):
    """``roverimpact._kernels.compile_notice`` wraps a compile that numba's cache cannot
    serve (a first run can compile for half a minute); the command line's shows the
    kernel's name on a terminal and nothing in a pipe or a log."""
    import io

    from numba import types
    from rich.console import Console

    from roverimpact import _kernels
    from roverimpact._kernels import _jit
    from roverimpact.cli._app import compile_notice

    events = []

    class Notice:
        def __init__(self, kernel):
            self.kernel = kernel

        def __enter__(self):
            events.append(("enter", self.kernel.__name__, self.kernel.compiled))

        def __exit__(self, *exc):
            events.append(("exit", self.kernel.__name__, self.kernel.compiled))

    monkeypatch.setattr(_jit, "njit", lambda signature, **options: lambda f: f)
    monkeypatch.setattr(_kernels, "compile_notice", Notice)

    def fresh():
        pass

    def warm():
        pass

    for f, cached in ((fresh, False), (warm, True)):
        k = _jit.Kernel(f, types.void())
        monkeypatch.setattr(k, "cached", lambda cached=cached: cached)
        k.get()
        k.get()  # built once: no second notice
    assert events == [("enter", "fresh", False), ("exit", "fresh", True)]

    kernel = _jit.Kernel(fresh, types.void())
    tty = Console(file=io.StringIO(), force_terminal=True, width=200)
    with compile_notice(kernel, tty):
        pass
    assert "compiling fresh, first run on this machine only" in tty.file.getvalue()
    pipe = Console(file=io.StringIO(), force_terminal=False)
    with compile_notice(kernel, pipe):
        pass
    assert pipe.file.getvalue() == ""
    other = Console(file=io.StringIO(), force_terminal=True)  # a forked worker's terminal
    with compile_notice(kernel, other, pid=os.getpid() + 1):
        pass
    assert other.file.getvalue() == ""
