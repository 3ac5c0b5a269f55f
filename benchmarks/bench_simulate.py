"""Wall time of one compliant impact (2-D rover, 3-D rocker-bogie) vs the T_c^- evaluation.

Each impact starts from a settled state (settling is done once, timed separately, as a
study sweeping beta or the speed would do) 1 mm before a vertical wall at 0.3 m/s, Earth
gravity, Hunt-Crossley k = 1e7 N/m^1.5, e = 0.5, default integrator (LSODA, rtol 1e-7).
T_c^- is timed two ways on the pre-impact state of the same run: with the Pinocchio
evaluation of M and the constraint rows (``effective_energy``), and the partition alone
(``roverimpact.partition`` on the precomputed M, A, v), one call and per item of a
batch of 10 000 (how a study evaluates T_c^-).

    python benchmarks/bench_simulate.py [--repeat 5]
    python benchmarks/bench_simulate.py --settle-once [--rounds 3]

``--settle-once``: the two built-in angle studies (DETC2014 Fig. 2, 2-D rover; DETC2015
Fig. 2, 3-D rocker-bogie; 17 angles, own engine and MuJoCo) through the study evaluator,
with its cases settling once per engine (``reuse_settled_states``, as shipped) and each
on its own (the context replaced by a no-op), in turns in one process: wall time and
whether the results are the same to the bit.
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import time
from pathlib import Path

import numpy as np
from machine import reference

import roverimpact as ri
from roverimpact.models import rocker_bogie, rover2d
from roverimpact.simulate import (
    SimulationConfig,
    build_system,
    effective_energy,
    initial_state,
    simulate_impact,
)


def best_of(fn, repeat):
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def case(name, mbm, cfg, repeat):
    t_settle = best_of(lambda: initial_state(mbm, cfg), 1)
    q0, v0 = initial_state(mbm, cfg)
    r = simulate_impact(mbm, cfg, q0=q0, v0=v0)
    t_sim = best_of(lambda: simulate_impact(mbm, cfg, q0=q0, v0=v0), repeat)
    sys = build_system(mbm, cfg)
    w = [x.name for x in mbm.wheels].index(r.contact_wheel)
    # place the face through the contact point (gap 0) so the rows match the run
    c = sys.wheel_centres(r.q_minus)[w] - sys.radii[w] * sys.planes[-1].n
    sys.planes[-1].p0 = c
    sys._set_planes()
    n_tc = 2000
    t_tc = best_of(lambda: [effective_energy(sys, mbm, r.q_minus, r.v_minus, w,
                                             cfg)
                            for _ in range(n_tc)], 3) / n_tc
    cs = sys.contacts(r.q_minus, r.v_minus)
    M = sys.mass_matrix(r.q_minus)
    A = np.array([sys.planes[-1].n @ cs.Jp[-1, w]]
                 + [sys.planes[0].n @ cs.Jp[0, k] for k in np.flatnonzero(cs.delta[0] > 0)])
    n_p = 20000
    t_p = best_of(lambda: [ri.partition(M, A, r.v_minus, want_velocities=False)
                           for _ in range(n_p)], 3) / n_p
    nb = 10000
    Mb, Ab, vb = (np.broadcast_to(x, (nb, *x.shape)).copy() for x in (M, A, r.v_minus))
    t_b = best_of(lambda: ri.partition(Mb, Ab, vb, want_velocities=False), 3) / nb
    print(f"{name}: nv = {mbm.model.nv}, F_max = {r.F_max_total:.5g} N, "
          f"{r.stats['steps']} steps, {r.stats['nfev']} force evaluations")
    print(f"  settle (once)            {1e3 * t_settle:8.2f} ms")
    print(f"  impact run               {1e3 * t_sim:8.2f} ms")
    print(f"  T_c^- with Pinocchio     {1e6 * t_tc:8.2f} us   ratio {t_sim / t_tc:9.0f}x")
    print(f"  T_c^- partition only     {1e6 * t_p:8.2f} us   ratio {t_sim / t_p:9.0f}x")
    print(f"  T_c^- batched (per item) {1e6 * t_b:8.2f} us   ratio {t_sim / t_b:9.0f}x")


def settle_once(rounds: int) -> None:
    """The built-in angle studies with their cases settling once and each on its own."""
    import roverimpact.simulate as simulate
    import roverimpact.studies.evaluate as evaluate
    from roverimpact._io import read_toml

    # the evaluator takes the context from roverimpact.simulate when its cases simulate
    shipped = simulate.reuse_settled_states
    studies = Path(ri.__file__).parent / "data" / "studies"
    for name in ("detc2014_fig2_beta", "detc2015_fig2_beta"):
        d = read_toml(studies / f"{name}.toml")
        g = d["grid"]["obstacle.beta_deg"]
        overrides = [{"obstacle.beta_deg": float(b)}
                     for b in np.linspace(g["start"], g["stop"], g["num"])]
        ev = evaluate.ScenarioEvaluator()
        ev.evaluate(d["base"], overrides[:2], simulate=d["simulate"])  # warm
        times: dict[bool, list[float]] = {True: [], False: []}
        out = {}
        try:
            for _ in range(rounds):
                for once in (False, True):
                    simulate.reuse_settled_states = shipped if once else contextlib.nullcontext
                    t = time.perf_counter()
                    out[once] = ev.evaluate(d["base"], overrides, simulate=d["simulate"])
                    times[once].append(time.perf_counter() - t)
        finally:
            simulate.reuse_settled_states = shipped
        same = all(np.array_equal(out[True][c], out[False][c], equal_nan=True)
                   for c in out[True] if np.asarray(out[True][c]).dtype.kind == "f")
        each, once = times[False], times[True]
        print(f"{name}: {len(overrides)} cases x {len(d['simulate'])} engines, best / median "
              f"of {rounds}: settling each case {min(each):.2f} / {statistics.median(each):.2f}"
              f" s, settling once {min(once):.2f} / {statistics.median(once):.2f} s "
              f"({min(each) / min(once):.2f}x); results the same to the bit: {same}")


def main():
    print(reference())  # how fast this machine is right now (machine.py)
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--settle-once", action="store_true",
                    help="the built-in angle studies settling once per engine and per case")
    ap.add_argument("--rounds", type=int, default=3)
    a = ap.parse_args()
    if a.settle_once:
        settle_once(a.rounds)
        return
    base = dict(speed=0.3, obstacle={"k": 1e7, "e": 0.5}, t_after=0.1)
    case("2-D rover (rocker)", rover2d(suspension="rocker"),
         SimulationConfig(**base, springs={"rocker": {"k": 50.0, "c": 2.0}}), a.repeat)
    case("3-D rocker-bogie", rocker_bogie(), SimulationConfig(**base), a.repeat)


if __name__ == "__main__":
    main()
