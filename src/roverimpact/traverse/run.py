"""Run a traverse file: every path in chunks of stations, serially or on Dask; tables out.

:func:`run_traverse` validates the file and the output folder before any work, splits
every path into chunks of ``run.chunk`` stations (one task each: :func:`traverse_chunk`,
module-level so Dask can ship it; a worker builds the terrain and the rover once per
process), gathers the per-station and per-wheel rows, derives the speed-limit segments
(and, with ``[suspension]``, the least-risk setting of each), and writes

``poses.parquet``   one row per station: pose, status, worst impact, speed limit;
``wheels.parquet``  one row per station and wheel: next contact, T_c^-, m_eff, v_n,
                    F_pred (closed form), F_model (weight model) and the band, speed
                    limit, the rows held through the impact;
``segments.parquet`` one row per segment of ``drive.segment`` metres;
``traverse.toml``, ``manifest.json`` (inputs, software versions, timings).

Figures and the HTML report are drawn by :mod:`roverimpact.report.traverse`.
"""

from __future__ import annotations

import functools
import json
import math
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from ..exceptions import ConfigError, InputError, ModelError
from ..studies.store import atomic_parquet, atomic_write_bytes, check_out_dir, versions
from .compute import evaluate_stations
from .limits import band_laws, contact_duration, peak_force, speed_limit_energy, speed_limit_force
from .path import Stations, stations
from .schema import TerrainSpec, TraverseConfig, load_traverse, traverse_from_dict

__all__ = ["POSES", "SEGMENTS", "TRAVERSE_KERNELS", "WEIGHT_MODEL_KERNELS", "WHEELS",
           "TraverseResult", "build_terrain", "path_stations", "run_traverse",
           "traverse_chunk", "traverse_kernels"]

POSES, WHEELS, SEGMENTS = "poses.parquet", "wheels.parquet", "segments.parquet"
CONFIG_COPY, MANIFEST = "traverse.toml", "manifest.json"


# ------------------------------------------------------------------------ inputs
def _stamp(file: str | None) -> tuple | None:
    """(size, modification time) of a file, for the caches' keys: a file written again is
    read again (None: no file, or not one on disk)."""
    if file is None:
        return None
    try:
        st = Path(file).stat()
    except OSError:
        return None   # the loader names the missing file
    return (st.st_size, st.st_mtime_ns)


@functools.lru_cache(maxsize=4)
def _terrain(spec_json: str, stamp: tuple | None):
    """``stamp``: the file's (size, modification time) in the key, so that a file
    written again is read again."""
    spec = TerrainSpec.model_validate_json(spec_json)
    from ..models.terrain import HeightField
    from ..models.terrain_synth import synthetic_mars

    if spec.kind == "synthetic":
        try:
            return synthetic_mars(spec.size, spec.spacing, seed=spec.seed,
                                  **spec.synthetic_params())
        except InputError as exc:
            raise ConfigError(f"terrain: {exc}") from None
    return HeightField.from_file(spec.file, spec.spacing, spec.origin, nodata=spec.nodata)


def build_terrain(spec: TerrainSpec):
    """The terrain of ``[terrain]`` (cached per process: a Dask worker builds it once; a
    height-field file is read again when it has changed)."""
    return _terrain(spec.model_dump_json(), _stamp(spec.file))


@functools.lru_cache(maxsize=4)
def _model(model_json: str, loops_json: str, stamp: tuple | None):
    from ..scenario.build import make_model
    from ..scenario.schema import LoopSpec, ModelSpec

    spec = ModelSpec.model_validate_json(model_json)
    loops = [LoopSpec.model_validate(x) for x in json.loads(loops_json)]
    try:
        return make_model(spec, loops=loops)
    except (ModelError, InputError, ValueError) as exc:
        raise ConfigError(f"model: {exc}") from None


def build_model(cfg: TraverseConfig):
    """The rover of ``[model]`` (with ``[[contacts.loops]]``), cached per process; a
    ``model.file`` written again is read again (the meshes it names are not followed).
    The threads of a Dask worker share it: the traverse only reads it, and its frame
    loops take turns on their one Pinocchio data
    (:class:`~roverimpact.models.declare.FrameLoopClosure`)."""
    return _model(cfg.model.model_dump_json(),
                  json.dumps([lp.model_dump() for lp in cfg.contacts.loops]),
                  _stamp(cfg.model.file))


def path_stations(cfg: TraverseConfig, i: int) -> Stations:
    """Stations of the ``i``-th path."""
    p = cfg.all_paths()[i]
    return stations(p.points(), p.spacing)


def _check_inputs(cfg: TraverseConfig, where: str) -> None:
    """Model, terrain and paths that fit together: one ConfigError line otherwise."""
    from ..models.declare import base_info
    from ..models.pose import place

    mbm = build_model(cfg)
    if not mbm.wheels:
        raise ConfigError(f"{where}: model {mbm.name!r} has no wheels")
    kind = base_info(mbm).kind
    if kind == "fixed":
        raise ConfigError(f"{where}: model {mbm.name!r} has a fixed base: it cannot drive "
                          "(declare [model.base] kind = 'floating' or 'planar')")
    names = [w.name for w in mbm.wheels]
    for key, vals in (("contacts.wheels", cfg.contacts.wheels or []),):
        bad = [v for v in vals if v not in names]
        if bad:
            raise ConfigError(f"{where}: {key}: unknown wheel(s) {bad}; wheels: {names}")
    from ..models.joints import lock_row

    for j in cfg.contacts.locked:  # any 1-DoF joint, as a scenario's (a robot's steering)
        try:
            lock_row(mbm, j)
        except (ModelError, InputError) as exc:
            raise ConfigError(f"{where}: {exc}") from None
    lim = cfg.limits
    if lim.F_allow is not None and lim.model == "weight":
        from .refine import model_speed_cap

        cap = model_speed_cap(mbm, lim.window)
        if cap <= cfg.drive.speed:
            raise ConfigError(
                f"{where}: limits.window = {lim.window:g} s: the weight model (pose frozen "
                f"while the rover travels half its smallest wheel radius) covers speeds up "
                f"to {cap:.3g} m/s, not the reference drive.speed = {cfg.drive.speed:g} m/s: "
                "shorten the window (default 0.05 s) or lower the speed")
    terrain = build_terrain(cfg.terrain)
    # the rover's reach from its base: wheel centres + radius + look-ahead + 2 cells
    import pinocchio as pin

    q = place(mbm)   # the base at (x, y) = (0, 0) (q[:2] of a planar base is (x, z))
    data = mbm.model.createData()
    pin.framesForwardKinematics(mbm.model, data, q)
    centres = np.array([data.oMf[mbm.model.getFrameId(w.frame)].translation
                        for w in mbm.wheels])
    reach = max(np.hypot(*c[:2]) + w.radius for c, w in zip(centres, mbm.wheels, strict=True))
    (xa, xb), (ya, yb) = terrain.extent if hasattr(terrain, "extent") else (
        (-math.inf, math.inf), (-math.inf, math.inf))
    res = terrain.resolution if math.isfinite(terrain.resolution) else 0.0
    for i, p in enumerate(cfg.all_paths()):
        if kind == "planar":
            pts = np.asarray(p.points())
            if np.any(pts[:, 1] != 0.0) or np.any(np.diff(pts[:, 0]) <= 0):
                raise ConfigError(f"{where}: path {p.name!r}: the planar rover {mbm.name!r} "
                                  "drives along +x at y = 0; give waypoints [[x0, 0], [x1, 0]] "
                                  "with x1 > x0")
        st = path_stations(cfg, i)
        m = reach + cfg.look_ahead(p) + 2 * res
        # a planar rover moves in its plane: its wheels' discs stay at their own y
        my = (np.abs(centres[:, 1]).max() + 2 * res) if kind == "planar" else m
        out = (st.x < xa + m) | (st.x > xb - m) | (st.y < ya + my) | (st.y > yb - my)
        if out.any():
            k = int(np.flatnonzero(out)[0])
            across = "" if kind != "planar" else f", {my:.3f} m across its plane"
            raise ConfigError(
                f"{where}: path {p.name!r} leaves the terrain: station {k} at (x, y) = "
                f"({st.x[k]:.3f}, {st.y[k]:.3f}) m is within {m:.3f} m (the rover's reach "
                f"and look-ahead{across}) of the edge of the terrain (x in [{xa:.10g}, "
                f"{xb:.10g}] m, y in [{ya:.10g}, {yb:.10g}] m); {int(out.sum())} of "
                f"{len(st)} stations are")


# ------------------------------------------------------------------------ one chunk
#: The compiled kernels (``module:attribute``) a traverse's stations use (the
#: lane-parallel partition, the effective masses of single rows, Lemke's impact kernel),
#: and those the weight model adds: what a running scheduler's workers are asked about
#: (:func:`~roverimpact.studies.executors.check_workers`); ``cli._traverse._compile_plan``
#: compiles the same ahead for a run here
TRAVERSE_KERNELS = ("roverimpact._kernels.lanes_jit:LANES",
                    "roverimpact._kernels.masses:masses_kernel",
                    "roverimpact._kernels.lemke:impact_kernel")
WEIGHT_MODEL_KERNELS = ("roverimpact._kernels.reduced:rk4_peaks",
                        "roverimpact._kernels.reduced:stiff_peaks")


def traverse_kernels(cfg: TraverseConfig) -> tuple[str, ...]:
    """:data:`TRAVERSE_KERNELS`, and :data:`WEIGHT_MODEL_KERNELS` with ``F_allow`` and the
    weight model."""
    weight = cfg.limits.F_allow is not None and cfg.limits.model == "weight"
    return TRAVERSE_KERNELS + (WEIGHT_MODEL_KERNELS if weight else ())


def traverse_chunk(cfg_dict: dict, path_index: int, i0: int, i1: int, *,
                   code: dict | None = None):
    """Stations ``i0:i1`` of path ``path_index``: the poses table and the wheels table.

    ``code``: the submitting command's :func:`~roverimpact.studies.store.code_identity`;
    on a Dask worker of other code (one that joined after the command's
    :func:`~roverimpact.studies.executors.check_workers`) the chunk returns that error
    instead of its rows."""
    if code is not None:
        from ..studies.executors import other_code_error

        wrong = other_code_error(code, "it joined while the traverse ran: nothing was "
                                 "written; run it again once that worker is stopped")
        if wrong is not None:
            return wrong
    cfg = traverse_from_dict(cfg_dict)
    mbm = build_model(cfg)
    terrain = build_terrain(cfg.terrain)
    path = cfg.all_paths()[path_index]
    st = path_stations(cfg, path_index).slice(i0, i1)
    u = cfg.drive.speed
    res = evaluate_stations(mbm, terrain, st.x, st.y, st.yaw, u=u,
                            max_travel=cfg.look_ahead(path),
                            contacts=cfg.contacts.scenario_contacts(),
                            constraints=cfg.constraints, wheels=cfg.contacts.wheels)
    return _tables(cfg, mbm, path.name, st, i0, res)


def _tables(cfg, mbm, path_name, st: Stations, i0: int, res):
    k = len(st)
    names = list(res.wheels)
    nw = len(names)
    imp, hit = res.impact, res.hit
    T = imp.T_c_minus
    u = cfg.drive.speed
    has_impact = T > 0
    law = cfg.contact_law
    vn = np.where(has_impact, imp.v_n, np.nan)
    F = peak_force(law, imp.m_eff, vn) if law else None
    F_lo = F_hi = v_band = F_model = v_closed = None
    grid = band_laws(law, cfg.band.k, cfg.band.e, cfg.band.n) \
        if law is not None and cfg.band is not None else []
    weight = cfg.limits.F_allow is not None and cfg.limits.model == "weight"
    if grid and not weight:
        Fs = np.stack([peak_force(law, imp.m_eff, vn, k=kk, e=ee) for kk, ee in grid])
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore", RuntimeWarning)   # stations without impact
            F_lo, F_hi = np.nanmin(Fs, axis=0), np.nanmax(Fs, axis=0)
        if cfg.limits.F_allow is not None:
            vb = np.stack([speed_limit_force(law, imp.m_eff, vn, u, cfg.limits.F_allow,
                                             k=kk, e=ee) for kk, ee in grid])
            v_band = np.min(vb, axis=0)
    if cfg.limits.T_allow is not None:
        v_lim = speed_limit_energy(T, u, cfg.limits.T_allow)
    else:
        v_lim = speed_limit_force(law, imp.m_eff, vn, u, cfg.limits.F_allow)
    if weight:
        v_closed = v_lim
        laws = [law] + [law.model_copy(update={"k": kk, "e": ee}) for kk, ee in grid]
        Fm, Vm, F_cut = _weight_model(cfg, mbm, res, has_impact, v_closed, laws)
        F_model, v_lim = Fm[0], Vm[0]
        if grid:       # the nominal law with the grid (the model need not be monotone)
            with warnings.catch_warnings(), np.errstate(all="ignore"):
                warnings.simplefilter("ignore", RuntimeWarning)   # stations without impact
                F_lo, F_hi = np.nanmin(Fm, axis=0), np.nanmax(Fm, axis=0)
            v_band = np.min(Vm, axis=0)
    ok = np.asarray(res.pose.status) == "ok"
    v_lim = np.where(ok[:, None], np.where(np.isnan(v_lim), np.inf, v_lim), np.nan)
    if v_band is not None:
        v_band = np.where(ok[:, None], np.where(np.isnan(v_band), np.inf, v_band), np.nan)
    station = np.arange(i0, i0 + k)
    rep = lambda a: np.repeat(a, nw)  # noqa: E731
    pt, nr = hit["point"], hit["normal"]
    wheels = {
        "path": np.full(k * nw, path_name, dtype=object), "station": rep(station),
        "s": rep(st.s), "wheel": np.tile(names, k),
        "found": hit["found"].ravel(), "distance": hit["distance"].ravel(),
        "x_c": pt[..., 0].ravel(), "y_c": pt[..., 1].ravel(), "z_c": pt[..., 2].ravel(),
        "n_x": nr[..., 0].ravel(), "n_y": nr[..., 1].ravel(), "n_z": nr[..., 2].ravel(),
        "beta_deg": np.degrees(hit["beta"]).ravel(),
        "alpha_deg": np.degrees(hit["alpha"]).ravel(),
        "T_c_minus": np.where(ok[:, None], T, np.nan).ravel(),
        "v_n": imp.v_n.ravel(), "m_eff": imp.m_eff.ravel(),
        "wheel_speed_ratio": (res.extra["wheel_speed"] / u).ravel(),
    }
    if F is not None:
        wheels["F_pred"] = F.ravel()
    if F_model is not None:
        wheels["F_model"] = F_model.ravel()
        wheels["F_model_rising"] = F_cut.ravel()
    if F_lo is not None:
        wheels["F_lo"], wheels["F_hi"] = F_lo.ravel(), F_hi.ravel()
    wheels["v_lim"] = v_lim.ravel()
    if v_closed is not None:
        wheels["v_lim_closed"] = np.where(ok[:, None], np.where(np.isnan(v_closed), np.inf,
                                                               v_closed), np.nan).ravel()
    if v_band is not None:
        wheels["v_lim_band"] = v_band.ravel()
    wheels["held"] = imp.held.ravel().astype(str)
    wdf = pd.DataFrame(wheels)
    # one row per station
    with np.errstate(all="ignore"):
        Tm = np.where(ok[:, None], T, np.nan)
        worst = np.where(ok & (Tm.max(axis=1, initial=0.0) > 0),
                         np.nanargmax(np.where(np.isnan(Tm), -1.0, Tm), axis=1), -1)
    q = res.pose.q
    poses = {"path": np.full(k, path_name, dtype=object), "station": station, "s": st.s,
             "x": st.x, "y": st.y, "yaw_deg": np.degrees(st.yaw),
             "status": np.asarray(res.pose.status).astype(str),
             "iterations": np.asarray(res.pose.iterations)}
    poses.update(_pose_columns(mbm, q))
    with np.errstate(all="ignore"):
        poses["wheel_speed_ratio"] = np.nanmax(np.where(ok[:, None], res.extra["wheel_speed"],
                                                        -1.0), axis=1) / u
    poses["wheel_speed_ratio"] = np.where(ok, poses["wheel_speed_ratio"], np.nan)
    poses["n_impacts"] = has_impact.sum(axis=1)
    poses["worst_wheel"] = np.where(worst >= 0, np.asarray(names, dtype=object)[worst], "")
    poses["T_c_max"] = np.where(ok, T.max(axis=1), np.nan)
    if F is not None:
        poses["F_pred_max"] = np.where(ok, np.nanmax(np.where(np.isnan(F), 0.0, F), axis=1),
                                       np.nan)
    if F_model is not None:
        poses["F_model_max"] = np.where(ok, np.nanmax(np.where(np.isnan(F_model), 0.0,
                                                               F_model), axis=1), np.nan)
    if F_hi is not None:
        poses["F_hi_max"] = np.where(ok, np.nanmax(np.where(np.isnan(F_hi), 0.0, F_hi),
                                                   axis=1), np.nan)
    cap = cfg.drive.v_max if cfg.drive.v_max is not None else np.inf
    poses["v_lim"] = np.minimum(v_lim.min(axis=1), cap)
    if v_band is not None:
        poses["v_lim_band"] = np.minimum(v_band.min(axis=1), cap)
    return pd.DataFrame(poses), wdf


def _weight_model(cfg, mbm, res, has_impact, v_closed, laws):
    """The weight model (:mod:`roverimpact.traverse.refine`) of every impact for each law
    spec of ``laws``: peak forces (L, k, nw) [N] at the reference speed and speed limits
    (L, k, nw) [m/s] for ``limits.F_allow`` (NaN / inf without an impact). The limits are
    capped at the top speed ``drive.v_max`` and at the model's own cap
    (:func:`~roverimpact.traverse.refine.model_speed_cap`); a rigid lock (m_eff = inf)
    keeps the closed form's limit 0, and so does an impact the model cannot take (a contact
    normal along the wheel's axis: NaN ``F_model``). Third: (k, nw), the nominal law's
    force still rising when ``limits.window`` ends, the window shorter than the impact's
    closed-form duration (:func:`~roverimpact.traverse.limits.contact_duration`), and a
    limit below the cap: its peak is later and higher, its limit may be too high."""
    from .refine import impact_models, model_speed_cap, peak_forces, speed_limits

    k, nw = has_impact.shape
    L = len(laws)
    F_model = np.full((L, k, nw), np.nan)
    cut = np.zeros((k, nw), dtype=bool)
    v_lim = np.broadcast_to(np.where(has_impact, v_closed, np.inf), (L, k, nw)).copy()
    st = res.extra.get("states")
    lim = cfg.limits
    u = cfg.drive.speed
    items = np.argwhere(has_impact & np.isfinite(res.impact.m_eff))
    if st is None or items.size == 0:
        return F_model, v_lim, cut
    ok_index = res.extra["ok_index"]
    pos = np.full(k, -1)
    pos[ok_index] = np.arange(ok_index.size)
    kk, ww = items[:, 0], items[:, 1]
    contacts = cfg.contacts.scenario_contacts()
    models = impact_models(mbm, st, res.v[ok_index], res.pose.normal[ok_index], pos[kk], ww,
                           res.hit["normal"][kk, ww], supports=res.extra["chosen"],
                           locked=contacts.locked, gravity=[0.0, 0.0, -lim.g],
                           loop_closure=contacts.loop_closure)
    ground = lim.ground_law.to_law()
    cap = min(cfg.drive.v_max or np.inf, model_speed_cap(mbm, lim.window))
    s0 = v_closed[kk, ww] / u
    for i, spec in enumerate(laws):
        law = spec.to_law()
        pk = peak_forces(models, law, ground, t_max=lim.window, v_ref=lim.ground_law.v_ref)
        F_model[i, kk, ww] = pk.peak_force
        if i == 0:  # still rising when the window ends, within the impact itself
            # a force still rising after the impact's closed-form duration is the wheel
            # taking its weight share (climbing), which the window is meant to cut
            cut[kk, ww] = (~pk.ended & (pk.time_of_peak >= lim.window * (1.0 - 1e-6))
                           & (lim.window < contact_duration(spec, res.impact.m_eff[kk, ww],
                                                            res.impact.v_n[kk, ww])))
        vl = speed_limits(models, law, ground, u, lim.F_allow, s0=s0, s_max=cap / u,
                          t_max=lim.window, v_ref=lim.ground_law.v_ref)
        # no model (a contact normal along the wheel's axis): the closed form's limit
        v_lim[i, kk, ww] = np.where(np.isnan(vl), v_closed[kk, ww], vl)
        if i == 0:                      # the nominal law's limits start the band's search
            s0 = np.where(np.isfinite(v_lim[0, kk, ww]) & (v_lim[0, kk, ww] > 0),
                          v_lim[0, kk, ww] / u, s0)
    # only where the limit binds (below the cap): a grazing contact (v_n ~ 1e-5 m/s, a few
    # N taking its weight share for longer than the window) keeps the cap
    cut &= v_lim[0] < cap * (1.0 - 1e-9)
    return F_model, v_lim, cut


def _pose_columns(mbm, q) -> dict:
    """Base height, roll, pitch [deg] and the suspension joint values of each pose."""
    import pinocchio as pin

    from ..models.declare import base_info
    from ..models.joints import joint_value

    out = {}
    info = base_info(mbm)
    model = mbm.model
    if info.kind == "floating":
        j = model.joints[model.getJointId(info.joints[0])]
        out["z"] = q[:, j.idx_q + 2]
        rpy = np.array([pin.rpy.matrixToRpy(pin.Quaternion(x[j.idx_q + 3:j.idx_q + 7])
                                            .normalized().toRotationMatrix())
                        if np.isfinite(x).all() else np.full(3, np.nan) for x in q])
        out["roll_deg"], out["pitch_deg"] = np.degrees(rpy[:, 0]), np.degrees(rpy[:, 1])
    elif info.kind == "planar":
        jz, jp = (model.joints[model.getJointId(n)] for n in info.joints[1:])
        out["z"], out["pitch_deg"] = q[:, jz.idx_q], np.degrees(q[:, jp.idx_q])
    for name in mbm.lockable_joints:
        try:
            out[f"{name}_deg"] = np.degrees(joint_value(mbm, q, name))
        except (ModelError, InputError):
            pass
    return out


# ------------------------------------------------------------------------ segments
def segments_table(cfg: TraverseConfig, poses: pd.DataFrame, wheels: pd.DataFrame
                   ) -> pd.DataFrame:
    """One row per ``drive.segment`` metres of each path: the speed limit (the least of
    its stations'), the worst impact (wheel, T_c^-, beta range of that wheel's impacts).
    The last segment ends at the end of the path (shorter than ``drive.segment`` where the
    path's length is not a multiple of it) and holds a station at the very end."""
    rows = []
    L = cfg.drive.segment
    length = {p.name: p.length for p in cfg.all_paths()}
    for name, P in poses.groupby("path", sort=False):
        W = wheels[wheels["path"] == name]
        end = length.get(name, float(P["s"].max()))
        last = max(math.ceil(end / L - 1e-9) - 1, 0)
        seg = np.minimum(np.floor(P["s"].to_numpy() / L + 1e-9).astype(int), last)
        wseg = np.minimum(np.floor(W["s"].to_numpy() / L + 1e-9).astype(int), last)
        for g in np.unique(seg):
            p = P[seg == g]
            w = W[(wseg == g) & (W["T_c_minus"].to_numpy() > 0)]
            row = {"path": name, "segment": int(g), "s0": g * L,
                   "s1": min((g + 1) * L, end) if g == last else (g + 1) * L,
                   "stations": len(p), "failed": int((p["status"] != "ok").sum()),
                   "v_lim": float(p["v_lim"].min()) if p["v_lim"].notna().any() else math.nan,
                   "n_impacts": len(w)}
            if "v_lim_band" in p:
                row["v_lim_band"] = float(p["v_lim_band"].min())
            if len(w):
                i = int(np.argmax(w["T_c_minus"].to_numpy()))
                worst = w.iloc[i]
                ww = w[w["wheel"] == worst["wheel"]]
                row.update(worst_wheel=worst["wheel"], T_c_max=float(worst["T_c_minus"]),
                           beta_min_deg=float(ww["beta_deg"].min()),
                           beta_max_deg=float(ww["beta_deg"].max()),
                           s_worst=float(worst["s"]))
                for c in ("F_pred", "F_model"):
                    if c in w:
                        row[f"{c}_max"] = float(w[c].max())
            else:
                row.update(worst_wheel="", T_c_max=0.0, beta_min_deg=math.nan,
                           beta_max_deg=math.nan, s_worst=math.nan)
            rows.append(row)
    return pd.DataFrame(rows)


# ------------------------------------------------------------------------ the run
@dataclass
class TraverseResult:
    """Outcome of :func:`run_traverse`: the tables, the output folder and the files."""

    config: TraverseConfig
    out_dir: Path | None
    poses: pd.DataFrame
    wheels: pd.DataFrame
    segments: pd.DataFrame
    elapsed: float
    files: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)
    #: where the stations ran (also in the manifest)
    executor: str = "serial"


def _chunks(cfg: TraverseConfig) -> list[tuple[int, int, int]]:
    out = []
    for i in range(len(cfg.all_paths())):
        n = len(path_stations(cfg, i))
        out += [(i, a, min(n, a + cfg.run.chunk)) for a in range(0, n, cfg.run.chunk)]
    return out


#: The probe that sizes the work before a local cluster is started: about this fraction
#: of the first chunk's stations (at least 2), computed here and discarded.
PROBE_FRACTION = 1 / 64


def _local_or_serial(cfg_dict, chunks, total, workers) -> str | None:
    """Whether the stations run on a local cluster of ``workers``: None if so, else why
    they run here (:func:`~roverimpact.studies.executors.why_serial`). One station first
    builds the terrain and the model and loads or compiles every compiled function a
    station needs, which forked workers then inherit instead of each compiling them (a
    first run with ``--workers 2`` took 35.6 s where a serial one took 22 s); then about
    :data:`PROBE_FRACTION` of the first chunk (at least 2 stations), and one station, timed:
    the difference separates what a chunk costs once from what a station costs."""
    from ..studies.executors import why_serial

    i, a, b = chunks[0]
    k = min(b - a, max(2, math.ceil((b - a) * PROBE_FRACTION)))
    return why_serial(workers, len(chunks), lambda n: traverse_chunk(cfg_dict, i, a, a + n),
                      k, total, unit="stations")


def run_traverse(source, out_dir: str | Path | None = None, *, workers: int | None = None,
                 scheduler: str | None = None, csv: bool = False,
                 progress: Callable[[int, int], None] | None = None,
                 note: Callable[[str], None] | None = None,
                 prepare: Callable[[], None] | None = None) -> TraverseResult:
    """Run a traverse file (path, dict or :class:`TraverseConfig`) and write its tables.

    Parameters
    ----------
    source : path, dict or TraverseConfig
    out_dir : path, optional
        Output folder (None: nothing is written).
    workers, scheduler
        A local Dask cluster of ``workers`` processes, or a running scheduler's address;
        default from ``[run]``, else serial.
    csv : bool
        Also write the tables as CSV.
    progress : callable, optional
        ``progress(stations_done, stations_total)``.
    note : callable, optional
        ``note(text)``: why ``workers`` were asked for but the stations ran here (a
        single chunk, or less work than the cluster costs to start, timed on a probe of
        a few stations first; :func:`_local_or_serial`).
    prepare : callable, optional
        ``prepare()``: called once the inputs are checked, before any station and before
        a local cluster forks its workers (the command line compiles its kernels there:
        a path that leaves the terrain is refused without waiting for a compile).

    Raises
    ------
    ConfigError
        A bad file, a path that leaves the terrain, an unwritable folder, an unreachable
        scheduler: before any work.
    """
    from ..studies.executors import (
        check_scheduler,
        check_workers,
        compile_note,
        local_cluster,
        need_dask,
        worker_start_method,
    )

    if isinstance(source, (TraverseConfig, dict)):
        # relative file names from the working folder, made absolute: a Dask worker
        # started in another folder read them from its own
        cfg, text = traverse_from_dict(source, base_dir=Path.cwd()), None
    else:
        from .._io import read_text_utf8, tomllib

        cfg, text = load_traverse(source), read_text_utf8(source)
        if cfg != traverse_from_dict(tomllib.loads(text), where=str(source)):
            # file names relative to the traverse file: the copy written next to the
            # results names them by absolute path, so that it runs from there too
            text = None
    where = str(source) if isinstance(source, (str, Path)) else "traverse"
    if out_dir is not None:          # refused before any work; created only to write
        from .._io import check_writable

        out_dir = Path(out_dir)
        check_writable(out_dir, folder=True, option="-o")
    workers = workers if workers is not None else cfg.run.workers
    scheduler = scheduler if scheduler is not None else cfg.run.scheduler
    if workers is not None and scheduler is not None:
        raise ConfigError("give --workers (a local cluster) or --scheduler, not both")
    if scheduler is not None:
        need_dask()
        scheduler = check_scheduler(scheduler, note=note)
        cold = check_workers(scheduler, traverse_kernels(cfg))
        if cold and note is not None:
            note(compile_note(cold))
    elif workers is not None:
        need_dask()
        worker_start_method()  # a bad ROVERIMPACT_WORKER_START fails before any work
    _check_inputs(cfg, where)
    if prepare is not None:
        prepare()
    chunks = _chunks(cfg)
    total = sum(b - a for _, a, b in chunks)
    # the keys given only: a default the schema would refuse as ignored (limits.gravity
    # with T_allow) is not written out
    cfg_dict = cfg.model_dump(mode="json", exclude_unset=True)
    t0 = time.perf_counter()
    parts: dict[int, tuple] = {}
    done = 0
    if progress:
        progress(0, total)
    executor = ("dask " + str(scheduler)) if scheduler is not None else "serial"
    if workers is not None and scheduler is None:
        why = _local_or_serial(cfg_dict, chunks, total, workers)
        if why is None:
            executor = f"dask local {workers} workers"
        else:
            executor, workers = why, None
            if note:
                note(why)
    if workers is None and scheduler is None:
        for n, (i, a, b) in enumerate(chunks):
            parts[n] = traverse_chunk(cfg_dict, i, a, b)
            done += b - a
            if progress:
                progress(done, total)
    elif scheduler is not None:
        done = _run_dask(scheduler, cfg_dict, chunks, parts, progress, total)
    else:
        with local_cluster(workers) as address:
            _run_dask(address, cfg_dict, chunks, parts, progress, total)
    elapsed = time.perf_counter() - t0
    poses = pd.concat([parts[n][0] for n in range(len(chunks))], ignore_index=True)
    wheels = pd.concat([parts[n][1] for n in range(len(chunks))], ignore_index=True)
    segments = segments_table(cfg, poses, wheels)
    timings = {"stations": float(elapsed)}
    said = []
    rising = int(wheels["F_model_rising"].sum()) if "F_model_rising" in wheels else 0
    if rising:
        said.append(f"{rising} impact(s) still loading when limits.window = "
                    f"{cfg.limits.window:g} s ended (wheels.parquet: F_model_rising): their "
                    "F_model is below the peak and their speed limits too high; lengthen the "
                    "window")
    stuck = wheels[wheels["v_lim"] == 0.0]
    if len(stuck):
        said.append(
            f"{len(stuck)} impact(s) at {stuck['station'].nunique()} station(s) allow no speed "
            f"(v_lim = 0, the first at s = {stuck['s'].iloc[0]:g} m of path "
            f"{stuck['path'].iloc[0]!r}): the weight model's force exceeds limits.F_allow even "
            "at 1 % of drive.speed (the wheel's weight share), or the wheel is locked against "
            "the feature (m_eff infinite); drive round them, or check limits.F_allow")
    for msg in said:
        if note:
            note(msg)
        else:
            warnings.warn(msg, UserWarning, stacklevel=2)
    if cfg.suspension is not None:
        from .suspension import least_risk_settings

        t1 = time.perf_counter()
        segments = least_risk_settings(cfg, segments)
        timings["suspension"] = time.perf_counter() - t1
    res = TraverseResult(config=cfg, out_dir=out_dir, poses=poses, wheels=wheels,
                         segments=segments, elapsed=elapsed, timings=timings,
                         executor=executor)
    if out_dir is not None:
        check_out_dir(out_dir)
        _write(res, text, csv)
    return res


def _run_dask(address, cfg_dict, chunks, parts, progress, total) -> int:
    from dask.distributed import Client, as_completed

    from ..studies.executors import as_finished, worker_result
    from ..studies.store import code_identity

    done = 0
    code = code_identity()   # each chunk checks it on its worker (other_code_error)
    with Client(address, timeout="10s") as client:
        futures = {client.submit(traverse_chunk, cfg_dict, i, a, b, code=code, retries=2,
                                 pure=False): n
                   for n, (i, a, b) in enumerate(chunks)}
        # every worker gone: a bounded wait for one, not for ever
        for fut in as_finished(as_completed(list(futures)), client, address,
                               then="rerun once workers run again"):
            n = futures[fut]
            i, a, b = chunks[n]
            parts[n] = worker_result(fut, address, what=f"the chunk of stations {a}-{b - 1} "
                                     f"of path {i}")
            done += b - a
            if progress:
                progress(done, total)
            fut.release()
    return done


def file_sha256(path: str | Path) -> str:
    """SHA-256 (hex) of a file's bytes, read in blocks (a DEM may be large)."""
    import hashlib

    h = hashlib.sha256()
    with Path(path).open("rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def config_fingerprint(text: str) -> str:
    """SHA-256 (hex) of the traverse file copy's text, stored in ``manifest.json`` as
    ``config_sha256``: ``traverse-report`` refuses a copy edited since the run. Line
    endings are normalised to ``\\n`` first (as reading the file back in text mode does)."""
    import hashlib

    return hashlib.sha256(text.replace("\r\n", "\n").encode()).hexdigest()


def _write(res: TraverseResult, text: str | None, csv: bool) -> None:
    from .._io import tomllib  # tomli on Python 3.10

    out = res.out_dir
    cfg = res.config
    files = {}
    for name, df in ((POSES, res.poses), (WHEELS, res.wheels), (SEGMENTS, res.segments)):
        atomic_parquet(df, out / name)
        files[name.split(".")[0]] = out / name
        if csv:
            p = out / name.replace(".parquet", ".csv")
            atomic_write_bytes(p, df.to_csv(index=False).encode())
            files[name.split(".")[0] + "_csv"] = p
    if text is None:
        text = _toml(cfg.model_dump(mode="json", exclude_none=True, exclude_unset=True))
    tomllib.loads(text)
    atomic_write_bytes(out / CONFIG_COPY, text.encode())
    manifest = {"name": cfg.name, "paths": [p.name for p in cfg.all_paths()],
                "stations": len(res.poses),
                "failed_poses": int((res.poses["status"] != "ok").sum()),
                "elapsed_s": res.elapsed, "timings": res.timings,
                "executor": res.executor,
                "config_sha256": config_fingerprint(text),
                "versions": versions()}
    if cfg.terrain.file is not None:   # traverse-report redraws the map on it from any folder
        f = Path(cfg.terrain.file).resolve()
        manifest["terrain_file"] = {"path": str(f), "sha256": file_sha256(f)}
    atomic_write_bytes(out / MANIFEST, json.dumps(manifest, indent=2).encode())
    files["config"], files["manifest"] = out / CONFIG_COPY, out / MANIFEST
    res.files = files


def _toml(d: dict, prefix: str = "") -> str:
    """A small TOML writer for the config's own dump (tables, arrays of tables, values)."""
    def val(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, (int, float)):
            return repr(v) if math.isfinite(v) else ("inf" if v > 0 else "-inf")
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(val(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{ " + ", ".join(f"{json.dumps(k)} = {val(x)}" for k, x in v.items()) + " }"
        raise TypeError(v)

    lines, tables = [], []
    for k, v in d.items():
        if isinstance(v, dict) or (isinstance(v, list) and v
                                   and all(isinstance(x, dict) for x in v)):
            tables.append((k, v))
        else:
            lines.append(f"{k} = {val(v)}")
    for k, v in tables:
        name = f"{prefix}{k}"
        if isinstance(v, list):
            for item in v:
                lines.append(f"\n[[{name}]]")
                lines.append(_toml(item, f"{name}.").strip())
        else:
            lines.append(f"\n[{name}]")
            lines.append(_toml(v, f"{name}.").strip())
    return "\n".join(x for x in lines if x) + "\n"
