"""Figures and the HTML report of a traverse (``roverimpact traverse``).

* :func:`plot_map`: the hillshaded terrain around each path, the path coloured by risk
  (the predicted peak force of the worst wheel at each station, or T_c^- without a
  contact law; logarithmic colour scale), the worst impacts marked and numbered;
* :func:`plot_speed`: the speed limit along each path (per station and per segment), the
  reference speed and the top speed, with the risk below it;
* :func:`traverse_report`: ``map.png/svg``, ``speed.png/svg`` and a self-contained
  ``report.html`` (figures embedded, summary, segments, worst impacts, the traverse file,
  software versions) from the tables of an output folder: no recomputation.

Matplotlib's object-oriented API only (``matplotlib.figure.Figure``), as report/plots.py.
"""

from __future__ import annotations

import html
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from .._io import atomic_write, check_writable
from ..exceptions import ConfigError
from .html import REPORT_CSS, img_tag
from .plots import save_figure

__all__ = ["load_traverse_results", "plot_map", "plot_speed", "risk_column", "statistics",
           "summary", "traverse_report"]

REPORT = "report.html"
N_WORST = 10


def load_traverse_results(folder: str | Path):
    """``(poses, wheels, segments, manifest, config_text)`` of a traverse output folder."""
    from ..traverse.run import CONFIG_COPY, MANIFEST, POSES, SEGMENTS, WHEELS

    folder = Path(folder)
    missing = [f for f in (POSES, WHEELS, SEGMENTS) if not (folder / f).is_file()]
    if missing:
        raise ConfigError(f"{folder}: not a traverse output folder ({', '.join(missing)} "
                          "missing); run `roverimpact traverse FILE -o FOLDER` first")
    try:
        tables = [pd.read_parquet(folder / f) for f in (POSES, WHEELS, SEGMENTS)]
    except Exception as exc:  # a damaged file: one line naming it
        raise ConfigError(f"{folder}: cannot read the traverse tables ({exc})") from None
    man = {}
    if (folder / MANIFEST).is_file():
        try:
            man = json.loads((folder / MANIFEST).read_text(encoding="utf-8"))
        except (ValueError, UnicodeDecodeError) as exc:  # JSONDecodeError is a ValueError
            raise ConfigError(f"{folder / MANIFEST}: damaged, not a JSON file ({exc}); it is "
                              "the run's record (stations, time, versions): run the traverse "
                              "again") from None
        if not isinstance(man, dict):
            raise ConfigError(f"{folder / MANIFEST}: damaged, not a JSON object; it is the "
                              "run's record (stations, time, versions): run the traverse "
                              "again")
    text = (folder / CONFIG_COPY).read_text() if (folder / CONFIG_COPY).is_file() else ""
    return (*tables, man, text)


def risk_column(wheels: pd.DataFrame) -> tuple[str, str]:
    """The risk shown: ``F_model`` (N, the weight model of ``limits.model = "weight"``),
    else ``F_pred`` (N, the closed form) when a law was given, else ``T_c_minus`` (J)."""
    if "F_model" in wheels:
        return "F_model", "predicted peak force with the weight $F_{model}$ [N]"
    if "F_pred" in wheels:
        return "F_pred", r"predicted peak force $F_{pred}$ [N]"
    return "T_c_minus", r"effective kinetic energy $T_c^-$ [J]"


def _station_risk(poses, wheels, col):
    w = wheels[["path", "station", col]].copy()
    w[col] = w[col].fillna(0.0)
    per = w.groupby(["path", "station"], sort=False)[col].max()
    key = list(zip(poses["path"], poses["station"], strict=True))
    return np.array([per.get(k, np.nan) for k in key], dtype=float)


def _norm(values):
    from matplotlib.colors import LogNorm

    pos = values[np.isfinite(values) & (values > 0)]
    if pos.size == 0:
        return LogNorm(1e-3, 1.0)
    lo = max(float(np.percentile(pos, 5)), float(pos.max()) * 1e-4)
    return LogNorm(lo, float(pos.max()))


def plot_map(terrain, poses: pd.DataFrame, wheels: pd.DataFrame, *, path: str | None = None,
             title: str = "", n_worst: int = N_WORST, max_pixels: int = 1600):
    """Hillshaded terrain around a path (default: the first), the path coloured by risk,
    the ``n_worst`` strongest impacts marked (numbered by rank, at their contact points)."""
    from matplotlib.collections import LineCollection
    from matplotlib.colors import LightSource
    from matplotlib.figure import Figure

    name = path if path is not None else poses["path"].iloc[0]
    P = poses[poses["path"] == name]
    W = wheels[wheels["path"] == name]
    col, label = risk_column(W)
    risk = _station_risk(P, W, col)
    x, y = P["x"].to_numpy(), P["y"].to_numpy()
    pad = 1.5
    (xa, xb), (ya, yb) = terrain.extent
    x0, x1 = max(xa, x.min() - pad), min(xb, x.max() + pad)
    y0, y1 = max(ya, y.min() - pad), min(yb, y.max() + pad)
    j0, j1 = int((x0 - terrain.x0) / terrain.dx), math.ceil((x1 - terrain.x0) / terrain.dx)
    i0, i1 = int((y0 - terrain.y0) / terrain.dy), math.ceil((y1 - terrain.y0) / terrain.dy)
    z = terrain.z[i0:i1 + 1, j0:j1 + 1]
    step = max(1, math.ceil(max(z.shape) / max_pixels))
    z = z[::step, ::step]
    ls = LightSource(azdeg=315, altdeg=40)
    shade = ls.hillshade(z, vert_exag=2.0, dx=terrain.dx * step, dy=terrain.dy * step)
    ext = (terrain.x0 + j0 * terrain.dx, terrain.x0 + j1 * terrain.dx,
           terrain.y0 + i0 * terrain.dy, terrain.y0 + i1 * terrain.dy)
    aspect = (ext[3] - ext[2]) / max(ext[1] - ext[0], 1e-9)
    width = 11.0
    fig = Figure(figsize=(width, min(max(width * aspect + 2.0, 3.6), 11.0)),
                 layout="constrained")
    ax = fig.add_subplot()
    ax.imshow(shade, cmap="gray", origin="lower", extent=ext, vmin=0, vmax=1,
              interpolation="bilinear")
    pts = np.column_stack([x, y])
    segs = np.stack([pts[:-1], pts[1:]], axis=1)
    norm = _norm(risk)
    seg_risk = np.fmax(risk[:-1], risk[1:])
    lc = LineCollection(segs, cmap="inferno_r", norm=norm, linewidths=3.0)
    lc.set_array(np.clip(np.nan_to_num(seg_risk, nan=norm.vmin), norm.vmin, norm.vmax))
    ax.add_collection(lc)
    failed = P["status"].to_numpy() != "ok"
    if failed.any():
        ax.plot(x[failed], y[failed], "x", color="tab:blue", ms=5,
                label=f"no pose found ({int(failed.sum())})")
    hits = W[W[col].fillna(0) > 0].nlargest(n_worst, col)
    for rank, (_, h) in enumerate(hits.iterrows(), start=1):
        ax.plot(h["x_c"], h["y_c"], "o", mfc="none", mec="tab:cyan", mew=1.6, ms=11)
        ax.annotate(str(rank), (h["x_c"], h["y_c"]), xytext=(6, 6), textcoords="offset points",
                    color="tab:cyan", fontsize=9, weight="bold")
    if len(hits):
        ax.plot([], [], "o", mfc="none", mec="tab:cyan", mew=1.6,
                label=f"{len(hits)} strongest impacts (rank)")
    ax.plot(x[0], y[0], ">", color="tab:green", ms=9, label="start")
    ax.set_xlim(ext[0], ext[1])
    ax.set_ylim(ext[2], ext[3])
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(loc="upper right", fontsize=8, framealpha=0.85)
    wide = aspect < 0.6
    cb = fig.colorbar(lc, ax=ax, location="bottom" if wide else "right",
                      shrink=0.6 if wide else 0.8, pad=0.02, fraction=0.05, aspect=40)
    cb.set_label(label + " (worst wheel)")
    ax.set_title(title or f"{name}: risk along the path")
    return fig


def plot_speed(poses: pd.DataFrame, segments: pd.DataFrame, wheels: pd.DataFrame, *,
               v_ref: float, v_max: float | None = None, path: str | None = None,
               title: str = ""):
    """Speed limit along a path (stations and segments) over the risk at the reference
    speed (and its band over k and e, when given)."""
    from matplotlib.figure import Figure

    name = path if path is not None else poses["path"].iloc[0]
    P = poses[poses["path"] == name]
    S = segments[segments["path"] == name]
    W = wheels[wheels["path"] == name]
    col, label = risk_column(W)
    s = P["s"].to_numpy()
    v = P["v_lim"].to_numpy(float)
    finite = v[np.isfinite(v)]
    if v_max:                      # no limit below the top speed: drawn at the top speed
        top = v_max
    else:
        top = 2.0 * v_ref
        if finite.size:
            top = max(top, min(float(np.percentile(finite, 95)) * 1.1, 4 * v_ref))
    fig = Figure(figsize=(11, 6.2), layout="constrained")
    ax, ax2 = fig.subplots(2, 1, sharex=True, height_ratios=[3, 2])
    # no impact (inf): drawn at the top; no pose (NaN): no limit known, marked apart
    shown = np.where(np.isfinite(v), np.minimum(v, top), np.where(np.isinf(v), top, np.nan))
    ax.plot(s, shown, ".", ms=2.5, color="0.55", label="limit at each station")
    nopose = np.isnan(v)
    if nopose.any():
        ax.plot(s[nopose], np.zeros(int(nopose.sum())), "x", ms=4, color="tab:blue",
                clip_on=False, label=f"no pose found ({int(nopose.sum())})")
    if "v_lim_band" in P:
        vb = P["v_lim_band"].to_numpy(float)
        ax.plot(s, np.where(np.isfinite(vb), np.minimum(vb, top),
                            np.where(np.isinf(vb), top, np.nan)), ".", ms=2,
                color="tab:orange", alpha=0.6, label="limit over the k, e band (lowest)")
    if len(S):
        edges = np.r_[S["s0"].to_numpy(), S["s1"].to_numpy()[-1]]
        vs = S["v_lim"].to_numpy(float)
        vs = np.where(np.isfinite(vs), np.minimum(vs, top), np.where(np.isinf(vs), top, np.nan))
        ax.stairs(vs, edges, baseline=None, color="tab:red", lw=2.0, label="limit per segment")
    ax.axhline(v_ref, color="tab:blue", ls="--", lw=1, label=f"reference speed {v_ref:g} m/s")
    if v_max:
        ax.axhline(v_max, color="k", ls=":", lw=1, label=f"top speed {v_max:g} m/s")
    else:  # without a top speed, the axis' top holds "no limit" and limits above it
        over = [x for x in (v, S["v_lim"].to_numpy(float),
                            P["v_lim_band"].to_numpy(float) if "v_lim_band" in P else v)
                if (x > top).any()]
        if over:
            ax.axhline(top, color="k", ls=":", lw=1,
                       label=f"no limit, or one above {top:.3g} m/s (drawn here)")
    ax.set_ylim(0, top * 1.05)
    ax.set_ylabel("speed limit [m/s]")
    ax.legend(loc="lower right", fontsize=8, ncol=2, framealpha=0.85)
    ax.set_title(title or f"{name}: speed limit along the path")
    risk = _station_risk(P, W, col)
    ax2.semilogy(s, np.where(risk > 0, risk, np.nan), ".", ms=2.5, color="tab:purple",
                 label=f"worst wheel at {v_ref:g} m/s")
    if col in ("F_pred", "F_model") and "F_hi" in W:
        hi = _station_risk(P, W, "F_hi")
        lo = _station_risk(P, W, "F_lo")
        ax2.fill_between(s, np.where(lo > 0, lo, np.nan), np.where(hi > 0, hi, np.nan),
                         color="tab:purple", alpha=0.2, lw=0, label="band over k, e")
    finite = risk[np.isfinite(risk) & (risk > 0)]
    if finite.size:                # grazing contacts of a few micronewtons: not the story
        ax2.set_ylim(bottom=max(float(finite.min()), 1e-3 * float(finite.max())) / 1.5)
    ax2.set_ylabel(label.replace(r" [", "\n["))
    ax2.set_xlabel("distance along the path s [m]")
    ax2.legend(loc="upper right", fontsize=8)
    return fig


#: How an infinite speed limit (no impact limits the speed, and no ``drive.v_max``) is
#: shown in the report's tables and the command's summary
NO_LIMIT = "no limit"


def _cell(v) -> str:
    return "" if v != v else NO_LIMIT if v == math.inf else f"{v:.4g}"


#: Units of the tables' columns, shown in the report's headers ("v_lim [m/s]"); a column
#: whose name ends in ``_deg`` is in degrees
UNITS = {"s": "m", "s0": "m", "s1": "m", "s_worst": "m", "distance": "m", "x_c": "m",
         "y_c": "m", "z_c": "m", "T_c_minus": "J", "T_c_max": "J", "m_eff": "kg",
         "v_n": "m/s", "v_lim": "m/s", "v_lim_closed": "m/s", "v_lim_band": "m/s",
         "F_pred": "N", "F_model": "N", "F_lo": "N", "F_hi": "N", "F_pred_max": "N",
         "F_model_max": "N", "T_c_flat_nominal": "J", "T_c_flat_best": "J"}


def _with_unit(col: str) -> str:
    unit = UNITS.get(col, "deg" if col.endswith("_deg") else None)
    return col if unit is None else f"{col} [{unit}]"


def _table(df: pd.DataFrame, max_rows: int = 60) -> str:
    """``df`` as an HTML table: headers with their units (:data:`UNITS`), numbers to 4
    digits, NaN empty, an infinite speed limit :data:`NO_LIMIT` (not "inf")."""
    more = (f"<p class='small'>first {max_rows} of {len(df)} rows</p>"
            if len(df) > max_rows else "")
    df = df.head(max_rows)
    floats = [c for c in df.columns if df[c].dtype.kind == "f"]
    return df.rename(columns=_with_unit).to_html(
        index=False, border=0, na_rep="",
        formatters={_with_unit(c): _cell for c in floats}) + more


def summary(poses: pd.DataFrame, wheels: pd.DataFrame, config=None) -> pd.DataFrame:
    """One row per path: length (the polyline's, from the traverse ``config``; without it
    the last station's ``s``), stations, failed poses, impacts, worst T_c^- (and F_pred),
    the lowest speed limit and where (NaN where it is the config's top speed
    ``drive.v_max`` at every station: no impact limits the speed below it, there is no
    "where")."""
    lengths = {p.name: p.length for p in config.all_paths()} if config is not None else {}
    v_max = config.drive.v_max if config is not None else None
    rows = []
    for name, P in poses.groupby("path", sort=False):
        W = wheels[wheels["path"] == name]
        hit = W[W["T_c_minus"].fillna(0) > 0]
        v = P["v_lim"].to_numpy(float)
        i = int(np.nanargmin(v)) if np.isfinite(v).any() else None
        end = lengths.get(name, float(P["s"].max()))
        row = {"path": name, "length [m]": end, "stations": len(P),
               "failed poses": int((P["status"] != "ok").sum()), "impacts": len(hit),
               "max T_c^- [J]": float(hit["T_c_minus"].max()) if len(hit) else 0.0}
        for c in ("F_pred", "F_model"):
            if c in W:
                row[f"max {c} [N]"] = float(hit[c].max()) if len(hit) else 0.0
        # no finite limit: inf where every station with a pose is free of impacts, NaN
        # (n/a) where no station has a pose (as the segments' v_lim)
        row["lowest limit [m/s]"] = float(v[i]) if i is not None else (
            math.inf if np.isinf(v).any() else math.nan)
        capped = i is not None and v_max is not None and v[i] >= v_max
        row["at s [m]"] = float(P["s"].iloc[i]) if i is not None and not capped else math.nan
        rows.append(row)
    return pd.DataFrame(rows)


def statistics(poses: pd.DataFrame, wheels: pd.DataFrame, segments: pd.DataFrame, *,
               v_ref: float, F_allow: float | None = None) -> dict:
    """Figures of a traverse for a comparison table: stations, failed poses, impacts
    (T_c^- > 0), percentiles of the predicted peak force (:func:`risk_column`: the weight
    model's where it was used, else the closed form's), impacts above ``F_allow``, the
    share of stations and of segments whose limit is below the reference speed, the lowest
    segment limit, stations where a wheel moves faster than twice the path speed."""
    hit = wheels[wheels["T_c_minus"].fillna(0) > 0]
    out = {"stations": len(poses), "failed": int((poses["status"] != "ok").sum()),
           "impacts": len(hit),
           "T_c_max": float(hit["T_c_minus"].max()) if len(hit) else 0.0,
           "below_ref": float((poses["v_lim"] < v_ref).mean()),
           "segments_below_ref": float((segments["v_lim"] < v_ref).mean()),
           "segment_min": float(segments["v_lim"].min()),
           "fast_wheels": int((poses.get("wheel_speed_ratio", pd.Series(dtype=float)) > 2)
                              .sum())}
    col, _ = risk_column(wheels)
    if col != "T_c_minus" and len(hit):
        F = hit[col].to_numpy(float)
        F = F[np.isfinite(F)]
        out.update(F50=float(np.percentile(F, 50)), F90=float(np.percentile(F, 90)),
                   F99=float(np.percentile(F, 99)), F_max=float(F.max()))
        if F_allow is not None:
            out["over"] = int((F > F_allow).sum())
    return out


def _terrain_file_of_the_run(folder: Path, config, man: dict):
    """``config`` with the height-field file the run read (``terrain_file`` of
    ``manifest.json``: its absolute path): the copy's ``file = "dem.npy"`` is relative to
    the traverse file, not to the output folder nor to the working folder. A file changed
    since the run is refused (the map would not be the terrain of the tables)."""
    from ..traverse.run import file_sha256

    rec = man.get("terrain_file")
    if config.terrain.file is None or not isinstance(rec, dict) or "path" not in rec:
        return config            # a synthetic terrain, or a folder written before
    f = Path(rec["path"])
    if not f.is_file():
        raise ConfigError(f"{folder}: the traverse ran on the height field {f}, which is "
                          "gone: cannot redraw the map (put it back, or run the traverse "
                          "again)")
    if rec.get("sha256") not in (None, file_sha256(f)):
        raise ConfigError(f"{folder}: the height field {f} changed since the traverse ran "
                          "(its SHA-256 differs from terrain_file in manifest.json): a map "
                          "drawn on it would not be the terrain of the tables; restore it, or "
                          "run the traverse again")
    return config.model_copy(update={"terrain": config.terrain.model_copy(
        update={"file": str(f)})})


def traverse_report(folder: str | Path, *, terrain=None, config=None,
                    shown_as: str | Path | None = None) -> Path:
    """Draw ``map.png/svg`` and ``speed.png/svg`` (per path: ``map-<path>``..., the path's
    name made a file name by :func:`~roverimpact.traverse.schema.file_tag`: "route 1/a"
    gives ``map-route_1_a.png``) and write ``report.html`` in a traverse output folder;
    ``terrain`` and ``config`` default to those of the folder's ``traverse.toml``, which
    must be the copy the run wrote (``config_sha256`` of ``manifest.json``; folders
    written before the fingerprint are not checked). ``shown_as``: the folder's name in
    the report's redraw command (default ``folder``; ``roverimpact traverse`` draws the
    report in a staging folder beside the output folder and gives the output folder's)."""
    from ..traverse.run import build_terrain
    from ..traverse.schema import file_tag, traverse_from_dict

    folder = Path(folder)
    poses, wheels, segments, man, text = load_traverse_results(folder)
    check_writable(folder, folder=True, option=None)
    if config is None:
        from .._io import tomllib  # tomli on Python 3.10

        if not text:
            raise ConfigError(f"{folder}: traverse.toml missing: cannot redraw the map")
        try:
            raw = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise ConfigError(f"{folder / 'traverse.toml'}: malformed TOML ({exc}); it is the "
                              "copy of the traverse file the run wrote: restore it, or run "
                              "the traverse again") from None
        from ..traverse.run import config_fingerprint

        stored = man.get("config_sha256")
        if stored is not None and stored != config_fingerprint(text):
            raise ConfigError(
                f"{folder / 'traverse.toml'} was edited after the traverse ran (its SHA-256 "
                "differs from config_sha256 in manifest.json): the tables were computed with "
                "the original, so a report from the edited file would contradict them; "
                "restore it, or run `roverimpact traverse` on the edited file")
        config = traverse_from_dict(raw, where=str(folder / "traverse.toml"))
        config = _terrain_file_of_the_run(folder, config, man)
    if terrain is None:
        terrain = build_terrain(config.terrain)
    names = list(dict.fromkeys(poses["path"]))
    figs = []
    for name in names:
        tag = "" if len(names) == 1 else f"-{file_tag(str(name))}"
        f1 = plot_map(terrain, poses, wheels, path=name, title=f"{config.name}: {name}")
        f2 = plot_speed(poses, segments, wheels, v_ref=config.drive.speed,
                        v_max=config.drive.v_max, path=name)
        figs.append((name, save_figure(f1, folder / f"map{tag}", dpi=110),
                     save_figure(f2, folder / f"speed{tag}", dpi=110)))
    col, _ = risk_column(wheels)
    worst = wheels[wheels[col].fillna(0) > 0].nlargest(N_WORST, col)
    keep = [c for c in ("path", "s", "wheel", "distance", "x_c", "y_c", "z_c", "beta_deg",
                        "T_c_minus", "m_eff", "v_n", "F_pred", "F_model", "F_lo", "F_hi",
                        "v_lim", "v_lim_closed", "v_lim_band", "held") if c in worst]
    worst = worst[keep].assign(rank=np.arange(1, len(worst) + 1))
    lim = config.limits
    limit = (f"T_c^- at most {lim.T_allow:g} J" if lim.T_allow is not None
             else f"predicted peak force at most {lim.F_allow:g} N ("
             + (f"weight model: gravity {lim.g:g} m/s^2, supports {lim.ground_law.name} "
                f"k = {lim.ground_law.k:g}" if lim.model == "weight"
                else "closed form: no weight, rigid supports") + ")")
    law = config.contact_law
    law_text = (f"{law.name}, k = {law.k:g}" + (f", e = {law.e:g}" if law.e is not None else "")
                if law else "none (T_c^- only)")
    parts = [f"<h1>{html.escape(config.name)}</h1>"]
    if config.description:
        parts.append(f"<p>{html.escape(config.description)}</p>")
    parts.append(
        f"<p>Rover <code>{html.escape(config.model.name or str(config.model.file))}</code> "
        f"at the reference speed {config.drive.speed:g} m/s; speed limit: {html.escape(limit)}"
        f"; contact law: {html.escape(law_text)}; look-ahead per wheel "
        f"{', '.join(f'{config.look_ahead(p):g}' for p in config.all_paths())} m; active set "
        f"<code>{html.escape(str(config.constraints))}</code>, supports "
        f"<code>{config.contacts.ground}</code>. Computed in "
        f"{man.get('elapsed_s', float('nan')):.1f} s ({html.escape(str(man.get('executor', '')))})."
        "</p>")
    parts.append("<h2>Summary</h2>" + _table(summary(poses, wheels, config)))
    for name, m, s in figs:
        parts.append(f"<h2>{html.escape(name)}</h2>")
        parts.append(img_tag(m["png"], f"{name}: map"))
        parts.append("<p class='small'>Hillshaded terrain; the path coloured by the worst "
                     "wheel's risk at each station (log scale); circles: the strongest "
                     "impacts, numbered by rank (table below).</p>")
        parts.append(img_tag(s["png"], f"{name}: speed limit"))
    parts.append("<h2>Strongest impacts</h2>" + _table(worst))
    seg_cols = [c for c in segments.columns if c != "setting_note" or
                segments["setting_note"].astype(str).str.len().any()]
    parts.append("<h2>Segments</h2>" + _table(segments[seg_cols], 200))
    parts.append("<details><summary>traverse file</summary><pre>" + html.escape(text)
                 + "</pre></details>")
    vers = "".join(f"<tr><th style='text-align:left'>{html.escape(k)}</th>"
                   f"<td>{html.escape(str(v))}</td></tr>"
                   for k, v in man.get("versions", {}).items())
    parts.append(f"<h2>Software versions</h2><table>{vers}</table>")
    parts.append("<p class='small'>Tables: poses.parquet (one row per station), "
                 "wheels.parquet (per station and wheel), segments.parquet. Redraw with "
                 f"<code>roverimpact traverse-report "
                 f"{html.escape(str(folder if shown_as is None else shown_as))}</code>.</p>")
    doc = (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>"
           f"{html.escape(config.name)}</title><style>{REPORT_CSS}</style></head><body>"
           + "\n".join(parts) + "</body></html>")
    path = folder / REPORT
    atomic_write(path, lambda tmp: tmp.write_text(doc, encoding="utf-8"))
    return path
