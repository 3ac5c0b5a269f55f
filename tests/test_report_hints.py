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
