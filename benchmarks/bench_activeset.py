"""Cost of the automatic active set against the plain T_c^- evaluation.

Rover-sized configurations: n = 9..18 coordinates, 3..8 unilateral rows (ground contacts
and the obstacle) plus 2 bilateral rows (loop closure / locked joint). Baseline: ``partition``
of all rows (the T_c^- evaluation with a fixed set). Auto: ``unilateral_impact`` (LCP +
T_c^- with the active set, one kernel) and ``active_set``. Prints microseconds per item,
batched (10 000 items) and single calls, and the ratio auto / baseline.

Run: ``python benchmarks/bench_activeset.py``
"""
# ruff: noqa: B023

from __future__ import annotations

import time

import numpy as np
from machine import reference

import roverimpact as ri


def _spd(rng, n):
    X = rng.standard_normal((n, n))
    D = np.diag(10.0 ** rng.uniform(-0.5, 0.5, n))
    return D @ (X @ X.T + n * np.eye(n)) @ D


def best(f, repeat=5):
    ts = []
    for _ in range(repeat):
        t = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t)
    return min(ts)


def main():
    print(reference())  # how fast this machine is right now (machine.py)
    rng = np.random.default_rng(0)
    nb = 10_000
    print(f"{'n':>3} {'k':>3} | batched us/item: T_c fixed  auto(impact)  active_set  ratio"
          f" | single call us: T_c fixed  auto  ratio")
    for n, k in [(9, 3), (12, 5), (15, 6), (18, 8)]:
        M = np.stack([_spd(rng, n) for _ in range(nb)])
        N = rng.standard_normal((nb, k, n))
        B = rng.standard_normal((nb, 2, n))
        v = rng.standard_normal((nb, n))
        v -= np.einsum("bij,bj->bi", np.linalg.pinv(B), np.einsum("bij,bj->bi", B, v))
        A = np.concatenate([N, B], axis=1)
        ri.partition(M[:2], A[:2], v[:2])  # compile / warm up
        ri.unilateral_impact(M[:2], v[:2], N[:2], 0.0, bilateral=B[:2])
        t_p = best(lambda: ri.partition(M, A, v, want_velocities=False)) / nb * 1e6
        t_u = best(lambda: ri.unilateral_impact(M, v, N, 0.0, bilateral=B)) / nb * 1e6
        t_a = best(lambda: ri.active_set(M, v, N, B)) / nb * 1e6
        s_p = best(lambda: [ri.partition(M[i], A[i], v[i]) for i in range(200)]) / 200 * 1e6
        s_u = best(lambda: [ri.unilateral_impact(M[i], v[i], N[i], 0.0, bilateral=B[i])
                            for i in range(200)]) / 200 * 1e6
        print(f"{n:>3} {k:>3} | {t_p:26.2f} {t_u:13.2f} {t_a:11.2f} {t_a / t_p:6.2f}"
              f" | {s_p:25.1f} {s_u:5.1f} {s_u / s_p:6.2f}")
    print("ratio = active_set (LCP + T_c^- with the active set) / partition with all rows")


if __name__ == "__main__":
    main()
