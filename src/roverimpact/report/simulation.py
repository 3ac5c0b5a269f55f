"""Plot of a simulated impact: obstacle force vs time, peak and the T_c^- prediction."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .plots import savefig, typeset


def plot_force_history(result, path: str | Path | None = None, *, law=None, title: str = ""):
    """Obstacle normal force vs time with the peak F_max marked.

    If the contact had not ended when the simulation stopped (``result.separated`` is
    False: the contact lasted the whole window), the end of the window is drawn and the
    plot says so.

    If ``law`` (a contact law) is given, the peak force the 1-D closed form predicts from
    ``T_c^-`` (``roverimpact.contact.peak_force(T_c^-, v_n, law)``) is drawn as a dashed
    line, so the indicator and the simulated reference can be compared at a glance.

    Parameters
    ----------
    result : SimulationResult
    path : str or Path, optional
        Where to save the figure (format from the suffix, e.g. ``.png``).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    h = result.history
    cols = [c for c in h.columns if c.startswith("obstacle_") and c.endswith("_fn")]
    active = [c for c in cols if h[c].max() > 0]
    fig = Figure(figsize=(6.4, 4.0), dpi=120)
    ax = fig.subplots()
    t_ms = 1e3 * h["t"].to_numpy()
    keep = t_ms >= -0.05 * max(1e3 * result.contact_duration, 1e-3)
    for c in active:
        ax.plot(t_ms[keep], h[c].to_numpy()[keep], lw=1.5,
                label=c.removeprefix("obstacle_").removesuffix("_fn"))
    if len(active) > 1:
        total = h[active].sum(axis=1).to_numpy()
        ax.plot(t_ms[keep], total[keep], "k-", lw=1, label="sum")
    key = max(result.F_max, key=result.F_max.get)
    t_pk = 1e3 * result.t_peak[key]
    ax.plot([t_pk], [result.F_max[key]], "rv", ms=8,
            label=rf"$F_{{max}}$ = {result.F_max[key]:.4g} N")
    if law is not None:
        from ..contact import peak_force

        f_pred = float(peak_force(result.T_c_minus, result.v_n, law))
        ax.axhline(f_pred, color="tab:gray", ls="--", lw=1,
                   label=rf"from $T_c^-$ = {result.T_c_minus:.4g} J: {f_pred:.4g} N")
    ax.set_xlabel("time after first obstacle contact [ms]")
    ax.set_ylabel("obstacle normal force [N]")
    ax.set_title(typeset(title or f"T_c^- = {result.T_c_minus:.4g} J, v_n = {result.v_n:.3g} m/s"))
    if not result.separated:  # the wheel stays on the face: no finished impact
        ax.axvline(t_ms[-1], color="k", ls=":", lw=1)
        fig.text(0.01, 0.01, "dotted line: end of the simulated window; the contact had "
                 "not ended (whole window), so $F_{max}$ is the largest force in the window, "
                 "not the peak of a finished impact", fontsize=7, color="0.25",
                 ha="left", va="bottom", wrap=True)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    ax.set_ylim(bottom=0.0)
    ax.set_xlim(left=float(np.min(t_ms[keep])))
    fig.tight_layout(rect=None if result.separated else (0, 0.05, 1, 1))
    if path is not None:
        savefig(fig, path)
    return fig
