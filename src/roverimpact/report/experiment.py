"""Figure of the measured forces next to the model."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from ..experiments.compare import ModelComparison
from .plots import savefig

__all__ = ["plot_overlay"]


def plot_overlay(trials_df: pd.DataFrame, comparison: ModelComparison | None, path):
    """Peak force vs beta (measured points, model F_max if simulated) with T_c^- on a
    second, scaled axis.

    The right axis is scaled so that the largest T_c^- sits at the height of the largest
    measured mean peak: equal shapes overlay.
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7, 4.2))
    ax = fig.subplots()
    speeds = sorted(trials_df["speed"].unique())
    markers = "osD^v<>"
    for i, sp in enumerate(speeds):
        d = trials_df[trials_df["speed"] == sp]
        ax.plot(d["beta_deg"], d["F_peak"], markers[i % len(markers)], color=f"C{i}",
                alpha=0.7, label=f"measured, {sp:g} m/s")
    if comparison is not None:
        tab = comparison.table
        ax2 = ax.twinx()
        simulated = bool(tab["F_max"].notna().any())  # not without simulation
        for i, sp in enumerate(speeds):
            d = tab[tab["speed"] == sp]
            if simulated:
                ax.plot(d["beta_deg"], d["F_max"], "-", color=f"C{i}",
                        label=f"model $F_{{max}}$, {sp:g} m/s")
            ax2.plot(d["beta_deg"], d["T_c_minus"], "--", color=f"C{i}", alpha=0.8,
                     label=f"model $T_c^-$, {sp:g} m/s")
        fmax = float(tab["F_peak_mean"].max())
        tmax = float(tab["T_c_minus"].max())
        top = ax.get_ylim()[1]
        ax.set_ylim(0, top)
        ax2.set_ylim(0, top * tmax / fmax if fmax > 0 else 1)
        ax2.set_ylabel("effective kinetic energy $T_c^-$ [J] (dashed)\nfrom 0; largest "
                       "$T_c^-$ at the height of the largest mean peak", fontsize=8)
        s = comparison.stats
        ax.set_title(f"Kendall $\\tau$ = {s['kendall_tau_Tc']:.2f}, Spearman $\\rho$ = "
                     f"{s['spearman_rho_Tc']:.2f} (peak vs $T_c^-$)", fontsize=10)
        h1, l1 = ax.get_legend_handles_labels()
        h2, l2 = ax2.get_legend_handles_labels()
        ax.legend(h1 + h2, l1 + l2, fontsize=8, loc="best")
    else:
        ax.set_ylim(bottom=0)
        ax.legend(fontsize=8)
    ax.set_xlabel(r"face angle $\beta$ [deg]")
    ax.set_ylabel("peak normal force [N]")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    savefig(fig, path, dpi=120)
    return Path(path)
