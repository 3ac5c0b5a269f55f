"""Reading small input files: mass matrix, Jacobian and velocity from .npz or TOML."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from .exceptions import ConfigError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


def validation_message(exc, where: str, what: str = "") -> str:
    """One line from a pydantic ``ValidationError``: ``where: what loc: msg; loc: msg``.

    ``extra_forbidden`` errors read "unknown key", so a misspelt option names itself.
    """
    parts = []
    for err in exc.errors():
        loc = ".".join(str(x) for x in err["loc"]) or "(top level)"
        msg = err["msg"].removeprefix("Value error, ")
        if err["type"] == "extra_forbidden":
            msg = "unknown key"
        parts.append(f"{loc}: {msg}")
    return f"{where}: {what}" + "; ".join(parts)


def read_toml(path: str | Path) -> dict:
    """Read a TOML file, turning syntax errors into :class:`ConfigError`."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: no such file")
    try:
        with path.open("rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: malformed TOML: {exc}") from None
    except UnicodeDecodeError:
        raise ConfigError(f"{path}: not a text (UTF-8) TOML file") from None


def load_system(path: str | Path) -> dict[str, np.ndarray]:
    """Load ``M``, ``A``, ``v`` (and optional ``restitution``, ``persistent``) from a file.

    Supported formats: ``.npz`` (arrays named ``M``, ``A``, ``v``) and ``.toml`` (keys
    ``M``, ``A``, ``v`` holding nested lists). Shapes and values are checked later by
    the functions that use them.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".npz":
        if not path.is_file():
            raise ConfigError(f"{path}: no such file")
        try:
            with np.load(path, allow_pickle=False) as data:
                raw = {k: data[k] for k in data.files}
        except (ValueError, OSError, EOFError):
            raise ConfigError(
                f"{path}: not a readable .npz file (expected a NumPy archive written by "
                "numpy.savez with arrays M, A and v)"
            ) from None
    elif suffix == ".toml":
        raw = read_toml(path)
    else:
        raise ConfigError(f"{path}: unknown file type {suffix!r}; use .npz or .toml")
    missing = [k for k in ("M", "A", "v") if k not in raw]
    if missing:
        raise ConfigError(f"{path}: missing {', '.join(missing)} (needs arrays M, A and v)")
    known = {"M", "A", "v", "restitution", "persistent", "names", "description"}
    unknown = sorted(set(raw) - known)
    if unknown:
        raise ConfigError(f"{path}: unknown key(s) {', '.join(unknown)}; known: {sorted(known)}")
    out = {}
    for k, val in raw.items():
        if k in ("names", "description"):
            out[k] = val
            continue
        try:
            out[k] = np.asarray(val, dtype=np.float64)
        except (TypeError, ValueError):
            raise ConfigError(f"{path}: {k} is not a (rectangular) array of numbers") from None
    return out
