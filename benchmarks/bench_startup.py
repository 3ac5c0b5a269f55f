"""Start-up of the command line: what every command pays before it works, warm and cold.

Times whole processes and prints each against bare Python measured in the same run
(``python -c pass``; the ratio column), so that the figures survive a loaded machine:

- warm (numba's cache filled by a first run): ``roverimpact --version`` and ``--help``
  (issue target: within 0.3 s of bare Python), ``roverimpact energy
  examples/rover2d_beta45.toml`` (target: under 1 s; also with its kernels loaded from
  the cache, ``ROVERIMPACT_KERNELS=compiled``, the behaviour before 2026-11-30, whose
  first load sets up numba's compiler: see
  ``roverimpact._kernels._jit.declare_small_work``), ``roverimpact reproduce --quick``;
- cold (``NUMBA_CACHE_DIR`` an empty folder, as on a fresh install, which compiles every
  kernel the command uses): ``energy`` (target: under 3 s; also with the background
  compile of the partition kernel forced and switched off, see
  ``roverimpact._kernels._jit.compile_in_background``) and ``reproduce --quick``;
  ``--full`` adds the full ``roverimpact reproduce`` cold and warm (target: under 20 s
  cold; one run each, about a minute), ``roverimpact simulate
  examples/simulate_rover2d.toml``, ``roverimpact sweep
  examples/study_rover2d_beta_h.toml`` and ``roverimpact traverse
  examples/traverse_rocky.toml`` cold and warm, and that traverse cold with
  ``--workers 2`` (one run each, about a minute);
- ``--reproduce``: only the full ``roverimpact reproduce``, its studies side by side (one
  process per core, the default) against one process (``--workers 1``, the behaviour
  before 2026-11-29 second session), in alternation, cold and warm, ``-n`` pairs each
  (default 2 here; target: under 20 s cold);
- ``--kernels``: the compile time of each compiled kernel alone (a fresh process and an
  empty cache per kernel, after a trivial compile that pays numba's one-off set-up) and
  the time to load it from the cache it wrote. A kernel's time includes the functions it
  calls (they are compiled for it).

Run: ``python benchmarks/bench_startup.py [-n 5] [--cold-runs 2] [--full] [--kernels]``
or ``python benchmarks/bench_startup.py --reproduce [-n 2]``

What makes a fresh install faster (measured with this script; see also
``roverimpact._kernels._jit``): every kernel compiled for exactly one signature (the
unilateral impact kernel was compiled four times by ``reproduce``, once per combination of
read-only and writable index arrays, the partition kernels twice; the frictional kernel up
to six times), no literal-int specialisations of the Lemke and friction helpers (five of
the latter were compiled twice or three times), the lane-parallel kernel (6-8 s to
compile) only for batches of 64 items or more, and a second process compiling while the
command works, when the machine has a core to spare (``energy`` sends the row assembly it
needs first and compiles the partition kernel itself meanwhile: the other way round left
it waiting 1.4 s for the second process), and the end of the process without the
interpreter's teardown (``roverimpact.cli.run``: 0.3 s after compiled kernels were
loaded), and, for small work (``energy``, ``simulate``, ``reproduce``, a ``sweep`` of at
most 500 cases), the kernels' own Python code run while the second process compiles them
(``roverimpact._kernels._jit.Kernel.get``; the rows "kernels always compiled" set
``ROVERIMPACT_KERNELS=compiled``, the behaviour before 2026-11-29). Every run here waits
for the compiles it left in the background before the next one starts. Not done: caches
built at install time. numba keys a cache entry to the source
file (its folder, modification time and size) and to the CPU (name and features): an
editable install keeps its caches next to the source and rebuilds them after any edit, a
wheel's caches would be built for another machine's CPU and ignored, and pip has no
post-install step for wheels (a hook in the build would be fragile). A user can warm the
cache once with ``roverimpact reproduce --quick``.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from machine import reference

ROOT = Path(__file__).resolve().parents[1]
BG = "ROVERIMPACT_BACKGROUND_COMPILE"  # auto (load < cores), 1 (always), 0 (never)
KM = "ROVERIMPACT_KERNELS"  # auto (Python code for small work until cached), compiled

#: (label, module, attribute) of every :class:`roverimpact._kernels._jit.Kernel`
KERNELS = [
    ("partition (one item at a time)", "roverimpact._kernels.partition", "partition_kernel"),
    ("partition lanes (batched, SLP)", "roverimpact._kernels.lanes_jit", "LANES"),
    ("effective mass of single rows", "roverimpact._kernels.masses", "masses_kernel"),
    ("unilateral impact (Lemke)", "roverimpact._kernels.lemke", "impact_kernel"),
    ("row assembly, one configuration", "roverimpact.models._assemble", "_evaluate_one"),
    ("row assembly, batched", "roverimpact.models._assemble", "_evaluate_many"),
    ("row assembly + partition (T_c_at)", "roverimpact.models._assemble", "_partition_at"),
    ("frictional impact", "roverimpact._kernels.friction", "friction_kernel"),
    ("reduced model, RK4 peaks", "roverimpact._kernels.reduced", "rk4_peaks"),
    ("reduced model, stiff peaks", "roverimpact._kernels.reduced", "stiff_peaks"),
    ("bootstrap of agreement (> 400 cases)", "roverimpact._kernels.bootstrap",
     "agreement_kernel"),
]

_KERNEL_CODE = """
import json, sys, time, importlib
import numba
numba.njit(lambda x: x + 1)(1.0)          # numba's one-off set-up, not the kernel's
k = getattr(importlib.import_module(sys.argv[1]), sys.argv[2])
t = time.perf_counter()
k.get()
print(json.dumps(time.perf_counter() - t))
"""


def _env(cache: str | None = None) -> dict:
    env = dict(os.environ, MPLBACKEND="Agg")
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = cache
    return env


#: a pattern (pgrep's extended regular expression: no parentheses) of what the background
#: compile process runs (roverimpact._kernels._jit._BACKGROUND_CODE)
_BACKGROUND_MARK = "spec[.]split"


def _settle(limit: float = 600.0) -> None:
    """Wait until no background compile is left over from the previous command.

    A command that ran its kernels' Python code ends before the compiles it sent to a
    second process; that process goes on filling numba's cache (for the next run) and
    would load the machine during the next measurement."""
    t0 = time.perf_counter()
    while time.perf_counter() - t0 < limit:
        found = subprocess.run(["pgrep", "-f", _BACKGROUND_MARK], capture_output=True)
        if found.returncode != 0:  # none (or no pgrep: nothing to wait for)
            return
        time.sleep(0.5)


def _run(cmd: list[str], env: dict) -> float:
    t0 = time.perf_counter()
    subprocess.run(cmd, capture_output=True, check=True, env=env, cwd=ROOT)
    t = time.perf_counter() - t0
    _settle()
    return t


def _warm(cmd: list[str], n: int, cache: str) -> list[float]:
    _run(cmd, _env(cache))  # fills the cache
    return [_run(cmd, _env(cache)) for _ in range(n)]


def _cold(cmd: list[str], n: int, env: dict | None = None) -> list[float]:
    out = []
    for _ in range(n):
        with tempfile.TemporaryDirectory() as cache:
            out.append(_run(cmd, _env(cache) | (env or {})))
    return out


def _row(label: str, t: list[float], base: float) -> None:
    best, med = min(t), statistics.median(t)
    print(f"{label:44s} {best:8.3f} {med:9.3f} {med - base:10.3f} {med / base:8.1f}")


def _reproduce_pairs(side: list[str], one: list[str], out: str, n: int,
                     base: float) -> None:
    """The full reproduce side by side and in one process, in alternation: ``n`` pairs on
    an empty cache each, then ``n`` pairs on a warm cache; the ratio of the medians."""
    times: dict[str, list[float]] = {}
    for kind in ("cold", "warm"):
        with tempfile.TemporaryDirectory() as cache:
            if kind == "warm":
                _run(one, _env(cache))  # fills the cache
            for _ in range(n):
                for label, cmd in (("side by side", side), ("one process", one)):
                    shutil.rmtree(f"{out}/full", ignore_errors=True)
                    if kind == "cold":
                        shutil.rmtree(cache)
                        os.mkdir(cache)
                    times.setdefault(f"reproduce, full, {label} ({kind})", []).append(
                        _run(cmd, _env(cache)))
    for label, t in times.items():
        _row(label, t, base)
    for kind in ("cold", "warm"):
        a = statistics.median(times[f"reproduce, full, side by side ({kind})"])
        b = statistics.median(times[f"reproduce, full, one process ({kind})"])
        print(f"{kind}: side by side / one process = {a / b:.2f}")


def _kernel_times() -> None:
    print("\ncompile of each kernel alone (fresh process, empty cache) and load from cache:")
    print(f"{'kernel':36s} {'compile [s]':>12s} {'load [s]':>9s}")
    for label, module, attr in KERNELS:
        with tempfile.TemporaryDirectory() as cache:
            cmd = [sys.executable, "-c", _KERNEL_CODE, module, attr]
            runs = [json.loads(subprocess.run(cmd, capture_output=True, check=True,
                                              env=_env(cache), text=True).stdout)
                    for _ in range(2)]
        print(f"{label:36s} {runs[0]:12.2f} {runs[1]:9.3f}")


def main() -> None:
    print(reference())  # how fast this machine is right now (machine.py)
    ap = argparse.ArgumentParser()
    ap.add_argument("-n", type=int, default=None,
                    help="counted warm runs per command (default 5; --reproduce: pairs, 2)")
    ap.add_argument("--cold-runs", type=int, default=2, help="counted cold runs per command")
    ap.add_argument("--full", action="store_true", help="also the full reproduce, cold/warm")
    ap.add_argument("--kernels", action="store_true", help="compile time of each kernel")
    ap.add_argument("--reproduce", action="store_true",
                    help="only the full reproduce: side by side vs one process, cold/warm")
    args = ap.parse_args()
    pairs = args.n or 2  # --reproduce's pairs (two full runs each)
    args.n = args.n or 5
    exe = shutil.which("roverimpact") or str(Path(sys.executable).with_name("roverimpact"))
    out = tempfile.mkdtemp(prefix="bench_startup_")
    energy = [exe, "energy", "examples/rover2d_beta45.toml"]
    quick = [exe, "reproduce", "--quick", "--overwrite", "-o", f"{out}/quick"]
    full = [exe, "reproduce", "-o", f"{out}/full"]
    traverse = [exe, "traverse", "examples/traverse_rocky.toml", "-o", f"{out}/traverse"]
    sweep = [exe, "sweep", "examples/study_rover2d_beta_h.toml", "-o", f"{out}/sweep",
             "--overwrite", "--no-report"]
    simulate = [exe, "simulate", "examples/simulate_rover2d.toml", "-o", f"{out}/simulate",
                "--no-plot"]
    py = [sys.executable, "-c", "pass"]
    _run(py, _env())
    base = statistics.median([_run(py, _env()) for _ in range(max(args.n, 5))])
    print(f"{'command':44s} {'best [s]':>8s} {'median [s]':>9s} {'- python':>10s} "
          f"{'/ python':>8s}")
    _row("python -c pass", [base], base)
    if args.reproduce:
        _reproduce_pairs(full, [*full, "--workers", "1"], out, pairs, base)
        shutil.rmtree(out, ignore_errors=True)
        return
    with tempfile.TemporaryDirectory() as cache:
        for label, cmd in (("roverimpact --version", [exe, "--version"]),
                           ("roverimpact --help", [exe, "--help"]),
                           ("energy rover2d_beta45 (warm cache)", energy),
                           ("reproduce --quick (warm cache)", quick)):
            _row(label, _warm(cmd, args.n, cache), base)
            if cmd is energy:  # the kernels loaded at once: numba's compiler set up
                _row("  same, kernels loaded (before 2026-11-30)",
                     [_run(cmd, _env(cache) | {KM: "compiled"}) for _ in range(args.n)], base)
        for label, cmd, env in (
                ("energy rover2d_beta45 (cold: empty cache)", energy, {}),
                ("  same, background compile forced", energy, {BG: "1"}),
                ("  same, background compile off", energy, {BG: "0"}),
                ("  same, kernels always compiled (before 2026-11-29)", energy, {KM: "compiled"}),
                ("reproduce --quick (cold: empty cache)", quick, {}),
                ("  same, kernels always compiled", quick, {KM: "compiled"})):
            _row(label, _cold(cmd, args.cold_runs, env), base)
    if args.full:
        with tempfile.TemporaryDirectory() as cache:
            _row("reproduce, full (cold: empty cache)", [_run(full, _env(cache))], base)
            shutil.rmtree(f"{out}/full")
            _row("reproduce, full (warm cache)", [_run(full, _env(cache))], base)
        with tempfile.TemporaryDirectory() as cache:
            shutil.rmtree(f"{out}/full")
            _row("  same, cold, kernels always compiled",
                 [_run(full, _env(cache) | {KM: "compiled"})], base)
        with tempfile.TemporaryDirectory() as cache:
            _row("simulate simulate_rover2d (cold: empty cache)",
                 [_run(simulate, _env(cache))], base)
            _row("simulate simulate_rover2d (warm cache)", [_run(simulate, _env(cache))], base)
        with tempfile.TemporaryDirectory() as cache:
            _row("sweep rover2d_beta_h (cold: empty cache)", [_run(sweep, _env(cache))],
                 base)
            _row("sweep rover2d_beta_h (warm cache)", [_run(sweep, _env(cache))], base)
        with tempfile.TemporaryDirectory() as cache:
            _row("traverse traverse_rocky (cold: empty cache)", [_run(traverse, _env(cache))],
                 base)
            shutil.rmtree(f"{out}/traverse")
            _row("traverse traverse_rocky (warm cache)", [_run(traverse, _env(cache))], base)
        with tempfile.TemporaryDirectory() as cache:  # forked workers, never slower
            shutil.rmtree(f"{out}/traverse")
            _row("traverse traverse_rocky --workers 2 (cold: empty cache)",
                 [_run([*traverse, "--workers", "2"], _env(cache))], base)
    shutil.rmtree(out, ignore_errors=True)
    if args.kernels:
        _kernel_times()


if __name__ == "__main__":
    main()
