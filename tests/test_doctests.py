"""The examples in the public docstrings run and print what they claim."""

import doctest

import pytest

import roverimpact.energy
import roverimpact.impulse

MODULES = [roverimpact.energy, roverimpact.impulse]


@pytest.mark.parametrize("module", MODULES, ids=lambda m: m.__name__)
def test_docstring_examples(module):
    result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0
    assert result.failed == 0
