"""Locate real robot descriptions shipped by the ``example-robot-data`` wheel.

The PyPI wheel ``example-robot-data`` installs its URDFs under
``<site-packages>/cmeel.prefix/share/example-robot-data/robots`` and, in recent
releases, no importable ``example_robot_data`` module. This finds the files through the
installed distribution's file list, so it works with or without that module.

Wherever roverimpact takes a robot file (:func:`roverimpact.models.load_robot`, a
scenario's ``model.file``, ``roverimpact safety arm``), a robot of the package is named
by one of two equivalent spellings, resolved here by :func:`example_robot_file`:

* ``"example-robot-data:<name or path>"`` (the long form, e.g. in scenario files:
  ``"example-robot-data:panda_description/urdf/panda.urdf"``);
* ``"erd:<name or path>"`` (the short form of the CLI and README: ``"erd:panda"``,
  ``"erd:ur5"``).

``<name or path>`` is what :func:`example_robot_urdf` accepts: a short name of
:data:`ROBOTS`, the stem of any URDF of the package, or a path relative to its ``robots``
folder.
"""

from __future__ import annotations

import functools
import importlib.metadata as md
from pathlib import Path

from ..exceptions import ModelError

__all__ = [
    "ERD_PREFIXES",
    "ERD_SCHEME",
    "ROBOTS",
    "example_robot_file",
    "example_robot_urdf",
    "example_robots_dir",
    "is_example_robot",
]

#: Long prefix of a robot of the package, e.g. ``"example-robot-data:panda"``.
ERD_SCHEME = "example-robot-data:"
#: Both spellings of a robot of the package: the long one and the short ``"erd:"``.
ERD_PREFIXES = (ERD_SCHEME, "erd:")

#: Short names of a few arms and their URDF paths relative to the ``robots`` folder.
ROBOTS = {
    "panda": "panda_description/urdf/panda.urdf",
    "ur3": "ur_description/urdf/ur3_robot.urdf",  # ur3.urdf is an empty <robot/>
    "ur5": "ur_description/urdf/ur5_robot.urdf",
    "ur10": "ur_description/urdf/ur10_robot.urdf",
}


@functools.cache
def example_robots_dir() -> Path:
    """The ``robots`` folder of the installed ``example-robot-data`` distribution (found
    once per process: the distribution's list of some 100 000 files takes tens of
    milliseconds to read, and a study loads a robot per chunk; a failure is not kept).

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
            "(or the extra: pip install 'roverimpact[robots]')"
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
    for pattern in (f"*/urdf/{name}.urdf", f"*/robots/{name}.urdf", f"*/urdf/{name}_robot.urdf"):
        hits = sorted(root.glob(pattern))
        if hits:
            return hits[0]
    like = sorted({p.stem for p in root.glob(f"*/*/*{Path(name).stem}*.urdf")})
    raise ModelError(
        f"no robot {name!r} in example-robot-data ("
        + (f"URDFs whose name contains it: {like[:12]}; " if like else "")
        + f"short names: {sorted(ROBOTS)}; or the stem of any URDF under its robots folder, "
        "or a path relative to it)"
    )


def is_example_robot(source) -> bool:
    """Whether ``source`` names a robot of example-robot-data (either prefix of
    :data:`ERD_PREFIXES`) rather than a file.

    >>> is_example_robot("erd:panda"), is_example_robot("example-robot-data:ur5")
    (True, True)
    >>> is_example_robot("arm.urdf")
    False
    """
    return isinstance(source, str) and source.startswith(ERD_PREFIXES)


def example_robot_file(source: str) -> Path:
    """Path of the URDF named ``"erd:<name or path>"`` or
    ``"example-robot-data:<name or path>"`` (a bare ``<name or path>`` too).

    Raises
    ------
    ModelError
        If the package is not installed or has no such robot.

    Examples
    --------
    >>> example_robot_file("erd:panda") == example_robot_file(  # doctest: +SKIP
    ...     "example-robot-data:panda_description/urdf/panda.urdf")
    True
    """
    for prefix in ERD_PREFIXES:
        if source.startswith(prefix):
            source = source[len(prefix):]
            break
    return example_robot_urdf(source)
