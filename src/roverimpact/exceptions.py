"""Exception types of roverimpact.

Every error the package raises on purpose derives from :class:`RoverImpactError`.
Errors caused by what the user passed in (arrays, files, options) also derive from
:class:`ValueError`, so ``except ValueError`` keeps working for callers who do not
know about roverimpact. The CLI turns any :class:`RoverImpactError` into one line on
stderr and exit code 2.
"""

from __future__ import annotations


class RoverImpactError(Exception):
    """Base class of every error raised on purpose by roverimpact."""


class InputError(RoverImpactError, ValueError):
    """An argument is malformed: wrong shape, NaN/inf, non-SPD mass matrix, out of range."""


class ConfigError(InputError):
    """A scenario, study or trials file is malformed or names something unknown."""


class ModelError(InputError):
    """A multibody model is malformed (URDF/MJCF, unknown frame or joint, bad inertia)."""


class SolverError(RoverImpactError, RuntimeError):
    """A numerical solver failed (LCP infeasible, integrator stalled, no contact in time)."""


class HeldRowsWarning(UserWarning):
    """The rows held through the impact make the effective mass of a vehicle (floating or
    planar base) larger than its total mass: they jam it (e.g. bilateral no-slip rows on
    every wheel), and T_c^- is then near T whatever the face."""


class PullingContactWarning(HeldRowsWarning):
    """A contact held through the impact (``contacts.ground = "noslip"``: the frictionless
    active set, then the no-slip rows of every holding contact kept as bilateral rows)
    needs a negative, pulling normal impulse to hold: the held set is not a possible one,
    and T_c^- is too high. ``ground = "coulomb"`` with ``mu = inf`` decides the set with
    the no-slip rows in it."""


class EnergyGainWarning(UserWarning):
    """An impact law returned a velocity after the impact with more kinetic energy than
    before. Newton's kinematic restitution with ``e > 0`` does this with Coulomb friction
    when a contact's slip stops or reverses (Kane's paradox), and with or without friction
    when the contacts have different ``e`` and one separates before the impact, or when
    bilateral (persistent) rows move before the impact. The result is the law's answer, not
    a physical one: use ``e = 0``, or (frictionless) one ``e``, bilateral rows at rest, or
    Poisson's law."""


class GroundGapWarning(UserWarning):
    """A ground wheel of a scenario on flat ground (no ``[terrain]``) is off the plane
    z = 0 in its configuration: its ground rows treat it as touching all the same.
    ``gaps``: wheel name -> height of its lowest rim point above z = 0 [m] (< 0: below),
    the wheels the message names."""

    def __init__(self, message, gaps=None):
        super().__init__(message)
        self.gaps = dict(gaps or {})


class StudyInterrupted(KeyboardInterrupt):
    """A study stopped by Ctrl-C: its message says what is kept and how to continue."""


__all__ = ["ConfigError", "EnergyGainWarning", "GroundGapWarning", "HeldRowsWarning",
           "InputError", "ModelError", "PullingContactWarning", "RoverImpactError",
           "SolverError", "StudyInterrupted"]
