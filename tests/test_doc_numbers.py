"""Numbers and figures in the docs come from scripts in the repository.

* Every number between ``<!-- num:KEY -->`` markers (or found by an anchor in a code block)
  in README.md and docs/*.md equals what ``tools/doc_numbers.py`` computes with the library
  now (the cheap producers here, a few seconds; the whole studies in the ``slow`` test).
  This pins the docs to the code: it proves the docs are current, not that the physics is
  right (the physics is tested against references elsewhere).
* Every marker names a known key, every key is quoted, every anchor matches once.
* Every image the docs show exists, and a script in examples/ or tools/ writes it.
* Every script the docs tell you to run exists.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from .doctool import doc_numbers

ROOT = Path(__file__).resolve().parents[1]

dn = doc_numbers()


@pytest.fixture(scope="module")
def fresh():
    """The cheap numbers, computed once for this module."""
    return dn.compute(slow=False)


def test_cheap_docs_numbers_match_a_fresh_run(fresh):
    bad, problems = dn.check(fresh=fresh)
    assert not problems, "\n".join(problems)
    assert not bad, "docs out of date (python tools/doc_numbers.py --write):\n" + \
        "\n".join(map(str, bad))


def test_every_marker_is_known_and_every_key_is_quoted():
    where, problems = dn.placements(dn.read_docs())
    assert not problems, "\n".join(problems)
    owners = dn.key_owner()
    assert set(where) == set(owners)
    cheap = [k for k, p in owners.items() if not p.slow]
    assert len(cheap) >= 50        # the cheap check really covers the docs' numbers


def test_check_reports_a_changed_number_an_unknown_marker_and_a_lost_anchor(fresh):
    texts = dn.read_docs()
    key = "trust.n_sims"
    (name, a, b), = dn.placements(texts)[0][key]
    assert texts[name][a:b] == fresh[key]
    changed = dict(texts)
    changed[name] = texts[name][:a] + "253" + texts[name][b:]
    bad, problems = dn.check(texts=changed, fresh=fresh)
    assert [(m.file, m.key, m.quoted, m.fresh) for m in bad] == [(name, key, "253", "252")]
    assert not problems

    changed[name] = texts[name] + "\n<!-- num:no.such_key -->1<!-- /num -->\n"
    _, problems = dn.check(texts=changed, fresh=fresh)
    assert any("no.such_key" in p and "not produced" in p for p in problems)

    changed[name] = texts[name] + "\n<!-- num:trust.n_sims -->252\n"       # never closed
    _, problems = dn.check(texts=changed, fresh=fresh)
    assert any("unbalanced" in p for p in problems)

    readme = dict(texts)
    readme["README.md"] = texts["README.md"].replace("# 0.390625 J", "# J")
    _, problems = dn.check(texts=readme, fresh=fresh)
    assert any("readme.rod_T_c" in p and "matches 0 times" in p for p in problems)


def test_write_restores_the_docs(tmp_path, fresh):
    """--write puts the fresh values back between the markers and changes nothing else."""
    (tmp_path / "docs").mkdir()
    for p in dn.doc_files():
        shutil.copyfile(p, tmp_path / p.relative_to(ROOT))
    trust = tmp_path / "docs" / "trust.md"
    original = trust.read_text()
    broken = original.replace("<!-- num:trust.n_cells -->36<!-- /num -->",
                              "<!-- num:trust.n_cells -->35<!-- /num -->")
    assert broken != original
    trust.write_text(broken)
    assert dn.write(root=tmp_path, fresh=fresh) == ["docs/trust.md"]
    assert trust.read_text() == original
    assert dn.write(root=tmp_path, fresh=fresh) == []


def test_formatting_helpers():
    assert dn.sig(181.7, 2) == "180"
    assert dn.sig(11.5000001, 3) == "11.5"
    assert dn.sig(1.4, 2) == "1.4"
    assert dn.pct(-0.0234) == "\u22122.3" and dn.pct(0.018) == "+1.8"
    assert dn.latex_pow(4.2e-8) == "$4\\times10^{-8}$"
    assert dn.latex_pow(0.97e-9) == "$10^{-9}$"
    assert dn.latex_pow(9.7e-9) == "$10^{-8}$"
    t = dn.table(["", "a"], [["x", "1"]])
    assert t == "\n\n| | a |\n|---|---|\n| x | 1 |\n\n"


@pytest.mark.slow
def test_slow_docs_numbers_match_a_fresh_run():
    """The full trust map (252 simulations), MuJoCo friction runs, the 1 km terrain."""
    slow = {k for k, p in dn.key_owner().items() if p.slow}
    fresh = dn.compute(only=slow)
    bad, problems = dn.check(fresh=fresh)
    assert not problems, "\n".join(problems)
    assert not bad, "\n".join(map(str, bad))


# ------------------------------------------------------------------------ figures, scripts
def _doc_texts():
    files = [*dn.doc_files(), ROOT / "benchmarks" / "README.md"]
    return {p: p.read_text() for p in files}


def _scripts():
    paths = [*(ROOT / "examples").rglob("*.py"), *(ROOT / "tools").glob("*.py")]
    return {p: p.read_text() for p in paths}


def test_every_docs_image_exists_and_a_script_writes_it():
    scripts = _scripts()
    images = set()
    for path, text in _doc_texts().items():
        for ref in re.findall(r"!\[[^\]]*\]\(([^)\s]+)\)", text):
            img = (path.parent / ref).resolve()
            assert img.is_file(), f"{path.name} shows {ref}, which does not exist"
            images.add(img)
    assert len(images) >= 13
    for img in sorted(images):
        literal = re.compile(rf"[\"'/]{re.escape(img.name)}[\"']")     # "x.png", "img/x.png"
        writers = [p.relative_to(ROOT) for p, src in scripts.items() if literal.search(src)]
        assert writers, (f"no script in examples/ or tools/ names {img.name} as an output: "
                         "every figure needs a generator")


def test_every_script_the_docs_name_exists():
    named = set()
    for path, text in _doc_texts().items():
        for rel in re.findall(r"\b((?:examples|benchmarks|tools)/[\w/.-]+\.py)\b", text):
            named.add(rel)
            assert (ROOT / rel).is_file(), f"{path.name} names {rel}, which does not exist"
    assert "tools/doc_numbers.py" in named and "examples/trust_map.py" in named
