"""`roverimpact contact` command and the contact plots."""

import matplotlib
import pytest

import roverimpact
from roverimpact.cli import main
from roverimpact.contact import get_law, predict


def test_top_level_exports():
    assert roverimpact.contact.get_law is get_law
    assert callable(roverimpact.peak_force) and callable(roverimpact.impact_1dof)


def test_contact_prints_predictions(capsys):
    assert main(["contact", "--law", "hunt-crossley", "--k", "1e6", "--e", "0.8",
                 "--mass", "12", "--speed", "0.5", "--check"]) == 0
    out = capsys.readouterr().out
    p = predict(get_law("hunt-crossley", k=1e6, e=0.8), 12.0, 0.5)
    assert f"{p.peak_force:.6g}" in out and "integrated" in out
    assert "max indentation [mm]" in out


def test_contact_check_elastic_energy_difference(capsys):
    """Hertz is elastic: the closed form dissipates 0 J, the integration ~4e-12 J of
    T_c^- = 0.96 J. The rel. diff column showed 1.0e+00 (the difference relative to the
    integrated 4e-12 J itself); it is now relative to T_c^-."""
    assert main(["contact", "--law", "hertz", "--k", "1e7", "--mass", "3", "--speed",
                 "0.8", "--check"]) == 0
    out = capsys.readouterr().out
    line = next(ln for ln in out.splitlines() if ln.strip().startswith("energy dissipated"))
    assert float(line.split()[-1]) < 1e-8
    assert "/ T_c^-" in out


def test_contact_from_tc_and_plot(tmp_path, capsys):
    png = tmp_path / "loop.png"
    assert main(["contact", "--law", "kelvin-voigt", "--k", "1e5", "--e", "0.5",
                 "--tc", "1.5", "--speed", "0.5", "--plot", str(png)]) == 0
    assert png.stat().st_size > 1000


def test_contact_list(capsys):
    assert main(["contact", "--list"]) == 0
    out = capsys.readouterr().out
    assert "carvalho-martins" in out and "Hunt" in out


@pytest.mark.parametrize(
    ("args", "msg"),
    [
        (["--law", "flores", "--k", "1e6", "--e", "0", "--mass", "1", "--speed", "1"],
         "undefined at e = 0"),
        (["--law", "hertz", "--k", "-1", "--mass", "1", "--speed", "1"], "k"),
        (["--law", "hertz", "--k", "1e6", "--mass", "1", "--speed", "0"], "v_n"),
        (["--law", "zzz", "--k", "1e6", "--mass", "1", "--speed", "1"], "unknown contact law"),
    ],
)
def test_contact_bad_input_exit_2(args, msg, capsys):
    assert main(["contact", *args]) == 2
    assert msg in capsys.readouterr().err


def test_peak_force_plot(tmp_path):
    from roverimpact.report.contact import default_laws, plot_peak_force_vs_T

    fig = plot_peak_force_vs_T(default_laws(1e6, 0.7, m_eff=10.0), 0.5,
                               path=tmp_path / "pf.png")
    assert isinstance(fig, matplotlib.figure.Figure) and (tmp_path / "pf.png").exists()


@pytest.mark.parametrize("law", ["gonthier", "flores"])
def test_contact_small_restitution(law, capsys):
    """e = 0.001 (z ~ 1000): the closed forms crashed with a ZeroDivisionError traceback."""
    assert main(["contact", "--law", law, "--k", "1e6", "--e", "0.001", "--mass", "12",
                 "--speed", "0.5", "--check"]) == 0
    out = capsys.readouterr().out
    p = predict(get_law(law, k=1e6, e=0.001), 12.0, 0.5)
    assert f"{p.peak_force:.6g}" in out and f"{1e3 * p.duration:.6g}" in out


def test_contact_check_and_plot_of_a_long_damped_contact(tmp_path, capsys):
    """gonthier at e = 1e-8 lasts 8.3e4 Hertz times (closed form 362.39 s here): --check
    and --plot gave up at impact_1dof's default 1e4 ("pass a larger max_duration", an
    argument the command does not have; exit 2). They now integrate as long as the closed
    form says the contact lasts; the integrated duration and e* match it (the reference:
    docs/contact.md's vanishing-restitution asymptotics t_c/t_H = 2/(n+1) 2^-a z^a/(1-a),
    e* = 1/z, to O(ln z / z))."""
    import json

    assert main(["contact", "--law", "gonthier", "--k", "1e6", "--e", "1e-8", "--mass", "1",
                 "--speed", "1", "--check", "--json", "--plot", str(tmp_path / "g.png")]) == 0
    out = json.loads(capsys.readouterr().out)
    z = (1 - 1e-16) / 1e-8                       # gonthier: chi v_i = (1 - e^2) / e
    n, a = 1.5, 1.5 / 2.5
    d_H = (2.5 * 1.0 / (2 * 1e6)) ** (1 / 2.5)   # t_H = d_H / v, v = 1 m/s
    t_asym = 2 / (n + 1) * 2 ** -a * z ** a / (1 - a) * d_H
    assert out["integrated"]["duration"] == pytest.approx(t_asym, rel=1e-3)
    assert out["integrated"]["restitution_achieved"] == pytest.approx(1 / z, rel=1e-3)
    assert out["integrated"]["duration"] == pytest.approx(out["closed_form"]["duration"],
                                                          rel=1e-6)
    assert (tmp_path / "g.png").exists()
