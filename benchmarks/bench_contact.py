"""Speed of the closed-form peak force against impact_1dof integration.

Run: python benchmarks/bench_contact.py
Prints peak forces per second for 1e6 (T_c^-, v_n) pairs (Hertz and Hunt–Crossley closed
forms, one core) and the speed-up of the closed form over the numerical integration.
"""

from __future__ import annotations

import time

import numpy as np
from machine import reference

from roverimpact.contact import get_law, impact_1dof, peak_force, predict


def best_of(fn, repeat=5):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(N: int = 1_000_000) -> None:
    print(reference())  # how fast this machine is right now (machine.py)
    rng = np.random.default_rng(0)
    T = rng.uniform(0.01, 100.0, N)
    v = rng.uniform(0.05, 2.0, N)
    laws = {"hertz": get_law("hertz", k=1e6), "hunt-crossley": get_law("hunt-crossley",
                                                                         k=1e6, e=0.8)}
    print(f"closed-form peak_force over N = {N:,} (T_c^-, v_n) pairs")
    for name, law in laws.items():
        peak_force(T[:10], v[:10], law)  # warm the per-law cache
        t = best_of(lambda law=law: peak_force(T, v, law))
        print(f"  {name:14s} {t * 1e3:8.1f} ms  -> {N / t:,.0f} predictions/s")
    law = laws["hunt-crossley"]
    n_int = 50
    m = 2 * T[:n_int] / v[:n_int] ** 2
    t0 = time.perf_counter()
    for i in range(n_int):
        impact_1dof(law, m[i], v[i])
    t_int = (time.perf_counter() - t0) / n_int
    t_cf = best_of(lambda: peak_force(T, v, law)) / N
    t0 = time.perf_counter()
    for i in range(n_int):
        predict(law, m[i], v[i])
    t_pred = (time.perf_counter() - t0) / n_int
    print(f"impact_1dof (hunt-crossley): {t_int * 1e3:.2f} ms per impact")
    print(f"speed-up of batched closed-form peak_force over impact_1dof: {t_int / t_cf:,.0f}x")
    print(f"scalar predict() call (all quantities): {t_pred * 1e6:.1f} us "
          f"-> {t_int / t_pred:,.0f}x faster than impact_1dof")


if __name__ == "__main__":
    main()
