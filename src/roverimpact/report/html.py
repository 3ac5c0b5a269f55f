"""One self-contained HTML report of saved study results (no recomputation).

:func:`build_report` reads every study folder below a results folder (a folder with a
``results.parquet``, as written by :func:`roverimpact.studies.run_study`), computes the
agreement statistics of T_c^- with the simulated F_max, redraws the figures (PNG and
SVG next to the table) and writes ``report.html``: figures embedded as base64, the
statistics, the tables, the study files (parameters) and the software versions.
"""

from __future__ import annotations

import base64
import html
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from .._io import atomic_write, check_writable
from ..exceptions import ConfigError
from ..studies.forked import ProcessDied, map_forked, side_by_side
from ..studies.indicators import IndicatorComparison, compare_indicators, with_baselines
from ..studies.stats import Agreement, ForceRatios, agreement, check_n_boot, force_ratios
from ..studies.store import (
    CHUNKS,
    MANIFEST,
    RESULTS,
    STUDY_COPY,
    WHOLE_WINDOW,
    count_not_posed,
    load_results,
    not_posed,
    read_manifest,
    simulated_forces,
    whole_window_cases,
)
from .plots import (
    ENGINE_LABELS,
    MAP_MAX_CELLS,
    force_column,
    plot_study,
    plot_study_map,
    plot_study_summary,
    save_figure,
)
from .summary import LARGE_TABLE, results_rows, summarize

__all__ = ["EngineStats", "StudySection", "analyse_folder", "build_report",
           "find_study_folders"]

REPORT = "report.html"
MAX_TABLE_ROWS = 200

#: Cases whose contact lasted the whole simulated window (``contact_whole_window``: the
#: wheel stays on the face, so F_max is the largest force within the window, not the peak
#: of a finished impact) are left out of the agreement statistics; the results table flags
#: them, the figure marks them and the statistics say how many were excluded.
WHOLE_WINDOW_POLICY = "excluded"


@dataclass
class EngineStats:
    """Agreement of the indicators with one engine's peak force.

    Attributes
    ----------
    engine : str
        ``"own"`` or ``"mujoco"``.
    force : str
        Its column (``F_max`` for the study's reference engine, ``F_max_mujoco``).
    agreement : Agreement or None
        T_c^- vs that force (whole-window cases excluded); None with fewer than 3 cases.
    n_whole_window : int
        Cases excluded because that engine's contact lasted the whole window.
    comparison : IndicatorComparison or None
        T_c^- and the baselines against that force, with the statements.
    ratios : list of ForceRatios
        Predicted over that engine's peak force on the true impacts (``not_an_impact``
        and the engine's whole-window cases excluded): the closed form ``F_pred`` and,
        where the table has them, ``F_pred_refined`` and (MuJoCo)
        ``F_pred_refined_mujoco``.
    """

    engine: str
    force: str
    agreement: Agreement | None
    n_whole_window: int
    comparison: IndicatorComparison | None
    ratios: list[ForceRatios] = field(default_factory=list)

    @property
    def label(self) -> str:
        return ENGINE_LABELS.get(self.engine, self.engine)

    def as_dict(self) -> dict:
        return {"engine": self.engine, "force": self.force,
                "n": self.agreement.n if self.agreement is not None else 0,
                "n_whole_window": self.n_whole_window, "whole_window": WHOLE_WINDOW_POLICY,
                "agreement": self.agreement.as_dict() if self.agreement is not None else None,
                "baselines": (self.comparison.as_dict() if self.comparison is not None
                              else None),
                "force_ratios": [r.as_dict() for r in self.ratios]}


@dataclass
class StudySection:
    """What the report shows for one study folder (``agreement``: T_c^- vs ``F_max``, the
    reference engine; ``engines``: every engine's statistics, the reference first)."""

    folder: Path
    name: str
    table: pd.DataFrame
    manifest: dict
    study_text: str
    x: str
    force: str | None
    agreement: Agreement | None
    figures: dict[str, Path] = field(default_factory=dict)
    note: str = ""
    description: str = ""
    n_whole_window: int = 0
    engines: list[EngineStats] = field(default_factory=list)
    n_rows: int | None = None
    head: pd.DataFrame | None = None
    maps: dict[str, Path] = field(default_factory=dict)

    @property
    def n_cases(self) -> int:
        """Cases of the study (rows of its results table)."""
        return len(self.table) if self.n_rows is None else self.n_rows

    @property
    def n_text(self) -> str:
        """``n = 15 (2 whole-window cases excluded)``: the cases the statistics use."""
        n = self.agreement.n if self.agreement is not None else 0
        return f"n = {n}" + (f" ({self.n_whole_window} whole-window case"
                             f"{'s' if self.n_whole_window != 1 else ''} excluded)"
                             if self.n_whole_window else "")


def find_study_folders(root: str | Path) -> list[Path]:
    """``root`` itself if it holds results, else its subfolders that do (sorted)."""
    root = Path(root)
    if not root.is_dir():
        raise ConfigError(f"{root}: no such folder")
    if (root / RESULTS).is_file():
        return [root]
    found = sorted(p.parent for p in root.glob(f"*/{RESULTS}"))
    if not found and any((root / CHUNKS).glob("*.parquet")):
        study = root / STUDY_COPY
        raise ConfigError(
            f"{root}: no {RESULTS} here, but {CHUNKS}/ holds the finished chunks of a study"
            f"{_stopped(root)}: finish it (the finished chunks are not recomputed) with "
            f"`roverimpact sweep {study} -o {root} --resume`, then report again")
    if not found:
        raise ConfigError(
            f"{root}: no study results here ({RESULTS} in it or in its subfolders); "
            "run `roverimpact sweep` or `roverimpact reproduce` first"
        )
    return found


def _stopped(folder: Path) -> str:
    """`` (stopped after 8 of 40 cases: interrupted)`` from a study's manifest, or ``""``.
    The advice once said "nothing is recomputed", also of a study stopped half-way."""
    m = read_manifest(folder)
    try:
        done, n, status = int(m["n_done"]), int(m["n_cases"]), str(m["status"])
    except (ValueError, KeyError, TypeError):  # (TypeError: None, no manifest)
        return ""
    return f" (stopped after {done} of {n} cases: {status})"


def _fmt(v: float) -> str:
    return "n/a" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.3f}"


def correlation_subtitle(a: Agreement | None, force: str | None, n_whole_window: int = 0,
                         n_failed: int = 0) -> str:
    """One line of the agreement statistics (plain text; figures typeset it).
    ``n_failed``: cases without a peak force (failed simulations), left out."""
    if a is None:
        return "F_max unavailable (no simulation): correlation not computed"
    excl = f", {n_whole_window} whole-window excluded" if n_whole_window else ""
    excl += f", {n_failed} without {force} (simulation failed)" if n_failed else ""
    return (f"Spearman {_fmt(a.spearman.value)}, Kendall {_fmt(a.kendall.value)}, "
            f"Pearson {_fmt(a.pearson.value)} (T_c^- vs {force}, n={a.n}{excl})")


def _tc_agreement(sub, col: str, comp, n_boot: int, seed: int):
    """Agreement of T_c^- with the force ``col`` over the cases ``sub`` (None with fewer
    than 3 finite forces): ``comp``'s own (:func:`compare_indicators` of the same cases,
    bootstrap and seed) where it has one, which is the same to the bit, instead of a
    second bootstrap of 1000 resamples."""
    if np.isfinite(sub[col].to_numpy(float)).sum() < 3:
        return None
    tc = None if comp is None else comp.result("T_c_minus")
    if tc is not None and not tc.constant:
        return tc.agreement
    return agreement(sub["T_c_minus"], sub[col], n_boot=n_boot, seed=seed)


def analyse_folder(folder: str | Path, *, n_boot: int = 1000, seed: int = 0) -> StudySection:
    """Statistics and figures of one study folder (figures written into it).

    A table of more than :data:`~roverimpact.report.summary.LARGE_TABLE` rows is not read
    whole (:func:`_analyse_large`): the figure shows exact per-bin summaries of every case
    and the statistics come from a seeded random sample, as the report says.
    """
    check_n_boot(n_boot)
    folder = Path(folder)
    if (folder / RESULTS).is_file() and results_rows(folder / RESULTS) > LARGE_TABLE:
        return _analyse_large(folder, n_boot=n_boot, seed=seed)
    table, manifest, study = load_results(folder)
    check_writable(folder, folder=True, option=None)
    params = manifest.get("parameters") or (study.parameters() if study else [])
    x = manifest.get("x") or (params[0] if params else "case")
    if x not in table:
        raise ConfigError(f"{folder / RESULTS}: the swept parameter {x!r} is not a column")
    table = with_baselines(table)
    fcol = force_column(table)
    whole = whole_window_cases(table)
    if whole.any() and WHOLE_WINDOW not in table:
        table = table.assign(**{WHOLE_WINDOW: whole})
    agr, note = None, ""
    kept = table[~whole]
    engines = []
    for engine, col, suffix in simulated_forces(table, manifest.get("simulate", True)):
        ww = whole if col == "F_max" else whole_window_cases(table, suffix)
        comp = compare_indicators(table, col, exclude=ww, n_boot=n_boot, seed=seed,
                                  force_label=f"{ENGINE_LABELS.get(engine, engine)}'s F_max")
        a = _tc_agreement(table[~ww], col, comp, n_boot, seed)
        engines.append(EngineStats(engine, col, a, int(ww.sum()), comp,
                                   _ratios(table, col, engine, ww)))
    n_with = (int(np.isfinite(table["F_max"].to_numpy(float)).sum()) if "F_max" in table
              else 0)
    n_unposed = len(not_posed(table))
    n_failed = len(table) - n_with - n_unposed if n_with else 0
    if n_with and np.isfinite(kept["F_max"].to_numpy(float)).sum() >= 3:
        agr = engines[0].agreement
        if n_failed:
            note = _failed_note(n_failed)
        note = " ".join(t for t in (_constant_note(kept, "F_max"), note) if t)
    elif n_with >= 3:
        note = (f"F_max agreement not computed: fewer than 3 cases left once the "
                f"{int(whole.sum())} whole-window cases are excluded.")
    elif n_with:
        note = (f"F_max agreement not computed: {n_with} case{'s' if n_with != 1 else ''} "
                "with F_max, at least 3 are needed." + (" " + _failed_note(n_failed)
                                                       if n_failed else ""))
    else:
        note = _no_force_note(manifest, fcol)
    note = " ".join(t for t in (note, _not_posed_note(n_unposed)) if t)
    name = manifest.get("name") or (study.name if study else folder.name)
    n_ww = int(whole.sum())
    subtitle = correlation_subtitle(agr, "F_max", n_ww, n_failed)
    if len(engines) > 1:
        subtitle += "; " + "; ".join(
            f"{e.label}: Spearman {_fmt(e.agreement.spearman.value)} (n={e.agreement.n})"
            for e in engines[1:] if e.agreement is not None)
    if len(table) > PLOT_ALL_MAX and pd.api.types.is_numeric_dtype(table[x]):
        # every case drawn was a wall of markers (1e5 cases: one red and blue block)
        cols = ["T_c_minus", *([fcol] if fcol else [])]
        summ = summarize(folder / RESULTS, x, cols, binned=cols, seed=seed)
        dots = table.sample(n=PLOT_SAMPLE, random_state=seed).sort_index()
        fig = plot_study_summary(summ.bins, x, title=name, subtitle=subtitle, force=fcol,
                                 sample=dots)
    else:
        fig = plot_study(table, x, title=name, subtitle=subtitle,
                         group_by=[p for p in params if p != x] or None,
                         flagged=whole if n_ww else None,
                         flag_label="contact not ended in the window (excluded)",
                         forces=[(e.force, e.label) for e in engines] if len(engines) > 1
                         else None)
    figures = save_figure(fig, folder / "figure")
    maps = _study_map(folder, table, x, params, name, fcol)
    if agr is not None:
        _write_stats(folder, agr, n_ww, engines)
    text = (folder / STUDY_COPY).read_text() if (folder / STUDY_COPY).is_file() else ""
    return StudySection(folder=folder, name=name, table=table, manifest=manifest,
                        study_text=text, x=x, force=fcol, agreement=agr, figures=figures,
                        note=note, description=study.description if study else "",
                        n_whole_window=n_ww, engines=engines, maps=maps)


def _study_map(folder: Path, table: pd.DataFrame | None, x: str, params, name: str,
               force: str | None, *, grid: bool = False) -> dict[str, Path]:
    """``map.png`` and ``map.svg`` of a study over two numeric parameters whose cases are
    a grid (:func:`~roverimpact.report.plots.plot_study_map`). ``table`` None (a large
    study, whose table is not read whole): the columns the map needs are read from the
    results file if the study is a ``[grid]`` design (``grid``) of at most
    :data:`~roverimpact.report.plots.MAP_MAX_CELLS` cases. A study that is not such a grid
    has no map: one left by an earlier report of the folder is removed."""
    others = [p for p in params if p != x]
    fig = None
    if len(others) == 1:
        if table is None and grid:
            import pyarrow.parquet as pq

            path = folder / RESULTS
            names = pq.read_schema(path).names
            cols = [c for c in (x, others[0], "T_c_minus", force) if c and c in names]
            if pq.ParquetFile(path).metadata.num_rows <= MAP_MAX_CELLS:
                table = pq.read_table(path, columns=cols).to_pandas()
        if table is not None:
            fig = plot_study_map(table, x, others[0], title=name, force=force)
    if fig is None:
        for suffix in (".png", ".svg"):
            (folder / f"map{suffix}").unlink(missing_ok=True)
        return {}
    return save_figure(fig, folder / "map")


def _ratios(table: pd.DataFrame, col: str, engine: str, whole) -> list[ForceRatios]:
    """F_pred (and the refined predictions) over ``col`` on the true impacts."""
    out = []
    excl = np.asarray(whole, bool).copy()
    if "not_an_impact" in table:
        excl |= table["not_an_impact"].fillna(False).to_numpy(dtype=bool)
    preds = ["F_pred", "F_pred_refined"]
    if engine == "mujoco":
        preds.append("F_pred_refined_mujoco")
    for p in preds:
        if p in table and np.isfinite(table[p].to_numpy(float)).any():
            out.append(force_ratios(table[p], table[col], excl, prediction=p,
                                    force_name=col))
    return out


def _ratios_html(e: EngineStats) -> str:
    """Predicted / simulated peak force on the true impacts, one row per prediction."""
    if not e.ratios:
        return ""
    rows = "".join(
        f"<tr><th style='text-align:left'>{html.escape(r.prediction)} / "
        f"{html.escape(r.force)}</th><td>{_fmt(r.median)}</td><td>{_fmt(r.min)}</td>"
        f"<td>{_fmt(r.max)}</td><td>{r.n_within} of {r.n}</td></tr>" for r in e.ratios)
    tol = round(100 * e.ratios[0].tolerance)
    n_ex = e.ratios[0].n_excluded
    return (f"<table><tr><th>predicted / {html.escape(e.label)}'s peak force</th>"
            f"<th>median</th><th>min</th><th>max</th><th>within {tol}%</th></tr>{rows}"
            "</table><p class='small'>True impacts only: " + (
                f"{n_ex} case{'s' if n_ex != 1 else ''} left out (not an impact: the contact "
                "lasted the whole window or there was no approach; or no result)"
                if n_ex else "no case left out") +
            ". F_pred: closed form from (T_c^-, v_n); F_pred_refined: with the compliant, "
            "preloaded ground contacts and the weight (docs/contact.md, Newtons from "
            "T_c^-); F_pred_refined_mujoco: the same with the MuJoCo engine's "
            "spring-dampers.</p>")


def _analyse_large(folder: Path, *, n_boot: int, seed: int) -> StudySection:
    """:func:`analyse_folder` of a large table, streamed (:mod:`roverimpact.report.summary`):
    memory and time do not grow with the cases beyond one pass over a few columns."""
    _, manifest, study = load_results(folder, read_table=False)
    check_writable(folder, folder=True, option=None)
    params = manifest.get("parameters") or (study.parameters() if study else [])
    x = manifest.get("x") or (params[0] if params else "case")
    path = folder / RESULTS
    import pyarrow.parquet as pq

    names = pq.read_schema(path).names
    if x not in names:
        raise ConfigError(f"{path}: the swept parameter {x!r} is not a column")
    forces = ["F_max", "F_pred", *(c for c in names if c.startswith("F_max_"))]
    wanted = [*params, "T_c_minus", "v_n", "m_total", "m_eff_free", "T_n_total",
              "T_c_obstacle", "simulation.t_after", *forces,
              *(c for c in names if c.startswith(("contact_whole_window", "contact_duration",
                                                  "sim_error")))]
    summ = summarize(path, x, wanted, binned=["T_c_minus", *forces], seed=seed)
    sample = with_baselines(summ.sample)
    fcol = next((c for c in ("F_max", "F_pred") if summ.n_finite.get(c, 0) > 0), None)
    whole = whole_window_cases(sample)
    n_ww = summ.n_true.get(WHOLE_WINDOW, int(whole.sum()))
    ns = len(sample)
    of = f"a seeded random sample of {ns:,} of the {summ.n:,} cases (seed {seed})"
    engines = []
    for engine, col, suffix in simulated_forces(sample, manifest.get("simulate", True)):
        ww = whole if col == "F_max" else whole_window_cases(sample, suffix)
        comp = compare_indicators(sample, col, exclude=ww, n_boot=n_boot, seed=seed,
                                  force_label=f"{ENGINE_LABELS.get(engine, engine)}'s F_max")
        a = _tc_agreement(sample[~ww], col, comp, n_boot, seed)
        engines.append(EngineStats(engine, col, a, summ.n_true.get(WHOLE_WINDOW + suffix,
                                                                   int(ww.sum())), comp))
    agr = engines[0].agreement if engines and engines[0].force == "F_max" else None
    n_with = summ.n_finite.get("F_max", 0)
    n_unposed = count_not_posed(path)[0]
    n_failed = summ.n - n_with - n_unposed if n_with else 0
    if agr is not None:
        note = (f"{summ.n:,} cases: the statistics are computed on {of}; the figure "
                "summarizes every case." + (" " + _failed_note(n_failed) if n_failed
                                            else ""))
    else:
        note = _no_force_note(manifest, fcol)
    note = " ".join(t for t in (note, _not_posed_note(n_unposed)) if t)
    name = manifest.get("name") or (study.name if study else folder.name)
    subtitle = correlation_subtitle(agr, "F_max", n_ww, n_failed)
    if agr is not None:
        subtitle += f"; statistics on a random sample of {ns:,}"
    rng = np.random.default_rng(seed)
    pick = (np.sort(rng.choice(ns, size=min(ns, PLOT_SAMPLE), replace=False)) if ns
            else np.zeros(0, np.int64))
    dots = sample.iloc[pick]
    if summ.bins is not None:
        fig = plot_study_summary(summ.bins, x, title=name, subtitle=subtitle, force=fcol,
                                 sample=dots)
    else:  # x not numeric: the sample alone, as a small study
        fig = plot_study(dots, x, title=name, subtitle=subtitle + f" (random sample of "
                         f"{len(dots):,} of {summ.n:,} cases)")
    figures = save_figure(fig, folder / "figure")
    maps = _study_map(folder, None, x, params, name, fcol,
                      grid=study is not None and study.grid is not None)
    if agr is not None:
        _write_stats(folder, agr, n_ww, engines,
                     sample={"n_cases": summ.n, "n_sample": ns, "seed": seed})
    text = (folder / STUDY_COPY).read_text() if (folder / STUDY_COPY).is_file() else ""
    return StudySection(folder=folder, name=name, table=sample, manifest=manifest,
                        study_text=text, x=x, force=fcol, agreement=agr, figures=figures,
                        note=note, description=study.description if study else "",
                        n_whole_window=n_ww, engines=engines, n_rows=summ.n,
                        head=summ.head, maps=maps)


#: Dots drawn in the summary figure of a large study (a random subset of the sample).
PLOT_SAMPLE = 3000
#: A study of more cases (and a numeric x) is drawn as the summary figure of a large one
#: (per-bin median, 5-95 % band, range, and PLOT_SAMPLE random dots), its statistics
#: still computed on every case.
PLOT_ALL_MAX = 3000


def _constant_note(table: pd.DataFrame, force: str) -> str:
    """Why the correlations are n/a although there are enough cases: T_c^- or the force
    is the same in every case used (a correlation of a constant is undefined; it is
    never shown as 1), or ``""``."""
    x = table["T_c_minus"].to_numpy(float)
    y = table[force].to_numpy(float)
    ok = np.isfinite(x) & np.isfinite(y)
    same = [name for name, v in (("T_c^-", x[ok]), (force, y[ok]))
            if v.size >= 3 and np.ptp(v) == 0]
    if not same:
        return ""
    return (f"Correlations not defined: {' and '.join(same)} "
            f"{'is' if len(same) == 1 else 'are'} the same in all {int(ok.sum())} cases "
            "used, so nothing can be ranked.")


def _failed_note(n_failed: int) -> str:
    """The note of a study section where simulations failed."""
    return (f"{n_failed:,} case{'s' if n_failed != 1 else ''} without F_max (the simulation "
            "failed: see sim_error in the results) left out of the statistics and the "
            "figure's force points.")


def _not_posed_note(n: int) -> str:
    """The note of a study section with cases that could not be posed (``--on-error
    record``), or ""."""
    if not n:
        return ""
    return (f"{n:,} case{'s' if n != 1 else ''} could not be posed (see error in the "
            "results): no outputs, left out of the statistics and the figure.")


def _no_force_note(manifest: dict, fcol: str | None) -> str:
    """The note of a study section without simulated peak forces."""
    if manifest.get("simulate"):
        return "F_max unavailable: the compliant-contact simulator gave no result."
    return ("F_max unavailable: this study did not run the simulator (simulate = false); "
            + ("the right axis shows the contact law's predicted peak force F_pred."
               if fcol == "F_pred" else "only the indicator T_c^- is shown."))


def _write_stats(folder: Path, agr: Agreement, n_ww: int, engines: list[EngineStats],
                 **extra) -> None:
    """``stats.json`` of a study: T_c^- vs the reference engine's F_max, the baselines and
    every engine's statistics (``extra`` keys added as they are)."""
    stats = agr.as_dict() | {"n_whole_window": n_ww,
                             "whole_window": WHOLE_WINDOW_POLICY,
                             "engine": engines[0].engine, **extra,
                             "baselines": (engines[0].comparison.as_dict()
                                           if engines[0].comparison is not None else None),
                             "engines": {e.engine: e.as_dict() for e in engines}}
    text = json.dumps(_nulls(stats), indent=2, allow_nan=False)
    atomic_write(folder / "stats.json", lambda tmp: tmp.write_text(text))


def _nulls(obj):
    """NaN -> None, recursively (strict JSON)."""
    if isinstance(obj, dict):
        return {k: _nulls(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_nulls(v) for v in obj]
    return None if isinstance(obj, float) and not math.isfinite(obj) else obj


#: The style sheet of every HTML report (studies, reproduce, traverse).
REPORT_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:2em auto;
max-width:1100px;color:#222;padding:0 1em}
h1{font-size:1.6em}h2{border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:2em}
table{border-collapse:collapse;font-size:.8em;margin:.5em 0}
td,th{border:1px solid #ddd;padding:2px 6px;text-align:right}th{background:#f4f4f4}
pre{background:#f7f7f7;padding:.7em;overflow-x:auto;font-size:.8em}
.fig{max-width:100%;height:auto;border:1px solid #eee}.note{color:#a33}
details{margin:.5em 0}.small{color:#666;font-size:.85em}
"""


def _stats_table(a: Agreement, n_whole_window: int = 0) -> str:
    pct = round(100 * a.confidence)
    excl = (f" ({n_whole_window} whole-window case{'s' if n_whole_window != 1 else ''} "
            "excluded: their contact had not ended when the simulation stopped, so their "
            "F_max is not the peak of a finished impact; flagged in the results table)"
            if n_whole_window else "")
    rows = [("Spearman rank correlation", a.spearman), ("Kendall tau-b", a.kendall),
            ("Pearson correlation", a.pearson),
            ("concordant pair fraction", a.concordant_fraction)]
    body = "".join(
        f"<tr><th style='text-align:left'>{html.escape(n)}</th><td>{_fmt(e.value)}</td>"
        f"<td>[{_fmt(e.low)}, {_fmt(e.high)}]</td></tr>" for n, e in rows)
    return (f"<table><tr><th>statistic (T_c^- vs F_max)</th><th>value</th>"
            f"<th>{pct}% bootstrap CI</th></tr>{body}</table>"
            f"<p class='small'>n = {a.n} cases{excl}; pairs: {a.n_concordant} concordant, "
            f"{a.n_discordant} discordant, {a.n_tied} tied; bootstrap {a.n_boot} resamples, "
            f"seed {a.seed}.</p>")


def _baselines_html(e: EngineStats) -> str:
    """T_c^- and the baselines against one engine's F_max, and the statements."""
    c = e.comparison
    if c is None:
        return ""
    pct = round(100 * c.results[0].agreement.confidence)
    rows = []
    for r in c.results:
        a = r.agreement
        gain = ("" if r.spearman_gain is None else
                f"{_sgn(r.spearman_gain.value)} [{_sgn(r.spearman_gain.low)}, "
                f"{_sgn(r.spearman_gain.high)}]")
        rho = ("same in every case" if r.constant else
               f"{_fmt(a.spearman.value)} [{_fmt(a.spearman.low)}, {_fmt(a.spearman.high)}]")
        rows.append(f"<tr><th style='text-align:left'>{html.escape(r.label)}</th>"
                    f"<td>{rho}</td><td>{_fmt(a.kendall.value)}</td>"
                    f"<td>{_fmt(a.concordant_fraction.value)}</td><td>{gain}</td></tr>")
    items = "".join(f"<li>{html.escape(t)}</li>" for t in c.statements)
    return (f"<table><tr><th>indicator vs {html.escape(e.label)}'s F_max (n = {c.n})</th>"
            f"<th>Spearman [{pct}% CI]</th><th>Kendall tau-b</th><th>concordant</th>"
            f"<th>Spearman of T_c^- minus this [{pct}% CI, paired]</th></tr>"
            + "".join(rows) + "</table>" + (f"<ul>{items}</ul>" if items else ""))


def _sgn(v: float) -> str:
    return "n/a" if v is None or not math.isfinite(v) else f"{v:+.3f}"


def img_tag(png: Path, alt: str) -> str:
    """An ``<img>`` of a report holding the PNG file ``png`` itself (the study and the
    traverse reports)."""
    data = base64.b64encode(png.read_bytes()).decode("ascii")
    return f"<img class='fig' alt='{html.escape(alt)}' src='data:image/png;base64,{data}'>"


def _section_html(s: StudySection, anchor: str) -> str:
    img = "\n".join(img_tag(png, f"{s.name}: {what}") for png, what in (
        (s.figures.get("png"), f"T_c^- and peak force vs {s.x}"),
        (s.maps.get("png"), "map of T_c^- over the grid")) if png and png.is_file())
    outputs = [c for c in ("T_c_minus", "m_eff", "v_n", "F_pred", "F_pred_refined", "F_lo",
                           "F_hi", "not_an_impact", "T_n_total", "T_c_obstacle",
                           "F_max", "contact_duration", WHOLE_WINDOW) if c in s.table]
    for e in s.engines[1:]:
        sfx = e.force.removeprefix("F_max")
        outputs += [c for c in ("F_pred_refined" + sfx, e.force, "contact_duration" + sfx,
                                WHOLE_WINDOW + sfx) if c in s.table]
    params = s.manifest.get("parameters") or []
    cols = ["case", *[p for p in params if p in s.table], *outputs]
    rows = s.table if s.head is None else s.head
    cols = [c for c in cols if c in rows]
    shown = rows[cols].head(MAX_TABLE_ROWS)
    more = (f"<p class='small'>first {MAX_TABLE_ROWS} of {s.n_cases} rows; the full "
            f"table is {html.escape(str(s.folder / RESULTS))}</p>"
            if s.n_cases > MAX_TABLE_ROWS else "")
    parts = [f"<h2 id='{anchor}'>{html.escape(s.name)}</h2>"]
    if s.description:
        parts.append(f"<p>{html.escape(s.description)}</p>")
    parts.append(img)
    if s.agreement is not None:
        if len(s.engines) > 1:
            parts.append(f"<h3>{html.escape(s.engines[0].label)} (F_max)</h3>")
        parts.append(_stats_table(s.agreement, s.n_whole_window))
    if s.engines:
        parts.append(_baselines_html(s.engines[0]))
        parts.append(_ratios_html(s.engines[0]))
    for e in s.engines[1:]:
        parts.append(f"<h3>{html.escape(e.label)} ({html.escape(e.force)})</h3>")
        if e.agreement is not None:
            parts.append(_stats_table(e.agreement, e.n_whole_window).replace(
                "(T_c^- vs F_max)", f"(T_c^- vs {html.escape(e.force)})"))
        parts.append(_baselines_html(e))
        parts.append(_ratios_html(e))
    if s.note:
        parts.append(f"<p class='note'>{html.escape(s.note)}</p>")
    parts.append(f"<p class='small'>{s.n_cases} cases; swept: "
                 f"{html.escape(', '.join(params))}; folder {html.escape(str(s.folder))}</p>")
    parts.append("<details><summary>results table</summary>"
                 + shown.to_html(index=False, float_format=lambda v: f"{v:.6g}", border=0)
                 + more + "</details>")
    parts.append("<details><summary>study file (parameters)</summary><pre>"
                 + html.escape(s.study_text) + "</pre></details>")
    return "\n".join(parts)


def write_report(path: str | Path, sections: list[StudySection], *, title: str,
                 intro: str = "") -> Path:
    """Write the self-contained HTML report of ``sections`` to ``path``."""
    from .._version import __version__

    path = Path(path)
    versions = {}
    for s in sections:
        versions.update(s.manifest.get("versions", {}))
    versions.setdefault("roverimpact (report)", __version__)
    toc = "".join(f"<li><a href='#s{i}'>{html.escape(s.name)}</a></li>"
                  for i, s in enumerate(sections))
    vers = "".join(f"<tr><th style='text-align:left'>{html.escape(k)}</th>"
                   f"<td>{html.escape(str(v))}</td></tr>" for k, v in versions.items())
    body = "\n".join(_section_html(s, f"s{i}") for i, s in enumerate(sections))
    doc = (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
           f"<title>{html.escape(title)}</title><style>{REPORT_CSS}</style></head><body>"
           f"<h1>{html.escape(title)}</h1>"
           + (f"<p>{intro}</p>" if intro else "")
           + f"<ul>{toc}</ul>{body}<h2>Software versions</h2><table>{vers}</table>"
           "<p class='small'>Regenerate with <code>roverimpact report "
           f"{html.escape(str(path.parent))}</code>.</p></body></html>")
    atomic_write(path, lambda tmp: tmp.write_text(doc, encoding="utf-8"))
    return path


def missing_studies_note(root: str | Path) -> str:
    """A sentence naming the studies of ``root`` that the report leaves out, or ``""``:
    the built-in studies missing from a reproduction folder (one whose subfolders include
    a built-in study: the others' results deleted or never run), and any subfolder holding
    a study without its results (an interrupted run: its ``chunks/`` or ``manifest.json``
    but no ``results.parquet``; such a study was once left out without a word)."""
    from ..studies.builtin import BUILTIN_STUDIES

    root = Path(root)
    if (root / RESULTS).is_file() or not root.is_dir():
        return ""
    have = {p.parent.name for p in root.glob(f"*/{RESULTS}")}
    missing = []
    if have & set(BUILTIN_STUDIES):
        missing = [f"{s} ({BUILTIN_STUDIES[s]})" for s in BUILTIN_STUDIES if s not in have]
    unfinished = [p for p in sorted(root.iterdir())
                  if p.is_dir() and p.name not in have and p.name not in BUILTIN_STUDIES
                  and ((p / MANIFEST).is_file() or any((p / CHUNKS).glob("*.parquet")))]
    parts = []
    if missing:
        parts.append(f"Not in this report: {', '.join(missing)}: no {RESULTS} in its "
                     f"subfolder of {root} (deleted, or the reproduction did not finish); "
                     f"run `roverimpact reproduce -o {root}` again to recompute it.")
    for p in unfinished:
        parts.append(f"Not in this report: {p.name}, a study without {RESULTS}"
                     f"{_stopped(p)}; finish it with `roverimpact sweep {p / STUDY_COPY} "
                     f"-o {p} --resume`, then report again.")
    return " ".join(parts)


def build_report(root: str | Path, *, title: str | None = None, intro: str = "",
                 n_boot: int = 1000, seed: int = 0,
                 processes: int | None = None) -> tuple[Path, list[StudySection]]:
    """Regenerate the figures and ``report.html`` of a results folder from saved tables.

    A reproduction folder missing some of the built-in studies says so at the top of the
    report (:func:`missing_studies_note`). The studies' statistics and figures
    (:func:`analyse_folder`) are computed side by side in ``processes`` forked processes
    (default one per usable core, at most one per study,
    :func:`~roverimpact.studies.forked.side_by_side`; 1: one after the other here); the
    results are the same."""
    check_n_boot(n_boot)  # before any work
    root = Path(root)
    folders = find_study_folders(root)
    note = missing_studies_note(root)
    if note:
        intro = (intro + " " if intro else "") + f"<b>{html.escape(note)}</b>"
    for f in folders:  # every table readable, every folder writable: before any figure
        load_results(f, read_table=results_rows(f / RESULTS) <= LARGE_TABLE)
        check_writable(f, folder=True, option=None)
    check_writable(root, folder=True, option=None)
    n = side_by_side(len(folders)) if processes is None else processes
    try:
        sections = map_forked(lambda f, _: analyse_folder(f, n_boot=n_boot, seed=seed),
                              folders, processes=n)
    except ProcessDied as exc:
        if exc.item is None:  # pragma: no cover - died before it said which folder
            raise
        raise ProcessDied(f"the process drawing the figures of {folders[exc.item]} died "
                          f"({exc.how}; it may have run out of memory); the results are "
                          "kept: run `roverimpact report` again", exc.item, exc.how) from None
    title = title or ("roverimpact study report: " + (sections[0].name if len(sections) == 1
                                                       else root.name))
    return write_report(root / REPORT, sections, title=title, intro=intro), sections
