"""Wall time of one impact per engine: the own simulator vs MuJoCo, same scenario.

One 2-D rover (rocker) impact and one 3-D rocker-bogie impact, 0.3 m/s into a wall
(beta = 90 deg) 1 mm ahead, Earth gravity, from a settled state (settling done once,
as a sweep would). Two contact laws: the default Hunt-Crossley (k = 1e7, e = 0.5; MuJoCo
through the equivalent Kelvin-Voigt, an approximation) and Kelvin-Voigt (k = 1e6 N/m,
c = 2000 N s/m, exact in both engines). Best of ``--repeat`` runs each; the ratio is
own / MuJoCo time, and F_max(MuJoCo) / F_max(own) - 1.

Second part, what ``roverimpact simulate --engine NAME`` costs per impact: the whole
``simulate_scenario`` of examples/simulate_rover2d.toml with Kelvin-Voigt contacts (build
the model, settle it, export it to MJCF and compile it for MuJoCo, run the impact), in
the process (best of ``--repeat``), and the wall time of the command itself (one run
each, Python start-up and imports included, ``--no-plot``).

    python benchmarks/bench_engines.py [--repeat 5] [--no-cli]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from machine import reference

from roverimpact.models import rocker_bogie, rover2d
from roverimpact.simulate import SimulationConfig, initial_state, simulate_impact
from roverimpact.simulate.engines import simulate_impact_mujoco, simulate_impact_mujoco_laws

KV = {"name": "kelvin-voigt", "k": 1e6, "c": 2000.0, "e": None, "n": None}
HC = {"name": "hunt-crossley", "k": 1e7, "e": 0.5}


def best_of(fn, repeat):
    best, out = np.inf, None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def case(name, mbm, law, repeat):
    ground = KV if law is KV else {"name": "hunt-crossley", "k": 1e7, "e": 0.2}
    cfg = SimulationConfig(speed=0.3, beta_deg=90.0, obstacle=law, ground_contact=ground,
                           t_after=0.1)
    q0, v0 = initial_state(mbm, cfg)
    simulate_impact_mujoco(mbm, cfg, q0=q0, v0=v0)          # warm-up (imports, caches)
    simulate_impact(mbm, cfg, q0=q0, v0=v0)
    t_own, r_own = best_of(lambda: simulate_impact(mbm, cfg, q0=q0, v0=v0), repeat)
    t_mj, r_mj = best_of(lambda: simulate_impact_mujoco(mbm, cfg, q0=q0, v0=v0), repeat)
    lname = "kelvin-voigt" if law is KV else "hunt-crossley"
    print(f"{name}, {lname}: nv = {mbm.model.nv}")
    print(f"  own     {1e3 * t_own:8.2f} ms   F_max = {r_own.F_max_total:9.2f} N   "
          f"{r_own.stats['nfev']} force evaluations")
    print(f"  mujoco  {1e3 * t_mj:8.2f} ms   F_max = {r_mj.F_max_total:9.2f} N   "
          f"{r_mj.stats['steps']} steps of {1e6 * r_mj.stats['timestep']:.2f} us")
    print(f"  time own/mujoco = {t_own / t_mj:5.2f}x   "
          f"F_max mujoco/own - 1 = {r_mj.F_max_total / r_own.F_max_total - 1:+.2%}")
    t_ml, r_ml = best_of(lambda: simulate_impact_mujoco_laws(mbm, cfg, q0=q0, v0=v0), repeat)
    print(f"  mujoco_laws (the laws applied as forces) {1e3 * t_ml:8.2f} ms   "
          f"F_max = {r_ml.F_max_total:9.2f} N   {r_ml.stats['steps']} steps   "
          f"time mujoco_laws/mujoco = {t_ml / t_mj:5.2f}x")


_KV = {k: v for k, v in KV.items() if v is not None}
SCENARIO_KV = {
    "model": {"name": "rover2d", "params": {"suspension": "rocker", "h": 0.4}},
    "velocity": {"u": 0.3}, "obstacle": {"wheel": "front", "beta_deg": 60.0},
    "contact_law": _KV,
    "simulation": {"distance": 0.001, "t_after": 0.05, "ground_contact": _KV,
                   "springs": {"rocker": {"k": 50.0, "c": 2.0}}},
}


def scenario_per_impact(repeat):
    """``simulate_scenario`` (what the command runs) per engine, one 2-D rover impact."""
    from roverimpact.scenario import scenario_from_dict
    from roverimpact.simulate import simulate_scenario

    sc = scenario_from_dict(SCENARIO_KV)
    print("simulate_scenario, 2-D rover (rocker), Kelvin-Voigt, beta = 60 deg, 0.3 m/s "
          "(model, settling, MJCF export and compilation included):")
    times = {}
    for engine in ("own", "mujoco"):
        simulate_scenario(sc, engine=engine)                     # warm-up
        times[engine], r = best_of(lambda e=engine: simulate_scenario(sc, engine=e), repeat)
        print(f"  {engine:7s} {1e3 * times[engine]:8.2f} ms per impact   "
              f"F_max = {r.F_max_total:9.2f} N")
    print(f"  time own/mujoco = {times['own'] / times['mujoco']:5.2f}x")


def cli_per_impact():
    """Wall time of `roverimpact simulate FILE --engine NAME` (one run each)."""
    import subprocess
    import sys
    import tempfile
    from pathlib import Path

    import tomli_w

    with tempfile.TemporaryDirectory() as tmp:
        f = Path(tmp) / "kv.toml"
        f.write_text(tomli_w.dumps(SCENARIO_KV))
        print("roverimpact simulate FILE --engine NAME --no-plot (one run, Python start-up "
              "and imports included):")
        for engine in ("own", "mujoco"):
            t = time.perf_counter()
            subprocess.run([sys.executable, "-m", "roverimpact.cli", "simulate", str(f),
                            "-o", str(Path(tmp) / engine), "--engine", engine,
                            "--no-plot", "--json"], check=True, capture_output=True)
            print(f"  {engine:7s} {time.perf_counter() - t:6.2f} s")


def main():
    print(reference())  # how fast this machine is right now (machine.py)
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--no-cli", action="store_true", help="skip the command-line timing")
    a = ap.parse_args()
    for law in (HC, KV):
        case("2-D rover (rocker)", rover2d(suspension="rocker"), law, a.repeat)
        case("3-D rocker-bogie", rocker_bogie(), law, a.repeat)
    scenario_per_impact(a.repeat)
    if not a.no_cli:
        cli_per_impact()


if __name__ == "__main__":
    main()
