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

from ..exceptions import ConfigError
from ..studies.stats import Agreement, agreement
from ..studies.sweep import RESULTS, STUDY_COPY, load_results
from .plots import force_column, plot_study, save_figure

__all__ = ["StudySection", "analyse_folder", "build_report", "find_study_folders"]

REPORT = "report.html"
MAX_TABLE_ROWS = 200


@dataclass
class StudySection:
    """What the report shows for one study folder."""

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


def find_study_folders(root: str | Path) -> list[Path]:
    """``root`` itself if it holds results, else its subfolders that do (sorted)."""
    root = Path(root)
    if not root.is_dir():
        raise ConfigError(f"{root}: no such folder")
    if (root / RESULTS).is_file():
        return [root]
    found = sorted(p.parent for p in root.glob(f"*/{RESULTS}"))
    if not found:
        raise ConfigError(
            f"{root}: no study results here ({RESULTS} in it or in its subfolders); "
            "run `roverimpact sweep` or `roverimpact reproduce` first"
        )
    return found


def _fmt(v: float) -> str:
    return "n/a" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.3f}"


def correlation_subtitle(a: Agreement | None, force: str | None) -> str:
    if a is None:
        return "F_max unavailable (no simulation): correlation not computed"
    return (f"Spearman {_fmt(a.spearman.value)}, Kendall {_fmt(a.kendall.value)}, "
            f"Pearson {_fmt(a.pearson.value)} (T_c^- vs {force}, n={a.n})")


def analyse_folder(folder: str | Path, *, n_boot: int = 1000, seed: int = 0) -> StudySection:
    """Statistics and figures of one study folder (figures written into it)."""
    folder = Path(folder)
    table, manifest, study = load_results(folder)
    params = manifest.get("parameters") or (study.parameters() if study else [])
    x = manifest.get("x") or (params[0] if params else "case")
    fcol = force_column(table)
    agr, note = None, ""
    if "F_max" in table and np.isfinite(table["F_max"].to_numpy(float)).sum() >= 3:
        agr = agreement(table["T_c_minus"], table["F_max"], n_boot=n_boot, seed=seed)
    elif manifest.get("simulate"):
        note = "F_max unavailable: the compliant-contact simulator gave no result."
    else:
        note = ("F_max unavailable: this study did not run the simulator (simulate = false); "
                + ("the right axis shows the contact law's predicted peak force F_pred."
                   if fcol == "F_pred" else "only the indicator T_c^- is shown."))
    name = manifest.get("name") or (study.name if study else folder.name)
    fig = plot_study(table, x, title=name, subtitle=correlation_subtitle(agr, "F_max"),
                     group_by=[p for p in params if p != x] or None)
    figures = save_figure(fig, folder / "figure")
    if agr is not None:
        (folder / "stats.json").write_text(json.dumps(agr.as_dict(), indent=2))
    text = (folder / STUDY_COPY).read_text() if (folder / STUDY_COPY).is_file() else ""
    return StudySection(folder=folder, name=name, table=table, manifest=manifest,
                        study_text=text, x=x, force=fcol, agreement=agr, figures=figures,
                        note=note, description=study.description if study else "")


_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:2em auto;
max-width:1100px;color:#222;padding:0 1em}
h1{font-size:1.6em}h2{border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:2em}
table{border-collapse:collapse;font-size:.8em;margin:.5em 0}
td,th{border:1px solid #ddd;padding:2px 6px;text-align:right}th{background:#f4f4f4}
pre{background:#f7f7f7;padding:.7em;overflow-x:auto;font-size:.8em}
.fig{max-width:100%;height:auto;border:1px solid #eee}.note{color:#a33}
details{margin:.5em 0}.small{color:#666;font-size:.85em}
"""


def _stats_table(a: Agreement) -> str:
    pct = round(100 * a.confidence)
    rows = [("Spearman rank correlation", a.spearman), ("Kendall tau-b", a.kendall),
            ("Pearson correlation", a.pearson),
            ("concordant pair fraction", a.concordant_fraction)]
    body = "".join(
        f"<tr><th style='text-align:left'>{html.escape(n)}</th><td>{_fmt(e.value)}</td>"
        f"<td>[{_fmt(e.low)}, {_fmt(e.high)}]</td></tr>" for n, e in rows)
    return (f"<table><tr><th>statistic (T_c^- vs F_max)</th><th>value</th>"
            f"<th>{pct}% bootstrap CI</th></tr>{body}</table>"
            f"<p class='small'>n = {a.n} cases; pairs: {a.n_concordant} concordant, "
            f"{a.n_discordant} discordant, {a.n_tied} tied; bootstrap {a.n_boot} resamples, "
            f"seed {a.seed}.</p>")


def _section_html(s: StudySection, anchor: str) -> str:
    png = s.figures.get("png")
    img = ""
    if png and png.is_file():
        data = base64.b64encode(png.read_bytes()).decode("ascii")
        img = (f"<img class='fig' alt='{html.escape(s.name)}: T_c^- and peak force vs "
               f"{html.escape(s.x)}' src='data:image/png;base64,{data}'>")
    outputs = [c for c in ("T_c_minus", "m_eff", "v_n", "F_pred", "F_max", "contact_duration")
               if c in s.table]
    params = s.manifest.get("parameters") or []
    cols = ["case", *[p for p in params if p in s.table], *outputs]
    shown = s.table[cols].head(MAX_TABLE_ROWS)
    more = (f"<p class='small'>first {MAX_TABLE_ROWS} of {len(s.table)} rows; the full "
            f"table is {html.escape(str(s.folder / RESULTS))}</p>"
            if len(s.table) > MAX_TABLE_ROWS else "")
    parts = [f"<h2 id='{anchor}'>{html.escape(s.name)}</h2>"]
    if s.description:
        parts.append(f"<p>{html.escape(s.description)}</p>")
    parts.append(img)
    if s.agreement is not None:
        parts.append(_stats_table(s.agreement))
    if s.note:
        parts.append(f"<p class='note'>{html.escape(s.note)}</p>")
    parts.append(f"<p class='small'>{len(s.table)} cases; swept: "
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
           f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>"
           f"<h1>{html.escape(title)}</h1>"
           + (f"<p>{intro}</p>" if intro else "")
           + f"<ul>{toc}</ul>{body}<h2>Software versions</h2><table>{vers}</table>"
           "<p class='small'>Regenerate with <code>roverimpact report "
           f"{html.escape(str(path.parent))}</code>.</p></body></html>")
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(doc, encoding="utf-8")
    tmp.replace(path)
    return path


def build_report(root: str | Path, *, title: str | None = None, intro: str = "",
                 n_boot: int = 1000, seed: int = 0) -> tuple[Path, list[StudySection]]:
    """Regenerate the figures and ``report.html`` of a results folder from saved tables."""
    root = Path(root)
    sections = [analyse_folder(f, n_boot=n_boot, seed=seed) for f in find_study_folders(root)]
    title = title or ("roverimpact study report: " + (sections[0].name if len(sections) == 1
                                                       else root.name))
    return write_report(root / REPORT, sections, title=title, intro=intro), sections
