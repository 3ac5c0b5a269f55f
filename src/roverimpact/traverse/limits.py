r"""Peak forces and speed limits of impacts, from (T_c^-, m_eff, v_n) at a reference speed.

At a fixed pose the driving velocity is proportional to the speed ``u`` (every rate of
:func:`~roverimpact.traverse.compute.driving_velocity` is), the active set of a frictionless
or no-slip impact does not depend on it (the impact problem is homogeneous in ``v``), and
so ``m_eff`` is independent of ``u`` while :math:`v_n \propto u` and
:math:`T_c^- \propto u^2`. Hence, from the values at the reference speed :math:`u_{ref}`:

.. math::

    u_{lim} = u_{ref}\sqrt{T_{allow} / T_c^-(u_{ref})}

keeps :math:`T_c^-` at or below :math:`T_{allow}`, and for a contact law whose closed-form
peak force :math:`F(m_{eff}, v_n)` (:func:`roverimpact.contact.predict`) increases with
:math:`v_n`,

.. math::

    u_{lim} = u_{ref}\, s^*, \qquad F(m_{eff}, s^* v_n(u_{ref})) = F_{allow},

found by bisection on :math:`\log s` (every law of the registry: for Hertz and the
Hunt–Crossley family :math:`F \propto v_n^{2n/(n+1)}`, so
:math:`s^* = (F_{allow}/F_{ref})^{(n+1)/2n}`, which the tests check). With Coulomb friction
the active set may change with the speed; the limit is then that of the reference
speed's set.
"""

from __future__ import annotations

import numpy as np

from ..contact import get_law, law_class
from ..scenario.schema import band_laws

__all__ = ["band_laws", "peak_force", "speed_limit_energy", "speed_limit_force"]


def _law(spec, k=None, e=None, m_eff=None):
    return get_law(spec.name, k=spec.k if k is None else k, e=spec.e if e is None else e,
                   n=spec.n, c=spec.c, m_eff=m_eff)


def peak_force(spec, m_eff, v_n, *, k: float | None = None, e: float | None = None
               ) -> np.ndarray:
    """Closed-form peak force [N] of ``spec`` (a :class:`~roverimpact.scenario.schema.
    ContactLawSpec`, optionally with another ``k``/``e``) for each impact.

    ``m_eff`` and ``v_n`` broadcast; items without an impact (``v_n <= 0`` or NaN, or a
    non-finite ``m_eff``) give NaN, except ``m_eff = inf`` with ``v_n > 0`` (the other held
    rows block the normal: a rigid lock) which gives inf.
    """
    return _closed_form(spec, m_eff, v_n, "peak_force", k=k, e=e, locked=np.inf)


def contact_duration(spec, m_eff, v_n) -> np.ndarray:
    """Closed-form contact duration [s] of ``spec`` for each impact, as :func:`peak_force`
    (NaN without an impact and for a rigid lock)."""
    return _closed_form(spec, m_eff, v_n, "duration")


def _closed_form(spec, m_eff, v_n, what: str, *, k=None, e=None, locked=np.nan):
    """Field ``what`` of the law's closed-form prediction for each impact (see
    :func:`peak_force`); ``locked`` where ``m_eff = inf`` and ``v_n > 0``."""
    m, v = np.broadcast_arrays(np.asarray(m_eff, float), np.asarray(v_n, float))
    out = np.full(m.shape, np.nan)
    ok = np.isfinite(m) & (m > 0) & np.isfinite(v) & (v > 0)
    out[np.isinf(m) & (v > 0)] = locked
    if not ok.any():
        return out
    if law_class(spec.name).needs_mass and spec.c is None:     # damping from e and m_eff
        mo, vo = m[ok], v[ok]
        out[ok] = [float(getattr(_law(spec, k, e, mi).predict(mi, vi), what))
                   for mi, vi in zip(mo, vo, strict=True)]
    else:
        out[ok] = np.asarray(getattr(_law(spec, k, e).predict(m[ok], v[ok]), what), float)
    return out


def speed_limit_energy(T_c, u_ref: float, T_allow: float) -> np.ndarray:
    r""":math:`u_{ref}\sqrt{T_{allow}/T_c^-}` [m/s]; inf where :math:`T_c^- = 0` (no impact),
    NaN where it is NaN."""
    T = np.asarray(T_c, float)
    with np.errstate(divide="ignore"):
        return np.where(T > 0, u_ref * np.sqrt(T_allow / np.where(T > 0, T, 1.0)),
                        np.where(np.isnan(T), np.nan, np.inf))


def speed_limit_force(spec, m_eff, v_n, u_ref: float, F_allow: float, *,
                      k: float | None = None, e: float | None = None,
                      iters: int = 64) -> np.ndarray:
    """The speed [m/s] at which the closed-form peak force of each impact equals
    ``F_allow`` (module docstring); inf without an impact, 0 for a rigid lock."""
    m, v = np.broadcast_arrays(np.asarray(m_eff, float), np.asarray(v_n, float))
    out = np.where(np.isinf(m) & (v > 0), 0.0, np.inf)
    out = np.where(np.isnan(v), np.nan, out)
    ok = np.isfinite(m) & (m > 0) & np.isfinite(v) & (v > 0)
    if not ok.any():
        return out
    mo, vo = m[ok], v[ok]
    lo = np.full(mo.shape, np.log(1e-6))
    hi = np.full(mo.shape, np.log(1e6))
    top = peak_force(spec, mo, vo * np.exp(hi), k=k, e=e)
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        F = peak_force(spec, mo, vo * np.exp(mid), k=k, e=e)
        over = F > F_allow
        hi = np.where(over, mid, hi)
        lo = np.where(over, lo, mid)
    s = np.exp(0.5 * (lo + hi))
    out[ok] = np.where(top <= F_allow, np.inf, u_ref * s)
    return out
