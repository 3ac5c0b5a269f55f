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
