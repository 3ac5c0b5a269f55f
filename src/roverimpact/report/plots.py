"""Figures of a study: the indicator T_c^- and the peak force against the swept parameter.

As in the papers (DETC2014-35554 Figs. 2-3, DETC2015-47747 Fig. 2), both quantities are
drawn against the swept parameter on two y axes; the correlation goes in the title.
Matplotlib is imported only when a figure is drawn, and only its object-oriented API
(``matplotlib.figure.Figure``): the library never selects or changes the backend.
"""

from __future__ import annotations

import re
import textwrap
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # tables are read where given; a figure of one model (draw) needs no pandas
    import pandas as pd

__all__ = ["ENGINE_LABELS", "LABELS", "MAP_MIN_VALUES", "force_column", "grid_map",
           "plot_study", "plot_study_map", "plot_study_summary", "save_figure", "typeset"]

#: Axis labels of known columns (units at the user boundary: degrees for angles).
LABELS = {
    "obstacle.beta_deg": r"impact angle $\beta$ [deg]",
    "model.params.com_height": r"COM height $h$ [m]",
    "model.params.h": r"COM height $h$ [m]",
    "velocity.u": r"speed $u$ [m/s]",
    "contact_law.k": r"contact stiffness $k$ [N/m$^n$]",
    "contact_law.e": r"coefficient of restitution $e$",
    "motion.speed": r"speed $u$ [m/s]",
    "T_c_minus": r"effective kinetic energy $T_c^-$ [J]",
    "F_max": r"simulated peak force $F_{max}$ [N]",
    "F_pred": r"predicted peak force $F_{pred}$ [N]",
    "m_eff": r"effective mass $m_{eff}$ [kg]",
}


def label(col: str) -> str:
    """The axis label of a column: :data:`LABELS`, a joint value or rate by its joint's
    name, else the column's name."""
    if col in LABELS:
        return LABELS[col]
    for prefix, what in (("configuration.joints.", "[rad or m]"),
                         ("velocity.joints.", "rate [rad/s or m/s]")):
        if col.startswith(prefix) and len(col) > len(prefix):
            return f"joint {col[len(prefix):]} {what}"
    return col


#: Plain-text names of the papers' symbols and their mathtext, as in the axis labels.
_SYMBOLS = [
    (re.compile(r"(?<![\w$\\])T_c\^-"), r"$T_c^-$"),
    (re.compile(r"(?<![\w$\\])T_c\^\+"), r"$T_c^+$"),
    (re.compile(r"(?<![\w$\\])F_max\b"), r"$F_{max}$"),
    (re.compile(r"(?<![\w$\\])F_pred\b"), r"$F_{pred}$"),
    (re.compile(r"(?<![\w$\\])m_eff\b"), r"$m_{eff}$"),
    (re.compile(r"(?<![\w$\\])v_n\b"), r"$v_n$"),
    (re.compile(r"(?<![\w$\\])T_c\b"), r"$T_c$"),
    (re.compile(r"(?<![\w$\\])beta\b"), r"$\beta$"),
]


def typeset(text: str) -> str:
    """``text`` with the symbols written in plain text (``T_c^-``, ``F_max``, ``F_pred``,
    ``m_eff``, ``v_n``, ``beta``) in matplotlib's mathtext, as the axis labels write them.

    Text that already holds ``$`` is returned unchanged (it is typeset by its author).

    >>> print(typeset("F_max and T_c^- vs beta"))
    $F_{max}$ and $T_c^-$ vs $\\beta$
    """
    if "$" in text:
        return text
    for pattern, math in _SYMBOLS:
        text = pattern.sub(lambda _m, math=math: math, text)
    return text


def force_column(table: pd.DataFrame) -> str | None:
    """``F_max`` if the table holds simulated forces, else ``F_pred`` if any, else None."""
    for col in ("F_max", "F_pred"):
        if col in table and np.isfinite(table[col].to_numpy(dtype=float)).any():
            return col
    return None


#: Engine names as the figures and tables print them.
ENGINE_LABELS = {"own": "own simulator", "mujoco": "MuJoCo",
                 "mujoco_laws": "MuJoCo with the scenario's laws"}
#: Style of further engines' peak forces (marker, line, colour), in engine order.
_EXTRA_STYLES = (("^", ":", "tab:purple"), ("v", "-.", "tab:brown"))


def plot_study(table: pd.DataFrame, x: str, *, title: str = "", subtitle: str = "",
               group_by: list[str] | None = None, flagged=None,
               flag_label: str = "flagged case", forces=None):
    """Draw T_c^- (left axis) and the peak force (right axis) against ``x``.

    Both axes start at 0 and end 5 % above their largest value, so equal heights are equal
    fractions of each maximum (the curves are compared in proportion, not stretched to
    the same span); the figure says so.

    Parameters
    ----------
    table : DataFrame
        A study's results (``T_c_minus`` and optionally ``F_max`` / ``F_pred``).
    x : str
        Column of the swept parameter.
    title, subtitle : str
        Title (e.g. the study name) and a second line (e.g. the correlation); symbols
        written in plain text (``T_c^-``, ``F_max``) are typeset (:func:`typeset`).
    group_by : list of str, optional
        Other swept parameters: one line per combination of their values.
    flagged : (len(table),) bool array, optional
        Cases to mark (a black ring on the peak force, or on T_c^- without one), e.g.
        those whose contact lasted the whole simulated window; ``flag_label`` names them
        in the legend.
    forces : list of (column, label), optional
        Several peak forces on the right axis, e.g. ``[("F_max", "own simulator"),
        ("F_max_mujoco", "MuJoCo")]`` (the first in red squares, the others with their
        own markers, one shared axis); default: :func:`force_column` alone.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    fcol = force_column(table)
    extra: list[tuple[str, str]] = []
    ref_tag = ""
    if forces:
        forces = [(c, lab) for c, lab in forces
                  if c in table and np.isfinite(table[c].to_numpy(float)).any()]
        if forces and fcol == "F_max" and forces[0][0] == "F_max":
            ref_tag = forces[0][1] if len(forces) > 1 else ""
            extra = forces[1:]
        elif forces and fcol is None:
            fcol = forces[0][0]
    fig = Figure(figsize=(6.4, 4.5), dpi=110)
    ax1 = fig.subplots()
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
                     + (f" {ref_tag}" if ref_tag else "") + (f" ({tag})" if tag else ""))
            for (col, lab), (mk, ls, colour) in zip(extra, _EXTRA_STYLES, strict=False):
                ax2.plot(sub[x], sub[col], mk + ls, color=colour, alpha=alpha, ms=5,
                         mfc="none", label=r"$F_{max}$ " + lab + (f" ({tag})" if tag else ""))
    if flagged is not None and np.any(flagged):
        sel = table[np.asarray(flagged, dtype=bool)]
        ax_f, col = (ax2, fcol) if ax2 is not None else (ax1, "T_c_minus")
        ax_f.plot(sel[x], sel[col], "o", ms=11, mfc="none", mec="k", mew=1.2,
                  label=flag_label)
    _from_zero(ax1, table["T_c_minus"])
    ax1.set_xlabel(label(x))
    ax1.set_ylabel(label("T_c_minus"), color="tab:blue")
    ax1.tick_params(axis="y", colors="tab:blue")
    ax1.grid(alpha=0.3)
    if ax2 is not None:
        _from_zero(ax2, np.concatenate([table[c].to_numpy(float)
                                        for c in (fcol, *(c for c, _ in extra))]))
        ax2.set_ylabel(label(fcol), color="tab:red")
        ax2.tick_params(axis="y", colors="tab:red")
        fig.text(0.01, 0.01, "both axes from 0 to 1.05 x their largest value: equal heights "
                 "are equal fractions of each maximum", fontsize=7, color="0.35",
                 ha="left", va="bottom")
    handles, labels_ = ax1.get_legend_handles_labels()
    if ax2 is not None:
        h2, l2 = ax2.get_legend_handles_labels()
        handles, labels_ = handles + h2, labels_ + l2
    if len(handles) <= 9:
        ax1.legend(handles, labels_, fontsize=7, loc="best")
    elif len(groups) > 1:  # too many lines for a legend: say what they are
        names = ", ".join(g.split(".")[-1] for g in group_by)
        ax1.text(0.01, 0.99, "\n".join(textwrap.wrap(
            f"{len(groups)} lines each ({names}: one line per combination, lighter to "
            "darker in increasing order); solid: " + (r"$T_c^-$, dashed: peak force"
                                                      if ax2 is not None else r"$T_c^-$"),
            70)), transform=ax1.transAxes, fontsize=6.5, va="top", ha="left", color="0.25",
            bbox={"facecolor": "white", "alpha": 0.8, "lw": 0, "pad": 1})
    lines = [typeset(ln) for text in (title, subtitle) if text
             for ln in textwrap.wrap(text, 78, break_on_hyphens=False)]
    ax1.set_title("\n".join(lines), fontsize=10 if len(lines) <= 2 else 9)
    fig.tight_layout(rect=(0, 0.03, 1, 1) if ax2 is not None else None)
    return fig


#: A study over two numeric parameters with at least this many values each, whose cases
#: fill at least half of their grid, is also drawn as a map (:func:`plot_study_map`).
MAP_MIN_VALUES = 5
#: ... of at most this many cells (a finer grid is drawn as the summary figure only: it
#: has more cells than a panel of the map has pixels, and takes seconds to draw).
MAP_MAX_CELLS = 250_000


def grid_map(table: pd.DataFrame, x: str, y: str, col: str
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """``(xs, ys, Z)``: column ``col`` of ``table`` on the grid of the numbers of columns
    ``x`` and ``y`` (``Z[j, i]`` at ``xs[i]``, ``ys[j]``; NaN where the grid has no case,
    or a case without that output). None unless ``x`` and ``y`` are numbers (finite,
    not booleans) with at least :data:`MAP_MIN_VALUES` values each and at most
    :data:`MAP_MAX_CELLS` cells, each pair of values at most once (no third parameter),
    filling at least half of the grid (a random design over two parameters is no grid).
    """
    if x == y or any(c not in table for c in (x, y, col)) or len(table) == 0:
        return None
    from pandas.api.types import is_bool_dtype, is_numeric_dtype

    xy = []
    for c in (x, y):
        if not is_numeric_dtype(table[c]) or is_bool_dtype(table[c]):
            return None
        v = table[c].to_numpy(dtype=float)
        if not np.isfinite(v).all():
            return None
        xy.append(np.unique(v, return_inverse=True))
    (xs, ix), (ys, iy) = xy
    nx, ny = len(xs), len(ys)
    if min(nx, ny) < MAP_MIN_VALUES or nx * ny > MAP_MAX_CELLS:
        return None
    cell = iy.reshape(-1) * nx + ix.reshape(-1)
    if np.unique(cell).size != cell.size or 2 * cell.size < nx * ny:
        return None
    Z = np.full(nx * ny, np.nan)
    Z[cell] = table[col].to_numpy(dtype=float)
    return xs, ys, Z.reshape(ny, nx)


def plot_study_map(table: pd.DataFrame, x: str, y: str, *, title: str = "",
                   force: str | None = None):
    """T_c^- (and the peak force ``force``, if the table has it) as maps over the grid of
    the swept parameters ``x`` and ``y`` (:func:`grid_map`), one panel each, the largest
    value marked and written; cells without a case (or whose case has no output) are left
    blank. None if the cases are not such a grid.

    Returns
    -------
    matplotlib.figure.Figure or None
    """
    from matplotlib.figure import Figure

    panels = [(c, grid_map(table, x, y, c)) for c in ("T_c_minus", force) if c]
    panels = [(c, g) for c, g in panels if g is not None
              and np.isfinite(g[2]).any()]
    if not panels or panels[0][0] != "T_c_minus":
        return None
    fig = Figure(figsize=(5.2 * len(panels) + 0.6, 4.4), dpi=110, layout="constrained")
    axes = fig.subplots(1, len(panels), squeeze=False)[0]
    for ax, (col, (xs, ys, Z)), cmap in zip(axes, panels, ("viridis", "magma"),
                                            strict=False):
        # rasterized: a vector quad per cell made the SVG of a fine grid tens of MB
        mesh = ax.pcolormesh(xs, ys, np.ma.masked_invalid(Z), shading="nearest", cmap=cmap,
                             rasterized=True)
        fig.colorbar(mesh, ax=ax, label=label(col))
        j, i = np.unravel_index(int(np.nanargmax(Z)), Z.shape)
        ax.plot(xs[i], ys[j], "*", ms=13, color="white", mec="k", mew=0.8)
        ax.set_title(f"largest {Z[j, i]:.4g} at ({xs[i]:.4g}, {ys[j]:.4g})", fontsize=8)
        ax.set_xlabel(label(x))
        ax.set_ylabel(label(y))
    lines = [typeset(ln) for ln in textwrap.wrap(title, 90, break_on_hyphens=False)]
    if lines:
        fig.suptitle("\n".join(lines), fontsize=10)
    return fig


def _from_zero(ax, values) -> None:
    """y from 0 to 1.05 x the largest value (if the values are finite and >= 0)."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size and v.min() >= 0 and v.max() > 0:
        ax.set_ylim(0.0, 1.05 * float(v.max()))


#: Suffixes of the image files a figure can be written to.
FIGURE_TYPES = (".png", ".svg", ".pdf")


def savefig(fig, path: str | Path, **kw) -> Path:
    """``fig.savefig(path, **kw)``, atomically (:func:`roverimpact._io.atomic_write`): an
    interrupted or failed write (Ctrl-C, a full disk) leaves no half-written image and the
    previous file, if any, as it was. The format is ``path``'s suffix."""
    from .._io import atomic_write

    path = Path(path)
    fmt = kw.pop("format", None) or path.suffix.lstrip(".").lower() or None
    atomic_write(path, lambda tmp: fig.savefig(tmp, format=fmt, **kw))
    return path


def save_figure(fig, stem: str | Path, dpi: float | None = None) -> dict[str, Path]:
    """Write ``<stem>.png`` and ``<stem>.svg`` (each atomically, :func:`savefig`); return
    the paths. The suffixes are added to the whole name: a stem holding a dot
    (``map-route_1.5``) keeps it (replacing its "suffix" wrote the maps of routes 1.5 and
    1.7 both to ``map-route_1.png``)."""
    out = {"png": savefig(fig, Path(f"{stem}.png"), dpi=dpi or "figure")}
    # the layout (constrained or tight: about half of a traverse figure's drawing time)
    # is computed once, for the PNG; the SVG keeps it instead of computing it again
    engine = fig.get_layout_engine()
    if engine is not None:
        fig.set_layout_engine("none")
    try:
        out["svg"] = savefig(fig, Path(f"{stem}.svg"), dpi=dpi or "figure")
    finally:
        if engine is not None:
            fig.set_layout_engine(engine)
    return out


def figure_files(target: str | Path) -> list[Path]:
    """The files :func:`save_figure_to` writes for ``target``."""
    target = Path(target)
    if target.suffix.lower() in FIGURE_TYPES:
        return [target]
    return [Path(f"{target}.png"), Path(f"{target}.svg")]


def save_figure_to(fig, target: str | Path, dpi: float | None = None) -> dict[str, Path]:
    """Write ``target`` if it names an image file (``.png``, ``.svg``, ``.pdf``), else
    ``<target>.png`` and ``<target>.svg``; return the paths by type."""
    files = figure_files(target)
    if len(files) > 1:
        return save_figure(fig, target, dpi)
    savefig(fig, files[0], dpi=dpi or "figure")
    return {files[0].suffix.lower()[1:]: files[0]}


def plot_study_summary(summary, x: str, *, title: str = "", subtitle: str = "",
                       force: str | None = None, sample: pd.DataFrame | None = None):
    """A large study drawn as a summary: per bin of ``x``, the median, the 5-95 % band and
    the range (min to max) of T_c^- (left axis) and of the peak force (right axis) over
    every case, and a seeded random sample of the cases as dots; the figure says what it
    shows.

    Parameters
    ----------
    summary : BinnedSummary
        Exact per-bin aggregates over all the cases
        (:func:`roverimpact.report.summary.summarize`).
    x : str
        Column of the swept parameter.
    force : str, optional
        Force column on the right axis (``F_max`` or ``F_pred``).
    sample : DataFrame, optional
        Random rows drawn as dots (at most a few thousand).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.4, 4.5), dpi=110)
    ax1 = fig.subplots()
    ax2 = ax1.twinx() if force else None
    xc = summary.centers
    axes = [(ax1, "T_c_minus", "tab:blue", r"$T_c^-$")]
    if ax2 is not None:
        axes.append((ax2, force, "tab:red",
                     r"$F_{max}$" if force == "F_max" else r"$F_{pred}$"))
    top = {}
    for ax, col, colour, name in axes:
        st = summary.columns[col]
        ok = st.count > 0
        ax.fill_between(xc[ok], st.min[ok], st.max[ok], color=colour, alpha=0.10, lw=0,
                        label=f"{name}: min-max")
        ax.fill_between(xc[ok], st.quantile(0.05)[ok], st.quantile(0.95)[ok], color=colour,
                        alpha=0.25, lw=0, label=f"{name}: 5-95 %")
        ax.plot(xc[ok], st.quantile(0.5)[ok], "-", color=colour, lw=1.5,
                label=f"{name}: median")
        if sample is not None and col in sample and len(sample):
            ax.plot(sample[x], sample[col], ".", color=colour, ms=1.2, alpha=0.3,
                    label=f"{name}: {len(sample):,} random cases")
        top[ax] = st.max[ok]
    for ax, values in top.items():
        _from_zero(ax, values)
    ax1.set_xlabel(label(x))
    ax1.set_ylabel(label("T_c_minus"), color="tab:blue")
    ax1.tick_params(axis="y", colors="tab:blue")
    ax1.grid(alpha=0.3)
    if ax2 is not None:
        ax2.set_ylabel(label(force), color="tab:red")
        ax2.tick_params(axis="y", colors="tab:red")
    note = (f"all {summary.n:,} cases in {len(xc)} bins of x, other parameters pooled: "
            "min-max exact, median and 5-95 % from a histogram of each bin (to 1/400 of the "
            "range); dots: a seeded random sample")
    fig.text(0.01, 0.01, "\n".join(textwrap.wrap(note, 130)), fontsize=6, color="0.35",
             ha="left", va="bottom")
    handles, labels_ = ax1.get_legend_handles_labels()
    if ax2 is not None:
        h2, l2 = ax2.get_legend_handles_labels()
        handles, labels_ = handles + h2, labels_ + l2
    ax1.legend(handles, labels_, fontsize=6, loc="upper right", markerscale=4, ncol=2)
    lines = [typeset(ln) for text in (title, subtitle) if text
             for ln in textwrap.wrap(text, 78, break_on_hyphens=False)]
    ax1.set_title("\n".join(lines), fontsize=10 if len(lines) <= 2 else 9)
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    return fig
