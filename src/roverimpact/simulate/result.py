"""Result of a compliant-contact impact simulation."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from ..exceptions import InputError


@dataclass(frozen=True)
class SimulationResult:
    """Outcome of :func:`~roverimpact.simulate.simulate_impact`.

    Attributes
    ----------
    history : pandas.DataFrame
        One row per accepted integrator step: ``t`` [s], ``q_<i>``, ``v_<i>`` and for every
        wheel/plane pair ``<plane>_<wheel>_fn`` (normal force, N), ``..._ft`` (friction
        force magnitude, N), ``..._delta`` (indentation, m). Time is 0 at the first
        obstacle contact (negative before).
    F_max : dict
        Peak normal force [N] of each obstacle contact (keys ``obstacle_<wheel>``), refined
        between steps on the integrator's dense output.
    t_peak : dict
        Time of each peak [s].
    F_max_total : float
        Peak of the summed obstacle normal force [N] (the papers' f_n).
    impulse : dict
        Normal impulse of each obstacle contact, integral of f_n dt [N s].
    contact_duration : float
        From first obstacle contact to separation (or to the end of the run) [s].
    separated : bool
        Whether every wheel left the obstacle before the end of the run.
    T_minus, T_plus : float
        Kinetic energy at first contact and at the end of the run [J].
    E_minus, E_plus : float
        Total mechanical energy (kinetic + gravity + springs + elastic contact) [J].
    q_minus, v_minus : (nq,), (nv,) ndarray
        State at the instant of first obstacle contact (gap = 0).
    q_plus, v_plus : ndarray
        State at separation (or at the end of the run).
    T_c_minus : float
        Effective kinetic energy of ``(q_minus, v_minus)`` [J].
    m_eff : float
        Effective mass along the obstacle normal, the obstacle row alone (the other rows
        of ``T_c_minus`` free: ``m_eff_free`` of :func:`~roverimpact.energy_of`), [kg].
        With the other rows held, ``2 T_c_minus / v_n**2``.
    v_n : float
        Normal approach speed of the first obstacle contact [m/s].
    contact_wheel : str
        Wheel that touched the obstacle first.
    A_rows : list of str
        Labels of the constraint rows used for ``T_c_minus``.
    stats : dict
        Integrator statistics (``nfev``, ``steps``, ``segments``).
    """

    history: pd.DataFrame
    F_max: dict
    t_peak: dict
    F_max_total: float
    impulse: dict
    contact_duration: float
    separated: bool
    T_minus: float
    T_plus: float
    E_minus: float
    E_plus: float
    q_minus: np.ndarray
    v_minus: np.ndarray
    q_plus: np.ndarray
    v_plus: np.ndarray
    T_c_minus: float
    m_eff: float
    v_n: float
    contact_wheel: str
    A_rows: list = field(default_factory=list)
    stats: dict = field(default_factory=dict)

    def summary(self) -> dict:
        """Scalar figures of the run (for tables and JSON)."""
        return {
            "contact_wheel": self.contact_wheel,
            "F_max_total": self.F_max_total,
            **{f"F_max[{k}]": v for k, v in self.F_max.items()},
            **{f"impulse[{k}]": v for k, v in self.impulse.items()},
            "contact_duration": self.contact_duration,
            "separated": self.separated,
            "v_n": self.v_n,
            "m_eff": self.m_eff,
            "T_c_minus": self.T_c_minus,
            "T_minus": self.T_minus,
            "T_plus": self.T_plus,
            "E_minus": self.E_minus,
            "E_plus": self.E_plus,
        }

    def write(self, path: str | Path) -> Path:
        """Write the time history to ``.parquet`` or ``.csv`` (chosen by the suffix)."""
        path = Path(path)
        suffix = path.suffix.lower()
        if suffix == ".parquet":
            self.history.to_parquet(path, index=False)
        elif suffix == ".csv":
            self.history.to_csv(path, index=False)
        else:
            raise InputError(f"{path}: unknown table format {suffix!r}; use .parquet or .csv")
        return path
