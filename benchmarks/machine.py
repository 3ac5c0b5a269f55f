"""How fast this machine is right now, for reading a benchmark's figures against another
day's: the same host can run two to three times slower from one session to the next
(a shared virtual machine), which shifts every absolute figure but few ratios.

    python benchmarks/machine.py

The bench scripts print :func:`reference` first. Two yardsticks, best of five:
a pure-Python loop (the interpreter: what start-up, case generation and the studies'
bookkeeping cost) and numpy's batched Cholesky of 10 000 SPD 18 x 18 matrices (compiled
arithmetic on data larger than the caches: what the kernels cost). Then how the system
hands out memory (:func:`memory`), which decides what fresh pages cost: transparent huge
pages, and on a virtual machine whether its memory balloon reports free pages to the host
(memory a process freed goes back to the host within seconds, and touching it again
costs a trip there: a 1e6-item ``partition``'s results in ``bench_single.py``).
"""

from __future__ import annotations

import os
import time
from pathlib import Path

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


#: virtio feature bit of a memory balloon that reports free pages (VIRTIO_BALLOON_F_REPORTING)
_BALLOON_REPORTING_BIT = 5


def memory() -> str:
    """How this system hands out memory: the transparent-huge-page mode (Linux) and, on a
    virtual machine with a virtio memory balloon, whether it reports free pages to the
    host. "" where neither is known (another system)."""
    facts = []
    try:
        thp = Path("/sys/kernel/mm/transparent_hugepage/enabled").read_text()
        facts.append("huge pages " + thp.split("[", 1)[1].split("]", 1)[0])
    except (OSError, IndexError):
        pass
    for dev in Path("/sys/bus/virtio/devices").glob("*"):
        try:
            if int((dev / "device").read_text(), 16) != 5:  # 5: memory balloon
                continue
            bits = (dev / "features").read_text().strip()
        except (OSError, ValueError):
            continue
        on = len(bits) > _BALLOON_REPORTING_BIT and bits[_BALLOON_REPORTING_BIT] == "1"
        facts.append("memory balloon reporting free pages to the host" if on
                     else "memory balloon without free page reporting")
    return ", ".join(facts)


def reference() -> str:
    """One line: cores, load, the two yardsticks, how memory is handed out (:func:`memory`)."""
    rng = np.random.default_rng(0)
    B = rng.standard_normal((10_000, 18, 18))
    M = B @ np.swapaxes(B, 1, 2) + 18 * np.eye(18)
    t_py = _best(_loop)
    t_chol = _best(lambda: np.linalg.cholesky(M))
    try:
        load = f"load {os.getloadavg()[0]:.1f}"
    except OSError:  # pragma: no cover - no load average on this system
        load = "load unknown"
    mem = memory()
    return (f"machine: {os.cpu_count()} cores, {load}; pure-Python loop of 1e6 additions "
            f"{1e3 * t_py:.0f} ms, numpy Cholesky of 1e4 x (18 x 18) {1e3 * t_chol:.1f} ms"
            + (f"; {mem}" if mem else ""))


if __name__ == "__main__":
    print(reference())
