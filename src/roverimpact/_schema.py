"""One strict base for every configuration schema, and one formatter of its errors.

Every file roverimpact reads (scenario, study, trials, optimisation) is validated by a
pydantic model derived from :class:`StrictModel`: unknown keys are errors and values are
frozen. :func:`validate` turns a ``ValidationError`` into one :class:`ConfigError` line
naming the file and every offending key.
"""

from __future__ import annotations

import re
import typing
from collections.abc import Mapping
from typing import Any, TypeVar

from pydantic import BaseModel, ConfigDict, ValidationError, model_validator

from .exceptions import ConfigError

__all__ = ["UNIT_RE", "StrictModel", "validate", "validation_message"]

T = TypeVar("T", bound=BaseModel)


class _Constructed(type(BaseModel)):
    """Keyword construction of a schema (``SimulationConfig(beta_deg=120)``): a bad value
    is one :class:`ConfigError` naming the class and the keys, as from a file. (A metaclass,
    not ``__init__``: pydantic calls a custom ``__init__`` for every nested model too.)"""

    def __call__(cls, *args, **kwargs):
        try:
            return super().__call__(*args, **kwargs)
        except ValidationError as exc:
            raise ConfigError(validation_message(exc, cls.__name__)) from None


class StrictModel(BaseModel, metaclass=_Constructed):
    """Base of the configuration schemas: unknown keys are errors, instances are frozen,
    and a boolean is not a number (pydantic reads ``beta_deg = true`` as 1.0)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    @model_validator(mode="before")
    @classmethod
    def _booleans_are_not_numbers(cls, data):
        if type(data) is dict:
            plain = None
            for key, value in data.items():
                t = type(value)  # numbers and strings: nothing to look at
                if t is bool or t is list or t is dict or t is tuple:
                    if plain is None:
                        plain = _PLAIN.get(cls) or _plain_fields(cls)
                    if key in plain and _has_bool(value):
                        data = {**data, key: _mark_bools(value)}
        return data


class _Boolean:
    """A TOML/JSON boolean given where a number is expected: no number type accepts it,
    and the error message shows it as the file wrote it."""

    __slots__ = ("value",)

    def __init__(self, value: bool):
        self.value = value

    def __repr__(self) -> str:
        return "true" if self.value else "false"


def _has_bool(value) -> bool:
    if type(value) is bool:
        return True
    if type(value) in (list, tuple):
        return any(_has_bool(v) for v in value)
    if type(value) is dict:
        return any(_has_bool(v) for v in value.values())
    return False


def _mark_bools(value):
    if type(value) is bool:
        return _Boolean(value)
    if type(value) in (list, tuple):
        return type(value)(_mark_bools(v) for v in value)
    if type(value) is dict:
        return {k: _mark_bools(v) for k, v in value.items()}
    return value


_PLAIN: dict[type, frozenset] = {}


def _plain_fields(cls) -> frozenset:
    """The fields of ``cls`` whose type admits no boolean and holds no schema (whose own
    validator looks at its values): a boolean anywhere in their value is an error."""
    plain = _PLAIN.get(cls)
    if plain is None:
        def admits(tp) -> bool:
            if tp is bool or tp is typing.Any or (isinstance(tp, type)
                                                   and issubclass(tp, BaseModel)):
                return True
            if typing.get_origin(tp) is typing.Literal:
                return any(type(a) is bool for a in typing.get_args(tp))
            return any(admits(a) for a in typing.get_args(tp))

        plain = _PLAIN[cls] = frozenset(name for name, f in cls.model_fields.items()
                                        if not admits(f.annotation))
    return plain


#: a number followed by a unit, e.g. "0.35 m", "45 deg"
UNIT_RE = re.compile(r"^\s*[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?\s*[A-Za-z°%/\^\d]+\s*$")
# pydantic's own location parts: "function-after[_order(), Uniform]", "list[float]", ...
_INTERNAL_LOC = re.compile(r"^([a-z][a-z_-]*\[.*\]|float|int|str|bool)$")
# a union member refusing the value's whole kind (a string for a pair, a list for a
# number): not the member meant when another member took the value's kind
_KIND_MISMATCH = {"float_type", "int_type", "string_type", "bool_type", "tuple_type",
                  "list_type", "dict_type", "set_type", "model_type", "model_attributes_type"}


def _schema_names() -> set[str]:
    names, todo = set(), [BaseModel]
    while todo:
        for sub in todo.pop().__subclasses__():
            if sub.__name__ not in names:
                names.add(sub.__name__)
                todo.append(sub)
    return names


def _loc(parts, schema_names) -> str:
    keep = [str(p) for p in parts
            if not (isinstance(p, str) and (_INTERNAL_LOC.match(p) or p in schema_names))]
    return ".".join(keep)


def _intended_members(errors: list[dict], schema_names) -> list[dict]:
    """Of a union's members, the errors of the one the value was meant for.

    Pydantic reports every member of a union that failed: ``{ low = 90, high = 10 }`` fails
    ``Uniform`` (high < low) and ``Choice`` (no ``choices``, unknown ``low``). A member
    whose own validator refused the value (``value_error``) is the one meant; the others'
    complaints are dropped. Without such a member, every error is kept.
    """
    def split(err):
        loc = err["loc"]
        for k, p in enumerate(loc):
            if isinstance(p, str) and (_INTERNAL_LOC.match(p) or p in schema_names):
                return tuple(loc[:k]), p
        return None, None

    meant: dict[tuple, set] = {}
    for err in errors:
        base, member = split(err)
        if base is not None and err["type"] == "value_error":
            meant.setdefault(base, set()).add(member)
    # no validator spoke: the members that took the value's kind ("5cm" for float | pair:
    # the number; [0.05, "x"]: the pair), when some member did
    members: dict[tuple, dict] = {}
    for err in errors:
        base, member = split(err)
        if base is not None and base not in meant:
            whole = len(err["loc"]) == len(base) + 1
            kind = members.setdefault(base, {}).setdefault(member, True)
            members[base][member] = kind and whole and err["type"] in _KIND_MISMATCH
    for base, kinds in members.items():
        took = {m for m, mismatch in kinds.items() if not mismatch}
        if took and len(took) < len(kinds):
            meant[base] = took
    out = []
    for err in errors:
        base, member = split(err)
        if base is None or base not in meant or member in meant[base]:
            out.append(err)
    return out


def validation_message(exc: ValidationError, where: str, what: str = "") -> str:
    """One line from a pydantic ``ValidationError``: ``where: what loc: msg; loc: msg``.

    ``extra_forbidden`` errors read "unknown key", so a misspelt option names itself; a
    number written with a unit ("0.35 m") gets a hint; pydantic's internal location parts
    (union members, validator names) are left out and repeated messages given once.
    """
    schema_names = _schema_names()
    parts: list[str] = []
    for err in _intended_members(exc.errors(), schema_names):
        loc = _loc(err["loc"], schema_names) or "(top level)"
        msg = err["msg"].removeprefix("Value error, ")
        if err["type"] == "extra_forbidden":
            msg = "unknown key"
        val = err.get("input")
        if isinstance(val, _Boolean):
            msg += f" (got {val!r}, a boolean)"
        elif isinstance(val, str) and UNIT_RE.match(val):
            msg += (f" (got {val!r}: write a plain number in the unit of the key: "
                    "*_deg in degrees, everything else SI)")
        text = f"{loc}: {msg}"
        head = re.match(r"[A-Za-z_][\w]*", msg)
        if head and msg[head.end():head.end() + 1] in (":", ".") and (
                loc == head.group() or loc.endswith("." + head.group())):
            # the validator named its own table ("obstacle: give ..."): not twice
            text = loc + msg[head.end():]
        if text not in parts:
            parts.append(text)
    return f"{where}: {what}" + "; ".join(parts)


def validate(cls: type[T], raw: Mapping[str, Any] | T, where: str, what: str = "") -> T:
    """``cls.model_validate(raw)``, or one :class:`ConfigError` naming ``where`` and the keys."""
    if isinstance(raw, cls):
        return raw
    try:
        return cls.model_validate(raw)
    except ValidationError as exc:
        raise ConfigError(validation_message(exc, where, what)) from None
