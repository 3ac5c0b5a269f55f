"""How fast this machine is right now, for reading a benchmark's figures against another
day's: the same host can run two to three times slower from one session to the next
(a shared virtual machine), which shifts every absolute figure but few ratios.

    python benchmarks/machine.py

The bench scripts print :func:`reference` first. Two yardsticks, best of five:
a pure-Python loop (the interpreter: what start-up, case generation and the studies'
bookkeeping cost) and numpy's batched Cholesky of 10 000 SPD 18 x 18 matrices (compiled
arithmetic on data larger than the caches: what the kernels cost).
"""

from __future__ import annotations

import os
import time

import numpy as np


def _best(fn, runs: int = 5) -> float:
    best = float("inf")
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def _loop(n: int = 1_000_000) -> int:
    s = 0
    for i in range(n):
        s += i
    return s


def reference() -> str:
    """One line: cores, load, the two yardsticks."""
    rng = np.random.default_rng(0)
    B = rng.standard_normal((10_000, 18, 18))
    M = B @ np.swapaxes(B, 1, 2) + 18 * np.eye(18)
    t_py = _best(_loop)
    t_chol = _best(lambda: np.linalg.cholesky(M))
    try:
        load = f"load {os.getloadavg()[0]:.1f}"
    except OSError:  # pragma: no cover - no load average on this system
        load = "load unknown"
    return (f"machine: {os.cpu_count()} cores, {load}; pure-Python loop of 1e6 additions "
            f"{1e3 * t_py:.0f} ms, numpy Cholesky of 1e4 x (18 x 18) {1e3 * t_chol:.1f} ms")


if __name__ == "__main__":
    print(reference())
