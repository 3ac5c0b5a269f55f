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
   (:func:`roverimpact.studies.stats.agreement`, which calls ``scipy.stats``), and
   Spearman's :math:`\rho` of the baselines (:mod:`roverimpact.studies.indicators`: v_n,
   1/2 m_total v_n^2, T_c^- of the obstacle row alone) with the same :math:`F_{max}`.

The simulator is an axis too (``engines``): every cell is simulated in each engine
(``"own"``, ``"mujoco"``: :mod:`roverimpact.simulate.engines`), one row of the table per
engine and cell, one row of heat maps per engine.

The runs go through the study runner (:func:`roverimpact.studies.sweep.run_study`): the
configurations crossed with the grid are one study with ``[[cases]]``, so chunking,
``resume``, Dask workers and the progress callback are those of ``roverimpact sweep``.

Output folder::

    out/
      results.parquet   one row per (configuration, cell): inputs, T_c_minus, F_max, ...
      trust.parquet     tidy table: law, k, e, tau, spearman, n, n_failed, ..., engine,
                        spearman_v_n, spearman_T_n_total, spearman_T_c_obstacle
      trust_map.png/svg one heat map per law (k on a log axis, e up, tau in colour)
      study.toml, manifest.json, chunks/   as written by the study runner

Stiffness ``k`` in N/m^n (n = 3/2 unless the study's law says otherwise), restitution
``e`` dimensionless. For an ``elastic`` law (``hertz``) only e = 1 is meaningful, so its
map has a single row at e = 1.
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
from .store import atomic_parquet

__all__ = [
    "TrustGrid",
    "TrustResult",
    "builtin_study",
    "trust_map",
    "trust_table",
]

#: Betas [deg] of the built-in 2-D rover sweep (full and ``quick``).
BUILTIN_BETAS_DEG = (10.0, 20.0, 35.0, 50.0, 65.0, 80.0, 90.0)
QUICK_BETAS_DEG = (15.0, 40.0, 65.0, 90.0)
TRUST_TABLE = "trust.parquet"
FIGURE_STEM = "trust_map"

@dataclass(frozen=True)
class TrustGrid:
    """Contact-parameter grid of a trust map.

    Attributes
    ----------
    laws : tuple of str
        Obstacle contact laws (names of :data:`roverimpact.contact.LAWS`, except those
        that ``needs_mass`` (``kelvin-voigt``): their damping for a given e needs an
        effective mass, which differs between configurations).
    k : tuple of float
        Stiffness values [N/m^n], > 0.
    e : tuple of float
        Coefficients of restitution, in (0, 1]. Ignored for ``elastic`` laws (``hertz``:
        e = 1 only).
    """

    laws: tuple[str, ...] = ("hunt-crossley", "lankarani-nikravesh", "flores")
    k: tuple[float, ...] = (1e5, 1e6, 1e7, 1e8)
    e: tuple[float, ...] = (0.2, 0.6, 1.0)

    def __post_init__(self):
        from ..contact import LAWS
        from ..contact.registry import normalise_name

        laws = tuple(normalise_name(x) for x in self.laws)
        if not laws:
            raise ConfigError("trust map: give at least one contact law")
        for law in laws:
            if law not in LAWS or LAWS[law].needs_mass:
                ok = [n for n, cls in LAWS.items() if not cls.needs_mass]
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
        """``(law, k, e)`` of every cell (``elastic`` laws: e = 1 only)."""
        from ..contact import LAWS

        out = []
        for law in self.laws:
            es = (1.0,) if LAWS[law].elastic else self.e
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
        Written files by role (``trust``, ``results``, ...); the heat maps are drawn by
        :func:`roverimpact.report.trust.plot_trust_map` (the CLI adds ``png``, ``svg``).
    title : str
        Title of the figure: the study name and the number of configurations.
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
    title: str = ""


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


_LAW_KEYS = ("contact_law.",)


def _crossed_study(study: Study, grid: TrustGrid, engines: Sequence[str] = ("own",)
                   ) -> tuple[dict, int]:
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
        raise ConfigError("trust map: the 'rigid_body' model has no wheels to simulate; "
                          "use a rover (model.name = 'rover2d' or 'rocker_bogie') or a robot "
                          "file")
    # The base law: a restitution law first (so that each swept key validates alone), e = 1
    # (accepted by every law, hertz included).
    from ..contact import LAWS

    cells = grid.cells()
    first = next((c for c in cells if not LAWS[c[0]].elastic), cells[0])
    old = dict(base.get("contact_law") or {})
    law = {"name": first[0], "k": first[1], "e": 1.0}
    if "n" in old:
        law["n"] = old["n"]
    base["contact_law"] = law
    cases = []
    for law_name, k, e in cells:
        for c in configs:
            cases.append({**c.overrides,
                          "contact_law.name": law_name, "contact_law.k": k, "contact_law.e": e})
    data = {"name": f"{study.name} trust map", "description": study.description,
            "base": base, "cases": cases, "chunk_size": len(configs),
            # True for the own engine alone: the study (and its fingerprint, which
            # --resume checks) as before engines were an axis
            "simulate": (True if tuple(engines) == ("own",) else
                         list(engines) if len(engines) > 1 else engines[0])}
    if study.x is not None:
        data["x"] = study.x
    return data, len(configs)


#: Columns of the trust table.
TABLE_COLUMNS = ["law", "k", "e", "tau", "spearman", "n", "n_failed", "F_max_min",
                 "F_max_max", "engine", "spearman_v_n", "spearman_T_n_total",
                 "spearman_T_c_obstacle"]


def trust_table(results: pd.DataFrame, grid: TrustGrid | None = None, *,
                simulate=True) -> pd.DataFrame:
    """Rank agreement of T_c^- (and of the baselines) with F_max per cell and engine.

    Parameters
    ----------
    results : pandas.DataFrame
        Rows with ``contact_law.name``, ``contact_law.k``, ``contact_law.e``,
        ``T_c_minus`` and ``F_max`` (one row per configuration and cell), and for further
        engines ``F_max_<engine>``; the baselines from ``v_n``, ``m_total``,
        ``m_eff_free`` where present.
    grid : TrustGrid, optional
        Orders the rows (law order of the grid); default: sorted.
    simulate : bool, str or list
        The study's ``simulate`` (names the engine of ``F_max``; default the own one).

    Returns
    -------
    pandas.DataFrame
        ``law, k, e, tau, spearman, n, n_failed, F_max_min, F_max_max, engine,
        spearman_v_n, spearman_T_n_total, spearman_T_c_obstacle``, one row per engine and
        cell. ``tau`` is Kendall's tau-b and ``spearman`` Spearman's rho of (T_c^-,
        F_max) over the configurations with a finite F_max; NaN if fewer than 3 or a
        constant column (a baseline constant over the configurations, such as v_n at a
        fixed approach speed, has NaN).
    """
    from .indicators import BASELINES, with_baselines
    from .stats import agreement
    from .store import simulated_forces

    need = {"contact_law.name", "contact_law.k", "contact_law.e", "T_c_minus", "F_max"}
    missing = sorted(need - set(results.columns))
    if missing:
        raise ConfigError(f"trust table: the results lack the column(s) {missing}")
    results = with_baselines(results)
    rows = []
    keys = ["contact_law.name", "contact_law.k", "contact_law.e"]
    for engine, col, _sfx in simulated_forces(results, simulate):
        for (law, k, e), g in results.groupby(keys, sort=False):
            x = g["T_c_minus"].to_numpy(float)
            y = g[col].to_numpy(float)
            ok = np.isfinite(x) & np.isfinite(y)
            a = agreement(x, y, n_boot=0)
            row = {"law": str(law), "k": float(k), "e": float(e),
                   "tau": float(a.kendall.value), "spearman": float(a.spearman.value),
                   "n": int(a.n), "n_failed": int((~np.isfinite(y)).sum()),
                   "F_max_min": float(np.min(y[ok])) if ok.any() else math.nan,
                   "F_max_max": float(np.max(y[ok])) if ok.any() else math.nan,
                   "engine": engine}
            for b in BASELINES:
                row[f"spearman_{b}"] = (float(agreement(g[b].to_numpy(float), y, n_boot=0)
                                              .spearman.value) if b in g else math.nan)
            rows.append(row)
    table = pd.DataFrame(rows, columns=TABLE_COLUMNS)
    order = {law: i for i, law in enumerate(grid.laws)} if grid else {}
    eng = {e: i for i, e in enumerate(dict.fromkeys(table["engine"]))}
    table["_o"] = table["law"].map(lambda s: order.get(s, len(order)))
    table["_e"] = table["engine"].map(eng)
    return (table.sort_values(["_e", "_o", "law", "k", "e"], kind="stable")
            .drop(columns=["_o", "_e"]).reset_index(drop=True))


def trust_map(
    study: str | Path | Mapping[str, Any] | Study | None,
    out_dir: str | Path,
    *,
    grid: TrustGrid | None = None,
    quick: bool = False,
    workers: int | None = None,
    resume: bool = False,
    overwrite: bool = False,
    progress: Callable[[int, int], None] | None = None,
    engines: Sequence[str] | str = ("own",),
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
    progress : callable, optional
        ``progress(done_runs, total_runs)``.
    engines : str or sequence of str
        Simulators of the map (``"own"``, ``"mujoco"``, or both): each cell is simulated
        in each; the table has one row per engine and cell.

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
    engines = _engine_list(engines)
    crossed, n_configs = _crossed_study(st, grid, engines)
    res = run_study(crossed, out_dir, workers=workers, resume=resume, overwrite=overwrite,
                    progress=progress)
    results = res.table
    if "F_max" not in results or not np.isfinite(results["F_max"].to_numpy(float)).any():
        errs = results.get("sim_error")
        first = next((s for s in (errs if errs is not None else []) if s), "")
        raise ConfigError("trust map: no simulation succeeded, so there is no F_max to rank"
                          + (f" (first error: {first})" if first else ""))
    table = trust_table(results, grid, simulate=crossed["simulate"])
    out = Path(out_dir)
    files = dict(res.files)
    files["trust"] = out / TRUST_TABLE
    atomic_parquet(table, files["trust"])
    return TrustResult(table=table, results=results, grid=grid, n_configs=n_configs,
                       out_dir=out, files=files, elapsed=time.perf_counter() - t0,
                       title=f"{st.name}: {n_configs} configurations")


def _engine_list(engines) -> tuple[str, ...]:
    from .._engines import engine_name

    names = [engines] if isinstance(engines, str) else list(engines)
    if not names:
        raise ConfigError("trust map: give at least one engine (own, mujoco)")
    out = tuple(engine_name(n) for n in names)
    if len(set(out)) != len(out):
        raise ConfigError(f"trust map: engines repeated in {names}")
    return out


def grid_from_options(laws: Sequence[str] | None = None, k: Sequence[float] | None = None,
                      e: Sequence[float] | None = None, *, quick: bool = False) -> TrustGrid:
    """A :class:`TrustGrid` from optional lists (missing ones from the default/quick grid)."""
    d = TrustGrid.quick() if quick else TrustGrid()
    return TrustGrid(laws=tuple(laws) if laws else d.laws, k=tuple(k) if k else d.k,
                     e=tuple(e) if e else d.e)
