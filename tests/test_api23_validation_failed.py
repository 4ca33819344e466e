"""``ValidationFailed`` raised by planner code (a check of its own, docs/api.md's
*Errors*): a message as text is one problem at the line that raised it, one
``LocatedError`` is taken as it is, and anything else is refused in one line.

``ValidationFailed("the map has no tee")`` was one problem per character
(``t:... \\n h ...``: its ``str()`` the message's letters, one per line), and
``ValidationFailed(LocatedError(...))`` Python's *'LocatedError' object is not
iterable*.
"""

from __future__ import annotations

import pickle

import pytest

from pirate_bt.errors import (
    ArgumentTypeError,
    InputError,
    LocatedError,
    SourceLocation,
    ValidationFailed,
)


def test_a_message_is_one_problem_at_the_line_that_raised_it() -> None:
    error = ValidationFailed("the map has no tee")
    (only,) = error.errors
    assert only.message == "the map has no tee"
    assert only.location.file.endswith("test_api23_validation_failed.py")
    assert str(error) == f"{only.location}: the map has no tee"
    assert "\n" not in str(error)
    assert str(pickle.loads(pickle.dumps(error))) == str(error)


def test_one_located_error_is_taken_as_it_is() -> None:
    located = LocatedError("torque: too high", SourceLocation("t.yaml", 4, 34))
    error = ValidationFailed(located)
    assert error.errors == (located,)
    assert str(error) == "t.yaml:4:34: torque: too high"


@pytest.mark.parametrize(
    ("errors", "message"),
    [
        (
            ["a"],
            "errors: each is a LocatedError(message, SourceLocation(file, line, column)),"
            " not a str",
        ),
        (5, "errors: give LocatedErrors (a list of them), or a message as text, not an int"),
    ],
)
def test_anything_else_is_refused_in_one_line(errors: object, message: str) -> None:
    with pytest.raises(ArgumentTypeError) as refused:
        ValidationFailed(errors)  # type: ignore[arg-type]
    assert str(refused.value) == message
    assert isinstance(refused.value, InputError) and isinstance(refused.value, TypeError)


@pytest.mark.parametrize("location", [(), (None,)])
def test_a_located_error_without_a_place_is_at_the_line_that_made_it(
    location: tuple[None, ...],
) -> None:
    error = LocatedError("the map has no tee", *location)
    assert error.location.file.endswith("test_api23_validation_failed.py")
    assert str(error) == f"{error.location}: the map has no tee"
    assert not str(error).startswith("None")
    assert str(pickle.loads(pickle.dumps(error))) == str(error)
