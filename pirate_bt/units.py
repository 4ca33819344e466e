"""Quantities with units, parsed once at load time into SI floats.

Files say ``90 deg``, ``80 mm/s``, ``0.6 N*m``, ``250 ms`` or ``63 mm``; the code
above the loaders only ever sees floats in SI units (radians for angles), with the
unit in the name (``angle_rad``, ``velocity_mps``). A unit expression is a product
of unit names, each with an optional integer power, joined by ``*``, ``·`` or
``/`` (``/`` divides by the next name only): ``m/s^2``, ``N*m``, ``rad/s``.

The dimension of every field is fixed by the schema, so ``angle: 90 mm`` is an
error that names both dimensions instead of a silently wrong robot.

Why not pint: importing it and building its registry costs about 0.4 s, which
alone would blow the CLI's 0.3 s cold-start budget, and we need only a few dozen
units with fixed dimensions (see ``docs/performance.md``).

In files a dimensioned number must carry its unit (``angle: 90`` is refused,
because 90 rad is never what anybody meant). In Python code numbers are taken as
SI: ``BendParams(angle=1.57)`` is 1.57 rad.
"""

from __future__ import annotations

import math
import numbers
import operator
import re
import sys
from typing import Annotated, Any, Final, Literal

from pydantic import BeforeValidator, ValidationInfo, WithJsonSchema
from pydantic_core import PydanticCustomError

from pirate_bt.errors import ArgumentTypeError, ArgumentValueError, UnitError, kind_of

__all__ = [
    "DIMENSIONS",
    "MAGNITUDE_LIMITS",
    "Acceleration",
    "Angle",
    "AngularVelocity",
    "Current",
    "Dimensionless",
    "Duration",
    "Force",
    "Frequency",
    "Length",
    "Torque",
    "Velocity",
    "check_magnitude",
    "format_quantity",
    "parse_quantity",
    "plain_number",
    "quantity_type",
    "units_of",
]

# Dimension vectors: exponents of (metre, second, kilogram, ampere, radian).
_Dim = tuple[int, int, int, int, int]

DIMENSIONS: Final[dict[str, _Dim]] = {
    "dimensionless": (0, 0, 0, 0, 0),
    "length": (1, 0, 0, 0, 0),
    "time": (0, 1, 0, 0, 0),
    "angle": (0, 0, 0, 0, 1),
    "velocity": (1, -1, 0, 0, 0),
    "angular_velocity": (0, -1, 0, 0, 1),
    "acceleration": (1, -2, 0, 0, 0),
    "force": (1, -2, 1, 0, 0),
    "torque": (2, -2, 1, 0, 0),
    "frequency": (0, -1, 0, 0, 0),
    "current": (0, 0, 0, 1, 0),
    "mass": (0, 0, 1, 0, 0),
}

_M: Final = DIMENSIONS["length"]
_S: Final = DIMENSIONS["time"]
_KG: Final = DIMENSIONS["mass"]
_A: Final = DIMENSIONS["current"]
_RAD: Final = DIMENSIONS["angle"]
_ONE: Final = DIMENSIONS["dimensionless"]
_N: Final = DIMENSIONS["force"]
_HZ: Final = DIMENSIONS["frequency"]

# name -> (factor to SI, dimension)
_UNITS: Final[dict[str, tuple[float, _Dim]]] = {
    "m": (1.0, _M),
    "cm": (1e-2, _M),
    "mm": (1e-3, _M),
    "um": (1e-6, _M),
    "km": (1e3, _M),
    "s": (1.0, _S),
    "ms": (1e-3, _S),
    "us": (1e-6, _S),
    "min": (60.0, _S),
    "h": (3600.0, _S),
    "kg": (1.0, _KG),
    "g": (1e-3, _KG),
    "A": (1.0, _A),
    "mA": (1e-3, _A),
    "rad": (1.0, _RAD),
    "mrad": (1e-3, _RAD),
    "deg": (math.pi / 180.0, _RAD),
    "°": (math.pi / 180.0, _RAD),
    "rev": (2 * math.pi, _RAD),
    "rpm": (2 * math.pi / 60.0, (0, -1, 0, 0, 1)),
    "N": (1.0, _N),
    "mN": (1e-3, _N),
    "Nm": (1.0, DIMENSIONS["torque"]),
    "Hz": (1.0, _HZ),
    "kHz": (1e3, _HZ),
    "%": (1e-2, _ONE),
    "1": (1.0, _ONE),
}

_DISPLAY: Final[dict[str, tuple[str, float]]] = {
    "length": ("m", 1.0),
    "time": ("s", 1.0),
    "angle": ("deg", 180.0 / math.pi),
    "velocity": ("mm/s", 1e3),
    "angular_velocity": ("deg/s", 180.0 / math.pi),
    "acceleration": ("m/s^2", 1.0),
    "force": ("N", 1.0),
    "torque": ("N*m", 1.0),
    "frequency": ("Hz", 1.0),
    "current": ("A", 1.0),
    "mass": ("kg", 1.0),
    "dimensionless": ("", 1.0),
}

_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
# ASCII only: \d would take other scripts' digits ('١ s'), which no reader expects
_QUANTITY_RE: Final = re.compile(rf"^\s*(?P<num>{_NUMBER})\s*(?P<unit>.*?)\s*$", re.ASCII)
_TERM_RE: Final = re.compile(r"^(?P<name>[A-Za-z°%]+|1)(?:\^(?P<pow>[+-]?\d+))?$", re.ASCII)
_MAX_POWER: Final = 4
"""Largest exponent of a unit term (m^3, s^-2 and their like; km^999999 overflows)."""
_QUANTITY_PATTERN: Final = rf"^\s*{_NUMBER}\s*[A-Za-z°%0-9*·/^ +-]*$"


def _article(noun: str) -> str:
    vowel = noun[:1] in "aeiou" and not noun.startswith("unit")  # "a unit", not "an unit"
    return ("an " if vowel else "a ") + noun.replace("_", " ")


def _dim_name(dim: _Dim) -> str:
    for name, vec in DIMENSIONS.items():
        if vec == dim:
            return name
    return "unit " + "·".join(
        f"{b}^{p}" for b, p in zip(("m", "s", "kg", "A", "rad"), dim, strict=True) if p
    )


_SHOWN = 40
"""The most characters of a value quoted back in a message."""


def _shown(value: object, *, quoted: bool = True) -> str:
    """``value`` for a one-line message: quoted (``repr``), cut to :data:`_SHOWN`
    characters with its length when longer (a 100 kB value is not echoed whole)."""
    text = str(value)
    if len(text) > _SHOWN:
        cut = f"{text[:_SHOWN]}... ({len(text)} characters)"
        return repr(cut) if quoted else cut
    return repr(value) if quoted else text


def _number_goes_on(text: str, match: re.Match[str]) -> bool:
    """Whether what follows the number read is more of a number written otherwise: a
    decimal comma, a digit group or a second dot, a hex, binary or octal prefix after
    the '0' read (each right after it), or a second number ('1 5 s'; the unit '1' of
    '1/s' is a unit)."""
    rest = match["unit"]
    glued = match.end("num") < len(text) and not text[match.end("num")].isspace()
    if glued and re.match(r"[,_.]|[xXbBoO][0-9A-Fa-f]", rest):
        return True
    return bool(re.match(r"[0-9]", rest)) and not re.match(r"1(?:$|[*/·^\s])", rest)


def _parse_unit(expr: str, original: str) -> tuple[float, _Dim]:
    factor = 1.0
    dim = [0, 0, 0, 0, 0]
    # spaces around an operator go; a space between two terms multiplies ('N m', 's s')
    text = re.sub(r"\s+", "*", re.sub(r"\s*([*/])\s*", r"\1", expr.replace("·", "*")))
    if not text:
        return 1.0, _ONE
    sign = 1
    token = ""
    pieces: list[tuple[int, str]] = []
    for ch in text + "*":
        if ch in "*/":
            if not token:
                raise UnitError(f"malformed unit in {_shown(original)}")
            pieces.append((sign, token))
            token = ""
            sign = -1 if ch == "/" else 1
        else:
            token += ch
    for sgn, piece in pieces:
        match = _TERM_RE.match(piece)
        if match is None or match["name"] not in _UNITS:
            name = match["name"] if match else piece
            raise UnitError(
                f"unknown unit {_shown(name)} in {_shown(original)}; known: {', '.join(_UNITS)}"
            )
        power = sgn * int(match["pow"] or 1)
        if abs(power) > _MAX_POWER:
            raise UnitError(f"unit power {power} in {_shown(original)} is beyond ±{_MAX_POWER}")
        unit_factor, unit_dim = _UNITS[match["name"]]
        factor *= unit_factor**power
        for i, exponent in enumerate(unit_dim):
            dim[i] += exponent * power
    return factor, (dim[0], dim[1], dim[2], dim[3], dim[4])


_SI: Final[dict[str, str]] = {
    "length": "m",
    "time": "s",
    "angle": "rad",
    "velocity": "m/s",
    "angular_velocity": "rad/s",
    "acceleration": "m/s^2",
    "force": "N",
    "torque": "N*m",
    "frequency": "Hz",
    "current": "A",
    "mass": "kg",
}
"""The SI unit of each dimension, as a file writes it: what a bare number means in
Python, and in BehaviorTree.CPP's own ports (radians, metres per second)."""


def plain_number(value: Any) -> Any:
    """A NumPy scalar, or a 0-d NumPy array, as the Python value it stands for
    (``numpy.float64(0.2)`` and ``numpy.array(0.2)`` as ``0.2``, ``numpy.bool_(True)``
    as ``True``, ``numpy.str_("x")`` as ``"x"``), and any other ``numbers.Integral`` or
    ``numbers.Real`` but a bool as the plain ``int`` or ``float`` it stands for;
    anything else as it is. The one reading of a number given in Python, at every
    edge of the API (:mod:`pirate_bt.api.options` re-exports it), a node's parameters
    and a quantity: a seed of ``numpy.int64(3)`` was refused as no whole number, a
    velocity of ``numpy.float32(0.08)`` as no velocity, a boolean parameter of
    ``numpy.bool_(True)`` as no boolean. NumPy is not imported: a value can be one of
    its scalars only once NumPy is."""
    if type(value) in (bool, int, float, str):
        return value
    numpy = sys.modules.get("numpy")
    if numpy is not None and (
        isinstance(value, numpy.generic) or (isinstance(value, numpy.ndarray) and value.ndim == 0)
    ):
        item = value.item()  # a NumPy bool is neither of the kinds below
        if isinstance(item, bool | int | float | str):
            return item
        if isinstance(value, numpy.ndarray):  # its scalar (a long double), read below
            value = value[()]
    if isinstance(value, bool | int | float | str):  # a subclass, as it is
        return value
    if isinstance(value, numbers.Integral):
        return operator.index(value)
    if isinstance(value, numbers.Real):
        return float(value)
    return value


def _needs_unit(value: int | float | str, dimension: str) -> str:
    """The message for a bare number of a dimensioned quantity: the number with the SI
    unit, and the same value in the unit people read when that is another one
    (``'1.57' needs a unit: write it as e.g. '1.57 rad' or '89.95 deg'``): a number
    meant as SI is not mistaken for degrees or millimetres, nor the other way."""
    text = _shown(value, quoted=False)
    hint = f"'{text} {_SI[dimension]}'"
    unit = _DISPLAY[dimension][0]
    number = float(value)
    if unit != _SI[dimension] and math.isfinite(number):
        hint += f" or '{format_quantity(number, dimension)}'"
    return f"{_shown(value)} needs a unit: write it as e.g. {hint}"


def parse_quantity(value: object, dimension: str, *, require_unit: bool = True) -> float:
    """Turn ``value`` into an SI float of the given dimension.

    Args:
        value: A string such as ``"90 deg"``, or a number (taken as SI).
        dimension: One of :data:`DIMENSIONS`, e.g. ``"angle"``.
        require_unit: Refuse a bare number for a dimensioned quantity (the rule
            for files); planner code passes numbers in SI.

    Returns:
        The value in SI units (radians for angles).

    Raises:
        UnitError: unknown unit, malformed text, or the wrong dimension.
    """
    _dimension(dimension)
    value = plain_number(value)  # numpy.float32(0.08) is a number in SI, as a float is
    if isinstance(value, bool):
        raise UnitError(f"expected {_article(dimension)} quantity, got {_shown(value)}")
    if isinstance(value, int | float):
        try:
            finite = math.isfinite(value)
        except OverflowError:  # an int beyond a float's range
            finite = False
        if not finite:
            raise UnitError(f"{_shown(value)} is not a finite number")
        if require_unit and dimension != "dimensionless" and value != 0:
            raise UnitError(_needs_unit(value, dimension))
        result = float(value)
    elif isinstance(value, str):
        match = _QUANTITY_RE.match(value)
        if match is None:
            raise UnitError(f"not a quantity: {_shown(value)} (expected e.g. '90 deg', '80 mm/s')")
        if _number_goes_on(value, match):  # '1,5 s', '0x10 s', '1_000 mm', '1 5 s'
            example = f"1.5 {_DISPLAY[dimension][0]}".strip() if dimension in _DISPLAY else "1.5"
            raise UnitError(
                f"not a quantity: {_shown(value)}: write the number in decimal digits with a"
                f" dot (e.g. '{example}'), one number, then its unit"
            )
        factor, dim = _parse_unit(match["unit"], value)
        expected = DIMENSIONS[dimension]
        if not match["unit"] and dimension != "dimensionless":
            if float(match["num"]) == 0:
                return 0.0
            raise UnitError(_needs_unit(value, dimension))
        if dim != expected:
            raise UnitError(
                f"{_shown(value)} is {_article(_dim_name(dim))},"
                f" but {_article(dimension)} is expected"
                f" (e.g. '1 {_DISPLAY[dimension][0] or '1'}')"
            )
        result = float(match["num"]) * factor
    else:
        raise UnitError(
            f"expected {_article(dimension)} quantity such as '1 {_DISPLAY[dimension][0]}'"
        )
    if not math.isfinite(result):
        raise UnitError(f"{_shown(value)} is not a finite number")
    return result


MAGNITUDE_LIMITS: Final[dict[str, float]] = {
    "length": 1e6,  # 1,000 km of pipe
    "time": 1e9,  # 31 years, the longest run a mission allows (max_time)
    "angle": 1e6,  # some 159,000 turns
    "velocity": 1e3,
    "angular_velocity": 1e4,
    "acceleration": 1e4,
    "force": 1e7,
    "torque": 1e6,
    "frequency": 1e9,
    "current": 1e4,
    "mass": 1e6,
}
"""The largest magnitude, in SI units, a value of a tree's parameter can mean, per
dimension: far beyond any pipe robot, short of a number that only overflows what is
computed from it (a distance of 2**62 m was a finite double, and taken)."""


def check_magnitude(value_si: float, dimension: str, written: object) -> None:
    """Refuse ``value_si`` (``written`` as given) beyond :data:`MAGNITUDE_LIMITS` for
    ``dimension`` (``dimensionless`` has none).

    Raises:
        UnitError: ``'1e300 m' is out of range: a length is at most 1e+06 m``.
    """
    _dimension(dimension)
    limit = MAGNITUDE_LIMITS.get(dimension)
    if limit is not None and abs(value_si) > limit:
        raise UnitError(
            f"{_shown(written)} is out of range: {_article(dimension)} is at most"
            f" {limit:g} {_SI[dimension]} (either sign)"
        )


def _dimension(dimension: object) -> None:
    """Refuse a dimension that is none of :data:`DIMENSIONS` (``format_quantity`` and
    ``units_of`` raised a bare ``KeyError: 'lenght'``), naming the known ones."""
    if not isinstance(dimension, str) or dimension not in DIMENSIONS:
        raise ArgumentValueError(
            f"dimension: unknown dimension {dimension!r}; known: {', '.join(DIMENSIONS)}"
        )


def in_unit_of(value_si: float, written: object) -> str | None:
    """``value_si`` in the unit ``written`` uses (``in_unit_of(pi / 2, "180 deg")`` is
    ``"90 deg"``), for a message in the words of a file; ``None`` when ``written`` is
    not a quantity with a unit."""
    if not isinstance(value_si, int | float) or not isinstance(written, str):
        return None
    match = _QUANTITY_RE.match(written)
    unit = match["unit"] if match else ""
    if not unit:
        return None
    try:
        factor, _dim = _parse_unit(unit, written)
    except UnitError:
        return None
    return f"{value_si / factor:.6g} {unit}" if factor else None


def format_quantity(value_si: float, dimension: str, digits: int = 4) -> str:
    """Format an SI value for people, e.g. ``format_quantity(1.5708, "angle") == "90 deg"``.

    A NumPy number or 0-d array is the number it holds, for ``value_si`` and ``digits``
    alike (``numpy.float32(1.5708)`` was refused *give a number in SI units, not a
    float32*).

    Raises:
        ArgumentValueError: an unknown dimension, or ``digits`` not from 0 to 17.
        ArgumentTypeError: ``value_si`` is no number.
    """
    _dimension(dimension)
    value_si, digits = plain_number(value_si), plain_number(digits)
    if isinstance(value_si, bool) or not isinstance(value_si, int | float):
        raise ArgumentTypeError(f"value_si: give a number in SI units, not {kind_of(value_si)}")
    if isinstance(digits, bool) or not isinstance(digits, int) or not 0 <= digits <= 17:
        raise ArgumentValueError(f"digits: give a whole number from 0 to 17, not {digits!r}")
    unit, scale = _DISPLAY[dimension]
    shown = f"{value_si * scale:.{digits}g}"
    return f"{shown} {unit}".strip()


def units_of(dimension: str) -> list[str]:
    """List the single unit names whose dimension is ``dimension``."""
    _dimension(dimension)
    want = DIMENSIONS[dimension]
    return [name for name, (_, dim) in _UNITS.items() if dim == want]


def parse_in_context(
    value: object, dimension: str, context: object, *, require_unit: bool
) -> float:
    """``value`` parsed in SI units (:func:`parse_quantity`) and, where the validation
    ``context`` asks for it (``magnitude_limits``: a tree file's node), bounded by
    :data:`MAGNITUDE_LIMITS`, as every quantity of a node's parameters is.

    Raises:
        UnitError: not a quantity of ``dimension``, or out of range.
    """
    si = parse_quantity(value, dimension, require_unit=require_unit)
    if isinstance(context, dict) and context.get("magnitude_limits"):
        check_magnitude(si, dimension, value)
    return si


def _validator(dimension: str) -> Any:
    def validate(value: object, info: ValidationInfo) -> float:
        context = info.context if isinstance(info.context, dict) else {}
        try:
            return parse_in_context(
                value,
                dimension,
                context,
                require_unit=bool(context.get("units_required", False)),
            )
        except UnitError as exc:
            # pydantic wraps ValueError into a located validation error.
            raise ValueError(str(exc)) from None

    return validate


def _json_schema(dimension: str) -> dict[str, Any]:
    unit = _DISPLAY[dimension][0]
    return {
        "anyOf": [
            {
                "type": "string",
                "pattern": _QUANTITY_PATTERN,
                "description": f"{_article(dimension)} with its unit, e.g. '1 {unit}'",
            },
            {"type": "number", "description": "SI value (only 0 is allowed without a unit)"},
        ]
    }


def quantity_type(dimension: str) -> Any:
    """An ``Annotated[float, ...]`` type that parses a quantity of ``dimension``."""
    return Annotated[
        float, BeforeValidator(_validator(dimension)), WithJsonSchema(_json_schema(dimension))
    ]


def _q(dimension: str) -> tuple[BeforeValidator, WithJsonSchema]:
    return BeforeValidator(_validator(dimension)), WithJsonSchema(_json_schema(dimension))


# Spelled out (not built by quantity_type) so that type checkers see plain floats.
Length = Annotated[float, *_q("length")]
Duration = Annotated[float, *_q("time")]
Angle = Annotated[float, *_q("angle")]
Velocity = Annotated[float, *_q("velocity")]
AngularVelocity = Annotated[float, *_q("angular_velocity")]
Acceleration = Annotated[float, *_q("acceleration")]
Force = Annotated[float, *_q("force")]
Torque = Annotated[float, *_q("torque")]
Frequency = Annotated[float, *_q("frequency")]
Current = Annotated[float, *_q("current")]
Dimensionless = Annotated[float, *_q("dimensionless")]


def _whole(value: Any) -> Any:
    """A whole number of a file as written: text (``'20'``) or a boolean (``true``, a
    plain ``yes``) is none, where pydantic's lax reading took ``'20'`` as 20 and ``yes``
    as 1 (a board's ``id``, a ``slot``, a raw range, a ``schema_version``)."""
    if isinstance(value, bool | str):
        raise PydanticCustomError("int_type", "Input should be a valid integer")
    return value


def _flag(value: Any) -> Any:
    """A yes/no of a file as written: ``true`` or ``false`` (a plain ``yes`` is read
    as true by YAML), never text (``'off'``, which pydantic's lax reading took as false)
    nor a number (``1``)."""
    value = plain_number(value)
    if not isinstance(value, bool):
        raise PydanticCustomError("bool_type", "Input should be a valid boolean")
    return value


WholeNumber = Annotated[int, BeforeValidator(_whole)]
"""An ``int`` field of a file: a whole number, never text nor a boolean."""
Flag = Annotated[bool, BeforeValidator(_flag)]
"""A ``bool`` field of a file: true or false, never text nor a number."""
SchemaVersion = Annotated[Literal[1], BeforeValidator(_whole)]
"""A file's ``schema_version``: 1, never ``true`` nor ``'1'``."""
