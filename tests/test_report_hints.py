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
