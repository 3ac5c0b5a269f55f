"""One-line validation messages name each table once."""

from __future__ import annotations

import pytest

from roverimpact._schema import validate
from roverimpact.exceptions import ConfigError
from roverimpact.scenario.schema import Scenario


@pytest.mark.parametrize("obstacle, expected", [
    ({"beta_deg": 30.0}, "x.toml: obstacle: give exactly one of wheel or frame"),
    ({"wheel": "front", "beta_deg": 130.0},
     "x.toml: obstacle.beta_deg must be in [0, 90] degrees, got 130.0"),
])
def test_table_named_once(obstacle, expected):
    """The validator's own 'obstacle: ...' came after the formatter's location:
    'obstacle: obstacle: give exactly one of wheel or frame'."""
    with pytest.raises(ConfigError) as err:
        validate(Scenario, {"model": {"name": "rover2d"}, "obstacle": obstacle}, "x.toml")
    assert str(err.value) == expected


@pytest.mark.parametrize("spacing, expected", [
    ("5cm", "x.toml: spacing: Input should be a valid number, unable to parse string "
            "as a number (got '5cm': write a plain number in the unit of the key: *_deg in "
            "degrees, everything else SI)"),
    ([0.05, "x"], "x.toml: spacing.1: Input should be a valid number, unable to "
                  "parse string as a number"),
])
def test_number_or_pair_names_the_member_meant(spacing, expected):
    """terrain.spacing is one length or a pair [dx, dy]: a string was refused by both
    members, 'terrain.spacing.float: Input should be a valid number ...; terrain.spacing:
    Input should be a valid tuple'; now one message, the number's for a string and the
    pair's for a list, with no internal 'float' in the key."""
    from roverimpact.traverse.schema import TerrainSpec

    with pytest.raises(ConfigError) as err:
        validate(TerrainSpec, {"file": "dem.npy", "spacing": spacing}, "x.toml")
    assert str(err.value) == expected


@pytest.mark.parametrize("name", ["scenario", "study", "traverse"])
def test_utf16_and_bom_toml(tmp_path, name):
    """A TOML file saved as UTF-16 (PowerShell's '>', Notepad's "Unicode") said "not a
    text (UTF-8) TOML file"; one with a UTF-8 byte-order mark "malformed TOML: Invalid
    statement (at line 1, column 1)". Now the first names the encoding and what to do,
    and the second reads as the file without its mark."""
    import codecs
    from pathlib import Path

    from roverimpact.scenario import load_scenario
    from roverimpact.studies.config import load_study
    from roverimpact.traverse.schema import load_traverse

    ex = Path(__file__).parents[1] / "examples"
    src, load = {"scenario": ("rover2d_beta45.toml", load_scenario),
                 "study": ("study_rigid_body.toml", load_study),
                 "traverse": ("traverse_sparse.toml", load_traverse)}[name]
    text = (ex / src).read_text(encoding="utf-8")
    p16 = tmp_path / "utf16.toml"
    p16.write_bytes(text.encode("utf-16"))
    with pytest.raises(ConfigError, match=r"utf16\.toml: the file is UTF-16: save it as "
                                          r"UTF-8$"):
        load(p16)
    bom = tmp_path / "bom.toml"
    bom.write_bytes(codecs.BOM_UTF8 + text.encode("utf-8"))
    plain = tmp_path / "plain.toml"
    plain.write_text(text, encoding="utf-8")
    assert repr(load(bom)) == repr(load(plain))
