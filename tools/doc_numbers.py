"""Every number the docs quote that the code computes: recompute it, check it, rewrite it.

    python tools/doc_numbers.py --check            # the cheap numbers (tests/test_doc_numbers.py)
    python tools/doc_numbers.py --check --slow     # also the expensive ones (full trust map, ...)
    python tools/doc_numbers.py --write [--slow]   # put fresh values into the Markdown
    python tools/doc_numbers.py --list             # every key: file, cost, producer

In README.md and docs/*.md a computed number (or a generated table) sits between markers:

    <!-- num:trust.tau_soft -->0.905<!-- /num -->

The key names a *producer* below, a function that computes it with the library and returns
the text exactly as the docs print it. A number printed by a code block (an output shown
as a comment, where a marker would be displayed) is found by an *anchor* instead: a
regular expression with one group ``v`` that must match exactly once in its file.

Producers marked ``slow`` (whole studies, several seconds to minutes) are checked only with
``--slow`` (a test marked ``slow``); the others run in a few seconds. Timings are not
here: they are printed by benchmarks/*.py and the commands the docs name, stated with the
machine and the date of the measurement, and never asserted by a test.

A producer may also assert the claim around its number (e.g. "for every beta"): a failing
claim stops the run with the producer's name.
"""

from __future__ import annotations

import argparse
import functools
import math
import re
import sys
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# a marker quoted in a code span (`<!-- num:KEY -->`, as docs/index.md does) is not a marker
MARKER = re.compile(r"(?<!`)<!-- num:(?P<key>[\w.-]+) -->(?P<body>.*?)(?<!`)<!-- /num -->",
                    re.S)
OPEN = re.compile(r"(?<!`)<!-- num:([\w.-]+) -->")
CLOSE = re.compile(r"(?<!`)<!-- /num -->")
MINUS = "\u2212"


def doc_files(root: Path = ROOT) -> list[Path]:
    """README.md and docs/*.md, the files whose numbers are kept here."""
    return [root / "README.md", *sorted((root / "docs").glob("*.md"))]


# --------------------------------------------------------------------------- registry
@dataclass(frozen=True)
class Producer:
    """A function computing the texts of ``keys`` (dict key -> text)."""

    name: str
    keys: tuple[str, ...]
    fn: Callable[[], dict[str, str]]
    slow: bool


PRODUCERS: dict[str, Producer] = {}
#: key -> (file relative to the root, regular expression with one group ``v``)
ANCHORS: dict[str, tuple[str, str]] = {}


def produces(*keys: str, slow: bool = False):
    """Register a producer of ``keys``."""

    def deco(fn):
        PRODUCERS[fn.__name__] = Producer(fn.__name__, keys, fn, slow)
        return fn

    return deco


def anchor(key: str, file: str, pattern: str) -> None:
    ANCHORS[key] = (file, pattern)


def key_owner() -> dict[str, Producer]:
    out = {}
    for p in PRODUCERS.values():
        for k in p.keys:
            if k in out:
                raise RuntimeError(f"key {k!r} produced by {out[k].name} and {p.name}")
            out[k] = p
    return out


# --------------------------------------------------------------------------- formatting
def sig(x: float, n: int) -> str:
    """``x`` rounded to ``n`` significant digits, no exponent (181.7, 2 -> '180')."""
    if x == 0 or not math.isfinite(x):
        return f"{x:g}"
    d = n - 1 - math.floor(math.log10(abs(x)))
    y = round(x, d)
    return f"{y:.{max(d, 0)}f}"


def pct(x: float, digits: int = 1, sign: bool = True) -> str:
    """Relative value as a percentage, typographic minus: -0.0234 -> '−2.3'."""
    s = f"{100 * x:+.{digits}f}" if sign else f"{100 * x:.{digits}f}"
    return s.replace("-", MINUS)


def latex_pow(x: float) -> str:
    """One significant digit in LaTeX: 4.2e-8 -> '$4\\times10^{-8}$', 1e-9 -> '$10^{-9}$'."""
    e = math.floor(math.log10(abs(x)))
    m = round(abs(x) / 10**e)
    if m == 10:
        m, e = 1, e + 1
    return f"$10^{{{e}}}$" if m == 1 else f"${m}\\times10^{{{e}}}$"


def table(header: list[str], rows: list[list[str]], align: list[str] | None = None) -> str:
    """A Markdown table between blank lines (the body of a table marker)."""
    align = align or ["---"] * len(header)
    lines = ["|" + "|".join(f" {h} " if h else " " for h in header) + "|",
             "|" + "|".join(align) + "|"]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n\n" + "\n".join(lines) + "\n\n"


# =========================================================================== README.md
anchor("readme.rod_T_c", "README.md", r"print\(p\.T_c\) +# (?P<v>\S+) J")
anchor("readme.rod_m_eff", "README.md",
       r"print\(ri\.effective_mass\(M, A\[0\]\)\) +# (?P<v>\S+) kg")


@produces("readme.rod_T_c", "readme.rod_m_eff")
def readme_rod():
    """The README's rod on a ledge: T_c^- and m_eff (= m/4) of the Python example."""
    import numpy as np

    import roverimpact as ri

    M = np.diag([2.0, 2.0, 2.0 / 12])
    A = np.array([[0.0, 1.0, -0.5]])
    v = np.array([0.3, -1.0, 0.5])
    return {"readme.rod_T_c": f"{float(ri.partition(M, A, v).T_c):g}",
            "readme.rod_m_eff": f"{float(ri.effective_mass(M, A[0])):g}"}


# =========================================================================== active-set.md
anchor("active.point_active", "docs/active-set.md", r"print\(r\.active\) +# (?P<v>\[[^\]]*\])")
anchor("active.point_T_c", "docs/active-set.md", r"print\(r\.T_c_minus\) +# (?P<v>\S+) J")


@produces("active.point_active", "active.point_T_c")
def active_point():
    """The API example: a point on the floor sliding into a 45 degree slope."""
    import numpy as np

    import roverimpact as ri

    s = np.sqrt(0.5)
    r = ri.unilateral_impact(np.eye(2), [1.0, 0.0], [[0.0, 1.0], [-s, s]], restitution=0.0)
    return {"active.point_active": str(np.asarray(r.active)),
            "active.point_T_c": f"{float(r.T_c_minus):g}"}


@produces("active.rover_mass", "active.all_held_T")
def active_all_held():
    """Planar rover (rigid) at 0.5 m/s, both ground normals and the obstacle held: T_c^-
    is the whole horizontal kinetic energy, the same for every beta."""
    import numpy as np
    import pinocchio as pin

    import roverimpact as ri
    from roverimpact.models import rover2d

    sc = ri.Scenario.model_validate({
        "model": {"name": "rover2d", "params": {"suspension": "rigid"}},
        "velocity": {"u": 0.5}, "constraints": "all",
        "contacts": {"ground_wheels": ["rear", "front"], "ground": "normal"},
        "obstacle": {"wheel": "front", "beta_deg": 45.0}})
    with warnings.catch_warnings():   # the jam this doc section shows: HeldRowsWarning
        warnings.simplefilter("ignore", ri.exceptions.HeldRowsWarning)
        T = ri.sweep_energy(sc, np.radians(np.linspace(10.0, 90.0, 81))).T_c_minus
    assert np.ptp(T) <= 1e-9 * T.max(), "all-held T_c^- varies with beta"
    m = pin.computeTotalMass(rover2d(suspension="rigid").model)
    assert abs(T[0] - 0.5 * m * 0.5**2) <= 1e-9 * T[0], "T_c^- is not 1/2 m u^2"
    return {"active.rover_mass": f"{m:.0f}", "active.all_held_T": f"{T[0]:.3g}"}


@produces("active.rear_holds_to", "active.front_holds_from", "active.steep_T",
          "active.obstacle_only_90")
def active_auto_rows():
    """Which ground contact holds in examples/active_set_beta.py (rigid rover2d, both
    wheels' ground rows candidates): the rear one at shallow faces, the front (obstacle)
    wheel's own from a steep face on, where T_c^- stays constant; the obstacle-only value at
    90 deg (tests/test_activeset_mujoco.py checks the held set against MuJoCo)."""
    import numpy as np

    import roverimpact as ri

    sc = ri.Scenario.model_validate({
        "model": {"name": "rover2d", "params": {"suspension": "rigid"}},
        "velocity": {"u": 0.5}, "constraints": "auto",
        "contacts": {"ground_wheels": ["rear", "front"], "ground": "normal"},
        "obstacle": {"wheel": "front", "beta_deg": 45.0}})
    rear, front, T = [], [], []
    for b in range(10, 91):
        obs = sc.obstacle.model_copy(update={"beta_deg": float(b)})
        s = ri.ImpactSetup.from_scenario(sc.model_copy(update={"obstacle": obs}))
        rear.append("ground:rear:normal" in s.labels)
        front.append("ground:front:normal" in s.labels)
        T.append(float(s.partition().T_c_minus))
    rear, front, T = np.array(rear), np.array(front), np.array(T)
    betas = np.arange(10, 91)
    to, fr = int(betas[rear].max()), int(betas[front].min())
    assert rear[: to - 9].all() and not rear[to - 9:].any(), "rear holds on one interval"
    assert front[fr - 10:].all() and not front[: fr - 10].any(), "front holds from fr on"
    assert np.ptp(T[fr - 10:]) <= 1e-9 * T[-1], "T_c^- not constant where the front holds"
    only = ri.energy_of(sc.model_copy(update={
        "constraints": ["obstacle:front:normal"],
        "obstacle": sc.obstacle.model_copy(update={"beta_deg": 90.0})}))
    return {"active.rear_holds_to": f"{to}", "active.front_holds_from": f"{fr}",
            "active.steep_T": f"{T[-1]:.2f}",
            "active.obstacle_only_90": f"{float(only.T_c_minus):.2f}"}


# =========================================================================== contact.md
#: beta [deg] of the default-ground check (tests/test_default_ground_mujoco.py)
GROUND_BETAS = (10.0, 20.0, 30.0, 45.0, 60.0, 70.0, 80.0, 90.0)


@functools.cache
def default_ground_mujoco_peaks() -> tuple[float, ...]:
    """MuJoCo's first-impact peak force [N] of the six-wheel rocker-bogie at 0.3 m/s, all
    wheels on the ground with mu = 0.5, a face ahead of the left front wheel, at each of
    :data:`GROUND_BETAS`. Computed once per process: tests/test_default_ground_mujoco.py
    checks the same eight runs."""
    from roverimpact.models import rocker_bogie
    from roverimpact.simulate import SimulationConfig, initial_state
    from roverimpact.simulate.engines import simulate_impact_mujoco

    mbm = rocker_bogie()
    F = []
    for b in GROUND_BETAS:
        cfg = SimulationConfig(speed=0.3, beta_deg=b, mu=0.5, obstacle_wheels=["left_front"],
                               t_after=0.05)
        q0, v0 = initial_state(mbm, cfg)
        F.append(float(simulate_impact_mujoco(mbm, cfg, q0=q0, v0=v0).F_max_total))
    return tuple(F)


@produces("active.mujoco_ground_table")
def active_default_ground_mujoco():
    """The six-wheel rocker-bogie in MuJoCo with mu = 0.5 (tests/test_default_ground_mujoco)."""
    import roverimpact as ri
    from roverimpact.studies.stats import rank_correlation

    betas = GROUND_BETAS
    F = list(default_ground_mujoco_peaks())
    rows = []
    for label, contacts in (('"normal" (default)', {}),
                            ('"coulomb", mu = 0.5', {"ground": "coulomb", "mu": 0.5}),
                            ('"noslip"', {"ground": "noslip"})):
        with warnings.catch_warnings():  # "noslip" holds pulling wheels: the row shows it
            warnings.simplefilter("ignore", ri.exceptions.PullingContactWarning)
            T = [float(ri.energy_of(ri.Scenario.model_validate({
                "model": {"name": "rocker_bogie"}, "velocity": {"u": 0.3},
                "obstacle": {"wheel": "left_front", "beta_deg": b}, "contacts": contacts}))
                .T_c_minus) for b in betas]
        rows.append([label, f"{rank_correlation(T, F).spearman_rho:.3f}"])
    assert float(rows[0][1]) >= 0.95, "the default ground no longer ranks MuJoCo's force"
    return {"active.mujoco_ground_table": table(["contacts.ground", "Spearman vs MuJoCo F_max"],
                                                rows, ["---", "--:"])}


@produces("contact.restitution_table", "contact.cm_within")
def contact_restitution():
    """Achieved restitution of every law (restitution_table), and how close
    Carvalho-Martins stays to the typed e."""
    from roverimpact.contact import restitution_table

    df = restitution_table()
    rows = [[name, *(f"{x:.3f}" for x in row)] for name, row in df.iterrows()]
    cm = df.loc["carvalho-martins"]
    dev = float((cm - cm.index.to_numpy(dtype=float)).abs().max())
    return {"contact.restitution_table": table(
                ["law", *(f"e = {c:g}" for c in df.columns)], rows),
            "contact.cm_within": f"{math.ceil(100 * dev) / 100:.2f}"}


@produces("contact.hertz_duration")
def contact_hertz_duration():
    """Hertz contact time t_c = 2/(n+1) B(1/2, 1/(n+1)) delta_max / v at n = 3/2."""
    from scipy.special import beta

    n = 1.5
    return {"contact.hertz_duration": f"{2 / (n + 1) * beta(0.5, 1 / (n + 1)):.4f}"}


@produces("contact.closed_form_agreement")
def contact_closed_form_agreement():
    """Largest relative difference of the closed forms (peak force, max indentation,
    duration, e*) from impact_1dof over a small grid of laws and parameters."""
    from roverimpact.contact import LAWS, get_law, impact_1dof, predict

    worst = 0.0
    for name, cls in LAWS.items():
        if name == "kelvin-voigt":
            cases = [dict(k=1e5, e=e, m_eff=4.0) for e in (0.3, 0.9)]
        elif cls.elastic:
            cases = [dict(k=1e6, n=n) for n in (1.0, 1.5, 2.0)]
        else:
            cases = [dict(k=k, e=e) for k, e in ((1e6, 0.3), (1e8, 0.9))]
        for kw in cases:
            law = get_law(name, **kw)
            for m, v in ((4.0, 0.5), (30.0, 2.0)):
                p, r = predict(law, m, v), impact_1dof(law, m, v)
                for a, b in ((p.peak_force, r.peak_force),
                             (p.max_indentation, r.max_indentation),
                             (p.duration, r.duration),
                             (p.restitution_achieved, r.restitution_achieved)):
                    worst = max(worst, abs(a / b - 1.0))
    return {"contact.closed_form_agreement": f"~1e{round(math.log10(worst))}"}


# =========================================================================== models.md
@produces("models.rover2d_mass", "models.rb_prototype_mass", "models.rb_mer_mass",
          "models.rb_mer_axles", "models.rb_sojourner_mass", "models.rocker_clearance")
def models_masses():
    """Total masses of the built-in rovers, the MER preset's axle distance, the clearance
    of the rover2d rocker pivot."""
    import numpy as np
    import pinocchio as pin

    from roverimpact.models import rocker_bogie, rover2d
    from roverimpact.models.geometry import clearance

    out = {"models.rover2d_mass": f"{pin.computeTotalMass(rover2d().model):.0f}"}
    for preset, digits in (("prototype", 2), ("mer", 2), ("sojourner", 3)):
        out[f"models.rb_{preset}_mass"] = sig(pin.computeTotalMass(rocker_bogie(preset).model),
                                              digits)
    mer = rocker_bogie("mer")
    d = mer.model.createData()
    pin.framesForwardKinematics(mer.model, d, np.array(mer.params["q_nominal"]))
    x = {w.name: d.oMf[mer.model.getFrameId(w.frame)].translation[0] for w in mer.wheels}
    out["models.rb_mer_axles"] = sig(x["left_front"] - x["left_rear"], 2)
    rv = rover2d(suspension="rocker")
    out["models.rocker_clearance"] = f"{clearance(rv, np.array(rv.params['q_nominal'])):.2f}"
    return out


# =========================================================================== terrain.md
anchor("terrain.hf_example", "docs/terrain.md",
       r"print\(hf\.height\(0\.5, 1\.0\), hf\.normal\(0\.5, 1\.0\)\) +# (?P<v>.*?): exact")
anchor("terrain.step_example", "docs/terrain.md",
       r"print\(np\.degrees\(c\.beta\), c\.distance, c\.point\) +# (?P<v>.*)")


@produces("terrain.hf_example", "terrain.step_example", "terrain.step_beta",
          "terrain.step_travel")
def terrain_examples():
    """The code example of docs/terrain.md (paraboloid height field, 5 cm step)."""
    import numpy as np

    from roverimpact.models.terrain import FunctionTerrain, HeightField, first_rim_contact

    x = np.arange(0.0, 2.0001, 0.05)
    X, _ = np.meshgrid(x, x)
    hf = HeightField(0.1 * X**2, 0.05)
    h, n = float(hf.height(0.5, 1.0)), np.asarray(hf.normal(0.5, 1.0)) + 0.0
    step = FunctionTerrain(lambda x, y: np.where(x >= 0.5, 0.05, 0.0))
    c = first_rim_contact(step, centre=(0.2, 0, 0.1), axis=(0, 1, 0), radius=0.1,
                          heading=(1, 0, 0), max_travel=0.5)
    p = np.asarray(c.point) + 0.0
    beta = float(np.degrees(c.beta))
    r, hs = 0.1, 0.05                       # the closed forms the page states
    assert abs(beta - np.degrees(np.arccos((r - hs) / r))) < 1e-6
    assert abs(float(c.distance) - (0.3 - np.sqrt(2 * r * hs - hs**2))) < 1e-6
    return {
        "terrain.hf_example": f"{h:.3g}, ({n[0]:.3g}, {n[1] + 0.0:.3g}, {n[2]:.3g})",
        "terrain.step_example": (f"{beta:.1f} deg, {float(c.distance):.4f} m, "
                                 f"[{p[0]:.3g}, {p[1] + 0.0:.3g}, {p[2]:.3g}]"),
        "terrain.step_beta": f"{beta:.6f}",
        "terrain.step_travel": f"{float(c.distance):.6f}",
    }


@produces("terrain.rms_slope_1m", "terrain.rms_slope_5cm", "terrain.rock_table")
def terrain_synthetic():
    """Synthetic Mars terrain as examples/terrain_figure.py draws it (20 m x 8 m at 5 cm,
    seed 7): slopes of the surface alone, rocks at k = 0.05 and 0.2."""
    import numpy as np

    from roverimpact.models.terrain_synth import (
        fractal_surface,
        golombek_rapp_area,
        synthetic_mars,
    )

    size, spacing, seed = (20.0, 8.0), 0.05, 7
    g0 = fractal_surface((161, 401), spacing, np.random.default_rng(seed))
    out = {}
    for base, key in ((20, "terrain.rms_slope_1m"), (1, "terrain.rms_slope_5cm")):
        d = (g0[:, base:] - g0[:, :-base]) / (base * spacing)
        out[key] = f"{np.degrees(np.arctan(np.sqrt(np.mean(d**2)))):.1f}"
    rows = []
    for k in (0.05, 0.2):
        T = synthetic_mars(size, spacing, seed=seed, rock_abundance=k)
        (xa, xb), (ya, yb) = T.extent
        A = (xb - xa) * (yb - ya)
        model = golombek_rapp_area(0.1, k) - golombek_rapp_area(2.0, k)
        rows.append([f"{k:g}", f"{len(T.rocks)}", f"{100 * T.rocks.area_fraction(0.1, A):.2f} %",
                     f"{100 * model:.2f} %", f"{T.rocks.diameter.max():.2f} m"])
    out["terrain.rock_table"] = table(
        ["k", "rocks (0.1–2 m)", "area covered", "model F_k(0.1) − F_k(2)", "largest rock"],
        rows)
    return out


@produces("terrain.strip_rocks", slow=True)
def terrain_strip():
    """Rocks of the 1 km x 20 m strip of benchmarks/bench_terrain.py (seeded)."""
    from roverimpact.models.terrain_synth import synthetic_mars

    n = [len(synthetic_mars((1000.0, 20.0), 0.05, seed=seed, rock_abundance=k).rocks)
         for k, seed in ((0.05, 1), (0.2, 1))]
    return {"terrain.strip_rocks": " / ".join(f"{x:,}".replace(",", " ") for x in n)}



# =========================================================================== traverse.md
anchor("traverse.slope_step_example", "docs/traverse.md",
       r"print\(np\.degrees\(hit\.beta\), hit\.distance\) +# (?P<v>.*)")


@produces("traverse.slope_step_example", "traverse.slope_step_beta")
def traverse_example():
    """The code example of docs/traverse.md: a wheel on a 10 degree slope meets a 5 cm
    step of that slope (closed form 10 + arccos((r - h)/r) = 70 degrees)."""
    import numpy as np

    from roverimpact.models.terrain import FunctionTerrain
    from roverimpact.traverse.lookahead import first_contact_ahead

    a = np.radians(10.0)
    step = FunctionTerrain(lambda x, y: np.tan(a) * x
                           + np.where(x >= 0.5 / np.cos(a), 0.05 / np.cos(a), 0.0) + 0 * y)
    centre = 0.1 * np.array([-np.sin(a), 0.0, np.cos(a)])
    hit = first_contact_ahead(step, centre, (0, 1, 0), 0.1, (1, 0, 0), (0, 0, 0),
                              max_travel=0.6)
    beta = float(np.degrees(hit.beta))
    assert abs(beta - 70.0) < 1e-6
    # the top edge, along the slope from the support: 0.5/cos^2 a + h tan a, less the
    # rim's reach sqrt(2 r h - h^2) (tests/test_traverse_geometry.py)
    xi_edge = 0.5 / np.cos(a) ** 2 + 0.05 * np.tan(a)
    assert abs(float(hit.distance) - (xi_edge - np.sqrt(2 * 0.1 * 0.05 - 0.05**2))) < 1e-7
    return {"traverse.slope_step_example": f"{beta:.4f} deg, {float(hit.distance):.4f} m",
            "traverse.slope_step_beta": f"{beta:.4f}"}


@produces("traverse.tutorial_table", slow=True)
def traverse_tutorial():
    """The two traverses of examples/traverse_{sparse,rocky}.toml (as
    examples/traverse_figure.py runs them)."""
    from roverimpact.report.traverse import statistics
    from roverimpact.traverse.run import build_terrain, run_traverse
    from roverimpact.traverse.schema import load_traverse

    rows, stats = [], {}
    for tag in ("sparse", "rocky"):
        cfg = load_traverse(ROOT / "examples" / f"traverse_{tag}.toml")
        res = run_traverse(cfg)
        st = statistics(res.poses, res.wheels, res.segments, v_ref=cfg.drive.speed,
                        F_allow=cfg.limits.F_allow)
        stats[tag] = st
        if tag == "sparse":   # the page: its largest impact is at a flagged station
            worst = res.wheels.loc[res.wheels["F_model"].idxmax()]
            assert worst["wheel"].endswith("rear")
            assert res.poses.loc[res.poses["station"] == worst["station"],
                                 "wheel_speed_ratio"].iloc[0] > 2
        nseg = len(res.segments)
        rows.append([f"{cfg.terrain.rock_abundance:g}", f"{len(build_terrain(cfg.terrain).rocks)}",
                     f"{st['impacts']}", f"{st['F50']:.1f} / {st['F90']:.1f} / {st['F99']:.0f}",
                     f"{st['F_max']:.0f}", f"{st['over']}",
                     f"{round(st['segments_below_ref'] * nseg)} of {nseg}",
                     f"{st['segment_min']:.3f}", f"{st['failed']}", f"{st['fast_wheels']}"])
    a, b = stats["sparse"], stats["rocky"]     # the comparisons the page states
    assert b["F90"] > a["F90"] and b["F99"] > a["F99"] and b["over"] > a["over"]
    assert b["segments_below_ref"] > a["segments_below_ref"]
    return {"traverse.tutorial_table": table(
        ["k", "rocks", "impacts", "F_model median / 90 % / 99 % [N]", "largest F_model [N]",
         "impacts over 150 N", "2 m segments limited below 0.1 m/s", "lowest segment limit [m/s]",
         "stations without pose", "stations with a wheel > 2 u"], rows)}


@produces("traverse.check_n", "traverse.check_spearman_model", "traverse.check_spearman_tc",
          "traverse.check_model_sim", "traverse.check_pred_sim", "traverse.check_Fallow",
          "traverse.check_within", "traverse.check_limited", "traverse.check_ratio_median",
          "traverse.check_ratio_range", "traverse.check_capped", "traverse.check_nospeed",
          "traverse.check_closed_median", "traverse.check_closed_over", slow=True)
def traverse_check():
    """tests/test_traverse_physics.py's slow check: 50 seeded impacts simulated with the
    weight (Earth's gravity, preloaded supports)."""
    import numpy as np

    from roverimpact.traverse.validate import check_against_simulation

    c = check_against_simulation(50, seed=0)
    assert c.spearman_model >= 0.9 and c.within.mean() >= 0.95
    r = c.ratio_at_limit
    lim = ~c.capped & ~c.no_speed
    q = c.F_model / c.F_sim
    return {"traverse.check_n": "50",
            "traverse.check_spearman_model": f"{c.spearman_model:.3f}",
            "traverse.check_spearman_tc": f"{c.spearman:.3f}",
            "traverse.check_model_sim": (f"{np.median(q):.3f} ({np.min(q):.2f} to "
                                         f"{np.max(q):.2f})"),
            "traverse.check_pred_sim": f"{np.median(c.F_pred / c.F_sim):.2f}",
            "traverse.check_Fallow": f"{c.F_allow:.1f}",
            "traverse.check_within": f"{100 * c.within.mean():.0f}",
            "traverse.check_limited": f"{int(lim.sum())}",
            "traverse.check_ratio_median": f"{np.median(r[lim]):.3f}",
            "traverse.check_ratio_range": f"{np.min(r[lim]):.2f} to {np.max(r[lim]):.2f}",
            "traverse.check_capped": f"{int(c.capped.sum())}",
            "traverse.check_nospeed": f"{int(c.no_speed.sum())}",
            "traverse.check_closed_median": f"{np.median(c.ratio_at_closed):.2f}",
            "traverse.check_closed_over": f"{100 * (c.ratio_at_closed > 1.1).mean():.0f}"}


@produces("traverse.nog_spearman", "traverse.nog_within", "traverse.nog_pred_sim",
          "traverse.nog_closed_median", slow=True)
def traverse_check_no_gravity():
    """The same 50 impacts without gravity: the impact forces only."""
    import numpy as np

    from roverimpact.traverse.validate import check_against_simulation

    c = check_against_simulation(50, seed=0, gravity=0.0)
    ok = c.F_sim > 0
    return {"traverse.nog_spearman": f"{c.spearman:.3f}",
            "traverse.nog_within": f"{100 * c.within.mean():.0f}",
            "traverse.nog_pred_sim": f"{np.median(c.F_pred[ok] / c.F_sim[ok]):.2f}",
            "traverse.nog_closed_median": f"{np.median(c.ratio_at_closed):.2f}"}


# =========================================================================== robot-safety.md
anchor("safety.m_R", "docs/robot-safety.md",
       r"m_R = s\.iso_robot_mass\(20\.0, payload=1\.0\) +# (?P<v>\S+) kg")
anchor("safety.v_hand", "docs/robot-safety.md",
       r's\.max_transient_speed\("hands_fingers", m_R\) +# (?P<v>\S+) m/s')
anchor("safety.v_chest", "docs/robot-safety.md",
       r's\.max_transient_speed\("chest", m_R\) +# (?P<v>\S+) m/s')
anchor("safety.E_hand", "docs/robot-safety.md",
       r's\.transfer_energy\("hands_fingers"\) +# (?P<v>\S+) J')


@produces("safety.m_R", "safety.v_hand", "safety.v_chest", "safety.E_hand",
          "safety.n_regions", "safety.n_areas")
def safety_closed_forms():
    """The ISO/TS 15066 example of docs/robot-safety.md and the size of the tables."""
    import roverimpact.safety as s

    m_R = float(s.iso_robot_mass(20.0, payload=1.0))
    return {"safety.m_R": f"{m_R:g}",
            "safety.v_hand": f"{float(s.max_transient_speed('hands_fingers', m_R)):.3f}",
            "safety.v_chest": f"{float(s.max_transient_speed('chest', m_R)):.3f}",
            "safety.E_hand": f"{float(s.transfer_energy('hands_fingers')):.3f}",
            "safety.n_regions": f"{len(s.BODY_REGIONS)}",
            "safety.n_areas": f"{len(s.BODY_AREAS)}"}


@produces("safety.panda_M", "safety.panda_m_R", "safety.proximal_m", "safety.link7_m",
          "safety.v_iso_chest", "safety.v_exact_chest")
def safety_panda():
    """Panda at its ready pose, link centres of mass, payload 1 kg, chest
    (examples/robot_safety_panda.py draws the same table)."""
    import numpy as np

    from roverimpact.safety import READY_POSES, arm_effective_masses, load_arm

    model = load_arm("erd:panda")
    df = arm_effective_masses(model, np.array(READY_POSES["panda"]), payload=1.0,
                              region="chest").set_index("link")
    m_R = float(df["m_R_iso"].iloc[0])
    lo, hi = sorted(float(df.at[link, "m_min"]) for link in ("panda_link1", "panda_link2"))
    l7 = df.loc["panda_link7"]
    return {"safety.panda_M": f"{2 * (m_R - 1.0):.1f}",
            "safety.panda_m_R": f"{m_R:.1f}",
            "safety.proximal_m": f"{sig(lo, 1)}–{sig(hi, 2)}".replace("14000", "14 000"),
            "safety.link7_m": f"{l7['m_min']:.1f}–{l7['m_max']:.1f}",
            "safety.v_iso_chest": f"{l7['v_iso']:.2f}",
            "safety.v_exact_chest": f"{l7['v_exact_worst']:.2f}–{l7['v_exact_best']:.2f}"}


# =========================================================================== studies.md
anchor("studies.reproduce_cases", "docs/studies.md",
       r"roverimpact reproduce +# (?P<v>\d+) cases with simulation")
anchor("studies.quick_points", "docs/studies.md",
       r"roverimpact reproduce --quick +# smoke run, (?P<v>\d+) points per study")


@produces("studies.reproduce_cases", "studies.quick_points", "studies.one_swap_spearman")
def studies_counts():
    """Cases of the built-in paper studies, points per study with --quick, Spearman of five
    cases with one swapped neighbour pair."""
    from roverimpact.studies import agreement
    from roverimpact.studies.config import expand, load_study
    from roverimpact.studies.reproduce import BUILTIN_STUDIES, QUICK_POINTS, builtin_study_path

    n = 0
    for name in BUILTIN_STUDIES:
        st, _ = load_study(builtin_study_path(name))
        assert st.simulate, f"built-in study {name} does not simulate"
        n += len(expand(st))
    a = agreement([1, 2, 3, 4, 5], [1, 2, 4, 3, 5], n_boot=0)
    return {"studies.reproduce_cases": f"{n}", "studies.quick_points": f"{QUICK_POINTS}",
            "studies.one_swap_spearman": f"{a.spearman.value:g}"}


@produces("studies.large_table", "studies.sample_rows", "studies.max_chunk",
          "studies.min_chunk", "studies.cheap_chunk", "studies.n_bins", "studies.n_ybins",
          "studies.own_block", "studies.head_rows", "studies.map_min_values",
          "studies.map_max_cells")
def studies_scale():
    """Settings of large studies (issue 19): the table size above which the report
    streams, its statistics sample, the smallest and largest automatic chunk, the summary
    bins, the grids drawn as maps."""
    from roverimpact.report import summary
    from roverimpact.report.html import MAX_TABLE_ROWS
    from roverimpact.report.plots import MAP_MAX_CELLS, MAP_MIN_VALUES
    from roverimpact.studies.evaluate import _OwnCases
    from roverimpact.studies.sweep import CHEAP_AUTO_CHUNK, MAX_AUTO_CHUNK, MIN_AUTO_CHUNK

    def n(x: int) -> str:
        return f"{x:,}".replace(",", " ")

    return {"studies.large_table": n(summary.LARGE_TABLE),
            "studies.sample_rows": n(summary.SAMPLE_ROWS),
            "studies.max_chunk": n(MAX_AUTO_CHUNK), "studies.min_chunk": n(MIN_AUTO_CHUNK),
            "studies.cheap_chunk": n(CHEAP_AUTO_CHUNK),
            "studies.n_bins": n(summary.N_BINS),
            "studies.n_ybins": n(summary.N_YBINS), "studies.own_block": n(_OwnCases.BLOCK),
            "studies.head_rows": n(MAX_TABLE_ROWS), "studies.map_min_values": n(MAP_MIN_VALUES),
            "studies.map_max_cells": n(MAP_MAX_CELLS)}


_IND_ORDER = ("T_c_minus", "v_n", "T_n_total", "T_c_obstacle")


@produces("studies.engines_table", "studies.mj_spearman", "studies.mj_ratio",
          "studies.mj_ratio_worst", "studies.statements", "studies.fixed_tc",
          "studies.fixed_obst", slow=True)
def studies_engines():
    """`roverimpact reproduce` (full, both engines, n_boot = 1000, seed 0): Spearman of
    T_c^- and of the baselines with each engine's F_max, MuJoCo's F_max against the own
    one, the derived statements. Asserts the claim: MuJoCo's Spearman >= 0.95 on the
    three paper studies."""

    import numpy as np

    from roverimpact.studies.reproduce import BUILTIN_STUDIES

    res = _full_reproduction()
    rows, mj_rho, ratios, lines = [], [], [], []
    fixed = {}
    for sec in res.sections:
        label = BUILTIN_STUDIES[sec.folder.name]
        t = sec.table
        for e in sec.engines:
            c = e.comparison
            cells = []
            for col in _IND_ORDER:
                r = c.result(col)
                cells.append("same in every case" if r.constant
                             else f"{r.agreement.spearman.value:.3f}")
            rows.append([label, e.label, f"{c.n}", *cells])
            short = c.statements[-1].removeprefix("In short: ")
            lines.append(f"- {label}, {e.label}: {short}")
            if sec.folder.name.startswith("fixed"):
                fixed[e.engine] = (c.result("T_c_minus").agreement.spearman.value,
                                   c.result("T_c_obstacle").agreement.spearman.value)
        if sec.folder.name.startswith("detc"):
            mj = next(e for e in sec.engines if e.engine == "mujoco")
            rho = mj.agreement.spearman.value
            assert rho >= 0.95, f"{label}: MuJoCo Spearman {rho:.3f} < 0.95: rewrite the docs"
            mj_rho.append(rho)
            ok = ~(t["contact_whole_window"].to_numpy(bool)
                   | t["contact_whole_window_mujoco"].to_numpy(bool))
            q = (t["F_max_mujoco"] / t["F_max"] - 1.0).to_numpy(float)[ok]
            x = t[sec.x].to_numpy(float)[ok]
            ratios += [(v, label, sec.x, xv) for v, xv in zip(q, x, strict=True)]
    # the sentences of docs/studies.md after the table
    by = {(sec.folder.name, e.engine): e.comparison for sec in res.sections
          for e in sec.engines}
    for (stem, eng), c in by.items():
        rho = {col: c.result(col).agreement.spearman.value for col in _IND_ORDER}
        const = c.result("v_n").constant
        if stem.endswith("_beta"):
            assert rho["v_n"] < rho["T_c_minus"] and not const, (stem, eng, rho)
        else:
            assert const and c.result("T_n_total").constant, (stem, eng)
        if stem.startswith("detc"):
            assert rho["T_c_obstacle"] >= rho["T_c_minus"] - 1e-12, (stem, eng, rho)
        else:
            assert rho["T_c_obstacle"] < rho["T_c_minus"], (stem, eng, rho)
        if stem == "detc2015_fig2_beta":
            assert rho["T_c_obstacle"] > rho["T_c_minus"], (stem, eng, rho)
    worst = min(ratios, key=lambda r: -abs(r[0]))
    unit = {"obstacle.beta_deg": " deg", "model.params.h": " m"}
    where = (f"{worst[1]}, {worst[2].split('.')[-1].replace('_deg', '')} = "
             f"{worst[3]:g}{unit.get(worst[2], '')}")
    vals = np.array([r[0] for r in ratios])
    head = ["study", "engine", "n", "T_c^-", "v_n", "1/2 m_total v_n^2",
            "T_c^- (obstacle row only)"]
    return {
        "studies.engines_table": table(head, rows),
        "studies.mj_spearman": ", ".join(f"{r:.3f}" for r in mj_rho[:-1])
                               + f" and {mj_rho[-1]:.3f}",
        "studies.mj_ratio": f"{pct(vals.min(), 1)} … {pct(vals.max(), 1)} %",
        "studies.mj_ratio_worst": where,
        "studies.statements": "\n\n" + "\n".join(lines) + "\n\n",
        "studies.fixed_tc": f"{fixed['own'][0]:.3f} / {fixed['mujoco'][0]:.3f}",
        "studies.fixed_obst": f"{fixed['own'][1]:.3f} / {fixed['mujoco'][1]:.3f}",
    }


_REPRODUCTION: list = []


def _full_reproduction():
    """`reproduce()` into a temporary folder, run once per process (the tables stay in
    memory: the sections keep them)."""
    import tempfile

    from roverimpact.report.reproduce import reproduce

    if not _REPRODUCTION:
        with tempfile.TemporaryDirectory() as tmp:
            _REPRODUCTION.append(reproduce(Path(tmp) / "full"))
    return _REPRODUCTION[0]


@produces("contact.newtons_table", "contact.newtons_before", "contact.newtons_after_own",
          "contact.newtons_after_mj", "contact.newtons_mj_worst", "contact.newtons_mj_laws",
          "contact.newtons_excluded", "contact.newtons_rb90_low", slow=True)
def contact_newtons():
    """`roverimpact reproduce` (full): predicted / simulated peak force on the true impacts,
    per study and engine, the closed form F_pred (before) and F_pred_refined (after), and
    F_pred_refined_mujoco / F_max_mujoco. Asserts the claims of docs/contact.md: the
    refined prediction within 5% of the own engine on every true impact and the MuJoCo-law
    variant within 1% of MuJoCo."""

    from roverimpact.studies.reproduce import BUILTIN_STUDIES

    res = _full_reproduction()
    rows, before, own, mj, mjl, worst, excluded = [], [], [], [], [], [], set()

    def rng(r):
        return f"{r.median:.3f} ({r.min:.3f} … {r.max:.3f})"

    for sec in res.sections:
        label = BUILTIN_STUDIES[sec.folder.name]
        for e in sec.engines:
            rs = {r.prediction: r for r in e.ratios}
            a, b = rs["F_pred"], rs["F_pred_refined"]
            rows.append([label, e.label, f"{b.n}", rng(a), rng(b),
                         f"{b.n_within} of {b.n}"])
            before += [a.min, a.max]
            if e.engine == "own":
                own += [b.min, b.max]
                assert b.n_within == b.n, (label, b)
            else:
                mj += [b.min, b.max]
                c = rs["F_pred_refined_mujoco"]
                mjl += [c.min, c.max]
                assert max(abs(c.min - 1), abs(c.max - 1)) <= 0.01, (label, c)
            t = sec.table
            flag = t["not_an_impact"].to_numpy(bool)
            excluded |= {f"{label}: {sec.x.split('.')[-1].replace('_deg', '')} = {x:g}"
                         for x in t[sec.x][flag]}
            if e.engine == "mujoco":
                ok = ~flag & ~t["contact_whole_window_mujoco"].to_numpy(bool)
                q = (t["F_pred_refined"] / t["F_max_mujoco"]).to_numpy(float)
                for x, v in zip(t[sec.x][ok], q[ok], strict=True):
                    if abs(v - 1) > 0.05:    # docs/contact.md names the rocker-bogie
                        assert sec.folder.name == "detc2015_fig2_beta", (label, x, v)
                        worst.append(f"{sec.x.split('.')[-1].replace('_deg', '')} = {x:g} deg "
                                     f"({v:.3f})")
    rb = next(s.table for s in res.sections if s.folder.name == "detc2015_fig2_beta")
    at90 = rb[rb["obstacle.beta_deg"] == 90.0].iloc[0]
    rb90 = 1.0 - at90["F_pred"] / at90["F_max"]
    head = ["study", "engine", "true impacts", "F_pred / F_max: median (min … max)",
            "F_pred_refined / F_max", "refined within 5%"]

    def span(v):
        return f"{min(v):.3f} … {max(v):.3f}"

    return {
        "contact.newtons_table": table(head, rows),
        "contact.newtons_before": span(before),
        "contact.newtons_after_own": span(own),
        "contact.newtons_after_mj": span(mj),
        "contact.newtons_mj_worst": ", ".join(worst) if worst else "none",
        "contact.newtons_mj_laws": span(mjl),
        "contact.newtons_excluded": "; ".join(sorted(excluded)),
        "contact.newtons_rb90_low": f"{100 * rb90:.0f}",
    }


@produces("contact.newtons_mj_laws_table", "contact.newtons_mj_laws_span", slow=True)
def contact_newtons_mujoco_laws():
    """The refined prediction against MuJoCo running the scenario's own laws (engine
    ``mujoco_laws``) on every case of the four built-in studies of `roverimpact
    reproduce`; asserts the 5% of docs/contact.md on every true impact."""
    import numpy as np

    from roverimpact._io import read_toml
    from roverimpact.studies.config import apply_overrides, cases_of, study_from_dict
    from roverimpact.studies.evaluate import evaluate_case
    from roverimpact.studies.reproduce import BUILTIN_STUDIES, builtin_study_path

    rows, allr = [], []
    for stem, label in BUILTIN_STUDIES.items():
        data = read_toml(builtin_study_path(stem))
        study = study_from_dict(data)
        r = []
        for case in cases_of(study):
            out = evaluate_case(apply_overrides(data["base"], case.overrides),
                                simulate="mujoco_laws")
            assert out["sim_error"] == "", (stem, case.overrides, out["sim_error"])
            if not (out["not_an_impact"] or out["contact_whole_window"]):
                r.append(out["F_pred_refined"] / out["F_max"])
        r = np.asarray(r)
        assert np.all(np.abs(r - 1.0) <= 0.05), (stem, r)
        allr += list(r)
        rows.append([label, f"{len(r)}",
                     f"{np.median(r):.3f} ({r.min():.3f} … {r.max():.3f})",
                     f"{int(np.sum(np.abs(r - 1.0) <= 0.05))} of {len(r)}"])
    head = ["study", "true impacts", "F_pred_refined / F_max (MuJoCo, the scenario's laws)",
            "within 5%"]
    return {"contact.newtons_mj_laws_table": table(head, rows),
            "contact.newtons_mj_laws_span": f"{min(allr):.3f} … {max(allr):.3f}"}


@produces("contact.newtons_causes")
def contact_newtons_causes():
    """The causes of the closed form's deficit (docs/contact.md): the contact-space model
    without the weight (ground contacts unloaded, no gravity) and with the weight on a
    ground 1e4 times stiffer, against the full model, on both rovers (no simulation).
    Asserts the claims around the table: without the weight the prediction is low at
    30 deg, with a rigid ground it is high everywhere."""
    import numpy as np

    from roverimpact._io import read_toml
    from roverimpact.contact import get_law, peak_force
    from roverimpact.contact.reduced import reduced_impact
    from roverimpact.scenario import ImpactSetup, scenario_from_dict
    from roverimpact.simulate.newtons import reduced_system
    from roverimpact.studies.config import apply_overrides
    from roverimpact.studies.reproduce import builtin_study_path

    rows = []
    for stem, rover in (("detc2014_fig2_beta", "2-D rover"),
                        ("detc2015_fig2_beta", "rocker-bogie")):
        base = read_toml(builtin_study_path(stem))["base"]
        for beta in (30.0, 60.0, 90.0):
            sc = scenario_from_dict(apply_overrides(base, {"obstacle.beta_deg": beta}))
            setup = ImpactSetup.from_scenario(sc)
            en = setup.partition()
            rs = reduced_system(sc, setup)
            law = sc.contact_law.to_law()
            m = len(rs.labels)
            v_i = [rs.v_ref] * (m - 1) + [rs.v_n]
            full = rs.impact(law).peak_force
            g = sc.simulation.ground_contact
            stiff = get_law(g.name, k=1e4 * g.k, e=g.e)
            no_w = reduced_impact(rs.G, np.zeros(m), [rs.ground_law] * (m - 1) + [law], v_i,
                                  rs.rate0, t_max=rs.t_max, impact=m - 1,
                                  preload=False).peak_force
            rigid = reduced_impact(rs.G, rs.b, [stiff] * (m - 1) + [law], v_i, rs.rate0,
                                   t_max=rs.t_max, impact=m - 1).peak_force
            closed = float(peak_force(en.T_c_minus, en.v_n, law))
            assert rigid > full, (stem, beta)
            if beta == 30.0:
                assert no_w < closed < full, (stem, beta)
            rows.append([rover, f"{beta:g}", f"{closed / full:.3f}", f"{no_w / full:.3f}",
                         f"{rigid / full:.3f}", f"{full:.0f}"])
    head = ["rover", "beta [deg]", "closed form F_pred", "no weight",
            "weight, rigid ground", "F_pred_refined [N]"]
    return {"contact.newtons_causes": table(head, rows)}


@produces("contact.newtons_example")
def contact_newtons_example():
    """The DETC2014 rover against a 90 deg wall, no simulation: F_pred, F_pred_refined and
    the band of docs/contact.md (the example's printed numbers)."""
    from roverimpact._io import read_toml
    from roverimpact.studies.config import apply_overrides
    from roverimpact.studies.evaluate import evaluate_case
    from roverimpact.studies.reproduce import builtin_study_path

    base = read_toml(builtin_study_path("detc2014_fig2_beta"))["base"]
    sc = apply_overrides(base, {"obstacle.beta_deg": 90.0})
    sc["band"] = {"k": [5e6, 2e7], "e": [0.8, 1.0]}
    out = evaluate_case(sc)
    assert out["F_lo"] <= out["F_pred_refined"] <= out["F_hi"]
    return {"contact.newtons_example": (
        f"F_pred {out['F_pred']:.0f} N, F_pred_refined {out['F_pred_refined']:.0f} N "
        f"[{out['F_lo']:.0f}, {out['F_hi']:.0f}] N, not_an_impact {out['not_an_impact']}")}


# =========================================================================== reconfiguration.md
def _reconfiguration(file: str, prefix: str) -> dict[str, str]:
    from roverimpact import optimize_setting

    res = optimize_setting(ROOT / "examples" / file)
    spec = res.problem.spec
    n, b = res.nominal, res.best
    rows = []
    for name, (lo, hi) in spec.variables.items():
        note = ""
        if math.isclose(b.values[name], hi, rel_tol=1e-6):
            note = " (upper bound)"
        elif math.isclose(b.values[name], lo, rel_tol=1e-6):
            note = " (lower bound)"
        elif math.isclose(b.margin, spec.stability_margin, abs_tol=1e-6):
            note = " (stability margin active)"
        rows.append([f"{name} [m]", f"{n.values[name]:.2f}", f"{b.values[name]:.2f}{note}"])

    def bound(x, limit):
        return " (constraint active)" if math.isclose(x, limit, abs_tol=1e-6) else ""

    sims = ", ".join(f"{x:g}" for x in res.sim_betas_deg)
    rows += [
        [f"{spec.objective} T_c^- [J] (beta)", f"{n.objective:.3g} ({n.beta_worst_deg:g} deg)",
         f"{b.objective:.3g} ({b.beta_worst_deg:g} deg)"],
        ["predicted F_max [N]", f"{n.F_pred:.0f}", f"{b.F_pred:.0f}"],
        [f"simulated F_max [N] (beta = {sims} deg)", f"{res.F_sim_nominal:.0f}",
         f"{res.F_sim_best:.0f}"],
        ["stability margin [m]", f"{n.margin:.2f}",
         f"{b.margin:.2f}{bound(b.margin, spec.stability_margin)}"],
        ["clearance [m]", f"{n.clearance:.2f}",
         f"{b.clearance:.2f}{bound(b.clearance, spec.min_clearance)}"],
    ]
    return {f"{prefix}.table": table(["", "nominal", "optimum"], rows),
            f"{prefix}.drop_T": f"{100 * res.reduction:.0f}",
            f"{prefix}.drop_F": f"{100 * (1 - res.F_sim_best / res.F_sim_nominal):.0f}",
            f"{prefix}.n_sims": {2: "two", 4: "four", 6: "six"}.get(
                2 * len(res.sim_betas_deg), str(2 * len(res.sim_betas_deg)))}


@produces("reconf.rover2d.table", "reconf.rover2d.drop_T", "reconf.rover2d.drop_F",
          "reconf.rover2d.n_sims")
def reconfiguration_rover2d():
    """`roverimpact optimize examples/reconfigure_rover2d.toml`."""
    return _reconfiguration("reconfigure_rover2d.toml", "reconf.rover2d")


@produces("reconf.rb.table", "reconf.rb.drop_T", "reconf.rb.drop_F", "reconf.rb.n_sims")
def reconfiguration_rocker_bogie():
    """`roverimpact optimize examples/reconfigure_rocker_bogie.toml`."""
    return _reconfiguration("reconfigure_rocker_bogie.toml", "reconf.rb")


# =========================================================================== experiments.md
@functools.cache
def synthetic_comparison():
    """``(run_experiment(examples/experiment/trials.toml), its compare_with_model with the
    model scenario rover.toml)``, once per process: the model side simulates the 14
    conditions; tests/test_experiment.py checks the same two results."""
    from roverimpact.experiments import compare_with_model, run_experiment, scenario_model

    res = run_experiment(ROOT / "examples" / "experiment" / "trials.toml")
    return res, compare_with_model(res.trials, scenario_model(res.config.model, res.base_dir))


@produces("exp.n_recordings", "exp.table", "exp.baselines")
def experiments_synthetic():
    """The shipped synthetic trials (examples/experiment) against their truth and the model
    scenario rover.toml (k 20 % below the data's)."""
    import pandas as pd

    folder = ROOT / "examples" / "experiment"
    res, cmp = synthetic_comparison()
    truth = pd.read_csv(folder / "truth.csv")
    m = res.trials.merge(truth, on="file", suffixes=("", "_true"))
    assert len(m) == len(truth) == len(res.trials), "a trial failed or has no truth"

    def err(col):
        return float((m[col] / m[f"{col}_true"] - 1.0).abs().max())

    st, t = cmp.stats, cmp.table
    lo, hi = float(t["F_ratio"].min()), float(t["F_ratio"].max())
    rows = [
        ["peaks recovered vs truth", f"within {100 * err('F_peak'):.2f} % (test: 2 %)"],
        ["impulses / durations vs truth",
         f"{100 * err('impulse'):.2f} % / {100 * err('duration'):.1f} % (tests: 2 % / 5 %)"],
        ["measured peak vs model $T_c^-$", f"Kendall $\\tau$ = {st['kendall_tau_Tc']:.3f}, "
                                          f"Spearman $\\rho$ = {st['spearman_rho_Tc']:.3f}"],
        ["measured peak vs model $F_{max}$", f"Kendall $\\tau$ = {st['kendall_tau_Fmax']:.3f}, "
                                            f"Spearman $\\rho$ = {st['spearman_rho_Fmax']:.3f}"],
        ["measured peak vs the baselines", f"Spearman $\\rho$ = {st['spearman_rho_vn']:.3f} "
         f"($v_n$), {st['spearman_rho_Tn_total']:.3f} ($\\tfrac12 m_{{total}} v_n^2$), "
         f"{st['spearman_rho_Tc_obstacle']:.3f} ($T_c^-$, obstacle row only)"],
        ["measured / model $F_{max}$",
         f"{lo:.3f}–{hi:.3f} (1-DOF Hunt–Crossley scaling $(1/0.8)^{{2/5}}$ = "
         f"{(1 / 0.8) ** 0.4:.3f})"],
    ]
    short = cmp.indicators.statements[-1].removeprefix("In short: ")
    return {"exp.n_recordings": f"{len(res.trials)}", "exp.table": table(["", "value"], rows),
            "exp.baselines": short}


# =========================================================================== simulate.md
@produces("sim.conv_fine", "sim.conv_mid")
def simulate_convergence():
    """F_max of the 2-D rover (rocker, k = 1e7, 0.3 m/s) at the default tolerances and at
    (rtol, atol) = (1e-7, 1e-9), relative to (1e-10, 1e-12)."""
    from roverimpact.models import rover2d
    from roverimpact.simulate import SimulationConfig, initial_state, simulate_impact

    rv = rover2d(suspension="rocker")
    base = dict(speed=0.3, springs={"rocker": {"k": 50.0, "c": 2.0}}, t_after=0.03)
    q0, v0 = initial_state(rv, SimulationConfig(**base))

    def F(**integrator):
        cfg = SimulationConfig(**base, integrator=integrator)
        return simulate_impact(rv, cfg, q0=q0, v0=v0).F_max_total

    ref = F(rtol=1e-10, atol=1e-12)
    return {"sim.conv_fine": latex_pow(abs(F() / ref - 1.0)),
            "sim.conv_mid": latex_pow(abs(F(rtol=1e-7, atol=1e-9) / ref - 1.0))}


_KV = {"name": "kelvin-voigt", "k": 1e6, "c": 2000.0, "e": None, "n": None}


def _both_engines(mbm, cfg):
    from roverimpact.simulate import initial_state, simulate_impact
    from roverimpact.simulate.engines import simulate_impact_mujoco

    q0, v0 = initial_state(mbm, cfg)
    return (simulate_impact(mbm, cfg, q0=q0, v0=v0),
            simulate_impact_mujoco(mbm, cfg, q0=q0, v0=v0))


def _rovers():
    from roverimpact.models import rocker_bogie, rover2d

    return (("rover2d (rocker)", rover2d(suspension="rocker"),
             {"springs": {"rocker": {"k": 50.0, "c": 2.0}}}),
            ("rocker-bogie", rocker_bogie(), {}))


def _slider():
    """The 1-DoF slider of examples/mujoco_engine.py: 4 kg on an x slide, a 5 cm ball."""
    import numpy as np
    import pinocchio as pin

    from roverimpact.models.base import MultibodyModel, Wheel

    model = pin.Model()
    j = model.addJoint(0, pin.JointModelPX(), pin.SE3.Identity(), "x")
    model.appendBodyToJoint(j, pin.Inertia(4.0, np.zeros(3), 0.01 * np.eye(3)),
                            pin.SE3.Identity())
    model.addFrame(pin.Frame("ball", j, 0, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
    return MultibodyModel(model=model, name="slider", wheels=[Wheel("ball", "ball", 0.05)],
                          params={"q_nominal": [0.0]})


@produces("sim.mj_table", "sim.mj_example")
def simulate_mujoco_agreement():
    """examples/mujoco_engine.py, parts 1-2: Kelvin-Voigt contact, own engine vs MuJoCo."""
    from roverimpact.contact import get_law, predict
    from roverimpact.simulate import SimulationConfig, simulate_impact
    from roverimpact.simulate.engines import simulate_impact_mujoco

    slider = _slider()
    law = {"name": "kelvin-voigt", "k": 1e5, "c": 50.0, "e": None, "n": None}
    cfg = SimulationConfig(ground=False, speed=0.5, obstacle=law, t_after=0.05)
    own, mj = simulate_impact(slider, cfg), simulate_impact_mujoco(slider, cfg)
    closed = predict(get_law("kelvin-voigt", k=1e5, c=50.0), 4.0, 0.5).peak_force

    def d(a, b):
        return f"{pct(b / a - 1.0, 2)} %"

    rows = [[f"1-DoF slider, 4 kg at 0.5 m/s ($k = 10^5$, $c = 50$; closed form "
             f"{closed:.2f} N)", f"{own.F_max_total:.2f} N", f"{mj.F_max_total:.2f} N",
             d(own.F_max_total, mj.F_max_total)]]
    example = None
    for name, mbm, extra in _rovers():
        for beta in (30.0, 60.0, 90.0):
            cfg = SimulationConfig(speed=0.3, beta_deg=beta, obstacle=_KV, ground_contact=_KV,
                                   t_after=0.03, **extra)
            own, mj = _both_engines(mbm, cfg)
            rows.append([f"{name}, β = {beta:.0f}°", f"{own.F_max_total:.1f} N",
                         f"{mj.F_max_total:.1f} N", d(own.F_max_total, mj.F_max_total)])
            if name.startswith("rover2d") and beta == 60.0:
                example = f"{own.F_max_total:.1f} N, {mj.F_max_total:.1f} N"
    return {"sim.mj_table": table(["case", "own F_max", "MuJoCo F_max", "difference"], rows),
            "sim.mj_example": example}


anchor("sim.mj_example", "docs/simulate.md",
       r"print\(own\.F_max_total, mj\.F_max_total\) +# (?P<v>.*)$")


def _span(xs: list[float], digits: int = 1) -> str:
    return f"{pct(min(xs), digits)} … {pct(max(xs), digits)} %"


@produces("sim.mj_hc_rb", "sim.mj_hc_rb_worst", "sim.mj_hc_rv", "sim.mj_laws_rb",
          "sim.mj_laws_rv")
def simulate_mujoco_hunt_crossley():
    """examples/mujoco_engine.py, part 3: default Hunt-Crossley obstacle (k = 1e7, e = 0.5)
    through MuJoCo's equivalent Kelvin-Voigt, and the law itself in MuJoCo
    (``contact="laws"``); asserts the latter within 0.5% of the own engine."""
    from roverimpact.simulate import SimulationConfig, initial_state
    from roverimpact.simulate.engines import simulate_impact_mujoco_laws

    out = {}
    for name, mbm, _extra in _rovers():
        diff, laws = {}, {}
        for beta in (30.0, 45.0, 60.0, 90.0):
            cfg = SimulationConfig(speed=0.3, beta_deg=beta, obstacle={"k": 1e7, "e": 0.5},
                                   t_after=0.05)
            own, mj = _both_engines(mbm, cfg)
            diff[beta] = mj.F_max_total / own.F_max_total - 1.0
            q0, v0 = initial_state(mbm, cfg)
            ml = simulate_impact_mujoco_laws(mbm, cfg, q0=q0, v0=v0)
            laws[beta] = ml.F_max_total / own.F_max_total - 1.0
            assert abs(laws[beta]) < 5e-3, (name, beta, laws[beta])
        if name == "rocker-bogie":
            out["sim.mj_hc_rb"] = _span(list(diff.values()))
            out["sim.mj_hc_rb_worst"] = f"{max(diff, key=lambda b: abs(diff[b])):.0f}"
            out["sim.mj_laws_rb"] = _span(list(laws.values()), 2)
        else:
            out["sim.mj_hc_rv"] = _span(list(diff.values()))
            out["sim.mj_laws_rv"] = _span(list(laws.values()), 2)
    return out


@produces("sim.mj_equiv_duration")
def simulate_mujoco_equivalent_duration():
    """The equivalent Kelvin-Voigt keeps the law's peak force and restitution, not its
    contact duration: the slider (4 kg at 0.5 m/s) into Hertz (k = 1e7) and Hunt-Crossley
    (k = 1e7, e = 0.2, 0.5, 0.8) faces, duration in MuJoCo against the own engine."""
    from roverimpact.simulate import SimulationConfig, simulate_impact
    from roverimpact.simulate.engines import simulate_impact_mujoco

    diff = []
    for law in ({"name": "hertz", "k": 1e7}, *({"name": "hunt-crossley", "k": 1e7, "e": e}
                                              for e in (0.2, 0.5, 0.8))):
        cfg = SimulationConfig(ground=False, speed=0.5, obstacle=law, t_after=0.05)
        own, mj = simulate_impact(_slider(), cfg), simulate_impact_mujoco(_slider(), cfg)
        assert abs(mj.F_max_total / own.F_max_total - 1.0) < 0.01, law
        diff.append(mj.contact_duration / own.contact_duration - 1.0)
    return {"sim.mj_equiv_duration": f"{pct(-max(diff), 0, sign=False)}–"
                                     f"{pct(-min(diff), 0, sign=False)} %"}


@produces("sim.mj_hc_rb_one", "sim.mj_hc_rb_one_ground")
def simulate_mujoco_hunt_crossley_one_wheel():
    """examples/mujoco_engine.py, part 3b: the rocker-bogie with the obstacle in front of
    the left front wheel only (what a scenario's obstacle.wheel gives), default
    Hunt-Crossley obstacle and ground; and at beta = 90 the exact Kelvin-Voigt obstacle
    (k = 1e6, c = 500) on the Hunt-Crossley ground (its tangent line in MuJoCo)."""
    from roverimpact.models import rocker_bogie
    from roverimpact.simulate import SimulationConfig

    mbm = rocker_bogie()
    diff = []
    for beta in (30.0, 45.0, 60.0, 90.0):
        cfg = SimulationConfig(speed=0.3, beta_deg=beta, obstacle={"k": 1e7, "e": 0.5},
                               obstacle_wheels=["left_front"], t_after=0.05)
        own, mj = _both_engines(mbm, cfg)
        diff.append(mj.F_max_total / own.F_max_total - 1.0)
    kv = {"name": "kelvin-voigt", "k": 1e6, "c": 500.0, "e": None, "n": None}
    cfg = SimulationConfig(speed=0.3, beta_deg=90.0, obstacle=kv,
                           obstacle_wheels=["left_front"], t_after=0.05)
    own, mj = _both_engines(mbm, cfg)
    return {"sim.mj_hc_rb_one": _span(diff),
            "sim.mj_hc_rb_one_ground": f"{pct(mj.F_max_total / own.F_max_total - 1.0)} %"}


@produces("sim.mj_fric_within", "sim.mj_fric_rv", "sim.mj_fric_rb", "sim.mj_fric_ratio",
          slow=True)
def simulate_mujoco_friction():
    """examples/mujoco_engine.py, part 4: friction mu = 0.3, Kelvin-Voigt, beta = 45, 90."""
    from roverimpact.simulate import SimulationConfig

    out, ratios, worst = {}, [], 0.0
    for name, mbm, _extra in _rovers():
        diff = []
        for beta in (45.0, 90.0):
            cfg = SimulationConfig(speed=0.3, beta_deg=beta, obstacle=_KV, ground_contact=_KV,
                                   mu=0.3, t_after=0.02)
            own, mj = _both_engines(mbm, cfg)
            diff.append(mj.F_max_total / own.F_max_total - 1.0)
            col = f"obstacle_{own.contact_wheel}_ft"
            ratios.append(own.history[col].max() / mj.history[col].max())
        worst = max(worst, *map(abs, diff))
        out["sim.mj_fric_rb" if name == "rocker-bogie" else "sim.mj_fric_rv"] = _span(diff)
    out["sim.mj_fric_within"] = f"{math.ceil(100 * worst):.0f}"
    out["sim.mj_fric_ratio"] = f"{sig(min(ratios), 2)}–{sig(max(ratios), 2)}"
    return out


def _slope_scenario():
    import numpy as np

    import roverimpact as ri

    a = np.radians(10.0)
    return ri.Scenario.model_validate({
        "model": {"name": "rover2d"}, "velocity": {"u": 0.3},
        "obstacle": {"wheel": "front", "beta_deg": 45.0},
        "terrain": {"plane": {"normal": [-np.sin(a), 0.0, np.cos(a)]}},
        "simulation": {"t_after": 0.05}})


@produces("sim.terrain_example", "sim.terrain_tilted", "sim.terrain_tc_sim",
          "sim.terrain_tc_ind", "sim.terrain_T_sim", "sim.terrain_T_ind",
          "sim.terrain_t_contact")
def simulate_terrain():
    """examples/simulate_on_terrain.py, parts 1-2: rover2d up a 10 deg slope; the flat run
    with gravity tilted; the simulated vs the indicator's T_c^- of the sloped scenario."""
    import numpy as np

    import roverimpact as ri
    from roverimpact.models import rover2d
    from roverimpact.models.terrain import PlaneTerrain
    from roverimpact.simulate import run, simulate_impact, simulate_scenario

    a = np.radians(10.0)
    rv = rover2d(suspension="rocker")
    cfg = ri.SimulationConfig(speed=0.3, beta_deg=60, obstacle={"k": 1e7, "e": 0.5},
                              springs={"rocker": {"k": 50.0, "c": 2.0}})
    r = simulate_impact(rv, cfg, terrain=PlaneTerrain((0, 0, 0), (-np.sin(a), 0, np.cos(a))))
    tilted = run.gravity_vector
    run.gravity_vector = lambda g: g * np.array([-np.sin(a), 0.0, -np.cos(a)])
    try:
        f = simulate_impact(rv, cfg.model_copy(update={"beta_deg": 50.0}),
                            terrain=PlaneTerrain())
    finally:
        run.gravity_vector = tilted
    assert abs(f.F_max_total / r.F_max_total - 1) < 1e-6
    assert abs(f.T_c_minus / r.T_c_minus - 1) < 1e-6
    sc = _slope_scenario()
    s, e = simulate_scenario(sc), ri.energy_of(sc)
    return {"sim.terrain_example": f"{r.F_max_total:.1f} N, {r.T_c_minus:.4f} J",
            "sim.terrain_tilted": f"{f.F_max_total:.1f} N and {f.T_c_minus:.4f} J",
            "sim.terrain_tc_sim": f"{s.T_c_minus:.4f}",
            "sim.terrain_tc_ind": f"{float(e.T_c_minus):.4f}",
            "sim.terrain_T_sim": f"{s.T_minus:.3f}", "sim.terrain_T_ind": f"{float(e.T):.3f}",
            "sim.terrain_t_contact": f"{1e3 * s.stats['t_contact']:.1f}"}


anchor("sim.terrain_example", "docs/simulate.md",
       r"print\(r\.F_max_total, r\.T_c_minus\) +# (?P<v>.*)$")


@produces("sim.terrain_bumps", slow=True)
def simulate_terrain_bumps():
    """examples/simulate_on_terrain.py, part 3: roverimpact simulate
    examples/rocker_bogie_on_bumps.toml (a Python-function terrain: ~5 s)."""
    import roverimpact as ri
    from roverimpact.simulate import simulate_scenario

    sc = ri.load_scenario(ROOT / "examples" / "rocker_bogie_on_bumps.toml")
    b = simulate_scenario(sc)
    return {"sim.terrain_bumps": f"F_max = {b.F_max_total:.1f} N, T_c^- = "
                                 f"{b.T_c_minus:.4f} J (the indicator's, at the posed start: "
                                 f"{float(ri.energy_of(sc).T_c_minus):.4f} J)"}


# =========================================================================== trust.md
@produces("trust.n_cells", "trust.n_betas", "trust.n_sims", "trust.quick_sims",
          "trust.tc_table")
def trust_setup():
    """Size of the default and quick trust maps; T_c^- of the built-in configurations."""
    from roverimpact.studies.config import apply_overrides, expand, study_from_dict
    from roverimpact.studies.evaluate import evaluate_case
    from roverimpact.studies.trust import TrustGrid, builtin_study

    cells = len(TrustGrid().cells())
    study = study_from_dict(builtin_study())
    configs = expand(study)
    quick = len(TrustGrid.quick().cells()) * len(expand(study_from_dict(builtin_study(True))))
    rows = []
    for case in configs:
        e = evaluate_case(apply_overrides(study.base, case.overrides))
        rows.append([f"{case.overrides['obstacle.beta_deg']:g}", f"{e['T_c_minus']:.4f}",
                     f"{e['v_n']:.3f}", f"{e['m_eff']:.2f}"])
    return {"trust.n_cells": f"{cells}", "trust.n_betas": f"{len(configs)}",
            "trust.n_sims": f"{cells * len(configs)}", "trust.quick_sims": f"{quick}",
            "trust.tc_table": table(["beta [deg]", "T_c^- [J]", "v_n [m/s]", "m_eff [kg]"],
                                    rows)}


@produces("trust.n_perfect", "trust.n_soft", "trust.tau_soft", "trust.rho_soft",
          "trust.soft_cells", "trust.tau_min", "trust.flip_pair", "trust.flip_gap",
          "trust.flip_dF", "trust.soft_sat", "trust.F_soft", "trust.F_stiff", slow=True)
def trust_results():
    """`roverimpact trust` with the defaults (252 simulations): where tau < 1 and why."""
    import itertools
    import tempfile

    import numpy as np

    from roverimpact.studies.trust import trust_map

    with tempfile.TemporaryDirectory() as tmp:
        res = trust_map(None, Path(tmp) / "trust")
    t, r = res.table, res.results
    assert (t["n_failed"] == 0).all() and (t["n"] == res.n_configs).all()
    perfect = t[np.isclose(t["tau"], 1.0)]
    soft = t[~np.isclose(t["tau"], 1.0)]
    assert soft["tau"].nunique() == 1 and soft["spearman"].nunique() == 1, \
        "the imperfect cells have different tau: rewrite the text of docs/trust.md"
    ks = sorted(soft["k"].unique())
    assert len(ks) == 1, "imperfect cells at several k: rewrite docs/trust.md"
    parts = []
    for law in dict.fromkeys(soft["law"]):
        es = ", ".join(f"{e:g}" for e in sorted(soft[soft["law"] == law]["e"]))
        parts.append(f"{law} (e = {es})")
    # the discordant pairs of every imperfect cell
    beta = "obstacle.beta_deg"
    pairs, dF = set(), []
    for _, c in soft.iterrows():
        sel = r[(r["contact_law.name"] == c["law"]) & np.isclose(r["contact_law.k"], c["k"])
                & np.isclose(r["contact_law.e"], c["e"])].set_index(beta)
        for a, b in itertools.combinations(sel.index, 2):
            if (sel.at[a, "T_c_minus"] - sel.at[b, "T_c_minus"]) * \
                    (sel.at[a, "F_max"] - sel.at[b, "F_max"]) < 0:
                pairs.add(tuple(sorted((a, b))))
                dF.append(abs(sel.at[a, "F_max"] - sel.at[b, "F_max"]))
    assert len(pairs) == 1, f"discordant pairs {pairs}: rewrite docs/trust.md"
    (a, b), = pairs
    T = r.groupby(beta)["T_c_minus"].first()
    gap = abs(T[a] - T[b]) / min(T[a], T[b])
    # soft-cell saturation: F_max of the imperfect cells for beta >= 35 deg
    sat = r[r[beta] >= 35.0].merge(soft[["law", "k", "e"]], left_on=[
        "contact_law.name", "contact_law.k", "contact_law.e"], right_on=["law", "k", "e"])
    per_cell = sat.groupby(["law", "k", "e"])["F_max"].agg(lambda f: f.max() / f.min() - 1)
    k_lo, k_hi = r["contact_law.k"].min(), r["contact_law.k"].max()
    F_lo = r[r["contact_law.k"] == k_lo]["F_max"]
    F_hi = r[r["contact_law.k"] == k_hi]["F_max"]
    return {
        "trust.n_perfect": f"{len(perfect)}", "trust.n_soft": f"{len(soft)}",
        "trust.tau_soft": f"{soft['tau'].iloc[0]:.3f}",
        "trust.rho_soft": f"{soft['spearman'].iloc[0]:.3f}",
        "trust.soft_cells": ", ".join(parts) + f", all at k = {ks[0]:.0e}".replace("e+0", "e"),
        "trust.tau_min": f"{t['tau'].min():.3f}",
        "trust.flip_pair": f"{a:g} and {b:g} deg",
        "trust.flip_gap": f"{100 * gap:.1f}",
        "trust.flip_dF": f"{min(dF):.2f}–{max(dF):.2f}",
        "trust.soft_sat": f"{sat['F_max'].min():.0f}–{sat['F_max'].max():.0f} N, each cell "
                          f"within {100 * per_cell.max():.1f} %",
        "trust.F_soft": f"{F_lo.min():.0f}–{F_lo.max():.0f}",
        "trust.F_stiff": f"{F_hi.min():.0f}–{F_hi.max():.0f}",
    }


# =========================================================================== main
def placements(texts: dict[str, str]) -> tuple[dict[str, list[tuple[str, int, int]]], list[str]]:
    """Where each key is quoted: key -> [(file, start, end) of its text], and problems
    (unknown keys, unbalanced markers, anchors that do not match exactly once)."""
    where: dict[str, list[tuple[str, int, int]]] = {}
    problems = []
    owners = key_owner()
    for name, text in texts.items():
        found = list(MARKER.finditer(text))
        if len(OPEN.findall(text)) != len(found) or len(CLOSE.findall(text)) != len(found):
            problems.append(f"{name}: unbalanced or nested <!-- num: --> markers")
        for m in found:
            if OPEN.search(m.group("body")):
                problems.append(f"{name}: marker {m.group('key')} contains another marker")
            where.setdefault(m.group("key"), []).append((name, m.start("body"), m.end("body")))
    for key, (name, pattern) in ANCHORS.items():
        hits = list(re.finditer(pattern, texts.get(name, ""), flags=re.M))
        if len(hits) != 1:
            problems.append(f"{name}: anchor {key} matches {len(hits)} times (want 1)")
            continue
        where.setdefault(key, []).append((name, hits[0].start("v"), hits[0].end("v")))
    for key, spots in where.items():
        if key not in owners:
            problems.append(f"{spots[0][0]}: marker num:{key} is not produced by "
                            "tools/doc_numbers.py (stale or misspelt)")
    for key in owners:
        if key not in where:
            problems.append(f"key {key} ({owners[key].name}) is quoted nowhere")
    return where, problems


def read_docs(root: Path = ROOT) -> dict[str, str]:
    return {str(p.relative_to(root)): p.read_text() for p in doc_files(root)}


def compute(*, slow: bool = False, only: set[str] | None = None,
            verbose: bool = False) -> dict[str, str]:
    """Run the producers (cheap ones, all with ``slow``; or those of the keys ``only``)."""
    out: dict[str, str] = {}
    for p in PRODUCERS.values():
        if only is not None:
            if not only.intersection(p.keys):
                continue
        elif p.slow and not slow:
            continue
        t0 = time.perf_counter()
        got = p.fn()
        if set(got) != set(p.keys):
            raise RuntimeError(f"producer {p.name} returned {sorted(got)}, declared "
                               f"{sorted(p.keys)}")
        out.update(got)
        if verbose:
            print(f"  {p.name:32s} {time.perf_counter() - t0:6.2f} s", file=sys.stderr)
    return out


@dataclass(frozen=True)
class Mismatch:
    file: str
    key: str
    quoted: str
    fresh: str

    def __str__(self):
        if "\n" in self.quoted or "\n" in self.fresh:
            import difflib

            diff = "\n".join(difflib.unified_diff(self.quoted.strip().splitlines(),
                                                  self.fresh.strip().splitlines(),
                                                  "docs", "fresh", lineterm=""))
            return f"{self.file}: {self.key}:\n{diff}"
        return f"{self.file}: {self.key}: docs say {self.quoted!r}, a fresh run gives " \
               f"{self.fresh!r}"


def check(*, slow: bool = False, texts: dict[str, str] | None = None,
          fresh: dict[str, str] | None = None, verbose: bool = False):
    """Compare the quoted texts with a fresh run: (mismatches, problems)."""
    texts = read_docs() if texts is None else texts
    where, problems = placements(texts)
    fresh = compute(slow=slow, verbose=verbose) if fresh is None else fresh
    bad = []
    for key, spots in where.items():
        if key not in fresh:
            continue
        for name, a, b in spots:
            if texts[name][a:b] != fresh[key]:
                bad.append(Mismatch(name, key, texts[name][a:b], fresh[key]))
    return bad, problems


def write(*, slow: bool = False, only: set[str] | None = None, verbose: bool = False,
          root: Path = ROOT, fresh: dict[str, str] | None = None) -> list[str]:
    """Replace the quoted texts by fresh ones (computed unless ``fresh`` is given); returns
    the files changed."""
    texts = read_docs(root)
    where, problems = placements(texts)
    problems = [p for p in problems if "is quoted nowhere" not in p]
    if problems:
        raise SystemExit("fix these first:\n  " + "\n  ".join(problems))
    if fresh is None:
        fresh = compute(slow=slow, only=only, verbose=verbose)
    edits: dict[str, list[tuple[int, int, str]]] = {}
    for key, spots in where.items():
        if key in fresh:
            for name, a, b in spots:
                edits.setdefault(name, []).append((a, b, fresh[key]))
    changed = []
    for name, ed in edits.items():
        text = texts[name]
        for a, b, new in sorted(ed, reverse=True):
            text = text[:a] + new + text[b:]
        if text != texts[name]:
            (root / name).write_text(text)
            changed.append(name)
    return changed


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--check", action="store_true", help="compare the docs with a fresh run")
    g.add_argument("--write", action="store_true", help="rewrite the docs with a fresh run")
    g.add_argument("--list", action="store_true", help="list the keys")
    ap.add_argument("--slow", action="store_true", help="include the expensive producers")
    ap.add_argument("--only", nargs="+", metavar="KEY", help="only the producers of these keys")
    a = ap.parse_args(argv)
    if a.list:
        where, problems = placements(read_docs())
        for key, p in key_owner().items():
            spot = where.get(key, [("(nowhere)", 0, 0)])[0][0]
            print(f"{key:34s} {spot:24s} {'slow' if p.slow else 'cheap':5s} {p.name}")
        for pr in problems:
            print("problem:", pr)
        return 1 if problems else 0
    if a.write:
        changed = write(slow=a.slow, only=set(a.only) if a.only else None, verbose=True)
        print("rewritten:", ", ".join(changed) if changed else "nothing (all up to date)")
        return 0
    fresh = compute(slow=a.slow, only=set(a.only) if a.only else None, verbose=True)
    bad, problems = check(fresh=fresh)
    for pr in problems:
        print("problem:", pr)
    for m in bad:
        print(m)
    print(f"{len(fresh)} numbers checked, {len(bad)} differ, {len(problems)} problems")
    return 1 if bad or problems else 0


if __name__ == "__main__":
    sys.exit(main())
