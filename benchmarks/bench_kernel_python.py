"""What a kernel's Python code costs an item, against the compiled kernel.

While numba's cache lacks a kernel (a fresh install), small work runs the kernel's own
Python source (``roverimpact._kernels._jit.Kernel.get`` with ``items``;
``ROVERIMPACT_KERNELS=python`` forces it here): this prints milliseconds an item for
each, through the public functions (n = 18 coordinates, m = 5 rows or contacts, 20 items
a call), next to the compiled kernel's (loaded from the cache, or compiled first, not
timed). Compare with a kernel's compile time: ``python benchmarks/bench_startup.py
--kernels``.

Run: ``python benchmarks/bench_kernel_python.py``
"""

from __future__ import annotations

import os
import time

import numpy as np
from machine import reference

import roverimpact as ri
from roverimpact.contact.reduced import reduced_impact_batch
from roverimpact.frictional import frictional_impact

N, M_ROWS, B = 18, 5, 20


def _spd(rng, b, n):
    X = rng.standard_normal((b, n, n))
    return X @ X.transpose(0, 2, 1) + n * np.eye(n)


def per_item(f, items, repeat=3):
    f()  # first call: compile or load, Python stand-ins built
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t)
    return 1e3 * best / items


def main():
    print(reference())  # how fast this machine is right now (machine.py)
    rng = np.random.default_rng(0)
    M = _spd(rng, B, N)
    A = rng.standard_normal((B, M_ROWS, N))
    v = rng.standard_normal((B, N))
    T = rng.standard_normal((B, M_ROWS, 2, N))
    # a rover's impact in contact space: obstacle row and a held ground row, Hunt-Crossley
    # k = 1e7 N/m^1.5 (the studies' default law), 0.3 m/s
    G = np.array([[[0.1, 0.02], [0.02, 0.05]]] * 4)
    b = np.tile([[0.0, -9.81 * 0.05]], (4, 1))
    L = np.broadcast_to([[1e7, 1.5, 1.2 / 0.3, 0.0, 0.0], [1e7, 1.5, 3.0, 0.0, 0.0]],
                        (4, 2, 5))
    r0 = np.tile([[0.3, 0.0]], (4, 1))
    cases = [
        ("partition (item kernel)", lambda: ri.partition(M, A, v), B),
        ("unilateral impact (Lemke)", lambda: ri.unilateral_impact(M, v, A), B),
        ("frictional impact, mu = 0.5", lambda: frictional_impact(M, v, A, T, 0.5), B),
        ("contact-space RK4, Hunt-Crossley", lambda: reduced_impact_batch(
            G, b, L, r0, t_max=0.05, impact=0, integrator="rk4"), 4),
    ]
    print(f"n = {N}, m = {M_ROWS}; milliseconds an item")
    print(f"{'kernel':36s} {'Python':>9s} {'compiled':>9s} {'ratio':>8s}")
    for label, f, items in cases:
        times = {}
        for mode in ("python", "compiled"):
            os.environ["ROVERIMPACT_KERNELS"] = mode
            times[mode] = per_item(f, items)
        print(f"{label:36s} {times['python']:9.3f} {times['compiled']:9.4f} "
              f"{times['python'] / times['compiled']:7.0f}x")


if __name__ == "__main__":
    main()
