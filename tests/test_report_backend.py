"""Drawing a figure never selects or changes the user's matplotlib backend."""

from __future__ import annotations

import subprocess
import sys


def test_figures_leave_the_backend_alone(tmp_path):
    code = f"""
import matplotlib
matplotlib.use("svg")
import numpy as np, pandas as pd
from roverimpact.report.plots import plot_study, save_figure
from roverimpact.report.contact import default_laws, plot_peak_force_vs_T
t = pd.DataFrame({{"obstacle.beta_deg": [10.0, 50.0, 90.0], "T_c_minus": [0.1, 0.5, 0.9],
                   "F_max": [100.0, 400.0, 700.0]}})
save_figure(plot_study(t, "obstacle.beta_deg", title="t"), r"{tmp_path / 'study'}")
plot_peak_force_vs_T(default_laws(1e6, 0.7, m_eff=10.0), 0.5, (1e-2, 1.0),
                     r"{tmp_path / 'laws.png'}")
import matplotlib.pyplot  # noqa: F401  (a pyplot user's session)
print(matplotlib.get_backend())
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out[-1] == "svg"
    assert (tmp_path / "study.png").stat().st_size > 1000
    assert (tmp_path / "laws.png").stat().st_size > 1000


def test_an_interrupted_or_failed_figure_leaves_the_previous_one(tmp_path):
    """Ctrl-C or a full disk while a figure is written: matplotlib wrote into the file
    itself, so the previous figure was lost and a truncated image stayed (the report's
    figure.png, a `draw -o` file); now the file is the previous one, and no temporary is
    left. A real figure is written in the format of its suffix."""
    import errno

    import pytest
    from matplotlib.figure import Figure

    from roverimpact.report.plots import save_figure, savefig

    class Broken:
        def __init__(self, exc):
            self.exc = exc

        def savefig(self, path, **kw):
            with open(path, "wb") as f:
                f.write(b"half an image")
            raise self.exc

    for ext in ("png", "svg"):
        (tmp_path / f"figure.{ext}").write_bytes(b"the previous figure")
    for exc in (KeyboardInterrupt(), OSError(errno.ENOSPC, "No space left on device")):
        with pytest.raises(type(exc)) as info:
            save_figure(Broken(exc), tmp_path / "figure")
        if isinstance(exc, OSError):  # the error names the file
            assert info.value.filename == str(tmp_path / "figure.png")
        assert sorted(p.name for p in tmp_path.iterdir()) == ["figure.png", "figure.svg"]
        assert (tmp_path / "figure.png").read_bytes() == b"the previous figure"
    fig = Figure()
    fig.subplots().plot([0, 1], [0, 1])
    paths = save_figure(fig, tmp_path / "figure")
    assert paths["png"].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert b"<svg" in paths["svg"].read_bytes()[:1000]
    savefig(fig, tmp_path / "one.PDF")
    assert (tmp_path / "one.PDF").read_bytes()[:5] == b"%PDF-"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["figure.png", "figure.svg",
                                                           "one.PDF"]


def test_save_figure_lays_the_figure_out_once(tmp_path, monkeypatch):
    """A constrained-layout figure (the traverse map and speed profile, the trust and
    contact figures) was laid out twice by save_figure, for the PNG and again for the SVG:
    half of a traverse figure's drawing time. Now once: the SVG keeps the PNG's layout
    (the axes at the same place in both, to a fraction of a point), and the figure keeps
    its layout engine."""
    import re

    import pytest
    from matplotlib.figure import Figure
    from matplotlib.layout_engine import ConstrainedLayoutEngine

    from roverimpact.report.plots import save_figure

    runs = []
    execute = ConstrainedLayoutEngine.execute
    monkeypatch.setattr(ConstrainedLayoutEngine, "execute",
                        lambda self, fig: runs.append(fig) or execute(self, fig))
    fig = Figure(figsize=(4.0, 3.0), layout="constrained")
    ax = fig.subplots()
    ax.plot([0, 1], [0, 1])
    ax.set_ylabel("a long label that takes room [N]")
    fig.colorbar(ax.imshow([[0.0, 1.0]]), ax=ax, location="bottom")
    paths = save_figure(fig, tmp_path / "f", dpi=110)
    assert len(runs) == 1
    assert isinstance(fig.get_layout_engine(), ConstrainedLayoutEngine)
    # the axes' lower-left corner in the SVG (points, y down) and the figure's (inches)
    svg = paths["svg"].read_text()
    x0, y0 = map(float, re.search(r'<g id="patch_2">\s*<path d="M ([\d.]+) ([\d.]+)',
                                  svg).groups())
    box = ax.get_position()
    assert x0 == pytest.approx(box.x0 * 4.0 * 72, abs=0.01)
    assert y0 == pytest.approx((1 - box.y0) * 3.0 * 72, abs=0.01)


def test_study_figure_without_legend_says_what_its_lines_are():
    """A sweep over beta x h x u x suspension draws 8 lines of T_c^- and 8 of F_max: too
    many for a legend, and the figure once drew none, with nothing saying which line is
    which. The count is pandas' number of (h, u, suspension) groups."""
    import numpy as np
    import pandas as pd

    from roverimpact.report.plots import label, plot_study

    rng = np.random.default_rng(0)
    g = pd.MultiIndex.from_product([[20.0, 60.0, 90.0], [0.25, 0.45], [0.3, 0.6],
                                    ["rocker", "rigid"]],
                                   names=["obstacle.beta_deg", "model.params.h", "velocity.u",
                                          "model.params.suspension"]).to_frame(index=False)
    t = g.assign(T_c_minus=rng.uniform(0.1, 2, len(g)), F_max=rng.uniform(100, 900, len(g)))
    others = ["model.params.h", "velocity.u", "model.params.suspension"]
    fig = plot_study(t, "obstacle.beta_deg", group_by=others)
    ax = fig.axes[0]
    assert ax.get_legend() is None
    n = t.groupby(others).ngroups
    text = " ".join(x.get_text() for x in ax.texts)
    assert f"{n} lines each (h, u, suspension" in text.replace("\n", " ")
    assert "N/m" in label("contact_law.k")   # k [N/m^n] as the docs give it
