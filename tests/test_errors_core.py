"""Bad input to the core functions and the partition CLI: one clear error each."""

from __future__ import annotations

import re

import numpy as np
import pytest

import roverimpact as ri
from roverimpact.cli import main

M2 = np.diag([1.0, 2.0])
A2 = np.array([[1.0, 0.0]])
v2 = np.array([1.0, -1.0])


@pytest.mark.parametrize(
    ("M", "A", "v", "pattern"),
    [
        ([[1.0, 0.5], [0.0, 2.0]], A2, v2, r"M is not symmetric \(unbatched\)"),
        ([[1.0, 0.0], [0.0, -2.0]], A2, v2, r"M is not positive definite .*smallest eigenvalue -2"),
        ([[1.0, 0.0], [0.0, 0.0]], A2, v2, r"not positive definite"),
        ([[1.0, np.nan], [np.nan, 2.0]], A2, v2, r"M contains NaN"),
        (M2, [[1.0, np.inf]], v2, r"A contains NaN or inf"),
        (M2, A2, [np.nan, 1.0], r"v contains NaN or inf"),
        (M2, [[1.0, 0.0, 0.0]], v2, r"A must have shape \(\.\.\., m, n\) with n = 2"),
        (M2, A2, [1.0, 2.0, 3.0], r"v must have shape \(\.\.\., n\) with n = 2"),
        (np.ones((2, 3)), A2, v2, r"M must have shape \(\.\.\., n, n\)"),
        ([[1.0, "a"], [0.0, 2.0]], A2, v2, r"M must be an array of real numbers"),
    ],
)
def test_partition_rejects(M, A, v, pattern):
    with pytest.raises(ri.InputError, match=pattern):
        ri.partition(M, A, v)


@pytest.mark.parametrize("k", [None, 2, 70])  # one system, the item kernel, the lanes
@pytest.mark.parametrize("bad_pivot", [0, 2])
def test_asymmetric_and_not_positive_definite_is_called_asymmetric(k, bad_pivot):
    """The symmetry test runs inside the Cholesky factorisation, which stops at the first
    pivot that is not positive. A matrix asymmetric past that pivot (here at [3, 1]) and one
    asymmetric before it are both reported as not symmetric, numpy's own verdict
    (``M != M.T``), whichever pivot fails."""
    M = np.diag([2.0, 3.0, 4.0, 5.0])
    M[bad_pivot, bad_pivot] = -1.0
    M[3, 1] += 0.5
    assert not np.allclose(M, M.T)
    A, v = np.ones((1, 4)), np.ones(4)
    if k is not None:
        M = _stack_bad(np.eye(4), M, k)
    with pytest.raises(ri.InputError, match=r"M is not symmetric .*\|M\[1,3\] - M\[3,1\]\| = 0.5"):
        ri.partition(M, A, v)
    M_sym = np.diag([2.0, 3.0, 4.0, 5.0])
    M_sym[bad_pivot, bad_pivot] = -1.0
    if k is not None:
        M_sym = _stack_bad(np.eye(4), M_sym, k)
    with pytest.raises(ri.InputError, match="M is not positive definite"):
        ri.partition(M_sym, A, v)


def _stack_bad(good, bad, k):
    out = np.repeat(good[None], k, axis=0)
    out[1] = bad
    return out


def test_batch_index_is_named():
    M = np.stack([np.eye(3)] * 5)
    M[3, 1, 1] = -0.5
    with pytest.raises(ri.InputError, match=r"batch index 3, smallest eigenvalue -0.5"):
        ri.partition(M, np.ones((1, 3)), np.ones(3))
    v = np.ones((2, 4, 3))
    v[1, 2, 0] = np.nan
    with pytest.raises(ri.InputError, match=r"v contains NaN or inf \(batch index \(1, 2\)\)"):
        ri.partition(np.eye(3), np.ones((1, 3)), v)
    with pytest.raises(ri.InputError, match="batch shapes do not broadcast"):
        ri.partition(np.stack([np.eye(3)] * 4), np.ones((1, 3)), np.ones((5, 3)))


def test_errors_are_value_errors():
    assert issubclass(ri.InputError, ValueError)
    assert issubclass(ri.ConfigError, ri.RoverImpactError)


def test_impact_rejects_bad_restitution():
    with pytest.raises(ri.InputError, match=r"restitution must lie in \[0, 1\]"):
        ri.impulsive_impact(M2, A2, v2, 1.5)
    with pytest.raises(ri.InputError, match="restitution must be a scalar or have m = 1"):
        ri.impulsive_impact(M2, A2, v2, [0.1, 0.2])
    with pytest.raises(ri.InputError, match="persistent must have shape"):
        ri.impulsive_impact(M2, A2, v2, 0.5, persistent=np.ones((1, 3)))


def _restitution_calls():
    from roverimpact.frictional import frictional_impact

    M, v, N = np.diag([1.0, 2.0, 3.0]), np.array([1.0, -1.0, 0.5]), np.eye(3)[[1, 0]]
    return {
        "impulsive_impact": lambda e: ri.impulsive_impact(M, N, v, e),
        "unilateral_impact": lambda e: ri.unilateral_impact(M, v, N, e),
        "frictional_impact": lambda e: frictional_impact(M, v, N, None, 0.5, e),
    }


@pytest.mark.parametrize("fn", ["impulsive_impact", "unilateral_impact", "frictional_impact"])
def test_bad_restitution_names_its_row_and_batch_index(fn):
    """A per-row restitution (..., m): its last axis is the row, not a batch axis. A NaN in
    row 1 of an unbatched e was reported at 'batch index 1', one in row 1 of item 2 of a
    (4, 2) e at 'batch index (2, 1)' (a batch of shape (4,) has no such index), and a value
    outside [0, 1] at no index at all."""
    call = _restitution_calls()[fn]
    row = "contact" if fn == "frictional_impact" else "row"
    with pytest.raises(ri.InputError, match=rf"contains NaN or inf \({row} 1\)$"):
        call([0.2, np.nan])
    e = np.full((4, 2), 0.2)
    e[2, 1] = np.nan
    with pytest.raises(ri.InputError, match=rf"\({row} 1, batch index 2\)$"):
        call(e)
    e[2, 1] = 0.2
    e[3, 0] = 1.5
    with pytest.raises(ri.InputError,
                       match=rf"must lie in \[0, 1\], got 1.5 \({row} 0, batch index 3\)$"):
        call(e)
    with pytest.raises(ri.InputError, match=r"must lie in \[0, 1\], got -0.5$"):
        call(-0.5)  # a scalar has no row


def test_bad_mu_names_its_contact_and_batch_index():
    from roverimpact.frictional import frictional_impact

    mu = np.full((4, 2), 0.5)
    mu[1, 1] = np.nan
    args = (np.eye(3), [1.0, -1.0, 0.5], np.eye(3)[[1, 0]], None)
    with pytest.raises(ri.InputError, match=r"mu contains NaN \(contact 1, batch index 1\)$"):
        frictional_impact(*args, mu)
    mu[1, 1] = -0.1
    with pytest.raises(ri.InputError,
                       match=r"mu must be >= 0, got -0.1 \(contact 1, batch index 1\)$"):
        frictional_impact(*args, mu)


def test_effective_mass_held_of_another_batch_shape_is_named():
    """Several rows with held rows whose batch shape does not broadcast against M's and
    A's: numpy's 'operands could not be broadcast together with remapped shapes
    [original->remapped]: (3,5,5)->(3,newaxis,newaxis) ...' from inside a solve."""
    M = np.repeat(np.eye(3)[None], 3, axis=0)
    with pytest.raises(ri.InputError, match=r"batch shapes do not broadcast: M and A batch "
                                            r"shape \(3,\), held batch shape \(4,\)"):
        ri.effective_mass(M, np.eye(3)[:2], held=np.ones((4, 1, 3)))


def test_impact_restitution_of_another_batch_shape_is_named():
    """The error named a 'batch batch shape (3,)' (an internal name) beside restitution's."""
    with pytest.raises(ri.InputError, match=r"batch shapes do not broadcast: M batch shape "
                                            r"\(3,\), A batch shape \(\), v batch shape "
                                            r"\(\), restitution batch shape \(4,\)$"):
        ri.impulsive_impact(np.repeat(M2[None], 3, axis=0), A2, v2, np.full((4, 1), 0.2))


@pytest.mark.parametrize("nb", [None, 70])
def test_a_mass_matrix_filled_on_one_triangle_says_how_to_symmetrise_it(nb):
    """Pinocchio's crba fills the upper triangle of data.M only; passed as it is, the error
    said 'M is not symmetric' and no more. It now says which half is filled and how to
    complete it (and the completed matrix is accepted)."""
    full = np.array([[2.0, 1.0, 0.0], [1.0, 2.0, 1.0], [0.0, 1.0, 2.0]])
    cases = ((np.triu(full), "np.triu(M) + np.triu(M, 1).T",
              lambda M: np.triu(M) + np.triu(M, 1).T),
             (np.tril(full), "np.tril(M) + np.tril(M, -1).T",
              lambda M: np.tril(M) + np.tril(M, -1).T))
    for half, fix, complete in cases:
        M = half if nb is None else np.repeat(half[None], nb, axis=0)
        with pytest.raises(ri.InputError, match=r"M is not symmetric .*Only its "
                                                r"(upper|lower) triangle is filled.*"
                                                + re.escape(fix)):
            ri.partition(M, [1.0, 0.0, 0.0], [1.0, 1.0, 1.0])
        completed = complete(half)
        assert ri.partition(completed, [1.0, 0.0, 0.0], [1.0, 1.0, 1.0]).T_c == pytest.approx(
            _tc(full), rel=1e-12)
    with pytest.raises(ri.InputError, match=r"a mass matrix must be symmetric$"):
        ri.partition(full + np.diag([0.5, 0.0], 1), [1.0, 0.0, 0.0], [1.0, 1.0, 1.0])


def _tc(M):
    """1/2 (a v)^2 / (a M^-1 a^T) for a = (1, 0, 0), v = (1, 1, 1)."""
    return 0.5 / np.linalg.solve(M, [1.0, 0.0, 0.0])[0]


def test_effective_mass_zero_row():
    with pytest.raises(ri.InputError, match="zero row"):
        ri.effective_mass(M2, [0.0, 0.0])


def test_a_mass_matrix_singular_to_working_precision_is_one_rule():
    """M = diag(1000, 1, ..., 1, 1e-12) (n = 18) has a numpy Cholesky factor, but its
    smallest pivot is below the compiled kernels' floor n eps max M_ii = 4e-12: every
    function refuses it with the same message, which says why (partition said "not
    positive definite, smallest eigenvalue 1e-12" while projector and several-row
    effective_mass accepted it); 1e-11 passes everywhere."""
    n = 18
    A = np.zeros((2, n))
    A[0, 0] = A[1, 1] = 1.0
    v = np.ones(n)
    for low, ok in ((1e-12, False), (1e-11, True)):
        M = np.diag([1000.0] + [1.0] * (n - 2) + [low])
        np.linalg.cholesky(M)  # numpy factors both
        calls = (lambda M=M: ri.partition(M, A, v), lambda M=M: ri.projector(M, A),
                 lambda M=M: ri.effective_mass(M, A), lambda M=M: ri.effective_mass(M, A[0]),
                 lambda M=M: ri.impulsive_impact(M, A, v),
                 lambda M=M: ri.unilateral_impact(M, -v, A))
        for call in calls:
            if ok:
                call()
            else:
                with pytest.raises(ri.InputError, match=r"M is singular to working precision "
                                   r"\(unbatched\): its smallest eigenvalue 1e-12 is below "
                                   r"n \* eps \* max M_ii = 4e-12"):
                    call()


@pytest.mark.parametrize("rtol", [float("nan"), 0.0, -1.0, 2.0, None, "1e-9", [1e-9, 1e-8]])
def test_rtol_is_checked_everywhere(rtol):
    """A bad rtol is one InputError in every function that takes one (projector and
    several-row effective_mass returned zero matrices for NaN, None was a TypeError)."""
    calls = (lambda: ri.partition(M2, A2, v2, rtol=rtol),
             lambda: ri.projector(M2, A2, rtol=rtol),
             lambda: ri.effective_mass(M2, A2, rtol=rtol),
             lambda: ri.effective_mass(M2, A2[0], rtol=rtol),
             lambda: ri.impulsive_impact(M2, A2, v2, rtol=rtol),
             lambda: ri.unilateral_impact(M2, -v2, A2, rtol=rtol),
             lambda: ri.unilateral_impact(M2, -v2, A2, tol=rtol),
             lambda: ri.impact_1dof(ri.contact.get_law("hertz", k=1e6), 1.0, 0.5, rtol=rtol))
    for call in calls:
        with pytest.raises(ri.InputError, match=r"tol must be"):
            call()


def test_impact_1dof_refuses_what_would_hang_or_mislead():
    """rtol = 0 or NaN and max_duration = NaN made the integrator run forever, a negative
    max_duration returned a zero force; arrays of m_eff raised a bare TypeError."""
    law = ri.contact.get_law("hertz", k=1e6)
    for bad in (float("nan"), -1.0, 0.0, float("inf"), "10", None):
        with pytest.raises(ri.InputError, match="max_duration must be a finite number > 0"):
            ri.impact_1dof(law, 1.0, 0.5, max_duration=bad)
    with pytest.raises(ri.InputError, match="integrates one impact: pass scalars"):
        ri.impact_1dof(law, [1.0, 2.0], 0.5)
    assert ri.impact_1dof(law, 1.0, 0.5, max_duration=50.0).peak_force > 0


def test_edge_inputs_of_the_core_functions():
    """No rows at all is no constraint (projector 0, the impact map leaves v); a missing v,
    a ragged A and a scalar row are one InputError each; max_transient_speed with force
    and m_R of shapes that do not broadcast too."""
    M = np.diag([1.0, 2.0, 3.0])
    v = np.array([1.0, -1.0, 0.5])
    none = np.zeros((0, 3))
    np.testing.assert_array_equal(ri.projector(M, none), 0.0)
    imp = ri.impulsive_impact(M, none, v)
    np.testing.assert_array_equal(imp.v_plus, v)
    assert float(imp.energy_lost) == 0.0
    for call, match in ((lambda: ri.partition(M, none[:1] + 1, None), "v is required"),
                        (lambda: ri.impulsive_impact(M, none[:1] + 1, None), "v is required"),
                        (lambda: ri.effective_mass(M, [[1, 0, 0], [0, 1]]),
                         "A must be an array of real numbers"),
                        (lambda: ri.effective_mass([[2.0]], 1.0, single_row=True),
                         "at least 1 dimension"),
                        (lambda: ri.max_transient_speed("hands_fingers", [1.0, 2.0],
                                                        force=[100, 200, 300]),
                         "do not broadcast")):
        with pytest.raises(ri.InputError, match=match):
            call()


def test_impact_maps_refuse_an_energy_that_overflows():
    """Finite M and v whose kinetic energy overflows float64: the same InputError as
    partition's from the unilateral and frictional impact maps (they returned inf and NaN
    energies and 'not approaching' for a contact approaching at -5e159)."""
    from roverimpact.frictional import frictional_impact  # a submodule: not an attribute
    # of roverimpact until something imports it (this test alone failed)

    M = np.diag([1.0, 2.0, 3.0])
    N = np.array([[-1.0, 0.0, 0.0], [0.0, 1.0, 1.0]])
    v = np.array([1.0, -1.0, 0.5]) * 1e160
    T = np.zeros((2, 2, 3))
    T[:, 0] = [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]
    for call in (lambda: ri.partition(M, N, v), lambda: ri.unilateral_impact(M, v, N),
                 lambda: frictional_impact(M, v, N, T[:, :1], 0.5)):
        with pytest.raises(ri.InputError, match="overflows float64"):
            call()


# --- CLI ------------------------------------------------------------------------------


def test_cli_partition_example(capsys):
    assert main(["partition", "examples/rod_on_ledge.toml"]) == 0
    out = capsys.readouterr().out
    assert "0.390625 J" in out  # T_c^- = 1/2 (m/4) v_n^2 = 1/2 * 0.5 * 1.25^2
    assert main(["partition", "examples/rod_on_ledge.toml", "--json"]) == 0
    import json

    data = json.loads(capsys.readouterr().out)
    assert data["T_c"] == pytest.approx(0.390625, rel=1e-12)
    assert data["energy_lost"] == pytest.approx(0.75 * 0.390625, rel=1e-12)


def test_cli_partition_holds_the_persistent_rows(tmp_path, capsys):
    """A file's ``persistent`` rows (held through the impact) were left out of the
    partition but used by the impact map beside it: for two coupled masses with the second
    held (B v- = 0) and e = 0 the table said T_c = 0.75 J and "energy lost 1 J", though a
    plastic impact removes exactly T_c^- (theory.md, section 3). Reference: numpy,
    T_c^- = 1/2 (J v)^T (J M^-1 J^T)^-1 (J v) with J = [A; B], and v+ = v_a."""
    import json

    M = np.array([[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 1.0]])
    A, B, v = np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]), np.array([-1.0, 0, 0.5])
    f = tmp_path / "held.toml"
    f.write_text(f"M = {M.tolist()}\nA = {A.tolist()}\nv = {v.tolist()}\n"
                 f"restitution = 0.0\npersistent = {B.tolist()}\n")
    J = np.vstack([A, B])
    T_c = 0.5 * (J @ v) @ np.linalg.solve(J @ np.linalg.solve(M, J.T), J @ v)
    assert T_c == pytest.approx(1.0) and T_c != pytest.approx(   # A alone: 0.75 J
        0.5 * (A @ v) @ np.linalg.solve(A @ np.linalg.solve(M, A.T), A @ v))
    assert main(["partition", str(f), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["T_c"] == pytest.approx(T_c, rel=1e-12)
    assert out["energy_lost"] == pytest.approx(T_c, rel=1e-12)
    np.testing.assert_allclose(out["v_plus"], out["v_a"], atol=1e-12)
    assert out["rank"] == 2
    assert main(["partition", str(f)]) == 0
    assert "rank of A and persistent" in capsys.readouterr().out
    f.write_text(f"M = {M.tolist()}\nA = {A.tolist()}\nv = {v.tolist()}\n"
                 "persistent = [[0.0, 1.0]]\n")
    assert main(["partition", str(f)]) == 2
    err = capsys.readouterr().err
    assert "persistent has 2 columns, A has 3" in err and "Traceback" not in err


def test_cli_version(capsys):
    assert main(["--version"]) == 0
    assert ri.__version__ in capsys.readouterr().out


@pytest.mark.parametrize(
    ("content", "suffix", "pattern"),
    [
        ("M = [[1.0]]\nA = [[1.0]\n", ".toml", "malformed TOML"),
        ("M = [[1.0]]\nA = [[1.0]]\n", ".toml", "missing v"),
        ("M = [[1.0]]\nA = [[1.0]]\nv = [1.0]\nfoo = 3\n", ".toml", "unknown key"),
        ("M = [[-1.0]]\nA = [[1.0]]\nv = [1.0]\n", ".toml", "not positive definite"),
        ("M = [[1.0, 2.0], [1.0]]\nA = [[1.0]]\nv = [1.0]\n", ".toml", "rectangular"),
        ("hello", ".npz", "not a readable .npz"),
        ("M = [[1.0]]\nA = [[1.0]]\nv = [-1.0]\nrestitution = 1.5\n", ".toml",
         "restitution must lie in [0, 1]"),  # brackets survive the rich console
        ("x", ".csv", "unknown file type"),
    ],
)
def test_cli_bad_files(tmp_path, capsys, content, suffix, pattern):
    f = tmp_path / f"sys{suffix}"
    f.write_text(content)
    assert main(["partition", str(f)]) == 2
    err = capsys.readouterr().err
    assert pattern in err
    assert "Traceback" not in err


def test_cli_missing_file_and_unknown_option(capsys):
    assert main(["partition", "does-not-exist.toml"]) == 2
    assert "no such file" in capsys.readouterr().err
    assert main(["partition", "examples/rod_on_ledge.toml", "--bogus"]) == 2


def test_cli_npz(tmp_path, capsys):
    f = tmp_path / "sys.npz"
    np.savez(f, M=np.diag([2.0, 3.0]), A=np.array([[-1.0, 1.0]]), v=np.array([1.5, -0.5]))
    assert main(["partition", str(f), "--json"]) == 0
    import json

    data = json.loads(capsys.readouterr().out)
    mu = 6.0 / 5.0
    assert data["T_c"] == pytest.approx(0.5 * mu * 2.0**2, rel=1e-12)
