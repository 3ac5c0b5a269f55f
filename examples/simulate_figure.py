"""Compliant impact of the planar rover: force vs time with F_max and the T_c^- prediction.

Writes docs/img/simulate_rover2d.png (the figure of docs/simulate.md).

    python examples/simulate_figure.py [--out docs/img/simulate_rover2d.png]
"""

from __future__ import annotations

import argparse
from pathlib import Path

from roverimpact.simulate import build_system, simulate_impact
from roverimpact.simulate._files import load_simulation
from roverimpact.simulate.plots import plot_force_history

HERE = Path(__file__).resolve().parent


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(HERE.parent / "docs" / "img" / "simulate_rover2d.png"))
    a = ap.parse_args()
    model, cfg = load_simulation(HERE / "simulate_rover2d.toml")
    r = simulate_impact(model, cfg)
    law = build_system(model, cfg).planes[-1].law
    plot_force_history(r, a.out, law=law,
                       title=f"rover2d, beta = {cfg.beta_deg:g} deg, u = {cfg.speed:g} m/s, "
                             f"Mars gravity")
    key = max(r.F_max, key=r.F_max.get)
    print(f"F_max = {r.F_max_total:.4g} N at t = {1e3 * r.t_peak[key]:.3g} ms, "
          f"T_c^- = {r.T_c_minus:.4g} J, duration {1e3 * r.contact_duration:.3g} ms -> {a.out}")


if __name__ == "__main__":
    main()
