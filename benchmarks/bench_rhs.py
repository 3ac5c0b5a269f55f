"""Cost of one right-hand side of the own simulator, and of a whole impact run.

The integrator (LSODA) calls the right-hand side ``(dq, v, impulses) -> rates`` a few
thousand times per impact; its cost is what a simulated study pays per case. Cases: the
tutorial's Sawppy-like URDF rover (two turnbuckle point loops, four locked steering
joints), the MJCF rover of docs/tutorial-own-rover.md, the built-in 3-D rocker-bogie and
the 2-D rover with a sprung rocker. For each: the time of one evaluation of the right-hand
side on states of the contact phase (best of ``--repeat``), and one impact run
(``simulate_impact`` from a settled state) with its number of evaluations.

``--against SRC`` runs the same cases with the package in ``SRC`` (e.g. an export of an
older commit: ``git archive OLD src | tar -x -C /tmp/old``, then ``--against /tmp/old/src``)
and with this one, in turns (``--rounds``, one fresh process each), and prints the best
of each and their ratio, with the peak force and the number of evaluations of both.

    python benchmarks/bench_rhs.py [--repeat 3] [--only NAME]
    python benchmarks/bench_rhs.py --against /tmp/old/src [--rounds 3]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
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
    return {"nq": nq, "nv": nv, "loops": s.loop_closure is not None,
            "F_max": r.F_max_total, "nfev": r.stats["nfev"], "rhs": best, "run": t_run}


def show(name, f):
    print(f"{name}: nq = {f['nq']}, nv = {f['nv']}, loops/locks = {f['loops']}, "
          f"F_max = {f['F_max']!r} N, nfev = {f['nfev']}")
    print(f"  one right-hand side   {1e3 * f['rhs']:8.3f} ms")
    print(f"  impact run            {1e3 * f['run']:8.1f} ms   "
          f"({1e3 * f['run'] / f['nfev']:.3f} ms per evaluation, all included)")


def in_turns(against, rounds, extra):
    """Best figures of this package and of the one in ``against``, one process per round."""
    here = str(Path(__import__("roverimpact").__file__).resolve().parents[1])
    best = {}
    for _ in range(rounds):
        for which, src in (("old", against), ("new", here)):
            env = dict(os.environ, PYTHONPATH=src)
            out = subprocess.run([sys.executable, __file__, "--json", *extra], env=env,
                                 capture_output=True, text=True, check=True).stdout
            for name, f in json.loads(out.splitlines()[-1]).items():
                b = best.setdefault(name, {}).setdefault(which, f)
                for key in ("rhs", "run"):
                    b[key] = min(b[key], f[key])
    print(f"old: {against}\nnew: {here}\nbest of {rounds} rounds in turns")
    print(f"{'case':22s} {'RHS old':>9s} {'RHS new':>9s} {'ratio':>6s} {'run old':>9s} "
          f"{'run new':>9s} {'ratio':>6s}  same F_max, nfev")
    for name, b in best.items():
        o, n = b["old"], b["new"]
        same = o["F_max"] == n["F_max"] and o["nfev"] == n["nfev"]
        print(f"{name:22s} {1e3 * o['rhs']:7.3f}ms {1e3 * n['rhs']:7.3f}ms "
              f"{o['rhs'] / n['rhs']:5.2f}x {1e3 * o['run']:7.1f}ms {1e3 * n['run']:7.1f}ms "
              f"{o['run'] / n['run']:5.2f}x  {same} ({n['F_max']:.10g} N, {n['nfev']})")


def main():
    if "--json" not in sys.argv:
        print(reference())
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", default=None)
    ap.add_argument("--against", default=None, help="src folder of another version")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--json", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.against:
        extra = ["--repeat", str(a.repeat)] + (["--only", a.only] if a.only else [])
        in_turns(a.against, a.rounds, extra)
        return
    base = dict(speed=0.3, obstacle={"k": 1e7, "e": 0.5}, t_after=0.1)
    cases = {
        "sawppy-like URDF": lambda: scenario_case("sawppy_like_beta.toml"),
        "MJCF rover": lambda: scenario_case("mjcf_rover_beta.toml"),
        "3-D rocker-bogie": lambda: (rocker_bogie(), SimulationConfig(**base), None),
        "2-D rover (rocker)": lambda: (
            rover2d(suspension="rocker"),
            SimulationConfig(**base, springs={"rocker": {"k": 50.0, "c": 2.0}}), None),
    }
    out = {}
    for name, make in cases.items():
        if a.only and a.only not in name:
            continue
        out[name] = case(name, *make(), a.repeat)
        if not a.json:
            show(name, out[name])
    if a.json:
        print(json.dumps(out))


if __name__ == "__main__":
    main()
