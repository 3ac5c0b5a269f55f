"""Models of one family: the same joints, bodies, frames and wheels, other numbers.

A study that changes a built-in model's parameters from case to case (COM height, masses,
lengths) changes numbers only, never the structure of the model. Instead of building a
Pinocchio model per case, :func:`family_numbers` computes the numbers of a whole block of
parameter sets at once (body masses, centres of mass, inertias, joint placements, nominal
configurations, wheel radii, the placements of frames that are parameters such as the
rigid body's contact corner: one array each, over the block) and :class:`ModelFamily`
writes one member's numbers into one Pinocchio model of the family before its kinematics
and dynamics are evaluated (the Pinocchio functions read the model's inertias and joint
placements at each call). Tested against a freshly built model per member (M, A, v to
1e-12).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
import pinocchio as pin

from ._build import FamilyNumbers
from .base import MultibodyModel
from .rigid_body import rigid_body_numbers
from .rocker_bogie import rocker_bogie_numbers
from .rover2d import rover2d_numbers

__all__ = ["FamilyNumbers", "ModelFamily", "family_numbers", "has_family"]

#: The builders whose numbers :func:`family_numbers` computes without building:
#: ``(preset, [params, ...]) -> FamilyNumbers``.
_NUMBERS: dict[str, Callable[[str | None, Sequence[Mapping]], FamilyNumbers]] = {
    "rigid_body": rigid_body_numbers,
    "rocker_bogie": rocker_bogie_numbers,
    "rover2d": rover2d_numbers,
}


def has_family(name: str | None) -> bool:
    """Whether the built-in model ``name`` has :func:`family_numbers`."""
    return name in _NUMBERS


def family_numbers(name: str, preset: str | None, params: Sequence[Mapping]
                   ) -> FamilyNumbers:
    """The numbers of the built-in models ``name`` (``preset``) with parameters
    ``params[i]``, each checked as the builder checks it.

    Parameter sets that change the model's structure have no place in one family; the
    caller keys its blocks so that they do not (for the rocker-bogie every parameter is
    a number).

    Raises
    ------
    KeyError
        ``name`` has no family numbers (:func:`has_family`).
    ModelError
        A bad parameter set (the builder's message).
    """
    return _NUMBERS[name](preset, params)


class ModelFamily:
    """One Pinocchio model of a family, rewritten member by member.

    Parameters
    ----------
    mbm : MultibodyModel
        A model of the family, built by its builder (its Pinocchio model is modified by
        :meth:`write`: build it for this purpose).
    numbers : FamilyNumbers
        The members' numbers (:func:`family_numbers`).

    Only the bodies whose numbers differ from ``mbm``'s are written (a study that
    changes the chassis mass rewrites one inertia). ``mbm`` may be any model of the
    family: a body whose numbers are the same in every member but not those ``mbm`` was
    built with is written too (a block of a study's cases that keeps a parameter at
    another value than the family's first case had: that body was once left as built).
    The wheels and ``params`` of ``mbm`` stay those it was built with: the members' wheel
    radii and nominal configurations are in :attr:`numbers`. Frames whose placements are
    numbers of the family (:attr:`FamilyNumbers.frames`) keep their rotations.
    """

    def __init__(self, mbm: MultibodyModel, numbers: FamilyNumbers):
        model = mbm.model
        nb = numbers.mass.shape[1]
        if (model.njoints != nb + 1 or numbers.q_nominal.shape[-1] != model.nq
                or numbers.wheel_radius.shape[1] != len(mbm.wheels)):
            raise ValueError("the numbers are not those of this model's family")
        self.mbm = mbm
        self.numbers = numbers
        n = numbers

        def varies(x):
            return {b for b in range(nb) if not (x[:, b] == x[:1, b]).all()}

        frames = []
        for name, t in n.frames.items():
            if not model.existFrame(name) or t.shape != (n.k, 3):
                raise ValueError("the numbers are not those of this model's family")
            fid = model.getFrameId(name)
            placement = model.frames[fid].placement
            if not (t == placement.translation).all():
                frames.append((fid, placement.rotation.copy(), t))
        self._frames = frames
        inert = varies(n.mass) | varies(n.lever) | varies(n.inertia)
        self._inertias = sorted(inert | {b for b in range(nb)
                                         if b not in inert and not self._as_built(b)})
        self._placements = [b for b in range(nb) if not (
            n.translation[:, b] == model.jointPlacements[b + 1].translation).all()]

    def _inertia(self, i: int, b: int) -> pin.Inertia:
        """Body ``b``'s inertia in member ``i``, as appendBodyToJoint adds a body to a
        joint of no inertia (to rounding: it also moves the body's inertia by its
        placement, the identity, which changes the rotational inertia by 1e-17)."""
        n = self.numbers
        return pin.Inertia.Zero() + pin.Inertia(float(n.mass[i, b]), n.lever[i, b],
                                                n.inertia[i, b])

    def _as_built(self, b: int) -> bool:
        """Whether body ``b`` of the model holds the first member's inertia, to the bit
        (as appendBodyToJoint stores it)."""
        n, have = self.numbers, self.mbm.model.inertias[b + 1]
        want = pin.Inertia.Zero()
        want += pin.Inertia(float(n.mass[0, b]), n.lever[0, b], n.inertia[0, b]).se3Action(
            _IDENTITY)
        return bool(want.mass == have.mass and (want.lever == have.lever).all()
                    and (want.inertia == have.inertia).all())

    @property
    def k(self) -> int:
        """Number of members."""
        return self.numbers.k

    def write(self, i: int) -> None:
        """Make the Pinocchio model that of member ``i`` (inertias, joint placements, the
        placements of the frames in :attr:`FamilyNumbers.frames`)."""
        model, n = self.mbm.model, self.numbers
        for b in self._inertias:
            model.inertias[b + 1] = self._inertia(i, b)
        for b in self._placements:
            model.jointPlacements[b + 1] = pin.SE3(_EYE, n.translation[i, b])
        for fid, rotation, t in self._frames:
            model.frames[fid].placement = pin.SE3(rotation, t[i])


_EYE = np.eye(3)
_IDENTITY = pin.SE3.Identity()
