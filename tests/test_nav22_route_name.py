"""Session 22: the ``route`` navigator's ``route`` parameter is refused as
``simulate_mission`` refuses a route's name (docs/api.md, *Arguments the API
refuses*): an empty name was read as the working folder (*.:1:1: is a directory*), a
NUL was Python's *embedded null byte* with no parameter named, a name of 5,000
characters was echoed whole, and a list was shown by its whole ``repr``."""

from __future__ import annotations

from typing import Any

import pytest

import pirate_bt
from pirate_bt.errors import InputError


@pytest.mark.parametrize(
    ("value", "said"),
    [
        ("", "the file name is empty"),
        (" ", "the file name is empty"),
        ("a\0b.route", "a file name may not hold a NUL character"),
        ("x" * 5000, "a file name of 5000 characters is too long (at most 4096)"),
        (["x"] * 100_000, "give a route file, a bundled name or a Route, not a list"),
        (b"lab.route", "give a route file, a bundled name or a Route, not a bytes"),
    ],
    ids=["empty", "blank", "nul", "long", "list", "bytes"],
)
def test_a_route_name_that_is_no_file_name_is_refused_naming_the_parameter(
    value: Any, said: str
) -> None:
    with pytest.raises(InputError) as caught:
        pirate_bt.load_navigator("route", {"route": value})
    assert str(caught.value) == f"navigator 'route', parameter 'route': {said}"
