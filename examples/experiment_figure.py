"""Figure of docs/experiments.md: the synthetic trials vs the rover scenario model.

    python examples/experiment_figure.py   # writes docs/img/experiment_overlay.png
"""

from pathlib import Path

from roverimpact.studies.experiment import compare_with_model, plot_overlay, run_experiment

root = Path(__file__).resolve().parents[1]
res = run_experiment(root / "examples" / "experiment" / "trials.toml")
cmp = compare_with_model(res.trials, res.config.model.build(res.base_dir))
print(cmp.table.round(3).to_string(index=False))
print(cmp.stats)
out = plot_overlay(res.trials, cmp, root / "docs" / "img" / "experiment_overlay.png")
print("wrote", out)
