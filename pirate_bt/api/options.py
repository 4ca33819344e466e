"""The API's options, read the way the command line reads them.

Quantities as text with a unit (``"600 s"``, ``"20 Hz"``) or SI numbers; fault specs
(``"motor_stall:bend_3_drive@5s+20s,drop=0.05"``); seeds, flags, callbacks and
parameters. Files, folders, robot descriptions and connection targets are
:mod:`pirate_bt.api.file_options`' (re-exported here).

Every public function checks its arguments here, at the API's boundary, before
anything connects: a wrong type, a value out of range, ``nan`` or ``inf`` is an
:class:`~pirate_bt.errors.InputError` of one line that names the argument and
says what is allowed (docs/api.md, *Arguments the API refuses*).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any

from pirate_bt.api.fault_text import MAX_FAULT_TEXT, MAX_FAULTS, split_faults
from pirate_bt.api.file_options import (
    DEFAULT_NETWORK,
    file_name,
    find,
    load_robot_like,
    network_name,
    not_an_input,
    output_folder,
    output_path,
    parse_target,
    port_url,
    writable_folder,
)
from pirate_bt.errors import (
    MAX_PATH,
    MAX_SEED,
    InputError,
    UnitError,
    digit_count,
    kind_of,
    seed_argument,
)
from pirate_bt.units import parse_quantity, plain_number

__all__ = [
    "DEFAULT_NETWORK",
    "MAX_FAULTS",
    "MAX_FAULT_TEXT",
    "MAX_PATH",
    "MAX_RATE_HZ",
    "MAX_SEED",
    "MAX_TIME_S",
    "NO_LIMIT",
    "callback",
    "check_rate",
    "fault_list",
    "file_name",
    "find",
    "flag",
    "fraction",
    "kind_of",
    "load_robot_like",
    "network_name",
    "not_an_input",
    "output_folder",
    "output_path",
    "params_mapping",
    "parse_target",
    "plain_number",
    "port_url",
    "positive_time_s",
    "quantity",
    "report_extras",
    "run_limits",
    "seed_value",
    "split_faults",
    "tick_period_s",
    "writable_folder",
]

MAX_RATE_HZ = 1000.0
"""The fastest tick rate: ten ticks per state frame of the bridge (every 10 ms). The
one limit of the API, the command line (``--rate``) and campaigns (``rate:``)."""

MAX_TIME_S = 1e9
"""The longest time limit of a run (about 32 years of clock time)."""

_MAX_QUANTITY_TEXT = 64
_EXAMPLE = {"time": "600 s", "frequency": "20 Hz", "length": "1 m"}


def quantity(value: str | float | int, dimension: str, option: str) -> float:
    """A quantity given as text with its unit (``"600 s"``) or as an SI number.

    Raises:
        InputError: a malformed quantity, a number that is not finite (``nan``,
            ``inf``, an integer too large for a float), or neither text nor a number;
            named by ``option``.
    """
    example = _EXAMPLE.get(dimension, "1 m")
    value = plain_number(value)
    if isinstance(value, bool) or not isinstance(value, str | int | float):
        raise InputError(
            f"{option}: give text with a unit ({example!r}) or a number in SI units,"
            f" not {kind_of(value)}"
        )
    if isinstance(value, int | float):
        try:
            number = float(value)
        except OverflowError:
            raise InputError(
                f"{option}: a {digit_count(int(value))}-digit number is too large"
            ) from None
        if not math.isfinite(number):
            raise InputError(f"{option}: {value!r} is not a finite number; give e.g. {example!r}")
        return number
    if len(value) > _MAX_QUANTITY_TEXT:
        raise InputError(
            f"{option}: {len(value)} characters is too long for a quantity such as {example!r}"
        )
    try:
        return parse_quantity(value, dimension)
    except UnitError as exc:
        raise InputError(f"{option}: {exc}") from None


def positive_time_s(
    value: str | float | int, option: str, *, limit_s: float = MAX_TIME_S, instead: str = ""
) -> float:
    """A time above 0 and at most ``limit_s`` (``"600 s"`` or seconds).

    ``nan`` and ``inf`` are refused, not read as "no limit": a simulated run with no
    finite limit could run for ever. ``instead`` says what to give then.

    Raises:
        InputError: not a time, not finite, not positive or above ``limit_s``.
    """
    if isinstance(value, float) and not math.isfinite(value):
        hint = instead or f"give a time such as {'600 s'!r}"
        raise InputError(f"{option}: {value!r} is not a finite time; {hint}")
    seconds = quantity(value, "time", option)
    if not 0 < seconds <= limit_s:
        raise InputError(
            f"{option}: {value!r} is out of range; give a time above 0 s and at most {limit_s:g} s"
        )
    return seconds


def check_rate(
    rate_hz: float, max_time_s: float | None, rate: str = "rate", max_time: str = "max_time"
) -> None:
    """Refuse a tick rate that would never end a run: not above 0 (``nan`` too), above
    :data:`MAX_RATE_HZ`, or a tick period longer than the time limit (``max_time_s``;
    ``None``: no limit). ``rate`` and ``max_time`` name the options in the message.

    Raises:
        InputError: the rate is out of that range.
    """
    if not rate_hz > 0:  # nan too
        raise InputError(
            f"{rate} must be positive and at most {MAX_RATE_HZ:g} Hz (ticks per second),"
            f" not {rate_hz:g}"
        )
    if rate_hz > MAX_RATE_HZ or (max_time_s is not None and 1.0 / rate_hz > max_time_s):
        within = (
            f" and a tick must come within {max_time} ({max_time_s:g} s)"
            if max_time_s is not None
            else ""
        )
        raise InputError(
            f"{rate} {rate_hz:g} Hz: the tick rate must be at most {MAX_RATE_HZ:g} Hz{within}"
        )


def tick_period_s(
    rate: str | float | int,
    max_time_s: float | None,
    *,
    option: str = "rate",
    limit_option: str = "max_time",
) -> float:
    """The tick period for a ``rate`` (``"20 Hz"`` or hertz), checked by :func:`check_rate`
    against the run's time limit ``max_time_s`` (``None``: no limit).

    Raises:
        InputError: not a frequency, not finite, or out of :func:`check_rate`'s range.
    """
    rate_hz = quantity(rate, "frequency", option)
    check_rate(rate_hz, max_time_s, option, limit_option)
    return 1.0 / rate_hz


NO_LIMIT = (
    "a run with no finite time limit could run for ever; give a time limit such as"
    " '3600 s' (at most 1e9 s)"
)
"""What to give instead of a ``max_time`` of ``nan`` or ``inf``."""


def run_limits(max_time: str | float | int, rate: str | float | int) -> tuple[float, float]:
    """``(tick period, time limit)`` in seconds for a run's ``rate`` and ``max_time``.

    Raises:
        InputError: either is malformed or out of range (:func:`positive_time_s`,
            :func:`tick_period_s`); ``max_time`` ``nan`` or ``inf`` too.
    """
    max_time_s = positive_time_s(max_time, "max_time", instead=NO_LIMIT)
    return tick_period_s(rate, max_time_s), max_time_s


def flag(value: object, option: str) -> bool:
    """A yes/no option: ``True`` or ``False`` only (``"no"`` would be true).

    Raises:
        InputError: anything else.
    """
    value = plain_number(value)  # a NumPy bool is one
    if not isinstance(value, bool):
        raise InputError(f"{option}: give True or False, not {value!r}"[:200])
    return value


def fault_list(faults: Any) -> Any:
    """``faults`` to check, then run: a one-shot iterator (a generator, ``map(...)``) read
    once into a list, of at most ``MAX_FAULTS + 1`` (an endless one is refused as too
    many, not read for ever). Checked, then handed on, it reached the run read empty:
    the run "succeeded" with no fault in it. Anything else as it is."""
    if isinstance(faults, Iterator) and not isinstance(faults, str):
        return list(itertools.islice(faults, MAX_FAULTS + 1))
    return faults


def seed_value(seed: object, option: str = "seed") -> int:
    """A seed: a whole number from 0 to :data:`MAX_SEED`
    (:func:`pirate_bt.errors.seed_argument`, the one rule of the library).

    Raises:
        InputError: anything else (a bool, a float, text, a negative or huge number).
    """
    return seed_argument(plain_number(seed), option)  # a NumPy integer is a whole number


def fraction(value: object, option: str) -> float:
    """A number at least 0 and below 1 (``map_tolerance``: 0.1 is 10 %).

    Raises:
        InputError: not a number, or out of range (``nan`` too).
    """
    value = plain_number(value)  # a NumPy number is one
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InputError(
            f"{option}: give a number at least 0 and below 1 (0.1 = 10 %), not {kind_of(value)}"
        )
    if not 0.0 <= value < 1.0:
        raise InputError(f"{option}: {value!r} must be at least 0 and below 1"[:200])
    return float(value)


def callback(value: Any, option: str) -> Callable[..., Any] | None:
    """``None`` or something callable.

    Raises:
        InputError: anything else.
    """
    if value is not None and not callable(value):
        raise InputError(f"{option}: give a function (or None), not {kind_of(value)}")
    return value  # type: ignore[no-any-return]


def report_extras(wall_s: Any, sections: Any, pictures: Any, warn: Any) -> None:
    """:func:`~pirate_bt.api.missions.write_mission_outputs`' own arguments, before
    anything is written.

    ``extra_sections=5`` was a ``TypeError`` from inside the report, after the output
    folder had been made; ``wall_s=nan`` was written into the report as it was.

    Raises:
        InputError: the first that is wrong, named.
    """
    if wall_s is not None:
        if isinstance(wall_s, bool) or not isinstance(wall_s, int | float):
            raise InputError(f"wall_s: give seconds (a number) or None, not {wall_s!r}"[:200])
        if not 0 <= wall_s < float("inf"):
            raise InputError(f"wall_s: {wall_s!r} is not a finite number of seconds")
    callback(warn, "warn")

    def pairs(value: Any, name: str, text_list: bool) -> None:
        what = "(heading, [lines])" if text_list else "(caption, file name)"
        if isinstance(value, str | bytes) or not isinstance(value, Sequence):
            raise InputError(f"{name}: give a list of {what} pairs, not {value!r}"[:200])
        for item in value:
            ok = isinstance(item, tuple | list) and len(item) == 2 and isinstance(item[0], str)
            second = item[1] if ok else None
            if text_list:
                ok = ok and isinstance(second, list) and all(isinstance(x, str) for x in second)
            else:
                ok = ok and isinstance(second, str)
            if not ok:
                raise InputError(f"{name}: each item is a {what} pair, not {item!r}"[:200])

    pairs(sections, "extra_sections", True)
    pairs(pictures, "extra_pictures", False)


def params_mapping(params: object, option: str = "params") -> dict[str, Any]:
    """A tree's or navigator's parameters: a mapping of names (text) to values.

    Raises:
        InputError: not a mapping, or a name that is not text.
    """
    if params is None:
        return {}
    if not isinstance(params, Mapping):
        raise InputError(
            f"{option}: give a mapping of names to values ({{'roll': '90 deg'}}), not"
            f" {kind_of(params)}"
        )
    for key, value in params.items():
        if not isinstance(key, str) or not key:
            raise InputError(f"{option}: a parameter name is text, not {key!r}"[:200])
        if isinstance(value, str) and len(value) > MAX_PATH:
            raise InputError(f"{option}: {key}: {len(value)} characters is too long a value")
        if isinstance(value, int) and not isinstance(value, bool):
            try:
                float(value)
            except OverflowError:
                raise InputError(
                    f"{option}: {key}: a {digit_count(value)}-digit number is too large"
                ) from None
    # a NumPy number as the SI number it is: numpy.float32(0.2) was "expected a length
    # quantity such as '1 m'"
    return {str(key): plain_number(value) for key, value in params.items()}  # numpy.str_ too
