"""Run a study: evaluate every case, in chunks, serially or on a Dask cluster, resumable.

The output folder (:mod:`.store`) holds the study, a manifest, chunk files and the results.
Chunks are fixed by the study (chunk ``k`` holds cases ``k*chunk_size ...``), every row
carries its stable ``case_id``, and a chunk file appears only once complete (temp file +
``os.replace``). ``resume=True`` keeps the chunks whose ids match and computes the rest,
so an interrupted study continues without recomputing or duplicating rows. Where chunks run:
:mod:`.executors`.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from .._io import some_names, visible_entries
from ..exceptions import ConfigError, InputError, StudyInterrupted
from .config import (
    CaseSequence,
    Study,
    cases_of,
    load_study,
    named_files,
    study_from_dict,
    validate_scenarios,
)
from .evaluate import ScenarioEvaluator, get_evaluator
from .executors import (
    ChunkFile,
    LazyCluster,
    check_on_error,
    check_scheduler,
    check_workers,
    compile_note,
    compute_chunk,
    need_dask,
    reworded,
    run_dask,
    run_serial,
    why_serial,
)
from .store import (
    CHUNKS,
    DERIVED,
    MANIFEST,
    RESULTS,
    STUDY_COPY,
    ResultsStream,
    atomic_parquet,
    atomic_write_bytes,
    check_out_dir,
    chunk_path,
    finished_chunks,
    folder_lock,
    is_study_manifest,
    load_results,
    not_posed,
    read_results_table,
    remove_stale_temporaries,
    versions,
    write_manifest,
    write_results,
)

__all__ = ["StudyResult", "failed_simulations", "input_files", "load_results", "not_posed",
           "prepare_study", "run_study", "study_toml"]


class StudyResult:
    """Outcome of :func:`run_study`.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per case (sorted by ``case``): ``case``, ``case_id``, the swept
        parameters, the other scenario inputs, then the outputs. Read from
        ``results.parquet`` when first asked for (a study of 1e7 cases never holds its
        table in memory unless the caller asks for it).
    n_cases : int
        Rows of the table (without reading it).
    out_dir : pathlib.Path
        The output folder.
    files : dict
        Written files by role (``results``, ``csv``, ``study``, ``manifest``).
    n_computed, n_reused : int
        Cases computed in this run and cases taken from finished chunks (resume).
    failures : pandas.DataFrame
        The rows whose simulation failed (their forces are NaN, ``sim_error`` says why).
    not_posed : pandas.DataFrame
        The rows of cases that could not be posed (a run with ``on_error="record"``: their
        outputs are missing, ``error`` says why); empty otherwise.
    elapsed : float
        Wall time of this run [s].
    """

    def __init__(self, study: Study, table: pd.DataFrame | None = None,
                 out_dir: Path | None = None,
                 files: dict[str, Path] | None = None, n_computed: int = 0,
                 n_reused: int = 0, elapsed: float = 0.0, n_cases: int | None = None):
        self.study = study
        self._table = table
        self.out_dir = Path(out_dir) if out_dir is not None else None
        self.files = dict(files or {})
        self.n_computed = n_computed
        self.n_reused = n_reused
        self.elapsed = elapsed
        self.n_cases = int(n_cases if n_cases is not None else
                           len(table) if table is not None else 0)

    def __repr__(self) -> str:
        return (f"StudyResult(study={self.study.name!r}, n_cases={self.n_cases}, "
                f"out_dir={str(self.out_dir)!r}, n_computed={self.n_computed}, "
                f"n_reused={self.n_reused}, elapsed={self.elapsed:.3f})")

    @property
    def table(self) -> pd.DataFrame:
        """The results table (read from ``results.parquet`` on first use, then kept)."""
        if self._table is None:
            self._table = read_results_table(self.files.get("results")
                                             or self.out_dir / RESULTS)
        return self._table

    @property
    def failures(self) -> pd.DataFrame:
        """The cases where a simulation failed (``sim_error``, or a further engine's
        ``sim_error_<engine>``, not empty), with the error (in ``sim_error``)."""
        if self._table is None and not self.study.simulate:
            import pyarrow.parquet as pq

            # no simulation, no failure: the columns without reading the table
            path = self.files.get("results") or self.out_dir / RESULTS
            return pq.read_schema(path).empty_table().to_pandas()
        return failed_simulations(self.table)

    @property
    def not_posed(self) -> pd.DataFrame:
        """The rows of cases that could not be posed (``error`` not empty), read from
        ``results.parquet`` by that column alone if the table is not in memory."""
        if self._table is not None:
            return not_posed(self._table)
        return not_posed(self.files.get("results") or self.out_dir / RESULTS)


def failed_simulations(table: pd.DataFrame) -> pd.DataFrame:
    """Rows of a results table where a simulation failed, with the first error of each
    row in ``sim_error`` (prefixed by the engine for a further engine)."""
    cols = [c for c in table.columns if c == "sim_error" or c.startswith("sim_error_")]
    if not cols:
        return table.iloc[0:0]
    errs = pd.Series([""] * len(table), index=table.index, dtype=object)
    for c in cols:
        e = table[c].fillna("").astype(str)
        tag = "" if c == "sim_error" else c.removeprefix("sim_error_") + ": "
        errs = errs.where(errs != "", e.where(e == "", tag + e))
    return table.assign(sim_error=errs)[errs != ""]


@dataclass
class PreparedStudy:
    """A validated study, ready to run: its cases and normalized base scenario."""

    study: Study
    text: str | None
    evaluator: Any
    base: dict
    cases: CaseSequence
    chunk_size: int


#: Largest automatic chunk of indicator-only cases: a chunk is the unit held in memory
#: (its cases, its rows), so a study of 1e7 cases runs in 200 chunks, not 20 of 5e5.
MAX_AUTO_CHUNK = 50_000

#: Smallest automatic chunk of indicator-only cases.
MIN_AUTO_CHUNK = 256

#: Smallest automatic chunk of indicator-only cases of tens of microseconds each (an
#: angle sweep of one model, a built-in rover's model family:
#: :meth:`~.evaluate.ScenarioEvaluator.cheap`). A chunk costs a few milliseconds of its
#: own (its table, its Parquet file; in a grid, a model built and an angle sweep begun
#: again for each chunk a model's angles are split over), as much as a few hundred such
#: cases, and a chunk of 2 048 of them still takes well under a second. Cases built one
#: by one (robot files, terrains: milliseconds each) keep smaller chunks, so that the
#: progress bar moves.
CHEAP_AUTO_CHUNK = 2048


def _auto_chunk(n: int, simulate: bool, cheap: bool = False) -> int:
    """About 100 chunks of simulated cases (fine-grained resume and load balance; at
    least 8 cases a chunk), about 20 of indicator-only cases (fast: fewer, larger Parquet
    writes), at least :data:`MIN_AUTO_CHUNK` (:data:`CHEAP_AUTO_CHUNK` for ``cheap``
    cases) and at most :data:`MAX_AUTO_CHUNK` cases.

    Two workers finish ``c`` chunks of equal cost in ``ceil(c / 2)`` chunk times: 200
    simulated cases in chunks of 16 made 13 chunks, 7 rounds for 6.5 of work (at most
    1.86x), in chunks of 8 they make 25 (1.92x). A simulated case costs 36-110 ms
    (``benchmarks/bench_dask.py``, on days of different machine speed), far more than
    what a chunk adds to its cases (its table, its Parquet file, its task)."""
    if simulate:
        return max(8, math.ceil(n / 100))
    smallest = CHEAP_AUTO_CHUNK if cheap else MIN_AUTO_CHUNK
    return min(max(smallest, math.ceil(n / 20)), MAX_AUTO_CHUNK)


class Chunks(Sequence):
    """The chunks of a study: chunk ``k`` is the sequence of cases ``k*size ...
    (k+1)*size - 1`` (:meth:`CaseSequence.view`: made when iterated, small to ship to a
    worker, which makes the cases itself)."""

    def __init__(self, cases: CaseSequence, size: int):
        self.cases, self.size = cases, int(size)

    def __len__(self) -> int:
        return -(-len(self.cases) // self.size)

    def __getitem__(self, k):
        if isinstance(k, slice):
            return [self[i] for i in range(*k.indices(len(self)))]
        if not -len(self) <= k < len(self):
            raise IndexError(k)
        k %= len(self)
        return self.cases.view(k * self.size, (k + 1) * self.size)

    def n_cases(self, k: int) -> int:
        """Cases in chunk ``k`` (without making them)."""
        return min(self.size, len(self.cases) - k * self.size)


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
    check = getattr(ev, "check", None)
    if check is not None:
        # the built-in evaluator's checks share the models they build (one per model_key)
        shared = {"models": {}} if isinstance(ev, ScenarioEvaluator) else {}
        check = functools.partial(check, simulate=study.simulate, **shared)
    base = validate_scenarios(study, ev.validate, check)
    cases = cases_of(study)
    cheap = getattr(ev, "cheap", None)
    cs = chunk_size or study.chunk_size or _auto_chunk(
        len(cases), study.simulate,
        cheap is not None and cheap(study.base, study.parameters()))
    return PreparedStudy(study, text, ev, base, cases, int(cs))


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
    cluster: LazyCluster | None = None,
    note: Callable[[str], None] | None = None,
    prepare: Callable[[], None] | None = None,
    on_error: str = "stop",
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
        Run on a local Dask cluster of ``workers`` processes (1 thread each) when that is
        faster: a probe of a few cases runs here first and times the work; if it would
        take less than the cluster costs to start (:func:`~.executors.worth_a_cluster`),
        it runs here, and ``note`` says so. Never slower than serial by more than the
        probe (1/16 of a chunk, discarded).
    scheduler : str, optional
        Run on an existing Dask cluster, ``tcp://HOST:PORT``.
    chunk_size : int, optional
        Cases per chunk (default: the study's, else about 1/100 of the cases).
    progress : callable, optional
        ``progress(done_cases, total_cases)``, called after each chunk.
    retries : int
        Dask retries per chunk on errors (lost workers are recomputed anyway).
    cluster : LazyCluster, optional
        A local cluster shared with other studies (started when first needed); with
        ``workers``, default: one of this study's own.
    note : callable, optional
        ``note(text)`` receives what the user should know about how the study ran (e.g.
        serial because the work was too small for the cluster).
    prepare : callable, optional
        ``prepare()``: called once the options are checked, before the study's check
        (which evaluates its base scenario) and any case. The command line compiles its
        kernels there, while a second process compiles the one that check needs first:
        a bad option is refused without waiting for a compile, and a bad study or folder
        waits no longer than the check itself.
    on_error : "stop" or "record"
        What a case that cannot be posed (a combination of parameters no model has) does:
        stop the study with an error naming it (the finished chunks are kept), or get a
        row whose outputs are missing (NaN; False and "" for flags and texts) with column
        ``error`` saying why, the study going on (:attr:`StudyResult.not_posed`). With
        ``"record"`` every row has ``error`` ("" for a case that was posed). Not part of
        the study: ``--resume`` after a stop may record.

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
    if resume and overwrite:
        raise ConfigError("give either --resume (continue the results in the folder) or "
                          "--overwrite (discard them), not both")
    if workers is not None and scheduler is not None:
        raise ConfigError("give either --workers or --scheduler, not both")
    if workers is not None and workers < 1:
        raise ConfigError(f"--workers must be >= 1, got {workers}")
    check_on_error(on_error)
    check_out_dir(Path(out_dir), create=False)  # before the study's check, which compiles
    if prepare is not None:  # the study's check below evaluates it: compile meanwhile
        prepare()
    prep = prepare_study(study, evaluator=evaluator, chunk_size=chunk_size)
    if scheduler is not None:
        need_dask()
        scheduler = check_scheduler(scheduler, note=note)
        cold = check_workers(scheduler, study_kernels(prep.study))
        if cold and note is not None:
            note(compile_note(cold))
    elif workers is not None:
        need_dask()
    out_dir = Path(out_dir)
    check_out_dir(out_dir)
    with folder_lock(out_dir):  # one run at a time in a folder
        return _run_in_folder(prep, out_dir, resume=resume, overwrite=overwrite, csv=csv,
                              workers=workers, scheduler=scheduler, progress=progress,
                              retries=retries, cluster=cluster, note=note, t0=t0,
                              on_error=on_error)


#: The compiled kernels (``module:attribute``) every study's cases use, and those of the
#: own simulator's (``simulate``): what a running scheduler's workers are asked about
#: (:func:`~.executors.check_workers`); the command line compiles the same ahead for a
#: run here (``cli._study._compile_plan``)
STUDY_KERNELS = ("roverimpact._kernels.partition:partition_kernel",
                 "roverimpact._kernels.lemke:impact_kernel")
SIMULATOR_KERNELS = ("roverimpact._kernels.reduced:rk4_peaks",)


def study_kernels(study: Study) -> tuple[str, ...]:
    """:data:`STUDY_KERNELS`, and :data:`SIMULATOR_KERNELS` if the study runs the own
    simulator."""
    return STUDY_KERNELS + (SIMULATOR_KERNELS if "own" in study.engines() else ())


def _run_in_folder(prep: PreparedStudy, out_dir: Path, *, resume, overwrite, csv, workers,
                   scheduler, progress, retries, cluster, note, t0, on_error) -> StudyResult:
    """:func:`run_study` once the study is checked and the folder is this run's."""
    hashes = input_files(prep.study)  # each file read and hashed once per run
    _open_folder(prep, out_dir, hashes, resume=resume, overwrite=overwrite, note=note)

    cs = prep.chunk_size
    chunks = Chunks(prep.cases, cs)
    done = finished_chunks(out_dir, chunks) if resume else set()
    pending = [k for k in range(len(chunks)) if k not in done]
    manifest = _write_inputs(prep, out_dir, len(chunks), hashes, on_error)

    total = len(prep.cases)
    n_done = sum(chunks.n_cases(k) for k in done)
    if progress:
        progress(n_done, total)

    # on Dask this process waits for the workers: it writes the table meanwhile, in
    # chunk order as far as the chunks came (serially it would only move the same work)
    stream = (ResultsStream(out_dir, chunks, out_dir / RESULTS, done=done)
              if scheduler is not None or workers is not None or cluster is not None
              else None)

    in_flight = None  # the chunk being written (for the count of an interruption)

    def store(k: int, df: pd.DataFrame | ChunkFile) -> None:
        # written and dropped: no chunk is kept in memory (the table is assembled from
        # the files, one chunk at a time); a worker's chunk comes as the file's bytes
        nonlocal n_done, in_flight
        in_flight = k
        if isinstance(df, ChunkFile):
            atomic_write_bytes(chunk_path(out_dir, k), df.data)
            n_done += df.n_rows
        else:
            atomic_parquet(df, chunk_path(out_dir, k))
            n_done += len(df)
        in_flight = None
        if progress:
            progress(n_done, total)
        if stream is not None:
            stream.ready(k)

    def n_kept() -> int:
        """Cases in finished chunk files: a chunk put in place just before the
        interruption, which ``store`` had not counted yet, counts."""
        if in_flight is not None and finished_chunks(out_dir, chunks, [in_flight]):
            return n_done + chunks.n_cases(in_flight)
        return n_done

    args = (prep.evaluator, prep.study.base, prep.base)
    params = prep.study.parameters()
    simulate = prep.study.simulate
    own = cluster is None and workers is not None
    if own:
        cluster = LazyCluster(workers)
    finished = False
    # from here on the manifest says how the run ended: ``complete``, ``interrupted``
    # (Ctrl-C, or SIGTERM through the CLI) or ``failed`` (an error: a case that cannot be
    # posed, a full disk), never ``running`` once the run is over; an interruption while
    # the table is written (every chunk done) is resumed as well
    try:
        try:
            if not pending:
                pass
            elif scheduler is not None:
                run_dask(pending, chunks, args, params, simulate, scheduler, retries, store,
                         note=note, on_error=on_error)
                manifest["executor"] = f"Dask scheduler at {scheduler}"
            elif cluster is not None:
                executor = _local_or_serial(pending, chunks, args, params, simulate, store,
                                            cluster, retries, note, on_error)
                manifest["executor"] = executor
                if note and executor.startswith("serial"):
                    note(executor)
            else:
                run_serial(pending, chunks, args, params, simulate, store, on_error=on_error)
            finished = True
        finally:
            if own:
                cluster.close()
            if stream is not None and not finished:
                stream.abandon()
        return _finish(prep, out_dir, chunks, manifest, csv=csv, t0=t0,
                       n_computed=sum(chunks.n_cases(k) for k in pending),
                       n_reused=sum(chunks.n_cases(k) for k in done), stream=stream)
    except KeyboardInterrupt:
        kept = n_kept()
        _mark(out_dir, manifest, "interrupted", n_done=kept)
        if finished:
            raise StudyInterrupted(
                f"interrupted while writing {RESULTS}; all {total} cases are computed and "
                f"kept in {out_dir}: rerun with --resume to write the table") from None
        raise StudyInterrupted(
            f"interrupted after {kept} of {total} cases; the finished chunks are kept in "
            f"{out_dir}: rerun with --resume to continue") from None
    except Exception as exc:
        kept = n_kept()
        _mark(out_dir, manifest, "failed", n_done=kept, error=f"{type(exc).__name__}: {exc}")
        if isinstance(exc, InputError) and not finished:  # a case that cannot be posed
            raise reworded(exc, (
                f"{exc}. The study stopped after {kept} of {total} cases (kept in "
                f"{out_dir}); change the study so that every case can be posed and run it "
                "again with --overwrite, or record such cases and go on: --on-error record "
                "--resume")) from None
        if isinstance(exc, OSError) and exc.filename and exc.strerror:  # a full disk
            where = (f"all {total} cases are computed, kept in {out_dir}: once there is "
                     "room, rerun with --resume to write the table" if finished else
                     f"the study stopped after {kept} of {total} cases, kept in {out_dir}: "
                     "once there is room, rerun with --resume to continue")
            raise OSError(exc.errno, f"{exc.strerror} ({where})", exc.filename) from None
        raise


def _mark(out_dir: Path, manifest: dict, status: str, **extra) -> None:
    """The manifest of a run that stopped says how (``status``); a manifest that cannot
    be written (the disk that failed the run) leaves the first error to be reported."""
    try:
        write_manifest(out_dir, manifest | {"status": status, **extra})
    except OSError:
        pass


#: The probe that sizes the work before a local cluster is started: about this fraction
#: of the first pending chunk (at least one case), computed here and discarded.
PROBE_FRACTION = 1 / 16


def _local_or_serial(pending, chunks, args, params, simulate, store, cluster: LazyCluster,
                     retries: int, note=None, on_error: str = "stop") -> str:
    """Run all pending chunks on ``cluster`` if a probe of the first says that is worth it
    (:func:`~.executors.why_serial`: one case untimed, then one case and about
    :data:`PROBE_FRACTION` of the chunk, timed; rows discarded), else here. Returns what
    ran, for the manifest and the user. (Timing a whole first chunk here, as this
    function once did, cost a 1e6-case sweep on 2 workers 0.4-0.5 s of 10-11 s:
    ``benchmarks/bench_dask.py``.)"""
    first = pending[0] * chunks.size
    n_probe = max(1, math.ceil(chunks.n_cases(pending[0]) * PROBE_FRACTION))
    why = why_serial(
        cluster.workers, len(pending),
        lambda k: compute_chunk(*args, chunks.cases.view(first, first + k), params, simulate,
                                on_error=on_error),
        n_probe, sum(chunks.n_cases(k) for k in pending), running=cluster.running)
    if why is not None:
        run_serial(pending, chunks, args, params, simulate, store, on_error=on_error)
        return why
    run_dask(pending, chunks, args, params, simulate, cluster.address(), retries, store,
             note=note, on_error=on_error)
    return f"local Dask cluster of {cluster.workers} workers"


def _open_folder(prep: PreparedStudy, out_dir: Path, hashes: dict[str, str], *, resume: bool,
                 overwrite: bool, note: Callable[[str], None] | None = None) -> None:
    """Refuse a folder holding other results, and on resume one whose input files changed
    (``hashes``: :func:`input_files` now); on resume take the old chunk size (``note``
    says so if it differs, and names another version of roverimpact that began them);
    clear what an interrupted run left half-written, and the chunks on overwrite."""
    manifest_path = out_dir / MANIFEST
    old = None
    if manifest_path.is_file():
        try:
            old = json.loads(manifest_path.read_text())
        except (OSError, ValueError):
            old = {}
    # a manifest.json of another program (a web app's, a traverse's) is not a study's:
    # its folder is one of other files (an unreadable one is still taken as a study's, as
    # a run killed while writing it could leave one)
    ours = old is not None and (old == {} or is_study_manifest(old))
    if ours:
        if resume:
            fp = prep.study.fingerprint()
            if old.get("fingerprint") != fp:
                raise ConfigError(
                    f"{out_dir} holds results of another study ({old.get('name')!r}, "
                    f"fingerprint {old.get('fingerprint')}); --resume needs the same study "
                    "file. Use another folder, or --overwrite to discard them"
                )
            changed = [f for f, h in (old.get("input_files") or {}).items()
                       if hashes.get(f) != h]
            if changed:
                raise ConfigError(
                    f"{changed[0]} changed (or is gone) since the results in {out_dir} were "
                    "computed; --resume would put rows of both versions in one table. Use "
                    "--overwrite to recompute every case, or another folder")
            first = int(old.get("chunk_size", prep.chunk_size))
            if note is not None and first != prep.chunk_size:
                note(f"--resume keeps the first run's chunk size, {first} cases a chunk "
                     f"(not {prep.chunk_size}): the finished chunks are reused as they are")
            prep.chunk_size = first
            began = _roverimpact_of(old.get("versions"))
            now = _roverimpact_of(versions(), source="(source" in (began or ""))
            if note is not None and began not in (None, now):
                note(f"the results in {out_dir} were begun by roverimpact {began}, this is "
                     f"{now}: the table will hold rows of both; --overwrite recomputes "
                     "every case")
        elif not overwrite:
            raise ConfigError(
                f"{out_dir} already holds study results; pass --resume to continue them "
                "or --overwrite to discard them, or choose another folder"
            )
    elif out_dir.is_dir():
        entries = visible_entries(out_dir)
        if entries:  # -o . beside the study file, a folder of the user's own files
            raise ConfigError(
                f"{out_dir} holds files but no study results (no study {MANIFEST}: "
                f"{some_names(entries)}); "
                "choose a new or empty folder (nothing was written)")
    chunk_dir = out_dir / CHUNKS
    if overwrite and ours:
        for name in DERIVED:
            (out_dir / name).unlink(missing_ok=True)
        if chunk_dir.is_dir():  # the chunk files only (chunk_path's names)
            for f in chunk_dir.glob("chunk-*.parquet"):
                f.unlink()
    chunk_dir.mkdir(exist_ok=True)
    remove_stale_temporaries(out_dir)


def _roverimpact_of(vers, source: bool = True) -> str | None:
    """"0.1.0 (source 0123456789abcdef)": the roverimpact of a manifest's ``versions``
    (:func:`~.store.versions`; the version string stays 0.1.0 from one checkout to the
    next); the version alone without ``source``, or in a manifest written before the
    source hash was kept."""
    if not isinstance(vers, dict) or vers.get("roverimpact") is None:
        return None
    src = vers.get("roverimpact source") if source else None
    return f"{vers['roverimpact']} (source {src})" if src else str(vers["roverimpact"])


def input_files(study: Study) -> dict[str, str]:
    """SHA-256 of each file the study's scenarios read (``model.file``, ``terrain.file``,
    a ``terrain.function``'s ``.py`` file: the base's and those its grid, cases or random
    choices name, :func:`~.config.named_files`), by its name as the study gives it: the
    manifest keeps them, and ``--resume`` refuses to go on once one changed (the
    fingerprint holds only the names). Files those files name in turn (a robot's meshes)
    are not followed. (Only the base's were hashed: a grid over two robot files, one
    edited between the interrupted run and ``--resume``, kept the old robot's rows.)"""
    out = {}
    for name in named_files(study):
        if Path(name).is_file():
            out[name] = hashlib.sha256(Path(name).read_bytes()).hexdigest()
    return out


def _write_inputs(prep: PreparedStudy, out_dir: Path, n_chunks: int,
                  hashes: dict[str, str], on_error: str = "stop") -> dict:
    """The study file next to the results and a manifest saying ``running``, with the
    input files' ``hashes`` the run was checked against."""
    st = prep.study
    if prep.text is not None:
        atomic_write_bytes(out_dir / STUDY_COPY, prep.text.encode("utf-8"))
    else:
        atomic_write_bytes(out_dir / STUDY_COPY, study_toml(st).encode("utf-8"))
    manifest = {
        "name": st.name,
        "fingerprint": st.fingerprint(),
        "n_cases": len(prep.cases),
        "chunk_size": prep.chunk_size,
        "n_chunks": n_chunks,
        "parameters": st.parameters(),
        "x": st.x_parameter(),
        "simulate": st.simulate,
        "engines": list(st.engines()),
        "evaluator": getattr(prep.evaluator, "name", "?"),
        "input_files": hashes,
        "on_error": on_error,
        "versions": versions(),
        "status": "running",
    }
    write_manifest(out_dir, manifest)
    return manifest


def study_toml(study: Study) -> str:
    """The TOML text of a study given as a dict (or of a study file whose base is another
    file): read back, the same study with the same cases in the same order.

    ``tomli_w`` writes a table's plain values before its sub-tables, so a grid of a list
    and a ``{start, stop, num}`` range came back with its keys in another order: the
    same fingerprint, other case numbers (the first key varies slowest). ``--resume``
    with that copy (the advice of ``report`` on a stopped study) found no finished chunk
    and computed every case again. The grid is written as one inline value a key, in
    its order."""
    import tomli_w

    data = study.model_dump(mode="json", exclude_none=True)
    grid = data.pop("grid", None)
    text = tomli_w.dumps(data)
    if grid:
        def value(v) -> str:
            if isinstance(v, dict):
                return "{ " + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + " }"
            return tomli_w.dumps({"v": v}).split("=", 1)[1].strip()

        text += "\n[grid]\n" + "".join(f"{json.dumps(k)} = {value(v)}\n"
                                       for k, v in grid.items())
    return text


def _finish(prep, out_dir, chunks, manifest, *, csv, t0, n_computed, n_reused,
            stream=None) -> StudyResult:
    """Write the table (and the CSV) from the chunk files, one chunk at a time; mark the
    manifest. The table is not read back: :attr:`StudyResult.table` reads it if asked."""
    files = {"study": out_dir / STUDY_COPY, "manifest": out_dir / MANIFEST,
             "results": out_dir / RESULTS}
    if csv:
        files["csv"] = out_dir / "results.csv"
    n = write_results(out_dir, chunks, files["results"], csv=files.get("csv"), stream=stream)
    elapsed = time.perf_counter() - t0
    write_manifest(out_dir, manifest | {"status": "complete", "elapsed_s": round(elapsed, 3),
                                        "n_computed": n_computed})
    return StudyResult(study=prep.study, out_dir=out_dir, files=files, n_cases=n,
                       n_computed=n_computed, n_reused=n_reused, elapsed=elapsed)
