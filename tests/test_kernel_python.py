"""The kernels' Python code against the compiled kernels, and when it runs.

On a fresh install a kernel's compile costs seconds; until numba's cache holds it, small
work runs the kernel's own Python source with every compiled function it calls replaced
by its Python source (``roverimpact._kernels._jit.python_version``). The same public
functions must then give the compiled kernels' results (to rounding: LLVM contracts and
reorders floating-point operations) and the same errors. The reference here is the
compiled kernel; the kernels themselves are checked against closed forms, scipy and
MuJoCo elsewhere.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from numba import types

import roverimpact as ri
from roverimpact._kernels import _jit
from roverimpact.exceptions import ConfigError, InputError


def all_kernels():
    from roverimpact.models import _assemble

    from .prewarm import kernels

    return (*kernels(), _assemble._evaluate_one, _assemble._evaluate_many,
            _assemble._partition_at)


def both(monkeypatch, f):
    """``f()`` with the kernels' Python code, then compiled. The kernels this session has
    compiled are set aside for the first run (``=python`` runs the Python code of those
    not compiled in the process), and none may be compiled by it: every call went through
    the Python code."""
    for k in all_kernels():
        monkeypatch.setattr(k, "_dispatcher", None)
    monkeypatch.setenv("ROVERIMPACT_KERNELS", "python")
    py = f()
    assert [k.__name__ for k in all_kernels() if k.compiled] == []
    monkeypatch.setenv("ROVERIMPACT_KERNELS", "compiled")
    return py, f()


def close(a, b, rtol=1e-10):
    a, b = np.asarray(a, float), np.asarray(b, float)
    scale = max(1.0, float(np.max(np.abs(b), initial=0.0)))
    np.testing.assert_allclose(a, b, rtol=0, atol=rtol * scale)


def spd(rng, B, n):
    X = rng.standard_normal((B, n, n))
    return X @ X.transpose(0, 2, 1) + n * np.eye(n)


@pytest.mark.parametrize("B", [None, 5, 70])  # one system, the item kernel, the lanes
def test_partition(monkeypatch, rng, B):
    n, m = 9, 4
    M = spd(rng, B or 1, n)
    A = rng.standard_normal((B or 1, m, n))
    A[0, 3] = A[0, 0] + A[0, 1]  # a dependent row: the rank decision
    v = rng.standard_normal((B or 1, n))
    if B is None:
        M, A, v = M[0], A[0], v[0]
    py, co = both(monkeypatch, lambda: ri.partition(M, A, v))
    for f in ("T", "T_c", "T_a", "v_c", "v_a"):
        close(getattr(py, f), getattr(co, f))
    np.testing.assert_array_equal(py.rank, co.rank)


@pytest.mark.parametrize("B", [1, 70])
def test_partition_errors_are_the_compiled_ones(monkeypatch, rng, B):
    M = spd(rng, B, 5)
    M[-1, 2, 2] = -1.0  # not positive definite
    A = rng.standard_normal((2, 5))
    v = rng.standard_normal(5)
    msgs = []
    for kind in ("python", "compiled"):
        monkeypatch.setenv("ROVERIMPACT_KERNELS", kind)
        with pytest.raises(InputError) as err:
            ri.partition(M if B > 1 else M[0], A, v)
        msgs.append(str(err.value))
    assert msgs[0] == msgs[1]


def test_effective_masses(monkeypatch, rng):
    n = 7
    M = spd(rng, 70, n)
    a = rng.standard_normal((70, n))
    held = rng.standard_normal((2, n))
    py, co = both(monkeypatch, lambda: ri.effective_mass(M, a[:, None, :], held=held))
    close(py, co)


@pytest.mark.parametrize("law", ["newton", "poisson"])
def test_unilateral_impact(monkeypatch, rng, law):
    n, k = 8, 4
    M = spd(rng, 12, n)
    N = rng.standard_normal((12, k, n))
    v = rng.standard_normal((12, n))
    e = 0.4  # one e: no energy gain with Newton's law
    B = rng.standard_normal((1, n))
    py, co = both(monkeypatch, lambda: ri.unilateral_impact(M, v, N, e, B, law=law))
    for f in ("impulse", "v_plus", "T_minus", "T_plus", "T_c_minus"):
        close(getattr(py, f), getattr(co, f))
    np.testing.assert_array_equal(py.active, co.active)


def test_frictional_impact(monkeypatch, rng):
    n = 6
    M = spd(rng, 6, n)
    normal = rng.standard_normal((6, 2, n))
    tangent = rng.standard_normal((6, 2, 2, n))
    v = rng.standard_normal((6, n))
    from roverimpact.frictional import frictional_impact

    py, co = both(monkeypatch,
                  lambda: frictional_impact(M, v, normal, tangent, [0.3, 0.8], 0.0))
    for f in ("impulse", "impulse_tangent", "v_plus", "T_minus", "T_plus"):
        close(getattr(py, f), getattr(co, f), rtol=1e-8)
    np.testing.assert_array_equal(py.state, co.state)


def test_row_assembly_of_a_scenario(monkeypatch):
    from roverimpact.scenario import ImpactSetup, load_scenario
    from roverimpact.scenario.sweep import sweep_energy

    sc = load_scenario("examples/rover2d_beta45.toml")
    setup = ImpactSetup.from_scenario(sc)
    betas = np.radians(np.linspace(5.0, 85.0, 70))  # the batched row assembly, the lanes
    (p1, pm), (c1, cm) = both(monkeypatch,
                              lambda: (setup.partition(), sweep_energy(setup, betas)))
    for f in ("T", "T_c_minus", "T_a", "m_eff", "m_eff_free"):
        close(getattr(p1, f), getattr(c1, f))
        close(getattr(pm, f), getattr(cm, f))


def test_bootstrap_of_agreement(monkeypatch, rng):
    """The bootstrap kernel of studies above 400 cases (ties included), in Python and
    compiled: Spearman, Kendall, Pearson and the concordant fraction of every resample,
    and a Spearman difference."""
    from roverimpact.studies import stats

    x = np.round(rng.standard_normal(420), 1)
    y = np.round(x + rng.standard_normal(420), 1)
    (b_py, d_py), (b_c, d_c) = both(monkeypatch, lambda: (
        stats._boot_stats(x, y, np.random.default_rng(2), 6),
        stats.spearman_difference(x, -y, y, n_boot=100, seed=2)))
    close(b_py, b_c, rtol=1e-13)
    close([d_py.value, d_py.low, d_py.high], [d_c.value, d_c.low, d_c.high], rtol=1e-13)


@pytest.mark.parametrize("integrator", ["rk4", "rosenbrock"])
def test_reduced_impact_integrators(monkeypatch, integrator):
    from roverimpact.contact.reduced import reduced_impact_batch

    G = np.array([[[2.0, 0.5], [0.5, 1.0]]] * 2)
    b = np.array([[0.0, -9.81], [0.0, -3.0]])
    L = np.array([[1e6, 1.5, 0.2, 0.0, 0.0], [1e5, 1.0, 0.0, 50.0, 0.0]])
    L = np.broadcast_to(L, (2, 2, 5))
    rate0 = np.array([[0.3, 0.0], [0.5, 0.0]])
    py, co = both(monkeypatch, lambda: reduced_impact_batch(
        G, b, L, rate0, t_max=0.05, impact=0, integrator=integrator))
    close(py.peak_force, co.peak_force)
    close(py.time_of_peak, co.time_of_peak)


# --- when the Python code runs -----------------------------------------------------------


def _twice(x, out):  # pragma: no cover - the kernel's source
    out[0] = 2.0 * x


@pytest.fixture
def cold_kernel(monkeypatch):
    """A kernel missing from numba's cache, a background compile recorded, not run."""
    k = _jit.Kernel(_twice, types.void(types.float64, _jit.rw(_jit.f8, 1)), cache=False)
    monkeypatch.setattr(k, "cached", lambda: False)
    sent = []
    monkeypatch.setattr(_jit, "compile_in_background", lambda *ks: sent.extend(ks) or [])
    monkeypatch.setenv("ROVERIMPACT_KERNELS", "auto")
    monkeypatch.delenv("ROVERIMPACT_BACKGROUND_COMPILE", raising=False)
    return k, sent


def test_small_work_runs_python_until_the_budget_then_compiles(cold_kernel, monkeypatch):
    k, sent = cold_kernel
    monkeypatch.setattr(_jit, "PYTHON_ITEMS", 10)
    out = np.zeros(1)
    f = k.get(4)
    f(1.5, out)
    assert out[0] == 3.0 and not k.compiled and k.python_items == 4
    assert sent == [k]  # its compile sent to the background
    k.get(6)(2.0, out)
    assert not k.compiled and k.python_items == 10
    k.get(1)(2.5, out)  # past the budget: compiled here
    assert k.compiled and out[0] == 5.0
    assert k.get(1) is k.get()  # from then on, the compiled kernel


def test_a_finished_background_compile_is_loaded(cold_kernel):
    k, _ = cold_kernel

    class Done:
        def foreign(self):
            return False

        def poll(self):
            return 0

        def wait(self, timeout=None):
            return 0

    k._background = Done()
    k.get(1)
    assert k.compiled


def test_a_forked_process_runs_python_until_its_parent_s_compile_is_written(cold_kernel,
                                                                             monkeypatch):
    """In a process forked from the one that sent the kernel to the background (a study
    of ``reproduce`` side by side, a forked Dask worker), the job's process is not its
    own to poll: it ran the Python code only while it could not tell, and compiled the
    kernel itself (10-30 s on a core the studies need) as soon as it asked. It now runs
    the Python code until numba's cache holds the kernel, then loads it."""
    import os

    k, sent = cold_kernel
    job = _jit._Job(["true"], dict(os.environ))
    job.wait(timeout=10)
    k._background = job
    cache = {"written": False}
    monkeypatch.setattr(k, "cached", lambda: cache["written"])
    monkeypatch.setattr(_jit, "CACHE_POLL_S", 0.0)
    with monkeypatch.context() as m:
        m.setattr(_jit.os, "getpid", lambda: -1)  # as seen from a forked child
        assert job.foreign() and job.poll() == 0  # "finished", for all it can tell
        assert k.get(3) is k.python() and not k.compiled
        assert k.get(3) is k.python() and k.python_items == 6
        cache["written"] = True
        f = k.get(3)
        assert k.compiled and f is k.get()
    assert sent == []  # nothing else sent


def test_a_forked_process_reads_the_cache_at_most_every_poll_interval(cold_kernel,
                                                                      monkeypatch):
    import os

    k, _ = cold_kernel
    job = _jit._Job(["true"], dict(os.environ))
    job.wait(timeout=10)
    k._background = job
    reads = []
    monkeypatch.setattr(k, "cached", lambda: reads.append(1) or False)
    monkeypatch.setattr(_jit.os, "getpid", lambda: -1)
    for _ in range(20):
        assert k.get(1) is k.python()
    assert len(reads) == 1  # 20 calls within CACHE_POLL_S: the cache read once


def test_no_python_when_cached_asked_compiled_or_large(cold_kernel, monkeypatch):
    k, sent = cold_kernel
    assert k.get(10 ** 6) is not k.python()
    assert k.compiled and sent == []
    k2 = _jit.Kernel(_twice, k.signature, cache=False)
    monkeypatch.setattr(k2, "cached", lambda: True)
    k2.get(1)
    assert k2.compiled
    k3 = _jit.Kernel(_twice, k.signature, cache=False)
    monkeypatch.setattr(k3, "cached", lambda: False)
    monkeypatch.setenv("ROVERIMPACT_BACKGROUND_COMPILE", "0")
    k3.get(1)
    assert k3.compiled and sent == []


@pytest.fixture
def warm_kernel(monkeypatch):
    """A kernel in numba's cache, in a process where numba has not set up its compiler
    (no compiled kernel loaded yet); nothing may go to the background."""
    from roverimpact import _kernels

    k = _jit.Kernel(_twice, types.void(types.float64, _jit.rw(_jit.f8, 1)), cache=False)
    monkeypatch.setattr(k, "cached", lambda: True)
    monkeypatch.setattr(_jit, "numba_set_up", lambda: False)
    monkeypatch.setattr(_kernels, "small_work", False)
    monkeypatch.setattr(_jit, "PYTHON_ITEMS", 50)

    def nothing_sent(*ks):
        raise AssertionError(f"{[x.__name__ for x in ks]} sent to the background")

    monkeypatch.setattr(_jit, "compile_in_background", nothing_sent)
    monkeypatch.setenv("ROVERIMPACT_KERNELS", "auto")
    return k


def test_a_cached_kernel_loads_at_once_unless_the_work_is_declared_small(warm_kernel):
    """A library call (no declared small work) loads the cached kernel on its first call,
    as before: its results are the compiled kernel's from the first call on."""
    warm_kernel.get(1)
    assert warm_kernel.compiled and warm_kernel.python_items == 0


def test_small_work_runs_a_cached_kernel_s_python_until_its_warm_budget(warm_kernel,
                                                                        monkeypatch):
    """A small command (``energy``) would load its cached kernels only to set up numba's
    compiler (about 0.25 s) for items of a millisecond: it runs their Python code for
    ``PYTHON_ITEMS // WARM_SHARE`` items (5 here), then loads them."""
    _jit.declare_small_work()
    k = warm_kernel
    out = np.zeros(1)
    k.get(3)(1.5, out)
    assert out[0] == 3.0 and not k.compiled and k.python_items == 3
    assert k.get(2) is k.python() and k.python_items == 5
    k.get(1)(2.5, out)  # past 50 // 10 items: loaded
    assert k.compiled and out[0] == 5.0 and k.get(1) is k.get()


def test_small_work_loads_a_cached_kernel_once_numba_is_set_up(warm_kernel, monkeypatch):
    """Once one kernel has been loaded (numba's compiler set up), another loads in
    milliseconds: no Python code for it."""
    _jit.declare_small_work()
    monkeypatch.setattr(_jit, "numba_set_up", lambda: True)
    warm_kernel.get(1)
    assert warm_kernel.compiled and warm_kernel.python_items == 0


def test_small_work_loads_a_cached_integrator_at_once(warm_kernel):
    """No Python budget (the integrators): loaded at once, small work or not."""
    _jit.declare_small_work()
    warm_kernel.python_budget = 0
    warm_kernel.get(1)
    assert warm_kernel.compiled and warm_kernel.python_items == 0


def test_a_command_s_small_work_ends_with_the_command(monkeypatch):
    """``compile_ahead(small=True)`` declares small work for the command that calls it
    only: the command wrapper restores the flag (commands run in one process, as here, do
    not inherit it), and Dask workers forked for the work (``workers``) never have it."""
    from typer.testing import CliRunner

    from roverimpact import _kernels
    from roverimpact.cli import app
    from roverimpact.cli._app import compile_ahead

    monkeypatch.setattr(_kernels, "small_work", False)
    monkeypatch.setattr(_jit, "compile_in_background", lambda *ks: [])
    compile_ahead(small=True, workers=True)
    assert not _kernels.small_work
    seen = []
    monkeypatch.setattr(_jit, "declare_small_work",
                        lambda: seen.append(1) or setattr(_kernels, "small_work", True))
    res = CliRunner().invoke(app, ["energy", "examples/rover2d_beta45.toml", "--json"])
    assert res.exit_code == 0, res.output
    assert seen == [1] and not _kernels.small_work


_WARM_ENERGY = """
import json, sys
from roverimpact._kernels import _jit
from roverimpact._kernels.partition import partition_kernel
from roverimpact.models._assemble import _evaluate_one
assert partition_kernel.cached() and _evaluate_one.cached(), "the cache is not warm"
assert not _jit.numba_set_up()
from roverimpact.cli import main
sys.argv = ["roverimpact", "energy", "examples/rover2d_beta45.toml", "--json"]
code = main()
print(json.dumps([code, _jit.numba_set_up(), partition_kernel.compiled,
                  _evaluate_one.compiled]))
partition_kernel.get()
print(json.dumps(_jit.numba_set_up()))
"""


def test_a_warm_energy_command_loads_no_compiled_kernel():
    """``roverimpact energy`` in a fresh process with its kernels in numba's cache: no
    compiled kernel is loaded (numba's compiler never set up: a warm ``energy`` took
    0.82 s, 0.57 s without it, ``benchmarks/bench_startup.py``, 2026-11-30), its numbers
    are the compiled kernels' to rounding, and :func:`_jit.numba_set_up` does tell a
    process that has loaded one."""
    import os
    import subprocess
    import sys

    from typer.testing import CliRunner

    from roverimpact._kernels.partition import partition_kernel
    from roverimpact.cli import app
    from roverimpact.models._assemble import _evaluate_one

    partition_kernel.get(), _evaluate_one.get()  # both in numba's cache (compiled here)
    ref = json.loads(CliRunner().invoke(
        app, ["energy", "examples/rover2d_beta45.toml", "--json"]).stdout)
    env = {**os.environ, "ROVERIMPACT_KERNELS": "auto", "ROVERIMPACT_BACKGROUND_COMPILE": "0"}
    res = subprocess.run([sys.executable, "-c", _WARM_ENERGY], capture_output=True, text=True,
                         env=env, timeout=120)
    assert res.returncode == 0, res.stderr
    lines = res.stdout.strip().splitlines()
    assert json.loads(lines[-2]) == [0, False, False, False]
    assert json.loads(lines[-1]) is True  # loading a kernel sets numba up
    got = json.loads("\n".join(lines[:-2]))
    for key in ("T", "T_c_minus", "T_a", "m_eff", "peak_force"):
        assert got[key] == pytest.approx(ref[key], rel=1e-12)


def test_an_unknown_kernel_mode_is_refused(monkeypatch):
    monkeypatch.setenv("ROVERIMPACT_KERNELS", "jit")
    with pytest.raises(ConfigError, match="ROVERIMPACT_KERNELS='jit' is not one of auto"):
        _jit.kernel_mode()


def test_energy_on_a_fresh_install_compiles_nothing_here(monkeypatch):
    """``roverimpact energy`` with every kernel missing from numba's cache: no compile in
    the command's process (the Python code runs; the compiles go to the background,
    recorded here), and the numbers of the compiled kernels."""
    from typer.testing import CliRunner

    from roverimpact._kernels.partition import partition_kernel
    from roverimpact.cli import app
    from roverimpact.models import _assemble

    runner = CliRunner()
    args = ["energy", "examples/rover2d_beta45.toml", "--json"]
    monkeypatch.setenv("ROVERIMPACT_KERNELS", "compiled")
    ref = json.loads(runner.invoke(app, args).stdout)

    kernels = [partition_kernel, _assemble._evaluate_one]
    sent = []
    monkeypatch.setattr(_jit, "compile_in_background", lambda *ks: sent.extend(ks) or [])
    monkeypatch.setattr(_jit.Kernel, "cached", lambda self: False)

    def no_compile(self):
        raise AssertionError(f"{self.__name__} compiled in the command's process")

    monkeypatch.setattr(_jit.Kernel, "_build", no_compile)
    for k in kernels:
        monkeypatch.setattr(k, "_dispatcher", None)
        monkeypatch.setattr(k, "python_items", 0)
    monkeypatch.setenv("ROVERIMPACT_KERNELS", "auto")
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    got = json.loads(res.stdout)
    assert set(kernels) <= set(sent)
    for key in ("T", "T_c_minus", "T_a", "m_eff", "peak_force"):
        assert got[key] == pytest.approx(ref[key], rel=1e-12)


@pytest.mark.parametrize("small, workers, mode, sent, got", [
    (True, False, "auto", ["impact_kernel", "partition_kernel"], []),
    (False, False, "auto", ["impact_kernel"], ["partition_kernel"]),  # large work
    (True, True, "auto", ["impact_kernel"], ["partition_kernel"]),  # forked workers
    (True, False, "compiled", ["impact_kernel"], ["partition_kernel"]),
])
def test_compile_ahead_sends_small_work_s_kernels_away(monkeypatch, compile_plan, small,
                                                       workers, mode, sent, got):
    """Small work runs the Python code while every kernel compiles in the second process;
    large work, forked Dask workers and ``ROVERIMPACT_KERNELS=compiled`` have the kernels
    of ``now`` compiled here first, as before."""
    from roverimpact._kernels.lemke import impact_kernel
    from roverimpact._kernels.partition import partition_kernel
    from roverimpact.cli._app import compile_ahead

    monkeypatch.setenv("ROVERIMPACT_KERNELS", mode)
    compile_ahead(impact_kernel, now=(partition_kernel,), small=small, workers=workers)
    assert compile_plan.sent == sent
    assert compile_plan.got == got


def test_compile_ahead_compiles_kernels_costly_in_python_here(monkeypatch, compile_plan):
    """The Runge-Kutta kernel (tens of milliseconds an item in Python) is compiled here
    even for small work; the partition goes to the second process."""
    from roverimpact._kernels.partition import partition_kernel
    from roverimpact._kernels.reduced import rk4_peaks
    from roverimpact.cli._app import compile_ahead

    monkeypatch.setenv("ROVERIMPACT_KERNELS", "auto")
    compile_ahead(now=(partition_kernel, rk4_peaks), small=True)
    assert (compile_plan.sent, compile_plan.got) == (["partition_kernel"], ["rk4_peaks"])


def test_a_forked_process_does_not_wait_for_its_parent_s_queued_compile(monkeypatch):
    """A background compile queued behind another one (a thread of the parent waits to
    start it) counts as finished in a forked child, which has neither that thread nor the
    process: its kernels load or compile there instead of waiting for a start that never
    comes (5 minutes, BACKGROUND_TIMEOUT)."""
    import os
    import threading

    done = threading.Event()

    class Running:  # a previous job, still compiling during the test
        def wait(self, timeout=None):
            done.wait(timeout)

        def poll(self):
            return None

    job = _jit._Job(["true"], dict(os.environ), after=Running())
    try:
        assert job.poll() is None  # queued here
        with monkeypatch.context() as m:
            m.setattr(_jit.os, "getpid", lambda: -1)  # as seen from a forked child
            assert job.poll() == 0 and job.wait(timeout=0.1) == 0
    finally:
        done.set()  # the queued job starts (and ends: `true`)
    assert job.wait(timeout=10) == 0


@pytest.mark.parametrize(("integrator", "bad"), [
    *((i, bad) for i in ("rk4", "rosenbrock") for bad in (
        {"t_max": 0.0}, {"t_max": np.nan}, {"t_max": np.inf}, {"k": np.nan}, {"k": -1.0},
        {"k": np.inf}, {"n": 0.0}, {"rate0": np.inf})),
    ("rk4", {"t_max": 1e300})])  # more fixed steps than an int64 counts
def test_reduced_integrators_refuse_what_they_cannot_step_alike(monkeypatch, integrator,
                                                                 bad):
    """A NaN, infinite or zero step count: the compiled Runge-Kutta kernel raised
    ZeroDivisionError or returned a wrong result (``int`` of NaN, inf or past 2**63 wraps:
    no step taken, a zero peak over the whole window), its Python code ValueError or
    OverflowError, or ran for hours. Both now refuse the inputs with one InputError."""
    from roverimpact.contact.reduced import reduced_impact_batch

    G = np.array([[[2.0, 0.5], [0.5, 1.0]]])
    b = np.array([[0.0, -9.81]])
    L = np.array([[[1e6, 1.5, 0.2, 0.0, 0.0], [1e5, 1.0, 0.0, 50.0, 0.0]]])
    rate0 = np.array([[0.3, 0.0]])
    t_max = bad.get("t_max", 0.05)
    if "k" in bad:
        L[0, 0, 0] = bad["k"]
    if "n" in bad:
        L[0, 1, 1] = bad["n"]
    if "rate0" in bad:
        rate0[0, 0] = bad["rate0"]
    msgs = []
    for kind in ("python", "compiled"):
        monkeypatch.setenv("ROVERIMPACT_KERNELS", kind)
        with pytest.raises(InputError) as err:
            reduced_impact_batch(G, b, L, rate0, t_max=t_max, impact=0,
                                 integrator=integrator)
        msgs.append(str(err.value))
    assert msgs[0] == msgs[1]


def test_a_kernel_without_a_python_budget_always_compiles(cold_kernel):
    """The contact-space integrators (``python_budget = 0``): an item runs hundreds to
    thousands of steps, too slow in Python even while the kernel compiles elsewhere."""
    from roverimpact._kernels.reduced import rk4_peaks, stiff_peaks

    k, sent = cold_kernel
    k.python_budget = rk4_peaks.python_budget
    assert stiff_peaks.python_budget == rk4_peaks.python_budget == 0
    k.get(1)
    assert k.compiled and k.python_items == 0 and sent == []


def test_a_forked_process_starts_no_background_compile(monkeypatch):
    """``reproduce``'s two study processes each started a background compile of the same
    kernel (the rover's assembly), beside the command's own: three compiles on two
    cores, left running after the command. A forked process now sends nothing."""
    k = _jit.Kernel(_twice, types.void(types.float64, _jit.rw(_jit.f8, 1)), cache=False)
    monkeypatch.setattr(k, "cached", lambda: False)
    monkeypatch.setenv("ROVERIMPACT_BACKGROUND_COMPILE", "1")
    monkeypatch.setenv("ROVERIMPACT_KERNELS", "auto")
    started = []
    monkeypatch.setattr(_jit, "_Job", lambda *a, **kw: started.append(a) or _NoJob())
    monkeypatch.setattr(_jit, "_last_job", None)
    with monkeypatch.context() as m:
        m.setattr(_jit.os, "getpid", lambda: -1)  # as seen from a forked child
        assert _jit.compile_in_background(k) == [] and started == []
        out = np.zeros(1)
        k.get(1)(2.0, out)  # the Python code, as while a compile is under way
        assert out[0] == 4.0 and not k.compiled and started == []
    assert _jit.compile_in_background(k) == [k] and len(started) == 1  # here: sent


class _NoJob:
    _failed = False

    def foreign(self):
        return False

    def poll(self):
        return None
