"""Reading small input files: mass matrix, Jacobian and velocity from .npz or TOML."""

from __future__ import annotations

import os
import sys
import tempfile
import uuid
import zipfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from .exceptions import ConfigError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


def visible_entries(folder: Path) -> list[str]:
    """The names in ``folder``, sorted, without hidden ones (``.name``): what a user put
    there and an output folder's checks look at."""
    return sorted(p.name for p in folder.iterdir() if not p.name.startswith("."))


def some_names(names, k: int = 4) -> str:
    """The first ``k`` of ``names`` (sorted), ``", ..."`` after them if there are more: a
    folder's contents in one error line."""
    names = sorted(names)
    return ", ".join(names[:k]) + (", ..." if len(names) > k else "")


def no_file(path: Path) -> str:
    """What is wrong with a path that is not a file: "no such file", or a folder."""
    return "a folder, not a file" if path.is_dir() else "no such file"


def utf16_problem(head: bytes) -> str | None:
    """What to say of a file whose first bytes ``head`` are a UTF-16 (or UTF-32)
    byte-order mark (Excel's "Unicode text", PowerShell's ``>``), or None."""
    if head.startswith((b"\xff\xfe\x00\x00", b"\x00\x00\xfe\xff")):
        return "the file is UTF-32: save it as UTF-8"
    if head.startswith((b"\xff\xfe", b"\xfe\xff")):
        return "the file is UTF-16: save it as UTF-8"
    return None


def read_text_utf8(path: str | Path) -> str:
    """The text of a UTF-8 file, a byte-order mark (Notepad's "UTF-8 with BOM") dropped.

    Raises :class:`ConfigError` for a UTF-16 or UTF-32 file (:func:`utf16_problem`) and
    for bytes that are not UTF-8, naming the file; ``OSError`` as it comes."""
    path = Path(path)
    data = path.read_bytes()
    problem = utf16_problem(data[:4])
    if problem:
        raise ConfigError(f"{path}: {problem}")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: not a text (UTF-8) file (byte {exc.start} is not "
                          "UTF-8)") from None


def read_toml(path: str | Path) -> dict:
    """Read a TOML file (UTF-8, with or without a byte-order mark), turning syntax errors
    and other encodings into :class:`ConfigError`."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: {no_file(path)}")
    text = read_text_utf8(path)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: malformed TOML: {exc}") from None


def check_writable(path: str | Path, *, folder: bool, option: str | None = "-o",
                   suffixes: tuple[str, ...] | None = None) -> Path:
    """Refuse, before any work, an output folder or file that cannot be written.

    Nothing is created: the nearest existing folder on the way to ``path`` gets a probe
    file, removed at once (a permission check alone would not see a read-only file
    system, nor hold for the superuser).

    Parameters
    ----------
    path : str or Path
        The output folder (``folder=True``; it may not exist yet) or file (its folder
        must exist).
    option : str, optional
        The command-line option that names the output, for the hint of the message.
    suffixes : tuple of str, optional
        File types accepted (``(".png", ".svg", ".pdf")``).

    Raises
    ------
    ConfigError
        Unknown file type, a file where a folder is expected (or the reverse), a missing
        folder of an output file, or an unwritable location.
    """
    path = Path(path)
    what = "output folder" if folder else "output file"
    hint = f"; choose another {'folder' if folder else 'file'} with {option}" if option else ""
    if not folder and suffixes is not None and path.suffix.lower() not in suffixes:
        raise ConfigError(f"{path}: unknown output file type {path.suffix or '(none)'!r}; "
                          f"use {', '.join(suffixes)}")
    if path.exists() and path.is_dir() != folder:
        raise ConfigError(f"{what} {path} is a {'file' if folder else 'folder'}{hint}")
    if folder:
        where = path
        while not where.exists() and where != where.parent:
            where = where.parent
        if not where.is_dir():
            raise ConfigError(f"{what} {path}: {where} is a file, not a folder{hint}")
    else:
        where = path.parent
        if not where.is_dir():
            raise ConfigError(f"{what} {path}: no such folder {where}{hint}")
    try:
        if path.is_file() and not os.access(path, os.W_OK):
            raise PermissionError(13, "Permission denied")
        fd, probe = tempfile.mkstemp(dir=where, prefix=".roverimpact-write-test-")
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise ConfigError(f"{what} {path} is not writable ({exc.strerror or exc}){hint}"
                          ) from None
    return path


@contextmanager
def staged_folder(out_dir: str | Path, owned: tuple[str, ...], signature: tuple[str, ...],
                  what: str):
    """Write a command's outputs into a new folder beside ``out_dir`` and put them in place
    only when all of them are written: yields that folder.

    ``out_dir`` may be missing, empty (dot files aside), or hold a previous output of the
    same command: its ``signature`` files, and nothing but files matching the glob
    patterns ``owned`` (name the files exactly where a user's file could match a pattern);
    those are replaced as a whole (no file of an earlier run is left beside the new ones).
    A folder inside is never an output: it is never removed. A folder holding anything
    else is refused before any work, with
    one ConfigError naming what it holds (``-o .`` next to the input files). An
    interrupted or failed run removes its staging folder and leaves ``out_dir`` as it
    was."""
    import fnmatch
    import shutil

    out_dir = Path(out_dir)
    if out_dir.is_dir():
        entries = visible_entries(out_dir)
        ours = entries and all((out_dir / f).exists() for f in signature)
        foreign = [e for e in entries
                   if not (ours and (out_dir / e).is_file()
                           and any(fnmatch.fnmatch(e, pat) for pat in owned))]
        missing = [f for f in signature if not (out_dir / f).exists()]
        named = [e for e in entries if (out_dir / e).is_file()
                 and any(fnmatch.fnmatch(e, pat) for pat in owned)]
        if entries and missing and len(named) == len(entries):
            # names of our outputs, but without the signature: say that, not "foreign"
            shown = some_names(named)
            raise ConfigError(
                f"{out_dir} has no {' or '.join(missing)}, so its files ({shown}) are not "
                f"taken for the outputs of a previous {what} run and would not be replaced; "
                "if they are (its summary deleted), delete the folder, or choose a new or "
                "empty one (nothing was written)")
        if foreign:
            shown = some_names(foreign)
            raise ConfigError(
                f"{out_dir} holds files that are not the outputs of a previous {what} run "
                f"({shown}); choose a new or empty folder (nothing was written)")
    near = out_dir.parent  # the nearest existing folder: nothing is created on the way
    while not near.is_dir() and near != near.parent:
        near = near.parent
    stage = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.partial-", dir=near))
    existed = out_dir.is_dir() and bool(visible_entries(out_dir))
    try:
        try:
            yield stage
        except KeyboardInterrupt as exc:
            if str(exc):  # says already what was kept
                raise
            # a bare "interrupted" left the user to look whether the previous outputs
            # were still there
            raise KeyboardInterrupt(
                f"nothing was written; {out_dir} is as it was" if existed
                else f"nothing was written ({out_dir} was not made)") from None
        with signals_held():  # a Ctrl-C here would leave half of each run
            out_dir.mkdir(parents=True, exist_ok=True)
            names = {new.name for new in stage.iterdir()}
            for new in stage.iterdir():
                os.replace(new, out_dir / new.name)
            for old in out_dir.iterdir():
                if (old.name not in names and not old.name.startswith(".")
                        and old.is_file()
                        and any(fnmatch.fnmatch(old.name, pat) for pat in owned)):
                    old.unlink()
    finally:
        shutil.rmtree(stage, ignore_errors=True)


@contextmanager
def signals_held():
    """Ctrl-C (SIGINT) and SIGTERM held back, then acted on as they would have been, when
    the block ends: around a few file moves that must all happen (the new outputs put in
    place, the old ones removed). Their handlers are swapped for one that notes them (a
    signal mask would not do: the process's other threads, a progress bar's, take the
    signal). Elsewhere than in the main thread nothing is held."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pending: list[int] = []
    previous = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        handler = signal.getsignal(sig)
        if handler not in (signal.SIG_IGN, None):
            previous[sig] = signal.signal(sig, lambda signum, frame: pending.append(signum))
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        for sig in dict.fromkeys(pending):
            handler = previous[sig]
            if callable(handler):
                handler(sig, None)
            else:  # the default action (SIGTERM ends the process)
                os.kill(os.getpid(), sig)


@contextmanager
def writing(path: Path, cleanup):
    """Around writing ``path``: on any error ``cleanup()`` (what was half written goes),
    then the error again; an ``OSError`` (a full disk) names ``path``."""
    try:
        yield
    except OSError as exc:
        cleanup()
        raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from None
    except BaseException:
        cleanup()
        raise


def atomic_write(path: str | Path, write) -> None:
    """``write(tmp)`` then ``os.replace(tmp, path)``: ``path`` is the whole new file or, if
    writing fails or is interrupted (a full disk, Ctrl-C), as it was; the temp file
    (``.<name>.<32 hex digits>.tmp`` beside it) is removed and an ``OSError`` names
    ``path``."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
    with writing(path, lambda: tmp.unlink(missing_ok=True)):
        write(tmp)
        os.replace(tmp, path)


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
            raise ConfigError(f"{path}: {no_file(path)}")
        try:
            with np.load(path, allow_pickle=False) as data:
                raw = {k: data[k] for k in data.files}
        except (ValueError, OSError, EOFError, zipfile.BadZipFile, KeyError):
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
            arr = np.asarray(val)
            if arr.dtype.kind == "c":
                raise ConfigError(f"{path}: {k} holds complex numbers; it must be real")
            out[k] = arr.astype(np.float64)
        except ConfigError:
            raise
        except (TypeError, ValueError):
            raise ConfigError(f"{path}: {k} is not a (rectangular) array of numbers") from None
    names = out.get("names")
    if names is not None:
        names = np.asarray(names)
        n = np.shape(out["v"])[-1] if np.ndim(out["v"]) else 1
        if names.ndim != 1 or names.dtype.kind not in "UO" or len(names) != n:
            raise ConfigError(f"{path}: names must be a list of {n} strings, one per "
                              f"coordinate of v, got {out['names']!r}")
        out["names"] = [str(x) for x in names]
    return out
