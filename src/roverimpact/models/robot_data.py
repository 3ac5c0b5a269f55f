"""Locate real robot descriptions shipped by the ``example-robot-data`` wheel.

The PyPI wheel ``example-robot-data`` installs its URDFs under
``<site-packages>/cmeel.prefix/share/example-robot-data/robots`` and, in recent
releases, no importable ``example_robot_data`` module. This finds the files through the
installed distribution's file list, so it works with or without that module.
"""

from __future__ import annotations

import importlib.metadata as md
from pathlib import Path

from ..exceptions import ModelError

__all__ = ["ROBOTS", "example_robot_urdf", "example_robots_dir"]

#: Short names of a few arms and their URDF paths relative to the ``robots`` folder.
ROBOTS = {
    "panda": "panda_description/urdf/panda.urdf",
    "ur3": "ur_description/urdf/ur3.urdf",
    "ur5": "ur_description/urdf/ur5_robot.urdf",
    "ur10": "ur_description/urdf/ur10_robot.urdf",
}


def example_robots_dir() -> Path:
    """The ``robots`` folder of the installed ``example-robot-data`` distribution.

    Raises
    ------
    ModelError
        If the package is not installed (``pip install example-robot-data``).
    """
    try:
        dist = md.distribution("example-robot-data")
    except md.PackageNotFoundError:
        raise ModelError(
            "example-robot-data is not installed: pip install example-robot-data "
            "(or roverimpact[test])"
        ) from None
    for f in dist.files or ():
        parts = Path(str(f)).parts
        if "example-robot-data" in parts and "robots" in parts:
            i = parts.index("robots")
            return Path(str(f.locate())).parents[len(parts) - i - 2]
    raise ModelError("example-robot-data is installed but ships no robots folder")


def example_robot_urdf(name: str) -> Path:
    """Path of the URDF of robot ``name``.

    ``name`` is a short name of :data:`ROBOTS` (``"panda"``, ``"ur5"``), the stem of any
    URDF in the package (``"ur3_gripper"``, ``"solo"`` ...), or a path relative to the
    ``robots`` folder (``"panda_description/urdf/panda.urdf"``).

    Examples
    --------
    >>> from roverimpact.models.robot_data import example_robot_urdf
    >>> example_robot_urdf("panda").name  # doctest: +SKIP
    'panda.urdf'
    """
    root = example_robots_dir()
    path = root / ROBOTS.get(name, name.lstrip("/"))
    if path.is_file():
        return path
    for pattern in (f"*/urdf/{name}.urdf", f"*/urdf/{name}_robot.urdf"):
        hits = sorted(root.glob(pattern))
        if hits:
            return hits[0]
    raise ModelError(
        f"no robot {name!r} in example-robot-data (short names: {sorted(ROBOTS)}; or the "
        "stem of any URDF under its robots folder, or a path relative to it)"
    )
