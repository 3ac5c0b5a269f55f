"""Run a study from Python and print how well T_c^- ranks the simulated peak forces.

The statistics are those of the report this script writes (``report.html``,
``stats.json``): over the true impacts, the cases whose contact lasted the whole
simulated window left out (docs/studies.md, "Whole-window cases").

    python examples/run_study.py [results-folder]
"""

import sys
from pathlib import Path

from roverimpact.report.html import build_report
from roverimpact.studies import agreement, run_study
from roverimpact.studies.store import whole_window_cases

here = Path(__file__).parent
out = Path(sys.argv[1] if len(sys.argv) > 1 else "study-results")
res = run_study(here / "study_rover2d_beta_h.toml", out, overwrite=True)
t = res.table
print(t[["obstacle.beta_deg", "model.params.h", "T_c_minus", "F_pred", "F_max"]].round(3))
whole = whole_window_cases(t)          # contact not ended in the window: not an impact peak
a = agreement(t["T_c_minus"][~whole], t["F_max"][~whole], n_boot=1000, seed=0)
print(f"n = {a.n} ({int(whole.sum())} whole-window cases excluded)")
print(f"Spearman {a.spearman}  Kendall {a.kendall}  concordant pairs {a.concordant_fraction}")
report, _ = build_report(out)
print(f"report: {report}")
