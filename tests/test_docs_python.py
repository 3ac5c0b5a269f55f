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

#: Example files the blocks read, given here in a shorter version: the same code on less
#: work. traverse.md's run_traverse("examples/traverse_rocky.toml") drove 800 stations of
#: the 40 m path (21 s, the longest block of the docs); here its first 4 m (80 stations,
#: the same terrain, rover, limits, law and band). The whole path runs in the slow check
#: of tests/test_doc_numbers.py (traverse.tutorial_table).
SHORTER = {
    "traverse_rocky.toml": ("waypoints = [[0.0, 0.0], [15.0, 2.0], [28.0, -1.5], [40.0, 0.0]]",
                            "waypoints = [[0.0, 0.0], [4.0, 0.5]]"),
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


def _examples(folder: Path) -> None:
    """``folder/examples``: a link to each entry of examples/, a shorter copy of the
    files of :data:`SHORTER`."""
    (folder / "examples").mkdir()
    for p in (ROOT / "examples").iterdir():
        if p.name in SHORTER:
            old, new = SHORTER[p.name]
            text = p.read_text(encoding="utf-8")
            assert text.count(old) == 1, f"examples/{p.name} changed: update SHORTER"
            (folder / "examples" / p.name).write_text(text.replace(old, new),
                                                      encoding="utf-8")
        else:
            (folder / "examples" / p.name).symlink_to(p, target_is_directory=p.is_dir())


@pytest.mark.parametrize("page", sorted(PAGES))
def test_python_blocks_of_the_page_run(page, tmp_path, monkeypatch):
    _examples(tmp_path)
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
