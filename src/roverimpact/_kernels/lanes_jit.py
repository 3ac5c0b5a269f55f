"""The lane-parallel partition kernel compiled with LLVM's SLP vectoriser.

:mod:`.lanes` holds the plain Python source (generated); :func:`lanes_kernel` compiles it
once per process (or loads it from numba's on-disk cache) with SLP vectorisation switched
on for this one function.
"""

from __future__ import annotations

from . import lanes
from ._jit import Kernel, partition_signature
from .partition import FASTMATH

#: Inputs read-only (callers may pass read-only or broadcast views), outputs writable.
#: SLP vectoriser on, loop vectoriser off: the per-lane statements become one SIMD
#: instruction each, where the loop vectoriser would vectorise the loops over rows and
#: columns across iterations instead and read the lanes through gathers (328 gathers in
#: the kernel; n = 18, m = 4, batch 1e5, one core: 1.2-1.3e6 items/s against 1.6-1.9e6/s
#: without it, same results to 3e-15; ``benchmarks/bench_single.py``). The fallback's
#: functions it shares with the one-item kernel (``factor``, ``partition_factored``) are
#: :func:`._jit.shared`: compiled the same way whichever kernel a process builds first.
LANES = Kernel(lanes.partition_lanes, partition_signature(), slp=True, loop_vectorize=False,
               fastmath=FASTMATH, error_model="numpy", home=f"{__name__}:LANES")


def lanes_kernel(items: int | None = None):
    """The compiled lane-parallel partition kernel (``items``: see
    :meth:`._jit.Kernel.get`).

    Arguments: :func:`._jit.partition_signature`.

    Compiled once per process (or loaded from numba's on-disk cache) with SLP
    vectorisation enabled and loop vectorisation disabled for this function only; the
    previous settings are restored.
    """
    return LANES.get(items)
