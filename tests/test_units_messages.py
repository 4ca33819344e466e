"""A quantity's error quotes at most 40 characters of what it was given.

A 100 kB value in a tree's parameter, a route or ``--param`` used to come back whole
in the one-line message; an integer beyond a float's range raised OverflowError.
"""

from __future__ import annotations

import pytest

from pirate_bt.units import UnitError, parse_quantity


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ("x" * 100_000, "not a quantity: '" + "x" * 40 + "... (100000 characters)'"),
        ("9" * 5000, "'" + "9" * 40 + "... (5000 characters)' needs a unit"),
        ("1" + "0" * 400 + " m", "'1" + "0" * 39 + "... (403 characters)' is not a finite number"),
        (10**400, "'1" + "0" * 39 + "... (401 characters)' is not a finite number"),
        ("1 " + "furlong" * 100, "unknown unit 'furlongfurlong"),
    ],
)
def test_a_long_value_is_cut_in_its_message(value: object, message: str) -> None:
    with pytest.raises(UnitError) as caught:
        parse_quantity(value, "length")
    text = str(caught.value)
    assert text.startswith(message)
    assert len(text) < 400  # whatever the length of the value
    assert "\n" not in text


def test_a_short_value_is_quoted_whole() -> None:
    with pytest.raises(UnitError, match=r"^'90 deg' is an angle, but a length is expected"):
        parse_quantity("90 deg", "length")
    with pytest.raises(UnitError, match=r"^'5' needs a unit: write it as e.g. '5 m'$"):
        parse_quantity("5", "length")
