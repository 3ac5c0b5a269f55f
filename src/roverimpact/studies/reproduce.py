"""Reproduce the studies of both papers on the built-in rovers, with one command.

- DETC2014-35554 Fig. 2: F_max and T_c^- vs impact angle beta, 2-D rover;
- DETC2014-35554 Fig. 3: F_max and T_c^- vs COM height h, 2-D rover;
- DETC2015-47747 Fig. 2: F_max and T_c^- vs beta, 3-D rocker-bogie rover, e = 1;
- not in the papers: the 2-D rover at a fixed normal approach speed v_n (and total mass),
  COM height x rocker pivot height, so that the ranking cannot come from v_n.

Every case is simulated in the own simulator (``F_max``) and in MuJoCo (``F_max_mujoco``,
:mod:`roverimpact.simulate.engines`). The studies are TOML files shipped in the package
(``roverimpact/data/studies``); each states its assumptions (the papers do not give their
rover parameters). Output: one folder per study (table, study file, manifest);
:func:`roverimpact.report.reproduce.reproduce` adds the figures, statistics and
``report.html``.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from contextlib import ExitStack
from importlib import resources
from pathlib import Path

from .._io import read_toml, some_names, visible_entries
from ..exceptions import ConfigError, StudyInterrupted
from .builtin import BUILTIN_STUDIES
from .config import study_from_dict
from .executors import LazyCluster
from .forked import ProcessDied, map_forked, side_by_side
from .store import check_out_dir, is_study_manifest, read_manifest, write_manifest
from .sweep import run_study

__all__ = ["BUILTIN_STUDIES", "QUICK_POINTS", "builtin_study_path", "run_builtin_studies"]

#: Grid points of the x parameter in ``--quick`` mode (the other swept parameters keep
#: their two ends).
QUICK_POINTS = 5


def builtin_study_path(name: str) -> Path:
    """Path of a built-in study file (``name`` without ``.toml``)."""
    return Path(str(resources.files("roverimpact") / "data" / "studies" / f"{name}.toml"))


def _quick(data: dict) -> dict:
    data = copy.deepcopy(data)
    grid = data.get("grid") or {}
    x = data.get("x") or next(iter(grid), None)
    for key, spec in grid.items():
        n = QUICK_POINTS if key == x else 2
        if isinstance(spec, dict) and "num" in spec:
            spec["num"] = min(int(spec["num"]), n)
        elif isinstance(spec, list) and len(spec) > n:
            step = (len(spec) - 1) / (n - 1)
            grid[key] = [spec[round(i * step)] for i in range(n)]
    return data


def _refuse_replacing(out_dir: Path, stem: str, full) -> None:
    """ConfigError if ``out_dir/stem`` holds the full study's results (a quick run would
    replace them with 5 points)."""
    old = read_manifest(out_dir / stem) or {}
    if old.get("fingerprint") == full.fingerprint():
        raise ConfigError(
            f"{out_dir} holds a full reproduction ({stem}: {old.get('n_cases')} cases); "
            f"--quick would replace it with {QUICK_POINTS} points a study. Choose another "
            "folder with -o (without -o, --quick writes ./roverimpact-results-quick), or "
            "pass --overwrite to replace it"
        )


def _refuse_other_files(out_dir: Path) -> None:
    """ConfigError if ``out_dir`` holds files but no reproduction (no built-in study's
    folder with a study manifest): its ``report.html`` would be replaced (``-o .`` in a
    folder of the user's own files). Hidden files do not count, as for a study's folder."""
    if not out_dir.is_dir():
        return
    entries = visible_entries(out_dir)
    if not entries:
        return
    for stem in BUILTIN_STUDIES:
        if is_study_manifest(read_manifest(out_dir / stem)):
            return
    raise ConfigError(f"{out_dir} holds files but no reproduction ({some_names(entries)}); "
                      "choose a new or empty folder with -o (nothing was written)")


def run_builtin_studies(
    out_dir: str | Path = "roverimpact-results",
    *,
    quick: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Callable[[str, int, int], None] | None = None,
    overwrite: bool = False,
    note: Callable[[str], None] | None = None,
    prepare: Callable[[], None] | None = None,
    processes: int | None = None,
) -> None:
    """Run the built-in paper studies into ``out_dir/<study>`` (tables, study, manifest).

    Parameters
    ----------
    out_dir : str or Path
        Output folder (default ``./roverimpact-results``); one subfolder per study.
    quick : bool
        Smoke run: at most 5 points of the x parameter (and the two ends of any other
        swept parameter) per study.
    workers, scheduler : optional
        Run on a local Dask cluster of ``workers`` processes (started only when the work
        pays for it, see :func:`~roverimpact.studies.sweep.run_study`) or on
        ``tcp://HOST:PORT``.
    progress : callable, optional
        ``progress(study_name, done, total)``; called with ``done = 0`` for every study
        before the first begins.
    note : callable, optional
        ``note(text)``: how a study ran when the cluster was not worth starting.
    overwrite : bool
        Let a ``quick`` run replace a full reproduction found in ``out_dir`` (refused
        otherwise, before any work). A run of the same kind replaces its predecessor. A
        folder of other files (no built-in study's results) is refused whatever the flags.
    prepare : callable, optional
        ``prepare()``: called once the options and the folder are checked, before the
        first study's check (see :func:`~roverimpact.studies.sweep.run_study`).
    processes : int, optional
        Without ``workers`` or ``scheduler``: the studies run side by side in this many
        processes forked from this one (:func:`~roverimpact.studies.forked.map_forked`),
        each study's cases one after the other; default one per usable core, at most
        one per study (:func:`~roverimpact.studies.forked.side_by_side`: 1 where
        processes are not forked, macOS and Windows). 1: one study after the other here.
        ``workers=1`` asks for the same.

    Returns
    -------
    None
        The figures and the HTML report are drawn by
        :func:`roverimpact.report.reproduce.reproduce`.
    """
    out_dir = Path(out_dir)
    if workers is not None and scheduler is not None:
        raise ConfigError("give either --workers or --scheduler, not both")
    _refuse_other_files(out_dir)
    studies = []
    for stem in BUILTIN_STUDIES:
        data = read_toml(builtin_study_path(stem))
        full = study_from_dict(data, where=f"built-in study {stem}")
        if quick and not overwrite:
            _refuse_replacing(out_dir, stem, full)
        studies.append((stem, study_from_dict(_quick(data), where=f"built-in study {stem}")
                        if quick else full))
    check_out_dir(out_dir)  # each study's run checks its own folder, after the compile
    if progress is not None:  # every study's size from the start: one bar for them all
        for stem, study in studies:
            progress(stem, 0, study.n_cases())
    if workers is None and scheduler is None:
        n = side_by_side(len(studies)) if processes is None else processes
        if n > 1:
            _side_by_side(out_dir, studies, n, progress=progress, note=note, prepare=prepare)
            return
    elif processes is not None and processes > 1:
        raise ConfigError("processes apply without a Dask cluster (workers, scheduler)")
    with ExitStack() as stack:
        cluster = None
        if workers is not None and scheduler is None:  # one local cluster for all studies,
            cluster = stack.enter_context(LazyCluster(workers))   # started when worth it
        for stem, study in studies:
            cb = (lambda d, t, s=stem: progress(s, d, t)) if progress else None
            try:
                run_study(study, out_dir / stem, overwrite=True, scheduler=scheduler,
                          progress=cb, cluster=cluster, note=note, prepare=prepare)
            except StudyInterrupted:  # its "--resume" advice is the sweep command's
                raise StudyInterrupted(_interrupted(out_dir, stem)) from None


def _cost(study) -> float:
    """A study's relative cost for the order of :func:`_side_by_side` (longest first): its
    cases, a case of the 3-D rover counted twice (its study's ``elapsed_s`` in the
    manifests of a full reproduction, 2026-11-29: 0.46 s a case, against 0.20-0.25 s for
    the 2-D rover's)."""
    model = study.base.get("model", {})
    name = model.get("name") if isinstance(model, dict) else model
    return study.n_cases() * (1.0 if name == "rover2d" else 2.0)


def _side_by_side(out_dir: Path, studies, processes: int, *, progress, note,
                  prepare) -> None:
    """:func:`run_builtin_studies`'s studies in ``processes`` forked processes, the
    longest first; progress and notes reach the callbacks here."""
    if prepare is not None:  # compiled here, inherited by every process
        prepare()
    order = sorted(studies, key=lambda item: -_cost(item[1]))

    def one(item, emit):
        stem, study = item
        try:
            run_study(study, out_dir / stem, overwrite=True,
                      progress=lambda d, t: emit("progress", stem, d, t),
                      note=lambda text: emit("note", text))
        except StudyInterrupted:
            raise StudyInterrupted(_interrupted(out_dir, stem)) from None

    def events(kind, *args):
        if kind == "progress" and progress is not None:
            progress(*args)
        elif kind == "note" and note is not None:
            note(*args)

    try:
        map_forked(one, order, processes=processes, events=events)
    except StudyInterrupted:  # a study's, named
        raise
    except KeyboardInterrupt:  # here: every process has ended its study as a Ctrl-C does
        raise StudyInterrupted(_interrupted(out_dir)) from None
    except ProcessDied as exc:  # killed: its manifest said "running" for ever
        if exc.item is None:  # pragma: no cover - died before it said which study
            raise
        stem = order[exc.item][0]
        _mark_failed(out_dir / stem, f"its process died ({exc.how})")
        raise ProcessDied(
            f"the process running study {stem} died ({exc.how}; it may have run out of "
            f"memory); {out_dir} is incomplete: run the same `roverimpact reproduce` "
            "command again to recompute it", exc.item, exc.how) from None


def _mark_failed(folder: Path, error: str) -> None:
    """A study's manifest that still says ``running`` says ``failed`` (``error``)."""
    manifest = read_manifest(folder)
    if manifest is not None and manifest.get("status") == "running":
        try:
            write_manifest(folder, manifest | {"status": "failed", "error": error})
        except OSError:  # pragma: no cover - the error above is the one to report
            pass


def _interrupted(out_dir: Path, stem: str | None = None) -> str:
    where = f" in study {stem}" if stem else ""
    return (f"interrupted{where}; {out_dir} is incomplete: run the same "
            "`roverimpact reproduce` command again to recompute it")
