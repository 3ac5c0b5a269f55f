"""Input checks shared by the public functions (the API boundary).

Inside the package, arrays are trusted; these helpers run once per public call and
turn bad input into one :class:`~roverimpact.exceptions.InputError` naming the
input, the problem and, for batched input, the batch index.
"""

from __future__ import annotations

import numpy as np

from .exceptions import InputError

#: relative tolerance of the symmetry check on M: |M_ij - M_ji| <= SYM_RTOL * max_k |M_kk|
SYM_RTOL = 1e-8


def as_array(x, name: str, *, min_ndim: int = 0) -> np.ndarray:
    """Convert ``x`` to a float64 array with at least ``min_ndim`` dimensions."""
    try:
        arr = np.asarray(x)
        if arr.dtype.kind in "bc":  # True/False is a flag mistaken for a number
            kind = "complex numbers" if arr.dtype.kind == "c" else "True/False values"
            raise InputError(f"{name} holds {kind}; it must be real numbers")
        arr = arr.astype(np.float64, copy=False)
    except (TypeError, ValueError) as exc:
        if isinstance(exc, InputError):
            raise
        raise InputError(f"{name} must be an array of real numbers ({exc})") from None
    if arr.ndim < min_ndim:
        raise InputError(
            f"{name} must have at least {min_ndim} dimension(s), got shape {arr.shape}"
        )
    return arr


def fmt_index(index: tuple[int, ...]) -> str:
    """Format a batch index for messages: ``()`` -> 'unbatched', ``(3,)`` -> 'batch index 3'."""
    if len(index) == 0:
        return "unbatched"
    if len(index) == 1:
        return f"batch index {index[0]}"
    return f"batch index {index}"


def check_finite(arr: np.ndarray, name: str, core_ndim: int) -> None:
    """Raise if ``arr`` holds NaN or inf, naming the first offending batch item."""
    finite = np.isfinite(arr)
    if finite.all():  # the common case: one scan, no index bookkeeping
        return
    bad = ~finite
    if bad.any():
        batch_shape = arr.shape[: arr.ndim - core_ndim]
        if core_ndim:
            flat = bad.reshape(*batch_shape, -1).any(axis=-1)
        else:
            flat = bad
        idx = tuple(int(i) for i in np.argwhere(flat)[0]) if flat.ndim else ()
        raise InputError(f"{name} contains NaN or inf ({fmt_index(idx)})")


def check_coefficients(a: np.ndarray, name: str, *, low: float, high: float | None = None,
                       allow_inf: bool = False, item: str = "row") -> None:
    """Raise one InputError for the first entry of a coefficient array ``a`` (a scalar, or
    one value per ``item`` with optional leading batch axes, ``(..., k)``) that is NaN,
    inf (unless ``allow_inf``) or outside ``[low, high]``, naming the ``item`` and the
    batch index (the last axis is the ``item``, not a batch axis)."""
    with np.errstate(invalid="ignore"):
        ok = ~np.isnan(a) & (a >= low)
        if high is not None:
            ok &= a <= high
        if not allow_inf:
            ok &= np.isfinite(a)
    if ok.all():
        return
    first = tuple(int(i) for i in np.argwhere(~ok)[0]) if a.ndim else ()
    value = float(a[first])
    where = ""
    if first:
        parts = [f"{item} {first[-1]}"] + ([fmt_index(first[:-1])] if len(first) > 1 else [])
        where = f" ({', '.join(parts)})"
    if np.isnan(value) or (np.isinf(value) and not allow_inf):
        what = "NaN" if allow_inf else "NaN or inf"
        raise InputError(f"{name} contains {what}{where}")
    rng = f"lie in [{low:g}, {high:g}]" if high is not None else f"be >= {low:g}"
    raise InputError(f"{name} must {rng}, got {value:g}{where}")


def broadcast_batch(**shapes: tuple[int, ...]) -> tuple[int, ...]:
    """Broadcast batch shapes, with an error naming the inputs when they do not fit."""
    values = tuple(shapes.values())
    if all(s == values[0] for s in values):  # the common case, without numpy's machinery
        return values[0]
    try:
        return np.broadcast_shapes(*values)
    except ValueError:
        desc = ", ".join(f"{k} batch shape {v}" for k, v in shapes.items())
        raise InputError(f"batch shapes do not broadcast: {desc}") from None


def smallest_eigenvalue(M_item: np.ndarray) -> float:
    """Smallest eigenvalue of the symmetric part of one mass matrix (for error messages)."""
    return float(np.linalg.eigvalsh(0.5 * (M_item + M_item.T))[0])


def mass_matrix_error(M: np.ndarray, flat_index: int, code: int, name: str = "M") -> InputError:
    """Build the error for mass matrix number ``flat_index`` of ``M`` (batch flattened)."""
    batch_shape = M.shape[:-2]
    idx = tuple(int(i) for i in np.unravel_index(flat_index, batch_shape)) if batch_shape else ()
    item = M.reshape(-1, *M.shape[-2:])[flat_index]
    where = fmt_index(idx)
    if not np.isfinite(item).all():
        code = STATUS_NONFINITE_M
    if code == STATUS_NONFINITE_M:
        return InputError(f"{name} contains NaN or inf ({where})")
    if code == STATUS_ASYMMETRIC_M:
        asym = np.abs(item - item.T)
        i, j = np.unravel_index(int(np.argmax(asym)), asym.shape)
        # a triangle of zeros: half a matrix, e.g. Pinocchio's data.M after crba
        hint = ""
        if not np.tril(item, -1).any():
            hint = (". Only its upper triangle is filled (as Pinocchio's crba leaves it): "
                    "symmetrise it, M = np.triu(M) + np.triu(M, 1).T")
        elif not np.triu(item, 1).any():
            hint = (". Only its lower triangle is filled: symmetrise it, "
                    "M = np.tril(M) + np.tril(M, -1).T")
        return InputError(
            f"{name} is not symmetric ({where}): |{name}[{i},{j}] - {name}[{j},{i}]| = "
            f"{asym[i, j]:.3g}; a mass matrix must be symmetric{hint}"
        )
    lam = smallest_eigenvalue(item)
    floor = pd_floor(item)
    if lam > 0:  # positive, but below what a Cholesky factor resolves
        return InputError(
            f"{name} is singular to working precision ({where}): its smallest eigenvalue "
            f"{lam:.3g} is below n * eps * max {name}_ii = {floor:.3g}, the resolution of "
            "its Cholesky factor; check for a body with (almost) no mass or inertia on a "
            "joint, or coordinates of very different scales"
        )
    return InputError(
        f"{name} is not positive definite ({where}, smallest eigenvalue {lam:.3g}): "
        "check for zero or negative masses or inertias, or a body with no mass"
    )


def check_rtol(rtol, name: str = "rtol", upper: float = 1.0) -> float:
    """``rtol`` as a float in (0, ``upper``) (``upper`` included when it is below 1), or
    one InputError naming it (NaN, inf, None, strings and arrays fail)."""
    if isinstance(rtol, (bool, str, bytes)) or np.ndim(rtol) != 0:
        raise InputError(f"{name} must be a number in (0, {upper:g}"
                         f"{')' if upper >= 1.0 else ']'}, got {rtol!r}")
    try:
        r = float(rtol)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number, got {rtol!r}") from None
    ok = 0.0 < r < upper if upper >= 1.0 else 0.0 < r <= upper
    if not ok:
        raise InputError(f"{name} must be in (0, {upper:g}{')' if upper >= 1.0 else ']'}, "
                         f"got {rtol}")
    return r


def pd_floor(M: np.ndarray) -> np.ndarray:
    """``n * eps * max_i |M_ii|`` of (..., n, n) ``M``: a Cholesky pivot ``L_jj^2`` at or
    below it counts as zero (the compiled kernels' test, ``_kernels.partition.factor``)."""
    n = M.shape[-1]
    return n * np.finfo(np.float64).eps * np.abs(np.diagonal(M, axis1=-2, axis2=-1)).max(axis=-1)


# Status codes shared with the compiled kernels.
STATUS_OK = 0
STATUS_NONFINITE_M = 1
STATUS_ASYMMETRIC_M = 2
STATUS_NOT_PD = 3
STATUS_NONFINITE_A = 4
STATUS_NONFINITE_V = 5


def check_mass_matrix(M: np.ndarray, name: str = "M") -> None:
    """Full check of a (..., n, n) mass matrix stack: finite, symmetric, positive definite."""
    if M.ndim < 2 or M.shape[-1] != M.shape[-2]:
        raise InputError(f"{name} must have shape (..., n, n), got {M.shape}")
    flat = M.reshape(-1, *M.shape[-2:])
    finite = np.isfinite(flat).all(axis=(-1, -2))
    if not finite.all():
        raise mass_matrix_error(M, int(np.argmin(finite)), STATUS_NONFINITE_M, name)
    tol = SYM_RTOL * np.abs(np.diagonal(flat, axis1=-2, axis2=-1)).max(axis=-1)[:, None, None]
    asym = (np.abs(flat - np.swapaxes(flat, -1, -2)) > tol).any(axis=(-1, -2))
    if asym.any():
        raise mass_matrix_error(M, int(np.argmax(asym)), STATUS_ASYMMETRIC_M, name)
    # Cholesky item by item only on failure: the batched call tells us that one failed.
    try:
        L = np.linalg.cholesky(flat)
    except np.linalg.LinAlgError:
        for b in range(flat.shape[0]):
            try:
                np.linalg.cholesky(flat[b])
            except np.linalg.LinAlgError:
                raise mass_matrix_error(M, b, STATUS_NOT_PD, name) from None
        raise  # pragma: no cover - the batch failed, so one item does
    # pivots at or below the compiled kernels' floor: singular to working precision there
    pivots = np.diagonal(L, axis1=-2, axis2=-1) ** 2
    low = ~(pivots > pd_floor(flat)[:, None]).all(axis=-1)
    if low.any():
        raise mass_matrix_error(M, int(np.argmax(low)), STATUS_NOT_PD, name)


def check_psd(G: np.ndarray, name: str, what: str) -> None:
    """One InputError for the first item of a finite (..., m, m) stack ``G`` that is not
    symmetric positive semi-definite (``what`` says what it is, for the message): an
    asymmetry or a negative eigenvalue beyond ``SYM_RTOL * max_i |G_ii|`` of the item
    (its rounding; a negative diagonal is a negative eigenvalue), naming the batch item."""
    if G.ndim < 2 or G.shape[-1] != G.shape[-2]:
        raise InputError(f"{name} must have shape (..., m, m), got {G.shape}")
    if G.size == 0:
        return
    batch = G.shape[:-2]
    flat = G.reshape(-1, *G.shape[-2:])
    diag = np.diagonal(flat, axis1=-2, axis2=-1)
    tol = SYM_RTOL * np.abs(diag).max(axis=-1)
    asym = np.abs(flat - np.swapaxes(flat, -1, -2)).max(axis=(-1, -2))
    bad = asym > tol
    lam = np.zeros(flat.shape[0])
    sym = ~bad
    if sym.any():  # one batched call; the symmetric part of items symmetric to rounding
        lam[sym] = np.linalg.eigvalsh(0.5 * (flat[sym] + np.swapaxes(flat[sym], -1, -2)))[:, 0]
    bad |= lam < -tol
    if not bad.any():
        return
    b = int(np.argmax(bad))
    where = fmt_index(tuple(int(i) for i in np.unravel_index(b, batch)) if batch else ())
    item = flat[b]
    if asym[b] > tol[b]:
        i, j = np.unravel_index(int(np.argmax(np.abs(item - item.T))), item.shape)
        raise InputError(f"{name} is not symmetric ({where}): |{name}[{i},{j}] - "
                         f"{name}[{j},{i}]| = {abs(item[i, j] - item[j, i]):.3g}; {what} "
                         "must be symmetric positive semi-definite")
    if (diag[b] < -tol[b]).any():
        i = int(np.argmin(diag[b]))
        raise InputError(f"{name} is not positive semi-definite ({where}): {name}[{i},{i}] = "
                         f"{diag[b, i]:.3g} < 0; {what} must be symmetric positive "
                         "semi-definite")
    raise InputError(f"{name} is not positive semi-definite ({where}): its smallest "
                     f"eigenvalue is {lam[b]:.3g}; {what} must be symmetric positive "
                     "semi-definite")


def check_rows(x, name, n):
    """Rows ``x`` (..., rows, n), or (n,) for one: an array with ``n`` columns, finite, and
    no row all zeros (a contact normal or constraint row with no direction)."""
    R = as_array(x, name, min_ndim=1)
    if R.ndim == 1:
        R = R[None, :]
    if R.shape[-1] != n:
        raise InputError(
            f"{name} must have shape (..., rows, n) with n = {n} columns to match M, "
            f"got {R.shape}"
        )
    # one reduction for both checks: the largest |entry| of a row is NaN/inf if the row
    # holds one (then the exact scan names it) and 0 for an all-zero row
    big = np.max(np.abs(R), axis=-1) if R.size else np.zeros(R.shape[:-1])
    if not np.isfinite(big).all():
        check_finite(R, name, 2)
    zero = big == 0.0
    if zero.any():
        where = np.argwhere(zero)[0]
        idx = tuple(int(i) for i in where[:-1])
        raise InputError(
            f"{name} row {int(where[-1])} is all zeros ({fmt_index(idx)}): every contact "
            "normal or constraint row must have nonzero length"
        )
    return R
