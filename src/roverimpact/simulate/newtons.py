r"""Predicted peak force of a scenario's impact, with the ground compliance and the weight.

The closed form :func:`roverimpact.contact.peak_force` from :math:`(T_c^-, v_n)` (the
studies' ``F_pred``) is the peak of an impact of :math:`m_{eff}` on the law, with the held
rows rigid and no gravity. On the studies of ``roverimpact reproduce`` it is 0.68-0.99 of the
simulated :math:`F_{max}`, always low (docs/contact.md, "Newtons from T_c^-"). The deficit
comes from the ground contacts, which the simulators (and the rover) have and the closed
form does not:

* they are compliant and preloaded by the weight: the front wheel's ground contact holds
  until the obstacle force has taken over its load, and the rear wheel's (released by the
  impulsive active set at steep faces) stays in contact, pressed by its share of the
  weight, so the mass behind the obstacle contact is larger than :math:`m_{eff}`;
* the weight the obstacle takes over adds to the peak (gravity preload).

There is no drive torque in the simulated runs (the rover rolls freely into the face).

:func:`reduced_system` builds the contact-space model of
:mod:`roverimpact.contact.reduced` at the scenario's pre-impact state: the obstacle row
and the normal ground rows of *every* wheel (the simulators' ground touches every wheel),
the loop-closure and locked-joint rows held rigidly, the applied forces of the simulation
(gravity ``simulation.gravity``, Coriolis terms, ``simulation.springs``) and the laws of
the simulation (``[contact_law]`` on the obstacle, ``simulation.ground_contact`` on the
ground). Not modelled: friction (``simulation.mu > 0``), a ``[terrain]`` (the prediction
is then NaN), ``contacts.points``, the rows' drift terms and the change of configuration
during the impact (millimetres).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..contact.reduced import (
    ReducedImpact,
    held_inverse,
    reduced_impact,
    static_indentation,
    static_loads,
)
from ..scenario import Scenario

__all__ = ["ReducedSystem", "reduced_system"]


@dataclass(frozen=True)
class ReducedSystem:
    """The contact-space model of one scenario (:func:`reduced_system`).

    Attributes
    ----------
    G : (m, m) ndarray
        :math:`A N A^T` of the compliant rows, the obstacle row last.
    b : (m,) ndarray
        :math:`A N \\tau`.
    rate0 : (m,) ndarray
        Penetration rates at first touch (:math:`-A v`); the last is :math:`v_n`.
    labels : tuple of str
        Row labels (``ground:<wheel>:normal`` ..., then the obstacle row).
    ground_law, v_ref
        The ground's law object and its ``v_i`` [m/s].
    t_max : float
        The window ``simulation.t_after`` [s].
    """

    G: np.ndarray
    b: np.ndarray
    rate0: np.ndarray
    labels: tuple[str, ...]
    ground_law: object
    v_ref: float
    t_max: float

    @property
    def v_n(self) -> float:
        return float(self.rate0[-1])

    def impact(self, law) -> ReducedImpact | None:
        """Peak force etc. with ``law`` on the obstacle (None without an approach), by the
        compiled fixed-step Runge-Kutta (its step bounded by the damping too: exact for a
        stiff case, only slower; a study's few impacts do not pay for compiling the
        Rosenbrock pair, :func:`~roverimpact.contact.reduced.reduced_impact_batch`)."""
        if not (self.v_n > 0.0):
            return None
        m = len(self.labels)
        laws = [self.ground_law] * (m - 1) + [law]
        v_i = [self.v_ref] * (m - 1) + [self.v_n]
        return reduced_impact(self.G, self.b, laws, v_i, self.rate0, t_max=self.t_max,
                              impact=m - 1, method="rk4")

    def impact_mujoco(self, law, m_c: float) -> ReducedImpact | None:
        """The same model with the spring-dampers the MuJoCo engine puts in place of
        nonlinear laws (:func:`roverimpact.simulate.engines.mujoco.linear_contact`): on the
        obstacle the Kelvin-Voigt law with the closed-form peak force and restitution of
        ``law`` for a mass ``m_c`` [kg] (the engine takes 2 T_c^- / v_n^2 at its first
        contact) at v_n, on the ground the tangent line at each wheel's static load. What
        MuJoCo is expected to give for this scenario; the difference from :meth:`impact`
        is that of the engine's contact model, not of the rover."""
        from .engines.mujoco import linear_contact

        if not (self.v_n > 0.0):
            return None
        m = len(self.labels)
        gl = self.ground_law
        if m > 1:
            loads = static_loads(self.G[:-1, :-1], self.b[:-1])
            d0 = static_indentation(gl, loads, self.v_ref)
        ground = []
        for i in range(m - 1):
            if gl.spring_damper() is not None:
                ground.append(gl)
                continue
            lc = linear_contact(gl, delta0=max(float(d0[i]), 1e-12), v_i=self.v_ref)
            ground.append(_Linear(lc.k, lc.c, lc.offset))
        oc = linear_contact(law, m_eff=None if law.spring_damper() is not None else m_c,
                            v_n=self.v_n)
        laws = [*ground, _Linear(oc.k, oc.c, oc.offset)]
        v_i = [self.v_ref] * (m - 1) + [self.v_n]
        return reduced_impact(self.G, self.b, laws, v_i, self.rate0, t_max=self.t_max,
                              impact=m - 1, method="rk4")


@dataclass(frozen=True)
class _Linear:
    """f = max(0, k (delta - offset) + c delta_dot) [N] (a MuJoCo contact pair)."""

    k: float
    c: float
    offset: float = 0.0
    n: float = 1.0

    def force(self, delta, delta_dot, v_i=1.0):
        return np.maximum(self.k * (np.asarray(delta, float) - self.offset)
                          + self.c * np.asarray(delta_dot, float), 0.0)

    def reduced_form(self, v_i=1.0):
        """``(k, n, a, c, f0)`` of the compiled integrators
        (:func:`roverimpact.contact.reduced.law_form`)."""
        return self.k, 1.0, 0.0, self.c, self.k * self.offset


def reduced_system(sc: Scenario, setup=None) -> ReducedSystem | None:
    """The contact-space model of ``sc`` at its pre-impact state (module docstring);
    ``setup``: its :class:`~roverimpact.scenario.ImpactSetup` if already built. None for a
    scenario the model does not cover (a ``[terrain]``, an obstacle without ``beta_deg``
    or ``wheel``, no driving speed)."""
    from ..scenario import ImpactSetup
    from .config import SimulationConfig
    from .run import build_system

    if sc.terrain is not None or sc.obstacle.wheel is None or sc.obstacle.beta_deg is None \
            or not sc.velocity.u:
        return None
    if setup is None:
        setup = ImpactSetup.from_scenario(sc)
    cfg = SimulationConfig.from_scenario(sc)
    mbm, q, v = setup.model, setup.q, setup.v
    sys_ = build_system(mbm, cfg)
    on_ground = sys_.gaps(q)[0] <= 1e-9 if cfg.ground else np.zeros(len(mbm.wheels), bool)
    wheels = [w.name for w, on in zip(mbm.wheels, on_ground, strict=True) if on]
    contacts = sc.contacts.model_copy(update={"ground_wheels": wheels, "ground": "normal",
                                              "points": []})
    full = ImpactSetup.from_state(mbm, q, v, obstacle=sc.obstacle, contacts=contacts,
                                  constraints="all")
    labels = full.labels
    o = full.obstacle_row
    ground = [i for i, lab in enumerate(labels)
              if lab.startswith("ground:") and lab.endswith(":normal")]
    rigid = [i for i in range(len(labels)) if i != o and i not in ground]
    tau = -pin.nonLinearEffects(sys_.model, sys_.data, q, v) + sys_.spring_torque(q, v)
    N = held_inverse(full.M, full.A[rigid] if rigid else None)
    rows = [*ground, o]
    AU = full.A[rows]
    G = AU @ N @ AU.T
    G = 0.5 * (G + G.T)
    return ReducedSystem(G=G, b=AU @ N @ tau, rate0=-(AU @ v),
                         labels=tuple(labels[i] for i in rows),
                         ground_law=cfg.ground_contact.to_law(), v_ref=cfg.ground_contact.v_ref,
                         t_max=cfg.t_after)
