"""Textbook impact systems with answers derived by hand (the reference for the core tests).

Every function returns the system (M, A, v, ...) and, separately, the closed-form answer
derived in its docstring from momentum balance and Newton's restitution law, never from
roverimpact itself.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Case:
    M: np.ndarray
    A: np.ndarray
    v: np.ndarray
    e: float
    persistent: np.ndarray | None
    # closed-form answers
    v_plus: np.ndarray
    impulse: float
    energy_lost: float
    T_c_minus: float
    impulse_persistent: np.ndarray | None = None


def two_masses(m1=2.0, m2=3.0, u1=1.5, u2=-0.5, e=0.7) -> Case:
    r"""Two point masses colliding along a line (the 1-D collision formulas).

    ::

        m1 -->      <-- m2
        (o)u1       u2(o)
        ---x1---------x2---->  x

    Coordinates ``(x1, x2)``, ``M = diag(m1, m2)``. The gap ``g = x2 - x1`` closes when
    ``u2 - u1 < 0``; the contact row is ``a = [-1, 1]``. With reduced mass
    :math:`\mu = m_1 m_2/(m_1 + m_2)` and impulse :math:`P` on mass 2 (``-P`` on mass 1),
    momentum balance gives :math:`v_2^+ = u_2 + P/m_2`, :math:`v_1^+ = u_1 - P/m_1`, and
    Newton's law :math:`v_2^+ - v_1^+ = -e (u_2 - u_1)` gives
    :math:`P = (1 + e)\mu (u_1 - u_2)`. Hence the classical

    .. math::
        v_1^+ = \frac{m_1 u_1 + m_2 u_2 + m_2 e (u_2 - u_1)}{m_1 + m_2},\quad
        v_2^+ = \frac{m_1 u_1 + m_2 u_2 + m_1 e (u_1 - u_2)}{m_1 + m_2},

    energy lost :math:`\tfrac12 (1 - e^2)\mu (u_1 - u_2)^2`, and
    :math:`T_c^- = \tfrac12 \mu (u_1 - u_2)^2` (the energy of the relative motion).
    """
    mu = m1 * m2 / (m1 + m2)
    v1 = (m1 * u1 + m2 * u2 + m2 * e * (u2 - u1)) / (m1 + m2)
    v2 = (m1 * u1 + m2 * u2 + m1 * e * (u1 - u2)) / (m1 + m2)
    return Case(
        M=np.diag([m1, m2]),
        A=np.array([[-1.0, 1.0]]),
        v=np.array([u1, u2]),
        e=e,
        persistent=None,
        v_plus=np.array([v1, v2]),
        impulse=(1 + e) * mu * (u1 - u2),
        energy_lost=0.5 * (1 - e**2) * mu * (u1 - u2) ** 2,
        T_c_minus=0.5 * mu * (u1 - u2) ** 2,
    )


def rod_on_edge(m=2.0, length=1.0, x_dot=0.3, V=1.0, omega=0.5, e=0.5) -> Case:
    r"""A free slender rod, horizontal, striking a fixed edge with its left end.

    ::

              omega (ccw)
        end o=====G=====o
            ^ edge       falling at V

    Coordinates ``(x, z, theta)`` of the centre G; ``M = diag(m, m, m l^2/12)``. The left
    end is at ``z - (l/2) sin(theta)``; at ``theta = 0`` its vertical velocity is
    ``z_dot - (l/2) theta_dot``, so ``a = [0, 1, -l/2]`` and the approach speed is
    :math:`v_n = -V - \tfrac{l}{2}\omega`. An upward impulse :math:`P` at the end gives
    :math:`\Delta\dot z = P/m` and :math:`\Delta\dot\theta = -(l/2) P / I_G` with
    :math:`I_G = m l^2/12`. Newton's law on the end velocity,
    :math:`v_n^+ = -e v_n`, with :math:`1/m + (l/2)^2/I_G = 4/m` gives
    :math:`P = -(1 + e) v_n\, m/4`: the effective mass of the end is ``m/4``. Energy lost
    :math:`(1 - e^2)\tfrac12 (m/4) v_n^2`, and :math:`T_c^- = \tfrac12 (m/4) v_n^2`.
    """
    I_G = m * length**2 / 12
    v_n = -V - 0.5 * length * omega
    m_eff = m / 4
    P = -(1 + e) * v_n * m_eff
    v_plus = np.array([x_dot, -V + P / m, omega - 0.5 * length * P / I_G])
    return Case(
        M=np.diag([m, m, I_G]),
        A=np.array([[0.0, 1.0, -0.5 * length]]),
        v=np.array([x_dot, -V, omega]),
        e=e,
        persistent=None,
        v_plus=v_plus,
        impulse=P,
        energy_lost=0.5 * (1 - e**2) * m_eff * v_n**2,
        T_c_minus=0.5 * m_eff * v_n**2,
    )


def pendulum_on_stop(m=1.5, length=0.8, d=0.6, omega=2.0, e=0.3, dependent=False) -> Case:
    r"""A rod pendulum swinging into a stop at distance ``d`` below the pivot O.

    ::

            O  (pivot)
            |
            |  d
            |
            o| stop        pendulum hanging vertically, theta_dot = omega > 0
            |              moves the rod in +x
            G (at l/2)

    Independent coordinate: ``theta`` with ``M = [I_O]``, :math:`I_O = m l^2/3`. The point
    at distance ``d`` moves at :math:`d\dot\theta` toward the stop; the gap row is
    ``a = [-d]``. Newton's law: :math:`\dot\theta^+ = -e\omega`; the stop impulse
    :math:`P = (1 + e) I_O \omega / d`; energy lost :math:`(1 - e^2) \tfrac12 I_O\omega^2`
    (all kinetic energy is constrained: :math:`T_c^- = T`).

    Dependent coordinates (``dependent=True``): ``(x_G, z_G, theta)`` of the free rod with
    ``M = diag(m, m, m l^2/12)`` and the pivot as two persistent rows
    ``[1, 0, -l/2]`` (pivot x velocity) and ``[0, 1, 0]`` (pivot z velocity) at
    ``theta = 0``; the stop row is ``[-1, 0, -(d - l/2)]``. The same answer, plus the
    pivot reaction: horizontal momentum gives
    :math:`R_x = m\Delta\dot x_G + P = (1 + e)\omega (I_O/d - m l/2)`, which vanishes at
    the centre of percussion ``d = 2l/3``; :math:`R_z = 0`.
    """
    I_O = m * length**2 / 3
    P = (1 + e) * I_O * omega / d
    lost = 0.5 * (1 - e**2) * I_O * omega**2
    if not dependent:
        return Case(
            M=np.array([[I_O]]), A=np.array([[-d]]), v=np.array([omega]), e=e,
            persistent=None, v_plus=np.array([-e * omega]), impulse=P, energy_lost=lost,
            T_c_minus=0.5 * I_O * omega**2,
        )
    half = 0.5 * length
    R_x = (1 + e) * omega * (I_O / d - m * half)
    return Case(
        M=np.diag([m, m, m * length**2 / 12]),
        A=np.array([[-1.0, 0.0, -(d - half)]]),
        v=np.array([half * omega, 0.0, omega]),
        e=e,
        persistent=np.array([[1.0, 0.0, -half], [0.0, 1.0, 0.0]]),
        v_plus=np.array([-half * e * omega, 0.0, -e * omega]),
        impulse=P,
        energy_lost=lost,
        T_c_minus=0.5 * I_O * omega**2,
        impulse_persistent=np.array([R_x, 0.0]),
    )


def random_spd(rng: np.random.Generator, n: int, spread: float = 2.0) -> np.ndarray:
    """A random SPD mass matrix with coordinates of very different scales.

    ``M = D (X X^T + n I) D`` with ``D`` log-uniform over ``10^±spread``: the kind of
    spread a rover's mass matrix has (kg for translations, kg m^2 for rotations).
    """
    X = rng.standard_normal((n, n))
    D = np.diag(10.0 ** rng.uniform(-spread / 2, spread / 2, n))
    return D @ (X @ X.T + n * np.eye(n)) @ D
