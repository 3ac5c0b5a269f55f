"""Kinetic-energy partition: properties over random SPD systems and closed-form cases."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import roverimpact as ri
from roverimpact.energy import whitened
from roverimpact.exceptions import InputError

from .reference.systems import random_spd, rod_on_edge, two_masses
from .strategies import full_rank_rows, spd_matrices, vectors

REL = 1e-9


@st.composite
def systems(draw, max_n=30, max_m=8):
    """(M, A, v, rank) drawn entry by entry: A full rank, rank-deficient, or with
    duplicated rows; M with coordinates two decades apart (kg and kg m^2)."""
    n = draw(st.integers(1, max_n))
    m = draw(st.integers(1, max_m))
    kind = draw(st.sampled_from(["full", "deficient", "duplicate"]))
    M = draw(spd_matrices(n, decades=2.0))
    if kind == "full":
        A = draw(full_rank_rows(m, n))
        r = min(m, n)
    elif kind == "deficient":
        r = draw(st.integers(1, max(1, min(m, n) - 1))) if min(m, n) > 1 else 1
        A = draw(full_rank_rows(m, r)) @ draw(full_rank_rows(r, n))
    else:
        base = draw(full_rank_rows(m, n))
        A = np.vstack([base, 3.0 * base[: max(1, m // 2)]])
        r = min(m, n)
    v = draw(vectors(n, 10.0))
    assume(np.abs(v).max() > 1e-3)
    return M, A, v, r


def _rel(a, b, scale):
    return np.max(np.abs(np.asarray(a) - np.asarray(b))) / max(scale, 1e-300)


@settings(max_examples=150, deadline=None)
@given(systems())
def test_partition_properties(sys):
    """P_c^2 = P_c, v = v_c + v_a, M-orthogonality, T = T_c + T_a, A v_a = 0, rank."""
    M, A, v, r = sys
    p = ri.partition(M, A, v)
    T_ref = 0.5 * v @ M @ v
    assert p.T == pytest.approx(T_ref, rel=1e-10)
    assert p.T_c + p.T_a == pytest.approx(T_ref, rel=1e-9, abs=1e-12 * T_ref)
    assert p.T_c >= 0 and p.T_a >= 0
    assert p.rank == r == np.linalg.matrix_rank(A)
    np.testing.assert_allclose(p.v_c + p.v_a, v, rtol=0, atol=1e-12 * np.abs(v).max())
    # M-orthogonality of the two parts: v_c^T M v_a = 0
    assert abs(p.v_c @ M @ p.v_a) <= 1e-8 * T_ref + 1e-300
    # T_c from the velocity itself
    assert 0.5 * p.v_c @ M @ p.v_c == pytest.approx(p.T_c, rel=1e-7, abs=1e-10 * T_ref)
    # the admissible part satisfies the constraints
    Av_scale = np.abs(A).max() * np.abs(v).max() * np.sqrt(A.shape[1])
    assert np.abs(A @ p.v_a).max() <= 1e-8 * Av_scale
    # projector: idempotent and consistent with the kernel's v_c
    P = ri.projector(M, A)
    np.testing.assert_allclose(P @ P, P, atol=1e-7 * max(1.0, np.abs(P).max()))
    np.testing.assert_allclose(P @ v, p.v_c, atol=1e-7 * np.abs(v).max() * max(1.0, np.abs(P).max()))
    # M P_c is symmetric (P_c is M-orthogonal)
    MP = M @ P
    np.testing.assert_allclose(MP, MP.T, atol=1e-7 * np.abs(MP).max())


@settings(max_examples=100, deadline=None)
@given(systems(max_m=5), st.integers(0, 2**32 - 1))
def test_T_c_invariant_to_row_scaling_order_duplication(sys, seed):
    M, A, v, _ = sys
    rng = np.random.default_rng(seed)
    base = ri.partition(M, A, v).T_c
    scale = 10.0 ** rng.uniform(-3, 3, A.shape[0]) * rng.choice([-1, 1], A.shape[0])
    A2 = (A * scale[:, None])[rng.permutation(A.shape[0])]
    A3 = np.vstack([A, A[rng.integers(0, A.shape[0], 2)]])
    T = 0.5 * v @ M @ v
    for Ax in (A2, A3):
        assert ri.partition(M, Ax, v).T_c == pytest.approx(base, rel=1e-7, abs=1e-12 * T)


@settings(max_examples=100, deadline=None)
@given(systems())
def test_full_rank_matches_paper_formula(sys):
    """For full row rank, T_c = 1/2 (A v)^T (A M^-1 A^T)^-1 (A v) (papers' eq. 2-3)."""
    M, A, v, r = sys
    if r < A.shape[0]:
        return
    G = A @ np.linalg.solve(M, A.T)
    if np.linalg.cond(G) > 1e8:
        return
    Av = A @ v
    T_c = 0.5 * Av @ np.linalg.solve(G, Av)
    T = 0.5 * v @ M @ v
    assert ri.partition(M, A, v).T_c == pytest.approx(T_c, rel=1e-7, abs=1e-12 * T)
    # and the effective mass is the inverse Delassus matrix
    np.testing.assert_allclose(ri.effective_mass(M, A), np.linalg.inv(G), rtol=1e-6,
                               atol=1e-9 * np.abs(np.linalg.inv(G)).max())


def test_batched_equals_loop_and_broadcasts(rng):
    n, m, B = 9, 3, 40
    M = np.stack([random_spd(rng, n) for _ in range(B)])
    A = rng.standard_normal((B, m, n))
    A[5, 2] = A[5, 0] - A[5, 1]  # one rank-deficient item
    v = rng.standard_normal((B, n))
    p = ri.partition(M, A, v)
    assert p.T_c.shape == (B,) and p.v_c.shape == (B, n) and p.rank.shape == (B,)
    for b in range(B):
        q = ri.partition(M[b], A[b], v[b])
        assert p.T_c[b] == pytest.approx(q.T_c, rel=1e-12)
        assert p.rank[b] == q.rank
        np.testing.assert_allclose(p.v_c[b], q.v_c, rtol=1e-12, atol=1e-14)
    assert p.rank[5] == 2
    # broadcasting: one M, a (4, 5) grid of velocities, per-row-of-grid A
    M0 = M[0]
    A2 = rng.standard_normal((4, 1, m, n))
    v2 = rng.standard_normal((4, 5, n))
    q = ri.partition(M0, A2, v2)
    assert q.T_c.shape == (4, 5)
    assert q.T_c[2, 3] == pytest.approx(ri.partition(M0, A2[2, 0], v2[2, 3]).T_c, rel=1e-12)
    # projector and effective mass broadcast too
    assert ri.projector(M0, A2).shape == (4, 1, n, n)
    assert ri.effective_mass(M, A).shape == (B, m, m)


def test_small_batches_agree_with_the_lane_path(rng):
    """Batches below ``LANES_MIN_BATCH`` run the one-item kernel and return views of its
    output rows: the same items in a batch large enough for the lane kernel give the same
    numbers to rounding, v_a is v - v_c to the bit, and the types are the lane path's."""
    from roverimpact.energy import LANES_MIN_BATCH

    n, m, k = 9, 3, 5
    M = np.stack([random_spd(rng, n) for _ in range(k)])
    A = rng.standard_normal((k, m, n))
    A[2, 2] = A[2, 0] + 2.0 * A[2, 1]  # a dependent row
    v = rng.standard_normal((k, n))
    reps = -(-LANES_MIN_BATCH // k)
    big = ri.partition(np.tile(M, (reps, 1, 1)), np.tile(A, (reps, 1, 1)), np.tile(v, (reps, 1)))
    for small in (ri.partition(M, A, v), ri.partition(M, A, v, want_velocities=False)):
        for f in ("T", "T_c", "T_a"):
            got, want = getattr(small, f), getattr(big, f)[:k]
            assert got.dtype == want.dtype == np.float64 and got.shape == (k,)
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-14)
        assert small.rank.dtype == np.int64 and small.rank.tolist() == big.rank[:k].tolist()
        assert small.rank[2] == 2
    small = ri.partition(M, A, v)
    np.testing.assert_allclose(small.v_c, big.v_c[:k], rtol=1e-11, atol=1e-13)
    np.testing.assert_array_equal(small.v_a, v - small.v_c)
    # broadcast: one M and A, a grid of velocities; v_a against the broadcast v
    v2 = rng.standard_normal((2, 3, n))
    p = ri.partition(M[0], A[0], v2)
    assert p.v_c.shape == p.v_a.shape == (2, 3, n) and p.T_c.shape == (2, 3)
    np.testing.assert_array_equal(p.v_a, v2 - p.v_c)
    assert p.T_c[1, 2] == pytest.approx(ri.partition(M[0], A[0], v2[1, 2]).T_c, rel=1e-12)


def test_kernel_agrees_with_svd_reference(rng):
    """Second method: compiled pivoted-QR kernel vs LAPACK SVD projector, batched."""
    n, m, B = 18, 4, 200
    M = np.stack([random_spd(rng, n, spread=3) for _ in range(B)])
    A = rng.standard_normal((B, m, n))
    A[::3, 3] = 2 * A[::3, 0] - A[::3, 1]
    v = rng.standard_normal((B, n))
    p = ri.partition(M, A, v)
    L, _, U, mask = whitened(M, A, ri.energy.RTOL)
    u = np.einsum("bji,bj->bi", L, v)
    Uu = np.einsum("bji,bj->bi", U, u) * mask
    np.testing.assert_allclose(p.T_c, 0.5 * np.sum(Uu**2, axis=-1), rtol=1e-9)
    np.testing.assert_array_equal(p.rank, mask.sum(-1))


def test_closed_form_cases():
    c = two_masses()
    p = ri.partition(c.M, c.A, c.v)
    assert p.T_c == pytest.approx(c.T_c_minus, rel=1e-13)
    # the admissible part is the motion of the centre of mass
    u_G = (c.M[0, 0] * c.v[0] + c.M[1, 1] * c.v[1]) / np.trace(c.M)
    np.testing.assert_allclose(p.v_a, [u_G, u_G], rtol=1e-13)
    r = rod_on_edge()
    assert ri.partition(r.M, r.A, r.v).T_c == pytest.approx(r.T_c_minus, rel=1e-13)
    assert ri.effective_mass(r.M, r.A[0]) == pytest.approx(r.M[0, 0] / 4, rel=1e-13)


def test_effective_mass_single_row_and_rigid_body():
    """A free rigid body hit at r along n: 1/m_eff = 1/m + (r x n)^T I^-1 (r x n)."""
    m = 7.0
    I = np.diag([0.3, 0.5, 0.7])
    r = np.array([0.2, -0.1, 0.4])
    nrm = np.array([0.0, 0.6, 0.8])
    M = np.block([[m * np.eye(3), np.zeros((3, 3))], [np.zeros((3, 3)), I]])
    # point velocity = v_G + w x r = v_G - [r]x w ; row for n: [n, r x n]
    row = np.concatenate([nrm, np.cross(r, nrm)])
    rn = np.cross(r, nrm)
    ref = 1.0 / (1 / m + rn @ np.linalg.solve(I, rn))
    assert ri.effective_mass(M, row) == pytest.approx(ref, rel=1e-13)


def test_zero_rows_and_empty():
    M = np.diag([1.0, 2.0])
    v = np.array([1.0, 1.0])
    p = ri.partition(M, np.zeros((2, 2)), v)
    assert p.rank == 0 and p.T_c == 0.0 and p.T_a == pytest.approx(1.5)
    p = ri.partition(M, np.zeros((0, 2)), v)
    assert p.rank == 0 and p.T_c == 0.0
    p = ri.partition(M, [[0.0, 0.0], [1.0, 0.0]], v)
    assert p.rank == 1 and p.T_c == pytest.approx(0.5)


def test_want_velocities_false_matches(rng):
    M = random_spd(rng, 6)
    A = rng.standard_normal((2, 6))
    v = rng.standard_normal(6)
    a = ri.partition(M, A, v)
    b = ri.partition(M, A, v, want_velocities=False)
    assert b.v_c is None and b.T_c == a.T_c and b.rank == a.rank


def test_single_system_fast_path_equals_the_batched_path():
    """One unbatched float64 system skips the batch bookkeeping: the same numbers to the
    bit as the same system in a batch of one, and the same errors."""
    from roverimpact import energy

    rng = np.random.default_rng(7)
    for n, m in ((1, 1), (6, 2), (16, 5)):
        X = rng.standard_normal((n, n))
        M = X @ X.T + n * np.eye(n)
        A = rng.standard_normal((m, n))
        v = rng.standard_normal(n)
        assert energy._partition_single(M, A, v, 1e-9, True) is not None  # the fast path
        one, batch = ri.partition(M, A, v), ri.partition(M[None], A[None], v[None])
        for f in ("T", "T_c", "T_a", "rank"):
            assert getattr(one, f) == getattr(batch, f)[0]
        np.testing.assert_array_equal(one.v_c, batch.v_c[0])
        np.testing.assert_array_equal(one.v_a, batch.v_a[0])
    bad = np.diag([1.0, -1.0])
    with pytest.raises(InputError) as e1:
        ri.partition(bad, np.eye(2)[:1], np.ones(2))
    with pytest.raises(InputError) as e2:
        ri.partition(bad.tolist(), [[1.0, 0.0]], [1.0, 1.0])       # the generic path
    assert str(e1.value) == str(e2.value)


@pytest.mark.parametrize("M, A, v", [
    (np.eye(3)[:2], np.ones((1, 3)), np.ones(3)),             # M not square
    (np.eye(3), np.ones((1, 2)), np.ones(3)),                  # A with 2 columns
    (np.eye(3), np.ones((1, 3)), np.ones(4)),                  # v too long
    (np.eye(3), np.ones((1, 3)), np.ones(2)),                  # v too short
    (np.empty((0, 0)), np.empty((1, 0)), np.empty(0)),         # no degrees of freedom
    (np.eye(3)[:, :2].copy(), np.ones((1, 2)), np.ones(2)),    # M (3, 2)
])
def test_single_system_of_mismatched_shapes_gets_the_general_error(M, A, v):
    """The one-system kernel checks the shapes itself (it reads nothing out of bounds):
    mismatched ones go to the general path, whose message is the one float32 arrays
    (never the kernel's type) get."""
    from roverimpact import energy

    assert energy._partition_single(M, A, v, 1e-9, True) is None
    with pytest.raises(InputError) as fast:
        ri.partition(M, A, v)
    with pytest.raises(InputError) as generic:
        ri.partition(M.astype(np.float32), A.astype(np.float32), v.astype(np.float32))
    assert str(fast.value) == str(generic.value)


@pytest.mark.filterwarnings("ignore::PendingDeprecationWarning")  # np.matrix
def test_single_system_of_other_types_takes_the_general_path():
    """Lists, other dtypes, a Fortran layout, np.matrix, a zero-row A: the same result as
    float64 C arrays."""
    rng = np.random.default_rng(5)
    M = random_spd(rng, 4)
    A = rng.standard_normal((2, 4)).astype(np.float32).astype(np.float64)
    v = rng.standard_normal(4).astype(np.float32).astype(np.float64)
    ref = ri.partition(M, A, v)
    for args in ((M.tolist(), A.tolist(), v.tolist()), (np.asmatrix(M), A, v),
                 (M, A.astype(np.float32), v.astype(np.float32)), (np.asfortranarray(M), A, v)):
        got = ri.partition(*args)
        assert got.T_c == pytest.approx(ref.T_c, rel=1e-12)
        np.testing.assert_allclose(got.v_c, ref.v_c, rtol=1e-12, atol=1e-14)
    none = ri.partition(M, np.empty((0, 4)), v)
    assert none.T_c == 0.0 and none.rank == 0 and none.T_a == pytest.approx(ref.T)


def test_batches_and_lists_never_try_the_one_system_kernel(monkeypatch):
    """Only unbatched float64 ndarrays try the one-system kernel: anything else would get
    numba's TypeError there first, whose message alone costs tens of microseconds (a
    batch of 2 took 100 us instead of 16 us when it did)."""
    from roverimpact import energy

    tried = []
    real = energy._partition_single
    monkeypatch.setattr(energy, "_partition_single", lambda *a: tried.append(a) or real(*a))
    rng = np.random.default_rng(2)
    M = random_spd(rng, 5)
    A = rng.standard_normal((2, 5))
    v = rng.standard_normal(5)
    for args in ((M[None], A[None], v[None]), (M, A[None], v), (M, A, v[None]),
                 (M.tolist(), A, v), (M, A.astype(np.float32), v), (M, A[0], v)):
        ri.partition(*args)
    assert not tried
    ri.partition(M, A, v)
    assert len(tried) == 1


def test_transposes_and_column_slices_take_the_one_system_kernel_as_a_copy(monkeypatch):
    """A Fortran-ordered M (a transpose, scipy's output), a column slice of a Jacobian or
    a strided v: copied to C order for the one-system kernel, never handed to numba as
    they are (its TypeError cost 225 us a call against 6 us, and a TypeError from there
    would fall to the general path)."""
    from roverimpact import energy

    tried, general = [], []
    real, real_prepare = energy._partition_single, energy.prepare
    monkeypatch.setattr(energy, "_partition_single", lambda *a: tried.append(a) or real(*a))
    monkeypatch.setattr(energy, "prepare", lambda *a: general.append(a) or real_prepare(*a))
    rng = np.random.default_rng(5)
    M = random_spd(rng, 6)
    M = (M + M.T) / 2  # M.T == M to the bit
    A = rng.standard_normal((2, 6))
    v = rng.standard_normal(6)
    ref = ri.partition(M, A, v)
    wide = np.hstack([A, A])
    for args in ((np.asfortranarray(M), A, v), (M, wide[:, :6], v),
                 (M, A, np.repeat(v, 2)[::2]), (M.T, np.asfortranarray(A), v)):
        assert not all(a.flags.c_contiguous for a in args)
        p = ri.partition(*args)
        assert p.T_c == ref.T_c and p.rank == ref.rank
        np.testing.assert_array_equal(p.v_c, ref.v_c)
    assert len(tried) == 5 and not general
    assert all(a.flags.c_contiguous for t in tried for a in t[:3])


def _unaligned(x):
    """A copy of ``x`` whose data starts one byte into a buffer: not aligned for float64."""
    buf = np.zeros(x.nbytes + 1, dtype=np.uint8)
    y = np.frombuffer(buf[1:].data, dtype=x.dtype).reshape(x.shape)
    y[...] = x
    assert not y.flags.aligned
    return y


def test_one_system_kernel_takes_only_aligned_c_arrays_through_its_entry_point(monkeypatch):
    """The one-system path calls the compiled kernel's entry point, which reads an array's
    memory as its signature says it is, without numba's checks: an unaligned, read-only,
    Fortran or strided input reaches it as an aligned C array (a copy where needed) and
    gives the bits a plain C array gives."""
    from roverimpact import energy
    from roverimpact._kernels.partition import partition_kernel

    seen = []
    real = energy._partition_single

    def spy(M, A, v, *rest):
        for x in (M, A, v):
            seen.append(x.flags.c_contiguous and x.flags.aligned and x.dtype == np.float64)
        return real(M, A, v, *rest)

    monkeypatch.setattr(energy, "_partition_single", spy)
    rng = np.random.default_rng(8)
    M = random_spd(rng, 7)
    M = (M + M.T) / 2
    A = rng.standard_normal((3, 7))
    v = rng.standard_normal(7)
    ref = ri.partition(M, A, v)
    ro = [x.copy() for x in (M, A, v)]
    for x in ro:
        x.flags.writeable = False
    for args in ((_unaligned(M), _unaligned(A), _unaligned(v)), tuple(ro),
                 (M.T, A, v), (M, np.hstack([A, A])[:, :7], np.repeat(v, 2)[::2])):
        for want in (True, False):
            p = ri.partition(*args, want_velocities=want)
            assert (p.T, p.T_c, p.T_a, p.rank) == (ref.T, ref.T_c, ref.T_a, ref.rank)
            if want:
                np.testing.assert_array_equal(p.v_c, ref.v_c)
                np.testing.assert_array_equal(p.v_a, ref.v_a)
    assert seen and all(seen)
    if partition_kernel.compiled:  # ROVERIMPACT_KERNELS=python runs the Python code
        assert partition_kernel.unchecked(1) is not partition_kernel.get(1)


def test_unchecked_kernel_falls_back_to_the_dispatcher():
    """Where numba does not lay out a dispatcher's overloads as expected (none, several,
    no entry point), :meth:`Kernel.unchecked` returns the dispatcher, which checks."""
    from roverimpact._kernels import _jit

    class Several:
        def __init__(self):
            self.overloads = {1: object(), 2: object()}

    class NoEntry:
        def __init__(self):
            self.overloads = {1: object()}

    class Bare:
        pass

    for d in (Several(), NoEntry(), Bare()):
        assert _jit._entry_point(d) is d

    class Result:
        entry_point = "the entry"

    class One:
        def __init__(self):
            self.overloads = {1: Result()}

    assert _jit._entry_point(One()) == "the entry"


def _small_batch_cases():
    """(label, args, kwargs, takes the small-batch fast path) for
    :func:`test_small_batch_fast_path_equals_the_general_path`."""
    rng = np.random.default_rng(11)
    n, m, k = 6, 2, 3
    M = np.stack([random_spd(rng, n) for _ in range(64)])
    A = rng.standard_normal((64, m, n))
    v = rng.standard_normal((64, n))
    M3, A3, v3 = M[:k], A[:k], v[:k]

    def item1(arr, fn):  # a copy of arr with item 1 changed by fn
        out = arr.copy()
        out[1] = fn(out[1])
        return out

    dep = item1(A3, lambda a: np.stack([a[0], 2.0 * a[0]]))
    huge_M, huge_A = item1(M3, lambda x: 2.0 * np.eye(n)), item1(A3, lambda a: np.eye(n)[1:3])
    near_v, over_v = item1(v3, lambda x: 0 * x), item1(v3, lambda x: 0 * x)
    near_v[1, 0] = 0.9e154  # T = 8.1e307, just below T_LIMIT (T_c = 0)
    over_v[1, 0] = 1e154  # 2 T = 2e308 overflows
    asym = item1(M3, lambda x: x + np.triu(np.ones((n, n)), 1))
    wide_A = np.concatenate([A3, A3], axis=-1)
    return [
        ("equal batches", (M3, A3, v3), {}, True),
        ("no velocities", (M3, A3, v3), {"want_velocities": False}, True),
        ("rtol", (M3, A3, v3), {"rtol": 1e-3}, True),
        ("2-D batch", (M[:6].reshape(2, 3, n, n), A[:6].reshape(2, 3, m, n),
                       v[:6].reshape(2, 3, n)), {}, True),
        ("one item", (M[:1], A[:1], v[:1]), {}, True),
        ("63 items", (M[:63], A[:63], v[:63]), {}, True),
        ("Fortran-ordered M", (np.asfortranarray(M3), A3, v3), {}, True),
        ("column slice of A, strided v", (M3, wide_A[..., :n], np.repeat(v3, 2, -1)[:, ::2]),
         {}, True),
        ("dependent rows in item 1", (M3, dep, v3), {}, True),
        ("zero rows in item 1", (M3, item1(A3, lambda a: 0 * a), v3), {}, True),
        ("rows of 1e-200 in item 1", (M3, item1(A3, lambda a: 1e-200 * a), v3), {}, True),
        ("T just below T_LIMIT", (huge_M, huge_A, near_v), {}, True),
        ("T overflows, item 1", (huge_M, huge_A, over_v), {}, True),
        ("NaN in v, item 1", (M3, A3, item1(v3, lambda x: x + np.nan)), {}, True),
        ("inf in A, item 1", (M3, item1(A3, lambda a: a + np.inf), v3), {}, True),
        ("NaN in M, item 1", (item1(M3, lambda x: x + np.nan), A3, v3), {}, True),
        ("M not SPD, item 1", (item1(M3, lambda x: -x), A3, v3), {}, True),
        ("M not symmetric, item 1", (asym, A3, v3), {}, True),
        ("energy overflows, item 1", (item1(M3, lambda x: 1e300 * x),
                                      A3, item1(v3, lambda x: 1e10 * x)), {}, True),
        ("64 items (the lanes)", (M, A, v), {}, False),
        ("shared M", (M3[0], A3, v3), {}, True),
        ("shared A", (M3, A3[0], v3), {}, True),
        ("shared M and v", (M3[0], A3, v3[0]), {}, True),
        ("shared M, 2-D batch, no velocities", (M3[0], A[:6].reshape(2, 3, m, n),
                                                v[:6].reshape(2, 3, n)),
         {"want_velocities": False}, True),
        ("shared M, NaN in v, item 1", (M3[0], A3, item1(v3, lambda x: x + np.nan)), {}, True),
        ("shared M not SPD", (-M3[0], A3, v3), {}, True),
        ("shared A of 1e-200", (M3, 1e-200 * A3[0], v3), {}, True),
        ("shared M, A and v", (M3[0], A3[0], v3[0]), {}, False),
        ("v of batch shape (1,)", (M3, A3, v3[:1]), {}, False),
        ("A of batch shape (3,) against (2, 3)", (M[:6].reshape(2, 3, n, n), A3,
                                                  v[:6].reshape(2, 3, n)), {}, False),
        ("float32", (M3.astype(np.float32), A3.astype(np.float32), v3.astype(np.float32)),
         {}, False),
        ("lists", (M3.tolist(), A3.tolist(), v3.tolist()), {}, False),
        ("no rows", (M3, A3[:, :0], v3), {}, False),
        ("empty batch", (M3[:0], A3[:0], v3[:0]), {}, False),
        ("A of the wrong width", (M3, A3[..., :-1].copy(), v3), {}, False),
        ("v of the wrong length", (M3, A3, v3[..., :-1].copy()), {}, False),
        ("batch shapes that differ", (M3, A3[:2], v3), {}, False),
    ]


@pytest.mark.parametrize("label, args, kwargs, fast", _small_batch_cases(),
                         ids=[c[0] for c in _small_batch_cases()])
def test_small_batch_fast_path_equals_the_general_path(monkeypatch, label, args, kwargs,
                                                        fast):
    """Batches of 1 to 63 items of float64 arrays of one batch shape (or one M, A or v for
    all items) skip the broadcasting bookkeeping (``energy._partition_small``; 2 items, n = 18, m = 4: 47 us a call before,
    about 18 after, ``benchmarks/bench_single.py``): the same result to the bit, and the
    same error, as the general path, for inputs that take it and inputs that do not."""
    import warnings

    from roverimpact import energy

    taken = []
    real = energy._partition_small

    def spy(*a):
        try:
            out = real(*a)
        except InputError:
            taken.append(True)
            raise
        taken.append(out is not None)
        return out

    def run():
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                return ri.partition(*args, **kwargs)
        except InputError as e:
            return f"InputError: {e}"

    monkeypatch.setattr(energy, "_partition_small", spy)
    got = run()
    assert any(taken) == fast, label
    monkeypatch.setattr(energy, "_partition_small", lambda *a: None)  # the general path
    want = run()
    if isinstance(want, str) or isinstance(got, str):
        assert got == want
        return
    for f in ("T", "T_c", "T_a", "v_c", "v_a", "rank"):
        x, y = getattr(got, f), getattr(want, f)
        if y is None:
            assert x is None, f
            continue
        assert type(x) is type(y) and x.dtype == y.dtype and x.shape == y.shape, f
        assert x.tobytes() == y.tobytes(), f  # to the bit (-0.0 too)


def test_small_batch_fast_path_against_the_textbook_formula():
    """The small-batch path's numbers against T_c = 1/2 (A v)^T (A M^-1 A^T)^-1 (A v) and
    v_c = M^-1 A^T (A M^-1 A^T)^-1 A v by numpy's LAPACK, item by item (full-rank rows),
    for a (2, 3) batch."""
    rng = np.random.default_rng(12)
    n, m = 7, 3
    M = np.stack([random_spd(rng, n) for _ in range(6)]).reshape(2, 3, n, n)
    A = rng.standard_normal((2, 3, m, n))
    v = rng.standard_normal((2, 3, n))
    p = ri.partition(M, A, v)
    assert p.T_c.shape == p.rank.shape == (2, 3) and p.v_c.shape == (2, 3, n)
    for i in range(2):
        for j in range(3):
            Mi, Ai, vi = M[i, j], A[i, j], v[i, j]
            MiA = np.linalg.solve(Mi, Ai.T)
            lam = np.linalg.solve(Ai @ MiA, Ai @ vi)
            T = 0.5 * vi @ Mi @ vi
            assert p.T[i, j] == pytest.approx(T, rel=1e-12)
            assert p.T_c[i, j] == pytest.approx(0.5 * (Ai @ vi) @ lam, rel=1e-9)
            assert p.T_a[i, j] == pytest.approx(T - p.T_c[i, j], rel=1e-9, abs=1e-12 * T)
            assert p.rank[i, j] == m
            np.testing.assert_allclose(p.v_c[i, j], MiA @ lam, rtol=1e-9, atol=1e-12)
            np.testing.assert_array_equal(p.v_a[i, j], vi - p.v_c[i, j])


def test_single_system_result_is_a_normal_partition():
    """The one-system path builds its result without ``__init__``: the same type, fields,
    repr and frozenness as a Partition made the usual way."""
    import dataclasses

    rng = np.random.default_rng(3)
    M = random_spd(rng, 4)
    A = rng.standard_normal((2, 4))
    v = rng.standard_normal(4)
    p = ri.partition(M, A, v)
    assert type(p) is ri.Partition
    q = ri.Partition(**{f.name: getattr(p, f.name) for f in dataclasses.fields(p)})
    assert repr(p) == repr(q)
    assert vars(p).keys() == vars(q).keys()
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.T_c = 0.0
    assert isinstance(p.T_c, np.float64) and isinstance(p.rank, np.int64)
    # a Fortran-ordered (not C-contiguous) system takes the general path: same numbers
    pf = ri.partition(np.asfortranarray(M), np.asfortranarray(A), v)
    assert pf.T_c == pytest.approx(p.T_c, rel=1e-14)


# ----------------------------------------------------------------------------------------
# Effective mass of single rows, free and with held rows (the compiled row_masses)
# ----------------------------------------------------------------------------------------


def held_reference(M, a, B):
    """A second method: 1 / (a N a^T), N = M^-1 - M^-1 B^T (B M^-1 B^T)^+ B M^-1 with
    explicit inverses and numpy's pseudo-inverse (SVD), and 1 / (a M^-1 a^T)."""
    Mi = np.linalg.inv(M)
    N = Mi - Mi @ B.T @ np.linalg.pinv(B @ Mi @ B.T, rcond=1e-10) @ B @ Mi
    return 1.0 / (a @ N @ a), 1.0 / (a @ Mi @ a)


@settings(max_examples=60, deadline=None)
@given(st.integers(2, 9).flatmap(lambda n: st.tuples(
    spd_matrices(n, decades=2.0), full_rank_rows(1, n),
    st.integers(0, n - 2).flatmap(lambda p: full_rank_rows(p, n)) if n > 2
    else st.just(np.zeros((0, n))),
    st.integers(0, 2**32 - 1))))
def test_row_masses_match_the_schur_complement(args):
    """m_eff with held rows B (some of them redundant) and without, against
    held_reference; the same numbers from effective_mass."""
    from roverimpact.energy import row_masses

    M, a, B, seed = args
    a = a[0]
    rng = np.random.default_rng(seed)
    if len(B):  # a redundant held row: a combination of the others
        B = np.vstack([B, rng.standard_normal(len(B)) @ B])
    m_eff, m_free = row_masses(M, a, B)
    ref_eff, ref_free = held_reference(M, a, B)
    assert m_free == pytest.approx(ref_free, rel=1e-9)
    if ref_free / ref_eff < 1e-8:  # a (nearly) in the span of B: blocked, or all but
        assert m_eff > 1e6 * m_free  # (the reference is inf or rounding)
    else:
        assert m_eff == pytest.approx(ref_eff, rel=1e-7)
    assert m_eff >= m_free * (1 - 1e-12)  # holding rows never lowers the mass
    assert ri.effective_mass(M, a, held=B) == m_eff
    assert ri.effective_mass(M, a) == m_free


def test_row_masses_closed_forms():
    """A 3 kg point mass hit along (0, 0.6, 0.8): 3 kg free; with its vertical motion
    held, 1 / (0.6^2 / 3) kg; with both other directions held (the row blocked), inf. A
    free rigid body hit at r along n: 1/m_eff = 1/m + (r x n)^T I^-1 (r x n)."""
    from roverimpact.energy import row_masses

    M = 3.0 * np.eye(3)
    a = np.array([0.0, 0.6, 0.8])
    assert row_masses(M, a) == (pytest.approx(3.0, rel=1e-14), pytest.approx(3.0, rel=1e-14))
    m_eff, m_free = row_masses(M, a, [0.0, 0.0, 1.0])
    assert m_eff == pytest.approx(3.0 / 0.36, rel=1e-13) and m_free == pytest.approx(3.0)
    assert row_masses(M, a, [[0.0, 1.0, 0.0], [0.0, 0.0, 2.0]])[0] == np.inf
    assert row_masses(M, a, [[0.0, 1.0, 0.0], [0.0, 1.0, 0.0]])[0] == pytest.approx(3.0 / 0.64)
    m, I = 7.0, np.diag([0.3, 0.5, 0.7])
    r, nrm = np.array([0.2, -0.1, 0.4]), np.array([0.0, 0.6, 0.8])
    Mb = np.block([[m * np.eye(3), np.zeros((3, 3))], [np.zeros((3, 3)), I]])
    rn = np.cross(r, nrm)
    ref = 1.0 / (1 / m + rn @ np.linalg.solve(I, rn))
    assert row_masses(Mb, np.concatenate([nrm, rn]))[1] == pytest.approx(ref, rel=1e-13)


def test_row_masses_batches_and_broadcasting():
    """A batch equals its items one by one, with M, a or the held rows shared
    (broadcast), and batch shapes of more than one axis."""
    from roverimpact.energy import row_masses

    rng = np.random.default_rng(11)
    k, n, p = 70, 7, 3
    M = np.stack([random_spd(rng, n) for _ in range(k)])
    a = rng.standard_normal((k, n))
    B = rng.standard_normal((k, p, n))
    me, mf = row_masses(M, a, B)
    assert me.shape == mf.shape == (k,)
    for i in (0, 33, k - 1):
        one = row_masses(M[i], a[i], B[i])
        assert (me[i], mf[i]) == pytest.approx(one, rel=1e-14)
        assert me[i] == pytest.approx(held_reference(M[i], a[i], B[i])[0], rel=1e-9)
    shared_M = row_masses(M[0], a, B[0])
    shared_rows = row_masses(M, a[0], B[0])
    for i in (1, 50):
        assert shared_M[0][i] == pytest.approx(row_masses(M[0], a[i], B[0])[0], rel=1e-14)
        assert shared_rows[0][i] == pytest.approx(row_masses(M[i], a[0], B[0])[0], rel=1e-14)
    grid = row_masses(M[:6].reshape(2, 3, n, n), a[:6].reshape(2, 3, n), B[0])
    assert grid[0].shape == (2, 3)
    assert grid[0][1, 2] == pytest.approx(row_masses(M[5], a[5], B[0])[0], rel=1e-14)
    m_eff, m_free = row_masses(M[0], a[0])
    assert isinstance(m_eff, np.float64) and m_eff == m_free
    for k in (3, 70):  # no held rows (an empty set): the free mass exactly, on both paths
        got = row_masses(M[:k], a[:k], np.zeros((k, 0, n)))
        np.testing.assert_array_equal(got[0], got[1])
        np.testing.assert_array_equal(got[1], row_masses(M[:k], a[:k])[1])


def _stack(good, bad, k):
    """``k`` items: ``good`` everywhere but item 1, which is ``bad``."""
    out = np.repeat(np.asarray(good, float)[None], k, axis=0)
    out[1] = bad
    return out


@pytest.mark.parametrize("k", [2, 70])  # numpy and partition / the compiled kernel
@pytest.mark.parametrize("call, message", [
    (lambda M, a, B, k: (M, _stack(a, 0.0, k), B), "A is a zero row (batch index 1)"),
    (lambda M, a, B, k: (M, _stack(a, np.nan, k), B), "A contains NaN or inf (batch index 1)"),
    (lambda M, a, B, k: (M, a, _stack(B, np.inf, k)), "held contains NaN or inf (batch index 1)"),
    (lambda M, a, B, k: (_stack(M, -M, k), a, B), "M is not positive definite (batch index 1"),
    (lambda M, a, B, k: (_stack(M, M + np.triu(np.ones((3, 3)), 1), k), a, B),
     "M is not symmetric (batch index 1)"),
    (lambda M, a, B, k: (_stack(M, M * np.nan, k), a, B), "M contains NaN or inf (batch index 1)"),
    (lambda M, a, B, k: (M, a, np.ones((k, 1, 4))), "held must have shape (..., p, n) with n = 3"),
    (lambda M, a, B, k: (M, np.ones((k, 4)), B), "A must have shape"),
    (lambda M, a, B, k: (M[None].repeat(k, 0), a[None].repeat(k + 1, 0), B),
     "batch shapes do not broadcast"),
    (lambda M, a, B, k: (M, _stack(a, 1e200, k), B),
     "a M^-1 a^T of row A overflows float64 (batch index 1)"),
])
def test_row_masses_bad_input(call, message, k):
    """One clear error naming the input and the item, from both paths."""
    from roverimpact.energy import row_masses

    M = np.diag([1.0, 2.0, 3.0])
    a = np.array([1.0, 0.0, 0.0])
    B = np.array([[0.0, 1.0, 0.0]])
    with pytest.raises(InputError) as exc:
        row_masses(*call(M, a, B, k))
    assert message in str(exc.value)
    with pytest.raises(InputError, match="rtol"):
        row_masses(M, a, B, rtol=0.0)


@pytest.mark.parametrize("k", [2, 70])
def test_row_masses_check_M_without_held_rows(k):
    """Without held rows too, a mass matrix that is not symmetric is an error (numpy's
    Cholesky reads one triangle only)."""
    from roverimpact.energy import row_masses

    M = np.diag([1.0, 2.0, 3.0])
    bad = _stack(M, M + np.triu(np.ones((3, 3)), 1), k)
    with pytest.raises(InputError, match=r"M is not symmetric \(batch index 1\)"):
        row_masses(bad, [1.0, 0.0, 0.0])
    with pytest.raises(InputError, match=r"M is not symmetric \(batch index 1\)"):
        ri.effective_mass(bad, [1.0, 0.0, 0.0])


def test_row_masses_small_batches_and_the_kernel_agree():
    """Below LANES_MIN_BATCH items numpy's LAPACK and the partition; from it on the
    compiled kernel: the same masses to rounding, with redundant and blocking held rows."""
    from roverimpact import energy

    rng = np.random.default_rng(4)
    k, n, p = energy.LANES_MIN_BATCH, 9, 4
    M = np.stack([random_spd(rng, n) for _ in range(k)])
    a = rng.standard_normal((k, n))
    B = rng.standard_normal((k, p, n))
    B[::3, -1] = B[::3, 0] - 2.0 * B[::3, 1]  # a redundant held row
    B[1::5, 0] = 3.0 * a[1::5]  # a held row along a: blocked
    big = energy.row_masses(M, a, B)
    for lo in range(0, k, 16):
        small = energy.row_masses(M[lo:lo + 16], a[lo:lo + 16], B[lo:lo + 16])
        for got, ref in zip(small, big, strict=True):
            ref = ref[lo:lo + 16]
            assert np.array_equal(np.isinf(got), np.isinf(ref))
            fin = np.isfinite(ref)
            np.testing.assert_allclose(got[fin], ref[fin], rtol=1e-12)
    assert np.isinf(big[0][1::5]).all() and np.isfinite(big[1]).all()
