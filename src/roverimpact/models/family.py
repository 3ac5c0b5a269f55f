"""Models of one family: the same joints, bodies, frames and wheels, other numbers.

A study that changes a built-in rover's parameters from case to case (COM height, masses,
lengths) changes numbers only, never the structure of the model. Instead of building a
Pinocchio model per case, :func:`family_numbers` computes the numbers of a whole block of
parameter sets at once (body masses, centres of mass, inertias, joint placements, nominal
configurations, wheel radii: one array each, over the block) and :class:`ModelFamily`
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
from .rocker_bogie import rocker_bogie_numbers

__all__ = ["FamilyNumbers", "ModelFamily", "family_numbers", "has_family"]

#: The builders whose numbers :func:`family_numbers` computes without building:
#: ``(preset, [params, ...]) -> FamilyNumbers``.
_NUMBERS: dict[str, Callable[[str | None, Sequence[Mapping]], FamilyNumbers]] = {
    "rocker_bogie": rocker_bogie_numbers,
}


def has_family(name: str | None) -> bool:
    """Whether the built-in rover ``name`` has :func:`family_numbers`."""
    return name in _NUMBERS


def family_numbers(name: str, preset: str | None, params: Sequence[Mapping]
                   ) -> FamilyNumbers:
    """The numbers of the built-in rovers ``name`` (``preset``) with parameters
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

    Only the bodies whose numbers differ between members are written (a study that
    changes the chassis mass rewrites one inertia). The wheels and ``params`` of ``mbm``
    stay those it was built with: the members' wheel radii and nominal configurations are
    in :attr:`numbers`.
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
            return [b for b in range(nb) if not (x[:, b] == x[:1, b]).all()]

        inert = set(varies(n.mass)) | set(varies(n.lever)) | set(varies(n.inertia))
        self._inertias = sorted(inert)
        self._placements = varies(n.translation)

    @property
    def k(self) -> int:
        """Number of members."""
        return self.numbers.k

    def write(self, i: int) -> None:
        """Make the Pinocchio model that of member ``i`` (inertias, joint placements)."""
        model, n = self.mbm.model, self.numbers
        for b in self._inertias:
            # as appendBodyToJoint adds a body to a joint of no inertia
            model.inertias[b + 1] = pin.Inertia.Zero() + pin.Inertia(
                float(n.mass[i, b]), n.lever[i, b], n.inertia[i, b])
        for b in self._placements:
            model.jointPlacements[b + 1] = pin.SE3(_EYE, n.translation[i, b])


_EYE = np.eye(3)
