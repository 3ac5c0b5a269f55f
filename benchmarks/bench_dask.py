"""Dask against serial, in one run: does ``--workers 2`` help, and is it never slower?

    python benchmarks/bench_dask.py [--n-indicator 1000000] [--n-sim 200] [--workers 2]
                                    [--repeat 1]

Issue #19's targets: >= 1.7x on 2 workers for a 1e6-case indicator sweep (3-D
rocker-bogie, T_c^- only) and for 200 simulated cases (2-D rover, own engine); never
slower than serial (``run_study`` falls back to serial when the work is too small to pay
for starting a cluster, :func:`roverimpact.studies.executors.worth_a_cluster`).

Each workload runs three ways, wall time from the call to the finished table:
* serial (``workers=None``);
* ``workers=N``: a local cluster started for the study (its start-up included), or the
  serial fallback when the probe says the cluster does not pay (the executor used is
  printed, from the manifest);
* on an already running local cluster (``scheduler=address``), as several studies of one
  session share one (``reproduce``), start-up excluded.

``--repeat N`` runs the three in turns N times and prints every round and the medians of
the ratios: on a machine whose speed swings within a minute one round's ratio is one draw
(200 simulated cases on a cluster started for them gave 1.63-1.90x in six runs on
2026-11-30).

The load average is printed before each run: on a shared machine other jobs take cores
and the speed-up cannot exceed ``cores - load``. With forked workers (Linux, the default:
:func:`roverimpact.studies.executors.worker_start_method`) the script also times every
chunk's computation and prints the mean per chunk serially and on the running cluster:
their ratio is what two processes computing at once cost each other on this machine.
Then, for a chunk of each workload, the same without Dask (plain forked processes
computing at once) and in a cluster with and without ``CLUSTER_CONFIG``: the plain line
bounds what any cluster can reach on this machine.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from bench_study import BASE_2D, BASE_3D  # the same rovers as the study benchmark
from machine import reference

from roverimpact.studies import run_study


def indicator_study(n: int) -> dict:
    n_h = max(1, n // 1000)
    return {"name": "dask indicator", "base": BASE_3D, "grid": {
        "model.params.chassis_com_above_pivot": {"start": 0.02, "stop": 0.2, "num": n_h},
        "obstacle.beta_deg": {"start": 1.0, "stop": 90.0, "num": n // n_h}}}


def simulated_study(n: int) -> dict:
    return {"name": "dask simulated", "base": BASE_2D, "simulate": True,
            "random": {"n": n, "seed": 1, "params": {
                "obstacle.beta_deg": {"low": 20.0, "high": 90.0},
                "model.params.h": {"low": 0.2, "high": 0.6}}}}


def load() -> str:
    try:
        return f"load {os.getloadavg()[0]:.1f}"
    except OSError:  # pragma: no cover
        return "load ?"


CHUNK_LOG = os.path.join(tempfile.gettempdir(), f"bench_dask_chunks_{os.getpid()}.log")


def time_chunks() -> None:
    """Log the time of every chunk's computation (``compute_chunk``), in this process and
    in the workers forked from it after this call."""
    import roverimpact.studies.executors as ex

    compute = ex.compute_chunk

    def timed_compute(*args, **kw):
        t = time.perf_counter()
        out = compute(*args, **kw)
        with open(CHUNK_LOG, "a") as f:
            f.write(f"{time.perf_counter() - t}\n")
        return out

    ex.compute_chunk = timed_compute


def chunk_times() -> list[float]:
    """The chunk times logged since the last call (and clear the log)."""
    try:
        with open(CHUNK_LOG) as f:
            out = [float(x) for x in f]
        os.remove(CHUNK_LOG)
    except FileNotFoundError:
        out = []
    return out


def timed(study: dict, tmp: str, tag: str, **kw) -> tuple[float, str, np.ndarray]:
    chunk_times()
    before = load()
    t0 = time.perf_counter()
    res = run_study(study, f"{tmp}/{tag}", **kw)
    wall = time.perf_counter() - t0
    manifest = json.loads((Path(tmp) / tag / "manifest.json").read_text())
    T = res.table["T_c_minus"].to_numpy(float)
    return wall, f"{manifest.get('executor', 'serial')} ({before})", T


def compare(name: str, study: dict, workers: int, address: str, repeat: int = 1) -> None:
    """The study serially, on a cluster started for it and on the running cluster, in
    turns, ``repeat`` rounds: with more than one, every round's ratios and their medians
    (this machine's speed swings within a minute; one round's ratio is one draw)."""
    rounds = []
    with tempfile.TemporaryDirectory() as tmp:
        warm = ({**study, "grid": {"obstacle.beta_deg": [30.0]}} if "grid" in study
                else {**study, "random": {**study["random"], "n": 2}})
        run_study(warm, f"{tmp}/warm")                  # imports and compiled kernels
        for r in range(repeat):
            ts, es, Ts = timed(study, tmp, f"serial{r}")
            cs = chunk_times()
            tw, ew, Tw = timed(study, tmp, f"workers{r}", workers=workers)
            tr, er, Tr = timed(study, tmp, f"running{r}", scheduler=address)
            cr = chunk_times()
            same = (np.array_equal(Ts, Tw, equal_nan=True)
                    and np.array_equal(Ts, Tr, equal_nan=True))
            rounds.append((ts, es, tw, ew, tr, er, same, cs, cr))
    print(f"{name}:")
    for r, (ts, es, tw, ew, tr, er, same, cs, cr) in enumerate(rounds):
        if repeat > 1:
            print(f" round {r + 1} of {repeat}")
        print(f"  serial                        {ts:8.2f} s   {es}")
        print(f"  workers={workers} (cluster started) {tw:8.2f} s   {ts / tw:5.2f}x   {ew}")
        print(f"  running cluster               {tr:8.2f} s   {ts / tr:5.2f}x   {er}")
        print(f"  T_c^- identical in the three runs: {same}")
        if cs and cr:
            print(f"  computing a chunk: {np.mean(cs):.3f} s serially, {np.mean(cr):.3f} s on "
                  f"the running cluster ({np.mean(cr) / np.mean(cs):.2f}x; {len(cr)} chunks)")
    if repeat > 1:
        started = [ts / tw for ts, _, tw, *_ in rounds]
        running = [ts / tr for ts, _, _, _, tr, *_ in rounds]
        print(f"  median of {repeat} rounds: cluster started {np.median(started):.2f}x "
              f"({min(started):.2f}-{max(started):.2f}), running cluster "
              f"{np.median(running):.2f}x ({min(running):.2f}-{max(running):.2f})")


def _first_task(_i: int = 0) -> int:
    """What a worker's first chunk loads: the studies' evaluator and the compiled kernels."""
    import roverimpact.studies.evaluate  # noqa: F401
    from roverimpact._kernels.partition import partition_kernel

    partition_kernel.get()
    return os.getpid()


def cluster_start(workers: int) -> None:
    """Wall time of a local cluster (start, every worker's first task, close) by the way
    its workers start (:func:`roverimpact.studies.executors.worker_start_method`)."""
    from dask.distributed import Client

    from roverimpact.studies.executors import local_cluster

    _first_task()                                # this process as a study has it
    print(f"local cluster of {workers} workers: start, first tasks, close")
    for method in ("fork", "spawn"):
        os.environ["ROVERIMPACT_WORKER_START"] = method
        try:
            t0 = time.perf_counter()
            with local_cluster(workers) as address, Client(address) as client:
                t1 = time.perf_counter()
                client.gather([client.submit(_first_task, i, pure=False)
                               for i in range(workers)])
                t2 = time.perf_counter()
            t3 = time.perf_counter()
        finally:
            del os.environ["ROVERIMPACT_WORKER_START"]
        print(f"  {method:6s} {t3 - t0:5.2f} s  (start {t1 - t0:.2f}, first tasks "
              f"{t2 - t1:.2f}, close {t3 - t2:.2f})")


def _cpu(who) -> float:
    import resource

    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime


def _chunk_costs(k: int) -> tuple[float, float, float]:
    """Chunk ``k`` of the study of :func:`background_work` computed and encoded here: wall
    time, CPU of this thread, CPU of the process's other threads meanwhile."""
    import resource

    from roverimpact.studies.executors import compute_chunk_file

    prep, args, params = _BACKGROUND
    s0, t0, w = _cpu(resource.RUSAGE_SELF), _cpu(resource.RUSAGE_THREAD), time.perf_counter()
    compute_chunk_file(*args, prep.cases.view(k * prep.chunk_size, (k + 1) * prep.chunk_size),
                       params, prep.study.simulate)
    w = time.perf_counter() - w
    s1, t1 = _cpu(resource.RUSAGE_SELF), _cpu(resource.RUSAGE_THREAD)
    return w, t1 - t0, (s1 - s0) - (t1 - t0)


_BACKGROUND: tuple = ()


def _plain_worker(ks, queue) -> None:
    queue.put([_chunk_costs(k) for k in ks])


def background_work(workers: int, study: dict, what: str, n_chunks: int = 8) -> None:
    """What a chunk of ``study`` costs alone, in plain forked processes computing at once,
    and in the workers of a local cluster with Dask's default background work and with
    :data:`roverimpact.studies.executors.CLUSTER_CONFIG`: the chunk's wall time, the
    CPU of the worker's other threads, and the command's CPU (scheduler, nannies,
    client) while the chunks run. The plain processes' line is what the machine allows:
    two processes computing at once that slow each other (shared caches and memory, a
    virtual machine's cores) bound any cluster's speed-up below the number of workers."""
    global _BACKGROUND
    import multiprocessing as mp
    import resource

    from dask.distributed import Client

    import roverimpact.studies.executors as ex
    from roverimpact.studies.sweep import prepare_study

    prep = prepare_study(study)
    grid = list(prep.study.grid) if prep.study.grid else []
    _BACKGROUND = (prep, (prep.evaluator, prep.study.base, prep.base), grid)
    _chunk_costs(0)                                   # loads what the workers inherit
    ks = list(range(1, n_chunks + 1))
    alone = np.array([_chunk_costs(k) for k in ks]).mean(0)
    print(f"a chunk of {prep.chunk_size:,} {what} (mean of {n_chunks}), {workers} at once:")
    print(f"  alone in this process          {alone[0]:.3f} s")
    ctx = mp.get_context("fork")
    queue = ctx.Queue()
    procs = [ctx.Process(target=_plain_worker, args=(ks[j::workers], queue))
             for j in range(workers)]
    t = time.perf_counter()
    for p in procs:
        p.start()
    plain = np.array([c for _ in procs for c in queue.get()]).mean(0)
    for p in procs:
        p.join()
    wall = time.perf_counter() - t
    print(f"  plain forked processes         {plain[0]:.3f} s  {plain[0] / alone[0]:.2f}x   "
          f"{n_chunks} chunks in {wall:.2f} s ({n_chunks * alone[0] / wall:.2f}x serial)")
    saved = ex.CLUSTER_CONFIG
    for tag, cfg in (("Dask's defaults", {}), ("CLUSTER_CONFIG", saved)):
        ex.CLUSTER_CONFIG = cfg
        try:
            with ex.local_cluster(workers) as address, Client(address) as client:
                client.gather(client.map(_chunk_costs, [0] * workers, pure=False))
                c0, t = _cpu(resource.RUSAGE_SELF), time.perf_counter()
                got = np.array(client.gather(client.map(_chunk_costs, ks))).mean(0)
                wall, cmd = time.perf_counter() - t, _cpu(resource.RUSAGE_SELF) - c0
        finally:
            ex.CLUSTER_CONFIG = saved
        print(f"  cluster, {tag:15s}       {got[0]:.3f} s  {got[0] / alone[0]:.2f}x   "
              f"{n_chunks} chunks in {wall:.2f} s ({n_chunks * alone[0] / wall:.2f}x serial); "
              f"worker's other threads {100 * got[2] / got[1]:.1f} % of the chunk's CPU, "
              f"command {cmd:.2f} s CPU")


def parquet_encoding(n: int = 50_000) -> None:
    """One chunk of the indicator sweep (n rows) encoded with pyarrow's default options and
    with the studies' ``PARQUET_WRITE``: size and best of 5 encoding times."""
    import io

    import pyarrow.parquet as pq

    from roverimpact.studies.store import PARQUET_WRITE

    with tempfile.TemporaryDirectory() as tmp:
        table = run_study(indicator_study(n), f"{tmp}/p").table
    t = __import__("pyarrow").Table.from_pandas(table, preserve_index=False)
    print(f"Parquet encoding of a {n:,}-row chunk ({t.num_columns} columns):")
    for label, opts in (("pyarrow default", {}), (f"PARQUET_WRITE {PARQUET_WRITE}", PARQUET_WRITE)):
        best, size = float("inf"), 0
        for _ in range(5):
            buf = io.BytesIO()
            t0 = time.perf_counter()
            pq.write_table(t, buf, **opts)
            best = min(best, time.perf_counter() - t0)
            size = len(buf.getvalue())
        print(f"  {label:<45} {1e3 * best:7.1f} ms   {size / 1e6:6.2f} MB")


def main() -> None:
    print(reference())  # how fast this machine is right now (machine.py)
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n-indicator", type=int, default=1_000_000)
    ap.add_argument("--n-sim", type=int, default=200)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=1,
                    help="rounds of serial / cluster started / running cluster, in turns")
    args = ap.parse_args()
    from roverimpact.studies.executors import local_cluster, worker_start_method

    if worker_start_method() == "fork":
        time_chunks()                 # before the workers fork: they inherit the timing
    print(f"{os.cpu_count()} cores, {load()}")
    with local_cluster(args.workers) as address:      # as --workers starts one
        if args.n_indicator:
            compare(f"indicator sweep, 3-D rocker-bogie, {args.n_indicator:,} cases",
                    indicator_study(args.n_indicator), args.workers, address, args.repeat)
        if args.n_sim:
            compare(f"simulated sweep, 2-D rover, {args.n_sim} random cases",
                    simulated_study(args.n_sim), args.workers, address, args.repeat)
    cluster_start(args.workers)
    if args.n_indicator:
        background_work(args.workers, indicator_study(1_000_000), "indicator cases")
    if args.n_sim:
        background_work(args.workers, simulated_study(args.n_sim), "simulated cases")
    parquet_encoding()


if __name__ == "__main__":
    main()
