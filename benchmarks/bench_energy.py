"""Configurations per second of the kinetic-energy partition.

Batch of 100 000 random systems with n = 18, m = 4 (a 3-D rocker-bogie rover's size),
compiled kernel (one core) against a plain per-item numpy loop and against the batched
numpy a user would write (stacked Cholesky and solves; also with an SVD, rank-revealing as
the kernel is), all in the same run; ratios against the loop and the batched baseline.

Then the effective masses along the last row, free and with the other rows held
(``roverimpact.energy.row_masses``: the compiled kernel for the whole batch, and the same
call on batches of 32, below ``LANES_MIN_BATCH``, numpy's LAPACK and the partition)
against the batched numpy a user would write (stacked Cholesky, one solve, an SVD of the
held rows: what ``effective_mass`` did before, twice), checked against each other.

    python benchmarks/bench_energy.py [--n 18] [--m 4] [--batch 100000]
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np
from machine import reference

import roverimpact as ri


def best_of(fn, repeat=3):
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def per_item_loop(M, A, v):
    """Textbook numpy per configuration: P_c = M^-1 A^T (A M^-1 A^T)^-1 A."""
    out = np.empty(len(M))
    for b in range(len(M)):
        MinvAT = np.linalg.solve(M[b], A[b].T)
        Pc = MinvAT @ np.linalg.solve(A[b] @ MinvAT, A[b])
        vc = Pc @ v[b]
        out[b] = 0.5 * vc @ M[b] @ vc
    return out


def batched_lapack(M, A, v):
    """What a user would write, batched: T_c = 1/2 (A v)^T (A M^-1 A^T)^-1 (A v) with
    numpy's stacked Cholesky and solves (full-rank A; no rank decision)."""
    L = np.linalg.cholesky(M)
    W = np.linalg.solve(L, np.swapaxes(A, -1, -2))           # L^-1 A^T
    G = np.swapaxes(W, -1, -2) @ W                           # A M^-1 A^T
    Av = np.einsum("bij,bj->bi", A, v)
    return 0.5 * np.einsum("bi,bi->b", Av, np.linalg.solve(G, Av[..., None])[..., 0])


def batched_lapack_svd(M, A, v):
    """The same with an SVD of L^-1 A^T (rank-revealing, as the kernel is)."""
    L = np.linalg.cholesky(M)
    W = np.linalg.solve(L, np.swapaxes(A, -1, -2))
    U, _, _ = np.linalg.svd(W, full_matrices=False)
    u = np.einsum("bji,bj->bi", L, v)
    y = np.einsum("bji,bj->bi", U, u)
    return 0.5 * np.sum(y**2, axis=-1)


def batched_masses(M, a, B):
    """What a user would write, batched: ``1 / (a M^-1 a^T)`` and, with the rows ``B``
    held, ``1 / |(I - Pi) L^-1 a^T|^2`` (Pi onto range(L^-1 B^T), from an SVD with the rank
    decided at 1e-9) by numpy's stacked Cholesky, one solve and an SVD."""
    L = np.linalg.cholesky(M)
    W = np.linalg.solve(L, np.concatenate([a[..., None], np.swapaxes(B, -1, -2)], axis=-1))
    w, WB = W[..., 0], W[..., 1:]
    U, s, _ = np.linalg.svd(WB / np.linalg.norm(WB, axis=-2, keepdims=True),
                            full_matrices=False)
    U = U * (s > 1e-9 * s[..., :1])[..., None, :]
    wp = w - np.einsum("bij,bj->bi", U, np.einsum("bji,bj->bi", U, w))
    return 1.0 / np.einsum("bi,bi->b", wp, wp), 1.0 / np.einsum("bi,bi->b", w, w)


def masses(M, A):
    """Effective masses along the last row of A, held and free: row_masses against
    batched_masses."""
    from roverimpact.energy import row_masses

    B, n = len(M), M.shape[-1]
    a, held = A[:, -1], A[:, :-1]
    row_masses(M[:100], a[:100], held[:100])  # compile / load cache
    small = 32

    def in_small_batches():
        for s in range(0, B, small):
            row_masses(M[s:s + small], a[s:s + small], held[s:s + small])

    t_kernel = best_of(lambda: row_masses(M, a, held))
    k = min(B, 20_000)
    t_small = best_of(in_small_batches, repeat=1) if B <= k else best_of(
        lambda: [row_masses(M[s:s + small], a[s:s + small], held[s:s + small])
                 for s in range(0, k, small)], repeat=1) * B / k
    t_numpy = best_of(lambda: batched_masses(M, a, held), repeat=1)
    got, ref = row_masses(M[:500], a[:500], held[:500]), batched_masses(M[:500], a[:500],
                                                                         held[:500])
    assert np.allclose(got, ref, rtol=1e-9), "row_masses disagrees with batched numpy"
    rate = lambda t: B / t  # noqa: E731
    print(f"\neffective masses along one row (free, and {A.shape[1] - 1} rows held), batch "
          f"{B}, n = {n}, one core")
    print(f"{'method':48s} {'configs/s':>12s} {'vs batched':>11s}")
    for name, t in [("batched numpy (cholesky + solve + svd): baseline", t_numpy),
                    ("row_masses, whole batch (compiled kernel)", t_kernel),
                    (f"row_masses, batches of {small} (numpy + partition)", t_small)]:
        print(f"{name:48s} {rate(t):12.3g} {t_numpy / t:10.1f}x")


def main():
    print(reference())  # how fast this machine is right now (machine.py)
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=18)
    ap.add_argument("--m", type=int, default=4)
    ap.add_argument("--batch", type=int, default=100_000)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    n, m, B = args.n, args.m, args.batch
    X = rng.standard_normal((B, n, n))
    M = X @ np.swapaxes(X, -1, -2) + n * np.eye(n)
    A = rng.standard_normal((B, m, n))
    v = rng.standard_normal((B, n))
    ri.partition(M[:10], A[:10], v[:10])  # compile / load cache

    t_fast = best_of(lambda: ri.partition(M, A, v, want_velocities=False))
    t_full = best_of(lambda: ri.partition(M, A, v))
    t_shared = best_of(lambda: ri.partition(M[0], A, v, want_velocities=False))
    t_lapack = best_of(lambda: batched_lapack(M, A, v), repeat=1)
    t_lapack_svd = best_of(lambda: batched_lapack_svd(M, A, v), repeat=1)
    k = min(B, 5000)
    t_loop = best_of(lambda: per_item_loop(M[:k], A[:k], v[:k]), repeat=1) * B / k

    ref = per_item_loop(M[:200], A[:200], v[:200])
    got = ri.partition(M[:200], A[:200], v[:200]).T_c
    assert np.allclose(got, ref, rtol=1e-8), "kernel disagrees with the textbook formula"
    assert np.allclose(batched_lapack(M[:200], A[:200], v[:200]), ref, rtol=1e-8)

    # the two compiled kernels called directly (preallocated outputs, no input checks)
    from roverimpact._kernels.lanes_jit import lanes_kernel
    from roverimpact._kernels.partition import partition_kernel

    idx = np.arange(B)
    outs = [np.empty(B) for _ in range(3)] + [np.empty((0, n)), np.empty((0, n)),
                                              np.empty(B, np.int64), np.empty(B, np.int64)]

    def direct(kernel, ii=idx):
        kernel(M, A, v, ii, ii, ii, 1e-9, False, *outs)

    lanes = lanes_kernel()
    t_lanes = best_of(lambda: direct(lanes))
    one, stacked = partition_kernel.get(), (M.reshape(-1, n), A.reshape(-1, n), v.reshape(-1))
    index, out = np.stack((idx, idx, idx)), np.empty((B, 5))
    t_one = best_of(lambda: one(*stacked, index, m, 1e-9, False, out))
    # the same work on 1000 systems cycled (inputs stay in cache): memory traffic excluded
    t_cached = best_of(lambda: direct(lanes, idx % 1000))

    rate = lambda t: B / t  # noqa: E731
    print(f"kinetic-energy partition, batch {B}, n = {n}, m = {m}, one core")
    print(f"{'method':48s} {'configs/s':>12s} {'vs loop':>9s} {'vs batched':>11s}")
    rows = [
        ("per-item numpy loop", t_loop),
        ("batched numpy (cholesky + solves): the baseline", t_lapack),
        ("batched numpy (cholesky + solve + svd)", t_lapack_svd),
        ("roverimpact.partition, T_c only", t_fast),
        ("roverimpact.partition, with v_c and v_a", t_full),
        ("roverimpact.partition, one M shared by the batch", t_shared),
        ("lane kernel direct (8 per SIMD block), T_c only", t_lanes),
        ("one-item kernel direct (pivoted QR), T_c only", t_one),
        ("lane kernel, 1000 systems cycled (in cache)", t_cached),
    ]
    for name, t in rows:
        print(f"{name:48s} {rate(t):12.3g} {t_loop / t:8.1f}x {t_lapack / t:10.1f}x")
    print(f"target (issue #3): 1e6 configs/s; partition T_c only reaches {rate(t_fast) / 1e6:.2f}x "
          "of it")
    masses(M, A)


if __name__ == "__main__":
    main()
