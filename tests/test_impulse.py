"""Impulsive impact map: textbook cases, conservation laws, properties."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import roverimpact as ri
from roverimpact.exceptions import EnergyGainWarning

from .reference.systems import pendulum_on_stop, random_spd, rod_on_edge, two_masses
from .strategies import full_rank_rows, spd_matrices, vectors

CASES = {
    "two_masses": two_masses(),
    "two_masses_plastic": two_masses(e=0.0),
    "two_masses_elastic": two_masses(m1=1.0, m2=5.0, u1=3.0, u2=1.0, e=1.0),
    "rod_on_edge": rod_on_edge(),
    "pendulum": pendulum_on_stop(),
    "pendulum_dependent": pendulum_on_stop(dependent=True),
    "pendulum_percussion": pendulum_on_stop(length=0.9, d=0.6, dependent=True),
}


def _close(a, b, rel=1e-12):
    a, b = np.asarray(a, float), np.asarray(b, float)
    scale = max(np.abs(b).max(), 1e-300)
    assert np.abs(a - b).max() <= rel * scale, (a, b)


@pytest.mark.parametrize("name", list(CASES))
def test_textbook_cases(name):
    c = CASES[name]
    r = ri.impulsive_impact(c.M, c.A, c.v, c.e, c.persistent)
    _close(r.v_plus, c.v_plus)
    _close(r.impulse, [c.impulse])
    _close(r.energy_lost, c.energy_lost)
    _close(r.T_c_minus, c.T_c_minus)
    if c.impulse_persistent is not None:
        _close(r.impulse_persistent, c.impulse_persistent, rel=1e-12)
    # generalized impulse is M (v+ - v-)
    _close(r.generalized_impulse, c.M @ (c.v_plus - c.v))


def test_centre_of_percussion_has_no_pivot_reaction():
    c = pendulum_on_stop(length=0.9, d=0.6, dependent=True)  # d = 2 l / 3
    r = ri.impulsive_impact(c.M, c.A, c.v, c.e, c.persistent)
    assert abs(r.impulse_persistent[0]) < 1e-12 * r.impulse[0]


@settings(max_examples=100, deadline=None)
@given(st.integers(1, 20).flatmap(lambda n: st.tuples(
    spd_matrices(n, decades=2.0), full_rank_rows(1, n), vectors(n))), st.floats(0.0, 1.0))
def test_single_contact_energy_loss(system, e):
    """For one contact, energy lost = (1 - e^2) T_c^-, and Newton's law holds."""
    M, a, v = system
    a = a[0]
    assume(abs(a @ v) > 1e-6 * np.linalg.norm(a) * max(np.linalg.norm(v), 1e-300))
    if a @ v > 0:
        v = -v
    r = ri.impulsive_impact(M, a, v, e)
    T = 0.5 * v @ M @ v
    assert r.energy_lost == pytest.approx((1 - e**2) * r.T_c_minus, rel=1e-8, abs=1e-12 * T)
    assert a @ r.v_plus == pytest.approx(-e * (a @ v), rel=1e-8, abs=1e-10 * np.abs(a @ v))
    assert r.T_plus == pytest.approx(0.5 * r.v_plus @ M @ r.v_plus, rel=1e-9)
    assert r.impulse[0] >= 0  # approaching contact: compressive impulse


@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.EnergyGainWarning")
@settings(max_examples=100, deadline=None)
@given(st.integers(2, 18), st.integers(1, 4), st.integers(0, 3), st.data())
def test_energy_never_increases_with_persistent_rows(n, m, p, data):
    """Persistent rows at rest before impact.

    Per-row e: Newton's law holds row by row (with different e per row the bilateral
    Newton map may add energy: a known property of Newton restitution at simultaneous
    contacts, see Glocker 2004; the unilateral active-set solver handles that case).
    Common e: v+ = v- - (1 + e) P_c v- and T+ = T- - (1 - e^2) T_c^- <= T-.
    """
    assume(m + p <= n)
    M = data.draw(spd_matrices(n, decades=2.0))
    AB = data.draw(full_rank_rows(m + p, n))  # contact and persistent rows independent
    A, B = AB[:m], (AB[m:] if p else None)
    # start from an admissible velocity of the persistent rows
    v = data.draw(vectors(n))
    if B is not None:
        v -= np.linalg.pinv(B) @ (B @ v)
    assume(np.abs(A @ v).max() > 1e-6 * np.abs(A).max() * max(np.abs(v).max(), 1e-300))
    e = data.draw(arrays(np.float64, m, elements=st.floats(0.0, 1.0)))
    r = ri.impulsive_impact(M, A, v, e, B)
    T = 0.5 * v @ M @ v
    np.testing.assert_allclose(A @ r.v_plus, -e * (A @ v), atol=1e-8 * np.abs(A @ v).max())
    if B is not None:
        np.testing.assert_allclose(B @ r.v_plus, 0, atol=1e-8 * np.abs(v).max() * np.abs(B).max())
    # a common e and persistent rows at rest: v+ = v- - (1 + e) P_c v-
    r2 = ri.impulsive_impact(M, A, v, e[0], B)
    P = ri.projector(M, A if B is None else np.vstack([A, B]))
    np.testing.assert_allclose(r2.v_plus, v - (1 + e[0]) * P @ v, atol=1e-7 * np.abs(v).max())
    assert r2.energy_lost == pytest.approx((1 - e[0] ** 2) * r2.T_c_minus, rel=1e-7,
                                           abs=1e-10 * T)
    assert r2.energy_lost >= -1e-10 * T


def test_momentum_conserved_for_free_bodies(rng):
    """Three free planar discs (x, z, theta each) with two contacts: linear and angular
    momentum about the origin are unchanged by internal impulses."""
    masses = np.array([1.0, 2.5, 0.7])
    inertias = np.array([0.02, 0.1, 0.005])
    M = np.diag(np.repeat(masses, 3) * np.tile([1, 1, 0], 3) + np.tile([0, 0, 1], 3) * np.repeat(inertias, 3))
    pos = np.array([[0.0, 0.0], [0.31, 0.05], [0.2, 0.4]])

    def contact_row(i, j, point, normal):
        row = np.zeros(9)
        for body, sign in ((i, -1.0), (j, 1.0)):
            r = point - pos[body]
            # velocity of the point on body: v_G + w x r (planar: w x r = w * (-r_z, r_x))
            row[3 * body: 3 * body + 3] += sign * np.array([normal[0], normal[1],
                                                            -r[1] * normal[0] + r[0] * normal[1]])
        return row

    A = np.array([
        contact_row(0, 1, np.array([0.15, 0.02]), np.array([0.98, 0.2]) / np.hypot(0.98, 0.2)),
        contact_row(0, 2, np.array([0.1, 0.2]), np.array([0.45, 0.9]) / np.hypot(0.45, 0.9)),
    ])
    v = rng.standard_normal(9)
    r = ri.impulsive_impact(M, A, v, [0.4, 0.9])

    def momenta(vel):
        p = np.zeros(2)
        Lz = 0.0
        for b in range(3):
            vG = vel[3 * b: 3 * b + 2]
            p += masses[b] * vG
            Lz += masses[b] * (pos[b, 0] * vG[1] - pos[b, 1] * vG[0]) + inertias[b] * vel[3 * b + 2]
        return p, Lz

    p0, L0 = momenta(v)
    p1, L1 = momenta(r.v_plus)
    np.testing.assert_allclose(p1, p0, atol=1e-12)
    assert L1 == pytest.approx(L0, abs=1e-12)


@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.EnergyGainWarning")
def test_batched_impact(rng):
    B, n = 30, 5
    M = np.stack([random_spd(rng, n) for _ in range(B)])
    A = rng.standard_normal((B, 2, n))
    v = rng.standard_normal((B, n))
    e = rng.uniform(0, 1, (B, 2))
    r = ri.impulsive_impact(M, A, v, e)
    assert r.v_plus.shape == (B, n) and r.impulse.shape == (B, 2) and r.energy_lost.shape == (B,)
    for b in (0, 7, 29):
        q = ri.impulsive_impact(M[b], A[b], v[b], e[b])
        np.testing.assert_allclose(r.v_plus[b], q.v_plus, rtol=1e-12, atol=1e-14)


def test_duplicate_rows_split_impulse():
    c = two_masses()
    A = np.vstack([c.A, c.A])
    r = ri.impulsive_impact(c.M, A, c.v, c.e)
    np.testing.assert_allclose(r.v_plus, c.v_plus, rtol=1e-12)
    assert r.impulse.sum() == pytest.approx(c.impulse, rel=1e-12)
    assert r.rank == 1


def test_conflicting_targets_rejected():
    c = two_masses()
    A = np.vstack([c.A, c.A])
    with pytest.raises(ri.InputError, match="contradict"):
        ri.impulsive_impact(c.M, A, c.v, [0.2, 0.9])


def test_different_restitution_on_coupled_rows_can_add_energy():
    """Newton's law on coupled rows with different e, as the docstring warns: unit point
    mass, rows x (e = 1) and x + y (e = 0), v = (-1, -0.2). By hand: x^+ = 1, x^+ + y^+ = 0,
    so v^+ = (1, -1), T^+ = 1 J against T^- = 0.52 J, which an EnergyGainWarning says (it
    was returned with no word); with one e = 1 the energy is kept, and nothing is said."""
    with pytest.warns(EnergyGainWarning, match=r"T\+ = 1 J from T- = 0\.52 J"):
        r = ri.impulsive_impact(np.eye(2), [[1.0, 0.0], [1.0, 1.0]], [-1.0, -0.2],
                                restitution=[1.0, 0.0])
    np.testing.assert_allclose(r.v_plus, [1.0, -1.0], atol=1e-14)
    assert r.T_minus == pytest.approx(0.52) and r.T_plus == pytest.approx(1.0)
    assert r.energy_lost == pytest.approx(-0.48)
    with warnings.catch_warnings():
        warnings.simplefilter("error", EnergyGainWarning)
        r = ri.impulsive_impact(np.eye(2), [[1.0, 0.0], [1.0, 1.0]], [-1.0, -0.2], 1.0)
    assert float(r.energy_lost) == pytest.approx(0.0, abs=1e-12)


def test_a_separating_row_is_held_like_the_others():
    """Every row of A holds (the bilateral map): two unit masses already separating at
    1 m/s with e = 0.5 are pulled to approach at 0.5 m/s, by a negative impulse
    (p = -0.75 N s from momentum: each mass changes by 0.75 m/s)."""
    r = ri.impulsive_impact(np.eye(2), [[-1.0, 1.0]], [0.0, 1.0], restitution=0.5)
    np.testing.assert_allclose(r.v_plus, [0.75, 0.25], atol=1e-14)
    assert float(r.impulse[0]) == pytest.approx(-0.75)


@pytest.mark.parametrize("kw, message", [
    ({"A": [[0.0, 0.0]]}, "A row 0 is all zeros (unbatched)"),
    ({"A": [[[1.0, 0.0]], [[0.0, 0.0]]]}, "A row 0 is all zeros (batch index 1)"),
    ({"persistent": [[1.0, 0.0], [0.0, 0.0]]}, "persistent row 1 is all zeros"),
])
def test_a_row_of_zeros_is_refused(kw, message):
    """A contact or persistent row with no direction is an error, as in unilateral_impact
    (it used to give a zero impulse without a word)."""
    args = {"A": [[0.0, 1.0]], "persistent": None} | kw
    with pytest.raises(ri.InputError) as exc:
        ri.impulsive_impact(np.eye(2), args["A"], [1.0, -1.0], 0.5, args["persistent"])
    assert message in str(exc.value)


@pytest.mark.parametrize("scale, angle", [(1e-5, 1e-5), (1e-3, 1e-7), (1.0, 1.5e-9)])
def test_impulses_follow_partitions_rank_decision(scale, angle):
    """Rows x and (cos a, sin a, 0) scaled by s, independent for partition (pivot
    sin a > rtol on the normalised rows): both are held with e = 0, so by hand
    v+ = (0, 0, 0.5) and the energy lost is T_c^- = 1/2 (2 * 1 + 3 * 4) = 7 J. The SVD of
    the rows as given dropped the second one (its singular value below rtol times the
    largest) while T_c_minus and rank kept it: energy_lost 1 J."""
    M, v = np.diag([2.0, 3.0, 5.0]), np.array([-1.0, -2.0, 0.5])
    A = np.array([[1.0, 0.0, 0.0], [scale * np.cos(angle), scale * np.sin(angle), 0.0]])
    r = ri.impulsive_impact(M, A, v, restitution=0.0)
    assert int(r.rank) == 2 and float(r.T_c_minus) == pytest.approx(7.0, rel=1e-12)
    assert float(r.energy_lost) == pytest.approx(7.0, rel=1e-9)
    np.testing.assert_allclose(r.v_plus, [0.0, 0.0, 0.5], atol=1e-6)


def test_a_row_partition_counts_as_zero_is_named():
    """A row below rtol times the largest in whitened norm counts as zero in partition
    (rank 1 here); the impact map says so for that row instead of calling the rows
    dependent with contradicting targets."""
    M, A = np.diag([2.0, 3.0]), np.array([[1.0, 0.0], [0.0, 1e-10]])
    assert int(ri.partition(M, A, [-1.0, -1.0]).rank) == 1
    with pytest.raises(ri.InputError, match=r"row 1 of A is below rtol = 1e-09 times the "
                                            r"largest row in whitened norm \(unbatched\)"):
        ri.impulsive_impact(M, A, [-1.0, -1.0])
    r = ri.impulsive_impact(M, A, [-1.0, -1.0], rtol=1e-12)  # a smaller rtol keeps it
    np.testing.assert_allclose(r.v_plus, [0.0, 0.0], atol=1e-12)
    assert float(r.energy_lost) == pytest.approx(2.5, rel=1e-12)


@settings(max_examples=30, deadline=None)
@given(st.integers(2, 8), st.integers(1, 3), st.integers(0, 2), st.data())
def test_the_same_impact_in_every_form(n, m, p, data):
    """One impact given as one system, as an item of batches of 2 and 65 (the partition's
    lane kernel from 64 items) with M shared, as lists, in permuted coordinates (P M P^T,
    A P^T, P v) and with permuted, positively scaled rows gives the same v+, impulses,
    T_c^- and rank; all against numpy's solve of G p = d, G = J M^-1 J^T, J = [A; B]
    (J full rank: the impulses are unique), and M (v+ - v) = J^T p."""
    assume(m + p <= n)
    M = data.draw(spd_matrices(n, decades=2.0))
    J = data.draw(full_rank_rows(m + p, n))
    A, B = J[:m], J[m:]
    v = data.draw(vectors(n))
    e = data.draw(arrays(np.float64, m, elements=st.sampled_from([0.0, 0.3, 1.0])))
    assume(np.abs(v).max() > 1e-3)
    G = J @ np.linalg.solve(M, J.T)
    imp = np.linalg.solve(G, -np.concatenate([(1 + e) * (A @ v), B @ v]))
    v_plus = v + np.linalg.solve(M, J.T @ imp)
    pers = B if p else None

    def near(a, b, tol=1e-12):  # to tol of the largest velocity and impulse
        a, b = np.asarray(a, float), np.asarray(b, float)
        assert a.shape == b.shape and (a.size == 0 or np.abs(a - b).max() <= tol * big), (a, b)

    big = max(np.abs(v).max(), np.abs(v_plus).max(), np.abs(imp).max())
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", EnergyGainWarning)
        r = ri.impulsive_impact(M, A, v, e, pers)
    # different e per row, or a moving persistent row, can add energy (Newton's law): the
    # warning comes exactly when numpy's v+ has more kinetic energy than v (margin 1e-6)
    T_minus, T_plus = 0.5 * v @ M @ v, 0.5 * v_plus @ M @ v_plus
    warned = any(issubclass(w.category, EnergyGainWarning) for w in caught)
    if abs(T_plus - T_minus) > 1e-6 * T_minus:
        assert warned == (T_plus > T_minus), (T_plus, T_minus)
    warnings.simplefilter("ignore", EnergyGainWarning)  # the same impact again below
    near(r.v_plus, v_plus, 1e-9)
    near(np.concatenate([r.impulse, r.impulse_persistent]), imp, 1e-9)
    near(np.linalg.solve(M, r.generalized_impulse), r.v_plus - v, 1e-9)
    assert r.rank == m + p

    for nb in (2, 65):
        b = ri.impulsive_impact(M, np.broadcast_to(A, (nb, m, n)), np.tile(v, (nb, 1)), e, pers)
        for f in ("v_plus", "impulse", "impulse_persistent"):
            near(getattr(b, f), np.broadcast_to(getattr(r, f), getattr(b, f).shape))
        T = 0.5 * v @ M @ v
        for f in ("T_c_minus", "energy_lost"):
            assert np.abs(getattr(b, f) - getattr(r, f)).max() <= 1e-12 * T
        assert (b.rank == r.rank).all()
    lists = ri.impulsive_impact(M.tolist(), A.tolist(), v.tolist(), e.tolist(),
                                None if pers is None else pers.tolist())
    near(lists.v_plus, r.v_plus)

    P = np.eye(n)[data.draw(st.permutations(range(n)))]
    rows = np.array(data.draw(st.permutations(range(m))), dtype=int)
    s = data.draw(arrays(np.float64, m, elements=st.floats(1e-3, 1e3)))
    q = ri.impulsive_impact(P @ M @ P.T, (s[:, None] * A[rows]) @ P.T, P @ v, e[rows],
                            None if pers is None else pers @ P.T)
    near(P.T @ q.v_plus, r.v_plus, 1e-9)
    near(q.impulse * s, r.impulse[rows], 1e-9)
    assert abs(q.T_c_minus - r.T_c_minus) <= 1e-9 * (0.5 * v @ M @ v)
    assert q.rank == r.rank
