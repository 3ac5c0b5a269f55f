r"""The traverse file (``traverse.toml``): terrain, path(s), rover, speed, allowable load.

Every table is validated by a strict schema (:class:`~roverimpact._schema.StrictModel`:
unknown keys are errors, with one :class:`~roverimpact.exceptions.ConfigError` line naming
them). SI units; angles in degrees where a key ends in ``_deg``. Layout::

    name = "rocker-bogie over a rocky field"
    description = "optional text for the report"
    constraints = "auto"                  # the active set, as in a scenario

    [terrain]                             # a seeded synthetic Mars terrain ...
    kind = "synthetic"
    size = [60.0, 10.0]                   # m
    spacing = 0.05                        # m
    origin = [0.0, -5.0]                  # m, the grid's corner (smallest x, y)
    seed = 1
    rock_abundance = 0.1                  # Golombek-Rapp k
    # hurst = 0.8, rms = 0.1, corner_wavelength = 10.0, d_min = 0.1, d_max = 2.0,
    # height_ratio = 0.5                  (models.terrain_synth.synthetic_mars)
    # ... or a height field: kind = "file", file = "dem.npy" | "dem.csv" | "dem.tif",
    # spacing and origin for .npy/.csv (a GeoTIFF carries its own)

    [path]                                # one path, or several as [[paths]]
    name = "A"
    waypoints = [[2.0, 0.0], [30.0, 2.0], [50.0, 0.0]]   # (x, y) m; or start/end
    spacing = 0.05                        # m between stations along the path

    [model]                               # exactly as in a scenario
    name = "rocker_bogie"

    [contacts]                            # ground = "normal" | "noslip" | "coulomb",
    ground = "normal"                     # mu, locked, loop_closure, loops

    [drive]
    speed = 0.1                           # reference speed u_ref [m/s]
    look_ahead = 0.1                      # m, default 2 x path spacing (>= spacing)
    v_max = 0.2                           # m/s, caps the speed limit (optional)
    segment = 1.0                         # m, length of the speed-limit segments

    [limits]                              # one of
    T_allow = 0.05                        # J: keep T_c^- below
    F_allow = 800.0                       # N: keep the predicted peak force below
    # model = "weight"                    # F with the weight on compliant supports, or
    #                                       "closed-form" (no weight, rigid supports)
    # gravity = "earth"                   # "mars", "moon", "none" or m/s^2
    # ground_law = { name = "hunt-crossley", k = 1.0e7, e = 0.2 }   # the supports
    # window = 0.05                       # s, the peak is sought in

    [contact_law]                         # the obstacle's law (F_pred; needed by F_allow)
    name = "hunt-crossley"
    k = 1.0e7
    e = 0.5

    [band]                                # optional: the band of F over k and e
    k = [1.0e6, 1.0e8]
    e = [0.2, 0.8]
    n = 3

    [suspension]                          # optional: least-risk setting per segment
    variables = { chassis_com_above_pivot = [0.0, 0.2] }

    [run]
    chunk = 500                           # stations per task
    workers = 2                           # local Dask cluster, or scheduler = "tcp://..."

Relative file names (terrain, robot file) are relative to the traverse file.
"""

from __future__ import annotations

import itertools
import math
import os
import re
from pathlib import Path
from typing import Any, Literal

from pydantic import Field, field_validator, model_validator

from .._schema import StrictModel, validate
from ..exceptions import ConfigError
from ..scenario.schema import (
    BandSpec,
    ContactLawSpec,
    LoopSpec,
    ModelSpec,
    check_gravity,
    gravity_magnitude,
)
from ..studies.optimize import finite_bounds

__all__ = ["BandSpec", "DriveSpec", "LimitsSpec", "PathSpec", "RunSpec", "SuspensionSpec",
           "TerrainSpec", "TraverseConfig", "TraverseContactsSpec", "file_tag",
           "load_traverse", "suspension_parameters", "traverse_from_dict"]

Pair = tuple[float, float]


def _finite_pair(v, what):
    if not all(math.isfinite(x) for x in v):
        raise ValueError(f"{what} must be finite, got {list(v)}")
    return v


#: Memory a synthetic terrain takes while it is made, per grid point [bytes]: 34 measured
#: (tracemalloc peak, examples/traverse_rocky.toml), with a margin
TERRAIN_BYTES_PER_POINT = 40


def _check_grid_memory(size, spacing: float) -> None:
    """Refuse a synthetic terrain whose grid would not fit in half this machine's memory
    (a unit slip: size in mm, or spacing in km), before any work."""
    points = (size[0] / spacing + 1.0) * (size[1] / spacing + 1.0)
    need = points * TERRAIN_BYTES_PER_POINT
    try:
        have = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):  # pragma: no cover - not POSIX
        return
    if need > 0.5 * have:
        raise ValueError(
            f"size {list(size)} m at spacing {spacing} m is a grid of {points:.3g} "
            f"points, about {need / 2**30:.3g} GiB to make, more than half of this machine's "
            f"{have / 2**30:.3g} GiB; check the units of size and spacing (m), or make the "
            "terrain smaller or coarser")


#: The keys of a synthetic terrain (``synthetic_mars``'s) with their defaults: refused
#: with ``kind = "file"``, where they would be ignored
SYNTHETIC_DEFAULTS = {"rock_abundance": 0.1, "hurst": 0.8, "rms": 0.1,
                      "corner_wavelength": 10.0, "d_min": 0.1, "d_max": 2.0,
                      "height_ratio": 0.5}


class TerrainSpec(StrictModel):
    """``[terrain]``: a seeded synthetic Mars terrain or a height-field file.

    The synthetic terrain's keys (:data:`SYNTHETIC_DEFAULTS`, ``size``, ``seed``) are None
    when not given (:meth:`synthetic_params` fills in the defaults), so that a key that
    does not apply is refused rather than ignored: those with ``kind = "file"``, and
    ``spacing`` and ``origin`` with a GeoTIFF (which carries its own). A file's
    ``spacing`` is one length or ``[dx, dy]`` [m]; ``nodata``: the value (or values) its
    cells without data hold, refused like -9999 and NaN
    (:meth:`~roverimpact.models.terrain.HeightField.from_file`)."""

    kind: Literal["synthetic", "file"] = "synthetic"
    size: Pair | None = None
    spacing: float | Pair | None = None
    origin: Pair | None = None
    seed: int | None = Field(None, ge=0)
    rock_abundance: float | None = Field(None, ge=0.0, lt=1.0)
    hurst: float | None = Field(None, gt=0.0, le=1.0)
    rms: float | None = Field(None, ge=0.0, allow_inf_nan=False)
    corner_wavelength: float | None = Field(None, gt=0.0, allow_inf_nan=False)
    d_min: float | None = Field(None, gt=0.0, allow_inf_nan=False)
    d_max: float | None = Field(None, gt=0.0, allow_inf_nan=False)
    height_ratio: float | Pair | None = None
    file: str | None = None
    nodata: float | list[float] | None = None

    def synthetic_params(self) -> dict:
        """``synthetic_mars``'s keyword arguments besides size, spacing and seed: the keys
        given, the defaults for the others."""
        out = {k: (d if getattr(self, k) is None else getattr(self, k))
               for k, d in SYNTHETIC_DEFAULTS.items()}
        hr = out["height_ratio"]
        out["height_ratio"] = tuple(hr) if isinstance(hr, (tuple, list)) else hr
        out["origin"] = self.origin if self.origin is not None else (0.0, 0.0)
        return out

    @model_validator(mode="after")
    def _kind(self):
        if self.origin is not None:
            _finite_pair(self.origin, "terrain.origin")
        if self.spacing is not None:
            sp = self.spacing if isinstance(self.spacing, tuple) else (self.spacing,)
            if not all(math.isfinite(d) and d > 0 for d in sp):
                raise ValueError(f"terrain.spacing must be > 0 m and finite, got "
                                 f"{self.spacing}")
        synth = ("size", "seed")
        if self.kind == "synthetic":
            missing = [k for k in (*synth, "spacing") if getattr(self, k) is None]
            if missing:
                raise ValueError(f"a synthetic terrain needs {', '.join(missing)}")
            if self.file is not None or self.nodata is not None:
                raise ValueError("terrain.file and terrain.nodata are for kind = 'file'")
            if isinstance(self.spacing, tuple):
                raise ValueError(f"terrain.spacing of a synthetic terrain is one length (m), "
                                 f"got {list(self.spacing)}")
            if not all(math.isfinite(s) and s > 0 for s in self.size):
                raise ValueError(f"terrain.size must be two lengths > 0 m, got "
                                 f"{list(self.size)}")
            p = self.synthetic_params()
            if not p["d_min"] < p["d_max"]:
                raise ValueError(f"terrain.d_min < d_max needed, got {p['d_min']}, "
                                 f"{p['d_max']}")
            _check_grid_memory(self.size, self.spacing)
        else:
            if self.file is None:
                raise ValueError("kind = 'file' needs terrain.file (.npy, .csv, .tif)")
            given = [k for k in (*synth, *SYNTHETIC_DEFAULTS) if getattr(self, k) is not None]
            if given:
                raise ValueError(f"terrain.{', terrain.'.join(given)}: for a synthetic "
                                 "terrain only; a height-field file (kind = 'file') has its "
                                 "own heights: remove them")
            suffix = Path(self.file).suffix.lower()
            if suffix not in (".npy", ".csv", ".tif", ".tiff"):
                raise ValueError(f"terrain.file {self.file!r}: use a .npy, .csv or GeoTIFF "
                                 "(.tif) height field")
            if suffix in (".npy", ".csv") and self.spacing is None:
                raise ValueError(f"terrain.file {self.file!r} needs terrain.spacing (m)")
            if suffix in (".tif", ".tiff"):
                given = [k for k in ("spacing", "origin") if getattr(self, k) is not None]
                if given:
                    raise ValueError(f"terrain.{' and terrain.'.join(given)}: a GeoTIFF "
                                     f"({self.file!r}) carries its own grid spacing and "
                                     "origin: remove them")
        return self


class PathSpec(StrictModel):
    """A path: ``waypoints`` (x, y) [m], or a straight line ``start`` -> ``end``; stations
    every ``spacing`` [m] along it (the rover's heading follows the path)."""

    name: str | None = None
    waypoints: list[Pair] | None = None
    start: Pair | None = None
    end: Pair | None = None
    spacing: float = Field(0.05, gt=0.0, allow_inf_nan=False)

    @model_validator(mode="after")
    def _one(self):
        line = self.start is not None or self.end is not None
        if (self.waypoints is None) == (not line):
            raise ValueError("give the path as waypoints = [[x, y], ...] or as start and end")
        if line and (self.start is None or self.end is None):
            raise ValueError("a straight path needs both start and end")
        pts = self.points()
        for p in pts:
            _finite_pair(p, "path points")
        if len(pts) < 2:
            raise ValueError("a path needs at least two waypoints")
        if any(math.dist(a, b) == 0.0 for a, b in itertools.pairwise(pts)):
            raise ValueError("two consecutive waypoints coincide")
        return self

    def points(self) -> list[Pair]:
        return list(self.waypoints) if self.waypoints is not None else [self.start, self.end]

    @property
    def length(self) -> float:
        """Length of the polyline [m] (its last station is at or before it)."""
        return float(sum(math.dist(a, b) for a, b in itertools.pairwise(self.points())))


class TraverseContactsSpec(StrictModel):
    """``[contacts]``: how the supporting wheels meet the terrain through an impact, as a
    scenario's ``[contacts]`` (``ground``, ``mu``, ``locked``, ``loop_closure``,
    ``loops``). Every wheel stands on the terrain; ``wheels`` names those that must touch
    it (default all)."""

    ground: Literal["normal", "noslip", "coulomb"] = "normal"
    mu: float | dict[str, float] | None = None
    locked: list[str] = Field(default_factory=list)
    loop_closure: bool = True
    loops: list[LoopSpec] = Field(default_factory=list)
    wheels: list[str] | None = None

    @model_validator(mode="after")
    def _mu(self):
        if self.ground == "coulomb" and self.mu is None:
            raise ValueError('contacts.ground = "coulomb" needs contacts.mu (the friction '
                             "coefficient, >= 0)")
        if self.ground != "coulomb" and self.mu is not None:
            raise ValueError(f"contacts.mu is for ground = \"coulomb\" only; with ground = "
                             f"{self.ground!r} the supports are "
                             + ("frictionless" if self.ground == "normal" else "held (no slip)")
                             + ": remove mu, or set ground = \"coulomb\"")
        values = (list(self.mu.values()) if isinstance(self.mu, dict)
                  else [] if self.mu is None else [self.mu])
        if any(not (x >= 0.0) for x in values):  # inf allowed: no slip
            raise ValueError(f"contacts.mu must be >= 0, got {self.mu}")
        return self

    def scenario_contacts(self):
        """The scenario's :class:`~roverimpact.scenario.schema.ContactsSpec`."""
        from ..scenario.schema import ContactsSpec

        return ContactsSpec(ground=self.ground, mu=self.mu, locked=self.locked,
                            loop_closure=self.loop_closure, loops=self.loops)


class DriveSpec(StrictModel):
    """``[drive]``: reference speed ``speed`` [m/s] (T_c^- is computed at it; a horizontal
    speed along the path, as are the limits: on a slope the base moves faster along the
    ground than a scenario's ``[velocity] u``, by 1 / cos(slope)), the
    look-ahead of every wheel [m] (default twice the path spacing), an optional top speed
    ``v_max`` [m/s] capping the limit, and the ``segment`` length [m] of the speed profile."""

    speed: float = Field(gt=0.0, allow_inf_nan=False)
    look_ahead: float | None = Field(None, gt=0.0, allow_inf_nan=False)
    v_max: float | None = Field(None, gt=0.0, allow_inf_nan=False)
    segment: float = Field(1.0, gt=0.0, allow_inf_nan=False)


class LimitsSpec(StrictModel):
    """``[limits]``: the allowable ``T_allow`` [J] (effective kinetic energy) or
    ``F_allow`` [N] (peak force of ``[contact_law]`` on the feature).

    For ``F_allow``, ``model`` says how the peak force is predicted: ``"weight"`` (the
    default) with the rover's weight on compliant, preloaded supports
    (:mod:`roverimpact.traverse.refine`: ``gravity``, the supports' ``ground_law``, the
    ``window`` [s] in which the peak is sought), or ``"closed-form"``: the 1-DoF closed form
    of (m_eff, v_n), no weight and rigid supports (low where the weight share is of the
    order of the impact force, docs/traverse.md). Keys that would be ignored are refused
    where they differ from the defaults: ``model`` and the weight model's with ``T_allow``,
    the weight model's with ``"closed-form"``."""

    T_allow: float | None = Field(None, gt=0.0, allow_inf_nan=False)
    F_allow: float | None = Field(None, gt=0.0, allow_inf_nan=False)
    model: Literal["weight", "closed-form"] = "weight"
    gravity: str | float = "earth"
    ground_law: ContactLawSpec = ContactLawSpec(e=0.2)
    window: float = Field(0.05, gt=0.0, allow_inf_nan=False)

    @field_validator("gravity")
    @classmethod
    def _gravity(cls, g):
        return check_gravity(g)

    @property
    def g(self) -> float:
        """Gravity magnitude [m/s^2]."""
        return gravity_magnitude(self.gravity)

    @model_validator(mode="after")
    def _one(self):
        if (self.T_allow is None) == (self.F_allow is None):
            raise ValueError("give exactly one of limits.T_allow [J] or limits.F_allow [N]")
        # keys given that would be ignored: the weight model's without it. Values other
        # than the defaults: the copies of traverse files written before this check hold
        # every default (gravity = "earth" with T_allow) and traverse-report reads them
        weight_keys = ("gravity", "ground_law", "window")

        def other(k):
            return getattr(self, k) != type(self).model_fields[k].default

        if self.T_allow is not None:
            given = [k for k in ("model", *weight_keys) if other(k)]
            if given:
                raise ValueError(
                    f"limits.{', limits.'.join(given)}: for limits.F_allow (the peak force "
                    "and its model) only; with limits.T_allow they would be ignored: remove "
                    "them")
        elif self.model == "closed-form":
            given = [k for k in weight_keys if other(k)]
            if given:
                raise ValueError(
                    f"limits.{', limits.'.join(given)}: for the weight model (limits.model = "
                    "\"weight\") only; the closed form has no weight and rigid supports, so "
                    "they would be ignored: remove them, or drop limits.model")
        return self


class SuspensionSpec(StrictModel):
    """``[suspension]``: the least-risk setting of a built-in rover per segment, by the
    suspension optimiser (:mod:`roverimpact.studies.optimize`): ``variables`` (model
    parameters with bounds), ``objective``, ``stability_margin`` and ``min_clearance`` [m],
    ``n_starts``, ``seed``, ``n_beta``."""

    variables: dict[str, Pair] = Field(min_length=1)
    objective: Literal["worst", "mean"] = "worst"
    stability_margin: float = Field(0.05, allow_inf_nan=False)
    min_clearance: float = Field(0.0, allow_inf_nan=False)
    n_starts: int = Field(3, ge=1, le=100)
    n_beta: int = Field(5, ge=2, le=100)  # over each segment's range of beta
    seed: int = Field(0, ge=0)  # the optimiser's (a negative one ended in each segment's note)

    _bounds = field_validator("variables")(finite_bounds)


class RunSpec(StrictModel):
    """``[run]``: stations per task (``chunk``), a local Dask cluster of ``workers``
    processes or a ``scheduler`` address (the command line's options take precedence)."""

    chunk: int = Field(500, ge=1)
    workers: int | None = Field(None, ge=1)
    scheduler: str | None = None


class TraverseConfig(StrictModel):
    """A whole traverse file (module docstring)."""

    name: str = "traverse"
    description: str = ""
    terrain: TerrainSpec
    path: PathSpec | None = None
    paths: list[PathSpec] = Field(default_factory=list)
    model: ModelSpec
    contacts: TraverseContactsSpec = TraverseContactsSpec()
    constraints: Literal["auto", "all"] | list[str] = "auto"
    drive: DriveSpec
    limits: LimitsSpec
    contact_law: ContactLawSpec | None = None
    band: BandSpec | None = None
    suspension: SuspensionSpec | None = None
    run: RunSpec = RunSpec()

    @model_validator(mode="after")
    def _consistent(self):
        if (self.path is None) == (not self.paths):
            raise ValueError("give one path as [path] or several as [[paths]]")
        if self.limits.F_allow is not None and self.contact_law is None:
            raise ValueError("limits.F_allow needs [contact_law] (the law whose peak force "
                             "is limited)")
        if self.band is not None and self.contact_law is None:
            raise ValueError("[band] needs [contact_law] (the law whose k and e vary)")
        if self.contacts.ground == "coulomb" and self.constraints != "auto":
            raise ValueError(  # as a scenario's (roverimpact.scenario.schema.Scenario)
                'contacts.ground = "coulomb" needs constraints = "auto": with '
                f"{self.constraints!r} every tangent row would be held whatever mu (as "
                'ground = "noslip")')
        if self.suspension is not None and self.model.name not in ("rover2d", "rocker_bogie"):
            raise ValueError("[suspension] needs a built-in rover (model.name 'rover2d' or "
                             "'rocker_bogie'): the optimiser varies its parameters")
        if self.suspension is not None:
            bad = [v for v in self.suspension.variables
                   if v not in suspension_parameters(self.model.name)]
            if bad:
                raise ValueError(
                    f"suspension.variables: {', '.join(map(repr, bad))}: not a numeric "
                    f"parameter of {self.model.name}; choose from "
                    f"{', '.join(suspension_parameters(self.model.name))}")
        paths = self.all_paths()
        names = [p.name for p in paths]
        if len(set(names)) != len(names):
            raise ValueError(f"path names must differ, got {names}")
        tags = {}
        for n in names:
            tags.setdefault(file_tag(n).casefold(), []).append(n)
        same = [v for v in tags.values() if len(v) > 1]
        if same:
            raise ValueError(f"paths {same[0]} would share the figure files "
                             f"map-{file_tag(same[0][0])}.png (a file name keeps letters, "
                             "digits, '.', '-' and '_' of a path name, case aside): rename one")
        la = self.drive.look_ahead
        short = [p for p in paths if la is not None and la < p.spacing]
        if short:
            raise ValueError(f"drive.look_ahead = {la:g} m is shorter than path "
                             f"{short[0].name!r}'s spacing ({short[0].spacing:g} m): the "
                             "contacts between two stations would be missed; give "
                             "look_ahead >= the spacing (default twice the spacing)")
        return self

    @field_validator("contact_law")
    @classmethod
    def _law(cls, spec):
        if spec is not None:
            try:
                spec.to_law(m_eff=1.0)
            except Exception as exc:   # a law that cannot be built: one line, named
                raise ValueError(f"contact_law: {exc}") from None
        return spec

    def all_paths(self) -> list[PathSpec]:
        """The paths, in order, each with a name."""
        ps = [self.path] if self.path is not None else list(self.paths)
        return [p if p.name else p.model_copy(update={"name": f"path{i}"})
                for i, p in enumerate(ps)]

    def look_ahead(self, path: PathSpec) -> float:
        """The look-ahead of ``path`` [m]: ``drive.look_ahead`` or twice its spacing."""
        return self.drive.look_ahead or 2.0 * path.spacing


def suspension_parameters(model: str | None) -> list[str]:
    """The numeric parameters of a built-in rover (``[suspension] variables``)."""
    from dataclasses import fields

    from ..models import RockerBogieParams, Rover2DParams

    cls = {"rover2d": Rover2DParams, "rocker_bogie": RockerBogieParams}.get(model)
    return [] if cls is None else sorted(f.name for f in fields(cls)
                                         if f.type in ("float", float))


def file_tag(name: str) -> str:
    """The part of a file name that stands for path ``name`` (``map-<tag>.png``): its
    letters, digits, '.', '-' and '_', every other run of characters (a '/', spaces) one
    '_'."""
    tag = re.sub(r"[^\w.-]+", "_", name)
    return "_" if tag.strip(".") == "" else tag


def traverse_from_dict(raw: dict | TraverseConfig, *, where: str = "traverse",
                       base_dir: str | Path | None = None) -> TraverseConfig:
    """Validate a traverse given as a dict (as read from TOML); relative file names are
    made relative to ``base_dir``."""
    if not isinstance(raw, (dict, TraverseConfig)):
        raise ConfigError(f"{where}: a traverse file is a table of tables, got "
                          f"{type(raw).__name__}")
    cfg = validate(TraverseConfig, raw, where, "invalid traverse: ")
    if base_dir is not None:
        cfg = _resolve(cfg, Path(base_dir))
    return cfg


def _resolve(cfg: TraverseConfig, base: Path) -> TraverseConfig:
    from ..scenario.schema import is_example_robot_name

    upd: dict[str, Any] = {}
    t = cfg.terrain
    if t.file is not None and not Path(t.file).is_absolute():
        upd["terrain"] = t.model_copy(update={"file": str(base / t.file)})
    f = cfg.model.file
    if f is not None and not is_example_robot_name(f) and not Path(f).is_absolute():
        upd["model"] = cfg.model.model_copy(update={"file": str(base / f)})
    return cfg.model_copy(update=upd) if upd else cfg


def load_traverse(path: str | Path) -> TraverseConfig:
    """Read and validate a traverse file (relative file names: next to it).

    Raises
    ------
    ConfigError
        Missing or malformed file, unknown keys, bad values (one message naming them).
    """
    from .._io import read_toml

    path = Path(path)
    # absolute: a relative file name is read from the file's folder wherever the config
    # goes (a copy next to the results, a Dask worker started in another folder)
    return traverse_from_dict(read_toml(path), where=str(path),
                              base_dir=path.absolute().parent)
