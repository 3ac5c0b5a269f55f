"""Speed of the model layer: T_c^- of one built scenario end to end, and the beta sweep.

End to end = Pinocchio kinematics at q -> M (CRBA) and the active rows of A (frame
Jacobians) -> T_c^- (roverimpact.partition). The scenario is built once beforehand.
Run: python benchmarks/bench_models.py
"""

from __future__ import annotations

import time

import numpy as np

from roverimpact import partition
from roverimpact.scenario import Scenario, sweep_energy


def per_call(fn, n):
    fn()
    best = np.inf
    for _ in range(5):
        t0 = time.perf_counter()
        for _ in range(n):
            fn()
        best = min(best, (time.perf_counter() - t0) / n)
    return best


def main():
    cases = {
        "rover2d (rocker)": {"model": {"name": "rover2d", "params": {"suspension": "rocker"}},
                             "velocity": {"u": 0.5},
                             "obstacle": {"wheel": "front", "beta_deg": 45.0}},
        "rocker_bogie (17 rows, nv=16)": {"model": {"name": "rocker_bogie"},
                                          "velocity": {"u": 0.2},
                                          "obstacle": {"wheel": "left_front", "beta_deg": 30.0}},
    }
    for name, d in cases.items():
        setup = Scenario.model_validate(d).build()
        q, v = setup.q, setup.v

        def end_to_end(setup=setup, q=q, v=v):
            M, A = setup.evaluate(q)
            return partition(M, A, v, want_velocities=False).T_c

        def kin_only(setup=setup, q=q):
            return setup.evaluate(q)

        t_e2e = per_call(end_to_end, 2000)
        t_kin = per_call(kin_only, 2000)
        print(f"{name:32s} end to end {1e6 * t_e2e:7.1f} us  (kinematics + M + A "
              f"{1e6 * t_kin:6.1f} us, partition {1e6 * (t_e2e - t_kin):6.1f} us)")
        if "rocker" in name and "bogie" in name:
            print(f"{'':32s} issue #5 target for the 3-D rover: <= 50 us end to end -> "
                  f"{'met' if t_e2e <= 50e-6 else 'NOT met'}")
        for k in (91, 1000):
            beta = np.linspace(0, np.pi / 2, k)
            t_sw = per_call(lambda beta=beta, setup=setup: sweep_energy(setup, beta), 20)
            print(f"{'':32s} sweep over {k:5d} beta: {1e3 * t_sw:7.2f} ms total, "
                  f"{1e6 * t_sw / k:6.2f} us per beta ({t_e2e * k / t_sw:5.1f}x faster than "
                  "end to end per beta)")


if __name__ == "__main__":
    main()
