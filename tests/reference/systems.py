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


@dataclass(frozen=True)
class CompassGait:
    M: np.ndarray
    normal: np.ndarray    # (2, 4): z velocity of the trailing foot, of the landing foot
    tangent: np.ndarray   # (2, 1, 4): their x velocities
    v: np.ndarray
    # closed-form answers
    v_plus: np.ndarray
    energy_lost: float


def compass_gait(m_H=10.0, m=5.0, a=0.5, b=0.5, alpha_deg=20.0, w1=-1.2, w2=-0.3
                 ) -> CompassGait:
    r"""Heel strike of the compass-gait biped (Goswami, Espiau & Keramane 1997; Spong).

    ::

                 o hip (m_H)
                / \       legs: point mass m at distance b from the hip,
               o   o      a from the foot (l = a + b)
              /     \
        ---- 1 ----- 2 ----  foot 1 trailing (stance), foot 2 landing

    Coordinates ``(x_h, z_h, phi_1, phi_2)``: hip position and the absolute angle of each
    leg from the downward vertical, foot i at ``hip + l (sin phi_i, -cos phi_i)``. Both feet
    on the ground at ``phi = (-alpha, alpha)``; before the impact foot 1 is pinned
    (``hip' = -l w1 (cos phi_1, sin phi_1)``) and foot 2 descends.

    Plastic impact, foot 2 sticks, foot 1 leaves the ground (as it does here: its velocity
    after is upward). Its impulse is then zero, so (i) the angular momentum of the whole
    system about foot 2 and (ii) that of leg 1 about the hip (a frictionless pin) are
    conserved, and (iii) foot 2 is at rest after: four linear equations for ``v+``, the
    textbook derivation of the compass-gait impact map.
    """
    l = a + b
    alpha = np.radians(alpha_deg)
    q = np.array([0.0, l * np.cos(alpha), -alpha, alpha])
    hip = q[:2]

    def e(p):
        return np.array([np.cos(p), np.sin(p)])

    M = np.zeros((4, 4))
    M[:2, :2] = (m_H + 2 * m) * np.eye(2)
    for i in (2, 3):
        M[:2, i] = M[i, :2] = m * b * e(q[i])
        M[i, i] = m * b * b
    feet = []
    for i in (2, 3):
        J = np.zeros((2, 4))
        J[:, :2] = np.eye(2)
        J[:, i] = l * e(q[i])
        feet.append(J)
    v = np.array([*(-l * w1 * e(q[2])), w1, w2])

    def momentum(vv, about, legs, hip_mass):
        """Angular momentum (y-component, x-z plane) of the point masses about a point."""
        pts = [(hip, vv[:2], m_H)] if hip_mass else []
        for i in legs:
            p = q[2 + i]
            pts.append((hip + b * np.array([np.sin(p), -np.cos(p)]),
                        vv[:2] + b * vv[2 + i] * e(p), m))
        return sum(mass * ((r - about)[0] * u[1] - (r - about)[1] * u[0])
                   for r, u, mass in pts)

    foot2 = hip + l * np.array([np.sin(q[3]), -np.cos(q[3])])
    E = np.eye(4)
    eqs = [lambda vv: momentum(vv, foot2, (0, 1), True),
           lambda vv: momentum(vv, hip, (0,), False)]
    rows = [[f(E[k]) for k in range(4)] for f in eqs] + list(feet[1])
    rhs = [f(v) for f in eqs] + [0.0, 0.0]
    v_plus = np.linalg.solve(np.array(rows), np.array(rhs))
    return CompassGait(
        M=M, normal=np.array([feet[0][1], feet[1][1]]),
        tangent=np.array([feet[0][:1], feet[1][:1]]), v=v, v_plus=v_plus,
        energy_lost=0.5 * v @ M @ v - 0.5 * v_plus @ M @ v_plus)
