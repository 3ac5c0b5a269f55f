"""Achieved-restitution table: which laws honour the e the user types."""

from __future__ import annotations

import pandas as pd

from ._closed_form import achieved_restitution
from ._laws import LAWS, KelvinVoigt, get_law

__all__ = ["NOMINAL_E", "restitution_table"]

#: Nominal coefficients of restitution of the table.
NOMINAL_E = (0.1, 0.3, 0.5, 0.7, 0.9)


def restitution_table(e_values=NOMINAL_E, laws=None, *, n: float = 1.5) -> pd.DataFrame:
    """Restitution e* each damped law really produces for each nominal e.

    Independent of k, m_eff and v_n for the Hunt–Crossley family (it depends on
    z = chi v_i only) and for Kelvin–Voigt with c set from e and the same mass.

    Parameters
    ----------
    e_values : sequence of float
        Nominal e (columns).
    laws : sequence of str, optional
        Law names (rows); default: every dissipative law of :data:`LAWS`.
    n : float
        Exponent of the family laws (e* does not depend on it).

    Returns
    -------
    pandas.DataFrame
        Index: law name; columns: nominal e; values: achieved e*.
    """
    names = [k for k in LAWS if k != "hertz"] if laws is None else list(laws)
    rows = {}
    for name in names:
        row = []
        for e in e_values:
            if LAWS.get(name) is KelvinVoigt:
                law = get_law(name, k=1.0, e=e, m_eff=1.0)
                row.append(float(achieved_restitution(law, 1.0)))
            else:
                law = get_law(name, k=1.0, e=e, n=None if name == "hertz" else n)
                row.append(float(achieved_restitution(law)))
        rows[name] = row
    df = pd.DataFrame.from_dict(rows, orient="index", columns=[float(e) for e in e_values])
    df.index.name = "law"
    df.columns.name = "nominal e"
    return df
