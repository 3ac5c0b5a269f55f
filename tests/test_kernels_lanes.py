"""Lane-parallel partition kernel against the one-item kernel and an SVD reference.

The lane kernel (Gram-Schmidt twice in row order, 8 items per SIMD block) and the one-item
kernel (Householder QR with column pivoting) are two different factorisations of the same
projector; they must agree to rounding on every item, including rank-deficient,
duplicated, nearly dependent and invalid ones, whatever the batch size and broadcasting.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import roverimpact as ri
from roverimpact import _validation
from roverimpact._kernels import partition as one
from roverimpact._kernels.lanes_jit import lanes_kernel
from roverimpact.energy import LANES_MIN_BATCH

from .reference.systems import random_spd

ROOT = Path(__file__).resolve().parents[1]


def run_items(M, A, v, iM, iA, iv, rtol, want_vc, T, Tc, Ta, vc, va, rank, status):
    """The one-item kernel with the arguments and outputs of the lane kernel
    (``_jit.partition_signature``), to hold the two side by side. An item whose status is
    not ``STATUS_OK`` gets NaN energies and rank 0 (its ``vc`` row is undefined)."""
    nb, m, n = iM.shape[0], A.shape[1], M.shape[1]
    index = np.stack([iM, iA, iv]).astype(np.int64)
    out = np.empty((nb, one.OUT_V + (2 * n if want_vc else 0)))
    one.partition_kernel.get()(M.reshape(-1, n), A.reshape(-1, n), v.reshape(-1), index, m,
                               rtol, want_vc, out)
    T[:], Tc[:], Ta[:] = out[:, one.OUT_T], out[:, one.OUT_TC], out[:, one.OUT_TA]
    rank[:], status[:] = out[:, one.OUT_RANK], out[:, one.OUT_STATUS]
    if want_vc:
        vc[:] = out[:, one.OUT_V:one.OUT_V + n]
        va[:] = out[:, one.OUT_V + n:]


def _run(kernel, M, A, v, iM, iA, iv, want_vc=True, rtol=1e-9):
    nb, n = iM.shape[0], M.shape[1]
    T, Tc, Ta = np.full(nb, np.nan), np.full(nb, np.nan), np.full(nb, np.nan)
    vc = np.full((nb, n), np.nan) if want_vc else np.empty((0, n))
    va = np.full((nb, n), np.nan) if want_vc else np.empty((0, n))
    rank = np.full(nb, -1, dtype=np.int64)
    status = np.full(nb, -1, dtype=np.int64)
    kernel(M, A, v, iM, iA, iv, rtol, want_vc, T, Tc, Ta, vc, va, rank, status)
    return T, Tc, Ta, vc, rank, status, va


def _batch(rng, nb, n, m, kinds):
    """nb random items of one size; each item of a kind drawn from ``kinds``."""
    M = np.stack([random_spd(rng, n) for _ in range(nb)])
    A = np.empty((nb, m, n))
    for b in range(nb):
        kind = kinds[rng.integers(len(kinds))]
        if kind == "full":
            A[b] = rng.standard_normal((m, n))
        elif kind == "deficient":
            r = int(rng.integers(1, max(2, min(m, n))))
            A[b] = rng.standard_normal((m, r)) @ rng.standard_normal((r, n))
        elif kind == "duplicate":
            A[b] = rng.standard_normal((m, n))
            A[b, m // 2:] = 2.5 * A[b, : m - m // 2]
        elif kind == "near":  # rows a, a + delta b, b: row order matters for unpivoted GS
            base = rng.standard_normal((m, n))
            if m >= 3:
                delta = 10.0 ** rng.uniform(-12, -3)
                base[1] = base[0] + delta * base[2]
            A[b] = base
        elif kind == "zero":
            A[b] = rng.standard_normal((m, n))
            A[b, 0] = 0.0
    v = rng.standard_normal((nb, n)) * 10.0 ** rng.uniform(-1, 1, (nb, 1))
    return M, A, v


def _compare(M, A, v, iM, iA, iv, want_vc=True):
    got = _run(lanes_kernel(), M, A, v, iM, iA, iv, want_vc)
    ref = _run(run_items, M, A, v, iM, iA, iv, want_vc)
    np.testing.assert_array_equal(got[5], ref[5])  # status
    ok = ref[5] == _validation.STATUS_OK
    T = ref[0][ok]
    np.testing.assert_array_equal(got[4][ok], ref[4][ok])  # rank
    np.testing.assert_allclose(got[0][ok], T, rtol=1e-12)
    for k in (1, 2):  # T_c, T_a: relative to T (either may be tiny)
        assert np.all(np.abs(got[k][ok] - ref[k][ok]) <= 1e-9 * T + 1e-300)
    if want_vc:
        scale = np.abs(v[iv[ok]]).max(axis=-1, keepdims=True)
        assert np.all(np.abs(got[3][ok] - ref[3][ok]) <= 1e-7 * scale)
        # v_a written by the kernel: v - v_c to the bit, as numpy computes it
        np.testing.assert_array_equal(got[6][ok], v[iv[ok]] - got[3][ok])
    return got, ref


def test_generated_module_is_up_to_date():
    """src/roverimpact/_kernels/lanes.py is exactly what tools/gen_lanes_kernel.py writes."""
    spec = importlib.util.spec_from_file_location("gen", ROOT / "tools" / "gen_lanes_kernel.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    assert (ROOT / "src" / "roverimpact" / "_kernels" / "lanes.py").read_text() == gen.generate()


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(1, 24),
    m=st.integers(1, 9),
    nb=st.integers(1, 43),
    seed=st.integers(0, 2**32 - 1),
)
def test_lanes_agree_with_one_item_kernel(n, m, nb, seed):
    """Mixed full-rank, deficient, duplicated, nearly dependent and zero-row items."""
    rng = np.random.default_rng(seed)
    M, A, v = _batch(rng, nb, n, m, ["full", "deficient", "duplicate", "near", "zero"])
    idx = np.arange(nb)
    _compare(M, A, v, idx, idx, idx)


def test_lanes_match_svd_reference(rng):
    """T_c against the SVD of the whitened rows (numpy LAPACK), an independent method."""
    nb, n, m = 61, 18, 4
    M, A, v = _batch(rng, nb, n, m, ["full", "deficient", "duplicate"])
    idx = np.arange(nb)
    _, Tc, _, _, rank, status, _ = _run(lanes_kernel(), M, A, v, idx, idx, idx)
    assert np.all(status == 0)
    L = np.linalg.cholesky(M)
    Wt = np.linalg.solve(L, np.swapaxes(A, -1, -2))
    U, s, _ = np.linalg.svd(Wt, full_matrices=False)
    keep = s > 1e-9 * s[:, :1]
    u = np.einsum("bji,bj->bi", L, v)
    y = np.einsum("bji,bj->bi", U, u) * keep
    np.testing.assert_allclose(Tc, 0.5 * np.sum(y**2, axis=-1), rtol=1e-9)
    np.testing.assert_array_equal(rank, keep.sum(axis=-1))


def test_nearly_dependent_rows_use_the_pivoted_fallback():
    """Rows a, a + 1e-7 b, b: unpivoted Gram-Schmidt would keep a noise direction.

    The exact rank is 2 and T_c is the energy along span{a, b}. The lane kernel must send
    such items to the pivoted QR and return rank 2 and the exact T_c.
    """
    rng = np.random.default_rng(3)
    n, nb = 6, 16
    M = np.stack([random_spd(rng, n) for _ in range(nb)])
    a, b = rng.standard_normal((2, n))
    A = np.broadcast_to(np.stack([a, a + 1e-7 * b, b]), (nb, 3, n)).copy()
    v = rng.standard_normal((nb, n))
    idx = np.arange(nb)
    got, _ = _compare(M, A, v, idx, idx, idx)
    assert np.all(got[4] == 2)
    AB = np.stack([a, b])
    Tc_exact = [0.5 * (AB @ v[k]) @ np.linalg.solve(AB @ np.linalg.solve(M[k], AB.T), AB @ v[k])
                for k in range(nb)]
    np.testing.assert_allclose(got[1], Tc_exact, rtol=1e-6)


def test_bad_items_are_flagged_without_touching_their_neighbours(rng):
    """Non-SPD, asymmetric and non-finite items get their own status; others are exact."""
    nb, n, m = 29, 7, 3
    M, A, v = _batch(rng, nb, n, m, ["full"])
    M[3, 0, 0] = -1.0  # not positive definite
    M[9, 1, 2] += 1.0  # asymmetric
    M[11, 4, 4] = np.nan
    A[17, 1, 2] = np.inf
    v[20, 5] = np.nan
    M[25] = np.diag(np.r_[1.0, 1.0, 0.0, 1.0, 1.0, 1.0, 1.0])  # singular
    idx = np.arange(nb)
    got, _ = _compare(M, A, v, idx, idx, idx)
    status = got[5]
    assert status[3] == _validation.STATUS_NOT_PD and status[25] == _validation.STATUS_NOT_PD
    assert status[9] == _validation.STATUS_ASYMMETRIC_M
    assert status[11] == _validation.STATUS_NONFINITE_M
    assert status[17] == _validation.STATUS_NONFINITE_A and status[20] == _validation.STATUS_NONFINITE_V
    assert np.sum(status != 0) == 6


def test_shared_mass_matrix_and_broadcast_indices(rng):
    """One M for the whole batch (factor reused across blocks), repeated A and v items."""
    nb, n, m = 45, 18, 4
    M, A, v = _batch(rng, 5, n, m, ["full", "duplicate"])
    iM = np.zeros(nb, dtype=np.int64)
    iA = rng.integers(0, 5, nb)
    iv = np.arange(nb) % 5
    _compare(M, A, v, iM, iA, iv)
    # M switching in the middle of a block, and blocks of one repeated M
    iM = np.repeat(np.arange(5), 9)
    _compare(M, A, v, iM, iA, iv, want_vc=False)


def test_partition_uses_lanes_above_threshold_and_agrees(rng):
    """The public function gives the same numbers below and above LANES_MIN_BATCH."""
    nb = LANES_MIN_BATCH + 5
    M, A, v = _batch(rng, nb, 9, 3, ["full", "deficient"])
    big = ri.partition(M, A, v)
    for b in (0, 7, nb - 1):
        one = ri.partition(M[b], A[b], v[b])
        assert big.T_c[b] == pytest.approx(one.T_c, rel=1e-10, abs=1e-14 * one.T)
        assert big.rank[b] == one.rank
        np.testing.assert_allclose(big.v_c[b], one.v_c, rtol=1e-8, atol=1e-12)


def test_read_only_and_broadcast_inputs(rng):
    """Read-only arrays and zero-stride broadcast views go through the lane kernel."""
    nb, n, m = 33, 6, 2
    M, A, v = _batch(rng, nb, n, m, ["full"])
    ref = ri.partition(M, A, v)
    for arr in (M, A, v):
        arr.flags.writeable = False
    got = ri.partition(M, A, v)
    np.testing.assert_allclose(got.T_c, ref.T_c, rtol=1e-14)
    shared = ri.partition(np.broadcast_to(M[0], (nb, n, n)), A, v, want_velocities=False)
    one = ri.partition(M[0], A, v, want_velocities=False)
    np.testing.assert_allclose(shared.T_c, one.T_c, rtol=1e-13)
