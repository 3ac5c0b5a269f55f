"""Cost of the frictional active set against the frictionless one (issue 18: at most 3x).

1. Random rover-sized problems, batched (10 000 items): ``unilateral_impact`` and
   ``active_set`` (frictionless) against ``frictional_impact`` with ``mu = 0.5`` on the
   same normal and bilateral rows plus the tangent rows of each contact. 3-D: n = 16,
   6 contacts (5 wheels with two tangent rows, the obstacle with none), 1 bilateral row,
   ``facets`` = 8 and 4; planar: n = 6, 2 contacts (one with a tangent row). Velocities
   are random (every contact approaches or separates), or "rolling": the ground contacts
   at rest with zero slip and the obstacle approaching, as in a rover impact.
2. The rocker-bogie scenario (``examples/rocker_bogie_beta30.toml``) over 1000 obstacle
   angles: ``holding_rows`` (frictionless LCP, no-slip rows follow their wheel) and
   ``holding_rows`` with ``friction="frictionless"`` and ``"coulomb"``.

Prints microseconds per item, the ratio frictional / frictionless, and how many items
needed the perturbed pivoting (``fallback``).

Run: ``python benchmarks/bench_friction.py``
"""
# ruff: noqa: B023

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from machine import reference

import roverimpact as ri
from roverimpact.energy import RTOL
from roverimpact.frictional import _solve, frictional_impact
from roverimpact.scenario.build import holding_rows
from roverimpact.scenario.sweep import _obstacle_basis
from roverimpact.unilateral import TOL

ROOT = Path(__file__).resolve().parents[1]


def _spd(rng, n):
    X = rng.standard_normal((n, n))
    D = np.diag(10.0 ** rng.uniform(-0.5, 0.5, n))
    return D @ (X @ X.T + n * np.eye(n)) @ D


def best(f, repeat=3):
    ts = []
    for _ in range(repeat):
        t = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t)
    return min(ts)


def _problem(rng, nb, n, k, t, pb, rolling):
    M = np.stack([_spd(rng, n) for _ in range(nb)])
    N = rng.standard_normal((nb, k, n))
    T = rng.standard_normal((nb, k, t, n))
    T[:, -1] = 0.0  # the obstacle contact: no tangent rows (frictionless)
    B = rng.standard_normal((nb, pb, n))
    v = rng.standard_normal((nb, n))
    if rolling:
        # ground contacts at rest (N v = 0, T v = 0), the obstacle approaching at 1
        C = np.concatenate([N[:, :-1], T[:, :-1].reshape(nb, -1, n), N[:, -1:], B], axis=1)
        rhs = np.zeros((nb, C.shape[1]))
        rhs[:, (k - 1) * (1 + t)] = -1.0
        v = np.einsum("bij,bj->bi", np.linalg.pinv(C), rhs)
    else:
        v -= np.einsum("bij,bj->bi", np.linalg.pinv(B), np.einsum("bij,bj->bi", B, v))
    return M, N, T, B, v


def _methods(M, v, N, T, B, facets):
    """How the items were solved: frictionless solve / mode iteration / Lemke / Lemke
    with the perturbation."""
    out = _solve(M, v, N, T, 0.5, 0.0, B, facets, TOL, RTOL, False)[0]
    c = np.bincount(out["meth"].astype(np.int64) + 1, minlength=5)
    return f"{c[1]}/{c[2]}/{c[3]}/{c[4]}"


def random_problems():
    rng = np.random.default_rng(0)
    nb = 10_000
    print("1. random problems, batched (10 000 items), mu = 0.5, e = 0; us per item")
    print(f"{'case':<28} {'unilateral':>10} {'active_set':>10} {'frictional':>10} "
          f"{'ratio':>6}  solved by: none/modes/Lemke/perturbed")
    cases = [("3-D n=16 k=6 facets=8", 16, 6, 2, 1, 8),
             ("3-D n=16 k=6 facets=4", 16, 6, 2, 1, 4),
             ("planar n=6 k=2", 6, 2, 1, 0, 8)]
    for rolling in (False, True):
        for name, n, k, t, pb, facets in cases:
            M, N, T, B, v = _problem(rng, nb, n, k, t, pb, rolling)
            Bx = B if pb else None
            ri.unilateral_impact(M[:2], v[:2], N[:2], bilateral=None if Bx is None else B[:2])
            frictional_impact(M[:2], v[:2], N[:2], T[:2], 0.5,
                              bilateral=None if Bx is None else B[:2], facets=facets)
            t_u = best(lambda: ri.unilateral_impact(M, v, N, bilateral=Bx)) / nb * 1e6
            t_a = best(lambda: ri.active_set(M, v, N, Bx)) / nb * 1e6
            t_f = best(lambda: frictional_impact(M, v, N, T, 0.5, bilateral=Bx,
                                                 facets=facets)) / nb * 1e6
            fb = _methods(M, v, N, T, Bx, facets)
            label = f"{name}{' rolling' if rolling else ''}"
            print(f"{label:<28} {t_u:10.2f} {t_a:10.2f} {t_f:10.2f} {t_f / t_u:6.2f}  {fb}")
    print("ratio = frictional_impact / unilateral_impact (both return v+, impulses, T_c^-)")


def rover_sweep():
    from roverimpact.scenario import normal_from_beta

    sc = ri.load_scenario(ROOT / "examples" / "rocker_bogie_beta30.toml")
    s = ri.ImpactSetup.from_scenario(sc.model_copy(update={"constraints": "auto"}))
    beta = np.radians(np.linspace(0.5, 89.5, 1000))
    Nb = normal_from_beta(beta, s._heading)
    J, wheel, oMf = _obstacle_basis(s)
    a = oMf.rotation @ np.asarray(wheel.axis, float)
    d = Nb - (Nb @ a)[:, None] * a
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    rows = Nb @ J[:3] + np.cross(-wheel.radius * d, Nb) @ J[3:]
    A_all = s._cs.evaluate(s.q)[1]
    obs = len(s.candidate_labels) - 1
    A = np.broadcast_to(A_all, (len(beta), *A_all.shape)).copy()
    A[:, obs, :] = rows
    labels = s.candidate_labels
    nb = len(beta)
    print(f"\n2. rocker-bogie scenario, {nb} obstacle angles batched; us per angle")
    holding_rows(labels, s.M, A[:2], s.v, obstacle_row=obs, friction="no-slip")
    t_ns = best(lambda: holding_rows(labels, s.M, A, s.v, obstacle_row=obs,
                                     friction="no-slip")) / nb * 1e6
    t_fl = best(lambda: holding_rows(labels, s.M, A, s.v, obstacle_row=obs,
                                     friction="frictionless")) / nb * 1e6
    print(f"{'holding_rows no-slip':<40} {t_ns:8.2f}")
    print(f"{'holding_rows frictionless':<40} {t_fl:8.2f}")
    for mu, facets in [(0.5, 8), (0.5, 4), (1.0, 8), (np.inf, 8)]:
        holding_rows(labels, s.M, A[:2], s.v, obstacle_row=obs, friction="coulomb", mu=mu,
                     facets=facets)
        t_c = best(lambda: holding_rows(labels, s.M, A, s.v, obstacle_row=obs,
                                        friction="coulomb", mu=mu,
                                        facets=facets)) / nb * 1e6
        print(f"{f'coulomb mu={mu:g} facets={facets}':<40} {t_c:8.2f}   ratio to no-slip "
              f"{t_c / t_ns:5.2f}")


def main():
    print(reference())  # how fast this machine is right now (machine.py)
    random_problems()
    rover_sweep()


if __name__ == "__main__":
    main()
