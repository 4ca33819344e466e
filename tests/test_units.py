"""Quantities in files become SI floats once, with clear errors."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st
from pydantic import BaseModel, ValidationError

from pirate_bt.errors import UnitError
from pirate_bt.units import Angle, format_quantity, parse_quantity, units_of


@pytest.mark.parametrize(
    ("text", "dimension", "expected"),
    [
        ("90 deg", "angle", math.pi / 2),
        ("1.57 rad", "angle", 1.57),
        ("80 mm/s", "velocity", 0.08),
        ("0.6 N*m", "torque", 0.6),
        ("0.6 N·m", "torque", 0.6),
        ("600 mN*m", "torque", 0.6),
        ("0.6 Nm", "torque", 0.6),
        ("250 ms", "time", 0.25),
        ("63 mm", "length", 0.063),
        ("9.81 m/s^2", "acceleration", 9.81),
        ("60 rpm", "angular_velocity", 2 * math.pi),
        ("5 %", "dimensionless", 0.05),
        ("100 Hz", "frequency", 100.0),
        ("-2.5e-3 m", "length", -0.0025),
        ("0", "length", 0.0),
    ],
)
def test_parses_to_si(text: str, dimension: str, expected: float) -> None:
    assert parse_quantity(text, dimension) == pytest.approx(expected)


@pytest.mark.parametrize(
    ("value", "dimension", "message"),
    [
        ("90 mm", "angle", "is a length, but an angle is expected"),
        ("3 furlong", "length", "unknown unit 'furlong'"),
        ("fast", "velocity", "not a quantity"),
        ("1 m//s", "velocity", "malformed unit"),
        (90, "angle", "needs a unit"),
        (True, "angle", "expected an angle quantity"),
        ("inf m", "length", "not a quantity"),
        # not a number: refused as such, not advised to become 'nan s'
        (float("nan"), "time", r"^nan is not a finite number$"),
        (float("-inf"), "length", r"^-inf is not a finite number$"),
        # other scripts' digits are no number here
        ("\u0661 s", "time", "not a quantity"),
        # a space multiplies terms: 's s' is s^2, not an unknown unit 'ss'
        ("1 s s", "time", r"is a unit s\^2, but a time is expected"),
        # a power a pipe robot never needs overflows the factor (1000.0 ** 999999)
        ("1 km^999999", "length", r"unit power 999999 in '1 km\^999999' is beyond ±4"),
        ("1 s^-99999999", "frequency", "unit power -99999999"),
    ],
)
def test_rejects_with_clear_message(value: object, dimension: str, message: str) -> None:
    with pytest.raises(UnitError, match=message):
        parse_quantity(value, dimension)


def test_numbers_are_si_in_code_and_zero_needs_no_unit() -> None:
    assert parse_quantity(1.5, "angle", require_unit=False) == 1.5
    assert parse_quantity(0, "torque") == 0.0


def test_pydantic_field_requires_units_only_from_files() -> None:
    class Step(BaseModel):
        angle: Angle

    assert Step(angle=1.0).angle == 1.0
    assert Step.model_validate({"angle": "90 deg"}).angle == pytest.approx(math.pi / 2)
    with pytest.raises(ValidationError, match="needs a unit"):
        Step.model_validate({"angle": 90}, context={"units_required": True})


@given(st.floats(min_value=-1e6, max_value=1e6, allow_nan=False), st.sampled_from(["mm", "m"]))
def test_format_then_parse_round_trips(value: float, unit: str) -> None:
    text = f"{value!r} {unit}"
    si = parse_quantity(text, "length")
    assert parse_quantity(format_quantity(si, "length", digits=17), "length") == pytest.approx(si)


def test_units_of_lists_unit_names() -> None:
    assert {"deg", "rad"} <= set(units_of("angle"))
