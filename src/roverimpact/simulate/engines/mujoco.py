r"""The impact scenario of :func:`roverimpact.simulate.simulate_impact`, run in MuJoCo.

Same :class:`~roverimpact.simulate.SimulationConfig`, same start state, same
:class:`~roverimpact.simulate.SimulationResult`; only the contact model and the
integrator are MuJoCo's.

Contact: MuJoCo's soft constraint as a spring-damper
-----------------------------------------------------
MuJoCo computes the constraint forces from (Todorov 2014; MuJoCo docs, "Computation")

.. math:: (A + R)\,f = a_{ref} - a_0,\qquad a_{ref} = -b\,\dot r - k\,d\,r,\qquad
          R = \frac{1-d}{d}\,\tilde A

with :math:`A = J M^{-1} J^T`, :math:`a_0` the unconstrained constraint-space
acceleration, :math:`r` the signed distance, :math:`d` the impedance (``solimp``),
:math:`\tilde A` MuJoCo's diagonal approximation of :math:`A` (for a wheel/plane contact:
``body_invweight0`` of the wheel body, a constant of the compiled model). With the
*direct* ``solref = (-s, -\beta)``: :math:`k = s/d_{max}^2`, :math:`b = \beta/d_{max}`.
``solimp = (d, d, ...)`` makes the impedance constant (:math:`d = d_{max}`) and then

.. math:: \bigl(d A + (1-d)\tilde A\bigr) f = -(s\,r + \beta\,\dot r + d\,a_0).

The direct values are therefore *accelerations* per metre (per m/s), not N/m: the force
of ``solref = (-k, -c)`` is scaled by the constraint-space mass (a 4 kg slider gets
4 k). Two limits: :math:`d \to 1` prescribes the contact's *acceleration*
(:math:`\ddot r = -s r - \beta\dot r`) whatever the masses, with a force that depends on
every other active constraint (not a force law); :math:`d \to 0` gives

.. math:: f = -\frac{s\,r + \beta\,\dot r}{(1-d)\tilde A} + O(d),

a pure spring-damper per contact, independent of the configuration. This engine uses
``d = 1e-4`` (MuJoCo's minimum, ``mjMINIMP``) and
``solref = (-k a, -c a)``, :math:`a = (1-d)\tilde A + d A_{ii}` with the contact's
:math:`A_{ii} = J_i M^{-1} J_i^T` at the state where the pair is set (start for the
ground, pre-impact for the obstacle), so a Kelvin-Voigt law
:math:`f_n = \max(0, k\delta + c\dot\delta)` is reproduced up to
:math:`d\,\Delta A/\tilde A` (the change of A during contact, and the coupling to
other rows) and :math:`d\,a_0` (checked along whole force histories in
``tests/test_engine_mujoco.py``). The clamp at 0 is MuJoCo's (a contact cannot pull).

Law mapping (:func:`linear_contact`)
------------------------------------
* **Kelvin-Voigt**: exact, ``(k, c)``.
* **Obstacle, Hertz / Hunt-Crossley family**: no exact linear equivalent. At the
  pre-impact state the engine takes :math:`m_c = 2T_c^-/v_n^2` and the approach speed
  :math:`v_n`, and chooses the Kelvin-Voigt law with the same closed-form peak force *and*
  the same achieved restitution as the nonlinear law for a mass :math:`m_c` at
  :math:`v_n` (:func:`equivalent_kelvin_voigt`; :func:`roverimpact.contact.predict`).
  Approximation: exact for that 1-DoF impact, not for the force-history shape or the
  duration, and only as good as :math:`m_c` on a multibody rover.
* **Ground, nonlinear law**: tangent line at each wheel's static load (settled state):
  :math:`k_t = \partial f/\partial\delta`, :math:`c_t = \partial f/\partial\dot\delta` at
  :math:`(\delta_0, 0)`, shifted so that the force starts at
  :math:`\delta_a = \delta_0 - f_0/k_t` (the pair's ``margin = -\delta_a``: MuJoCo adds
  the contact only for ``dist < margin`` and its spring acts on ``dist - margin``; the
  ``gap`` attribute had no effect in MuJoCo 4.0.0): same static load and local stiffness, so the
  settled start state is an equilibrium of both engines. Approximation away from
  :math:`\delta_0`.

Friction: ``mu = 0`` -> ``condim = 1`` (one frictionless row per contact). ``mu > 0`` ->
``condim = 3``, elliptic cone, viscous slope :math:`\mu f_{ref}/v_{slip}` inside the cone
(``solreffriction``), :math:`f_{ref}` the wheel's static load (ground) or the predicted
peak force (obstacle), in place of the own simulator's
:math:`\mu f_n\tanh(|v_t|/v_{slip})`. Two MuJoCo details matter here. (1) With the
small impedance, the solver projects the unconstrained (normal, friction) forces onto the
cone in the metric R; with ``impratio = 1`` a sliding contact's friction demand
:math:`\mu|f_t^*|` is pushed into the *normal* force (measured: 11 400 N instead of
940 N at mu = 0.3); ``impratio = 1e4`` makes the friction rows cheap in that metric, and
the cone then only clips :math:`|f_t| \le \mu f_n`. (2) The friction slope is explicit:
:math:`\mu f_{ref}/v_{slip}` with ``v_slip = 1 mm/s`` would need ~1e-7 s steps, so the
slope is scaled down until its rate does not exceed that of the normal contact modes
(``stats["friction_slope_scale"]``), i.e. a larger effective ``v_slip``. An
approximation: F_max within a few per cent of the own engine in
``examples/mujoco_engine.py``.

Normal forces are read from ``efc_force`` (not ``mj_contactForce``): the contact's first
row for ``condim = 1`` and for the elliptic cone (its normal component), so no cone
conversion is involved.

Timestep
--------
Semi-implicit Euler (MuJoCo ``Euler``) with an explicit spring-damper needs
:math:`h\,\omega \ll 1`. The rule: :math:`h = \pi / (N(\omega_{max} + \lambda_{max}))`,
with :math:`\omega_{max}^2` the largest eigenvalue of :math:`(K, M)` and
:math:`\lambda_{max}` that of :math:`(C, M)`, :math:`K = \sum_i k_i J_i^T J_i`,
:math:`C = \sum_i c_i J_i^T J_i` over the linearised contact rows (ground of every
wheel, obstacle of the obstacle wheels, friction slopes): N steps per half period of the
fastest contact mode. Default ``N = 100`` (``steps_per_mode``); the approach runs with
the ground modes, the impact with the obstacle rows added (recomputed at the pre-impact
state). ``tests/test_engine_mujoco.py`` checks that halving h changes F_max by < 1 %.

First contact and separation
----------------------------
After every approach step the obstacle gaps ``n . (c - p0) - r`` are evaluated from
MuJoCo's geometry; on a sign change the step is redone with the secant fraction of h
(no obstacle force acts before it), so the pre-impact state has gap < 1e-10 m and
t = 0 falls on it. Separation: every obstacle gap positive again (linear interpolation
of the crossing), or ``t_after``.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import linalg, optimize

from ...contact import KelvinVoigt, achieved_restitution, predict
from ...contact.hunt_crossley import family_force, one_family
from ...energy import effective_mass
from ...exceptions import ConfigError, InputError, SolverError
from ...models.export_mjcf import (
    fmt_floats,
    mjcf_element,
    mujoco_qpos,
    mujoco_velocity,
    pinocchio_state,
)
from ..config import SimulationConfig
from ..result import SimulationResult
from ..run import (
    as_config,
    build_system,
    effective_energy,
    first_contact_wheel,
    initial_state,
    reference_configuration,
    simulate_impact,
)

__all__ = ["ENGINES", "LinearContact", "check_frictionless", "equivalent_kelvin_voigt",
           "linear_contact", "simulate_impact_mujoco", "simulate_impact_mujoco_laws"]

#: Constant impedance d of every contact (MuJoCo's minimum, mjMINIMP).
IMPEDANCE = 1.0e-4
#: Impedance of the loop-closure equality (MuJoCo's maximum, mjMAXIMP): nearly rigid.
LOOP_IMPEDANCE = 0.9999
#: MuJoCo impratio with friction: tangential rows cheap in the cone projection.
IMPRATIO = 1.0e4
_MAX_STEPS = 2_000_000
_FAR = 1.0e9


def _mujoco():
    try:
        import mujoco
    except ImportError:  # pragma: no cover - mujoco is in the test extra
        raise ConfigError("the MuJoCo engine needs the 'mujoco' package (pip install mujoco)") \
            from None
    return mujoco


@dataclass(frozen=True)
class LinearContact:
    """Spring-damper a MuJoCo contact pair reproduces: ``f = max(0, k (delta - offset) + c
    delta_dot)`` [N].

    ``exact`` is True for Kelvin-Voigt; ``note`` says what was approximated.
    """

    k: float
    c: float
    offset: float = 0.0
    exact: bool = True
    note: str = "kelvin-voigt: exact"


def equivalent_kelvin_voigt(law, m_eff: float, v_n: float) -> tuple[float, float]:
    r"""Kelvin-Voigt ``(k, c)`` with the closed-form peak force and achieved restitution of
    ``law`` for a mass ``m_eff`` [kg] hitting at ``v_n`` [m/s].

    The achieved restitution of the clamped Kelvin-Voigt law depends on the damping ratio
    alone, :math:`e^* = \exp(-2\alpha\cot\alpha)`, :math:`\alpha = \arccos\zeta`: solve it
    for :math:`\zeta`; its peak force is :math:`m v\omega\,\varphi(\zeta)`: solve for
    :math:`\omega`. Then :math:`k = m\omega^2`, :math:`c = 2\zeta m\omega`.

    >>> from roverimpact.contact import get_law, predict, KelvinVoigt
    >>> hc = get_law("hunt-crossley", k=1e7, e=0.5)
    >>> k, c = equivalent_kelvin_voigt(hc, 10.0, 0.3)
    >>> p_hc, p_kv = predict(hc, 10.0, 0.3), predict(KelvinVoigt(k=k, c=c), 10.0, 0.3)
    >>> bool(abs(p_kv.peak_force / p_hc.peak_force - 1) < 1e-9)
    True
    >>> bool(abs(p_kv.restitution_achieved - p_hc.restitution_achieved) < 1e-9)
    True
    """
    if law.spring_damper() is not None:
        return law.spring_damper()
    pred = predict(law, m_eff, v_n)
    F, e = float(pred.peak_force), float(pred.restitution_achieved)

    def e_of(z):
        return float(achieved_restitution(KelvinVoigt(k=1.0, c=2.0 * z), 1.0))

    if e >= 1.0 - 1e-12:
        zeta = 0.0
    else:
        zeta = optimize.brentq(lambda z: e_of(z) - e, 0.0, 1e3, xtol=1e-14, rtol=1e-13)
    phi = float(predict(KelvinVoigt(k=1.0, c=2.0 * zeta), 1.0, 1.0).peak_force)
    omega = F / (m_eff * v_n * phi)
    return m_eff * omega**2, 2.0 * zeta * m_eff * omega


def linear_contact(law, *, delta0: float | None = None, v_i: float = 1.0,
                   m_eff: float | None = None, v_n: float | None = None) -> LinearContact:
    """The spring-damper MuJoCo uses for ``law`` (see the module docstring).

    Parameters
    ----------
    law : ContactLaw
    delta0 : float, optional
        Static indentation [m] to linearise at (ground contacts): tangent line.
    v_i : float
        Penetration velocity passed to the law at ``delta0`` (``ground_contact.v_ref``).
    m_eff, v_n : float, optional
        Effective mass [kg] and approach speed [m/s] of an impact (obstacle): equivalent
        Kelvin-Voigt with the same peak force and restitution.
    """
    if law.spring_damper() is not None:
        return LinearContact(*law.spring_damper())
    if m_eff is not None:
        k, c = equivalent_kelvin_voigt(law, m_eff, v_n)
        return LinearContact(k, c, 0.0, False,
                             f"{law.name}: Kelvin-Voigt with the same closed-form peak force "
                             f"and restitution for m = {m_eff:.4g} kg at {v_n:.4g} m/s")
    d0 = float(delta0)
    f0 = float(law.force(d0, 0.0, v_i))
    hd = 1e-6 * d0
    k_t = float(law.force(d0 + hd, 0.0, v_i) - law.force(d0 - hd, 0.0, v_i)) / (2 * hd)
    hv = 1e-3 * v_i
    c_t = float(law.force(d0, hv, v_i) - law.force(d0, -hv, v_i)) / (2 * hv)
    if not k_t > 0.0:
        raise ConfigError(f"{law.name}: no positive contact stiffness at indentation "
                          f"{d0:.3g} m to map onto a MuJoCo spring-damper")
    return LinearContact(k_t, max(c_t, 0.0), d0 - f0 / k_t, False,
                         f"{law.name}: tangent line at the static indentation {d0:.4g} m "
                         f"(load {f0:.4g} N)")


def check_frictionless(mu: float) -> None:
    """The scenario's laws in MuJoCo (engine ``mujoco_laws``, ``contact="laws"``) apply
    normal forces only: ConfigError unless ``mu == 0``."""
    if mu > 0.0:
        raise ConfigError(f"engine 'mujoco_laws' (contact='laws') applies frictionless "
                          f"contact forces: it needs mu = 0, got mu = {mu} (engine "
                          "'mujoco' approximates friction, 'own' models it)")


def _obstacle_frame(beta: float):
    """Quaternion (w, x, y, z) of the rotation about y by -beta: local z = the face normal
    n = (-sin beta, 0, cos beta), local x = up the face (cos beta, 0, sin beta)."""
    return np.array([math.cos(-beta / 2), 0.0, math.sin(-beta / 2), 0.0])


def _place_obstacle(sys, q, config) -> float:
    """x of the obstacle foot, exactly as the own simulator places it."""
    n = sys.planes[-1].n
    c = sys.wheel_centres(q)
    if config.obstacle_x is None:
        return (config.distance - float(np.min(c @ n - sys.radii))) / math.sin(config.beta)
    return float(config.obstacle_x)


def _max_rate(M, rows) -> float:
    """omega_max + lambda_max of the linearised contact rows [(J (nv,), k, c)]."""
    nv = M.shape[0]
    K, C = np.zeros((nv, nv)), np.zeros((nv, nv))
    for J, k, c in rows:
        K += k * np.outer(J, J)
        C += c * np.outer(J, J)
    w2 = float(linalg.eigh(K, M, eigvals_only=True)[-1]) if rows else 0.0
    lc = float(linalg.eigh(C, M, eigvals_only=True)[-1]) if rows else 0.0
    return math.sqrt(max(w2, 0.0)) + max(lc, 0.0)


def simulate_impact_mujoco(mbm, config: SimulationConfig | dict | None = None, *, q0=None,
                           v0=None, timestep: float | None = None,
                           steps_per_mode: int = 100, contact: str = "soft") -> SimulationResult:
    r"""Run the impact of :func:`roverimpact.simulate.simulate_impact` in MuJoCo.

    Parameters
    ----------
    mbm : MultibodyModel
        A model :func:`~roverimpact.models.export_mjcf.export_mjcf` can write (built-in
        rovers, trees of 1-DoF joints with an optional free-flyer root).
    config : SimulationConfig or dict, optional
        The scenario (gravity, speed, distance, beta, obstacle_wheels, laws, mu, springs,
        t_max, t_after, contacts, constraints). ``integrator`` (scipy settings) is not used, except
        ``baumgarte`` (the loop-closure equality's stabilisation, as in the own engine).
    q0, v0 : array_like, optional
        Pinocchio start state, as for the own engine: without ``v0`` the model is settled
        by :func:`roverimpact.simulate.initial_state` (same state as the own engine) and
        driven at ``config.speed``.
    timestep : float, optional
        Fixed MuJoCo timestep [s] for the whole run; default: the rule of the module
        docstring.
    steps_per_mode : int
        N of the timestep rule (steps per half period of the fastest contact mode).
    contact : {"soft", "laws"}
        ``"soft"`` (default): MuJoCo's own soft contact, the laws mapped onto
        spring-dampers (module docstring). ``"laws"``: the scenario's contact laws
        themselves (Hunt-Crossley, Hertz, ... on the obstacle and the ground), evaluated
        before every step from MuJoCo's geometry (gap and rate of each wheel sphere) and
        applied to the wheel bodies at the contact point (``xfrc_applied``, between
        ``mj_step1`` and ``mj_step2``); MuJoCo then computes only the dynamics and
        integrates. Frictionless only (``mu = 0``).

    Returns
    -------
    SimulationResult
        ``F_max``, ``F_max_total``, ``t_peak``, ``impulse``, ``contact_duration``,
        ``separated``, the pre-impact state and its ``T_c_minus`` (Pinocchio coordinates),
        the history (``t``, ``q_i``, ``v_i``, ``<plane>_<wheel>_fn|ft|delta`` per step) and
        ``stats`` (``engine = "mujoco"``, ``contact``, ``timestep``, ``steps``,
        ``mapping``).

    Raises
    ------
    ConfigError, InputError, ModelError
        As the own engine (bad values, unknown law, no wheels, obstacle behind the rover),
        or a model MuJoCo cannot take.
    SolverError
        No obstacle contact within ``t_max``, or a diverging MuJoCo run.
    """
    mujoco = _mujoco()
    config = as_config(config)
    if not (isinstance(steps_per_mode, int) and steps_per_mode >= 4):
        raise ConfigError(f"steps_per_mode must be an integer >= 4, got {steps_per_mode!r}")
    if timestep is not None and not (math.isfinite(timestep) and timestep > 0):
        raise ConfigError(f"timestep must be a finite number > 0 s, got {timestep!r}")
    if contact not in ("soft", "laws"):
        raise ConfigError(f"contact must be 'soft' (MuJoCo's contact) or 'laws' (the "
                          f"scenario's laws applied as forces), got {contact!r}")
    laws_mode = contact == "laws"
    if laws_mode:
        check_frictionless(config.mu)
    sys = build_system(mbm, config)            # validates laws, springs, wheels
    model = sys.model
    nw = len(mbm.wheels)
    names_w = [w.name for w in mbm.wheels]

    # ---- start state (Pinocchio), as the own engine
    if v0 is None:
        q, v = initial_state(mbm, config, q0=q0)
    else:
        q = np.asarray(reference_configuration(mbm) if q0 is None else q0, dtype=float).copy()
        v = np.asarray(v0, dtype=float).copy()
        if q.shape != (sys.nq,) or v.shape != (sys.nv,):
            raise InputError(f"q0 and v0 must have shapes ({sys.nq},), ({sys.nv},), got "
                             f"{q.shape}, {v.shape}")
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
        raise InputError("q0 and v0 must be finite")

    # ---- obstacle, as the own engine
    x0 = _place_obstacle(sys, q, config)
    obst = sys.planes[-1]
    obst.p0 = np.array([x0, 0.0, 0.0])
    sys._set_planes()
    io = len(sys.planes) - 1
    gaps0 = sys.gaps(q)[io]
    if not np.isfinite(gaps0).any():
        raise InputError(f"the obstacle (height {config.obstacle_height} m) is lower than the "
                         "contact points of every wheel: the rover would pass over it")
    finite = np.isfinite(gaps0)
    if float(np.min(gaps0[finite])) < 0.0:
        w = int(np.argmin(np.where(finite, gaps0, np.inf)))
        raise InputError(f"the obstacle is behind or inside the rover: wheel "
                         f"{names_w[w]!r} is {-gaps0[w]:.4g} m past its face; "
                         "move obstacle_x ahead of the rover (+x)")
    touch = sys.touch[io]                     # wheels the obstacle is in front of
    n_o = obst.n

    # ---- linear contact laws
    cs0 = sys.contacts(q, v)
    has_ground = config.ground
    ground_map = []
    if has_ground:
        gl = sys.planes[0].law
        mass = float(sum(i.mass for i in model.inertias))
        W = mass * config.g / nw
        d_ref = (optimize.brentq(lambda d: float(gl.force(d, 0.0, 1.0)) - W, 0.0, 1.0)
                 if W > 0 and gl.spring_damper() is None else 1e-4)
        for w in range(nw):
            d0 = float(cs0.delta[0, w])
            if d0 <= 1e-6 * d_ref and gl.spring_damper() is None:
                # wheel not loaded at the start (to rounding: a settled rover without
                # gravity sits at 1e-17 m, where the tangent of k delta^n is ~0 N/m):
                # linearise at its share of the weight
                d0 = d_ref
            ground_map.append(linear_contact(gl, delta0=d0, v_i=config.ground_contact.v_ref))
    ol = obst.law
    if ol.spring_damper() is not None:
        obst_map = linear_contact(ol)
    else:   # provisional (for the approach timestep only); set again at first contact
        M0 = sys.mass_matrix(q)
        a = n_o @ cs0.Jp[io, int(np.argmin(np.where(finite, gaps0, np.inf)))]
        m0 = float(effective_mass(M0, a))
        obst_map = linear_contact(ol, m_eff=m0, v_n=max(float(-(a @ v)), 1e-3))

    # ---- MJCF: rover + planes + explicit pairs
    root, layout = mjcf_element(
        mbm, springs=config.springs, loop_solref=(-1.0, -1.0),     # set in configure()
        loop_solimp=(LOOP_IMPEDANCE, LOOP_IMPEDANCE, 0.001, 0.5, 2.0))
    cone = "elliptic"
    ET.SubElement(root, "option", timestep="1e-4", gravity=fmt_floats([0.0, 0.0, -config.g]),
                  integrator="Euler", cone=cone,
                  impratio=fmt_floats(IMPRATIO if config.mu > 0 else 1.0), solver="Newton",
                  tolerance="1e-12", iterations="100")
    world = root.find("worldbody")
    for el in world.iter("geom"):
        el.set("contype", "0")
        el.set("conaffinity", "0")
    if has_ground:
        ET.SubElement(world, "geom", name="ground", type="plane", size="0 0 1", pos="0 0 0",
                      contype="0", conaffinity="0")
    quat = _obstacle_frame(config.beta)
    if math.isfinite(config.obstacle_height):
        # half-plane face of finite height: a box whose face lies in the obstacle plane,
        # from 1 m below the ground line up to the height h along the face
        sb = math.sin(config.beta)
        t_up = np.array([math.cos(config.beta), 0.0, sb])
        L = config.obstacle_height / sb
        ext, thick, half_y = 1.0, 1.0, 50.0
        centre = obst.p0 + t_up * (L - ext) / 2 - n_o * thick / 2
        ET.SubElement(world, "geom", name="obstacle", type="box",
                      size=fmt_floats([(L + ext) / 2, half_y, thick / 2]), pos=fmt_floats(centre),
                      quat=fmt_floats(quat), contype="0", conaffinity="0")
    else:
        ET.SubElement(world, "geom", name="obstacle", type="plane", size="0 0 1",
                      pos=fmt_floats(obst.p0), quat=fmt_floats(quat), contype="0", conaffinity="0")
    condim = "1" if config.mu == 0.0 else "3"
    friction = fmt_floats([max(config.mu, 1e-5), max(config.mu, 1e-5), 0.0, 0.0, 0.0])
    imp = fmt_floats([IMPEDANCE, IMPEDANCE, 0.001, 0.5, 2.0])
    contact_el = ET.SubElement(root, "contact")
    pairs = []                                 # (plane index, wheel, pair name)
    # (with contact="laws" the pairs are only the rows of the timestep rule: MuJoCo has
    # no contact, the laws' forces are applied)
    for w, wn in enumerate(names_w):
        if has_ground:
            if not laws_mode:
                ET.SubElement(contact_el, "pair", name=f"ground_{wn}", geom1="ground",
                              geom2=layout.wheel_geoms[wn], condim=condim, friction=friction,
                              solimp=imp, solref="-1 -1",
                              margin=fmt_floats(-ground_map[w].offset), gap="0")
            pairs.append((0, w, f"ground_{wn}"))
    for w, wn in enumerate(names_w):
        if touch[w]:
            if not laws_mode:
                ET.SubElement(contact_el, "pair", name=f"obstacle_{wn}", geom1="obstacle",
                              geom2=layout.wheel_geoms[wn], condim=condim, friction=friction,
                              solimp=imp, solref="-1 -1", margin="0", gap="0")
            pairs.append((io, w, f"obstacle_{wn}"))
    xml = ET.tostring(root, encoding="unicode")
    try:
        m = mujoco.MjModel.from_xml_string(xml)
    except ValueError as exc:  # pragma: no cover - export_mjcf checks what MuJoCo rejects
        raise ConfigError(f"MuJoCo cannot compile the exported model: {exc}") from None
    d = mujoco.MjData(m)
    gid = np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, layout.wheel_geoms[wn])
                    for wn in names_w])
    A_tilde = np.array([m.body_invweight0[m.geom_bodyid[g], 0] for g in gid])
    radii = sys.radii
    npl = len(sys.planes)
    pair_of = -np.ones((m.ngeom, m.ngeom), dtype=int)
    plane_geom = {0: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "ground")} \
        if has_ground else {}
    plane_geom[io] = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "obstacle")
    # MuJoCo sorts the pairs (by body): address them by name
    pair_id = [-1 if laws_mode else mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_PAIR, nm)
               for _pl, _w, nm in pairs]
    for pl, w, _nm in pairs:
        g1, g2 = plane_geom[pl], gid[w]
        pair_of[g1, g2] = pair_of[g2, g1] = pl * nw + w

    def configure(qq, vv, obst_lc, f_obst, with_obstacle=True):
        """Set every pair's solref (and friction slope); return the rule's timestep and the
        friction-slope scale.

        Rows: normal J_i = n^T J_p,i with (k_i, c_i); with friction two tangent rows per
        contact with the viscous slope mu f_ref / v_slip of the own engine's regularised
        Coulomb law (f_ref: static load, or the obstacle's predicted peak), scaled down
        so that their rate lambda_max(C_t, M) does not exceed the normal modes' rate."""
        cs = sys.contacts(qq, vv)
        M = sys.mass_matrix(qq)
        Minv = np.linalg.inv(M)
        rows_n, rows_t, slope, A_ii = [], [], {}, {}
        for k_, (pl, w, _nm) in enumerate(pairs):
            lc = obst_lc if pl == io else ground_map[w]
            J = sys.planes[pl].n @ cs.Jp[pl, w]
            A_ii[k_] = float(J @ Minv @ J)
            if pl != io or with_obstacle:
                rows_n.append((J, lc.k, lc.c))
            if config.mu > 0.0:
                f_ref = f_obst if pl == io else lc.k * (cs.delta[pl, w] - lc.offset)
                slope[k_] = config.mu * max(f_ref, 0.0) / config.v_slip      # N s/m
                if pl != io or with_obstacle:
                    n = sys.planes[pl].n
                    for t in np.linalg.svd(np.eye(3) - np.outer(n, n))[0][:, :2].T:
                        rows_t.append((t @ cs.Jp[pl, w], 0.0, slope[k_]))
        rate_n = _max_rate(M, rows_n)
        lam_t = _max_rate(M, rows_t)
        scale = min(1.0, rate_n / lam_t) if lam_t > 0.0 else 1.0
        for k_, (pl, w, _nm) in enumerate(pairs):
            lc = obst_lc if pl == io else ground_map[w]
            p = pair_id[k_]
            if p < 0:      # contact="laws": no MuJoCo pair
                continue
            # f = -(s r + b r' + d a0) / (d A + (1 - d) A~): scale by that denominator,
            # with the contact's own A_ii at this state (the d A term is 0.1 % for a
            # pendulum tip whose A_ii is 13 A~)
            sa = (1.0 - IMPEDANCE) * A_tilde[w] + IMPEDANCE * A_ii[k_]
            m.pair_solref[p] = (-lc.k * sa, -lc.c * sa)
            if config.mu > 0.0:
                # friction rows: f_t = -B v_t / R_t with R_t = R_n / impratio
                m.pair_solreffriction[p] = (0.0, -scale * slope[k_] * sa / m.opt.impratio)
        rate = rate_n + scale * lam_t
        h_r = math.pi / (steps_per_mode * rate) if rate > 0 else 1e-4
        if m.neq:
            # loop closure: acceleration-level Baumgarte J a = -2 alpha J v - alpha^2 phi;
            # MuJoCo's (1 - d) a0 leak needs a faster alpha than the own engine's exact
            # constraint: alpha = 0.05 / h (alpha h fixed, stable), at least `baumgarte`
            h_e = h_r if timestep is None else float(timestep)
            a_e = max(config.integrator.baumgarte, 0.05 / h_e)
            m.eq_solref[:] = (-a_e * a_e, -2.0 * a_e)
        return h_r, scale

    h_rule, fric_scale = configure(q, v, obst_map, 0.0, ol.spring_damper() is not None)
    h_approach = h_rule if timestep is None else float(timestep)
    m.opt.timestep = h_approach

    d.qpos[:] = mujoco_qpos(model, layout, m, q)
    d.qvel[:] = mujoco_velocity(model, layout, m, q, v)
    d.time = 0.0
    mujoco.mj_forward(m, d)

    obstacle_w = np.flatnonzero(touch)
    z_max = config.obstacle_height
    offset_o = float(n_o @ obst.p0)

    def obstacle_gaps(xpos):
        c = xpos[gid_o]
        g = c @ n_o - offset_o - radii_o
        if math.isfinite(z_max):
            g = np.where(c[:, 2] - radii_o * n_o[2] <= z_max, g, np.inf)
        return g

    gid_o, radii_o = gid[obstacle_w], radii[obstacle_w]
    obst_gid = plane_geom[io]
    # raw records, one per step: the state before the step and what MuJoCo computed at it
    # (mj_step runs mj_forward on that state: contacts and efc_force belong to it)
    T_rec, QP, QV, XP, CON = [], [], [], [], []
    friction_rows = condim == "3"
    wheel_body = m.geom_bodyid[gid]
    wheel_root = m.body_rootid[wheel_body]

    # contact="laws": what applied_forces needs, bound once (it runs once per MuJoCo step:
    # Python on lists for the few wheels, numpy only where the bits depend on it)
    cvel_d, stc_d, xipos_d, xfrc_d = d.cvel, d.subtree_com, d.xipos, d.xfrc_applied
    N_l = sys.N.tolist()
    off_l = sys.offsets.tolist()
    rad_l = radii.tolist()
    zmax_l = sys.z_max.tolist()
    bounded = sys.bounded
    # pairs a plane can touch: (plane, wheel, z_max, height of c - r n over c)
    pair_geom = [(k_, w, zmax_l[k_], rad_l[w] * N_l[k_][2]) for k_ in range(npl)
                 for w in range(nw) if sys.touch[k_][w] or not bounded]
    laws = [p.law for p in sys.planes]
    # how each plane's law is evaluated: "family" (HuntCrossleyFamily.force, one exponent
    # for every plane: one family_force call for all pairs, parameters per pair), "kv"
    # (KelvinVoigt.force in Python floats: k d + c d' elementwise, the same operations),
    # else the law's own force per plane
    family = one_family(laws)
    fam_n = float(laws[0].n) if family else None
    fam_kz = [(float(law.k), float(law.z)) for law in laws] if family else None
    is_kv = [type(law).force is KelvinVoigt.force for law in laws]
    # xfrc_applied rows: the wheel bodies (first occurrence order) and their wheels
    bodies = list(dict.fromkeys(wheel_body.tolist()))
    body_rows = np.array(bodies)
    wheels_of = ([[w for w in range(nw) if wheel_body[w] == b] for b in bodies]
                 if len(bodies) < nw else None)
    zero6 = [0.0] * 6

    def applied_forces() -> tuple[list, bool]:
        """contact="laws": normal forces (planes x wheels, flat) of the laws at MuJoCo's
        current state (after mj_step1), applied to the wheel bodies at the contact points;
        and whether a wheel is inside the obstacle face."""
        c = xpos_d[gid]
        G = (sys.N @ c.T).tolist()                # as sys.gaps_of_centres (same matmul)
        cl = c.tolist()
        on = []                                   # (plane, wheel, delta) in contact
        for k_, w, zm, rnz in pair_geom:
            cw = cl[w]
            g = G[k_][w] - off_l[k_] - rad_l[w]
            if g < 0.0 and (not bounded or cw[2] - rnz <= zm):
                on.append((k_, w, -g))
        f_n = [0.0] * (npl * nw)
        if not on:
            xfrc_d[body_rows] = 0.0
            return f_n, False
        # velocity of the sphere centres from MuJoCo's com-based body velocities (as
        # mj_objectVelocity): v = v_o + w x (c - o), o the subtree com of the body's root
        cv = cvel_d[wheel_body].tolist()
        so = stc_d[wheel_root].tolist()
        vc = []
        for (w0, w1, w2, v0, v1, v2), (c0, c1, c2), (o0, o1, o2) in zip(cv, cl, so, strict=True):
            r0, r1, r2 = c0 - o0, c1 - o1, c2 - o2
            vc.append([v0 + (w1 * r2 - w2 * r1), v1 + (w2 * r0 - w0 * r2),
                       v2 + (w0 * r1 - w1 * r0)])
        R = (sys.N @ np.array(vc).T).tolist()    # rate = -n . v (same matmul as before)
        # the laws' forces, clamped at 0
        if family:
            v_i = [p.v_i for p in sys.planes]
            if len({k_ for k_, _w, _d in on}) == 1:
                k_ = on[0][0]
                kk, zz = fam_kz[k_]
                raw = family_force(kk, fam_n, zz, np.array([x for _k, _w, x in on]),
                                   np.array([-R[k_][w] for _k, w, _d in on]), v_i[k_])
            else:
                par = np.array([[fam_kz[k_][0] for k_, _w, _d in on],
                                [fam_kz[k_][1] for k_, _w, _d in on],
                                [v_i[k_] for k_, _w, _d in on],
                                [x for _k, _w, x in on],
                                [-R[k_][w] for k_, w, _d in on]])
                raw = family_force(par[0], fam_n, par[1], par[3], par[4], par[2])
            fl = [max(x, 0.0) for x in raw.tolist()]
        else:
            fl = []
            for k_ in range(npl):
                sel = [(w, x) for kk, w, x in on if kk == k_]
                if not sel:
                    continue
                law = laws[k_]
                if is_kv[k_]:
                    kk, cc = law.k, law.c
                    fl += [max(kk * x + cc * -R[k_][w], 0.0) for w, x in sel]
                else:
                    raw = law.force(np.array([x for _w, x in sel]),
                                    np.array([-R[k_][w] for w, _x in sel]),
                                    sys.planes[k_].v_i)
                    fl += np.maximum(np.asarray(raw, float), 0.0).tolist()
        # force f n at the contact point c - r n: xfrc_applied takes it at the body's com;
        # summed over the planes in plane order
        xi = xipos_d[wheel_body].tolist()
        wrench = [None] * nw
        for (k_, w, _x), f in zip(on, fl, strict=True):
            f_n[k_ * nw + w] = f
            n0, n1, n2 = N_l[k_]
            F0, F1, F2 = f * n0, f * n1, f * n2
            r = rad_l[w]
            cw, xw = cl[w], xi[w]
            a0, a1, a2 = (cw[0] - xw[0]) - r * n0, (cw[1] - xw[1]) - r * n1, \
                (cw[2] - xw[2]) - r * n2
            T0, T1, T2 = a1 * F2 - a2 * F1, a2 * F0 - a0 * F2, a0 * F1 - a1 * F0
            s = wrench[w]
            if s is None:       # 0.0 + as np.add.at on zeroed rows (a -0.0 becomes 0.0)
                wrench[w] = (0.0 + F0, 0.0 + F1, 0.0 + F2, 0.0 + T0, 0.0 + T1, 0.0 + T2)
            else:               # the next plane
                wrench[w] = (s[0] + F0, s[1] + F1, s[2] + F2, s[3] + T0, s[4] + T1, s[5] + T2)
        if wheels_of is None:   # one wheel per body, in wheel order
            rows = [z if z is not None else zero6 for z in wrench]
        else:                   # as np.add.at: each body's wheels added in wheel order
            rows = []
            for ws in wheels_of:
                acc = zero6
                for w in ws:
                    if wrench[w] is not None:
                        acc = [x + y for x, y in zip(acc, wrench[w], strict=True)]
                rows.append(acc)
        xfrc_d[body_rows] = rows
        return f_n, any(k_ == io for k_, _w, _x in on)

    def advance():
        """One MuJoCo step from the current state; contact="laws": the laws' forces and
        whether the obstacle is touched (:func:`applied_forces`)."""
        if not laws_mode:
            mujoco.mj_step(m, d)
            return None
        mujoco.mj_step1(m, d)
        forces = applied_forces()
        mujoco.mj_step2(m, d)
        return forces

    # MjData's arrays, bound once: views of its buffer (each attribute access builds one)
    qpos_d, qvel_d, xpos_d = d.qpos, d.qvel, d.geom_xpos
    mj_step = mujoco.mj_step

    def step_and_record() -> bool:
        """One step; True if the recorded state has an obstacle contact (one whose rows are
        in efc_force: a contact at dist = margin exactly is listed without rows). Records
        the contacts' geoms, efc addresses and the whole efc_force, sorted into pairs
        after the run, all at once: called once per MuJoCo step, its Python is the
        engine's overhead, as few numpy calls as possible."""
        T_rec.append(d.time)
        QP.append(qpos_d.copy())
        QV.append(qvel_d.copy())
        if laws_mode:
            forces = advance()
            XP.append(xpos_d.copy())           # touching: inside the face (a damper may
            CON.append(forces[0])              # have brought the force to 0 before)
            return forces[1]
        mj_step(m, d)
        XP.append(xpos_d.copy())
        if not d.ncon:
            CON.append(None)
            return False
        con = d.contact
        geom, adr = con.geom.copy(), con.efc_address.copy()
        CON.append((geom, adr, d.efc_force.copy()))
        # a few contacts: Python on lists is faster than numpy's calls on them. Either geom
        # (box-sphere contacts come as (sphere, box)), the contact with rows (adr >= 0)
        g = geom.ravel().tolist()
        if obst_gid not in g:
            return False
        a = adr.tolist()
        return any(a[j >> 1] >= 0 for j, x in enumerate(g) if x == obst_gid)

    def check(where):
        if d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number or not math.isfinite(
                float(d.qvel.sum())):
            raise SolverError(f"the MuJoCo run diverged {where} (t = {d.time:.6g} s, timestep "
                              f"{m.opt.timestep:.3g} s): lower the timestep or raise "
                              "steps_per_mode")

    # ---- approach: step until an obstacle gap changes sign, then redo that step partially
    n_max = int(min(config.t_max / h_approach + 2, _MAX_STEPS))
    if config.t_max / h_approach > _MAX_STEPS:
        raise SolverError(f"the approach would need {config.t_max / h_approach:.3g} MuJoCo "
                          f"steps of {h_approach:.3g} s: shorten t_max or reduce distance")
    g_prev = float(np.min(obstacle_gaps(d.geom_xpos)))
    hit = False
    for _ in range(n_max):
        g_n = g_prev
        step_and_record()                  # records the state before the step: keep it
        qpos_n, qvel_n, t_n = QP[-1], QV[-1], T_rec[-1]
        mujoco.mj_kinematics(m, d)
        g_prev = float(obstacle_gaps(xpos_d).min())
        if g_prev <= 0.0:
            hit = True
            break
        if d.time >= config.t_max:
            break
    check("before the obstacle")
    if not hit:
        raise SolverError(
            f"no obstacle contact within t_max = {config.t_max} s (nearest wheel started "
            f"{float(np.min(gaps0[finite])):.4g} m away at {config.speed} m/s): increase t_max "
            "or reduce distance")
    # secant on the fraction of the last step (no obstacle force acts within it)
    lo, hi, g_lo, g_hi = 0.0, h_approach, g_n, g_prev
    for _ in range(6):
        tau = lo + (hi - lo) * g_lo / (g_lo - g_hi) if g_lo != g_hi else hi
        d.qpos[:], d.qvel[:], d.time = qpos_n, qvel_n, t_n
        m.opt.timestep = max(tau, 1e-15)
        advance()
        mujoco.mj_kinematics(m, d)
        g = float(np.min(obstacle_gaps(d.geom_xpos)))
        if abs(g) < 1e-10:
            break
        if g > 0:
            lo, g_lo = tau, g
        else:
            hi, g_hi = tau, g
    m.opt.timestep = h_approach
    t_c = float(d.time)
    i_contact = len(T_rec)
    q_minus, v_minus = pinocchio_state(model, layout, m, d.qpos, d.qvel)

    # ---- pre-impact quantities (Pinocchio, the own engine's definitions)
    g_now = sys.gaps(q_minus)[io]
    wheel = first_contact_wheel(g_now)
    cs = sys.contacts(q_minus, v_minus)
    v_n = float(cs.delta_dot[io, wheel])
    if v_n <= 0.0:  # pragma: no cover - the gap decreased over the last step
        raise SolverError("the first obstacle contact has no approach velocity")
    obst.v_i = v_n
    T_c, m_eff, labels = effective_energy(sys, mbm, q_minus, v_minus, wheel, config)
    T_minus = sys.kinetic_energy(q_minus, v_minus)
    E_minus = float(T_minus + sys.potential_energy(q_minus))
    m_c = 2.0 * T_c / v_n**2
    obst_map = linear_contact(ol, m_eff=None if ol.spring_damper() is not None else m_c,
                              v_n=v_n)
    f_obst = float(predict(KelvinVoigt(k=obst_map.k, c=obst_map.c), m_c, v_n).peak_force)
    h_rule, fric_scale = configure(q_minus, v_minus, obst_map, f_obst)
    # a window shorter than the rule's step is one step of that length (never zero steps)
    h = min(h_approach, h_rule, config.t_after) if timestep is None else float(timestep)
    m.opt.timestep = h
    if m.neq and h_rule > h:       # keep alpha h = 0.05 with the step actually used
        a_e = max(config.integrator.baumgarte, 0.05 / h)
        m.eq_solref[:] = (-a_e * a_e, -2.0 * a_e)

    # ---- contact phase: until no obstacle contact is left (every gap >= 0) or t_after
    n_steps = max(1, math.ceil(config.t_after / h - 0.5))
    if n_steps > _MAX_STEPS:
        raise SolverError(f"the impact would need {n_steps:.3g} MuJoCo steps of "
                          f"{h:.3g} s: shorten t_after or soften the contact")
    started, separated = False, False
    for _ in range(n_steps):
        touching = step_and_record()
        if touching:
            started = True
        elif started:
            separated = True
            break
    check("during the impact")
    mujoco.mj_kinematics(m, d)
    XP.append(d.geom_xpos.copy())             # geometry of the state after the last step

    # ---- arrays: forces of every (plane, wheel) pair per record, gaps from the geometry
    T = np.asarray(T_rec)
    nrec = len(T)
    FNa = np.zeros((nrec, npl * nw))
    FTa = np.zeros((nrec, npl * nw))
    if laws_mode:
        if nrec:
            FNa[:] = np.reshape(CON, (nrec, npl * nw))
    else:
        # every record's contacts at once: record index, geoms, rows in the records'
        # efc_force laid end to end; pairs summed in contact order as one record at a time
        rec = [i for i, con in enumerate(CON) if con is not None]
        if rec:
            geom = np.concatenate([CON[i][0] for i in rec])
            adr = np.concatenate([CON[i][1] for i in rec])
            efc = [CON[i][2] for i in rec]
            f = np.concatenate(efc)
            ncon = np.array([len(CON[i][1]) for i in rec])
            start = np.cumsum([0] + [len(e) for e in efc[:-1]])
            rows = np.repeat(np.array(rec), ncon)
            idx = pair_of[geom[:, 0], geom[:, 1]]
            ok = (adr >= 0) & (idx >= 0)     # dist = margin exactly: listed, no rows
            at = (adr + np.repeat(start, ncon))[ok]
            cell = (rows[ok], idx[ok])
            np.add.at(FNa, cell, f[at])
            if friction_rows:
                np.add.at(FTa, cell, np.hypot(f[at + 1], f[at + 2]))
    FNa = FNa.reshape(nrec, npl, nw)
    FTa = FTa.reshape(nrec, npl, nw)
    XPa = np.asarray(XP)                      # (nrec + 1, ngeom, 3)
    GPa = np.full((nrec + 1, npl, nw), np.inf)
    if has_ground:
        GPa[:, 0] = XPa[:, gid, 2] - radii
    co = XPa[:, gid_o]
    go = co @ n_o - offset_o - radii_o
    if math.isfinite(z_max):
        go = np.where(co[..., 2] - radii_o * n_o[2] <= z_max, go, np.inf)
    GPa[:, io, obstacle_w] = go
    if separated:
        # last record: the first state without an obstacle contact (gap >= 0); the one
        # before it touched (gap < 0): interpolate the crossing
        g1 = float(np.min(GPa[nrec - 1, io, obstacle_w]))
        g0 = float(np.min(GPa[nrec - 2, io, obstacle_w]))
        t1, t0 = T[-1], T[-2]
        t_stop = t0 + (t1 - t0) * (-g0) / (g1 - g0) if g0 < 0.0 < g1 else t1
    else:
        t_stop = float(d.time)
    QPa, QVa = np.asarray(QP), np.asarray(QV)
    Qp, Vp = pinocchio_state(model, layout, m, QPa, QVa)
    q_plus, v_plus = Qp[-1], Vp[-1]
    T_plus = sys.kinetic_energy(q_plus, v_plus)
    E_plus = float(T_plus + sys.potential_energy(q_plus))

    # ---- peaks: parabola through the samples around an interior maximum, only where
    # the force is smooth: every wheel in contact in all three samples or in none
    # (Kelvin-Voigt jumps to c v_n at touch)
    def peak(forces, times):
        forces = forces.reshape(len(times), -1)
        series = forces.sum(axis=1)
        i = int(np.argmax(series))
        f, t = float(series[i]), float(times[i])
        on = forces[i - 1: i + 2] > 0.0
        if 0 < i < len(series) - 1 and f > 0.0 and np.all(on.all(axis=0) | ~on.any(axis=0)):
            y0, y1, y2 = series[i - 1], series[i], series[i + 1]
            den = y0 - 2 * y1 + y2
            if den < 0.0:
                s = 0.5 * (y0 - y2) / den
                f = float(y1 - 0.25 * (y0 - y2) * s)
                t = float(times[i] + s * (times[i + 1] - times[i]))
        return f, t

    Tc_ = T[i_contact:]
    fo = FNa[i_contact:, io, :]
    F_total, _t_total = peak(fo, Tc_)
    F_max, t_peak, impulse = {}, {}, {}
    dt = np.diff(np.append(Tc_, d.time))
    for w, wn in enumerate(names_w):
        if fo[:, w].max() > 0.0:
            F_max[f"obstacle_{wn}"], tp = peak(fo[:, w], Tc_)
            t_peak[f"obstacle_{wn}"] = tp - t_c
        else:
            F_max[f"obstacle_{wn}"], t_peak[f"obstacle_{wn}"] = 0.0, float("nan")
        impulse[f"obstacle_{wn}"] = float(np.sum(fo[:, w] * dt))

    # ---- history
    data = {"t": T - t_c}
    for j in range(sys.nq):
        data[f"q_{j}"] = Qp[:, j]
    for j in range(sys.nv):
        data[f"v_{j}"] = Vp[:, j]
    pl_names = [p.name for p in sys.planes]
    for p, pn in enumerate(pl_names):
        for w, wn in enumerate(names_w):
            data[f"{pn}_{wn}_fn"] = FNa[:, p, w]
            data[f"{pn}_{wn}_ft"] = FTa[:, p, w]
            gpw = GPa[:nrec, p, w]
            data[f"{pn}_{wn}_delta"] = np.where(np.isfinite(gpw), np.maximum(-gpw, 0.0), 0.0)
    history = pd.DataFrame(data)
    mapping = {"obstacle": obst_map.note, "obstacle_k": obst_map.k, "obstacle_c": obst_map.c}
    if laws_mode:
        mapping = {"obstacle": f"{ol.name}: the law itself, applied as a force",
                   "ground": (f"{sys.planes[0].law.name}: the law itself, applied as a force"
                              if has_ground else None),
                   "timestep rule": "the spring-dampers of contact='soft'"}
    elif has_ground:
        mapping["ground"] = ground_map[0].note
        mapping["ground_k"] = [gm.k for gm in ground_map]
        mapping["ground_c"] = [gm.c for gm in ground_map]
    return SimulationResult(
        history=history, F_max=F_max, t_peak=t_peak, F_max_total=F_total, impulse=impulse,
        contact_duration=float(t_stop - t_c), separated=separated,
        T_minus=T_minus, T_plus=T_plus, E_minus=E_minus, E_plus=E_plus,
        q_minus=q_minus, v_minus=v_minus, q_plus=q_plus, v_plus=v_plus,
        T_c_minus=T_c, m_eff=m_eff, v_n=v_n, contact_wheel=names_w[wheel], A_rows=labels,
        stats={"engine": "mujoco", "contact": contact, "timestep": h,
               "timestep_approach": h_approach,
               "steps": len(T), "t_contact": t_c, "cone": cone if condim == "3" else
               "frictionless (condim 1)",
               "force_source": ("the laws at MuJoCo's state (xfrc_applied)" if laws_mode
                                else "efc_force (normal row)"),
               "impedance": IMPEDANCE, "mapping": mapping,
               "friction_slope_scale": fric_scale if config.mu > 0 else None},
    )


def simulate_impact_mujoco_laws(mbm, config: SimulationConfig | dict | None = None, *,
                                q0=None, v0=None, timestep: float | None = None,
                                steps_per_mode: int = 100) -> SimulationResult:
    """:func:`simulate_impact_mujoco` with ``contact="laws"``: MuJoCo's dynamics and
    integrator, the scenario's own contact laws (engine ``"mujoco_laws"``)."""
    return simulate_impact_mujoco(mbm, config, q0=q0, v0=v0, timestep=timestep,
                                  steps_per_mode=steps_per_mode, contact="laws")


#: Engines by name (``roverimpact simulate --engine NAME``, ``simulate = "NAME"``).
ENGINES = {"own": simulate_impact, "mujoco": simulate_impact_mujoco,
           "mujoco_laws": simulate_impact_mujoco_laws}
