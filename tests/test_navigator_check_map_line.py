"""A navigator's ``check_map`` refusal is one line, whatever its message holds."""

from __future__ import annotations

import pytest

from pirate_bt.errors import InputError
from pirate_bt.task.navigators import check_navigator_map


class _Picky:
    def check_map(self, network: object) -> None:
        raise ValueError("this map\nis not\n\tfor me")


def test_a_refusal_with_newlines_is_one_line() -> None:
    with pytest.raises(InputError) as caught:
        check_navigator_map(_Picky(), "picky", None)
    assert str(caught.value) == "navigator 'picky': this map is not for me"
