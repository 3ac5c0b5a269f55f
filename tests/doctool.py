"""``tools/doc_numbers.py`` loaded once per test session (one module object, so that what
it computes once, such as the default-ground MuJoCo runs, serves every test module)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

TOOL = Path(__file__).resolve().parents[1] / "tools" / "doc_numbers.py"


def doc_numbers():
    mod = sys.modules.get("doc_numbers")
    if mod is not None and Path(mod.__file__).resolve() == TOOL:
        return mod
    spec = importlib.util.spec_from_file_location("doc_numbers", TOOL)
    mod = importlib.util.module_from_spec(spec)
    sys.modules["doc_numbers"] = mod      # dataclasses look their module up by name
    spec.loader.exec_module(mod)
    return mod
