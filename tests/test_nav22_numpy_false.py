"""Session 22: a ``check_map`` that returns NumPy's false (``numpy.bool_(False)``, what a
comparison of NumPy numbers gives: ``return net_length > 3`` on a NumPy length) refuses
the map as ``False`` does (docs/navigators.md); it was ignored, and the navigation ran
on the map its navigator had said no to."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import pirate_bt
from pirate_bt.api import navigation
from pirate_bt.errors import InputError


class _Says:
    def __init__(self, answer: Any) -> None:
        self.answer = answer

    def check_map(self, network: Any) -> Any:
        return self.answer

    def next_step(self, obs: Any) -> None:
        return None


def test_numpy_s_false_refuses_the_map(monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("connected on a refused map")

    monkeypatch.setattr(navigation, "connect", refuse)
    with pytest.raises(InputError) as caught:
        pirate_bt.navigate(_Says(np.float64(2.0) > 3), map="straight")
    assert str(caught.value) == (
        "navigator '_Says': check_map returned False: the map is refused (raise ValueError"
        " with the reason to say why)"
    )


def test_numpy_s_true_lets_the_map_be() -> None:
    result = pirate_bt.navigate(_Says(np.float64(4.0) > 3), map="straight")
    assert result.status == "success", result.why
