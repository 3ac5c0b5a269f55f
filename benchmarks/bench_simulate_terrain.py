"""Cost of the simulator on a terrain vs flat ground (3-D rocker-bogie, 6 wheels).

Grounds: the plane z = 0 of the flat-ground simulator (spheres, no terrain), a 10 deg
slope (``PlaneTerrain``, discs, closed form), the same slope sampled as a height field
(the same impact: the height-field contact's cost alone), a bumpy height field (20 m x 8 m at 5 cm,
smooth bumps, compiled contact kernel) and the same bumps as a Python ``FunctionTerrain``
(numpy ``wheel_ground_contact``, central-difference slopes). For each: the wheel-ground
contact of 6 wheels alone, one right-hand side of the equations of motion
(``generalized_forces`` + ``acceleration``), settling once (``initial_state``: pose,
static equilibrium, driving velocity) and one impact at 0.3 m/s into a 60 deg face 1 mm
ahead (Hunt-Crossley k = 1e7, e = 0.5; from the settled state). Best of ``--repeat``;
the ratio column is against the flat ground.

    python benchmarks/bench_simulate_terrain.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from machine import reference

from roverimpact.models import rocker_bogie
from roverimpact.models.terrain import FunctionTerrain, HeightField, PlaneTerrain
from roverimpact.simulate import SimulationConfig, build_system, initial_state, simulate_impact


def best_of(fn, repeat, n=1):
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        for _ in range(n):
            fn()
        best = min(best, (time.perf_counter() - t) / n)
    return best


def bumps(x, y):
    x, y = np.asarray(x, float), np.asarray(y, float)
    return (0.02 * np.sin(2.0 * x) * np.cos(3.0 * y)
            + 0.03 * np.exp(-((x - 0.3) ** 2 + (y - 0.1) ** 2) / 0.04))


def grounds():
    a = np.radians(10.0)
    x = np.arange(-10.0, 10.0 + 1e-9, 0.05)
    y = np.arange(-4.0, 4.0 + 1e-9, 0.05)
    hf = HeightField(bumps(x[None, :], y[:, None]), 0.05, (-10.0, -4.0))
    slope = np.tan(a) * x[None, :] + 0.0 * y[:, None]
    return {"flat (z = 0, no terrain)": None,
            "10 deg slope (PlaneTerrain)": PlaneTerrain((0, 0, 0), (-np.sin(a), 0, np.cos(a))),
            "10 deg slope as HeightField": HeightField(slope, 0.05, (-10.0, -4.0)),
            "bumps, HeightField 401 x 161": hf,
            "bumps, FunctionTerrain": FunctionTerrain(bumps)}


def main():
    print(reference())  # how fast this machine is right now (machine.py)
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=5)
    a = ap.parse_args()
    mbm = rocker_bogie()
    cfg = SimulationConfig(speed=0.3, beta_deg=60.0, obstacle={"k": 1e7, "e": 0.5},
                           t_after=0.1)
    rows = []
    initial_state(mbm, cfg)                  # warm-up (imports, compiled kernels)
    for name, terrain in grounds().items():
        q0, v0 = initial_state(mbm, cfg, terrain=terrain)
        t_settle = best_of(lambda t=terrain: initial_state(mbm, cfg, terrain=t),
                           max(1, a.repeat // 2))
        sys_ = build_system(mbm, cfg, terrain=terrain)
        if terrain is None:
            def ground(s=sys_, q=q0):
                s.gaps(q)
        else:
            import pinocchio as pin

            pin.framesForwardKinematics(sys_.model, sys_.data, q0)
            c, ax = sys_._centres_axes()

            def ground(s=sys_, c=c, ax=ax):
                s.terrain.contact(c, ax, s.radii)

        def rhs(s=sys_, q=q0, v=v0):
            _, tau = s.generalized_forces(q, v)
            s.acceleration(q, v, tau)

        t_ground = best_of(ground, a.repeat, 200)
        t_rhs = best_of(rhs, a.repeat, 200)
        r = simulate_impact(mbm, cfg, q0=q0, v0=v0, terrain=terrain)
        t_run = best_of(lambda t=terrain, q0=q0, v0=v0: simulate_impact(
            mbm, cfg, q0=q0, v0=v0, terrain=t), a.repeat)
        rows.append((name, t_ground, t_rhs, t_settle, t_run, r))
    base = rows[0]
    print(f"rocker-bogie (nv = {mbm.model.nv}), 6 wheels; best of {a.repeat}")
    print(f"{'ground':32s} {'contact':>10s} {'RHS':>10s} {'settle':>9s} {'impact':>9s} "
          f"{'ratio':>6s} {'nfev':>6s} {'per eval':>9s} {'F_max [N]':>10s}")
    for name, tg, tr, ts, tt, r in rows:
        print(f"{name:32s} {1e6 * tg:8.1f}us {1e6 * tr:8.1f}us {1e3 * ts:7.1f}ms "
              f"{1e3 * tt:7.1f}ms {tt / base[4]:6.2f} {r.stats['nfev']:6d} "
              f"{1e6 * tt / r.stats['nfev']:7.1f}us {r.F_max_total:10.2f}")
    print("(contact: the ground gaps of the flat simulator, or TerrainGround.contact; RHS: "
          "contacts + springs + loop-constrained acceleration; impact: whole run incl. "
          "history and peak refinement, per eval = impact / nfev)")


if __name__ == "__main__":
    main()
