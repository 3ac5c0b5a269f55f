r"""Trust map: does the T_c^- ranking survive changes of the contact parameters?

The papers (DETC2014-35554, DETC2015-47747) use the effective kinetic energy
:math:`T_c^-` to *order* impact configurations without knowing the contact stiffness or
damping. This module measures where that holds. For the configurations of a study
(by default the built-in 2-D rover beta sweep, :func:`builtin_study`):

1. :math:`T_c^-` of every configuration comes from the scenario layer (rigid-body
   partition, no contact parameters);
2. for every cell ``(law, k, e)`` of a contact-parameter grid (:class:`TrustGrid`),
   every configuration is simulated with that obstacle contact law
   (:func:`roverimpact.simulate.simulate_impact`), giving the peak force
   :math:`F_{max}`;
3. per cell, Kendall's :math:`\tau_b` and Spearman's :math:`\rho` between
   :math:`T_c^-` and :math:`F_{max}` over the configurations
   (:func:`roverimpact.studies.stats.agreement`, which calls ``scipy.stats``).

The runs go through the study runner (:func:`roverimpact.studies.sweep.run_study`): the
configurations crossed with the grid are one study with ``[[cases]]``, so chunking,
``resume``, Dask workers and the progress callback are those of ``roverimpact sweep``.

Output folder::

    out/
      results.parquet   one row per (configuration, cell): inputs, T_c_minus, F_max, ...
      trust.parquet     tidy table: law, k, e, tau, spearman, n, n_failed
      trust_map.png/svg one heat map per law (k on a log axis, e up, tau in colour)
      study.toml, manifest.json, chunks/   as written by the study runner

Stiffness ``k`` in N/m^n (n = 3/2 unless the study's law says otherwise), restitution
``e`` dimensionless. For ``hertz`` (purely elastic) only e = 1 is meaningful, so its map
has a single row at e = 1.
"""

from __future__ import annotations

import copy
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ..exceptions import ConfigError
from .config import Study, expand, load_study, study_from_dict
from .evaluate import SIMULATION_KEY

__all__ = [
    "TrustGrid",
    "TrustResult",
    "builtin_study",
    "plot_trust_map",
    "trust_map",
    "trust_table",
]

#: Betas [deg] of the built-in 2-D rover sweep (full and ``quick``).
BUILTIN_BETAS_DEG = (10.0, 20.0, 35.0, 50.0, 65.0, 80.0, 90.0)
QUICK_BETAS_DEG = (15.0, 40.0, 65.0, 90.0)
TRUST_TABLE = "trust.parquet"
FIGURE_STEM = "trust_map"

_ELASTIC_ONLY = ("hertz",)


def _norm_law(name: str) -> str:
    return str(name).strip().lower().replace("_", "-").replace(" ", "-")


@dataclass(frozen=True)
class TrustGrid:
    """Contact-parameter grid of a trust map.

    Attributes
    ----------
    laws : tuple of str
        Obstacle contact laws (names of :data:`roverimpact.contact.LAWS`, except
        ``kelvin-voigt``, whose damping needs an effective mass).
    k : tuple of float
        Stiffness values [N/m^n], > 0.
    e : tuple of float
        Coefficients of restitution, in (0, 1]. Ignored for ``hertz`` (e = 1 only).
    """

    laws: tuple[str, ...] = ("hunt-crossley", "lankarani-nikravesh", "flores")
    k: tuple[float, ...] = (1e5, 1e6, 1e7, 1e8)
    e: tuple[float, ...] = (0.2, 0.6, 1.0)

    def __post_init__(self):
        from ..contact import LAWS

        laws = tuple(_norm_law(x) for x in self.laws)
        if not laws:
            raise ConfigError("trust map: give at least one contact law")
        for law in laws:
            if law not in LAWS or law == "kelvin-voigt":
                ok = [n for n in LAWS if n != "kelvin-voigt"]
                raise ConfigError(f"trust map: unknown or unsupported contact law {law!r}; "
                                  f"choose from {', '.join(ok)}")
        if len(set(laws)) != len(laws):
            raise ConfigError(f"trust map: contact laws repeated in {list(laws)}")
        k = tuple(float(x) for x in self.k)
        e = tuple(float(x) for x in self.e)
        if not k or not all(math.isfinite(x) and x > 0 for x in k):
            raise ConfigError(f"trust map: stiffness values k must be finite and > 0 N/m^n, "
                              f"got {list(self.k)}")
        if not e or not all(math.isfinite(x) and 0.0 < x <= 1.0 for x in e):
            raise ConfigError(f"trust map: restitution values e must be in (0, 1], got "
                              f"{list(self.e)}")
        if len(set(k)) != len(k) or len(set(e)) != len(e):
            raise ConfigError("trust map: repeated k or e values in the grid")
        object.__setattr__(self, "laws", laws)
        object.__setattr__(self, "k", tuple(sorted(k)))
        object.__setattr__(self, "e", tuple(sorted(e)))

    @classmethod
    def quick(cls) -> TrustGrid:
        """2 x 2 grid with one law (tests, smoke runs)."""
        return cls(laws=("hunt-crossley",), k=(1e5, 1e7), e=(0.5, 1.0))

    def cells(self) -> list[tuple[str, float, float]]:
        """``(law, k, e)`` of every cell (``hertz``: e = 1 only)."""
        out = []
        for law in self.laws:
            es = (1.0,) if law in _ELASTIC_ONLY else self.e
            out.extend((law, k, e) for k in self.k for e in es)
        return out


@dataclass
class TrustResult:
    """Outcome of :func:`trust_map`.

    Attributes
    ----------
    table : pandas.DataFrame
        Tidy table, one row per cell: ``law``, ``k`` [N/m^n], ``e``, ``tau`` (Kendall
        tau-b), ``spearman``, ``n`` (configurations with a finite F_max), ``n_failed``
        (simulations that failed), ``F_max_min``, ``F_max_max`` [N].
    results : pandas.DataFrame
        One row per (configuration, cell), as written by the study runner.
    grid : TrustGrid
    n_configs : int
    out_dir : pathlib.Path
    files : dict
        Written files by role (``trust``, ``results``, ``png``, ``svg``, ...).
    elapsed : float
        Wall time [s].
    """

    table: pd.DataFrame
    results: pd.DataFrame
    grid: TrustGrid
    n_configs: int
    out_dir: Path
    files: dict[str, Path] = field(default_factory=dict)
    elapsed: float = 0.0


def builtin_study(quick: bool = False, speed: float = 0.3) -> dict:
    """The built-in configurations: the planar rover (``rover2d`` defaults) driving at
    ``speed`` [m/s] into obstacle faces of angle beta (DETC2014-35554, Fig. 2).

    Seven betas from 10 to 90 deg (four with ``quick``); the front wheel hits, the other
    wheels stay on the ground (the scenario layer's default constraint rows).
    """
    betas = QUICK_BETAS_DEG if quick else BUILTIN_BETAS_DEG
    return {
        "name": "rover2d beta sweep",
        "description": "planar rover driving into obstacle faces of angle beta",
        "base": {
            "model": {"name": "rover2d"},
            "velocity": {"u": float(speed)},
            "obstacle": {"wheel": "front", "beta_deg": 90.0},
        },
        "grid": {"obstacle.beta_deg": list(betas)},
    }


_LAW_KEYS = ("contact_law.", f"{SIMULATION_KEY}.obstacle.")


def _crossed_study(study: Study, grid: TrustGrid) -> tuple[dict, int]:
    """The study's configurations crossed with the grid cells, as a ``[[cases]]`` study."""
    for p in study.parameters():
        if p.startswith(_LAW_KEYS):
            raise ConfigError(
                f"study {study.name!r} sweeps {p!r}: a trust map varies the obstacle contact "
                "law itself; remove contact-law parameters from the study's grid/cases"
            )
    configs = expand(study)
    if len(configs) < 3:
        raise ConfigError(
            f"study {study.name!r} has {len(configs)} configuration(s): a rank correlation "
            "needs at least 3"
        )
    base = copy.deepcopy(dict(study.base))
    if isinstance(base.get("model"), Mapping) and base["model"].get("name") == "rigid_body":
        raise ConfigError("trust map: the 'rigid_body' demonstration model has no simulator; "
                          "use a rover (model.name = 'rover2d' or 'rocker_bogie') or a robot "
                          "file")
    # The base law: a restitution law first (so that each swept key validates alone), e = 1
    # (accepted by every law, hertz included).
    cells = grid.cells()
    first = next((c for c in cells if c[0] not in _ELASTIC_ONLY), cells[0])
    old = dict(base.get("contact_law") or {})
    law = {"name": first[0], "k": first[1], "e": 1.0}
    if "n" in old:
        law["n"] = old["n"]
    base["contact_law"] = law
    sim = dict(base.get(SIMULATION_KEY) or {})
    obst = dict(sim.get("obstacle") or {})
    obst.update({"law": first[0], "k": first[1], "e": 1.0})
    if "n" in old and "n" not in obst:
        obst["n"] = old["n"]
    sim["obstacle"] = obst
    base[SIMULATION_KEY] = sim
    cases = []
    for law_name, k, e in cells:
        for c in configs:
            cases.append({**c.overrides,
                          "contact_law.name": law_name, "contact_law.k": k, "contact_law.e": e,
                          f"{SIMULATION_KEY}.obstacle.law": law_name,
                          f"{SIMULATION_KEY}.obstacle.k": k,
                          f"{SIMULATION_KEY}.obstacle.e": e})
    data = {"name": f"{study.name} trust map", "description": study.description,
            "base": base, "cases": cases, "simulate": True, "chunk_size": len(configs)}
    if study.x is not None:
        data["x"] = study.x
    return data, len(configs)


def trust_table(results: pd.DataFrame, grid: TrustGrid | None = None) -> pd.DataFrame:
    """Rank agreement of T_c^- with F_max per cell of a results table.

    Parameters
    ----------
    results : pandas.DataFrame
        Rows with ``contact_law.name``, ``contact_law.k``, ``contact_law.e``,
        ``T_c_minus`` and ``F_max`` (one row per configuration and cell).
    grid : TrustGrid, optional
        Orders the rows (law order of the grid); default: sorted.

    Returns
    -------
    pandas.DataFrame
        ``law, k, e, tau, spearman, n, n_failed, F_max_min, F_max_max``. ``tau`` is
        Kendall's tau-b and ``spearman`` Spearman's rho of (T_c^-, F_max) over the
        configurations with a finite F_max; NaN if fewer than 3 or a constant column.
    """
    from .stats import agreement

    need = {"contact_law.name", "contact_law.k", "contact_law.e", "T_c_minus", "F_max"}
    missing = sorted(need - set(results.columns))
    if missing:
        raise ConfigError(f"trust table: the results lack the column(s) {missing}")
    rows = []
    keys = ["contact_law.name", "contact_law.k", "contact_law.e"]
    for (law, k, e), g in results.groupby(keys, sort=False):
        x = g["T_c_minus"].to_numpy(float)
        y = g["F_max"].to_numpy(float)
        ok = np.isfinite(x) & np.isfinite(y)
        a = agreement(x, y, n_boot=0)
        rows.append({"law": str(law), "k": float(k), "e": float(e),
                     "tau": float(a.kendall.value), "spearman": float(a.spearman.value),
                     "n": int(a.n), "n_failed": int((~np.isfinite(y)).sum()),
                     "F_max_min": float(np.min(y[ok])) if ok.any() else math.nan,
                     "F_max_max": float(np.max(y[ok])) if ok.any() else math.nan})
    table = pd.DataFrame(rows, columns=["law", "k", "e", "tau", "spearman", "n", "n_failed",
                                        "F_max_min", "F_max_max"])
    order = {law: i for i, law in enumerate(grid.laws)} if grid else {}
    table["_o"] = table["law"].map(lambda s: order.get(s, len(order)))
    return (table.sort_values(["_o", "law", "k", "e"], kind="stable")
            .drop(columns="_o").reset_index(drop=True))


def plot_trust_map(table: pd.DataFrame, stem: str | Path, *,
                   title: str | None = None) -> dict[str, Path]:
    """One heat map per law: k on a log x axis, e on y, Kendall tau in colour (annotated).

    Writes ``<stem>.png`` and ``<stem>.svg``; returns ``{"png": path, "svg": path}``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import Normalize

    stem = Path(stem)
    laws = list(dict.fromkeys(table["law"]))
    if not laws:
        raise ConfigError("trust map: empty table, nothing to plot")
    fig, axes = plt.subplots(1, len(laws), figsize=(4.2 * len(laws) + 1.0, 3.6),
                             squeeze=False, constrained_layout=True)
    norm = Normalize(-1.0, 1.0)
    cmap = plt.get_cmap("RdBu")
    mesh = None
    for ax, law in zip(axes[0], laws, strict=True):
        t = table[table["law"] == law]
        ks = np.sort(t["k"].unique())
        es = np.sort(t["e"].unique())
        Z = np.full((es.size, ks.size), np.nan)
        for _, r in t.iterrows():
            Z[np.searchsorted(es, r["e"]), np.searchsorted(ks, r["k"])] = r["tau"]
        kx = _edges(np.log10(ks))
        ey = _edges(es)
        mesh = ax.pcolormesh(10.0 ** kx, ey, np.ma.masked_invalid(Z), cmap=cmap, norm=norm,
                             shading="flat")
        ax.set_xscale("log")
        for i, ev in enumerate(es):
            for j, kv in enumerate(ks):
                z = Z[i, j]
                txt = "n/a" if not np.isfinite(z) else f"{z:.2f}"
                ax.text(kv, ev, txt, ha="center", va="center", fontsize=9,
                        color="white" if np.isfinite(z) and abs(z) > 0.6 else "black")
        ax.set_xticks(ks)
        ax.set_xticklabels([f"1e{math.log10(k):.3g}" if np.isclose(math.log10(k) % 1, 0)
                            else f"{k:.2g}" for k in ks])
        ax.minorticks_off()
        ax.set_yticks(es)
        ax.set_xlabel(r"stiffness $k$ [N/m$^{n}$]")
        ax.set_ylabel("restitution $e$")
        ax.set_title(law)
    fig.colorbar(mesh, ax=axes[0].tolist(), label=r"Kendall $\tau$ ($T_c^-$ vs $F_{max}$)")
    if title:
        fig.suptitle(title)
    from ..report.plots import save_figure

    return save_figure(fig, stem, dpi=120)


def _edges(c: np.ndarray) -> np.ndarray:
    """Cell edges around sorted centres ``c`` (unit spacing for a single centre)."""
    c = np.asarray(c, float)
    if c.size == 1:
        return np.array([c[0] - 0.5, c[0] + 0.5]) if c[0] != 1.0 else np.array([0.9, 1.1])
    mid = 0.5 * (c[1:] + c[:-1])
    return np.concatenate([[c[0] - (mid[0] - c[0])], mid, [c[-1] + (c[-1] - mid[-1])]])


def trust_map(
    study: str | Path | Mapping[str, Any] | Study | None,
    out_dir: str | Path,
    *,
    grid: TrustGrid | None = None,
    quick: bool = False,
    workers: int | None = None,
    resume: bool = False,
    overwrite: bool = False,
    plot: bool = True,
    progress: Callable[[int, int], None] | None = None,
) -> TrustResult:
    """Compute the trust map of a study: Kendall tau of (T_c^-, F_max) per contact cell.

    Parameters
    ----------
    study : path, dict, Study or None
        A study file (TOML) or study; its cases are the configurations ranked. ``None``:
        the built-in 2-D rover beta sweep (:func:`builtin_study`).
    out_dir : str or Path
        Output folder (see the module docstring).
    grid : TrustGrid, optional
        Contact-parameter grid; default :class:`TrustGrid()` (3 laws x 4 k x 3 e), or
        :meth:`TrustGrid.quick` with ``quick``.
    quick : bool
        Quick preset: 2 x 2 grid, one law and (for the built-in sweep) four betas.
    workers : int, optional
        Local Dask cluster of this many processes (as ``roverimpact sweep --workers``).
    resume, overwrite : bool
        As for :func:`roverimpact.studies.sweep.run_study`.
    plot : bool
        Write the heat maps.
    progress : callable, optional
        ``progress(done_runs, total_runs)``.

    Returns
    -------
    TrustResult

    Raises
    ------
    ConfigError
        Bad grid (unknown law, k <= 0, e outside (0, 1]), fewer than 3 configurations,
        a study that sweeps the contact law itself, or a model without simulator.
    """
    from .sweep import run_study

    t0 = time.perf_counter()
    if grid is None:
        grid = TrustGrid.quick() if quick else TrustGrid()
    elif not isinstance(grid, TrustGrid):
        raise ConfigError(f"trust map: grid must be a TrustGrid, got {type(grid).__name__}")
    if study is None:
        st = study_from_dict(builtin_study(quick=quick), where="built-in study")
    elif isinstance(study, (str, Path)):
        st = load_study(study)[0]
    else:
        st = study_from_dict(study)
    crossed, n_configs = _crossed_study(st, grid)
    res = run_study(crossed, out_dir, workers=workers, resume=resume, overwrite=overwrite,
                    progress=progress)
    results = res.table
    if "F_max" not in results or not np.isfinite(results["F_max"].to_numpy(float)).any():
        errs = results.get("sim_error")
        first = next((s for s in (errs if errs is not None else []) if s), "")
        raise ConfigError("trust map: no simulation succeeded, so there is no F_max to rank"
                          + (f" (first error: {first})" if first else ""))
    table = trust_table(results, grid)
    out = Path(out_dir)
    files = dict(res.files)
    files["trust"] = out / TRUST_TABLE
    table.to_parquet(files["trust"], index=False)
    if plot:
        files.update(plot_trust_map(table, out / FIGURE_STEM,
                                    title=f"{st.name}: {n_configs} configurations"))
    return TrustResult(table=table, results=results, grid=grid, n_configs=n_configs,
                       out_dir=out, files=files, elapsed=time.perf_counter() - t0)


def grid_from_options(laws: Sequence[str] | None = None, k: Sequence[float] | None = None,
                      e: Sequence[float] | None = None, *, quick: bool = False) -> TrustGrid:
    """A :class:`TrustGrid` from optional lists (missing ones from the default/quick grid)."""
    d = TrustGrid.quick() if quick else TrustGrid()
    return TrustGrid(laws=tuple(laws) if laws else d.laws, k=tuple(k) if k else d.k,
                     e=tuple(e) if e else d.e)
