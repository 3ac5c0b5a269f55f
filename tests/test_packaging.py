"""What a wheel carries: every data file of the package is declared in ``package-data``.

``roverimpact reproduce`` reads its study files with ``importlib.resources`` from
``roverimpact/data``; an editable install finds any file of the source tree, a wheel only
those that ``[tool.setuptools.package-data]`` names, so a data file left out works in
development and fails for a user. (Building a wheel here would take tens of seconds: this
checks the declaration instead.)
"""

from __future__ import annotations

import fnmatch
import subprocess
import sys
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
PKG = ROOT / "src" / "roverimpact"
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())


def _data_files() -> list[str]:
    """Non-Python files of the package, as git tracks them (no caches), relative to it."""
    try:
        out = subprocess.run(["git", "ls-files", "--", "."], cwd=PKG, capture_output=True,
                             text=True, check=True).stdout.split()
    except (OSError, subprocess.CalledProcessError):  # not a git checkout: the files here
        out = [str(p.relative_to(PKG)) for p in PKG.rglob("*") if p.is_file()
               and "__pycache__" not in p.parts]
    return sorted(f for f in out if not f.endswith(".py"))


def _declared(rel: str) -> bool:
    globs = PYPROJECT["tool"]["setuptools"]["package-data"]["roverimpact"]
    return any(fnmatch.fnmatch(rel, g) or fnmatch.fnmatch(rel, g.replace("**/", ""))
               for g in globs)


def test_every_data_file_is_declared():
    missing = [f for f in _data_files() if not _declared(f)]
    assert not missing, f"not in [tool.setuptools.package-data]: {missing}"


def test_the_builtin_studies_are_declared_data():
    from roverimpact.studies.reproduce import BUILTIN_STUDIES, builtin_study_path

    for name in BUILTIN_STUDIES:
        path = builtin_study_path(name)
        assert path.is_file()
        assert _declared(path.relative_to(PKG).as_posix()), path
