"""Figure of docs/robot-safety.md: T_c^- of the Panda's tool centre point over joints 2
and 4, from the study examples/study_panda_joints.toml (2 000 configurations, one state
block per chunk) and the map its report draws.

    python examples/panda_joint_map.py   # writes docs/img/panda_joint_map.png
"""

import shutil
import tempfile
from pathlib import Path

from roverimpact.report.html import analyse_folder
from roverimpact.studies import run_study

root = Path(__file__).resolve().parents[1]
with tempfile.TemporaryDirectory() as tmp:
    res = run_study(root / "examples" / "study_panda_joints.toml", Path(tmp) / "panda")
    section = analyse_folder(Path(tmp) / "panda", n_boot=0)
    table = res.table
    top = table.loc[table["T_c_minus"].idxmax()]
    print(f"{len(table)} configurations; largest T_c^- {top['T_c_minus']:.4g} J at "
          f"panda_joint2 = {top['configuration.joints.panda_joint2']:.4g} rad, "
          f"panda_joint4 = {top['configuration.joints.panda_joint4']:.4g} rad")
    out = root / "docs" / "img" / "panda_joint_map.png"
    shutil.copyfile(section.maps["png"], out)
print("wrote", out)
