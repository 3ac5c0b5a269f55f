"""Study files: a base scenario plus a grid, a list or a seeded random sample of cases.

A study file is TOML, validated by :class:`Study` (pydantic v2, unknown keys rejected)::

    name = "beta sweep"
    simulate = false              # also run the compliant-contact simulator (F_max):
                                  # true / "own", "mujoco", "mujoco_laws",
                                  # or a list such as ["own", "mujoco"]
    x = "obstacle.beta_deg"       # parameter on the x axis of the figures (optional)

    [base]                        # a scenario, same keys as a scenario file
    ...                           # (or:  base = "scenario.toml", relative to the study file;
                                  #  a relative model.file: relative to the file naming it)

    [grid]                        # full factorial over dotted paths into the scenario
    "obstacle.beta_deg" = { start = 0, stop = 80, num = 17 }
    "model.params.com_height" = [0.3, 0.4, 0.5]

Instead of ``[grid]``: ``[[cases]]`` tables (one per case, dotted keys) or
``[random]`` with ``n``, ``seed`` and ``[random.params]`` of ``{ low, high }`` (uniform)
or ``{ choices = [...] }``. Values are plain numbers in the unit the parameter's name
states (``*_deg`` in degrees, everything else SI).

:func:`expand` turns a study into its cases; each has a stable id that depends only on
its position and its parameter values, which is what ``--resume`` keys on.
"""

from __future__ import annotations

import copy
import hashlib
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import Field, ValidationError, field_validator, model_validator

from .._io import read_text_utf8, read_toml
from .._schema import UNIT_RE, StrictModel, validation_message
from ..exceptions import ConfigError, InputError

__all__ = ["FILE_KEYS", "Case", "CaseSequence", "Study", "apply_overrides", "cases_of", "expand",
           "get_path", "load_study", "named_files"]

Scalar = bool | int | float | str


class Linspace(StrictModel):
    """``{ start, stop, num }``: ``num`` evenly spaced values, both ends included."""

    start: float
    stop: float
    num: int = Field(ge=1, le=10_000_000)

    @model_validator(mode="after")
    def _ends(self):
        if self.num == 1 and self.start != self.stop:
            raise ValueError(f"num = 1 gives start = {self.start:g} only, not both ends: give "
                             "num >= 2, or start = stop for one value")
        return self

    def values(self) -> list[float]:
        return [float(x) for x in np.linspace(self.start, self.stop, self.num)]


class Uniform(StrictModel):
    """``{ low, high }``: uniform random values in [low, high]."""

    low: float
    high: float

    @model_validator(mode="after")
    def _order(self):
        if not self.high >= self.low:
            raise ValueError(f"high ({self.high}) must be >= low ({self.low})")
        return self


class Choice(StrictModel):
    """``{ choices = [...] }``: values drawn uniformly from a list."""

    choices: list[Scalar] = Field(min_length=1)


class RandomSample(StrictModel):
    """``[random]``: ``n`` cases drawn with ``seed`` (numpy default_rng)."""

    n: int = Field(ge=1, le=100_000_000)
    seed: int
    params: dict[str, Uniform | Choice] = Field(min_length=1)


class Study(StrictModel):
    """A study: base scenario and the cases to run (exactly one of grid, cases, random).

    Attributes
    ----------
    name : str
        Label used in file names, figures and the report.
    base : dict
        The base scenario (nested tables as in a scenario file).
    grid : dict of str -> list or Linspace, optional
        Full factorial over dotted parameter paths; the first key varies slowest.
    cases : list of dict, optional
        Explicit cases, each a table of dotted paths -> values.
    random : RandomSample, optional
        Seeded random sample.
    simulate : bool, str or list of str
        Also run a compliant-contact simulator (F_max, contact duration): ``true`` or
        ``"own"`` (roverimpact's simulator), ``"mujoco"``, ``"mujoco_laws"``
        (:data:`roverimpact.simulate.engines.ENGINE_NAMES`), or a list of engines such as
        ``["own", "mujoco"]``: the first gives ``F_max`` (the study's reference), each
        further one ``F_max_<engine>`` (:meth:`engines`).
    x : str, optional
        Parameter drawn on the x axis of the figures (default: first swept parameter).
    chunk_size : int, optional
        Cases per result chunk (the unit of resume and of distribution); default:
        about 1/100 of the cases (at least 16) with ``simulate``, else about 1/20 (at
        least 256).
    """

    name: str = Field(min_length=1)
    description: str = ""
    base: dict[str, Any]
    grid: dict[str, Linspace | list[Scalar]] | None = None
    cases: list[dict[str, Scalar]] | None = None
    random: RandomSample | None = None
    simulate: bool | str | list[str] = False
    x: str | None = None
    chunk_size: int | None = Field(default=None, ge=1)

    @field_validator("grid")
    @classmethod
    def _grid_nonempty(cls, grid):
        if grid is None:
            return grid
        if not grid:
            raise ValueError("the grid table is empty: give at least one parameter to sweep")
        for key, val in grid.items():
            if isinstance(val, list) and not val:
                raise ValueError(f"grid parameter {key!r} has an empty list of values")
        return grid

    @field_validator("simulate")
    @classmethod
    def _engines(cls, value):
        if isinstance(value, bool):
            return value
        from .._engines import engine_name

        names = [value] if isinstance(value, str) else list(value)
        if not names:
            raise ValueError("an empty list: give true/false, an engine ('own', 'mujoco') "
                             "or a list of engines")
        try:
            norm = [engine_name(n) for n in names]
        except InputError as exc:
            raise ValueError(str(exc)) from None
        if len(set(norm)) != len(norm):
            raise ValueError(f"simulate lists an engine twice: {names}")
        return norm[0] if isinstance(value, str) else norm

    @field_validator("cases")
    @classmethod
    def _cases_nonempty(cls, cases):
        if cases is not None and not cases:
            raise ValueError("the cases list is empty: give at least one case")
        return cases

    @model_validator(mode="after")
    def _one_design(self):
        given = [k for k in ("grid", "cases", "random") if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError(
                "a study needs exactly one of: a grid table, a cases list or a random table"
                + (f" (got {', '.join(given)})" if given else "")
            )
        return self

    # ---------------------------------------------------------------------------------
    def parameters(self) -> list[str]:
        """The swept parameters (dotted paths), in file order."""
        if self.grid is not None:
            return list(self.grid)
        if self.random is not None:
            return list(self.random.params)
        seen: dict[str, None] = {}
        for case in self.cases or []:
            seen.update(dict.fromkeys(case))
        return list(seen)

    def engines(self) -> tuple[str, ...]:
        """The simulators of the study, reference first: ``()`` without simulation,
        ``("own",)`` for ``simulate = true``."""
        if self.simulate is True:
            return ("own",)
        if self.simulate is False:
            return ()
        return (self.simulate,) if isinstance(self.simulate, str) else tuple(self.simulate)

    def x_parameter(self) -> str:
        return self.x or self.parameters()[0]

    def n_cases(self) -> int:
        if self.grid is not None:
            return int(np.prod([len(_grid_values(v)) for v in self.grid.values()]))
        if self.random is not None:
            return self.random.n
        return len(self.cases or [])

    def fingerprint(self) -> str:
        """Hash of everything that determines the rows (not the chunking)."""
        data = self.model_dump(mode="json", exclude={"chunk_size", "description", "x"})
        text = json.dumps(data, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()[:16]


def _grid_values(spec) -> list:
    return spec.values() if isinstance(spec, Linspace) else list(spec)


def load_study(path: str | Path) -> tuple[Study, str]:
    """Read and validate a study file; return the study and its original text.

    A ``base = "file.toml"`` string is read relative to the study file (the text is then
    ``None``: the study is self-contained only once the base is inlined). A relative
    ``model.file``, ``terrain.file`` or ``terrain.function`` file is read relative to the
    file that names it (the base file, or the study file for a ``[base]`` table), as a
    scenario file's is (the text is then ``None`` too: the copy beside the results names
    the files absolute).

    Raises
    ------
    ConfigError
        For malformed TOML, unknown keys, wrong types, an empty grid or a missing base.
    """
    path = Path(path)
    given = read_toml(path)
    raw = dict(given)
    if "base" not in raw and ("model" in raw or "obstacle" in raw):
        raise ConfigError(f"{path}: a scenario file, not a study: a study names its scenario "
                          "in [base] (or base = \"scenario.toml\") and what varies in [grid], "
                          "[[cases]] or [random] (docs/studies.md)")
    text = read_text_utf8(path)
    if isinstance(raw.get("base"), str):
        # the base lives in another file: the copy written next to results inlines it
        base_path = (path.parent / raw["base"]).resolve()
        raw["base"] = _files_from(read_toml(base_path), base_path.parent)
        text = None
    elif isinstance(raw.get("base"), dict):
        raw["base"] = _files_from(raw["base"], path.parent)
    raw = _case_files_from(raw, path.parent)
    if raw != given:
        # relative file names: the copy written next to the results names them absolute
        # (the text's, read from the results folder, named files that are not there, and
        # `--resume` with the copy, as `report` advises for a stopped study, failed)
        text = None
    try:
        study = Study.model_validate(raw)
    except ValidationError as exc:
        raise ConfigError(validation_message(exc, str(path))) from None
    return study, text


#: The scenario keys that name a file (read relative to the file that names them)
FILE_KEYS = ("model.file", "terrain.file", "terrain.function")


def _file_from(key: str, value: Any, folder: Path) -> Any:
    """``value`` of the scenario key ``key`` with a relative file name read from
    ``folder``; other keys and values unchanged."""
    from ..scenario.schema import is_example_robot_name

    if not isinstance(value, str):
        return value
    if key == "model.file":
        if is_example_robot_name(value) or Path(value).is_absolute():
            return value
        return str((folder / value).resolve())
    if key == "terrain.file":
        return value if Path(value).is_absolute() else str((folder / value).resolve())
    if key == "terrain.function":
        mod, _, name = value.rpartition(":")
        if mod.endswith(".py") and not Path(mod).is_absolute():
            return f"{(folder / mod).resolve()}:{name}"
    return value


def _files_from(base: Any, folder: Path) -> Any:
    """``base`` with its relative file names read from ``folder`` (the folder of the file
    that names them), as :func:`roverimpact.scenario.load_scenario` reads a scenario's:
    ``model.file``, ``terrain.file`` and a ``terrain.function`` of a ``.py`` file. (Only
    ``model.file`` was, and a study of a scenario that ``roverimpact energy`` reads
    refused its terrain, or took another one of the same name from the working folder.)"""
    if not isinstance(base, dict):
        return base
    out = dict(base)
    for key in FILE_KEYS:
        section, _, name = key.partition(".")
        table = out.get(section)
        if isinstance(table, dict) and name in table:
            value = _file_from(key, table[name], folder)
            if value != table[name]:
                out[section] = table | {name: value}
    return out


def _case_files_from(raw: dict, folder: Path) -> dict:
    """``raw`` (a study, as a dict) with the relative file names its ``[grid]``,
    ``[[cases]]`` and ``[random]`` choices give (``"model.file" = [...]``) read from
    ``folder``, as its base's are: they were read from the working folder of each
    process, and a Dask worker's is not the command's."""
    out = dict(raw)
    grid = raw.get("grid")
    if isinstance(grid, dict):
        out["grid"] = {k: ([_file_from(k, v, folder) for v in vals]
                           if k in FILE_KEYS and isinstance(vals, list) else vals)
                       for k, vals in grid.items()}
    cases = raw.get("cases")
    if isinstance(cases, list):
        out["cases"] = [{k: _file_from(k, v, folder) for k, v in c.items()}
                        if isinstance(c, dict) else c for c in cases]
    rnd = raw.get("random")
    params = rnd.get("params") if isinstance(rnd, dict) else None
    if isinstance(params, dict):
        out["random"] = rnd | {"params": {
            k: (spec | {"choices": [_file_from(k, v, folder) for v in spec["choices"]]}
                if k in FILE_KEYS and isinstance(spec, dict)
                and isinstance(spec.get("choices"), list) else spec)
            for k, spec in params.items()}}
    return out


def named_files(study: Study) -> list[str]:
    """The names of the files the study's scenarios read (``model.file``,
    ``terrain.file``, the ``.py`` file of a ``terrain.function``): its base's, then those
    its grid, cases or random choices give; each once, as the study gives it."""
    values = [(k, get_path(study.base, k, None)) for k in FILE_KEYS]
    if study.grid is not None:
        values += [(k, v) for k, spec in study.grid.items() if k in FILE_KEYS
                   and isinstance(spec, list) for v in spec]
    for case in study.cases or ():
        values += [(k, v) for k, v in case.items() if k in FILE_KEYS]
    if study.random is not None:
        values += [(k, v) for k, spec in study.random.params.items() if k in FILE_KEYS
                   and isinstance(spec, Choice) for v in spec.choices]
    out: dict[str, None] = {}
    for key, value in values:
        if not isinstance(value, str):
            continue
        if key == "terrain.function":
            mod = value.rpartition(":")[0]
            if mod.endswith(".py"):
                out[mod] = None
        else:
            out[value] = None
    return list(out)


def study_from_dict(data: Mapping[str, Any], where: str = "study") -> Study:
    """Validate a study given as a dict (as read from TOML), or take a :class:`Study`.

    A relative ``model.file``, ``terrain.file`` or ``terrain.function`` file of its base,
    grid, cases or random choices is made absolute from the working folder (where this
    process reads it): a Dask worker started in another folder read it there, another file
    of the same name or none (a study of a 24 kg rover computed with the 64 kg one beside
    the workers, no error). A :class:`Study` built in Python is treated alike (only its
    base's files were)."""
    if isinstance(data, Study):
        raw = data.model_dump()
        absolute = _case_files_from(raw, Path.cwd())
        absolute["base"] = _files_from(absolute["base"], Path.cwd())
        return data if absolute == raw else Study.model_validate(absolute)
    data = _case_files_from(dict(data), Path.cwd())
    if isinstance(data.get("base"), dict):
        data["base"] = _files_from(data["base"], Path.cwd())
    try:
        return Study.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(validation_message(exc, where)) from None


# -------------------------------------------------------------------------------------
# Dotted paths into nested scenario dicts
# -------------------------------------------------------------------------------------

_MISSING = object()


def get_path(tree: Mapping[str, Any], path: str, default=_MISSING):
    """Value at a dotted ``path`` ("model.params.com_height") of a nested dict."""
    node: Any = tree
    for part in path.split("."):
        if isinstance(node, Mapping) and part in node:
            node = node[part]
        else:
            if default is _MISSING:
                raise KeyError(path)
            return default
    return node


def apply_overrides(base: Mapping[str, Any], overrides: Mapping[str, Any]) -> dict:
    """A copy of ``base`` with dotted-path ``overrides`` set (base is not modified).

    Only the dicts on the overridden paths are copied, so this is cheap.
    """
    out = dict(base)
    for path, value in overrides.items():
        parts = path.split(".")
        node = out
        for part in parts[:-1]:
            child = node.get(part)
            child = dict(child) if isinstance(child, Mapping) else {}
            node[part] = child
            node = child
        node[parts[-1]] = copy.deepcopy(value) if isinstance(value, (list, dict)) else value
    return out


def flatten(tree: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Leaves of a nested dict as ``{dotted.path: value}`` (lists kept as values)."""
    out: dict[str, Any] = {}
    for key, val in tree.items():
        name = f"{prefix}{key}"
        if isinstance(val, Mapping) and val:
            out.update(flatten(val, name + "."))
        else:
            out[name] = val
    return out


# -------------------------------------------------------------------------------------
# Cases
# -------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Case:
    """One case of a study.

    Attributes
    ----------
    index : int
        Position in the study (0-based); results are sorted by it.
    case_id : str
        Stable id: the index and a hash of the parameter values.
    overrides : dict
        Dotted parameter path -> value for this case.
    """

    index: int
    case_id: str
    overrides: dict[str, Any]


def case_id(index: int, overrides: Mapping[str, Any]) -> str:
    """``"<index>-<hash of the parameter values>"``, e.g. ``"0000012-3f9a01bc"``.

    The hash is over ``repr`` of the sorted (path, value) pairs (Python's shortest
    round-trip float repr), so it is the same in every run and on every machine.
    """
    text = repr(sorted(overrides.items()))
    return f"{index:07d}-{hashlib.sha1(text.encode()).hexdigest()[:8]}"


def _to_python(x):
    if isinstance(x, np.generic):
        return x.item()
    return x


def design(study: Study) -> tuple[list[str], list[tuple]]:
    """The swept parameter names and one tuple of values per case."""
    seq = cases_of(study)
    return seq.names, [seq.values(i) for i in range(len(seq))]


class CaseSequence(Sequence):
    """The cases of a study, made on demand (``len``, ``seq[i]``, ``seq[a:b]``, iteration).

    Nothing per case is stored but, for a ``[random]`` design, the drawn values (8 bytes
    per case and uniform parameter, 4 per choice parameter, drawn once in the same order
    as :func:`expand` always drew them, so the cases are the same); a grid case is computed
    from its index (the first key varies slowest), and its id is hashed when the case is
    made. A study of 1e7 cases is not a list of 1e7 :class:`Case` objects.
    """

    def __init__(self, study: Study):
        self.names = study.parameters()
        self._grid = self._random = self._rows = None
        self._offset = 0  # index in the study of this sequence's first case (a view's)
        if study.grid is not None:
            self._grid = [_grid_values(study.grid[k]) for k in self.names]
            self._n = int(np.prod([len(a) for a in self._grid], dtype=np.int64))
        elif study.random is not None:
            rng = np.random.default_rng(study.random.seed)
            cols = []
            for key in self.names:
                spec = study.random.params[key]
                if isinstance(spec, Uniform):
                    cols.append((None, rng.uniform(spec.low, spec.high, study.random.n)))
                else:
                    idx = rng.integers(0, len(spec.choices), study.random.n)
                    cols.append((list(spec.choices), idx.astype(np.int32)))
            self._random = cols
            self._n = study.random.n
        else:
            self._rows = [tuple(case.get(k, _MISSING) for k in self.names)
                          for case in study.cases or []]
            self._n = len(self._rows)

    def __len__(self) -> int:
        return self._n

    def view(self, start: int, stop: int) -> CaseSequence:
        """Cases ``start ... stop - 1`` as a sequence of their own, made on demand and small
        to pickle (a grid's axes, or the slice of the drawn values): what a chunk ships to
        a Dask worker instead of its list of cases. Indices and ids are the study's."""
        start, stop, _ = slice(start, stop).indices(self._n)
        stop = max(stop, start)
        out = object.__new__(CaseSequence)
        out.names, out._grid = self.names, self._grid
        out._random = (None if self._random is None else
                       [(choices, arr[start:stop].copy()) for choices, arr in self._random])
        out._rows = None if self._rows is None else self._rows[start:stop]
        out._offset, out._n = self._offset + start, stop - start
        return out

    def values(self, i: int) -> tuple:
        """The parameter values of case ``i`` of this sequence (``_MISSING`` where a listed
        case has none)."""
        if self._grid is not None:
            i += self._offset
            out = []
            for axis in reversed(self._grid):
                i, r = divmod(i, len(axis))
                out.append(axis[r])
            return tuple(reversed(out))
        if self._random is not None:
            return tuple(float(arr[i]) if choices is None else choices[int(arr[i])]
                         for choices, arr in self._random)
        return self._rows[i]

    def case(self, i: int) -> Case:
        """Case ``i`` of this sequence with its id (index and id those of the study)."""
        ov = {k: _to_python(v) for k, v in zip(self.names, self.values(i), strict=False)
              if v is not _MISSING}
        j = i + self._offset
        return Case(index=j, case_id=case_id(j, ov), overrides=ov)

    def __getitem__(self, key):
        if isinstance(key, slice):
            return [self.case(i) for i in range(*key.indices(self._n))]
        i = int(key)
        if i < 0:
            i += self._n
        if not 0 <= i < self._n:
            raise IndexError(key)
        return self.case(i)

    def __iter__(self):
        if self._rows is not None:  # listed cases: each has its own parameters
            for i in range(self._n):
                yield self.case(i)
            return
        for start in range(0, self._n, _ITER_BLOCK):
            yield from self._cases(start, min(start + _ITER_BLOCK, self._n))

    def _cases(self, start: int, stop: int) -> list[Case]:
        """Cases ``start ... stop - 1`` of a grid or random design, made together: their
        values a column at a time (numpy), their ids by :func:`case_id`'s text written
        out (the same ids: tests/test_study_config.py checks them against :meth:`case`).
        A grid value's text is written once per value of the block, not once per case."""
        names = self.names
        heads = [f"({name!r}, " for name in names]
        cols, texts = [], []  # per parameter: each case's value, and its text in the id
        if self._grid is not None:
            idx = np.arange(start, stop, dtype=np.int64) + self._offset
            for axis, head in zip(reversed(self._grid), reversed(heads), strict=True):
                idx, r = np.divmod(idx, len(axis))
                used, at = np.unique(r, return_inverse=True)
                values = [_to_python(axis[j]) for j in used.tolist()]
                text = [head + repr(v) + ")" for v in values]
                at = at.reshape(-1).tolist()
                cols.append([values[j] for j in at])
                texts.append([text[j] for j in at])
            cols.reverse()
            texts.reverse()
        else:
            cols = [arr[start:stop].tolist() if choices is None
                    else [_to_python(choices[j]) for j in arr[start:stop].tolist()]
                    for choices, arr in self._random]
            texts = [[head + repr(v) + ")" for v in col]
                     for head, col in zip(heads, cols, strict=True)]
        order = sorted(range(len(names)), key=names.__getitem__)
        n, first = stop - start, start + self._offset
        rows = zip(*cols, strict=True) if cols else [()] * n
        parts = zip(*[texts[k] for k in order], strict=True) if cols else [()] * n
        sha1, join = hashlib.sha1, ", ".join
        # positional Case(...): a frozen dataclass takes keywords at twice the time; each
        # row has one value per name (made so above)
        return [Case(j, f"{j:07d}-" + sha1(("[" + join(p) + "]").encode()).hexdigest()[:8],
                     dict(zip(names, vals, strict=False)))
                for j, vals, p in zip(range(first, first + n), rows, parts, strict=True)]


#: Cases made together when a grid or random design is iterated.
_ITER_BLOCK = 4096


def cases_of(study: Study) -> CaseSequence:
    """The cases of a study, made on demand (:class:`CaseSequence`)."""
    return CaseSequence(study)


def expand(study: Study) -> list[Case]:
    """All cases of a study, in order, with their stable ids (a list: for small studies;
    :func:`cases_of` makes them on demand)."""
    return list(cases_of(study))


def distinct_values(study: Study) -> dict[str, list]:
    """Per parameter, the values to check before running (grid values, sample bounds)."""
    out: dict[str, list] = {}
    if study.grid is not None:
        for k, spec in study.grid.items():
            out[k] = _grid_values(spec)
    elif study.random is not None:
        for k, spec in study.random.params.items():
            out[k] = [spec.low, spec.high] if isinstance(spec, Uniform) else list(spec.choices)
    else:
        for case in study.cases or []:
            for k, v in case.items():
                out.setdefault(k, []).append(v)
    # keep order, drop duplicates (of the same type: 1, 1.0 and true are three values)
    return {k: list({(type(h), h): h for h in map(_hashable, v)}.values())
            for k, v in out.items()}


def _hashable(v):
    return tuple(v) if isinstance(v, list) else v


def _schema_values(values: Sequence) -> list:
    """Of a parameter's distinct ``values``, those the schema check validates, in order:
    every value but a finite number, and of the finite numbers the smallest and the
    largest of each type (int, float). The schema's rules on a number are ranges, so the
    values between two that pass pass too: a grid of 20 000 angles is not validated
    20 000 times, as a random design's samples are not (its bounds are)."""
    bounds: dict[type, list] = {}
    for v in values:
        if _finite_number(v):
            lo_hi = bounds.setdefault(type(v), [v, v])
            lo_hi[0], lo_hi[1] = min(lo_hi[0], v), max(lo_hi[1], v)
    out, seen = [], set()
    for v in values:
        if not _finite_number(v):
            out.append(v)
        elif v in bounds[type(v)] and (type(v), v) not in seen:
            seen.add((type(v), v))
            out.append(v)
    return out


def _finite_number(v) -> bool:
    return type(v) in (int, float) and math.isfinite(v)


def _builder_parameters(base: Mapping[str, Any]) -> list[str]:
    """``model.params.<name>`` of every parameter of the base's built-in model (the
    params table holds only those the base sets)."""
    from dataclasses import fields

    from ..models import RigidBodyParams, RockerBogieParams, Rover2DParams

    model = base.get("model") if isinstance(base, Mapping) else None
    cls = {"rover2d": Rover2DParams, "rocker_bogie": RockerBogieParams,
           "rigid_body": RigidBodyParams}.get(model.get("name") if isinstance(model, Mapping)
                                              else None)
    return [] if cls is None else [f"model.params.{f.name}" for f in fields(cls)]


def _unknown_parameter(study: Study, name: str, leaves: Mapping[str, Any]) -> ConfigError:
    import difflib

    leaves = dict.fromkeys([*leaves, *_builder_parameters(study.base)])
    close = difflib.get_close_matches(name, list(leaves), n=3, cutoff=0.5)
    hint = f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""
    return ConfigError(
        f"study {study.name!r}: unknown parameter {name!r}: it is not a field of the "
        f"base scenario{hint} (known: {', '.join(sorted(leaves)[:40])})"
    )


def validate_scenarios(study: Study, validate, check=None) -> dict:
    """Check a study against the evaluator's scenario validator before any work.

    ``validate(scenario_dict) -> normalized dict`` (a cheap schema check) raises
    :class:`ConfigError` (or a pydantic ``ValidationError``) for a bad scenario; the
    optional ``check(scenario_dict)`` is a deep check (e.g. building the model). The base
    is validated and checked; of each parameter's distinct swept values (grid values,
    sample bounds, listed cases), every value that is not a finite number is validated
    and checked, and of the finite numbers the smallest and largest of each type (int,
    float): the checks' rules on a number are ranges (:func:`_schema_values`). A case's
    value between them that a rule refuses all the same stops the study at that case.
    A swept parameter must name a leaf of the normalized scenario (free-form tables such
    as ``model.params`` count once the checks accept the key). Returns the normalized
    base.

    Raises
    ------
    ConfigError
        Unknown parameter (with close matches), bad value (type, unit, range).
    """
    def _run(fn, scn, where, value=None):
        try:
            return fn(scn)
        except ValidationError as exc:
            raise ConfigError(validation_message(exc, where)) from None
        except InputError as exc:  # ConfigError, or ModelError from building the model
            hint = ""
            if isinstance(value, str) and UNIT_RE.match(value) and "plain number" not in str(exc):
                hint = (" (write a plain number in the unit of the parameter name: *_deg in "
                        "degrees, everything else SI)")
            raise ConfigError(f"{where}: {exc}{hint}") from None

    where = f"study {study.name!r}"
    base = _run(validate, study.base, f"{where}: base scenario")
    if check is not None:
        _run(check, study.base, f"{where}: base scenario")
    leaves = flatten(base)
    for key, values in distinct_values(study).items():
        values = [list(v) if isinstance(v, tuple) else v for v in values]
        if key not in leaves:
            try:
                scn = apply_overrides(study.base, {key: values[0]})
                got = validate(scn)
                if check is not None:
                    check(scn)
            except (ValidationError, InputError):
                raise _unknown_parameter(study, key, leaves) from None
            if key not in flatten(got):
                raise _unknown_parameter(study, key, leaves)
        checked = _schema_values(values)
        for val in checked:
            _run(validate, apply_overrides(study.base, {key: val}), f"{where}: {key} = {val!r}",
                 val)
        if check is not None:
            for val in checked:
                _run(check, apply_overrides(study.base, {key: val}), f"{where}: {key} = {val!r}",
                     val)
    if study.x is not None and study.x not in study.parameters():
        raise ConfigError(
            f"{where}: x = {study.x!r} is not one of the swept parameters "
            f"{study.parameters()}"
        )
    return base
