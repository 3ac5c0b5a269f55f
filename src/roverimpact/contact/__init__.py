"""Contact-force laws and closed-form impact predictions from (m_eff, v_n) or T_c^-.

See docs/contact.md. Public names:

- laws: :class:`ContactLaw` (abstract), :class:`KelvinVoigt`, :class:`Hertz` and the
  Hunt–Crossley family (:class:`HuntCrossley`, :class:`LankaraniNikravesh`,
  :class:`HerbertMcWhannell`, :class:`LeeWang`, :class:`Gonthier`, :class:`Flores`,
  :class:`ZhiyingQishao`, :class:`CarvalhoMartins`); registry :data:`LAWS`, :func:`get_law`.
"""

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

__all__ = [
    "LAWS",
    "CarvalhoMartins",
    "ContactLaw",
    "Flores",
    "Gonthier",
    "HerbertMcWhannell",
    "Hertz",
    "HuntCrossley",
    "HuntCrossleyFamily",
    "KelvinVoigt",
    "LankaraniNikravesh",
    "LeeWang",
    "ZhiyingQishao",
    "get_law",
]
