"""The goal navigator's ``segment`` parameter given as a long list: the message names
the parameter and the type expected, and stays short (it showed the list's whole repr)."""

from __future__ import annotations

import pytest

import pirate_bt
from pirate_bt.errors import InputError


def test_goal_segment_given_a_long_list_is_named_and_cut() -> None:
    with pytest.raises(InputError) as info:
        pirate_bt.load_navigator("goal", {"segment": ["x"] * 1000})
    message = str(info.value)
    assert "'segment'" in message
    assert "as text" in message
    assert "a list" in message
    assert len(message) < 300
    assert "\n" not in message
