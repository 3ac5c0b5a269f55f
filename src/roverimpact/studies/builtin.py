"""The built-in studies (``roverimpact reproduce``): their names and the paper figures they
reproduce. Apart from :mod:`roverimpact.studies.reproduce`, which runs them, so that code
that only names them (the report of a results folder) does not import the study
machinery, the evaluator and the simulators with it.
"""

from __future__ import annotations

__all__ = ["BUILTIN_STUDIES"]

#: Built-in studies: file stem -> the paper figure it reproduces.
BUILTIN_STUDIES = {
    "detc2014_fig2_beta": "DETC2014-35554 Fig. 2",
    "detc2014_fig3_com_height": "DETC2014-35554 Fig. 3",
    "detc2015_fig2_beta": "DETC2015-47747 Fig. 2",
    "fixed_vn_configuration": "Fixed v_n: h x rocker pivot",
}
