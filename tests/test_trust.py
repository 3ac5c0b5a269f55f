"""Trust map (studies.trust): Kendall tau of T_c^- vs simulated F_max per contact cell.

The reference for one cell is computed by hand here: T_c^- from the scenario layer's
``energy_of`` per configuration, F_max from ``simulate_impact`` called directly with a
``SimulationConfig`` built in the test (not through the study runner), and
``scipy.stats.kendalltau`` / ``spearmanr`` on the pairs.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats as sps

from roverimpact.exceptions import ConfigError
from roverimpact.report.trust import plot_trust_map
from roverimpact.studies.trust import (
    QUICK_BETAS_DEG,
    TrustGrid,
    builtin_study,
    trust_map,
    trust_table,
)


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("trust")
    res = trust_map(None, out, quick=True)
    res.files.update(plot_trust_map(res.table, res.out_dir / "trust_map", title=res.title))
    return res


def test_quick_table_shape_and_files(quick):
    t = quick.table
    assert list(t.columns[:6]) == ["law", "k", "e", "tau", "spearman", "n"]
    assert len(t) == 4  # 1 law x 2 k x 2 e
    assert set(t["law"]) == {"hunt-crossley"}
    assert (t["n"] == len(QUICK_BETAS_DEG)).all() and (t["n_failed"] == 0).all()
    assert np.all(np.abs(t["tau"]) <= 1.0)
    for role in ("trust", "results", "png", "svg"):
        assert quick.files[role].is_file()
    assert pd.read_parquet(quick.files["trust"]).equals(t)
    assert len(quick.results) == 4 * len(QUICK_BETAS_DEG)


def test_one_cell_by_hand(quick):
    """tau of the (hunt-crossley, k = 1e7, e = 0.5) cell recomputed without the runner."""
    from roverimpact.models import rover2d
    from roverimpact.scenario import energy_of, scenario_from_dict
    from roverimpact.simulate import SimulationConfig, simulate_impact

    law, k, e = "hunt-crossley", 1e7, 0.5
    base = builtin_study(quick=True)["base"]
    mbm = rover2d()
    T, F = [], []
    for beta in QUICK_BETAS_DEG:
        scn = {**base, "obstacle": {"wheel": "front", "beta_deg": beta}}
        T.append(float(energy_of(scenario_from_dict(scn)).T_c_minus))
        cfg = SimulationConfig(speed=base["velocity"]["u"], beta_deg=beta,
                               obstacle={"name": law, "k": k, "e": e})
        F.append(simulate_impact(mbm, cfg).F_max_total)
    row = quick.table.query("law == @law and k == @k and e == @e").iloc[0]
    assert row["tau"] == pytest.approx(sps.kendalltau(T, F).statistic, abs=1e-12)
    assert row["spearman"] == pytest.approx(sps.spearmanr(T, F).statistic, abs=1e-12)
    # and the runner's F_max are the directly simulated ones
    sub = quick.results[(quick.results["contact_law.k"] == k)
                        & (quick.results["contact_law.e"] == e)].sort_values("obstacle.beta_deg")
    np.testing.assert_allclose(sub["F_max"].to_numpy(), F, rtol=1e-9)
    np.testing.assert_allclose(sub["T_c_minus"].to_numpy(), T, rtol=1e-12)


def test_trust_table_independent_of_row_order():
    """tau per cell from a hand-made table equals scipy on the same pairs."""
    rng = np.random.default_rng(1)
    rows = []
    for k in (1e5, 1e6):
        x = rng.random(6)
        y = x + (0.0 if k == 1e5 else 1.0) * rng.random(6)
        rows += [{"contact_law.name": "flores", "contact_law.k": k, "contact_law.e": 0.5,
                  "T_c_minus": a, "F_max": b} for a, b in zip(x, y, strict=True)]
    df = pd.DataFrame(rows)
    t = trust_table(df.sample(frac=1.0, random_state=3))
    for k in (1e5, 1e6):
        g = df[df["contact_law.k"] == k]
        ref = sps.kendalltau(g["T_c_minus"], g["F_max"]).statistic
        assert t.loc[t["k"] == k, "tau"].item() == pytest.approx(ref, abs=1e-12)
    assert t.loc[t["k"] == 1e5, "tau"].item() == pytest.approx(1.0)


@pytest.mark.parametrize("kwargs, match", [
    ({"k": (-1.0,)}, "stiffness"),
    ({"k": ()}, "stiffness"),
    ({"e": (0.5, 1.5)}, "restitution"),
    ({"e": (0.0,)}, "restitution"),
    ({"laws": ("kelvin-voigt",)}, "unsupported contact law"),
    ({"laws": ("no-such-law",)}, "unknown"),
    ({"laws": ()}, "at least one"),
])
def test_bad_grid(kwargs, match):
    with pytest.raises(ConfigError, match=match):
        TrustGrid(**kwargs)


def test_hertz_cells_have_e_one():
    cells = TrustGrid(laws=("hertz", "flores"), k=(1e6,), e=(0.3, 0.7)).cells()
    assert cells == [("hertz", 1e6, 1.0), ("flores", 1e6, 0.3), ("flores", 1e6, 0.7)]


def test_bad_studies(tmp_path):
    st = builtin_study(quick=True)
    bad = {**st, "grid": {"obstacle.beta_deg": [30.0, 60.0]}}
    with pytest.raises(ConfigError, match="at least 3"):
        trust_map(bad, tmp_path / "a", quick=True)
    bad = {**st, "grid": {**st["grid"], "contact_law.k": [1e5, 1e6]}}
    with pytest.raises(ConfigError, match=r"sweeps 'contact_law\.k'"):
        trust_map(bad, tmp_path / "b", quick=True)
    rb = {"name": "rb", "base": {"model": {"name": "rigid_body"},
                                 "obstacle": {"frame": "contact", "beta_deg": 90.0}},
          "grid": {"obstacle.beta_deg": [10.0, 40.0, 80.0]}}
    with pytest.raises(ConfigError, match="no wheels to simulate"):
        trust_map(rb, tmp_path / "c", quick=True)


def test_cli(tmp_path, capsys):
    from roverimpact.cli import main

    out = tmp_path / "tm"
    assert main(["trust", "--quick", "--k", "1e6", "--e", "0.8", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "Kendall tau" in text and "hunt-crossley" in text
    t = pd.read_parquet(out / "trust.parquet")
    assert len(t) == 1 and t["k"].item() == 1e6 and t["e"].item() == 0.8


def test_cli_bad_input(tmp_path, capsys):
    from roverimpact.cli import main

    assert main(["trust", "--quick", "--k", "-3", "-o", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert "stiffness" in err and "Traceback" not in err
    assert main(["trust", "--quick", "--e", "a,b", "-o", str(tmp_path / "y")]) == 2
    assert "comma-separated" in capsys.readouterr().err
    missing = tmp_path / "nope.toml"
    assert main(["trust", str(missing), "-o", str(tmp_path / "z")]) == 2


def test_cli_interrupt_after_the_simulations_says_resume_recomputes_nothing(
        tmp_path, monkeypatch, capsys):
    """Ctrl-C once a trust map's simulations are complete (while the table or the map is
    drawn): the message was a bare "interrupted"; it says the simulations are kept and
    that --resume draws the map. A Ctrl-C before that stays a plain interruption."""
    import json

    from roverimpact.cli import main
    from roverimpact.studies import trust

    out = tmp_path / "t"

    def interrupted_after_the_study(*a, **kw):
        out.mkdir(exist_ok=True)
        (out / "manifest.json").write_text(json.dumps({"status": "complete"}))
        raise KeyboardInterrupt

    monkeypatch.setattr(trust, "trust_map", interrupted_after_the_study)
    assert main(["trust", "--quick", "-o", str(out)]) == 130
    err = " ".join(capsys.readouterr().err.split())
    assert (f"interrupted: interrupted after the simulations, which are complete in {out}: "
            "rerun the same command with --resume") in err
    (out / "manifest.json").write_text(json.dumps({"status": "running"}))

    def interrupted(*a, **kw):
        raise KeyboardInterrupt

    monkeypatch.setattr(trust, "trust_map", interrupted)
    assert main(["trust", "--quick", "-o", str(out)]) == 130
    assert "complete" not in capsys.readouterr().err
