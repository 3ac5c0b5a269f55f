"""Every Python block of the docs runs as written (the blocks of one page in order, in one
namespace, as a reader pastes them; each page in a fresh folder that holds a link to
``examples/``, so what the blocks write stays there).

What a block prints is not compared here: the numbers the prose quotes are kept true by
``tools/doc_numbers.py`` and the tests that name them; this checks that the code a user
copies still runs against the library."""

from __future__ import annotations

import contextlib
import io
import os
import re
import textwrap
import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: Blocks that stand for a user's own files and cannot run here (page, block index): why.
NEEDS_USER_FILES = {
    ("studies.md", 0): "runs the reader's own study.toml",
}

PAGES = {}
for f in sorted((ROOT / "docs").glob("*.md")):
    blocks = re.findall(r"```python\n(.*?)```", f.read_text(encoding="utf-8"), flags=re.S)
    if any((f.name, k) not in NEEDS_USER_FILES for k in range(len(blocks))):
        PAGES[f.name] = blocks


@pytest.fixture(autouse=True)
def _law_registry_restored():
    """A page may register a law of its own (contact.md's "linear-spring"): it is taken
    out again, so that tests which go through every registered law do not meet it (the
    doc-number tests failed when they ran after this file)."""
    from roverimpact.contact.registry import LAWS

    saved = dict(LAWS)
    yield
    LAWS.clear()
    LAWS.update(saved)


@pytest.mark.parametrize("page", sorted(PAGES))
def test_python_blocks_of_the_page_run(page, tmp_path, monkeypatch):
    (tmp_path / "examples").symlink_to(ROOT / "examples", target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "__main__"}
    ran = 0
    for k, block in enumerate(PAGES[page]):
        if (page, k) in NEEDS_USER_FILES:
            continue
        # dont_inherit: not this module's ``from __future__ import annotations`` (a block's
        # dataclass with ClassVar fields runs as a reader's script would)
        code = compile(textwrap.dedent(block), f"docs/{page} (python block {k})", "exec",
                       dont_inherit=True)
        with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
            warnings.simplefilter("ignore")  # what a block warns about is its prose's business
            exec(code, namespace)
        ran += 1
    assert ran
    assert os.getcwd() == str(tmp_path)
