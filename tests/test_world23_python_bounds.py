"""Node parameters of a tree built in Python are bounded as a tree file's are.

A file's quantities are bounded by ``units.MAGNITUDE_LIMITS`` (a length at most
1,000 km, ...); a node built in Python was not: ``Drive.build("d", velocity=0.08,
distance=1e300)`` made a drive of 1e300 m, and a node constructed from a ``Params``
instance that no loader validated (``model_construct``) ran with a ``nan`` speed.
"""

from __future__ import annotations

import math

import py_trees
import pytest

from pirate_bt.behaviours.base import BuildContext
from pirate_bt.behaviours.basic import SetBlackboard, Timeout, Wait, WaitParams
from pirate_bt.behaviours.drive import Drive, DriveParams
from pirate_bt.behaviours.primitives import Clamp
from pirate_bt.errors import ArgumentValueError, ValidationFailed

HERE = "test_world23_python_bounds.py"


@pytest.mark.parametrize(
    ("build", "said"),
    [
        (
            lambda: Drive.build("d", velocity=0.08, distance=1e300),
            "d: distance: 1e+300 is out of range: a length is at most 1e+06 m (either sign)",
        ),
        (
            lambda: Drive.build("d", velocity="80 mm/s", until="blocked", max_distance="1e300 m"),
            "d: max_distance: '1e300 m' is out of range: a length is at most 1e+06 m",
        ),
        (lambda: Wait.build("w", duration=1e300), "w: duration: 1e+300 is out of range"),
        (
            lambda: Clamp.from_params("c", {"half": "front", "torque": -1e300}, BuildContext()),
            "c: torque: -1e+300 is out of range: a torque is at most 1e+06 N*m",
        ),
        (
            lambda: SetBlackboard.build("s", key="d", value="1e300 m", unit="length"),
            "s: '1e300 m' is out of range",
        ),
    ],
)
def test_a_node_built_in_python_is_bounded_as_in_a_file(build: object, said: str) -> None:
    with pytest.raises(ValidationFailed) as refused:
        build()  # type: ignore[operator]
    message = str(refused.value)
    # was: taken (a drive of 1e300 m, a wait of 1e300 s)
    assert "\n" not in message and said in message
    assert message.split(":")[0].endswith(HERE)  # the caller's line, as for a file's place


@pytest.mark.parametrize(
    ("make", "said"),
    [
        (
            lambda: Drive("d", DriveParams(velocity=0.08, distance=1e300), BuildContext()),
            "Drive('d'): distance: 1e+300 is out of range: a length is at most 1e+06 m",
        ),
        (
            lambda: Drive(
                "fast",
                DriveParams.model_construct(velocity=math.nan, distance=1.0),
                BuildContext(),
            ),
            "Drive('fast'): velocity: nan is not a finite number",
        ),
        (
            lambda: Timeout(
                "t",
                py_trees.behaviours.Success("s"),
                Timeout.Params.model_construct(duration=math.inf),
                BuildContext(),
            ),
            "Timeout('t'): duration: inf is not a finite number",
        ),
    ],
)
def test_a_node_constructed_from_unchecked_params_is_refused(make: object, said: str) -> None:
    with pytest.raises(ArgumentValueError) as refused:
        make()  # type: ignore[operator]
    assert "\n" not in str(refused.value) and said in str(refused.value)


def test_values_in_range_are_taken_as_before() -> None:
    drive = Drive.build("d", velocity=0.08, distance=1e6)
    assert drive.params.distance == 1e6  # type: ignore[attr-defined]
    wait = Wait("w", WaitParams(duration=2.0), BuildContext())
    assert wait.duration_s == 2.0
