"""Plots of the contact laws (matplotlib, Agg backend selected inside each function)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ._closed_form import peak_force
from ._impact import impact_1dof
from ._laws import LAWS, KelvinVoigt, get_law

__all__ = ["default_laws", "plot_hysteresis_loops", "plot_peak_force_vs_T"]


def default_laws(k: float, e: float, n: float = 1.5, m_eff: float = 1.0, names=None):
    """One law of each kind with common (k, e, n); Kelvin–Voigt gets c from e and m_eff."""
    out = []
    for name in names or LAWS:
        if LAWS[name] is KelvinVoigt:
            out.append(get_law(name, k=k, e=e, m_eff=m_eff))
        elif name == "hertz":
            out.append(get_law(name, k=k, n=n))
        else:
            out.append(get_law(name, k=k, e=e, n=n))
    return out


def plot_hysteresis_loops(laws, m_eff: float, v_n: float, path=None, *, title=None):
    """Force–indentation loops of ``laws`` for one impact (m_eff [kg], v_n [m/s]).

    Lengths in mm, forces in N. Returns the figure; saves it to ``path`` if given.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 5.0), constrained_layout=True)
    for law in laws:
        r = impact_1dof(law, m_eff, v_n)
        label = f"{law.name} (e* = {r.restitution_achieved:.2f})"
        ax.plot(1e3 * r.delta, r.force, label=label, lw=1.4)
    ax.set_xlabel("indentation δ [mm]")
    ax.set_ylabel("contact force f [N]")
    ax.set_title(title or f"m_eff = {m_eff:g} kg, v_n = {v_n:g} m/s")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    if path is not None:
        fig.savefig(Path(path), dpi=120)
    return fig


def plot_peak_force_vs_T(laws, v_n: float, T_range=(1e-2, 1e2), path=None, *, num: int = 200):
    """Peak force [N] against T_c^- [J] (log-log) for ``laws`` at approach speed v_n [m/s]."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    T = np.geomspace(*T_range, num)
    fig, ax = plt.subplots(figsize=(7.0, 4.8), constrained_layout=True)
    for law in laws:
        ax.loglog(T, peak_force(T, v_n, law), label=law.name, lw=1.4)
    ax.set_xlabel("effective kinetic energy $T_c^-$ [J]")
    ax.set_ylabel("peak contact force [N]")
    ax.set_title(f"v_n = {v_n:g} m/s")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    if path is not None:
        fig.savefig(Path(path), dpi=120)
    return fig
