"""Contact-force laws and closed-form impact predictions from (m_eff, v_n) or T_c^-.

See docs/contact.md. Public names:

- laws: :class:`ContactLaw` (abstract), :class:`KelvinVoigt`, :class:`Hertz` and the
  Hunt–Crossley family (:class:`HuntCrossley`, :class:`LankaraniNikravesh`,
  :class:`HerbertMcWhannell`, :class:`LeeWang`, :class:`Gonthier`, :class:`Flores`,
  :class:`ZhiyingQishao`, :class:`CarvalhoMartins`); registry :data:`LAWS`, :func:`get_law`.
"""

from ._closed_form import (
    Prediction,
    achieved_restitution,
    hertz_duration_factor,
    peak_force,
    predict,
)
from ._impact import ImpactHistory, impact_1dof
from ._laws import (
    LAWS,
    CarvalhoMartins,
    ContactLaw,
    Flores,
    Gonthier,
    HerbertMcWhannell,
    Hertz,
    HuntCrossley,
    HuntCrossleyFamily,
    KelvinVoigt,
    LankaraniNikravesh,
    LeeWang,
    ZhiyingQishao,
    get_law,
)
from ._stiffness import effective_modulus, hertz_stiffness, line_contact_stiffness
from ._table import NOMINAL_E, restitution_table

__all__ = [
    "LAWS",
    "NOMINAL_E",
    "CarvalhoMartins",
    "ContactLaw",
    "Flores",
    "Gonthier",
    "HerbertMcWhannell",
    "Hertz",
    "HuntCrossley",
    "HuntCrossleyFamily",
    "ImpactHistory",
    "KelvinVoigt",
    "LankaraniNikravesh",
    "LeeWang",
    "Prediction",
    "ZhiyingQishao",
    "achieved_restitution",
    "effective_modulus",
    "get_law",
    "hertz_duration_factor",
    "hertz_stiffness",
    "impact_1dof",
    "line_contact_stiffness",
    "peak_force",
    "predict",
    "restitution_table",
]
