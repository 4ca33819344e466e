"""A node's parameters given in Python as NumPy numbers are SI numbers, as a float is.

``Drive.build("d", ctx, velocity=numpy.float32(0.08))`` failed *expected a velocity
quantity* while ``numpy.float64(0.08)`` (a float subclass) was taken; a 0-d array,
``numpy.bool_`` and a NumPy integer for a whole-number parameter were refused too.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from pirate_bt.behaviours.base import BuildContext
from pirate_bt.behaviours.basic import Retry, Success
from pirate_bt.behaviours.drive import Drive
from pirate_bt.errors import ValidationFailed
from pirate_bt.units import parse_quantity


@pytest.mark.parametrize(
    "velocity", [np.float32(0.08), np.float16(0.08), np.array(0.08), np.array(0.08, np.float32)]
)
def test_a_numpy_velocity_is_a_number_in_si(velocity: Any) -> None:
    node: Any = Drive.build("d", BuildContext(), velocity=velocity, distance=np.int64(1))
    assert node.params.velocity == pytest.approx(0.08, rel=1e-3)
    assert node.params.distance == 1.0


def test_numpy_booleans_and_whole_numbers_are_taken_as_python_s() -> None:
    node: Any = Drive.build("d", velocity=0.05, distance=0.2, reverse=np.bool_(True))
    assert node.params.reverse is True
    retry: Any = Retry.build("r", child=Success.build("s"), attempts=np.int64(3))
    assert retry.num_failures == 3 and type(retry.num_failures) is int


def test_a_numpy_number_in_si_is_parsed_as_a_float_is() -> None:
    assert parse_quantity(np.float32(0.5), "time", require_unit=False) == 0.5
    assert parse_quantity(np.array(2.0), "length", require_unit=False) == 2.0


def test_a_numpy_number_out_of_range_is_still_refused_by_the_node() -> None:
    with pytest.raises(ValidationFailed, match=r"d: distance: .*out of range"):
        Drive.build("d", velocity=0.05, distance=np.float32(1e7))


@pytest.mark.parametrize("value", [np.longdouble(0.5), np.array(np.longdouble(0.5))])
def test_a_numpy_long_double_is_a_float(value: Any) -> None:
    from pirate_bt.units import plain_number

    assert type(plain_number(value)) is float
    assert parse_quantity(value, "length", require_unit=False) == 0.5


@pytest.mark.parametrize("value", [np.float32(0.5), np.array(0.5), np.float16(0.5)])
def test_format_quantity_takes_a_numpy_number_as_a_float(value: Any) -> None:
    from pirate_bt.units import format_quantity

    assert format_quantity(value, "length") == format_quantity(0.5, "length") == "0.5 m"
    assert format_quantity(1.0, "length", digits=np.int64(3)) == "1 m"


def test_a_params_model_made_directly_takes_numpy_values_too() -> None:
    from pirate_bt.behaviours.basic import RetryParams
    from pirate_bt.behaviours.drive import DriveParams

    params = DriveParams(velocity=np.float32(0.05), distance=0.1, reverse=np.bool_(True))
    assert params.reverse is True
    assert RetryParams(attempts=np.int64(3)).attempts == 3
    node: Any = Drive("d", params, BuildContext())
    assert node.params.reverse is True
