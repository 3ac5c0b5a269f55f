"""Figures of a study: the indicator T_c^- and the peak force against the swept parameter.

As in the papers (DETC2014-35554 Figs. 2-3, DETC2015-47747 Fig. 2), both quantities are
drawn against the swept parameter on two y axes; the correlation goes in the title.
Matplotlib is imported (with the Agg backend) only when a figure is drawn.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

__all__ = ["LABELS", "force_column", "plot_study", "save_figure"]

#: Axis labels of known columns (units at the user boundary: degrees for angles).
LABELS = {
    "obstacle.beta_deg": r"impact angle $\beta$ [deg]",
    "model.params.com_height": r"COM height $h$ [m]",
    "model.params.h": r"COM height $h$ [m]",
    "velocity.u": r"speed $u$ [m/s]",
    "contact_law.k": r"contact stiffness $k$",
    "contact_law.e": r"coefficient of restitution $e$",
    "motion.speed": r"speed $u$ [m/s]",
    "T_c_minus": r"effective kinetic energy $T_c^-$ [J]",
    "F_max": r"simulated peak force $F_{max}$ [N]",
    "F_pred": r"predicted peak force $F_{pred}$ [N]",
    "m_eff": r"effective mass $m_{eff}$ [kg]",
}


def label(col: str) -> str:
    return LABELS.get(col, col)


def force_column(table: pd.DataFrame) -> str | None:
    """``F_max`` if the table holds simulated forces, else ``F_pred`` if any, else None."""
    for col in ("F_max", "F_pred"):
        if col in table and np.isfinite(table[col].to_numpy(dtype=float)).any():
            return col
    return None


def plot_study(table: pd.DataFrame, x: str, *, title: str = "", subtitle: str = "",
               group_by: list[str] | None = None):
    """Draw T_c^- (left axis) and the peak force (right axis) against ``x``.

    Parameters
    ----------
    table : DataFrame
        A study's results (``T_c_minus`` and optionally ``F_max`` / ``F_pred``).
    x : str
        Column of the swept parameter.
    title, subtitle : str
        Title (e.g. the study name) and a second line (e.g. the correlation).
    group_by : list of str, optional
        Other swept parameters: one line per combination of their values.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fcol = force_column(table)
    fig, ax1 = plt.subplots(figsize=(6.4, 4.2), dpi=110)
    ax2 = ax1.twinx() if fcol else None
    groups = [((), table)]
    if group_by:
        groups = list(table.groupby(group_by, sort=True))
    for i, (key, sub) in enumerate(groups):
        sub = sub.sort_values(x)
        key = key if isinstance(key, tuple) else (key,)
        tag = ", ".join(
            f"{g.split('.')[-1]}={k:g}" if isinstance(k, (int, float)) else
            f"{g.split('.')[-1]}={k}" for g, k in zip(group_by or [], key, strict=False))
        alpha = 1.0 if len(groups) == 1 else 0.45 + 0.55 * (i + 1) / len(groups)
        ax1.plot(sub[x], sub["T_c_minus"], "o-", color="tab:blue", alpha=alpha, ms=4,
                 label=r"$T_c^-$" + (f" ({tag})" if tag else ""))
        if ax2 is not None:
            ax2.plot(sub[x], sub[fcol], "s--", color="tab:red", alpha=alpha, ms=4,
                     label=(r"$F_{max}$" if fcol == "F_max" else r"$F_{pred}$")
                     + (f" ({tag})" if tag else ""))
    ax1.set_xlabel(label(x))
    ax1.set_ylabel(label("T_c_minus"), color="tab:blue")
    ax1.tick_params(axis="y", colors="tab:blue")
    ax1.grid(alpha=0.3)
    if ax2 is not None:
        ax2.set_ylabel(label(fcol), color="tab:red")
        ax2.tick_params(axis="y", colors="tab:red")
    handles, labels_ = ax1.get_legend_handles_labels()
    if ax2 is not None:
        h2, l2 = ax2.get_legend_handles_labels()
        handles, labels_ = handles + h2, labels_ + l2
    if len(handles) <= 8:
        ax1.legend(handles, labels_, fontsize=7, loc="best")
    ax1.set_title(title + ("\n" + subtitle if subtitle else ""), fontsize=10)
    fig.tight_layout()
    return fig


def save_figure(fig, stem: str | Path, dpi: float | None = None) -> dict[str, Path]:
    """Write ``stem.png`` and ``stem.svg``; close the figure; return the paths."""
    import matplotlib.pyplot as plt

    stem = Path(stem)
    out = {}
    for ext in ("png", "svg"):
        path = stem.with_suffix(f".{ext}")
        fig.savefig(path, dpi=dpi or "figure")
        out[ext] = path
    plt.close(fig)
    return out
