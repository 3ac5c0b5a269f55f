"""The import graph points down the layers and has no cycle.

Layers, bottom to top (docs/models.md "Layers"). A module may import from its own layer's
package and from lower layers, never from a higher one, at module level or inside a
function alike. The core (exceptions, validation, kernels, energy, impulse, unilateral,
frictional) imports numpy and numba only, so it serves any engine's mass matrix.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"
PKG = SRC / "roverimpact"

#: bottom to top; a top-level module or sub-package of roverimpact per entry
LAYERS = [
    "_lazy", "exceptions", "_version", "_validation", "_kernels",  # checks and kernels
    "energy", "impulse", "unilateral", "frictional",            # the core: numbers in, out
    "_io", "_schema", "_engines",                               # files, config schemas, names
    "contact",
    "models",
    "scenario",
    "simulate",
    "safety",
    "studies",
    "experiments",
    "traverse",
    "report",
    "cli",
    "__init__", "__main__",
]
CORE = set(LAYERS[: LAYERS.index("frictional") + 1])
CORE_THIRD_PARTY = {"numpy", "numba", "llvmlite"}


def _layer(unit: str) -> int:
    if unit not in LAYERS:
        raise AssertionError(f"roverimpact.{unit} is in no layer: add it to LAYERS")
    return LAYERS.index(unit)


def _module_name(path: Path) -> str:
    rel = path.relative_to(SRC).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _imports(path: Path):
    """Absolute names imported by a file (relative imports resolved), with line numbers."""
    mod = _module_name(path)
    package = mod if path.name == "__init__.py" else mod.rsplit(".", 1)[0]
    tree = ast.parse(path.read_text(), filename=str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, node.lineno
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            # "from . import x" / "from .pkg import x": x may be a module or a name
            for alias in node.names:
                yield f"{target}.{alias.name}", node.lineno
            if node.module is not None:
                yield target, node.lineno


def _unit(name: str) -> str | None:
    parts = name.split(".")
    if parts[0] != "roverimpact":
        return None
    return parts[1] if len(parts) > 1 else "__init__"


FILES = sorted(PKG.rglob("*.py"))


def test_every_module_has_a_layer():
    for path in FILES:
        _layer(_unit(_module_name(path)))


def test_imports_point_down():
    problems = []
    for path in FILES:
        me = _unit(_module_name(path))
        lm = _layer(me)
        for name, line in _imports(path):
            other = _unit(name)
            if other is None or other == me:
                continue
            try:
                lo = _layer(other)
            except AssertionError:
                continue  # "from . import x" where x is a name, not a module
            if lo > lm:
                problems.append(f"{path.relative_to(ROOT)}:{line}: {me} (layer {lm}) imports "
                                f"{name} (layer {lo})")
    assert not problems, "upward or sideways imports:\n" + "\n".join(problems)


def test_core_imports_numpy_and_numba_only():
    stdlib = set(sys.stdlib_module_names)
    problems = []
    for path in FILES:
        if _unit(_module_name(path)) not in CORE:
            continue
        for name, line in _imports(path):
            top = name.split(".")[0]
            if top in stdlib or top == "roverimpact" or top == "":
                continue
            if top not in CORE_THIRD_PARTY:
                problems.append(f"{path.relative_to(ROOT)}:{line}: core imports {name}")
    assert not problems, "\n".join(problems)


def test_no_import_cycle_between_modules():
    """No cycle among the package's modules (inside a sub-package too)."""
    graph: dict[str, set[str]] = {}
    names = {_module_name(p) for p in FILES}
    for path in FILES:
        me = _module_name(path)
        deps = set()
        for name, _ in _imports(path):
            while name and name not in names:
                name = name.rpartition(".")[0]
            if name and name != me and not me.startswith(name + "."):
                deps.add(name)  # a package's __init__ importing its children is fine
        graph[me] = deps
    # Tarjan's strongly connected components
    index, low, stack, on, sccs = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                sccs.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in graph:
        if v not in index:
            visit(v)
    assert not sccs, f"import cycles: {sccs}"


def _modules_after(code: str, *argv: str) -> list[str]:
    """The modules a fresh interpreter holds after running ``code`` (with ``sys.argv[1:]``
    = ``argv``)."""
    script = f"import sys\n{code}\nprint(' '.join(sorted(sys.modules)))"
    return subprocess.run([sys.executable, "-c", script, *argv], capture_output=True,
                          text=True, check=True).stdout.split()


@pytest.mark.parametrize("module,forbidden", [
    ("roverimpact", ("pinocchio", "pandas", "pydantic", "scipy", "matplotlib", "dask",
                     "mujoco")),
    # (numba itself imports scipy for its LAPACK bindings)
    ("roverimpact.energy", ("pinocchio", "pandas", "pydantic", "matplotlib")),
    ("roverimpact.unilateral", ("pinocchio", "pandas", "pydantic", "matplotlib")),
    ("roverimpact.cli", ("pinocchio", "pandas", "numba", "scipy", "matplotlib", "dask",
                         "mujoco")),
])
def test_light_imports(module, forbidden):
    """What importing a module loads (a fresh interpreter): the heavy libraries wait."""
    out = _modules_after(f"import {module}")
    loaded = sorted(set(forbidden) & {m.split(".")[0] for m in out})
    assert not loaded, f"import {module} loads {loaded}"


def test_a_report_loads_neither_the_evaluator_nor_the_simulators(tmp_path):
    """``roverimpact report`` of saved results reads tables and draws: it imports neither
    the study evaluator (the scenario layer, Pinocchio, numba's kernels) nor the
    simulators, which took half a second of its start (``roverimpact.studies`` loads its
    names on first use; the engines' names are :mod:`roverimpact._engines`)."""
    from roverimpact.studies import run_study

    run_study(ROOT / "examples" / "study_rigid_body.toml", tmp_path / "rb")
    out = _modules_after("from roverimpact.report import build_report\n"
                         "build_report(sys.argv[1], n_boot=0)", str(tmp_path / "rb"))
    assert (tmp_path / "rb" / "report.html").is_file()
    loaded = [m for m in out if m.split(".")[0] in ("pinocchio", "numba", "mujoco")
              or m.startswith(("roverimpact.studies.evaluate", "roverimpact.studies.sweep",
                               "roverimpact.simulate", "roverimpact.scenario",
                               "roverimpact.models"))]
    assert not loaded, f"the report loads {loaded}"


def test_a_study_that_only_ranks_loads_no_simulator(tmp_path):
    """A study without ``simulate`` computes T_c^- and the predicted force: it imports
    neither the simulators nor MuJoCo (the evaluator imports them when a study simulates)."""
    out = _modules_after("from roverimpact.studies import run_study\n"
                         "run_study(sys.argv[1], sys.argv[2])",
                         str(ROOT / "examples" / "study_rigid_body.toml"), str(tmp_path / "rb"))
    assert (tmp_path / "rb" / "results.parquet").is_file()
    loaded = [m for m in out if m.split(".")[0] == "mujoco"
              or m.startswith("roverimpact.simulate")]
    assert not loaded, f"a study that only ranks loads {loaded}"


@pytest.mark.parametrize("module", ["roverimpact.report.simulation", "roverimpact.report.draw",
                                    "roverimpact.report.contact"])
def test_a_figure_of_one_case_loads_no_study_report(module):
    """``roverimpact simulate``, ``draw`` and ``contact --plot`` draw one case's figure: the
    report package loads its names on first use and its figures module reads tables
    without importing pandas, so these import neither the study report and its
    statistics (scipy.stats: half a second of ``simulate``'s 2.3 s) nor pandas (0.2 s of
    ``contact --plot``)."""
    out = _modules_after(f"import {module}")
    loaded = [m for m in out if m.startswith(("scipy.stats", "roverimpact.report.html",
                                              "roverimpact.studies", "pandas"))]
    assert not loaded, f"{module} loads {sorted({m.split('.')[0] for m in loaded})}: {loaded[:5]}"


def test_the_engines_names_are_the_engines():
    from roverimpact._engines import ENGINE_NAMES
    from roverimpact.simulate.engines import ENGINES

    assert ENGINE_NAMES == tuple(ENGINES)


def test_no_private_name_crosses_a_module():
    """``from module import _name`` only from private modules (``_validation``, ``_kernels``),
    never a private name of another public module."""
    problems = []
    for path in FILES:
        mod = _module_name(path)
        package = mod if path.name == "__init__.py" else mod.rsplit(".", 1)[0]
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, ast.ImportFrom) or not (node.level or (node.module or "")
                                                            .startswith("roverimpact")):
                continue
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module
            if target.rsplit(".", 1)[-1].startswith("_"):
                continue  # a private module: shared inside the package
            folder = SRC.joinpath(*target.split("."))
            for alias in node.names:
                is_module = (folder / f"{alias.name}.py").is_file() or (folder / alias.name).is_dir()
                if alias.name.startswith("_") and not alias.name.startswith("__") and not is_module:
                    problems.append(f"{path.relative_to(ROOT)}:{node.lineno}: "
                                    f"{target}.{alias.name}")
    assert not problems, "private names imported across modules:\n" + "\n".join(problems)
