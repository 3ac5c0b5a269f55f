"""``roverimpact reproduce``: the built-in paper studies, their figures and one HTML report.

- DETC2014-35554 Fig. 2: F_max and T_c^- vs impact angle beta, 2-D rover;
- DETC2014-35554 Fig. 3: F_max and T_c^- vs COM height h, 2-D rover;
- DETC2015-47747 Fig. 2: F_max and T_c^- vs beta, 3-D rocker-bogie rover, e = 1;
- a study at fixed normal approach speed (not in the papers).

The studies run in :mod:`roverimpact.studies.reproduce`; this module draws them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ..studies.reproduce import run_builtin_studies
from ..studies.stats import check_n_boot
from .html import build_report

__all__ = ["INTRO", "ReproduceResult", "reproduce"]

INTRO = (
    "Reproduction of the impact studies of Gonz&aacute;lez, MacMahon, Ghotbi, "
    "Kov&eacute;cses and Angeles (ASME DETC2014-35554) and MacMahon, Gonz&aacute;lez, "
    "Ghotbi and Kov&eacute;cses (ASME DETC2015-47747) on the built-in rovers of "
    "roverimpact: the effective kinetic energy T<sub>c</sub><sup>-</sup> (kinetic energy "
    "in the subspace of constrained motion just before impact) against the peak obstacle "
    "force F<sub>max</sub> of a compliant-contact (Hunt-Crossley) simulation, in "
    "roverimpact's own simulator and in MuJoCo (a second, independent engine with its own "
    "contact model: F<sub>max</sub> MuJoCo), beside three simpler indicators (the normal "
    "approach speed v<sub>n</sub>, &frac12; m<sub>total</sub> v<sub>n</sub><sup>2</sup> and "
    "T<sub>c</sub><sup>-</sup> with the obstacle row only). A fourth study, not in the "
    "papers, holds v<sub>n</sub> fixed and changes only the configuration. The rover "
    "parameters are assumptions stated in each study file below."
)



@dataclass
class ReproduceResult:
    """Outcome of :func:`reproduce`: output folder, report path, per-study sections."""

    out_dir: Path
    report: Path
    sections: list
    quick: bool


def reproduce(
    out_dir: str | Path = "roverimpact-results",
    *,
    quick: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
    n_boot: int = 1000,
    seed: int = 0,
    progress: Callable[[str, int, int], None] | None = None,
    note: Callable[[str], None] | None = None,
    overwrite: bool = False,
    prepare: Callable[[], None] | None = None,
    processes: int | None = None,
) -> ReproduceResult:
    """Run the built-in paper studies and write figures, tables and one HTML report.

    Parameters
    ----------
    out_dir : str or Path
        Output folder (default ``./roverimpact-results``); one subfolder per study.
    quick : bool
        Smoke run: at most 5 grid points per study.
    workers, scheduler : optional
        Run on a local Dask cluster of ``workers`` processes or on ``tcp://HOST:PORT``.
    n_boot, seed : int
        Bootstrap resamples and seed of the confidence intervals.
    progress : callable, optional
        ``progress(study_name, done, total)``.
    note : callable, optional
        ``note(text)``: how a study ran when a local cluster was not worth starting.
    overwrite : bool
        Let a ``quick`` run replace a full reproduction in ``out_dir`` (refused otherwise,
        before any work).
    prepare : callable, optional
        ``prepare()``: called once the options and the folder are checked, before the
        first study's check (the command line compiles its kernels there).
    processes : int, optional
        Processes the studies, then their figures and statistics, run in side by side
        (default one per usable core, at most one per study; 1, or ``workers=1``: one
        after the other here). Without ``workers`` or ``scheduler``: see
        :func:`~roverimpact.studies.reproduce.run_builtin_studies`.

    Returns
    -------
    ReproduceResult
    """
    check_n_boot(n_boot)  # before the studies run, not after
    out_dir = Path(out_dir)
    if processes is None and workers == 1 and scheduler is None:
        processes = 1  # "one after the other, here": the figures too
    run_builtin_studies(out_dir, quick=quick, workers=workers, scheduler=scheduler,
                        progress=progress, overwrite=overwrite, note=note,
                        prepare=prepare, processes=processes)
    intro = INTRO + (" <b>Quick smoke run</b> (5 points per study)." if quick else "")
    report, sections = build_report(out_dir, title="roverimpact: reproduction of "
                                    "DETC2014-35554 and DETC2015-47747", intro=intro,
                                    n_boot=n_boot, seed=seed, processes=processes)
    return ReproduceResult(out_dir=out_dir, report=report, sections=sections, quick=quick)
