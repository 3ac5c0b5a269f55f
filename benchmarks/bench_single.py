"""One-item partition against what a user would hand-write with numba, and batch scaling.

    python benchmarks/bench_single.py [--n 18] [--m 4]
    python benchmarks/bench_single.py --vectoriser

Issue #19's targets: a partition call of one item within 2x of a hand-written numba
kernel; the batched partition (n = 18, m = 4) at >= 1.5e6 items/s on one core and no
slower at 1e6 items than at 1e5.

The hand-written kernel is the textbook route for full-rank rows and nothing else:
Cholesky of M, W = L^-1 A^T, G = W^T W, T_c = 1/2 (A v)^T G^-1 (A v) by a second Cholesky
(no input checks, no rank-revealing factorisation, no result object). roverimpact's
``partition`` checks its inputs, handles dependent rows and returns v_c, v_a and the
ranks; the figure is what that costs per call.

The 1e5 and 1e6 batches are timed in turns (best of 7 rounds, 3 for numpy), over 1e6
items each, as ``partition``, as the lane kernel writing into output arrays made once
(the computation alone), and as what a user writes in numpy with results of the size of
v_c and v_a (``np.linalg.solve(M, v)`` twice: about as much fresh memory a call). A
``partition`` call of 1e6 items returns 320 MB of new arrays, above glibc's threshold for
reusing freed memory: ``MALLOC_MMAP_MAX_=0 MALLOC_TRIM_THRESHOLD_=100000000000`` in the
environment makes glibc reuse it at every size, as it does at 1e5 (docs/theory.md).

``--vectoriser``: the one-item kernel compiled twice in this process, as it is (LLVM's
loop vectoriser off, for it and for the functions it calls) and with numba's default
(on), timed in turns over several sizes.
"""

from __future__ import annotations

import argparse
import math
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from machine import reference
from numba import njit

import roverimpact as ri
from roverimpact._kernels.lanes_jit import lanes_kernel
from roverimpact.energy import RTOL


@njit(inline="always")
def _cholesky(X, L):
    """Lower Cholesky factor of X into L (L may be X itself: in place)."""
    n = X.shape[0]
    for j in range(n):
        s = X[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        d = math.sqrt(s)
        L[j, j] = d
        for i in range(j + 1, n):
            t = X[i, j]
            for k in range(j):
                t -= L[i, k] * L[j, k]
            L[i, j] = t / d


@njit(inline="always")
def _textbook(M, A, v):
    """L (M = L L^T), W = L^-1 A^T, R (G = W^T W = R R^T, in G's place) and
    y = R^-1 A v, so that T_c = 1/2 |y|^2."""
    n, m = M.shape[0], A.shape[0]
    L = np.zeros((n, n))
    _cholesky(M, L)
    W = np.empty((n, m))
    for c in range(m):
        for i in range(n):
            t = A[c, i]
            for k in range(i):
                t -= L[i, k] * W[k, c]
            W[i, c] = t / L[i, i]
    G = np.empty((m, m))
    for a in range(m):
        for b in range(m):
            t = 0.0
            for i in range(n):
                t += W[i, a] * W[i, b]
            G[a, b] = t
    g = A @ v
    _cholesky(G, G)
    y = np.empty(m)
    for i in range(m):
        t = g[i]
        for k in range(i):
            t -= G[i, k] * y[k]
        y[i] = t / G[i, i]
    return L, W, G, y


@njit(cache=True)
def hand_tc(M, A, v):
    y = _textbook(M, A, v)[3]
    return 0.5 * (y @ y)


@njit(cache=True)
def hand_vc(M, A, v):
    """The same route, returning what ``partition`` returns by default: T, T_c, T_a and
    the velocities v_c = M^-1 A^T G^-1 A v and v_a = v - v_c (full-rank rows only)."""
    n, m = M.shape[0], A.shape[0]
    L, W, G, y = _textbook(M, A, v)
    z = np.empty(m)  # G^-1 g = R^-T y
    for i in range(m - 1, -1, -1):
        t = y[i]
        for k in range(i + 1, m):
            t -= G[k, i] * z[k]
        z[i] = t / G[i, i]
    w = W @ z
    vc = np.empty(n)  # L^-T w
    for i in range(n - 1, -1, -1):
        t = w[i]
        for k in range(i + 1, n):
            t -= L[k, i] * vc[k]
        vc[i] = t / L[i, i]
    T = 0.5 * (v @ (M @ v))
    Tc = 0.5 * (y @ y)
    return T, Tc, T - Tc, vc, v - vc


def per_call(fn, reps: int) -> float:
    best = math.inf
    for _ in range(5):
        t = time.perf_counter()
        for _ in range(reps):
            fn()
        best = min(best, (time.perf_counter() - t) / reps)
    return best


def in_turns(*fns, rounds: int = 8, reps: int = 4000) -> list[float]:
    """Best time per call of each of ``fns``, over ``rounds`` rounds that call them in
    turns (``reps`` calls each): a slow second of the machine then costs every function a
    round, not one function its figure."""
    best = [math.inf] * len(fns)
    for _ in range(rounds):
        for i, fn in enumerate(fns):
            t = time.perf_counter()
            for _ in range(reps):
                fn()
            best[i] = min(best[i], (time.perf_counter() - t) / reps)
    return best


def _one_item_kernel(loop_vectorize: bool):
    """The one-item partition kernel and the functions it calls, compiled afresh from
    ``roverimpact/_kernels/partition.py`` (no on-disk cache) with the loop vectoriser on
    or off."""
    import types

    from roverimpact._kernels import partition
    from roverimpact._kernels._jit import vectorisers

    name = f"roverimpact._kernels._bench_{'vec' if loop_vectorize else 'novec'}"
    mod = types.ModuleType(name)
    mod.__package__ = "roverimpact._kernels"
    with open(partition.__file__) as f:
        src = f.read().replace("cache=True", "cache=False")
    shared = "@shared(fastmath=FASTMATH)"
    assert src.count(shared) == 2  # factor, partition_factored: else this no longer applies
    src = src.replace(shared, (
        "@njit(cache=False, nogil=True, fastmath=FASTMATH)"  # compiled with it on too
        if loop_vectorize else "@shared(cache=False, fastmath=FASTMATH)"))
    if loop_vectorize:
        src = src.replace("fastmath=FASTMATH, loop_vectorize=False)", "fastmath=FASTMATH)")
    exec(compile(src, name, "exec"), mod.__dict__)
    mod.partition_kernel._options["cache"] = False
    assert mod.partition_kernel._loop_vectorize == loop_vectorize
    with vectorisers(loop=1):  # numba's default, whatever the environment says
        return mod.partition_kernel.get()


def vectoriser() -> None:
    """The one-item kernel with LLVM's loop vectoriser off (as shipped) and on."""
    kernels = {"off (as shipped)": _one_item_kernel(False), "on": _one_item_kernel(True)}
    rng = np.random.default_rng(0)
    index = np.zeros((3, 1), dtype=np.int64)
    print("one-item kernel, one call, best of 5 rounds taken in turns [us]: "
          "T_c alone / with v_c and v_a")
    for n, m in ((5, 1), (9, 3), (18, 4), (18, 10), (30, 6), (60, 8)):
        B = rng.standard_normal((n, n))
        M = B @ B.T + n * np.eye(n)
        A, v = rng.standard_normal((m, n)), rng.standard_normal(n)
        out, out_v = np.empty((1, 5)), np.empty((1, 5 + 2 * n))
        args = (M, A, v, index, -1, 1e-9)
        times = in_turns(*(lambda k=k, o=o, w=w, a=args: k(*a, w, o)
                           for k in kernels.values() for w, o in ((False, out), (True, out_v))),
                         rounds=5, reps=2000)
        best = {name: (times[2 * i], times[2 * i + 1]) for i, name in enumerate(kernels)}
        print(f"  n = {n:2d}, m = {m:2d}:  " + "   ".join(
            f"loop vectoriser {name} {1e6 * t:6.2f} / {1e6 * tv:6.2f}"
            for name, (t, tv) in best.items()))


def main() -> None:
    print(reference())  # how fast this machine is right now (machine.py)
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=18)
    ap.add_argument("--m", type=int, default=4)
    ap.add_argument("--vectoriser", action="store_true",
                    help="time the one-item kernel with LLVM's loop vectoriser off and on")
    a = ap.parse_args()
    if a.vectoriser:
        vectoriser()
        return
    rng = np.random.default_rng(0)
    n, m = a.n, a.m
    B = rng.standard_normal((n, n))
    M = B @ B.T + n * np.eye(n)
    A = rng.standard_normal((m, n))
    v = rng.standard_normal(n)
    ref = hand_tc(M, A, v)
    got = float(ri.partition(M, A, v).T_c)
    assert abs(got - ref) <= 1e-12 * abs(ref), (got, ref)
    p = ri.partition(M, A, v)
    T, Tc, _, vc, va = hand_vc(M, A, v)
    assert abs(Tc - ref) <= 1e-12 * ref and abs(T - p.T) <= 1e-12 * T
    assert np.allclose(vc, p.v_c, rtol=1e-10, atol=0) and np.allclose(va, p.v_a, rtol=1e-10)
    from roverimpact._kernels.partition import partition_kernel  # the kernel alone
    kernel, index = partition_kernel.get(), np.zeros((3, 1), dtype=np.int64)
    out = np.empty((1, 0))  # one system (m = -1): T_c returned, out written only for v_c
    assert abs(kernel(M, A, v, index, -1, 1e-9, False, out)[2] - got) <= 1e-12 * got
    # rounds taken in turns: this machine's speed changes from one second to the next
    t_hand, t_hand_vc, t_ri, t_tc, t_kernel = in_turns(
        lambda: hand_tc(M, A, v), lambda: hand_vc(M, A, v), lambda: ri.partition(M, A, v),
        lambda: ri.partition(M, A, v, want_velocities=False),
        lambda: kernel(M, A, v, index, -1, 1e-9, False, out))
    print(f"one item, n = {n}, m = {m}, one core (T_c equal to {abs(got - ref) / ref:.1e}):")
    print(f"  hand-written numba kernel, T_c (Cholesky, full rank)   {1e6 * t_hand:6.2f} us")
    print(f"  hand-written, also T, T_a, v_c and v_a                 {1e6 * t_hand_vc:6.2f} us")
    print(f"  roverimpact.partition(want_velocities=False)           {1e6 * t_tc:6.2f} us   "
          f"{t_tc / t_hand:4.2f}x the T_c kernel (target <= 2x)")
    print(f"    of which its compiled kernel, called directly        {1e6 * t_kernel:6.2f} us   "
          f"{t_kernel / t_hand:4.2f}x (the rest: the Python around it)")
    print(f"  roverimpact.partition                                  {1e6 * t_ri:6.2f} us   "
          f"{t_ri / t_hand_vc:4.2f}x the v_c kernel (target <= 2x), "
          f"{t_ri / t_hand:4.2f}x the T_c kernel")
    print(f"batched roverimpact.partition, n = {n}, m = {m}, one core:")
    for k in (2, 17):  # below LANES_MIN_BATCH: the one-item kernel, item by item
        Bk = rng.standard_normal((k, n, n))
        Mk = Bk @ np.swapaxes(Bk, 1, 2) + n * np.eye(n)
        Ak, vk = rng.standard_normal((k, m, n)), rng.standard_normal((k, n))
        t = per_call(lambda Mk=Mk, Ak=Ak, vk=vk: ri.partition(Mk, Ak, vk), 5000)
        print(f"  {k:>9,} items  {1e6 * t:6.1f} us a call, {1e6 * t / k:5.2f} us an item")
    sizes = (100_000, 1_000_000)
    inputs = []
    for k in sizes:
        Bk = rng.standard_normal((k, n, n)) * 0.3
        Mk = Bk @ np.swapaxes(Bk, 1, 2) + n * np.eye(n)
        del Bk
        inputs.append((Mk, rng.standard_normal((k, m, n)), rng.standard_normal((k, n))))
    ri.partition(*inputs[0])
    lanes = lanes_kernel()

    def kernel_only(Mk, Ak, vk, out):
        """The lane kernel into output arrays made once (``out``)."""
        idx, T, Tc, Ta, vc, va, rank, status = out
        lanes(Mk, Ak, vk, idx, idx, idx, RTOL, True, T, Tc, Ta, vc, va, rank, status)

    def ten_times(fn, *args):  # 1e5 items ten times: as many items as one call of 1e6
        def call():
            for _ in range(10):
                fn(*args)
        return call

    def outputs(k):
        return (np.arange(k), *np.zeros((3, k)), np.zeros((k, n)), np.zeros((k, n)),
                np.zeros(k, np.int64), np.zeros(k, np.int64))

    # in turns, 1e6 items each: the machine's swings of speed would otherwise decide the
    # ratio. partition's results are dropped after each call, so the 1e5 calls reuse
    # memory freed by the last one (below glibc's 32 MB mmap threshold), where the 1e6
    # results (v_c and v_a 144 MB each) are fresh pages every call; the lane kernel into
    # output arrays made once shows the computation alone.
    full = in_turns(ten_times(ri.partition, *inputs[0]), lambda: ri.partition(*inputs[1]),
                    rounds=7, reps=1)
    outs = [outputs(k) for k in sizes]
    alone = in_turns(ten_times(kernel_only, *inputs[0], outs[0]),
                     lambda: kernel_only(*inputs[1], outs[1]), rounds=7, reps=1)
    # what a user writes in numpy, with results of the size of v_c and v_a: two new (k, n)
    # arrays a call. Its own 1e6 / 1e5 ratio is what fresh pages cost numpy's batched
    # calls on this machine (machine.py prints how memory is handed out)
    def solve_twice(Mk, _Ak, vk):
        return np.linalg.solve(Mk, vk[..., None]), np.linalg.solve(Mk, vk[..., None])

    numpy_solve = in_turns(ten_times(solve_twice, *inputs[0]),
                           lambda: solve_twice(*inputs[1]), rounds=3, reps=1)  # (slow)
    for what, times in (("partition", full), ("lane kernel alone", alone),
                        ("numpy solve twice", numpy_solve)):
        r = [1_000_000 / t for t in times]
        print(f"  {what:<18} 1e5 items {r[0]:9.3g}/s, 1e6 items {r[1]:9.3g}/s, "
              f"1e6 / 1e5 rate {r[1] / r[0]:.2f}")
    print("  (targets: >= 1.5e6 items/s; no slower at 1e6)")
    fresh, reused = fresh_pages(1_000_000 * (5 + 2 * n) * 8)
    print(f"  this machine's fresh memory, the size of 1e6 items' results: "
          f"{1e3 * fresh:.0f} ms to write it new in one pass, {1e3 * reused:.0f} ms to write "
          f"it again ({1e3 * (fresh - reused):.0f} ns an item; a 1e5-item call reuses freed "
          "memory instead; first touches spread over a long call, as partition's, can cost "
          "more on a virtual machine whose balloon reports free pages: machine line above)")


def fresh_pages(nbytes: int, rounds: int = 5) -> tuple[float, float]:
    """Best time to fill ``nbytes`` of newly allocated memory (pages the operating system
    hands out on first touch, as a 1e6-item ``partition``'s results) and to fill the same
    memory again."""
    fresh = reused = math.inf
    for _ in range(rounds):
        t = time.perf_counter()
        x = np.empty(nbytes // 8)
        x.fill(1.0)
        fresh = min(fresh, time.perf_counter() - t)
        t = time.perf_counter()
        x.fill(2.0)
        reused = min(reused, time.perf_counter() - t)
        del x
    return fresh, reused


if __name__ == "__main__":
    main()
