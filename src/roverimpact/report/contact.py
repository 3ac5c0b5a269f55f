"""Plots of the contact laws (matplotlib figures, no backend selected)."""

from __future__ import annotations

import numpy as np

from ..contact.closed_form import peak_force
from ..contact.impact import impact_1dof
from ..contact.registry import LAWS, get_law, law_class
from .plots import savefig, typeset

__all__ = ["default_laws", "plot_hysteresis_loops", "plot_peak_force_vs_T"]


def default_laws(k: float, e: float, n: float = 1.5, m_eff: float = 1.0, names=None):
    """One law of each kind with common (k, e, n): each law gets the ones it takes
    (``parameters``); a law that ``needs_mass`` gets c from e and ``m_eff`` [kg]."""
    common = {"k": k, "e": e, "n": n}
    out = []
    for name in names or LAWS:
        takes = law_class(name).parameters
        out.append(get_law(name, m_eff=m_eff, **{p: x for p, x in common.items() if p in takes}))
    return out


def plot_hysteresis_loops(laws, m_eff: float, v_n: float, path=None, *, title=None,
                          max_duration: float = 1e4):
    """Force–indentation loops of ``laws`` for one impact (m_eff [kg], v_n [m/s]).

    Lengths in mm, forces in N. Returns the figure; saves it to ``path`` if given.
    ``max_duration``: as in :func:`~roverimpact.contact.impact_1dof` (Hertz times).
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.5, 5.0), layout="constrained")
    ax = fig.subplots()
    for law in laws:
        r = impact_1dof(law, m_eff, v_n, max_duration=max_duration)
        label = f"{law.name} (e* = {r.restitution_achieved:.2f})"
        ax.plot(1e3 * r.delta, r.force, label=label, lw=1.4)
    ax.set_xlabel("indentation δ [mm]")
    ax.set_ylabel("contact force f [N]")
    ax.set_title(typeset(title or f"m_eff = {m_eff:g} kg, v_n = {v_n:g} m/s"))
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    if path is not None:
        savefig(fig, path, dpi=120)
    return fig


def plot_peak_force_vs_T(laws, v_n: float, T_range=(1e-2, 1e2), path=None, *, num: int = 200):
    """Peak force [N] against T_c^- [J] (log-log) for ``laws`` at approach speed v_n [m/s]."""
    from matplotlib.figure import Figure

    T = np.geomspace(*T_range, num)
    fig = Figure(figsize=(7.0, 4.8), layout="constrained")
    ax = fig.subplots()
    for law in laws:
        ax.loglog(T, peak_force(T, v_n, law), label=law.name, lw=1.4)
    ax.set_xlabel("effective kinetic energy $T_c^-$ [J]")
    ax.set_ylabel("peak contact force [N]")
    ax.set_title(typeset(f"v_n = {v_n:g} m/s"))
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    if path is not None:
        savefig(fig, path, dpi=120)
    return fig
