r"""Seeded synthetic Mars terrain: a spectral fractal surface plus Golombek–Rapp rocks.

Surface
-------
A Gaussian random surface with the self-affine power spectrum of Hurst exponent
:math:`H` rolled off below the spatial frequency :math:`f_c = 1/\lambda_c`
(``corner_wavelength``):

.. math::  P(f) \propto \left(1 + (f / f_c)^2\right)^{-(1 + H)},

i.e. :math:`P \propto f^{-2(1+H)}` for wavelengths shorter than :math:`\lambda_c` (height
differences over a baseline :math:`L` then grow as :math:`L^H`) and flat above it, so the
rms height does not grow with the size of the domain. It is synthesised by filtering
complex white noise in the discrete Fourier domain (``numpy.fft.irfft2``; the surface is
periodic over the domain) and scaled to zero mean and standard deviation ``rms``.

Rocks
-----
Golombek & Rapp (1997, JGR 102(E2), 4117) model the cumulative fractional area covered by
rocks of diameter :math:`\ge D` as

.. math::  F_k(D) = k\,e^{-q(k) D}, \qquad q(k) = 1.79 + 0.152/k  \quad [D \text{ in m}],

with :math:`k` the total rock abundance (about 0.05 to 0.2 at landing sites). The area
fraction in :math:`[D, D + dD]` is :math:`-F_k'(D)\,dD = k q e^{-qD} dD`; a rock of
diameter :math:`D` covers :math:`\pi D^2/4`, so the number of rocks per unit area with
diameter in :math:`dD` is

.. math::  n(D)\,dD = \frac{4 k q\, e^{-qD}}{\pi D^2}\, dD,

which diverges at small :math:`D`: the model is sampled on a truncated range
:math:`[D_{min}, D_{max}]` (default 0.1 to 2 m: the smallest rocks that matter to a
wheel of 0.1 m and above, up to boulders; the sampled rocks then cover
:math:`F_k(D_{min}) - F_k(D_{max})` of the area on average). Rocks are a Poisson
process: their number is Poisson with mean :math:`A \int n(D) dD`, their centres uniform
in the domain, their diameters drawn exactly from :math:`n(D)` by rejection (proposal
:math:`\propto D^{-2}` by inversion, accepted with probability :math:`e^{-q(D - D_{min})}`).

Each rock is the upper half of an ellipsoid (its equator on the ground): a circular
footprint of diameter :math:`D` (so it covers :math:`\pi D^2/4` as the model counts) and
height :math:`\eta D` above the ground at its centre, added to the surface by
``max()``. With :math:`\eta = 0.5` (default) it is a sphere buried to its equator.
Golombek & Rapp derived linear height-diameter relations from Viking height/diameter
ratios; "rock height about half the diameter" is the usual simplification in landing
and traverse hazard studies, taken here as the default. ``height_ratio`` may be a range
``(lo, hi)`` drawn uniformly per rock.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import integrate

from .._validation import as_array
from ..exceptions import InputError
from .terrain import HeightField

__all__ = [
    "Rocks",
    "SyntheticTerrain",
    "fractal_surface",
    "golombek_rapp_area",
    "golombek_rapp_q",
    "rock_density",
    "sample_rocks",
    "synthetic_mars",
]


def golombek_rapp_q(k):
    r"""Decay rate :math:`q(k) = 1.79 + 0.152/k` [1/m] of the Golombek–Rapp model."""
    return 1.79 + 0.152 / np.asarray(k, dtype=float)


def golombek_rapp_area(D, k):
    r"""Cumulative fractional area :math:`F_k(D) = k e^{-q(k) D}` of rocks of diameter >= D [m].

    >>> round(float(golombek_rapp_area(0.0, 0.1)), 12)
    0.1
    """
    return np.asarray(k, dtype=float) * np.exp(-golombek_rapp_q(k) * np.asarray(D, dtype=float))


def _check_k(k, d_min, d_max, *, zero: bool = False):
    k = float(k)
    if not ((0 <= k < 1) if zero else (0 < k < 1)):
        raise InputError(f"rock abundance k must be in [0, 1) (0: no rocks), got {k}" if zero
                         else f"rock abundance k must be in (0, 1), got {k}")
    if not (np.isfinite(d_min) and np.isfinite(d_max) and 0 < d_min < d_max):
        raise InputError(f"rock diameters need 0 < d_min < d_max, got d_min={d_min}, "
                         f"d_max={d_max}")
    return k


def rock_density(k: float, d_min: float = 0.1, d_max: float = 2.0) -> float:
    r"""Expected number of rocks per m² with diameter in [d_min, d_max]:
    :math:`\int 4 k q e^{-qD} / (\pi D^2)\, dD` (adaptive quadrature)."""
    k = _check_k(k, d_min, d_max)
    q = float(golombek_rapp_q(k))
    val, _ = integrate.quad(lambda D: 4 * k * q * np.exp(-q * D) / (np.pi * D * D),
                            d_min, d_max, epsrel=1e-12, limit=200)
    return val


@dataclass(frozen=True)
class Rocks:
    """Rocks of a synthetic terrain, one entry per rock (arrays of equal length).

    Attributes
    ----------
    x, y : (n,) ndarray
        Centre of the footprint [m].
    diameter : (n,) ndarray
        Footprint diameter D [m].
    height : (n,) ndarray
        Height above the ground at the centre [m] (``height_ratio * D``).
    """

    x: np.ndarray
    y: np.ndarray
    diameter: np.ndarray
    height: np.ndarray

    def __len__(self) -> int:
        return int(self.x.size)

    def area_fraction(self, D, area: float) -> np.ndarray:
        r"""Cumulative fractional area of these rocks with diameter >= D over ``area`` [m²]:
        :math:`\sum_{D_i \ge D} \pi D_i^2/4 / A`, the sample estimate of :math:`F_k(D)`."""
        D = np.asarray(D, dtype=float)
        d = np.sort(self.diameter)
        cum = np.concatenate([np.cumsum((np.pi / 4 * d * d)[::-1])[::-1], [0.0]])
        return cum[np.searchsorted(d, D, side="left")] / area


def sample_rocks(k: float, extent, rng, *, d_min: float = 0.1, d_max: float = 2.0,
                 height_ratio=0.5) -> Rocks:
    """Draw a Poisson field of Golombek–Rapp rocks over a rectangle (see the module doc).

    Parameters
    ----------
    k : float
        Total rock abundance (0 <= k < 1), e.g. 0.05 to 0.2; 0: no rocks.
    extent : ((x_min, x_max), (y_min, y_max))
        Domain of the rock centres [m].
    rng : numpy.random.Generator
    d_min, d_max : float
        Truncation of the diameter range [m].
    height_ratio : float or (lo, hi)
        Rock height / diameter, fixed or uniform in [lo, hi] per rock.
    """
    k = _check_k(k, d_min, d_max, zero=True)
    (xa, xb), (ya, yb) = extent
    area = (xb - xa) * (yb - ya)
    if not area > 0:
        raise InputError(f"rock domain has no area: {extent}")
    q = float(golombek_rapp_q(k)) if k > 0 else np.inf
    n = int(rng.poisson(rock_density(k, d_min, d_max) * area)) if k > 0 else 0
    D = np.empty(0)
    a, b = 1.0 / d_min, 1.0 / d_max
    while D.size < n:
        m = int(1.2 * (n - D.size)) + 16
        prop = 1.0 / (a - rng.random(m) * (a - b))  # density ~ 1/D^2 on [d_min, d_max]
        keep = rng.random(m) < np.exp(-q * (prop - d_min))
        D = np.concatenate([D, prop[keep]])
    D = D[:n]
    hr = np.asarray(height_ratio, dtype=float)
    if hr.ndim == 0:
        eta = np.full(n, float(hr))
    elif hr.shape == (2,) and hr[0] <= hr[1]:
        eta = rng.uniform(hr[0], hr[1], n)
    else:
        raise InputError(f"height_ratio must be a number or (lo, hi), got {hr.tolist()}")
    if not (np.isfinite(hr).all() and (hr > 0).all()):
        raise InputError(f"height_ratio must be positive, got {hr.tolist()}")
    return Rocks(x=rng.uniform(xa, xb, n), y=rng.uniform(ya, yb, n), diameter=D,
                 height=eta * D)


def fractal_surface(shape, spacing, rng, *, hurst: float = 0.8, rms: float = 0.1,
                    corner_wavelength: float = 10.0) -> np.ndarray:
    r"""Gaussian self-affine surface ``(ny, nx)`` [m] with spectrum
    :math:`(1 + (f \lambda_c)^2)^{-(1+H)}`, zero mean, standard deviation ``rms``.

    ``corner_wavelength = inf`` gives the pure power law :math:`f^{-2(1+H)}`.
    """
    ny, nx = (int(v) for v in shape)
    dx, dy = np.broadcast_to(np.asarray(spacing, dtype=float), (2,))
    if not (0 < hurst <= 1):
        raise InputError(f"hurst must be in (0, 1], got {hurst}")
    if not (rms >= 0 and np.isfinite(rms)):
        raise InputError(f"rms must be >= 0 and finite, got {rms}")
    if not corner_wavelength > 0:
        raise InputError(f"corner_wavelength must be > 0, got {corner_wavelength}")
    fx = np.fft.rfftfreq(nx, dx)
    fy = np.fft.fftfreq(ny, dy)
    f2 = fy[:, None] ** 2 + fx[None, :] ** 2
    f2[0, 0] = 1.0  # the mean is removed below
    if np.isinf(corner_wavelength):
        amp = f2 ** (-(1 + hurst) / 2)
    else:
        amp = (1.0 + f2 * corner_wavelength**2) ** (-(1 + hurst) / 2)
    amp[0, 0] = 0.0
    spec = amp * (rng.standard_normal(amp.shape) + 1j * rng.standard_normal(amp.shape))
    z = np.fft.irfft2(spec, s=(ny, nx))
    z -= z.mean()
    sd = z.std()
    return z * (rms / sd) if sd > 0 else z


def _stamp_rocks(z, rocks: Rocks, x0, y0, dx, dy) -> None:
    """Raise ``z`` in place to the half-ellipsoid of each rock (max), vectorised by size."""
    ny, nx = z.shape
    if len(rocks) == 0:
        return
    jc = np.clip(np.rint((rocks.x - x0) / dx).astype(np.intp), 0, nx - 1)
    ic = np.clip(np.rint((rocks.y - y0) / dy).astype(np.intp), 0, ny - 1)
    base = z[ic, jc].copy()  # ground height at the rock centre (nearest node)
    R = 0.5 * rocks.diameter
    mx = np.ceil(R / dx).astype(np.intp) + 1
    my = np.ceil(R / dy).astype(np.intp) + 1
    zf = z.ravel()
    for key in np.unique(mx * 100003 + my):
        sel = np.flatnonzero(mx * 100003 + my == key)
        bx, by = int(mx[sel[0]]), int(my[sel[0]])
        oj = np.arange(-bx, bx + 1)
        oi = np.arange(-by, by + 1)
        J = jc[sel, None, None] + oj[None, None, :]
        I = ic[sel, None, None] + oi[None, :, None]
        X = x0 + J * dx - rocks.x[sel, None, None]
        Y = y0 + I * dy - rocks.y[sel, None, None]
        rho2 = (X * X + Y * Y) / (R[sel, None, None] ** 2)
        inside = (rho2 < 1.0) & (J >= 0) & (J < nx) & (I >= 0) & (I < ny)
        top = base[sel, None, None] + rocks.height[sel, None, None] * np.sqrt(
            np.maximum(1.0 - rho2, 0.0))
        idx = np.broadcast_to(I * nx + J, top.shape)[inside]
        np.maximum.at(zf, idx, top[inside])


class SyntheticTerrain(HeightField):
    """A :class:`HeightField` made by :func:`synthetic_mars`, with its ``rocks`` and ``params``."""

    rocks: Rocks
    params: dict


def synthetic_mars(size, spacing: float, *, seed: int, hurst: float = 0.8, rms: float = 0.1,
                   corner_wavelength: float = 10.0, rock_abundance: float = 0.1,
                   d_min: float = 0.1, d_max: float = 2.0, height_ratio=0.5,
                   origin=(0.0, 0.0), outside: str = "error") -> SyntheticTerrain:
    """Seeded synthetic Mars terrain: fractal surface + Golombek–Rapp rocks (module doc).

    Parameters
    ----------
    size : (Lx, Ly)
        Extent [m]; the grid has ``round(L / spacing) + 1`` nodes per axis.
    spacing : float
        Grid spacing [m] (e.g. 0.05).
    seed : int
        Seed of ``numpy.random.default_rng``; the surface and the rocks use independent
        child streams, so changing surface parameters keeps the same rocks.
    hurst, rms, corner_wavelength
        Surface spectrum (see :func:`fractal_surface`); ``rms = 0`` gives flat ground.
        The defaults (0.8, 0.1 m, 10 m) are illustrative, not fitted to a site.
    rock_abundance : float
        Golombek–Rapp k (0 <= k < 1; 0: the fractal surface without rocks).
    d_min, d_max : float
        Diameter range of the sampled rocks [m].
    height_ratio : float or (lo, hi)
        Rock height / diameter (0.5: a sphere buried to its equator).

    Returns
    -------
    SyntheticTerrain
        The height field, with ``.rocks`` (:class:`Rocks`) and ``.params``.
    """
    sz = as_array(size, "size")
    if sz.shape != (2,) or not (np.isfinite(sz).all() and (sz > 0).all()):
        raise InputError(f"size must be (Lx, Ly) > 0, got {np.asarray(size).tolist()}")
    if not (np.isfinite(spacing) and spacing > 0):
        raise InputError(f"spacing must be positive, got {spacing}")
    nx = round(float(sz[0]) / spacing) + 1
    ny = round(float(sz[1]) / spacing) + 1
    if nx < 2 or ny < 2:
        raise InputError(f"size {sz.tolist()} is smaller than one spacing {spacing}")
    x0, y0 = (float(v) for v in as_array(origin, "origin"))
    rng_surface, rng_rocks = np.random.default_rng(seed).spawn(2)
    z = fractal_surface((ny, nx), spacing, rng_surface, hurst=hurst, rms=rms,
                        corner_wavelength=corner_wavelength)
    ext = ((x0, x0 + (nx - 1) * spacing), (y0, y0 + (ny - 1) * spacing))
    rocks = sample_rocks(rock_abundance, ext, rng_rocks, d_min=d_min, d_max=d_max,
                         height_ratio=height_ratio)
    _stamp_rocks(z, rocks, x0, y0, spacing, spacing)
    out = SyntheticTerrain(z, spacing, (x0, y0), outside=outside)
    out.rocks = rocks
    out.params = dict(size=sz.tolist(), spacing=spacing, seed=seed, hurst=hurst, rms=rms,
                      corner_wavelength=corner_wavelength, rock_abundance=rock_abundance,
                      d_min=d_min, d_max=d_max, height_ratio=height_ratio,
                      origin=[x0, y0])
    return out
