"""Issue #18's acceptance check for the default ground: the six-wheel rocker-bogie rolling
at 0.3 m/s, all wheels on the ground, a face ahead of the left front wheel, beta 10-90 deg,
run in MuJoCo with Coulomb friction mu = 0.5 (the built-in model exported to MJCF by
:mod:`roverimpact.models.export_mjcf`, Hunt-Crossley through the equivalent Kelvin-Voigt,
friction as MuJoCo's pyramidal cone with a capped viscous slope: see
:mod:`roverimpact.simulate.engines.mujoco`).

With the *default* scenario settings (``ground = "normal"``, the automatic active set)
T_c^- ranks MuJoCo's first-impact peak force with Spearman >= 0.95 (1.0 measured); so do
the Coulomb rows with the same mu. Bilateral no-slip rows rank worse (0.93 measured): they
are not the default. The engine and the contact model are MuJoCo's; the model export
and the start state are roverimpact's (tests/test_engine_mujoco.py checks the export's
M(q) against ``mj_fullM``).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import spearmanr

import roverimpact as ri

pytest.importorskip("mujoco")

from .doctool import doc_numbers

BETAS = (10.0, 20.0, 30.0, 45.0, 60.0, 70.0, 80.0, 90.0)


def _T_c(beta, **contacts):
    sc = ri.Scenario.model_validate({
        "model": {"name": "rocker_bogie"}, "velocity": {"u": 0.3},
        "obstacle": {"wheel": "left_front", "beta_deg": beta}, "contacts": contacts})
    return float(ri.energy_of(sc).T_c_minus)


@pytest.fixture(scope="module")
def mujoco_peaks():
    """The eight MuJoCo runs (rocker_bogie(), speed 0.3 m/s, mu = 0.5, the face ahead of
    left_front, t_after = 0.05 s), run once per session: tools/doc_numbers.py runs the same
    for the table of docs/active-set.md (tests/test_doc_numbers.py)."""
    dn = doc_numbers()
    assert dn.GROUND_BETAS == BETAS
    return np.array(dn.default_ground_mujoco_peaks())


# "noslip" holds wheels that would pull (the warning is right): it ranks worse
@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.PullingContactWarning")
def test_default_ground_ranks_mujocos_peak_force_with_friction(mujoco_peaks):
    T_default = [_T_c(b) for b in BETAS]
    T_coulomb = [_T_c(b, ground="coulomb", mu=0.5) for b in BETAS]
    T_noslip = [_T_c(b, ground="noslip") for b in BETAS]
    rho = {k: spearmanr(T, mujoco_peaks).statistic
           for k, T in (("default", T_default), ("coulomb", T_coulomb), ("noslip", T_noslip))}
    assert rho["default"] >= 0.95, rho
    assert rho["coulomb"] >= 0.95, rho
    assert rho["default"] >= rho["noslip"], rho
