"""Figure of a suspension reconfiguration: T_c^- vs beta at the nominal and the optimum."""

from __future__ import annotations

from pathlib import Path

from .plots import save_figure_to

__all__ = ["plot_reconfiguration"]


def plot_reconfiguration(result, target: str | Path) -> dict[str, Path]:
    """T_c^- against beta at the nominal and at the optimal setting, written to
    ``target`` if it names an image file (``.png``, ``.svg``, ``.pdf``), else to
    ``<target>.png`` and ``<target>.svg``; returns the paths by type."""
    from matplotlib.figure import Figure

    from ..studies.optimize import param_unit

    fig = Figure(figsize=(6.0, 3.8), layout="constrained")
    ax = fig.subplots()
    b = result.betas_deg
    fmt = ", ".join
    ax.plot(b, result.nominal.T_c, "o-", label="nominal: " + fmt(
        f"{k} = {v:.3g} {param_unit(k)}" for k, v in result.nominal.values.items()))
    ax.plot(b, result.best.T_c, "s-", label="optimum: " + fmt(
        f"{k} = {v:.3g} {param_unit(k)}" for k, v in result.best.values.items()))
    ax.set_xlabel(r"obstacle angle $\beta$ [deg]")
    ax.set_ylabel(r"$T_c^-$ [J]")
    ax.set_title(f"{result.problem.spec.objective}-case $T_c^-$ reduced by "
                 f"{100 * result.reduction:.1f} %")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    return save_figure_to(fig, target, dpi=120)
