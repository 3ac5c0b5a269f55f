"""Example scripts print what their header says."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_run_study_prints_the_statistics_of_its_report(tmp_path):
    """examples/run_study.py printed Spearman 0.997 over all 16 cases while the report it
    writes gives 0.996 over the 14 true impacts (two whole-window cases at beta = 20 deg);
    its statistics are now the report's (stats.json)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        p for p in (str(ROOT / "src"), os.environ.get("PYTHONPATH")) if p), MPLBACKEND="Agg")
    out = subprocess.run([sys.executable, str(ROOT / "examples" / "run_study.py"), "res"],
                         cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    stats = json.loads((tmp_path / "res" / "stats.json").read_text())
    assert stats["n_whole_window"] > 0           # the case this test is about
    m = re.search(r"n = (\d+) \((\d+) whole-window", out.stdout)
    assert m and (int(m[1]), int(m[2])) == (stats["n"], stats["n_whole_window"])
    printed = re.search(r"Spearman (\S+) \[(\S+), (\S+)\]", out.stdout).groups()
    want = stats["spearman"]
    assert [float(x) for x in printed] == [round(want[k], 3) for k in ("value", "low", "high")]
