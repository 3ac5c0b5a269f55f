"""T_c^- against the impact angle beta for three choices of held contacts (planar rover).

The built-in planar rover (rover2d, rigid suspension) rolls at 0.5 m/s; its front wheel
meets an obstacle face of angle beta. Both wheels' ground contacts (normal rows) are
candidates. Curves: "all held" (both ground contacts + obstacle), "auto" (the contacts
that hold through the impact, from the unilateral LCP) and "obstacle only".

Run: ``python examples/active_set_beta.py [out.png]`` (default docs/img/active_set_beta.png).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import roverimpact as ri


def scenario(constraints):
    return ri.Scenario.model_validate({
        "model": {"name": "rover2d", "params": {"suspension": "rigid"}},
        "velocity": {"u": 0.5}, "constraints": constraints,
        "contacts": {"ground_wheels": ["rear", "front"], "ground": "normal"},
        "obstacle": {"wheel": "front", "beta_deg": 45.0},
    })


def main(out: str | Path = "docs/img/active_set_beta.png") -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    beta_deg = np.linspace(10.0, 90.0, 81)
    beta = np.radians(beta_deg)
    curves = {
        "all held": ri.sweep_energy(scenario("all"), beta).T_c_minus,
        "auto (LCP)": ri.sweep_energy(scenario("auto"), beta).T_c_minus,
        "obstacle only": ri.sweep_energy(scenario(["obstacle:front:normal"]), beta).T_c_minus,
    }
    fig, ax = plt.subplots(figsize=(6, 4))
    for (name, y), ls in zip(curves.items(), ["-", "--", ":"], strict=True):
        ax.plot(beta_deg, y, ls, label=name, lw=2)
    ax.set_xlabel("impact angle beta [deg]")
    ax.set_ylabel("T_c^- [J]")
    ax.set_title("planar rover, 0.5 m/s: which contacts are held")
    ax.legend()
    ax.grid(alpha=0.3)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)
    for name, y in curves.items():
        print(f"{name:14s} T_c^- at beta = 10/45/90 deg: "
              + " / ".join(f"{y[i]:.4f}" for i in (0, 35, 80)) + " J")
    return out


if __name__ == "__main__":
    print(main(*sys.argv[1:]))
