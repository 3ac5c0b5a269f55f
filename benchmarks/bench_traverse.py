"""Speed of a traverse: a 1 km path at 5 cm (20 001 stations, 6 wheels), and 8 paths on Dask.

Run: python benchmarks/bench_traverse.py [--quick] [--no-dask]
Prints, on one core (CPU time of the process, and wall time with the load average: the
CI machine is shared):
* the synthetic terrain (1 km x 20 m at 5 cm, k = 0.1, seed 1) and the rover build;
* the whole 1 km traverse of the built-in rocker-bogie (``run_traverse``, serial, chunks of
  500 stations): seconds, stations per second, failed poses, against the 60 s budget,
  and the same with ``limits.model = "closed-form"`` (what the weight model costs);
* the share of each step on one 2 000-station stretch (poses, kinematics, driving
  velocity, look-ahead contacts, impact energies with the automatic active set, the
  weight model's build, peak forces and speed limits);
* 8 paths of 100 m (2 001 stations each) serially and on a local Dask cluster of 2
  workers (one thread each): time and speed-up (the cluster's start-up included, and
  reported alone).
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np
from machine import reference

from roverimpact.traverse.run import build_terrain, run_traverse
from roverimpact.traverse.schema import traverse_from_dict


def config(L: float, paths: list[dict], chunk: int = 500) -> dict:
    return {
        "name": "bench",
        "terrain": {"size": [L + 4.0, 20.0], "spacing": 0.05, "origin": [-2.0, -10.0],
                    "seed": 1, "rock_abundance": 0.1},
        "paths": paths,
        "model": {"name": "rocker_bogie"},
        "drive": {"speed": 0.1},
        "limits": {"F_allow": 500.0},
        "contact_law": {"name": "hunt-crossley", "k": 1e7, "e": 0.5},
        "run": {"chunk": chunk},
    }


def parts(cfg_dict: dict, n: int = 2000) -> None:
    """Time the steps of evaluate_stations on n stations of the first path."""
    from roverimpact.models.pose import PoseProblem
    from roverimpact.traverse import compute
    from roverimpact.traverse.lookahead import first_contact_ahead
    from roverimpact.traverse.run import build_model, path_stations

    cfg = traverse_from_dict(cfg_dict)
    mbm, terrain = build_model(cfg), build_terrain(cfg.terrain)
    st = path_stations(cfg, 0).slice(0, n)
    t = {}
    clock = time.process_time           # CPU time: the machine is shared
    t0 = clock()
    pose = compute.place_on_path(mbm, terrain, st.x, st.y, st.yaw)
    t["poses (place_on_path)"] = clock() - t0
    ok = np.asarray(pose.status) == "ok"
    t0 = clock()
    states = compute.rover_states(mbm, pose.q[ok])
    t["kinematics (M, Jacobians)"] = clock() - t0
    t0 = clock()
    chosen = np.ones(len(mbm.wheels), bool)
    v = compute.driving_velocity(mbm, PoseProblem(mbm, terrain), states, pose.point[ok],
                                 pose.normal[ok], 0.1, chosen=chosen)
    t["driving velocity"] = clock() - t0
    t0 = clock()
    yaw = st.yaw[ok]
    hd = np.stack([np.cos(yaw), np.sin(yaw), 0 * yaw], -1)[:, None, :]
    hit = first_contact_ahead(terrain, states.centre, states.axis,
                              np.array([w.radius for w in mbm.wheels]),
                              np.broadcast_to(hd, states.centre.shape), pose.point[ok],
                              max_travel=0.1)
    t["look-ahead contacts"] = clock() - t0
    t0 = clock()
    ib = compute.impact_energies(mbm, states, v, pose.point[ok], pose.normal[ok], hit,
                                 chosen=chosen)
    t["impact energies (active set)"] = clock() - t0
    from roverimpact.traverse.limits import speed_limit_force
    from roverimpact.traverse.refine import impact_models, peak_forces, speed_limits

    t0 = clock()
    items = np.argwhere((ib.T_c_minus > 0) & np.isfinite(ib.m_eff))
    kk, ww = items[:, 0], items[:, 1]
    models = impact_models(mbm, states, v, pose.normal[ok], kk, ww, hit.normal[kk, ww],
                           supports=chosen)
    t["weight model: build"] = clock() - t0
    law, ground = cfg.contact_law.to_law(), cfg.limits.ground_law.to_law()
    t0 = clock()
    peak_forces(models, law, ground)
    t["weight model: F at u_ref"] = clock() - t0
    t0 = clock()
    s0 = speed_limit_force(cfg.contact_law, ib.m_eff[kk, ww], ib.v_n[kk, ww], 0.1,
                           cfg.limits.F_allow) / 0.1
    speed_limits(models, law, ground, 0.1, cfg.limits.F_allow, s0=s0, s_max=10.0)
    t["weight model: speed limits"] = clock() - t0
    total = sum(t.values())
    print(f"steps on {n} stations ({6 * n} wheels), CPU time of one core:")
    for k, x in t.items():
        print(f"  {k:30s} {x:6.2f} s  {1e3 * x / n:5.2f} ms/station  {100 * x / total:4.0f} %")
    print(f"  {'total':30s} {total:6.2f} s  {1e3 * total / n:5.2f} ms/station")


def main(quick: bool = False, dask: bool = True) -> None:
    print(reference())  # how fast this machine is right now (machine.py)
    L = 100.0 if quick else 1000.0
    cfg = config(L, [{"name": "km", "start": [0.0, 0.0], "end": [L, 0.0], "spacing": 0.05}])
    t0 = time.perf_counter()
    build_terrain(traverse_from_dict(cfg).terrain)
    print(f"terrain {L + 4:g} m x 20 m at 5 cm (k = 0.1): {time.perf_counter() - t0:.2f} s")
    run_traverse(config(10.0, [{"start": [0.0, 0.0], "end": [5.0, 0.0]}]))   # compile
    t0, c0 = time.perf_counter(), time.process_time()
    res = run_traverse(cfg)
    dt, cpu = time.perf_counter() - t0, time.process_time() - c0
    n = len(res.poses)
    print(f"{L:g} m path at 5 cm: {n} stations x 6 wheels, serial: {dt:.1f} s wall, {cpu:.1f} s "
          f"CPU of this process ({1e3 * cpu / n:.2f} ms/station; the wall time exceeds it by "
          f"what other jobs take of the core); budget 60 s: "
          f"{'met' if cpu < 60 else 'NOT met'} in CPU time, {'met' if dt < 60 else 'NOT met'} "
          f"in wall time (load average {__import__('os').getloadavg()[0]:.1f})")
    closed = json.loads(json.dumps(cfg))
    closed["limits"]["model"] = "closed-form"
    c0 = time.process_time()
    run_traverse(closed)
    cpu_c = time.process_time() - c0
    print(f"  the same with limits.model = 'closed-form': {cpu_c:.1f} s CPU (the weight "
          f"model adds {cpu - cpu_c:.1f} s)")
    print(f"  failed poses {int((res.poses['status'] != 'ok').sum())}, impacts "
          f"{int((res.wheels['T_c_minus'] > 0).sum())}, least speed limit "
          f"{res.poses['v_lim'].min():.3f} m/s, Gauss-Newton steps per station "
          f"{res.poses['iterations'].mean():.2f} (mean)")
    parts(cfg, 500 if quick else 2000)
    if not dask:
        return
    Lp = 20.0 if quick else 100.0
    paths = [{"name": f"p{i}", "start": [0.0, -8.0 + 2.2 * i], "end": [Lp, -8.0 + 2.2 * i],
              "spacing": 0.05} for i in range(8)]
    c8 = config(L, paths, chunk=2001)
    t0, c0 = time.perf_counter(), time.process_time()
    r1 = run_traverse(c8)
    t_serial, c_serial = time.perf_counter() - t0, time.process_time() - c0
    import os

    from dask.distributed import Client

    from roverimpact.studies.executors import local_cluster

    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    with local_cluster(2) as address, Client(address) as client:
        t_start = time.perf_counter() - t0
        runs = []
        for _ in range(2):                      # cold (workers compile, build the terrain),
            before = client.run(time.process_time)   # then warm
            t1 = time.perf_counter()
            r2 = run_traverse(c8, scheduler=address)
            wall = time.perf_counter() - t1
            after = client.run(time.process_time)
            cpu = {w: after[w] - before[w] for w in after}
            runs.append((wall, cpu))
    same = np.allclose(r1.wheels["T_c_minus"].to_numpy(), r2.wheels["T_c_minus"].to_numpy(),
                       equal_nan=True)
    n8 = len(r1.poses)
    print(f"8 paths x {Lp:g} m ({n8} stations), load average {load:.1f} on {os.cpu_count()} "
          f"cores:")
    print(f"  serial: {t_serial:.1f} s wall, {c_serial:.1f} s CPU")
    for name, (wall, cpu) in zip(("cold", "warm"), runs, strict=True):
        per = sorted(cpu.values())
        print(f"  2 Dask workers, {name}: {wall:.1f} s wall (+ {t_start:.1f} s cluster start); "
              f"worker CPU {' + '.join(f'{c:.1f}' for c in per)} = {sum(per):.1f} s; "
              f"speed-up on two free cores (serial CPU / busiest worker's CPU) "
              f"{c_serial / max(per):.2f}x; wall-clock speed-up here {t_serial / wall:.2f}x")
    print(f"  results identical to the serial run: {same}")
    malloc_trim_effect(Lp)


def _one_path(Lp: float) -> None:
    """Child process: CPU time of one path of ``Lp`` m after a warm-up (printed)."""
    path = [{"name": "p", "start": [0.0, -8.0], "end": [Lp, -8.0], "spacing": 0.05}]
    run_traverse(config(Lp, [{**path[0], "end": [1.0, -8.0]}]))
    c0 = time.process_time()
    run_traverse(config(Lp, path, chunk=2001))
    print(time.process_time() - c0)


def malloc_trim_effect(Lp: float) -> None:
    """Why the local clusters unset Dask's MALLOC_TRIM_THRESHOLD_=65536: one path's CPU
    time in a fresh process with and without it."""
    import os
    import subprocess
    import sys

    def cpu(extra: dict) -> float:
        env = {k: v for k, v in os.environ.items() if k != "MALLOC_TRIM_THRESHOLD_"}
        out = subprocess.run([sys.executable, __file__, "--one-path", str(Lp)],
                             env=env | extra, capture_output=True, text=True, check=True)
        return float(out.stdout.split()[-1])

    plain, trim = cpu({}), cpu({"MALLOC_TRIM_THRESHOLD_": "65536"})
    print(f"one {Lp:g} m path, CPU: {plain:.2f} s; with Dask's default worker setting "
          f"MALLOC_TRIM_THRESHOLD_=65536 {trim:.2f} s ({trim / plain:.2f}x; the local "
          "clusters unset it)")


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--one-path":
        _one_path(float(sys.argv[2]))
        raise SystemExit(0)
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="100 m path, 8 x 20 m paths")
    ap.add_argument("--no-dask", action="store_true", help="skip the Dask part")
    a = ap.parse_args()
    main(a.quick, not a.no_dask)
