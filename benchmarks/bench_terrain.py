"""Speed of the terrain layer: height-field queries, wheel contacts, synthetic terrain.

Run: python benchmarks/bench_terrain.py [--quick]
Prints, on one core:
* synthetic_mars generation time for a 1 km x 20 m strip at 5 cm (8 million nodes),
  k = 0.05 and 0.2;
* HeightField height / gradient / Hessian queries per second (random points over the
  strip, and points along a path, the traverse's access pattern), with
  scipy's RectBivariateSpline.ev on a 100 m section as the baseline;
* wheel_ground_contact and first_rim_contact per second for 6 wheels at 20 000 poses
  along a 1 km path (5 cm steps), and the total against the 60 s budget of a traverse.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from machine import reference
from scipy.interpolate import RectBivariateSpline

from roverimpact.models.terrain import first_rim_contact, wheel_ground_contact
from roverimpact.models.terrain_synth import synthetic_mars


def best_of(fn, repeat=3):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(quick: bool = False) -> None:
    print(reference())  # how fast this machine is right now (machine.py)
    L = 200.0 if quick else 1000.0
    r = 0.1
    print(f"synthetic_mars({L:g} m x 20 m, 5 cm spacing)")
    terrains = {}
    for k in (0.05, 0.2):
        t = best_of(lambda k=k: terrains.__setitem__(
            k, synthetic_mars((L, 20.0), 0.05, seed=1, rock_abundance=k)), repeat=1)
        T = terrains[k]
        print(f"  k = {k:4.2f}: {T.ny} x {T.nx} nodes, {len(T.rocks):6d} rocks, {t:5.2f} s")
    T = terrains[0.2]
    rng = np.random.default_rng(0)
    N = 1_000_000
    xr, yr = rng.uniform(0, L, N), rng.uniform(0, 20, N)
    xp, yp = np.sort(rng.uniform(0, L, N)), 10 + rng.uniform(-1, 1, N)
    print(f"HeightField queries (N = {N:,}, one core)")
    for name, (x, y) in (("random points", (xr, yr)), ("along a path", (xp, yp))):
        for label, fn in (("height", T.height), ("normal", T.normal), ("hessian", T.hessian)):
            t = best_of(lambda fn=fn, x=x, y=y: fn(x, y))
            print(f"  {name:14s} {label:8s} {N / t / 1e6:6.2f} M points/s")
    # baseline: scipy's bicubic spline on a 100 m section (fitting the whole strip is slow)
    sec = T.z[:, :2001]
    t_fit = best_of(lambda: RectBivariateSpline(T.y, T.x[:2001], sec), repeat=1)
    spl = RectBivariateSpline(T.y, T.x[:2001], sec)
    xs, ys = np.sort(rng.uniform(0, 100, N)), 10 + rng.uniform(-1, 1, N)
    t_s = best_of(lambda: spl.ev(ys, xs))
    t_o = best_of(lambda: T.height(xs, ys))
    t_sg = best_of(lambda: (spl.ev(ys, xs, dx=1), spl.ev(ys, xs, dy=1)))
    t_og = best_of(lambda: T.gradient(xs, ys))
    print(f"  baseline RectBivariateSpline on 100 m (fit {t_fit:.2f} s): height "
          f"{N / t_s / 1e6:.2f} M/s (ours {N / t_o / 1e6:.2f}, x{t_s / t_o:.2f}); "
          f"slopes {N / t_sg / 1e6:.2f} M/s (ours {N / t_og / 1e6:.2f}, x{t_sg / t_og:.2f})")
    # 6 wheels, 20 000 poses along the strip's centre line (5 cm steps)
    npose = int(L / 0.05)
    xs = np.linspace(1.0, L - 1.5, npose)
    dx = np.array([0.0, 0.5, 1.0, 0.0, 0.5, 1.0])
    dy = np.array([-0.5, -0.5, -0.5, 0.5, 0.5, 0.5])
    C = np.zeros((npose, 6, 3))
    C[..., 0] = xs[:, None] + dx
    C[..., 1] = 10.0 + dy
    C[..., 2] = T.height(C[..., 0], C[..., 1]) + r + 0.02
    n = C.shape[0] * 6
    print(f"wheel contacts: {npose:,} poses x 6 wheels = {n:,} queries, r = {r} m")
    wc = None

    def run_wgc():
        nonlocal wc
        wc = wheel_ground_contact(T, C, (0, 1, 0), r)

    t_w = best_of(run_wgc, repeat=2)
    print(f"  wheel_ground_contact   {n / t_w:10,.0f} /s  ({t_w:.2f} s)")
    Cs = C - wc.gap[..., None] * wc.normal  # wheels set down on the terrain
    Cs[..., 2] -= wheel_ground_contact(T, Cs, (0, 1, 0), r).gap
    rc = None
    t_frc = {}
    for label, step in (("default step r/32", None), ("step r/16", r / 16)):
        def run_frc(step=step):
            nonlocal rc
            rc = first_rim_contact(T, Cs, (0, 1, 0), r, (1, 0, 0), max_travel=r, step=step)

        t_f = t_frc[label] = best_of(run_frc, repeat=2)
        print(f"  first_rim_contact ({label}) {n / t_f:10,.0f} /s  ({t_f:.2f} s); contact "
              f"within {r} m for {100 * rc.found.mean():.1f} %, median beta "
              f"{np.degrees(np.nanmedian(rc.beta)):.1f} deg")
    scale = 1000.0 / L
    print(f"traverse estimate, 1 km at 5 cm with 6 wheels, both contacts per pose: "
          f"{scale * (t_w + t_frc['default step r/32']):.1f} s (budget 60 s)")


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="200 m strip instead of 1 km")
    main(ap.parse_args().quick)
