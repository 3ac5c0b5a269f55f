"""`roverimpact report` on a damaged results folder says what to do."""

from __future__ import annotations

from roverimpact.cli import main

STUDY = """name = "rb"
[base]
model = { name = "rigid_body", params = { mass = 20.0, inertia = 1.2, com_height = 0.3, lever = 0.4 } }
velocity = { u = 0.5 }
obstacle = { frame = "contact", beta_deg = 90.0 }
[grid]
"obstacle.beta_deg" = { start = 10, stop = 90, num = 5 }
"""


def test_results_table_deleted_but_chunks_kept_hints_at_resume(tmp_path, capsys):
    """results.parquet deleted, chunks/ present: 'no study results here; run sweep'
    before; now the command that rebuilds the table from the chunks, which works."""
    f = tmp_path / "s.toml"
    f.write_text(STUDY)
    out = tmp_path / "out"
    assert main(["sweep", str(f), "-o", str(out), "--no-report"]) == 0
    (out / "results.parquet").unlink()
    capsys.readouterr()
    assert main(["report", str(out)]) == 2
    err = " ".join(capsys.readouterr().err.split())
    hint = f"roverimpact sweep {out / 'study.toml'} -o {out} --resume"
    assert "chunks/ holds the finished chunks" in err and hint in err
    assert main([*hint.split()[1:], "--no-report"]) == 0
    assert "0 computed, 5 reused" in capsys.readouterr().out
    assert main(["report", str(out)]) == 0


def test_reproduce_folder_missing_a_study_says_so(tmp_path, capsys):
    """A reproduction folder whose study subfolders were partly deleted: report.html
    dropped them without a word; now a note (stderr and the report) names them."""
    from roverimpact.studies.reproduce import BUILTIN_STUDIES

    f = tmp_path / "s.toml"
    f.write_text(STUDY)
    root = tmp_path / "rq"
    kept = list(BUILTIN_STUDIES)[:2]
    for stem in kept:
        assert main(["sweep", str(f), "-o", str(root / stem), "--no-report"]) == 0
    capsys.readouterr()
    assert main(["report", str(root)]) == 0
    err = " ".join(capsys.readouterr().err.split())
    gone = list(BUILTIN_STUDIES)[2:]
    assert "note: Not in this report:" in err
    for stem in gone:
        assert f"{stem} ({BUILTIN_STUDIES[stem]})" in err
    for stem in kept:
        assert f"{stem} (" not in err
    page = (root / "report.html").read_text()
    assert "Not in this report" in page and gone[0] in page
    # a complete one, or a folder of other studies: no note
    assert main(["report", str(root / kept[0])]) == 0
    assert "Not in this report" not in capsys.readouterr().err


def _forces(scenario):
    """T_c^- and a peak force from the angle; the simulation "fails" at 30 and 60 deg."""
    import math

    beta = scenario["obstacle"]["beta_deg"]
    t = math.sin(math.radians(beta)) ** 2
    failed = beta in (30.0, 60.0)
    return {"T_c_minus": t, "F_max": math.nan if failed else 900.0 * t ** 0.6 + beta,
            "contact_whole_window": False, "sim_error": "SimulationError: boom" if failed
            else ""}


def test_report_says_which_cases_the_statistics_leave_out(tmp_path, capsys):
    """Failed simulations (F_max NaN) left the statistics without a word: "cases 10,
    n 8, excl. 0"; and a study of 2 simulated cases said "the compliant-contact simulator
    gave no result" although both had F_max. Reference: scipy's Spearman of the rows with
    F_max, read from the chunk files."""
    import glob
    import json

    import pandas as pd
    from scipy import stats

    from roverimpact.studies import run_study

    base = {"obstacle": {"beta_deg": 0.0}}
    grid = {"obstacle.beta_deg": [10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 85.0, 90.0]}
    run_study({"name": "failing", "simulate": True, "chunk_size": 3, "base": base,
               "grid": grid}, tmp_path / "f", evaluator=_forces)
    capsys.readouterr()
    assert main(["report", str(tmp_path / "f")]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "2 cases without F_max (the simulation failed" in out
    t = pd.concat(pd.read_parquet(p) for p in sorted(glob.glob(str(tmp_path / "f/chunks/*"))))
    ok = t["F_max"].notna()
    ref = stats.spearmanr(t["T_c_minus"][ok], t["F_max"][ok]).statistic
    s = json.loads((tmp_path / "f" / "stats.json").read_text())
    assert s["n"] == 8 and abs(s["spearman"]["value"] - ref) < 1e-12
    assert "2 cases without F_max" in (tmp_path / "f" / "report.html").read_text()

    run_study({"name": "two", "simulate": True, "base": base,
               "grid": {"obstacle.beta_deg": [20.0, 40.0]}}, tmp_path / "two",
              evaluator=_forces)
    assert main(["report", str(tmp_path / "two")]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "2 cases with F_max, at least 3 are needed" in out
    assert "gave no result" not in (tmp_path / "two" / "report.html").read_text()


def test_folder_of_studies_with_one_interrupted_says_so(tmp_path, capsys):
    """A folder of two studies, one interrupted (its chunks and manifest, no
    results.parquet): the report showed the other alone, exit 0, without a word about
    the second; now a note (stderr and the report) names it and the command finishing
    it, which works."""
    import shutil

    f = tmp_path / "s.toml"
    f.write_text(STUDY)
    root = tmp_path / "all"
    assert main(["sweep", str(f), "-o", str(root / "a"), "--no-report"]) == 0
    shutil.copytree(root / "a", root / "b")
    (root / "b" / "results.parquet").unlink()
    capsys.readouterr()
    assert main(["report", str(root), "--n-boot", "0"]) == 0
    err = " ".join(capsys.readouterr().err.split())
    hint = f"roverimpact sweep {root / 'b' / 'study.toml'} -o {root / 'b'} --resume"
    assert "Not in this report: b, a study without results.parquet" in err and hint in err
    assert "Not in this report: b" in (root / "report.html").read_text()
    assert main([*hint.split()[1:], "--no-report"]) == 0
    capsys.readouterr()
    assert main(["report", str(root), "--n-boot", "0"]) == 0
    assert "Not in this report" not in capsys.readouterr().err


def test_constant_peak_force_is_named_not_shown_as_a_correlation(tmp_path, capsys):
    """F_max the same in every case: scipy's spearmanr is NaN (zero variance), the report
    showed n/a everywhere without saying why; now a note names the constant column."""
    import json
    import warnings

    import numpy as np
    import pandas as pd
    from scipy import stats as sps

    f = tmp_path / "s.toml"
    f.write_text(STUDY)
    out = tmp_path / "out"
    assert main(["sweep", str(f), "-o", str(out), "--no-report"]) == 0
    path = out / "results.parquet"
    t = pd.read_parquet(path).assign(F_max=250.0)
    t.to_parquet(path)
    m = json.loads((out / "manifest.json").read_text())
    (out / "manifest.json").write_text(json.dumps(m | {"simulate": True}))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert np.isnan(sps.spearmanr(t["T_c_minus"], t["F_max"]).statistic)
    capsys.readouterr()
    assert main(["report", str(out), "--n-boot", "0"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "F_max is the same in all 5 cases used" in text
    assert "1.000" not in text
    assert "F_max is the same in all 5 cases" in (out / "report.html").read_text()


def test_many_cases_are_drawn_binned_not_as_a_wall_of_markers(tmp_path):
    """A table of 4000 cases read whole was drawn point by point (1e5 cases: a solid red
    and blue block); now as the large-study summary (per-bin range, band and median of
    every case, PLOT_SAMPLE dots), and the figure says so. (Pipeline check: the binned
    aggregates themselves are tested against numpy in test_study_scale.)"""
    import numpy as np
    import pandas as pd

    from roverimpact.report.html import PLOT_SAMPLE, analyse_folder

    f = tmp_path / "s.toml"
    f.write_text(STUDY)
    out = tmp_path / "out"
    assert main(["sweep", str(f), "-o", str(out), "--no-report"]) == 0
    path = out / "results.parquet"
    t = pd.read_parquet(path)
    rng = np.random.default_rng(0)
    n = 4000
    big = t.iloc[rng.integers(0, len(t), n)].reset_index(drop=True)
    big["case"] = np.arange(n)
    big["obstacle.beta_deg"] = rng.uniform(10, 90, n)
    big["T_c_minus"] = rng.uniform(0.1, 2.0, n)
    big.to_parquet(path)
    s = analyse_folder(out, n_boot=0)
    assert s.agreement is None and len(s.table) == n
    svg = " ".join((out / "figure.svg").read_text().split())  # texts kept as comments
    assert f"all {n:,} cases in" in svg
    assert f"{PLOT_SAMPLE:,} random cases" in svg
