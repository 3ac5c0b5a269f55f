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

