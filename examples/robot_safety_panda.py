"""Figure of docs/robot-safety.md: ISO/TS 15066 m_R = M/2 + m_L vs the exact effective mass
of each Panda link, and the resulting transient-contact speed limits for the chest.

    python examples/robot_safety_panda.py   # writes docs/img/panda_effective_mass.png
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from roverimpact.safety import READY_POSES, arm_effective_masses, load_arm

root = Path(__file__).resolve().parents[1]
model = load_arm("erd:panda")
q = np.array(READY_POSES["panda"])
df = arm_effective_masses(model, q, payload=1.0, region="chest")
df = df[~df["link"].str.contains("finger")]  # fingers: 15 g prismatic bodies
print(df.round(3).to_string(index=False))

x = np.arange(len(df))
names = [n.replace("panda_", "") for n in df["link"]]
m_hi = np.minimum(df["m_max"].to_numpy(), 1e4)
fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
a1.vlines(x, df["m_min"], m_hi, lw=6, color="C0", alpha=0.6,
          label="exact $m_u$, all directions (min..max)")
a1.plot(x, df["m_min"], "o", color="C0")
a1.axhline(df["m_R_iso"].iloc[0], color="C3", ls="--", label="ISO/TS 15066 $m_R = M/2 + m_L$")
a1.set_yscale("log")
a1.set_ylim(1, 2e4)
a1.set_xticks(x, names, rotation=30)
a1.set_ylabel("robot-side mass [kg]")
a1.set_title("Panda, ready pose, link COMs, $m_L$ = 1 kg", fontsize=10)
a1.legend(fontsize=8)
a2.plot(x, df["v_iso"], "--", color="C3", label="ISO $m_R$")
a2.fill_between(x, df["v_exact_worst"], df["v_exact_best"], color="C0", alpha=0.3,
                label="exact, heaviest..lightest direction")
a2.set_xticks(x, names, rotation=30)
a2.set_ylabel("max transient speed, chest [m/s]")
a2.set_title(r"$v_{max} = F_T/\sqrt{\mu K}$, chest: $m_H$=40 kg, K=25 N/mm, $F_T$=280 N",
             fontsize=10)
a2.legend(fontsize=8)
for a in (a1, a2):
    a.grid(alpha=0.3)
fig.tight_layout()
out = root / "docs" / "img" / "panda_effective_mass.png"
fig.savefig(out, dpi=110)
print("wrote", out)
