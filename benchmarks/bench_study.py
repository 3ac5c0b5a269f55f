"""Speed of studies: indicator-only sweep of the 3-D rover, simulated sweep of the 2-D rover.

    python benchmarks/bench_study.py                 # both, default sizes (1e5 and 1000)
    python benchmarks/bench_study.py --n-sim 100     # shorter simulated sweep
    python benchmarks/bench_study.py --memory 1e5 1e6 1e7   # peak RSS of sweep + report
    python benchmarks/bench_study.py --model-sweep 2000 20000  # every case changes the model
    python benchmarks/bench_study.py --joint-sweep 2000 20000  # a robot's configurations

Targets (issue #7): 1e5 configurations of the 3-D rover, T_c^- only, in < 10 s on one
core; 1000 simulated configurations of the 2-D rover in < 60 s on 2 cores (Dask
LocalCluster with 2 worker processes). Prints wall times, rates and the ratio to a
per-case baseline (one ``evaluate_case`` call per case, timed on a sample).

``--memory N ...`` (issue #19: memory flat in the case count, a 1e7-case indicator sweep
and its report under 1 GB resident, the report of 1e6 cases under 10 s): for each N, one
fresh process runs the 3-D indicator sweep of N cases (N/1000 COM heights x 1000 angles)
and then its report, and prints its peak resident memory (``ru_maxrss``) after the sweep
and after the report, the sweep and report wall times.

``--model-sweep N ...`` (issue #19: model-changing sweeps at >= 5000 cases/s on one core):
for each N, a seeded random design of N cases of the 3-D rover where every case changes
the model (COM height, chassis mass, speed, angle), through ``run_study`` on one core,
against an angle grid (one model, 20 000 angles) and one ``evaluate_case`` per case, in
the same run; then the same for the 2-D rover (rocker suspension: COM height h, wheel and
chassis masses, speed, angle), the papers' own study variable, and the rigid body of
``examples/study_rigid_body.toml`` (every one of its parameters, speed, angle). A study's
fixed costs (its checks, which build a model for the smallest and largest value of each
model parameter, the speed's and angle's sharing the base's; the results table) weigh on
a small N: 2 000 and 20 000 show both.

``--joint-sweep N ...`` (issue #19, sweeps off the grid, for a robot file): for each N, a
seeded random design of N cases of the Panda arm (the URDF of example-robot-data): two
joint values and a joint rate, every case a configuration of its own, through
``run_study`` on one core, against one ``evaluate_case`` per case (a fresh build, which
loads the URDF).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core for the indicator sweep
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import numpy as np
from machine import reference

from roverimpact._io import read_toml
from roverimpact.studies import run_study
from roverimpact.studies.config import apply_overrides, expand
from roverimpact.studies.evaluate import evaluate_case
from roverimpact.studies.sweep import prepare_study

BASE_3D = {
    "model": {"name": "rocker_bogie", "preset": "prototype"},
    "velocity": {"u": 0.3},
    "contacts": {"ground": "normal"},
    "obstacle": {"wheel": "left_front", "beta_deg": 60.0},
    "contact_law": {"name": "hunt-crossley", "k": 1.0e7, "e": 1.0},
}
BASE_2D = {
    "model": {"name": "rover2d", "params": {"suspension": "rocker"}},
    "velocity": {"u": 0.5},
    "contacts": {"ground": "normal"},
    "obstacle": {"wheel": "front", "beta_deg": 60.0},
    "contact_law": {"name": "hunt-crossley", "k": 1.0e7, "e": 1.0},
    "simulation": {"mu": 0.0},
}


def indicator_sweep(n_beta: int, n_h: int) -> None:
    study = {
        "name": "bench 3-D indicator",
        "base": BASE_3D,
        "grid": {
            "model.params.chassis_com_above_pivot": {"start": 0.02, "stop": 0.2, "num": n_h},
            "obstacle.beta_deg": {"start": 1.0, "stop": 90.0, "num": n_beta},
        },
    }
    n = n_beta * n_h
    with tempfile.TemporaryDirectory() as tmp:
        run_study({**study, "grid": {"obstacle.beta_deg": [30.0]}}, f"{tmp}/warm")  # JIT, imports
        t0 = time.perf_counter()
        prep = prepare_study(study)
        t_prep = time.perf_counter() - t0
        t0 = time.perf_counter()
        res = run_study(study, f"{tmp}/out")
        wall = time.perf_counter() - t0
    assert len(res.table) == n and np.isfinite(res.table["T_c_minus"]).all()
    # baseline: one evaluate_case (one build + partition) per case, on a sample
    sample = expand(prep.study)[:: max(1, n // 200)][:200]
    t0 = time.perf_counter()
    for c in sample:
        evaluate_case(apply_overrides(BASE_3D, c.overrides))
    per_case = (time.perf_counter() - t0) / len(sample)
    print(f"indicator-only sweep, 3-D rocker-bogie, {n:,} configurations "
          f"({n_h} COM heights x {n_beta} angles), 1 core:")
    print(f"  validation + expansion      {t_prep:8.2f} s")
    print(f"  run_study (incl. validation, Parquet chunks, table)  {wall:8.2f} s  "
          f"= {n / wall:,.0f} cases/s   (target < 10 s)")
    print(f"  baseline: one evaluate_case per case  {per_case * 1e3:6.2f} ms/case -> "
          f"{per_case * n:8.1f} s for {n:,}   ratio {per_case * n / wall:6.1f}x")


def simulated_sweep(n_sim: int, workers: int) -> None:
    study = {
        "name": "bench 2-D simulated",
        "base": BASE_2D,
        "simulate": True,
        "random": {"n": n_sim, "seed": 1, "params": {
            "obstacle.beta_deg": {"low": 10.0, "high": 90.0},
            "model.params.h": {"low": 0.2, "high": 0.6},
        }},
    }
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        res = run_study(study, f"{tmp}/out", workers=workers)
        wall = time.perf_counter() - t0
    ok = np.isfinite(res.table["F_max"]).sum()
    print(f"simulated sweep, 2-D rover (rocker), {n_sim} random (beta, h) configurations, "
          f"Dask LocalCluster {workers} workers:")
    print(f"  wall {wall:8.2f} s = {wall / n_sim * 1e3:6.1f} ms/case ({ok}/{n_sim} simulated)  "
          f"(target: 1000 in < 60 s -> {wall / n_sim * 1000:6.1f} s per 1000)")


#: The model-changing designs: the rover, its base scenario and its numbers' ranges.
MODEL_SWEEPS = (
    ("3-D rocker-bogie", BASE_3D, {
        "model.params.chassis_com_above_pivot": {"low": 0.02, "high": 0.2},
        "model.params.chassis_mass": {"low": 10.0, "high": 20.0}}),
    ("2-D rover (rocker)", {k: v for k, v in BASE_2D.items() if k != "simulation"}, {
        "model.params.h": {"low": 0.25, "high": 0.6},
        "model.params.wheel_mass": {"low": 1.0, "high": 4.0},
        "model.params.chassis_mass": {"low": 12.0, "high": 30.0}}),
    ("rigid body", {**read_toml(Path(__file__).resolve().parents[1] / "examples"
                                / "study_rigid_body.toml")["base"],
                    "contact_law": {"name": "hunt-crossley", "k": 1.0e7, "e": 0.8}}, {
        "model.params.mass": {"low": 5.0, "high": 50.0},
        "model.params.inertia": {"low": 0.2, "high": 3.0},
        "model.params.com_height": {"low": 0.1, "high": 0.5},
        "model.params.lever": {"low": 0.1, "high": 0.5}}),
)


def _per_case(study: dict, k: int) -> float:
    """Seconds of one ``evaluate_case`` (a fresh scenario, model and setup) per case, over
    the first ``k`` cases of ``study``."""
    sample = expand(prepare_study(study).study)[:k]
    t0 = time.perf_counter()
    for c in sample:
        evaluate_case(apply_overrides(study["base"], c.overrides))
    return (time.perf_counter() - t0) / len(sample)


def model_sweep(n: int) -> None:
    for name, base, params in MODEL_SWEEPS:
        _model_sweep(n, name, base, params)


def _model_sweep(n: int, name: str, base: dict, params: dict) -> None:
    study = {"name": "bench model-changing", "base": base, "random": {
        "n": n, "seed": 1, "params": {
            "obstacle.beta_deg": {"low": 10.0, "high": 90.0}, **params,
            "velocity.u": {"low": 0.1, "high": 0.5}}}}
    grid = {"name": "bench angle grid", "base": base, "grid": {
        "obstacle.beta_deg": {"start": 1.0, "stop": 90.0, "num": 20_000}}}
    with tempfile.TemporaryDirectory() as tmp:
        # warm: load the compiled kernels both studies use (a batch of cases, a family's
        # block), which the first study in a process would otherwise load inside its time
        run_study({**grid, "grid": {"obstacle.beta_deg": [30.0]}}, f"{tmp}/warm")
        run_study({**study, "random": {**study["random"], "n": 300, "seed": 2}},
                  f"{tmp}/warm-model")
        run_study({**grid, "grid": {"obstacle.beta_deg": {**grid["grid"]["obstacle.beta_deg"],
                                                          "num": 300}}}, f"{tmp}/warm-grid")
        t0 = time.perf_counter()
        run_study(study, f"{tmp}/model")
        t_model = time.perf_counter() - t0
        t0 = time.perf_counter()
        run_study(grid, f"{tmp}/grid")
        t_grid = time.perf_counter() - t0
    per_case = _per_case(study, 200)
    r_model, r_grid = n / t_model, 20_000 / t_grid
    print(f"model-changing random design, {name}, {n:,} cases (every case a new "
          "model), 1 core:")
    print(f"  run_study          {r_model:9,.0f} cases/s   (target >= 5000)")
    print(f"  angle grid (1 model, 20,000 angles) {r_grid:9,.0f} cases/s   "
          f"ratio grid / model-changing {r_grid / r_model:6.1f}x")
    print(f"  one evaluate_case per case (fresh build) {1 / per_case:9,.0f} cases/s   "
          f"ratio run_study / that {r_model * per_case:6.2f}x")


#: The Panda striking a surface (examples/panda_tool_impact.toml, with a contact law) and
#: the ranges of its joint design.
PANDA = {**read_toml(Path(__file__).resolve().parents[1] / "examples"
                            / "panda_tool_impact.toml"),
         "contact_law": {"name": "hunt-crossley", "k": 1.0e7, "e": 0.8}}
PANDA_JOINTS = {"configuration.joints.panda_joint2": {"low": -1.0, "high": 1.0},
                "configuration.joints.panda_joint4": {"low": -2.5, "high": -1.0},
                "velocity.joints.panda_joint1": {"low": 0.1, "high": 1.0}}


def joint_sweep(n: int) -> None:
    study = {"name": "bench joint design", "base": PANDA,
             "random": {"n": n, "seed": 1, "params": PANDA_JOINTS}}
    with tempfile.TemporaryDirectory() as tmp:
        # warm: the compiled kernels and the robot file's first load
        run_study({**study, "random": {**study["random"], "n": 300, "seed": 2}},
                  f"{tmp}/warm")
        t0 = time.perf_counter()
        run_study(study, f"{tmp}/joints")
        t_joints = time.perf_counter() - t0
    per_case = _per_case(study, 50)
    r = n / t_joints
    print(f"joint random design, Panda (URDF), {n:,} cases (every case its own "
          "configuration and rate), 1 core:")
    print(f"  run_study          {r:9,.0f} cases/s   (target for sweeps off the grid "
          ">= 5000)")
    print(f"  one evaluate_case per case (fresh build) {1 / per_case:9,.0f} cases/s   "
          f"ratio run_study / that {r * per_case:6.0f}x")


def _memory_child(n: int, out: str) -> None:
    """Run in a fresh process: the sweep of ``n`` cases, then its report; print JSON."""
    import resource

    from roverimpact.report.html import build_report

    n_beta = 1000
    study = {
        "name": f"bench memory {n:.0e}",
        "base": BASE_3D,
        "grid": {
            "model.params.chassis_com_above_pivot": {"start": 0.02, "stop": 0.2,
                                                     "num": max(1, n // n_beta)},
            "obstacle.beta_deg": {"start": 1.0, "stop": 90.0, "num": n_beta},
        },
    }
    rss = lambda: resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # noqa: E731 [MB]
    t0 = time.perf_counter()
    res = run_study(study, out)
    t_sweep = time.perf_counter() - t0
    rss_sweep = rss()
    t0 = time.perf_counter()
    build_report(res.out_dir)
    t_report = time.perf_counter() - t0
    print(json.dumps({"n": res.n_cases, "t_sweep": t_sweep, "rss_sweep": rss_sweep,
                      "t_report": t_report, "rss_report": rss()}))


def memory(sizes: list[int]) -> None:
    print("memory of an indicator sweep + report (3-D rover, one fresh process per size, "
          "peak RSS = ru_maxrss):")
    print(f"{'cases':>12s} {'sweep':>9s} {'cases/s':>9s} {'RSS after sweep':>16s} "
          f"{'report':>8s} {'RSS after report':>17s}")
    for n in sizes:
        with tempfile.TemporaryDirectory() as tmp:
            out = subprocess.run(
                [sys.executable, __file__, "--memory-child", str(n), f"{tmp}/out"],
                check=True, capture_output=True, text=True).stdout
        r = json.loads(out.strip().splitlines()[-1])
        print(f"{r['n']:12,d} {r['t_sweep']:8.1f}s {r['n'] / r['t_sweep']:9,.0f} "
              f"{r['rss_sweep']:13.0f} MB {r['t_report']:7.1f}s {r['rss_report']:14.0f} MB",
              flush=True)
    print("targets (issue #19): 1e7 cases + report under 1 GB resident; report of 1e6 "
          "cases under 10 s")


def main() -> None:
    print(reference())  # how fast this machine is right now (machine.py)
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-beta", type=int, default=1000)
    ap.add_argument("--n-h", type=int, default=100)
    ap.add_argument("--n-sim", type=int, default=1000)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--skip-sim", action="store_true")
    ap.add_argument("--memory", type=float, nargs="+", metavar="N",
                    help="only the memory benchmark, at these case counts (1e5 1e6 1e7)")
    ap.add_argument("--memory-child", nargs=2, help=argparse.SUPPRESS)
    ap.add_argument("--model-sweep", type=int, nargs="+", metavar="N",
                    help="only the model-changing random design, of N cases (each N)")
    ap.add_argument("--joint-sweep", type=int, nargs="+", metavar="N",
                    help="only the Panda's joint random design, of N cases (each N)")
    args = ap.parse_args()
    if args.joint_sweep:
        for n in args.joint_sweep:
            joint_sweep(n)
        return
    if args.model_sweep:
        for n in args.model_sweep:
            model_sweep(n)
        return
    if args.memory_child:
        _memory_child(int(float(args.memory_child[0])), args.memory_child[1])
        return
    if args.memory:
        memory([int(n) for n in args.memory])
        return
    indicator_sweep(args.n_beta, args.n_h)
    if not args.skip_sim:
        simulated_sweep(args.n_sim, args.workers)


if __name__ == "__main__":
    main()
