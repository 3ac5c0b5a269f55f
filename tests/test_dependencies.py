"""Every module the package imports is a declared dependency.

A module imported at module level (what ``import roverimpact.x`` runs) must come from a
*base* dependency: nothing may work only because a test extra happens to pull it in
(``typer`` >= 0.28 no longer brings ``click``, and a bare install failed on it). A module
imported inside a function may also come from an optional extra.
"""

from __future__ import annotations

import ast
import functools
import re
import sys
from importlib import metadata
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "roverimpact"
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())


def _norm(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def _req_name(req: str) -> str:
    return _norm(re.split(r"[\s<>=!~;\[]", req.strip(), maxsplit=1)[0])


BASE = {_req_name(r) for r in PYPROJECT["project"]["dependencies"]}
EXTRAS = {
    extra: {_req_name(r) for r in reqs}
    for extra, reqs in PYPROJECT["project"]["optional-dependencies"].items()
}
OPTIONAL = set().union(*EXTRAS.values())

# import name -> distribution, for modules whose distribution may be absent here
KNOWN = {"pinocchio": "pin", "dask": "dask", "distributed": "dask", "mujoco": "mujoco",
         "tomli": "tomli", "tomli_w": "tomli-w", "yaml": "pyyaml"}


def _imports(path: Path):
    """``(top-level module, at module level?)`` for every absolute import in a file."""
    tree = ast.parse(path.read_text(), filename=str(path))
    funcs = (ast.FunctionDef, ast.AsyncFunctionDef)

    def walk(node, in_func):
        for child in ast.iter_child_nodes(node):
            inner = in_func or isinstance(child, funcs)
            if isinstance(child, ast.Import):
                for alias in child.names:
                    yield alias.name.split(".")[0], not in_func
            elif isinstance(child, ast.ImportFrom) and child.level == 0 and child.module:
                yield child.module.split(".")[0], not in_func
            yield from walk(child, inner)

    yield from walk(tree, False)


@functools.cache
def _providers() -> dict[str, list[str]]:
    """Top-level module -> distributions, once: a call reads every installed file list
    (about 0.4 s with pin's cmeel-boost), and the test asks for hundreds of imports."""
    return metadata.packages_distributions()


def _distribution(module: str) -> str | None:
    dists = _providers().get(module)
    if dists:  # several may provide it (mujoco 4: mujoco, mujoco-core): prefer a declared one
        names = [_norm(d) for d in dists]
        for pool in (BASE, OPTIONAL):
            for n in names:
                if n in pool:
                    return n
        return names[0]
    return _norm(KNOWN[module]) if module in KNOWN else None


def test_every_import_is_declared():
    stdlib = set(sys.stdlib_module_names) | {"__future__"}
    problems = []
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(ROOT)
        for module, top in _imports(path):
            if module in stdlib or module == "roverimpact":
                continue
            dist = _distribution(module)
            if dist is None:
                problems.append(f"{rel}: imports {module!r}, which no installed or known "
                                "distribution provides")
            elif top and dist not in BASE:
                problems.append(f"{rel}: imports {module!r} at module level, but its "
                                f"distribution {dist!r} is not a base dependency")
            elif dist not in BASE | OPTIONAL:
                problems.append(f"{rel}: imports {module!r} ({dist!r}), declared nowhere")
    assert not problems, "\n".join(problems)


def test_no_click_import():
    """typer >= 0.28 carries its own click; importing click needs a dependency we do not have."""
    for path in SRC.rglob("*.py"):
        mods = {m for m, _ in _imports(path)}
        assert "click" not in mods, path


# Standard-library modules newer than the oldest Python of ``requires-python`` (3.10), with the
# version that brought them: each import must sit under ``if sys.version_info >= ...`` with a
# fallback (``tomli`` for ``tomllib``), or come from a module that does (``_io.tomllib``).
NEWER_STDLIB = {"tomllib": (3, 11)}


def test_requires_python_matches_the_stdlib_imports():
    """``roverimpact traverse-report`` imported ``tomllib`` bare inside a function: on
    Python 3.10, which ``requires-python = ">=3.10"`` admits, it failed with
    ModuleNotFoundError."""
    floor = tuple(int(x) for x in re.findall(r"\d+", PYPROJECT["project"]["requires-python"]))
    problems = []
    for path in sorted(SRC.rglob("*.py")):
        tree = ast.parse(path.read_text(), filename=str(path))
        guarded = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.If) and "sys.version_info" in ast.unparse(node.test):
                guarded.update(id(n) for stmt in node.body for n in ast.walk(stmt))
        for node in ast.walk(tree):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                     [node.module] if isinstance(node, ast.ImportFrom) and node.level == 0
                     else [])
            for name in names:
                since = NEWER_STDLIB.get(name.split(".")[0])
                if since and since > floor and id(node) not in guarded:
                    problems.append(f"{path.relative_to(ROOT)}:{node.lineno}: imports {name} "
                                    f"(Python >= {'.'.join(map(str, since))}) unguarded")
    assert not problems, "\n".join(problems)
