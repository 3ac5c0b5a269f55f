"""Speed of the pose on terrain: rocker-bogie and rover2d placed on synthetic Mars terrain.

Run: python benchmarks/bench_pose.py [--quick]
     python benchmarks/bench_pose.py --function   # a terrain given as a Python function
Prints, on one core, for random placements (x, y, yaw) on a 20 m x 20 m terrain at 5 cm
(synthetic_mars, seed 1, rock abundance 0.05, rocks 0.1 to 0.5 m):
* time per pose of one call per pose, and of one batched call for all placements
  (target: 5 ms a pose for the rocker-bogie);
* Gauss-Newton steps per pose and the outcome (status counts), also on a rockier
  terrain (rock abundance 0.2);
* the floor of one step: one wheel_ground_contact call for the rover's wheels;
* baseline: scipy.optimize.least_squares on the same residual with a finite-difference
  Jacobian (what the analytic Jacobian saves), and its agreement with our poses.

``--function``: the rocker-bogie posed on ``examples/terrain/bumps.py`` (a
``FunctionTerrain``: a numpy function h(x, y), its derivatives by central differences),
one call per pose at 100 placements along x: time per pose and calls of the function per
pose (the derivatives' points stacked into one call since 2026-11-29: 13 calls became 1);
then one case of ``examples/rocker_bogie_on_bumps.toml`` through ``evaluate_case`` (its
pose, the driving velocity from two more poses, solved together since 2026-11-29, the
rows), time per case.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from machine import reference
from scipy.optimize import least_squares

from roverimpact.models import rocker_bogie, rover2d
from roverimpact.models.pose import PoseProblem, place, pose_on_terrain
from roverimpact.models.terrain import wheel_ground_contact
from roverimpact.models.terrain_synth import synthetic_mars


def best_of(fn, repeat=3):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def placements(mbm, n, rng):
    if mbm.params["planar"]:
        return np.array([place(mbm, x) for x in rng.uniform(-8.0, 8.0, n)])
    return np.array([place(mbm, *rng.uniform(-8.0, 8.0, 2), yaw=rng.uniform(-np.pi, np.pi))
                     for _ in range(n)])


def bench(name, mbm, terrain, n_single, n_batch):
    rng = np.random.default_rng(0)
    Q1 = placements(mbm, n_single, rng)
    QB = placements(mbm, n_batch, rng)
    pose_on_terrain(mbm, terrain, Q1[0], check=False)          # warm up
    t1 = best_of(lambda: [pose_on_terrain(mbm, terrain, q, check=False) for q in Q1])
    tb = best_of(lambda: pose_on_terrain(mbm, terrain, QB, check=False), repeat=2)
    res = pose_on_terrain(mbm, terrain, QB, check=False)
    status, counts = np.unique(res.status, return_counts=True)
    ok = res.ok
    steps = res.iterations[ok]
    print(f"{name} ({len(mbm.wheels)} wheels, {len(res.solved)} unknowns)")
    print(f"  one call per pose   : {1e3 * t1 / n_single:6.2f} ms a pose ({n_single} poses)")
    print(f"  one batched call    : {1e3 * tb / n_batch:6.2f} ms a pose ({n_batch} poses)")
    print(f"  steps per pose      : mean {steps.mean():.2f}, max {steps.max()}; status "
          + ", ".join(f"{s} {c}" for s, c in zip(status, counts, strict=True)))
    print(f"  largest |gap| of chosen wheels {np.abs(res.gap[ok]).max():.1e} m, loop "
          f"residual {np.abs(res.loop_residual[ok]).max(initial=0.0):.1e}")
    # floor of one step: the contact query of the wheels alone
    prob = PoseProblem(mbm, terrain)
    data = mbm.model.createData()
    import pinocchio as pin

    pin.framesForwardKinematics(mbm.model, data, res.q[0])
    C = np.array([data.oMf[f].translation for f in prob.fids])
    A = np.array([data.oMf[f].rotation @ a for f, a in zip(prob.fids, prob.axes, strict=True)])
    tc = best_of(lambda: [wheel_ground_contact(terrain, C, A, prob.radii) for _ in range(200)])
    print(f"  one wheel_ground_contact call for the {len(C)} wheels: {1e3 * tc / 200:.2f} ms")
    # baseline: scipy least squares, finite-difference Jacobian, from the same guesses
    n_ls = min(20, n_single)
    sols = []

    def run_ls():
        sols.clear()
        for q in Q1[:n_ls]:
            sol = least_squares(lambda x, q=q: prob.evaluate(prob.step(q, x),
                                                             jacobian=False)[0],
                                np.zeros(prob.nx), jac="2-point", xtol=1e-15, ftol=1e-15,
                                gtol=1e-15)
            sols.append(prob.step(q, sol.x))
    tl = best_of(run_ls, repeat=1)
    ours = pose_on_terrain(mbm, terrain, Q1[:n_ls], check=False)
    both = ours.ok
    dq = np.max(np.abs(np.array(sols)[both] - ours.q[both])) if both.any() else np.nan
    print(f"  baseline scipy least_squares (FD Jacobian): {1e3 * tl / n_ls:6.2f} ms a pose, "
          f"{(tl / n_ls) / (t1 / n_single):.1f}x our one-call time; "
          f"largest |q difference| {dq:.1e} (square problems agree)")
    return 1e3 * t1 / n_single, 1e3 * tb / n_batch


def main(quick: bool = False) -> None:
    print(reference())  # how fast this machine is right now (machine.py)
    t0 = time.perf_counter()
    terrain = synthetic_mars((20.0, 20.0), 0.05, seed=1, rock_abundance=0.05, d_max=0.5,
                             origin=(-10.0, -10.0))
    print(f"terrain: {terrain} ({len(terrain.rocks)} rocks), built in "
          f"{time.perf_counter() - t0:.2f} s")
    n1, nb = (30, 200) if quick else (100, 1000)
    rb1, rbb = bench("rocker_bogie (prototype)", rocker_bogie(), terrain, n1, nb)
    bench("rocker_bogie (mer)", rocker_bogie("mer"), terrain, n1 // 2, nb // 2)
    bench("rover2d (rocker)", rover2d(suspension="rocker"), terrain, n1, nb)
    bench("rover2d (prismatic, middle wheel)", rover2d(suspension="prismatic",
                                                        middle_wheel=True), terrain, n1, nb)
    rocky = synthetic_mars((20.0, 20.0), 0.05, seed=2, rock_abundance=0.2, d_max=0.5,
                           origin=(-10.0, -10.0))
    print(f"rocky terrain: k = 0.2, {len(rocky.rocks)} rocks")
    bench("rocker_bogie (prototype), rocky", rocker_bogie(), rocky, n1 // 3, nb)
    print(f"rocker-bogie, target 5 ms a pose: one call {rb1:.2f} ms "
          f"({'met' if rb1 < 5 else 'NOT met'}), batched {rbb:.2f} ms "
          f"({'met' if rbb < 5 else 'NOT met'})")


def function_terrain() -> None:
    import importlib.util
    from pathlib import Path

    from roverimpact.models.terrain import FunctionTerrain

    print(reference())
    path = Path(__file__).resolve().parents[1] / "examples" / "terrain" / "bumps.py"
    spec = importlib.util.spec_from_file_location("bumps", path)
    bumps = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bumps)
    calls = [0]

    def h(x, y):
        calls[0] += 1
        return bumps.h(x, y)

    terrain = FunctionTerrain(h)
    mbm = rocker_bogie()
    guesses = [place(mbm, x=float(x)) for x in np.linspace(0.0, 4.0, 100)]
    pose_on_terrain(mbm, terrain, guesses[0])  # warm: compiled kernels
    calls[0] = 0
    t = best_of(lambda: [pose_on_terrain(mbm, terrain, g) for g in guesses], repeat=3)
    print(f"rocker_bogie (prototype) on examples/terrain/bumps.py (FunctionTerrain), "
          f"{len(guesses)} poses along x, one call each: {1e3 * t / len(guesses):.2f} ms a "
          f"pose, {calls[0] / (3 * len(guesses)):.0f} calls of the function a pose")
    # a whole case on that terrain: the pose, the driving velocity (the pose moved back and
    # forth along the slope and placed again) and the rows
    from roverimpact._io import read_toml
    from roverimpact.studies import evaluate_case

    scenario = path.parents[1] / "rocker_bogie_on_bumps.toml"
    base = {**read_toml(scenario), "terrain": {"function": f"{path}:h"}}
    evaluate_case(base)
    t = best_of(lambda: [evaluate_case(base) for _ in range(10)], repeat=5)
    print(f"evaluate_case of {scenario.name} (pose, driving velocity, rows): "
          f"{1e3 * t / 10:.2f} ms a case")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--function", action="store_true")
    args = ap.parse_args()
    if args.function:
        function_terrain()
    else:
        main(args.quick)
