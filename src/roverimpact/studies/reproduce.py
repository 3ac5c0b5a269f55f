"""Reproduce the studies of both papers on the built-in rovers, with one command.

- DETC2014-35554 Fig. 2: F_max and T_c^- vs impact angle beta, 2-D rover;
- DETC2014-35554 Fig. 3: F_max and T_c^- vs COM height h, 2-D rover;
- DETC2015-47747 Fig. 2: F_max and T_c^- vs beta, 3-D rocker-bogie rover, e = 1.

The studies are TOML files shipped in the package (``roverimpact/data/studies``); each
states its assumptions (the papers do not give their rover parameters). Output: one
folder per study (table, study file, figure PNG/SVG, statistics) and ``report.html``.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

from .._io import read_toml
from ..exceptions import ConfigError
from .config import study_from_dict
from .evaluate import simulator_available
from .sweep import run_study

__all__ = ["BUILTIN_STUDIES", "ReproduceResult", "builtin_study_path", "reproduce"]

#: Built-in studies: file stem -> the paper figure it reproduces.
BUILTIN_STUDIES = {
    "detc2014_fig2_beta": "DETC2014-35554 Fig. 2",
    "detc2014_fig3_com_height": "DETC2014-35554 Fig. 3",
    "detc2015_fig2_beta": "DETC2015-47747 Fig. 2",
}

#: Grid points per swept parameter in ``--quick`` mode.
QUICK_POINTS = 5

INTRO = (
    "Reproduction of the impact studies of Gonz&aacute;lez, MacMahon, Ghotbi, "
    "Kov&eacute;cses and Angeles (ASME DETC2014-35554) and MacMahon, Gonz&aacute;lez, "
    "Ghotbi and Kov&eacute;cses (ASME DETC2015-47747) on the built-in rovers of "
    "roverimpact: the effective kinetic energy T<sub>c</sub><sup>-</sup> (kinetic energy "
    "in the subspace of constrained motion just before impact) against the peak obstacle "
    "force F<sub>max</sub> of a compliant-contact (Hunt-Crossley) simulation. The rover "
    "parameters are assumptions stated in each study file below."
)


def builtin_study_path(name: str) -> Path:
    """Path of a built-in study file (``name`` without ``.toml``)."""
    return Path(str(resources.files("roverimpact") / "data" / "studies" / f"{name}.toml"))


@dataclass
class ReproduceResult:
    """Outcome of :func:`reproduce`: output folder, report path, per-study sections."""

    out_dir: Path
    report: Path
    sections: list
    simulated: bool
    quick: bool


def _quick(data: dict) -> dict:
    data = copy.deepcopy(data)
    for key, spec in (data.get("grid") or {}).items():
        if isinstance(spec, dict) and "num" in spec:
            spec["num"] = min(int(spec["num"]), QUICK_POINTS)
        elif isinstance(spec, list) and len(spec) > QUICK_POINTS:
            step = (len(spec) - 1) / (QUICK_POINTS - 1)
            data["grid"][key] = [spec[round(i * step)] for i in range(QUICK_POINTS)]
    return data


def reproduce(
    out_dir: str | Path = "roverimpact-results",
    *,
    quick: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
    n_boot: int = 1000,
    seed: int = 0,
    progress: Callable[[str, int, int], None] | None = None,
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

    Returns
    -------
    ReproduceResult
        If the simulator is not installed, only T_c^- and the predicted peak force are
        computed and F_max is reported as unavailable (``simulated`` is False).
    """
    from ..report.html import build_report

    out_dir = Path(out_dir)
    simulated = simulator_available()
    studies = []
    for stem in BUILTIN_STUDIES:
        data = read_toml(builtin_study_path(stem))
        if quick:
            data = _quick(data)
        if not simulated:
            data["simulate"] = False
        studies.append((stem, study_from_dict(data, where=f"built-in study {stem}")))
    cluster = None
    if workers is not None and scheduler is None:
        if workers < 1:
            raise ConfigError(f"--workers must be >= 1, got {workers}")
        try:
            from dask.distributed import LocalCluster
        except ImportError:
            raise ConfigError("--workers needs Dask: pip install 'roverimpact[dask]'") from None
        # one local cluster for all studies
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        scheduler = cluster.scheduler_address
    try:
        for stem, study in studies:
            cb = (lambda d, t, s=stem: progress(s, d, t)) if progress else None
            run_study(study, out_dir / stem, overwrite=True, scheduler=scheduler, progress=cb)
    finally:
        if cluster is not None:
            cluster.close()
    intro = INTRO + (" <b>Quick smoke run</b> (5 points per study)." if quick else "")
    if not simulated:
        intro += (" <b>F<sub>max</sub> is unavailable: the compliant-contact simulator is "
                  "not installed; only T<sub>c</sub><sup>-</sup> and the contact law's "
                  "predicted peak force are shown.</b>")
    report, sections = build_report(out_dir, title="roverimpact: reproduction of "
                                    "DETC2014-35554 and DETC2015-47747", intro=intro,
                                    n_boot=n_boot, seed=seed)
    return ReproduceResult(out_dir=out_dir, report=report, sections=sections,
                           simulated=simulated, quick=quick)
