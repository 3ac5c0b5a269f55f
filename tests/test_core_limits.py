"""The core never returns inf or NaN for finite input: an energy beyond float64 is refused,
complex arrays are refused (they were cast with a ComplexWarning, the imaginary part lost).

Reference: the closed form T = 1/2 m v^2 of a point mass, and float64's largest number.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import roverimpact as ri
from roverimpact.energy import T_LIMIT
from roverimpact.exceptions import InputError


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
