"""A step's parameter given as a NumPy number is a number in SI units, as a float is.

``Step("straight", distance=numpy.float32(0.3))`` was written to ``navigation.jsonl``
as ``"distance": "0.3"`` (text with no unit, which a step written so refuses), and
``numpy.array(0.2)`` (a 0-d array) was refused *'0.2' needs a unit*.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

import pirate_bt
from pirate_bt import Step
from pirate_bt.task.navigation import check_step


class _Given:
    """Drives each given distance forward, then is done."""

    def __init__(self, *distances: Any) -> None:
        self.distances = list(distances)

    def next_step(self, obs: Any) -> Step | None:
        return Step("straight", distance=self.distances.pop(0)) if self.distances else None


def test_numpy_distances_run_and_are_recorded_as_numbers(tmp_path: Path) -> None:
    result = pirate_bt.navigate(
        _Given(np.float32(0.1), np.array(0.1)), sim="straight", trace=tmp_path / "nav"
    )
    assert result.status == "success", result.why
    lines = (tmp_path / "nav" / "navigation.jsonl").read_text(encoding="utf-8").splitlines()
    steps = [r["step"] for r in map(json.loads, lines) if r.get("type") == "decision"]
    distances = [s["params"]["distance"] for s in steps if s is not None]
    assert len(distances) == 2
    assert all(isinstance(d, float) for d in distances), distances
    assert distances[0] == float(np.float32(0.1)) and distances[1] == 0.1


def test_a_step_of_numpy_values_is_the_step_of_python_s() -> None:
    given = Step("straight", distance=np.array(0.2), slow=np.array(True))
    assert given == Step("straight", distance=0.2, slow=True)
    assert hash(given) == hash(Step("straight", distance=0.2, slow=True))
    assert repr(given) == "Step('straight', distance=0.2, slow=True)"
    checked = check_step(given)
    assert checked.distance_m == 0.2 and checked.slow is True
    assert check_step(Step("wait", time=np.float32(2))).time_s == 2.0
