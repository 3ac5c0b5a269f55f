"""Cost of one right-hand side of the own simulator, and of a whole impact run.

The integrator (LSODA) calls the right-hand side ``(dq, v, impulses) -> rates`` a few
thousand times per impact; its cost is what a simulated study pays per case. Cases: the
tutorial's Sawppy-like URDF rover (two turnbuckle point loops, four locked steering
joints), the MJCF rover of docs/tutorial-own-rover.md, the built-in 3-D rocker-bogie and
the 2-D rover with a sprung rocker. For each: the time of one evaluation of the right-hand
side on states of the contact phase (best of ``--repeat``), and one impact run
(``simulate_impact`` from a settled state) with its number of evaluations.

    python benchmarks/bench_rhs.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

try:
    from machine import reference
except ImportError:  # run from elsewhere
    def reference():
        return ""

from roverimpact.models import rocker_bogie, rover2d
from roverimpact.scenario import load_scenario
from roverimpact.scenario.build import configuration, scenario_model
from roverimpact.simulate import SimulationConfig, build_system, initial_state, simulate_impact

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def scenario_case(file):
    sc = load_scenario(EXAMPLES / file)
    mbm = scenario_model(sc)
    return mbm, SimulationConfig.from_scenario(sc), configuration(mbm, sc.configuration)


def rhs_of(sys_, q_ref, v_i, io):
    """The simulator's right-hand side at anchor ``q_ref`` (as ``run._run_phase``)."""
    nv = sys_.nv
    lean = hasattr(sys_, "applied_force")   # (an older version: generalized_forces)

    def rhs(y):
        dq, vv = y[:nv], y[nv:2 * nv]
        q = sys_.config(q_ref, dq)
        if lean:
            cf = sys_.applied_force(q, vv, v_i)
            tau, f_n = cf.tau, cf.f_n
        else:
            cs, tau = sys_.generalized_forces(q, vv, v_i)
            f_n = cs.f_n
        a = sys_.acceleration(q, vv, tau)
        return np.concatenate([sys_.chart_rate(q_ref, dq, vv), a, f_n[io]])

    return rhs


def case(name, mbm, cfg, q0, repeat):
    q0, v0 = initial_state(mbm, cfg, q0=q0)
    t = time.perf_counter()
    r = simulate_impact(mbm, cfg, q0=q0, v0=v0)
    t_run = time.perf_counter() - t
    for _ in range(repeat - 1):
        t = time.perf_counter()
        simulate_impact(mbm, cfg, q0=q0, v0=v0)
        t_run = min(t_run, time.perf_counter() - t)
    # states of the contact phase from the history, evaluated around q_minus
    s = build_system(mbm, cfg, q_ref=q0)
    io = len(s.planes) - 1
    h = r.history
    nq, nv = s.nq, s.nv
    during = h[h["t"] >= 0.0]
    rows = during.iloc[np.linspace(0, len(during) - 1, 8).astype(int)]
    Q = rows[[f"q_{j}" for j in range(nq)]].to_numpy()
    V = rows[[f"v_{j}" for j in range(nv)]].to_numpy()
    # the obstacle where the run put it: the contact wheel's gap at q_minus is 0
    w = [x.name for x in mbm.wheels].index(r.contact_wheel)
    c = s.wheel_centres(r.q_minus)[w] - s.radii[w] * s.planes[-1].n
    s.planes[-1].p0 = c
    s.planes[-1].v_i = r.v_n
    s._set_planes()
    v_i = [p.v_i for p in s.planes]
    ys = [np.concatenate([np.zeros(nv), vk, np.zeros(len(s.fids))]) for vk in V]
    n_call = 200
    best = np.inf
    for _ in range(repeat):
        for qk, yk in zip(Q, ys, strict=True):
            f = rhs_of(s, qk, v_i, io)
            f(yk)
            t = time.perf_counter()
            for _ in range(n_call):
                f(yk)
            best = min(best, (time.perf_counter() - t) / n_call)
    print(f"{name}: nq = {nq}, nv = {nv}, loops/locks = {s.loop_closure is not None}, "
          f"F_max = {r.F_max_total!r} N, nfev = {r.stats['nfev']}")
    print(f"  one right-hand side   {1e3 * best:8.3f} ms")
    print(f"  impact run            {1e3 * t_run:8.1f} ms   ({1e3 * t_run / r.stats['nfev']:.3f} "
          "ms per evaluation, all included)")
    return best, t_run


def main():
    print(reference())
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", default=None)
    a = ap.parse_args()
    base = dict(speed=0.3, obstacle={"k": 1e7, "e": 0.5}, t_after=0.1)
    cases = {
        "sawppy-like URDF": lambda: scenario_case("sawppy_like_beta.toml"),
        "MJCF rover": lambda: scenario_case("mjcf_rover_beta.toml"),
        "3-D rocker-bogie": lambda: (rocker_bogie(), SimulationConfig(**base), None),
        "2-D rover (rocker)": lambda: (
            rover2d(suspension="rocker"),
            SimulationConfig(**base, springs={"rocker": {"k": 50.0, "c": 2.0}}), None),
    }
    for name, make in cases.items():
        if a.only and a.only not in name:
            continue
        case(name, *make(), a.repeat)
    sys.stdout.flush()


if __name__ == "__main__":
    main()
