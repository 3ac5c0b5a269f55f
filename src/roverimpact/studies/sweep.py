"""Run a study: evaluate every case, in chunks, serially or on a Dask cluster, resumable.

Layout of an output folder::

    results/
      study.toml         the study file, copied as given
      manifest.json      study name and fingerprint, chunk size, evaluator, versions, status
      chunks/chunk-000012.parquet   finished chunks (written atomically)
      results.parquet    every input next to every output, one row per case, sorted
      results.csv        the same, on request

Chunks are fixed by the study (chunk ``k`` holds cases ``k*chunk_size ...``), every row
carries its stable ``case_id``, and a chunk file appears only once complete (temp file +
``os.replace``). ``resume=True`` keeps the chunks whose ids match and computes the rest,
so an interrupted study continues without recomputing or duplicating rows. On Dask the
client writes the chunks as the tasks return; a task lost with a dead worker is
recomputed by the scheduler (and retried on errors), and the chunk is written once.
"""

from __future__ import annotations

import json
import math
import os
import socket
import time
import uuid
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from urllib.parse import urlparse

import numpy as np
import pandas as pd

from ..exceptions import ConfigError, RoverImpactError
from .config import Case, Study, expand, flatten, load_study, study_from_dict, validate_scenarios
from .evaluate import get_evaluator

__all__ = ["StudyResult", "load_results", "prepare_study", "run_study"]

RESULTS = "results.parquet"
MANIFEST = "manifest.json"
STUDY_COPY = "study.toml"
CHUNKS = "chunks"


@dataclass
class StudyResult:
    """Outcome of :func:`run_study`.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per case (sorted by ``case``): ``case``, ``case_id``, the swept
        parameters, the other scenario inputs, then the outputs.
    out_dir : pathlib.Path
        The output folder.
    files : dict
        Written files by role (``results``, ``csv``, ``study``, ``manifest``).
    n_computed, n_reused : int
        Cases computed in this run and cases taken from finished chunks (resume).
    elapsed : float
        Wall time of this run [s].
    """

    study: Study
    table: pd.DataFrame
    out_dir: Path
    files: dict[str, Path] = field(default_factory=dict)
    n_computed: int = 0
    n_reused: int = 0
    elapsed: float = 0.0


@dataclass
class PreparedStudy:
    """A validated study, ready to run: its cases and normalized base scenario."""

    study: Study
    text: str | None
    evaluator: Any
    base: dict
    cases: list[Case]
    chunk_size: int


def _auto_chunk(n: int, simulate: bool) -> int:
    """About 100 chunks of simulated cases (fine-grained resume and load balance), about
    20 of indicator-only cases (fast: fewer, larger Parquet writes)."""
    return max(16, math.ceil(n / 100)) if simulate else max(256, math.ceil(n / 20))


def prepare_study(study, *, evaluator=None, chunk_size: int | None = None) -> PreparedStudy:
    """Validate a study (path, dict or :class:`Study`) and expand its cases; no work yet.

    Raises
    ------
    ConfigError
        Unknown parameter, empty grid, wrong types or units, bad scenario values.
    """
    text = None
    if isinstance(study, (str, Path)):
        study, text = load_study(study)
    else:
        study = study_from_dict(study)
    ev = get_evaluator(evaluator)
    base = validate_scenarios(study, ev.validate, getattr(ev, "check", None))
    cases = expand(study)
    cs = chunk_size or study.chunk_size or _auto_chunk(len(cases), study.simulate)
    return PreparedStudy(study, text, ev, base, cases, int(cs))


# -------------------------------------------------------------------------------------
# Output folder, scheduler: checked before any work starts
# -------------------------------------------------------------------------------------


def _check_out_dir(out_dir: Path) -> None:
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


def check_scheduler(address: str, timeout: float = 3.0) -> str:
    """Check that ``tcp://HOST:PORT`` is a well-formed, reachable address."""
    url = urlparse(address if "://" in address else f"tcp://{address}")
    if url.scheme not in ("tcp", "tls") or not url.hostname or not url.port:
        raise ConfigError(
            f"scheduler address {address!r} is not of the form tcp://HOST:PORT "
            "(the address `dask scheduler` prints)"
        )
    try:
        with socket.create_connection((url.hostname, url.port), timeout=timeout):
            pass
    except OSError as exc:
        raise ConfigError(
            f"cannot reach the Dask scheduler at {address} ({exc.strerror or exc}); start "
            "one with `dask scheduler` and check host, port and firewall"
        ) from None
    return f"{url.scheme}://{url.hostname}:{url.port}"


def _need_dask() -> None:
    try:
        import dask.distributed  # noqa: F401
    except ImportError:
        raise ConfigError(
            "distributed runs need Dask: pip install 'roverimpact[dask]'"
        ) from None


def _versions() -> dict[str, str]:
    import platform
    from importlib import metadata

    from .._version import __version__

    out = {"roverimpact": __version__, "python": platform.python_version()}
    # distribution metadata only: nothing is imported (a serial run never imports dask)
    for name, dist in (("numpy", "numpy"), ("scipy", "scipy"), ("pandas", "pandas"),
                       ("pyarrow", "pyarrow"), ("pinocchio", "pin"),
                       ("matplotlib", "matplotlib"), ("dask", "dask"),
                       ("distributed", "distributed")):
        try:
            out[name] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            pass
    return out


def _atomic_write_bytes(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def _atomic_parquet(df: pd.DataFrame, path: Path) -> None:
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
    df.to_parquet(tmp, index=False)
    os.replace(tmp, path)


# -------------------------------------------------------------------------------------
# One chunk: runs on the client (serial) or on a Dask worker
# -------------------------------------------------------------------------------------


def _cell(v):
    if isinstance(v, (list, tuple, dict)):
        return json.dumps(v)
    return v


def compute_chunk(evaluator, base: Mapping, normalized_base: Mapping, cases: Sequence[Case],
                  params: Sequence[str], simulate: bool) -> pd.DataFrame:
    """Evaluate ``cases`` and return their rows: ids, inputs, outputs."""
    overrides = [c.overrides for c in cases]
    outputs = evaluator.evaluate(base, overrides, simulate=simulate)
    n = len(cases)
    cols: dict[str, Any] = {
        "case": np.array([c.index for c in cases], dtype=np.int64),
        "case_id": [c.case_id for c in cases],
    }
    flat = flatten(normalized_base)
    for p in params:
        default = flat.get(p)
        cols[p] = [_cell(ov.get(p, default)) for ov in overrides]
    for k, v in flat.items():
        if k not in cols:
            v = _cell(v)
            cols[k] = (np.full(n, v) if isinstance(v, (bool, int, float)) and v is not None
                       else [v] * n)
    for k, v in outputs.items():
        arr = np.asarray(v)
        if arr.shape != (n,):
            raise RoverImpactError(
                f"evaluator {getattr(evaluator, 'name', evaluator)!r} returned {k!r} with "
                f"shape {arr.shape}, expected ({n},)"
            )
        cols[k] = arr
    return pd.DataFrame(cols)


# -------------------------------------------------------------------------------------
# The driver
# -------------------------------------------------------------------------------------


def _chunk_path(out_dir: Path, k: int) -> Path:
    return out_dir / CHUNKS / f"chunk-{k:06d}.parquet"


def _finished_chunks(out_dir: Path, chunks: list[list[Case]]) -> set[int]:
    """Chunks whose file exists and holds exactly the expected case ids."""
    import pyarrow.parquet as pq

    done = set()
    for k, chunk in enumerate(chunks):
        path = _chunk_path(out_dir, k)
        if not path.is_file():
            continue
        try:
            ids = pq.read_table(path, columns=["case_id"]).column("case_id").to_pylist()
        except Exception:  # a damaged chunk is recomputed
            continue
        if ids == [c.case_id for c in chunk]:
            done.add(k)
    return done


def run_study(
    study,
    out_dir: str | Path,
    *,
    evaluator=None,
    resume: bool = False,
    overwrite: bool = False,
    csv: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
    chunk_size: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    retries: int = 3,
) -> StudyResult:
    """Run a study and write its results table next to a copy of the study file.

    Parameters
    ----------
    study : str, Path, dict or Study
        A study file, or a study as a dict / :class:`Study`.
    out_dir : str or Path
        Output folder (created). Must be empty of results unless ``resume`` or
        ``overwrite``.
    evaluator : optional
        Evaluator object or plain function ``scenario -> outputs`` (see
        :mod:`roverimpact.studies.evaluate`); default: the scenario layer.
    resume : bool
        Continue an interrupted run of the same study: finished chunks are kept.
    overwrite : bool
        Discard results already in ``out_dir``.
    csv : bool
        Also write ``results.csv``.
    workers : int, optional
        Run on a local Dask cluster of ``workers`` processes (1 thread each).
    scheduler : str, optional
        Run on an existing Dask cluster, ``tcp://HOST:PORT``.
    chunk_size : int, optional
        Cases per chunk (default: the study's, else about 1/100 of the cases).
    progress : callable, optional
        ``progress(done_cases, total_cases)``, called after each chunk.
    retries : int
        Dask retries per chunk on errors (lost workers are recomputed anyway).

    Returns
    -------
    StudyResult

    Raises
    ------
    ConfigError
        Before any work: bad study, unwritable folder, unreachable scheduler, folder
        holding another study's results.
    """
    t0 = time.perf_counter()
    if workers is not None and scheduler is not None:
        raise ConfigError("give either --workers or --scheduler, not both")
    if workers is not None and workers < 1:
        raise ConfigError(f"--workers must be >= 1, got {workers}")
    prep = prepare_study(study, evaluator=evaluator, chunk_size=chunk_size)
    if scheduler is not None:
        _need_dask()
        scheduler = check_scheduler(scheduler)
    elif workers is not None:
        _need_dask()
    out_dir = Path(out_dir)
    _check_out_dir(out_dir)

    st = prep.study
    fp = st.fingerprint()
    manifest_path = out_dir / MANIFEST
    chunk_dir = out_dir / CHUNKS
    if manifest_path.is_file():
        try:
            old = json.loads(manifest_path.read_text())
        except (OSError, ValueError):
            old = {}
        if resume:
            if old.get("fingerprint") != fp:
                raise ConfigError(
                    f"{out_dir} holds results of another study ({old.get('name')!r}, "
                    f"fingerprint {old.get('fingerprint')}); --resume needs the same study "
                    "file. Use another folder, or --overwrite to discard them"
                )
            prep.chunk_size = int(old.get("chunk_size", prep.chunk_size))
        elif not overwrite:
            raise ConfigError(
                f"{out_dir} already holds study results; pass --resume to continue them "
                "or --overwrite to discard them, or choose another folder"
            )
    if overwrite and chunk_dir.is_dir():
        for f in chunk_dir.glob("*.parquet"):
            f.unlink()
    chunk_dir.mkdir(exist_ok=True)

    cs = prep.chunk_size
    chunks = [prep.cases[i:i + cs] for i in range(0, len(prep.cases), cs)]
    done = _finished_chunks(out_dir, chunks) if resume else set()
    pending = [k for k in range(len(chunks)) if k not in done]

    if prep.text is not None:
        _atomic_write_bytes(out_dir / STUDY_COPY, prep.text.encode("utf-8"))
    else:
        import tomli_w

        data = st.model_dump(mode="json", exclude_none=True)
        _atomic_write_bytes(out_dir / STUDY_COPY, tomli_w.dumps(data).encode("utf-8"))
    manifest = {
        "name": st.name,
        "fingerprint": fp,
        "n_cases": len(prep.cases),
        "chunk_size": cs,
        "n_chunks": len(chunks),
        "parameters": st.parameters(),
        "x": st.x_parameter(),
        "simulate": st.simulate,
        "evaluator": getattr(prep.evaluator, "name", "?"),
        "versions": _versions(),
        "status": "running",
    }
    _atomic_write_bytes(manifest_path, json.dumps(manifest, indent=2).encode())

    total = len(prep.cases)
    n_done = sum(len(chunks[k]) for k in done)
    if progress:
        progress(n_done, total)
    args = (prep.evaluator, st.base, prep.base)
    params = st.parameters()

    fresh: dict[int, pd.DataFrame] = {}

    def _store(k: int, df: pd.DataFrame) -> None:
        nonlocal n_done
        _atomic_parquet(df, _chunk_path(out_dir, k))
        fresh[k] = df
        n_done += len(df)
        if progress:
            progress(n_done, total)

    if pending and (workers is not None or scheduler is not None):
        _run_dask(pending, chunks, args, params, st.simulate, workers, scheduler, retries,
                  _store)
    else:
        for k in pending:
            _store(k, compute_chunk(*args, chunks[k], params, st.simulate))

    table = _assemble(out_dir, chunks, fresh)
    files = {"study": out_dir / STUDY_COPY, "manifest": manifest_path,
             "results": out_dir / RESULTS}
    _atomic_parquet(table, files["results"])
    if csv:
        files["csv"] = out_dir / "results.csv"
        _atomic_write_bytes(files["csv"], table.to_csv(index=False).encode())
    elapsed = time.perf_counter() - t0
    manifest.update(status="complete", elapsed_s=round(elapsed, 3),
                    n_computed=sum(len(chunks[k]) for k in pending))
    _atomic_write_bytes(manifest_path, json.dumps(manifest, indent=2).encode())
    return StudyResult(
        study=st, table=table, out_dir=out_dir, files=files,
        n_computed=sum(len(chunks[k]) for k in pending),
        n_reused=sum(len(chunks[k]) for k in done), elapsed=elapsed,
    )


def _assemble(out_dir: Path, chunks: list[list[Case]], fresh: dict) -> pd.DataFrame:
    """The full table: chunks computed in this run (as written) and finished ones (read)."""
    frames = [fresh[k] if k in fresh else pd.read_parquet(_chunk_path(out_dir, k))
              for k in range(len(chunks))]
    table = pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()
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


def _run_dask(pending, chunks, args, params, simulate, workers, scheduler, retries, store):
    from dask.distributed import Client, LocalCluster, as_completed

    cluster = None
    if scheduler is not None:
        client = Client(scheduler, timeout="10s")
    else:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
    try:
        futures = {}
        for k in pending:
            # arguments are small: shipped with each task, so a lost worker loses nothing
            fut = client.submit(compute_chunk, *args, chunks[k], params, simulate,
                                retries=retries, pure=False)
            futures[fut] = k
        written = set()
        for fut in as_completed(list(futures)):
            k = futures[fut]
            df = fut.result()
            if k not in written:  # a chunk is stored once, whatever happened to workers
                store(k, df)
                written.add(k)
            fut.release()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def load_results(out_dir: str | Path) -> tuple[pd.DataFrame, dict, Study | None]:
    """Read a results folder: the table, the manifest and the study (if readable)."""
    out_dir = Path(out_dir)
    path = out_dir / RESULTS
    if not path.is_file():
        raise ConfigError(f"{out_dir}: no {RESULTS} here; run `roverimpact sweep` first")
    table = pd.read_parquet(path)
    manifest = {}
    if (out_dir / MANIFEST).is_file():
        manifest = json.loads((out_dir / MANIFEST).read_text())
    study = None
    if (out_dir / STUDY_COPY).is_file():
        try:
            study, _ = load_study(out_dir / STUDY_COPY)
        except ConfigError:
            study = None
    return table, manifest, study
