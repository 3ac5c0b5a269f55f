"""The core never returns inf or NaN for finite input: an energy beyond float64 is refused,
complex arrays are refused (they were cast with a ComplexWarning, the imaginary part lost).

Reference: the closed form T = 1/2 m v^2 of a point mass, and float64's largest number.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import roverimpact as ri
from roverimpact.contact import get_law
from roverimpact.energy import T_LIMIT
from roverimpact.exceptions import InputError
from roverimpact.frictional import frictional_impact


def test_limit_is_half_the_largest_float():
    assert T_LIMIT == np.finfo(np.float64).max / 2  # 2 T = |L^T v|^2 is a float64


@pytest.mark.parametrize("v", [1e150, 1.3e154])  # 1/2 v^2 = 5e299, 8.45e307 < T_LIMIT
def test_energies_up_to_the_limit_are_computed(v):
    p = ri.partition(np.eye(2), [[1.0, 0.0]], [v, 0.0])
    assert np.isfinite(p.T) and p.T == pytest.approx(0.5 * v * v, rel=1e-12)
    assert p.T_c == pytest.approx(p.T, rel=1e-12) and np.isfinite(p.v_c).all()


@pytest.mark.parametrize(("m", "v"), [(1.0, 1.4e154), (1e300, 1.4e4), (1e300, 1e300)])
def test_an_energy_beyond_float64_is_refused(m, v):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow RuntimeWarning on the way either
        with pytest.raises(InputError, match="overflows"):
            ri.partition(m * np.eye(2), [[1.0, 0.0]], [v, 0.0])
        with pytest.raises(InputError, match="overflows"):
            ri.impulsive_impact(m * np.eye(2), [[1.0, 0.0]], [-v, 0.0], restitution=0.5)


@pytest.mark.parametrize("n", [20, 70])  # the one-item kernel, the lane kernel (64 and more)
def test_the_overflowing_item_of_a_batch_is_named(n):
    M = np.broadcast_to(np.eye(2), (n, 2, 2)).copy()
    M[7] *= 1e300
    v = np.full((n, 2), 1e5)
    with pytest.raises(InputError, match="batch index 7"):
        ri.partition(M, [[1.0, 0.0]], v)
    ok = ri.partition(M[:7], [[1.0, 0.0]], v[:7])
    assert np.all(np.isfinite(ok.T))


@pytest.mark.parametrize("call", [
    lambda: ri.partition(np.eye(2) * (1 + 1j), [[1.0, 0.0]], [1.0, 0.0]),
    lambda: ri.partition(np.eye(2), [[1.0, 1j]], [1.0, 0.0]),
    lambda: ri.partition(np.eye(2), [[1.0, 0.0]], np.array([1.0, 0.0], complex)),
    lambda: ri.effective_mass(np.eye(2), np.array([1.0, 0.0], complex)),
    lambda: ri.impulsive_impact(np.eye(2), [[1.0, 0.0]], [-1.0, 0.0], restitution=0.5 + 0j),
])
def test_complex_arrays_are_refused(call):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(InputError, match="complex"):
            call()


@pytest.mark.parametrize("call", [
    lambda: ri.partition(np.eye(2, dtype=bool), [[1.0, 0.0]], [1.0, 0.0]),
    lambda: ri.partition(np.eye(2), [[True, False]], [1.0, 0.0]),
    lambda: ri.effective_mass(np.eye(2), [True, False]),
    lambda: ri.impulsive_impact(np.eye(2), [[0.0, 1.0]], [1.0, -1.0], restitution=True),
    lambda: ri.unilateral_impact(np.eye(2), [[0.0, 1.0]], [1.0, -1.0], restitution=True),
    lambda: frictional_impact(np.eye(2), [1.0, -1.0], [0.0, 1.0], [[[1.0, 0.0]]], True),
    lambda: frictional_impact(np.eye(2), [1.0, -1.0], [0.0, 1.0], [[[1.0, 0.0]]], 0.5,
                              restitution=[np.True_]),
    lambda: get_law("hunt-crossley", k=True, e=0.5),
    lambda: get_law("hunt-crossley", k=1e6, e=np.False_),
])
def test_true_and_false_are_not_numbers(call):
    """``mu=True`` (friction "on") was friction coefficient 1 and ``restitution=True``
    e = 1, with no error: numpy and float() read True as 1. A flag where a number
    belongs is refused, naming the argument."""
    with pytest.raises(InputError, match=r"True/False|real number"):
        call()


# Rows of any finite scale: T_c and v+ do not depend on the scale of the rows of A
# (P_c = M^-1 A^T (A M^-1 A^T)^+ A), and the impulse along a row s a is 1/s times the one
# along a. Rows of entries about 1e-200 gave T_c = 0, rank 0 and v+ = v (the squared
# whitened norms underflowed); about 1e200, the same by overflow.
_RNG = np.random.default_rng(11)
_X = _RNG.standard_normal((5, 5))
M5 = _X @ _X.T + 5 * np.eye(5)
A5 = _RNG.standard_normal((3, 5))
A5[2] = A5[0] + A5[1]  # rank 2: dependent rows
V5 = _RNG.standard_normal(5)


def _reference_T_c(M, A, v):
    """numpy/scipy, on rows of order 1: 1/2 (A v)^T (A M^-1 A^T)^+ (A v)."""
    from scipy.linalg import pinvh

    Av = A @ v
    return 0.5 * Av @ pinvh(A @ np.linalg.solve(M, A.T)) @ Av


@pytest.mark.parametrize("s", [1e-300, 1e-200, 1e-160, 1e160, 1e200, 1e300])
@pytest.mark.parametrize("nb", [None, 3, 70])  # one system, the item kernel, the lanes
def test_partition_of_rows_far_from_order_one(s, nb):
    ref = _reference_T_c(M5, A5, V5)
    if nb is None:
        p = ri.partition(M5, s * A5, V5)
        T_c, rank = np.array([p.T_c]), np.array([p.rank])
    else:
        A = np.repeat(A5[None], nb, axis=0)
        A[1] *= s  # one item scaled among items of order 1
        p = ri.partition(M5, A, V5)
        T_c, rank = p.T_c, p.rank
    np.testing.assert_allclose(T_c, ref, rtol=1e-12)
    assert (rank == 2).all()


@pytest.mark.parametrize("s", [1e-200, 1e200])
def test_impulsive_impact_of_rows_far_from_order_one(s):
    A = A5[:2]
    G = A @ np.linalg.solve(M5, A.T)
    p = np.linalg.solve(G, -(1 + 0.5) * (A @ V5))  # the impulses along A, e = 0.5
    r = ri.impulsive_impact(M5, s * A, V5, 0.5)
    np.testing.assert_allclose(r.v_plus, V5 + np.linalg.solve(M5, A.T @ p), rtol=1e-12,
                               atol=1e-14)
    np.testing.assert_allclose(r.impulse * s, p, rtol=1e-12)
    assert r.T_c_minus == pytest.approx(_reference_T_c(M5, A, V5), rel=1e-12)


@pytest.mark.parametrize("s", [1e-200, 1e200])
def test_held_rows_far_from_order_one(s):
    """m_eff = (a N a^T)^-1, N = M^-1 - M^-1 B^T (B M^-1 B^T)^-1 B M^-1, depends on the
    span of the held rows B alone. With entries of 1e-200 or 1e200 the compiled kernel
    (batches of 64 items or more) and the several-row path ignored them: 1.63 kg, the mass
    with nothing held, against 1.78 kg (one item, through partition, was right)."""
    from roverimpact.energy import row_masses

    a, B = A5[0], np.vstack([A5[1], V5])  # (A5[2] = A5[0] + A5[1] would block a)
    Mi = np.linalg.inv(M5)
    N = Mi - Mi @ B.T @ np.linalg.solve(B @ Mi @ B.T, B @ Mi)
    ref = 1.0 / (a @ N @ a)
    assert ri.effective_mass(M5, a, held=s * B) == pytest.approx(ref, rel=1e-12)
    assert ri.effective_mass(M5, a[None], held=s * B)[0, 0] == pytest.approx(ref, rel=1e-12)
    m_eff, _ = row_masses(np.repeat(M5[None], 70, axis=0), a, s * B)
    np.testing.assert_allclose(m_eff, ref, rtol=1e-12)


@pytest.mark.parametrize("s", [1e-200, 1e200])
def test_projector_of_rows_far_from_order_one(s):
    """P_c = M^-1 A^T (A M^-1 A^T)^+ A does not depend on the scale of A: rows of 1e-200
    gave P_c = 0 (1e200: NaN), while partition (fixed alike) gave the full T_c."""
    from scipy.linalg import pinvh

    Mi = np.linalg.inv(M5)
    ref = Mi @ A5.T @ pinvh(A5 @ Mi @ A5.T) @ A5
    np.testing.assert_allclose(ri.projector(M5, s * A5), ref, atol=1e-12)
    np.testing.assert_allclose(ri.projector(M5, np.stack([A5, s * A5])), [ref, ref], atol=1e-12)


@pytest.mark.parametrize("s", [1e-200, 1e-160])
@pytest.mark.parametrize("nb", [None, 70])
def test_effective_mass_beyond_float64_is_refused(s, nb):
    """m_eff = 1 / (a M^-1 a^T) = 1/s^2 kg of the row (s, 0, 0) on M = I is beyond float64
    for s below 1e-154: a row of 1e-200 was called 'a zero row', one of 1e-160 returned
    inf (with a RuntimeWarning). The row is not zero; its effective mass overflows."""
    M = np.eye(3) if nb is None else np.repeat(np.eye(3)[None], nb, axis=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(InputError, match=r"m_eff = 1 / \(a M\^-1 a\^T\) of row A overflows"):
            ri.effective_mass(M, [s, 0.0, 0.0])
    with pytest.raises(InputError, match="A is a zero row"):
        ri.effective_mass(M, [0.0, 0.0, 0.0])
    assert ri.effective_mass(np.eye(3), [1e-150, 0.0, 0.0]) == pytest.approx(1e300, rel=1e-12)
