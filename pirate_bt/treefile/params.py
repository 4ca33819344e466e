"""Tree parameters: declared with a type, given by the caller, substituted as whole values.

A tree (or a named subtree) declares its parameters::

    params:
      roll: {type: angle, default: 0 deg, description: bend-plane roll}

and uses them as a whole value anywhere in a node's keys: ``angle: $roll``.
There is no string interpolation and no expression: a value is either exactly
``$name`` or it is left alone (``$$text`` writes the literal ``$text``, in a
parameter's ``default`` and ``example`` too; a value given by the caller, on the
command line or in Python, is taken as it is, unescaped by nothing). The
node's own parameter model then validates the substituted value, so a parameter
is checked twice: against its declared type when given, and against the node
that uses it.

Quantities are substituted as text in SI units (``"1.5707963267948966 rad"``), so
a node that requires a unit in files still gets one.
"""

from __future__ import annotations

import math
import re
import sys
from dataclasses import dataclass
from typing import Any, Final, Literal

from pydantic import BaseModel, ConfigDict, Field

from pirate_bt.errors import SourceLocation, UnitError, bytes_escaped, shown
from pirate_bt.units import check_magnitude, parse_quantity

__all__ = [
    "COMMAND_LINE",
    "PARAM_RE",
    "SI_UNITS",
    "OptionAt",
    "ParamDecl",
    "ParamType",
    "chain_text",
    "coerce_param",
    "given_location",
    "listed",
    "written_value",
]

PARAM_RE: Final = re.compile(r"^\$(?P<name>[A-Za-z_][A-Za-z0-9_]*)\Z")
"""A whole value that names a parameter (``$roll``), to the end: ``$`` would also match
before a last line break, and ``$roll`` and a line break (a ``|`` block's) is no whole
value, as ``$roll`` and a space is not."""

# parameter type -> (units dimension, SI unit written after the number)
SI_UNITS: Final[dict[str, tuple[str, str]]] = {
    "length": ("length", "m"),
    "duration": ("time", "s"),
    "angle": ("angle", "rad"),
    "velocity": ("velocity", "m/s"),
    "angular_velocity": ("angular_velocity", "rad/s"),
    "acceleration": ("acceleration", "m/s^2"),
    "force": ("force", "N"),
    "torque": ("torque", "N*m"),
    "frequency": ("frequency", "Hz"),
    "current": ("current", "A"),
}

ParamType = Literal[
    "length",
    "duration",
    "angle",
    "velocity",
    "angular_velocity",
    "acceleration",
    "force",
    "torque",
    "frequency",
    "current",
    "number",
    "integer",
    "boolean",
    "string",
]


class ParamDecl(BaseModel):
    """One declared tree parameter."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    type: ParamType = Field(description="the parameter's type; quantities need a unit")
    default: Any = Field(None, description="value used when the caller gives none")
    example: Any = Field(
        None,
        description="value used to check or draw the tree when the caller gives none"
        " (pirate-bt validate / render); never used to run it",
    )
    choices: list[str] | None = Field(
        None, min_length=1, description="the allowed values of a string parameter"
    )
    description: str = Field("", description="what the parameter means")


COMMAND_LINE: Final = SourceLocation("--param")
"""Where the values of pirate-bt's ``--param`` options are given (the pseudo-file)."""


@dataclass(frozen=True, slots=True)
class OptionAt(SourceLocation):
    """A value given on the command line, shown as typed: ``--param d=1e999s`` (until
    2026-12-01 ``--param:1:1``, naming neither the option nor its value). ``file``
    stays ``--param``, the pseudo-file of every command-line value."""

    written: str = ""

    def __str__(self) -> str:
        text = self.written
        if not text.isprintable():  # a line break given in a value: one line all the same
            text = "".join(c if c.isprintable() else repr(c)[1:-1] for c in bytes_escaped(text))
        return text


def given_location(origin: SourceLocation, name: str, value: Any) -> SourceLocation:
    """Where the caller's value of ``name`` was given: the ``--param`` option that gave
    it (:class:`OptionAt`) when ``origin`` is the command line, else ``origin``."""
    if origin != COMMAND_LINE:
        return origin
    text = _cut(value) if isinstance(value, str) else shown(value)
    return OptionAt(COMMAND_LINE.file, written=f"--param {_cut(str(name))}={text}")


def coerce_param(
    decl: ParamDecl, value: Any, *, from_text: bool = False, units_required: bool = False
) -> Any:
    """Check ``value`` against ``decl`` and return the value to substitute.

    Args:
        decl: The declaration.
        value: The given value (a number is SI for a quantity unless it came from a file).
        from_text: The value is command-line text (``--param roll=90deg``).
        units_required: The value is written in a file (a declared ``default`` or
            ``example``, a value given at a subtree call), where a quantity needs its
            unit as in a node's keys: ``default: 90`` for an angle is refused, not 90 rad.

    Returns:
        The substituted value: a quantity as SI text with its unit, else a plain value.

    Raises:
        ValueError: the value does not fit the type.
    """
    kind = decl.type
    if from_text and isinstance(value, str) and kind not in ("boolean", "string"):
        _not_too_long(value)
    if kind in SI_UNITS:
        dimension, unit = SI_UNITS[kind]
        try:
            # a number from Python is SI even beside text parameters (from_text): only
            # text, or a file's value, needs its unit
            written = isinstance(value, str) or units_required
            si = parse_quantity(value, dimension, require_unit=written)
            check_magnitude(si, dimension, value)
        except UnitError as exc:
            raise ValueError(str(exc)) from None
        return f"{si!r} {unit}"
    if from_text and isinstance(value, str):
        return _choice(decl, _from_text(kind, value))
    if kind == "boolean" and isinstance(value, bool):
        return value
    if kind == "integer" and isinstance(value, int) and not isinstance(value, bool):
        return value
    if kind == "number" and isinstance(value, int | float) and not isinstance(value, bool):
        return _finite(value)
    if kind == "string" and isinstance(value, str):
        return _choice(decl, value)
    raise ValueError(f"expected {'an' if kind == 'integer' else 'a'} {kind}, got {shown(value)}")


def _not_too_long(text: str) -> None:
    """Refuse a whole number of more digits than Python reads (4,300), in the words of a
    file's (:mod:`pirate_bt.yamlfile`): ``--param n=`` and 5,000 digits was *expected a
    finite number*, an angle's *needs a unit* and an integer's *expected an integer*."""
    written = text.strip()
    digits = len(written.lstrip("+-"))
    limit = sys.get_int_max_str_digits()
    if 0 < limit < digits and _INTEGER_TEXT.fullmatch(written):
        raise ValueError(f"a number of {digits} digits is too long")


def _finite(value: float, written: object = None) -> float:
    """``value`` as a float; NaN and infinities are refused (as they are in a quantity):
    every comparison with NaN is false, so ``op: '!='`` would always hold."""
    try:
        number = float(value)
    except OverflowError:  # a whole number too large for a float
        number = math.inf
    if not math.isfinite(number):
        raise ValueError(
            f"expected a finite number, got {shown(value if written is None else written)}"
        )
    return number


def written_value(value: Any) -> Any:
    """A parameter's ``default`` or ``example`` as a tree file means it, as a node's
    value: ``$$text`` is the literal ``$text``.

    Raises:
        ValueError: ``$text`` (a default is a value; it names no parameter).
    """
    if isinstance(value, str) and value.startswith("$"):
        if value.startswith("$$"):
            return value[1:]
        cut = _cut(value)
        raise ValueError(
            f"{shown(value)}: a default names no parameter; write ${cut} for the literal {cut}"
        )
    return value


def _cut(text: str, limit: int = 40) -> str:
    """``text`` as it is, or cut to ``limit`` characters ending in ``...``."""
    return text if len(text) <= limit else text[: limit - 3] + "..."


def chain_text(names: list[str], most: int = 10) -> str:
    """A recursion's chain for a message, ``a -> b -> a``; a longer one than ``most``
    with its middle left out (a loop through 10,000 XML trees was an 89 kB line)."""
    if len(names) <= most:
        return " -> ".join(names)
    half = most // 2
    return " -> ".join([*names[:half], f"... ({len(names) - 2 * half} more)", *names[-half:]])


def listed(names: list[str], mark: str = "", most: int = 20) -> str:
    """``names`` joined for a message, each cut short and at most ``most`` of them (a
    hostile file's names may be thousands, each thousands of characters long)."""
    cut = [mark + _cut(n) for n in names[:most]]
    more = f", ... ({len(names) - most} more)" if len(names) > most else ""
    return ", ".join(cut) + more


def _choice(decl: ParamDecl, value: Any) -> Any:
    if decl.choices is not None and value not in decl.choices:
        raise ValueError(f"expected one of {listed(decl.choices)}, got {shown(value)}")
    return value


_INTEGER_TEXT: Final = re.compile(r"[+-]?[0-9]+")
_NUMBER_TEXT: Final = re.compile(r"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?")


def _from_text(kind: str, text: str) -> Any:
    """A command-line text as an ``integer`` or ``number`` (ASCII digits, as a quantity's
    number: Python's own ``int`` and ``float`` also take ``1_000``, other scripts'
    digits, ``nan`` and ``inf``), a ``boolean``, or the text itself."""
    if kind in ("integer", "number"):
        pattern = _INTEGER_TEXT if kind == "integer" else _NUMBER_TEXT
        digits = text.strip()
        expected = f"expected {'an' if kind == 'integer' else 'a'} {kind}, got {shown(text)}"
        limit = sys.get_int_max_str_digits()
        if pattern.fullmatch(digits) is None or (kind == "integer" and 0 < limit < len(digits)):
            raise ValueError(expected)
        return int(digits) if kind == "integer" else _finite(float(digits), text)
    if kind == "boolean":
        lowered = text.strip().lower()
        if lowered in ("true", "yes", "1", "on"):
            return True
        if lowered in ("false", "no", "0", "off"):
            return False
        raise ValueError(f"expected true or false, got {shown(text)}")
    return text
