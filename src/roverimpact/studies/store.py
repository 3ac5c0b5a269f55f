"""The study output folder: manifest, chunk files, results table; every write atomic.

Layout::

    results/
      study.toml         the study file, copied as given
      manifest.json      study name and fingerprint, chunk size, evaluator, versions, status
      chunks/chunk-000012.parquet   finished chunks (written atomically)
      results.parquet    every input next to every output, one row per case, sorted
      results.csv        the same, on request

A file appears only once complete (temp file + ``os.replace``).
"""

from __future__ import annotations

import functools
import json
import os
import re
import uuid
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pandas as pd

from .._io import atomic_write, check_writable, writing
from ..exceptions import ConfigError, RoverImpactError
from .config import Case, Study, load_study

__all__ = [
    "CHUNKS",
    "ERROR_COLUMN",
    "MANIFEST",
    "PARQUET_WRITE",
    "RESULTS",
    "SAME_MAJOR",
    "STUDY_COPY",
    "WHOLE_WINDOW",
    "assemble",
    "atomic_parquet",
    "atomic_write_bytes",
    "check_out_dir",
    "chunk_path",
    "code_identity",
    "count_not_posed",
    "finished_chunks",
    "folder_lock",
    "is_study_manifest",
    "load_results",
    "not_posed",
    "read_manifest",
    "read_results_table",
    "remove_stale_temporaries",
    "simulated_forces",
    "source_hash",
    "tree_hash",
    "versions",
    "whole_window_cases",
    "write_manifest",
    "write_results",
]

RESULTS = "results.parquet"
MANIFEST = "manifest.json"
STUDY_COPY = "study.toml"
CHUNKS = "chunks"
#: What is made from a study's chunks (the results table, the report and its figures,
#: a trust map): ``--overwrite`` removes them before the new run, so that an interrupted
#: one leaves no table of the discarded study beside the new study file
DERIVED = (RESULTS, "results.csv", "stats.json", "report.html", "figure.png", "figure.svg",
           "trust.parquet", "trust_map.png", "trust_map.svg")


def check_out_dir(out_dir: Path, *, create: bool = True) -> None:
    """Refuse an output folder that is a file or cannot be written; create it, unless
    ``create`` is false (then nothing is created: :func:`roverimpact._io.check_writable`)."""
    if out_dir.exists() and not out_dir.is_dir():
        raise ConfigError(f"output folder {out_dir} is a file, not a folder; choose another "
                          "folder with -o")
    if not create:
        check_writable(out_dir, folder=True)
        return
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        probe = out_dir / f".write-test-{uuid.uuid4().hex}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise ConfigError(
            f"output folder {out_dir} is not writable ({exc.strerror or exc}); "
            "choose another folder with -o"
        ) from None


#: Column of the results saying the contact lasted the whole simulated window.
WHOLE_WINDOW = "contact_whole_window"
#: The column of a study run with ``on_error="record"``: "" for a case that was posed,
#: else why it could not be ("ModelError: ...")
ERROR_COLUMN = "error"


def whole_window_cases(table: pd.DataFrame, suffix: str = ""):
    """Boolean mask of the cases whose contact had not ended when the simulation stopped.

    From the ``contact_whole_window`` column, or for tables written before it existed,
    ``contact_duration >= simulation.t_after`` (the duration is capped at ``t_after``).
    All False if the study did not simulate. ``suffix``: that of a further engine's
    columns (``"_mujoco"``).
    """
    import numpy as np

    if WHOLE_WINDOW + suffix in table:
        return table[WHOLE_WINDOW + suffix].fillna(False).to_numpy(dtype=bool)
    if "contact_duration" + suffix in table and "simulation.t_after" in table:
        d = table["contact_duration" + suffix].to_numpy(dtype=float)
        cap = pd.to_numeric(table["simulation.t_after"], errors="coerce").to_numpy(float)
        with np.errstate(invalid="ignore"):
            return np.isfinite(d) & (d >= cap * (1 - 1e-9))
    return np.zeros(len(table), dtype=bool)


def simulated_forces(table: pd.DataFrame, simulate=True) -> list[tuple[str, str, str]]:
    """``(engine, force column, column suffix)`` of every engine whose peak force is in a
    results table, the study's reference (``F_max``) first.

    ``simulate``: the study's (or its manifest's) ``simulate`` value, naming the engine
    of ``F_max`` (``True`` or absent: the own simulator); further engines are found by
    their columns (``F_max_mujoco``).
    """
    from .._engines import ENGINE_NAMES, engines_of

    try:
        engines = engines_of(simulate) or ("own",)
    except RoverImpactError:
        engines = ("own",)
    out = [(engines[0], "F_max", "")] if "F_max" in table else []
    for name in (*engines[1:], *(e for e in ENGINE_NAMES if e not in engines)):
        if f"F_max_{name}" in table:
            out.append((name, f"F_max_{name}", f"_{name}"))
    return out


def versions() -> dict[str, str]:
    """Versions of roverimpact, Python and the packages it runs with (read once per
    process: a study's manifest asks for them every run)."""
    return dict(_versions())


@functools.lru_cache(maxsize=1)
def _versions() -> dict[str, str]:
    import platform
    from importlib import metadata

    from .._version import __version__

    # the version string is the same for every change of the source: its hash tells them
    out = {"roverimpact": __version__, "roverimpact source": source_hash(),
           "python": platform.python_version()}
    # distribution metadata only: nothing is imported (a serial run never imports dask)
    for name, dist in (("numpy", "numpy"), ("scipy", "scipy"), ("pandas", "pandas"),
                       ("pyarrow", "pyarrow"), ("pinocchio", "pin"),
                       ("matplotlib", "matplotlib"), ("mujoco", "mujoco"), ("dask", "dask"),
                       ("distributed", "distributed")):
        try:
            out[name] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            pass
    return out


#: The packages whose major version a Dask worker must share with the command
#: (:func:`code_identity`), by distribution name
SAME_MAJOR = (("numpy", "numpy"), ("pinocchio", "pin"))


def tree_hash(root: Path) -> str:
    """SHA-256 (first 16 hex digits) of the files under ``root``: their paths relative to
    it and their bytes, compiled caches (``__pycache__``, ``.pyc``, numba's ``.nbi`` and
    ``.nbc``) left out."""
    import hashlib

    root = Path(root)
    h = hashlib.sha256()
    for f in sorted(root.rglob("*")):
        if (not f.is_file() or "__pycache__" in f.relative_to(root).parts
                or f.suffix in (".pyc", ".nbi", ".nbc")):
            continue
        h.update(f.relative_to(root).as_posix().encode() + b"\0")
        h.update(f.read_bytes() + b"\0")
    return h.hexdigest()[:16]


@functools.lru_cache(maxsize=1)
def source_hash() -> str:
    """:func:`tree_hash` of the roverimpact package this process imports: what identifies
    "the same code", as the version string is the same for every change of an editable
    install or a checkout. Computed once per process (125 files: 20-35 ms, 75 ms on a
    loaded machine)."""
    return tree_hash(Path(__file__).resolve().parents[1])


def code_identity() -> dict[str, str]:
    """What a process that computes a study's cases must share with the command that
    writes them: roverimpact's version and :func:`source_hash`, and the major version of
    numpy and Pinocchio (:data:`SAME_MAJOR`). A Dask worker of another identity is
    refused (:func:`~.executors.check_workers`)."""
    v = versions()
    out = {"roverimpact": v["roverimpact"], "roverimpact source": source_hash()}
    for name, _ in SAME_MAJOR:
        out[f"{name} major version"] = v[name].split(".")[0] if name in v else "none"
    return out


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (never a half-written file)."""
    atomic_write(path, lambda tmp: tmp.write_bytes(data))


#: pyarrow's Parquet writer options of every table the studies write (chunk files,
#: results tables): plain encoding, no dictionary. The string columns repeat one value
#: over a study, which snappy compresses nearly as well as a dictionary does, and the
#: encoding takes half the time (a 50 000-row chunk of the 1e6-case benchmark: 14-16
#: against 29-31 ms, 3.65 against 3.60 MB; benchmarks/bench_dask.py). Every chunk is
#: encoded twice: into its file, and into the results table by the submitting process.
PARQUET_WRITE = {"use_dictionary": False}


def atomic_parquet(df: pd.DataFrame, path: Path) -> None:
    """Write ``df`` as Parquet to ``path`` atomically (:data:`PARQUET_WRITE`)."""
    atomic_write(path, lambda tmp: df.to_parquet(tmp, index=False, **PARQUET_WRITE))


#: The name of a temporary file of :func:`.atomic_write` (and of a results table being
#: written): ``.<name>.<32 hex digits>.tmp``
_TEMPORARY = re.compile(r"\..+\.[0-9a-f]{32}\.tmp")


def remove_stale_temporaries(out_dir: Path) -> None:
    """Delete temp files that an interrupted run left behind (never a finished file, nor
    a hidden ``.tmp`` file of another program: only the names :func:`.atomic_write`
    makes)."""
    for folder in (out_dir, out_dir / CHUNKS):
        if folder.is_dir():
            for f in folder.glob(".*.tmp"):
                if _TEMPORARY.fullmatch(f.name):
                    f.unlink(missing_ok=True)


def read_manifest(folder: Path) -> dict | None:
    """The parsed ``manifest.json`` of ``folder``; None if there is none, or it cannot be
    read, or it is not a JSON object."""
    try:
        data = json.loads((Path(folder) / MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def is_study_manifest(data) -> bool:
    """Whether ``data`` (a parsed ``manifest.json``) is a study's manifest, as
    :func:`roverimpact.studies.sweep.run_study` writes it: a ``manifest.json`` of another
    program (a web app's) or of a traverse does not make a folder a study's."""
    return isinstance(data, dict) and isinstance(data.get("fingerprint"), str)


#: Folder descriptors locked by :func:`folder_lock` in this process. A forked process (a
#: local Dask worker, started while a study holds its folder) closes its copies at once:
#: a flock belongs to every copy of the descriptor, and the worker's copy kept the folder
#: locked after the study ended, for as long as a shared cluster lived.
_LOCKED: set[int] = set()


def _close_locked_in_child() -> None:
    for fd in _LOCKED:
        try:
            os.close(fd)
        except OSError:  # pragma: no cover
            pass
    _LOCKED.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_close_locked_in_child)


@contextmanager
def folder_lock(out_dir: Path):
    """Hold an exclusive lock on the folder ``out_dir`` while a study writes it; a second
    run into the same folder meanwhile is a ConfigError instead of a second writer. Two
    runs in one folder deleted each other's chunks (a ``FileNotFoundError`` traceback) or,
    with the same case indices, wrote a results table holding the other study's rows.

    An advisory ``flock`` on the folder itself (no file is created); the system releases
    it when the process ends, however it ends (SIGKILL included). Where locks are not
    available (Windows, a file system without them) the run goes on unlocked."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows
        yield
        return
    try:
        fd = os.open(out_dir, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:  # pragma: no cover - the folder was checked just before
        yield
        return
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise ConfigError(
                f"{out_dir}: another roverimpact run is writing to this folder; wait for it "
                "to end, or choose another folder with -o") from None
        except OSError:  # pragma: no cover - no locks on this file system
            pass
        _LOCKED.add(fd)
        yield
    finally:
        _LOCKED.discard(fd)
        os.close(fd)


def write_manifest(out_dir: Path, manifest: dict) -> Path:
    """Write ``manifest.json`` atomically; return its path."""
    path = out_dir / MANIFEST
    atomic_write_bytes(path, json.dumps(manifest, indent=2).encode())
    return path


def chunk_path(out_dir: Path, k: int) -> Path:
    return out_dir / CHUNKS / f"chunk-{k:06d}.parquet"


def finished_chunks(out_dir: Path, chunks: list[list[Case]], among=None) -> set[int]:
    """Chunks whose file exists and holds exactly the expected case ids (of the chunk
    indices ``among``; default: every chunk)."""
    import pyarrow.parquet as pq

    done = set()
    for k in range(len(chunks)) if among is None else among:
        chunk = chunks[k]
        path = chunk_path(out_dir, k)
        if not path.is_file():
            continue
        try:
            ids = pq.read_table(path, columns=["case_id"]).column("case_id").to_pylist()
        except Exception:  # a damaged chunk is recomputed
            continue
        if ids == [c.case_id for c in chunk]:
            done.add(k)
    return done


def assemble(out_dir: Path, chunks: list[list[Case]], fresh: dict) -> pd.DataFrame:
    """The full table: chunks computed in this run (as written) and finished ones (read)."""
    frames = [fresh[k] if k in fresh else pd.read_parquet(chunk_path(out_dir, k))
              for k in range(len(chunks))]
    table = pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()
    if ERROR_COLUMN in table:  # chunks of a run that did not record (a resumed study)
        table[ERROR_COLUMN] = table[ERROR_COLUMN].fillna("")
    expected = [c.case_id for chunk in chunks for c in chunk]
    if table.empty and not expected:
        return table
    table = table.sort_values("case", kind="stable").reset_index(drop=True)
    if table["case_id"].tolist() != expected:  # pragma: no cover - a bug, not user input
        raise RoverImpactError(
            f"{out_dir}: assembled {len(table)} rows but the study has {len(expected)} "
            "cases (duplicated or missing chunk); rerun with --overwrite"
        )
    return table


def _chunk_table(paths: list[Path], chunks, k: int, schema):
    """Chunk ``k``'s rows (a pyarrow Table of ``schema``), in case order; they must be the
    chunk's cases (checked)."""
    import pyarrow.parquet as pq

    t = pq.read_table(paths[k], schema=schema)
    case = t.column("case").to_numpy()
    if case.size > 1 and not (case[1:] > case[:-1]).all():
        order = np.argsort(case, kind="stable")
        t, case = t.take(order), case[order]
    # the chunk's cases in order: their indices (their ids were checked when a chunk
    # was taken from an earlier run, and a fresh chunk's come from its own cases)
    first = k * chunks.size if hasattr(chunks, "size") else None
    expected = (np.arange(first, first + chunks.n_cases(k)) if first is not None
                else np.array([c.index for c in chunks[k]], dtype=np.int64))
    if not np.array_equal(case, expected):  # pragma: no cover - a bug
        raise RoverImpactError(
            f"{paths[k]}: holds {t.num_rows} rows that are not the {len(expected)} "
            "cases of its chunk (duplicated or missing rows); rerun with --overwrite")
    return t


class ResultsStream:
    """The results table written while the chunks arrive (a Dask run: this process waits
    for the workers meanwhile), in chunk order: :meth:`ready` marks a chunk's file complete
    (``done``: those finished by an earlier run) and appends every ready chunk from the
    first one not ready on; :meth:`finish` appends the rest and puts the table in place,
    the same table as :func:`write_results` (tested). A file that is there but not marked
    (a damaged chunk of an earlier run, being recomputed) is never read. Chunks of another
    column type than the first chunk's stop the stream (:meth:`finish` returns None and
    nothing is left behind: the caller writes the table with :func:`write_results`, which
    unifies them)."""

    def __init__(self, out_dir: Path, chunks, path: Path, done=()):
        self.path = Path(path)
        self._chunks = chunks
        self._ready = set(done)
        self._paths = [chunk_path(out_dir, k) for k in range(len(chunks))]
        self._tmp = self.path.with_name(f".{self.path.name}.{uuid.uuid4().hex}.tmp")
        self._writer = None
        self._schema = None
        self._next = 0
        self._stopped = not self._paths
        self.n_rows = 0

    @property
    def schema(self):
        """The table's schema (the first chunk's), once a chunk is written."""
        return self._schema

    def ready(self, k: int) -> None:
        """Chunk ``k``'s file is complete: append it and those after it that are ready."""
        self._ready.add(k)
        self.advance()

    def advance(self) -> None:
        """Append the ready chunks, in order (stops at the first one not ready). A failing
        disk: as :func:`.atomic_write`, no temporary is left and the error names the
        table."""
        with writing(self.path, self.abandon):
            self._advance()

    def _advance(self) -> None:
        import pyarrow.parquet as pq

        while not self._stopped and self._next < len(self._paths):
            path = self._paths[self._next]
            if self._next not in self._ready:
                return
            schema = pq.read_schema(path)
            if self._writer is None:
                self._schema = schema
                self._writer = pq.ParquetWriter(self._tmp, schema, **PARQUET_WRITE)
            elif not schema.remove_metadata().equals(self._schema.remove_metadata()):
                self.abandon()
                return
            t = _chunk_table(self._paths, self._chunks, self._next, self._schema)
            self._writer.write_table(t)
            self.n_rows += t.num_rows
            self._next += 1

    def finish(self) -> int | None:
        """Append the remaining chunks (every chunk is complete now) and put the table in
        place; the number of rows, or None if the stream stopped (then nothing is
        written)."""
        self._ready.update(range(len(self._paths)))
        self.advance()
        with writing(self.path, self.abandon):
            if self._stopped or self._next < len(self._paths):
                self.abandon()
                return None
            self._writer.close()
            self._writer = None
            os.replace(self._tmp, self.path)
        return self.n_rows

    def abandon(self) -> None:
        """Stop and remove the half-written table."""
        self._stopped = True
        if self._writer is not None:
            try:
                self._writer.close()
            except Exception:  # pragma: no cover - a failing disk: the file goes anyway
                pass
            self._writer = None
        self._tmp.unlink(missing_ok=True)


def write_results(out_dir: Path, chunks, path: Path, csv: Path | None = None, *,
                  stream: ResultsStream | None = None) -> int:
    """Write the results table ``path`` (and ``csv``) from the chunk files, one chunk at a
    time: memory is that of one chunk, whatever the number of cases. Each chunk's rows
    must be the chunk's cases in order (checked). Returns the number of rows.

    ``stream``: a :class:`ResultsStream` that has written the table as far as the chunks
    came (a Dask run); it is finished here. Without one, a stream over the finished chunk
    files writes the table now.

    Chunk files of different column types (which :func:`assemble` unifies as
    ``pandas.concat`` does) stop the stream and fall back to :func:`assemble` (in
    memory): the table is the same either way.
    """
    import pyarrow.parquet as pq

    paths = [chunk_path(out_dir, k) for k in range(len(chunks))]
    if stream is None:
        stream = ResultsStream(out_dir, chunks, path, done=range(len(paths)))
    n = stream.finish()
    if n is None:
        table = assemble(out_dir, chunks, {})
        atomic_parquet(table, path)
        if csv is not None:
            atomic_write_bytes(csv, table.to_csv(index=False).encode())
        return len(table)
    if csv is not None:
        schema = stream.schema

        def write_csv(tmp: Path) -> None:
            with open(tmp, "w", encoding="utf-8", newline="") as f:
                for k, p in enumerate(paths):
                    pq.read_table(p, schema=schema).to_pandas().to_csv(
                        f, index=False, header=k == 0)

        atomic_write(csv, write_csv)
    return n


def not_posed(table: pd.DataFrame | str | Path) -> pd.DataFrame:
    """Rows of a results table (or of its Parquet file, read only where the ``error``
    column is not empty) whose case could not be posed; no rows if the study ran without
    ``on_error="record"``."""
    if not isinstance(table, pd.DataFrame):
        import pyarrow.parquet as pq

        schema = pq.read_schema(table)
        if ERROR_COLUMN not in schema.names:
            return schema.empty_table().to_pandas()
        return pq.read_table(table, filters=[(ERROR_COLUMN, "!=", "")]).to_pandas()
    if ERROR_COLUMN not in table:
        return table.iloc[0:0]
    return table[table[ERROR_COLUMN].fillna("").astype(str) != ""]


def count_not_posed(path: str | Path) -> tuple[int, int | None, str]:
    """How many rows of the results table ``path`` are of cases that could not be posed
    (:func:`not_posed`), with the first one's case and error (None and "" if none),
    reading the ``case`` and ``error`` columns a row group at a time: a table of 1e7
    cases is never read whole."""
    import pyarrow.compute as pc
    import pyarrow.parquet as pq

    f = pq.ParquetFile(path)
    if ERROR_COLUMN not in f.schema_arrow.names:
        return 0, None, ""
    n, case, error = 0, None, ""
    for b in f.iter_batches(columns=["case", ERROR_COLUMN]):
        bad = pc.fill_null(pc.not_equal(b.column(1), ""), False)
        k = int(pc.sum(bad).as_py() or 0)
        if k and case is None:
            i = int(pc.index(bad, True).as_py())
            case, error = int(b.column(0)[i].as_py()), str(b.column(1)[i].as_py())
        n += k
    return n, case, error


def read_results_table(path: Path) -> pd.DataFrame:
    """Read a results table; a damaged file is a ConfigError naming it."""
    try:
        return pd.read_parquet(path)
    except OSError:
        raise
    except Exception as exc:  # pyarrow's ArrowInvalid and friends: a damaged file
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ConfigError(f"{path}: not a readable results table ({msg}); rerun the study "
                          "with --overwrite") from None


def load_results(out_dir: str | Path, *, read_table: bool = True
                 ) -> tuple[pd.DataFrame | None, dict, Study | None]:
    """Read a results folder: the table, the manifest and the study (if readable).

    ``read_table=False``: the table is not read (None; its columns are checked from the
    file's schema), for a table too large to hold.
    """
    out_dir = Path(out_dir)
    path = out_dir / RESULTS
    if not path.is_file():
        raise ConfigError(f"{out_dir}: no {RESULTS} here; run `roverimpact sweep` first")
    if read_table:
        table = read_results_table(path)
        columns = table.columns
    else:
        import pyarrow.parquet as pq

        table = None
        try:
            columns = pq.read_schema(path).names
        except OSError:
            raise
        except Exception as exc:  # a damaged file
            raise ConfigError(f"{path}: not a readable results table ({exc}); rerun the "
                              "study with --overwrite") from None
    manifest = {}
    if (out_dir / MANIFEST).is_file():
        try:
            manifest = json.loads((out_dir / MANIFEST).read_text())
        except ValueError:
            raise ConfigError(f"{out_dir / MANIFEST}: not a readable manifest (malformed "
                              "JSON)") from None
        if not isinstance(manifest, dict):
            raise ConfigError(f"{out_dir / MANIFEST}: not a readable manifest (not a JSON "
                              "object)")
    missing = [c for c in ("case", "T_c_minus") if c not in columns]
    if missing:
        raise ConfigError(f"{path}: not a study results table (no column "
                          f"{', '.join(missing)})")
    if table is not None and len(table) == 0:
        # a study writes one row per case (an empty grid is refused before any work), so
        # an empty table is a damaged or foreign file: its report once showed an empty
        # figure and "the compliant-contact simulator gave no result"
        raise ConfigError(f"{path}: the results table has no cases (0 rows"
                          + (f"; the manifest counts {manifest['n_cases']}"
                             if isinstance(manifest.get("n_cases"), int) else "")
                          + "); rerun the study with --overwrite")
    study = None
    if (out_dir / STUDY_COPY).is_file():
        try:
            study, _ = load_study(out_dir / STUDY_COPY)
        except ConfigError:
            study = None
    return table, manifest, study
