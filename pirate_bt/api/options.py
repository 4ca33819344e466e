"""The API's options, read the way the command line reads them.

Quantities as text with a unit (``"600 s"``, ``"20 Hz"``) or SI numbers; fault specs
(``"motor_stall:bend_3_drive@5s+20s,drop=0.05"``); connection targets (``"sim:lab"``,
a network file, a serial port or pyserial URL); user-named files that fall back to
the bundled ones (``"bend"`` → ``trees/bend.yaml``); robot descriptions.

Every public function checks its arguments here, at the API's boundary, before
anything connects: a wrong type, a value out of range, ``nan`` or ``inf`` is an
:class:`~pirate_bt.errors.InputError` of one line that names the argument and
says what is allowed (docs/api.md, *Arguments the API refuses*).
"""

from __future__ import annotations

import itertools
import math
import numbers
import operator
import os
import re
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pirate_bt.api.fault_text import MAX_FAULT_TEXT, MAX_FAULTS, split_faults
from pirate_bt.errors import (
    MAX_PATH,
    MAX_SEED,
    InputError,
    UnitError,
    digit_count,
    file_argument,
    kind_of,
)
from pirate_bt.units import parse_quantity

if TYPE_CHECKING:
    from pirate_bt.robot.description import RobotDescription

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

_PORT = re.compile(r"^([a-z][a-z0-9+.-]*://|/dev/|COM\d+$|\\\\\.\\)", re.IGNORECASE)

DEFAULT_NETWORK = "straight"
"""The simulator's network when none is named."""

MAX_RATE_HZ = 1000.0
"""The fastest tick rate: ten ticks per state frame of the bridge (every 10 ms). The
one limit of the API, the command line (``--rate``) and campaigns (``rate:``)."""

MAX_TIME_S = 1e9
"""The longest time limit of a run (about 32 years of clock time)."""

_MAX_QUANTITY_TEXT = 64
_EXAMPLE = {"time": "600 s", "frequency": "20 Hz", "length": "1 m"}


def plain_number(value: Any) -> Any:
    """A NumPy scalar (or any other ``numbers.Integral`` or ``numbers.Real`` but a bool)
    as the plain ``int`` or ``float`` it stands for; anything else as it is. A seed of
    ``numpy.int64(3)`` was refused as no whole number, a rate of ``numpy.float32(20)``
    as no number."""
    if isinstance(value, bool | int | float | str):  # a NumPy bool is neither of those below
        return value
    if isinstance(value, numbers.Integral):
        return operator.index(value)
    if isinstance(value, numbers.Real):
        return float(value)
    return value


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
    """A seed: a whole number from 0 to :data:`MAX_SEED`.

    Raises:
        InputError: anything else (a bool, a float, text, a negative or huge number).
    """
    seed = plain_number(seed)  # a NumPy integer is a whole number too
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= MAX_SEED:
        huge = isinstance(seed, int) and not isinstance(seed, bool) and abs(seed) >= 10**40
        shown = f"a {digit_count(seed)}-digit number" if huge else repr(seed)  # type: ignore[arg-type]
        if len(shown) > 40:
            shown = kind_of(seed)
        raise InputError(f"{option}: give a whole number from 0 to 2**63 - 1, not {shown}")
    return seed


def fraction(value: object, option: str) -> float:
    """A number at least 0 and below 1 (``map_tolerance``: 0.1 is 10 %).

    Raises:
        InputError: not a number, or out of range (``nan`` too).
    """
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


def file_name(value: object, option: str) -> Path:
    """A file name as given: text or a path, not empty, no NUL, at most :data:`MAX_PATH`
    (:func:`pirate_bt.errors.file_argument`, the one rule of the library).

    Raises:
        InputError: anything else (bytes, a number, a mapping...).
    """
    return file_argument(value, option)


def output_path(value: object, option: str, inputs: Mapping[str, Any] | None = None) -> Path:
    """A file to write: :func:`file_name`, not a directory, not an existing pipe or
    device (a FIFO hung the run before it began; ``/dev/full`` failed it at the end),
    no file on its way, and none of ``inputs`` (:func:`not_an_input`).

    Raises:
        InputError: a bad name, a directory, a pipe or device, a folder on its way that
            is a file, or one of the run's own input files.
    """
    target = file_name(value, option)
    if target.is_dir():
        raise InputError(f"{option}: {target} is a directory; name a file")
    if target.exists() and not target.is_file():
        raise InputError(
            f"{option}: {target} is not a regular file (a pipe or a device); name a file"
        )
    not_an_input(target, option, inputs or {})
    for parent in target.parents:
        if parent.exists():
            if not parent.is_dir():
                raise InputError(f"{option}: {target}: {parent} is not a directory")
            break
    return target


def not_an_input(target: Path, option: str, inputs: Mapping[str, Any]) -> None:
    """Refuse an output that is one of the run's own input files, by any name (a
    symlink, a hard link): ``run tree.jsonl --trace tree.jsonl`` replaced the tree with
    its trace, exit 0. ``inputs`` maps what each is (``"tree"``) to what was given; only
    a file name of a file that exists is compared, a bundled name or an object is not.

    Raises:
        InputError: ``target`` is one of them.
    """
    if not inputs:
        return
    try:
        if not target.exists():
            return
    except OSError:  # a name the system refuses (a part over 255 bytes): no input has it
        return
    for what, given in inputs.items():
        files = getattr(given, "files", None)  # a loaded tree: its file and its subtrees'
        for i, name in enumerate(files if isinstance(files, list | tuple) else [given]):
            if not isinstance(name, str | Path) or not name or "\0" in str(name):
                continue
            try:
                same = os.path.samefile(target, name)
            except (OSError, ValueError):
                continue  # not a file (a bundled name), or unreadable: not this one
            if same:
                kind = f"{what} file" if i == 0 else f"{what}'s subtree file"
                raise InputError(f"{option}: {target} is the {kind}; name another file")


def output_folder(value: object, option: str = "output") -> Path:
    """A folder to write into: :func:`file_name`, not an existing file (``/dev/zero``),
    no file on its way.

    Raises:
        InputError: a bad name, an existing file, or a file on its way.
    """
    folder = file_name(value, option)
    for place in (folder, *folder.parents):
        if place.exists():
            if not place.is_dir():
                raise InputError(f"{option}: {place} is a file, not a folder; give a folder")
            break
    return folder


def writable_folder(folder: Path, option: str = "output") -> Path:
    """Make ``folder`` (and its parents) and check a file can be made in it, before a
    run: a mission's output or trace folder that cannot be written was found only once
    the robot had moved, as a bare ``FileNotFoundError`` or ``PermissionError``.

    Raises:
        InputError: it cannot be made, or nothing can be written in it; named ``option``.
    """
    import tempfile

    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        raise InputError(
            f"{option}: cannot write in the folder {folder}: {exc.strerror or exc}"
        ) from None
    return folder


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
    return {key: plain_number(value) for key, value in params.items()}


def parse_target(target: Any) -> tuple[str, Any]:
    """``("sim", network)``, ``("firmware", network)`` or ``("port", url)`` for a
    :func:`connect` target.

    Raises:
        InputError: a target that is neither.
    """
    from pirate_bt.pipes import Network, NetworkSpec

    if target is None:
        return "sim", DEFAULT_NETWORK
    if isinstance(target, Network):
        return "sim", target
    if isinstance(target, NetworkSpec):  # as simulate_tree's network= and navigate's sim=
        return "sim", Network(target, f"<{target.name}>")
    if isinstance(target, Path):
        return "sim", target
    if not isinstance(target, str):
        raise InputError(
            f"connect: cannot connect to {kind_of(target)};"
            ' give "sim:NETWORK", a network file, a Network or a serial port URL'
        )
    text = target.strip()
    if not text:
        raise InputError('connect: empty target; give "sim:NETWORK" or a serial port URL')
    if len(text) > MAX_PATH or "\0" in text:
        raise InputError(
            f"connect: a target of {len(text)} characters (or with a NUL) is no network or port"
        )
    for kind in ("sim", "firmware"):
        if text == kind:
            return kind, DEFAULT_NETWORK
        if text.startswith(f"{kind}:"):
            # "sim://lab", written as a URL, is "sim:lab"
            return kind, text[len(kind) + 1 :].removeprefix("//") or DEFAULT_NETWORK
    if _PORT.match(text):
        return "port", text
    if text.endswith((".yaml", ".yml")) or Path(text).is_file():
        return "sim", text
    from pirate_bt.resources import data_dir

    if (data_dir("scenarios") / f"{text}.yaml").is_file():
        return "sim", text
    raise InputError(
        f"connect: {text!r} is neither a network (write sim:NAME or a .yaml file) nor a"
        " serial port (/dev/..., COMn, or a pyserial URL such as socket://host:port)"
    )


def port_url(port: object, option: str = "port") -> str:
    """A real robot's serial port or pyserial URL (not a simulator target).

    Raises:
        InputError: anything else, named by ``option``; a URL opening it would refuse
            (``bogus://x``), as that says it (``PortURLError``: *cannot open bogus://x*).
    """
    kind = None
    if isinstance(port, str) and port.strip():
        try:
            kind = parse_target(port)[0]
        except InputError:
            kind = None
    if kind != "port":
        raise InputError(
            f"{option}: {port!r} is not a serial port or pyserial URL (/dev/ttyACM0, COM3,"
            " socket://HOST:PORT)"[:240]
        )
    assert isinstance(port, str)
    from pirate_bt.link.faults import split_fault_url
    from pirate_bt.link.port_urls import scheme_problem
    from pirate_bt.link.transport import PortURLError, network_url_problem

    url = split_fault_url(port)[0]  # as opening it checks it, before anything is done
    if problem := scheme_problem(url) or network_url_problem(url):  # (a plan was printed)
        raise PortURLError(f"cannot open {url}: {problem}", url)
    return port


def load_robot_like(robot: Any) -> RobotDescription:
    """A robot description from a loaded one, a file path, or ``None`` (bundled).

    Raises:
        InputError: ``robot`` is none of those (a mapping, a number, an empty name).
        ValidationFailed: the file does not validate.
    """
    from pirate_bt.robot.description import RobotDescription
    from pirate_bt.robot.loader import load_robot

    if isinstance(robot, RobotDescription):
        return robot
    if robot is None:
        return load_robot(None)
    if not isinstance(robot, str | os.PathLike):
        raise InputError(
            f"robot: give a robot description file, a loaded RobotDescription or None"
            f" (the bundled robot), not {kind_of(robot)}"
        )
    return load_robot(str(file_name(robot, "robot")))


def find(kind: str, name: str | Path, suffix: str, option: str = "") -> Path:
    """A user-named file: the path if it exists, else a bundled file of that name, with
    ``suffix`` added when the name has none (``"bend"`` → the bundled ``trees/bend.yaml``,
    ``"lab"`` as a route → ``scenarios/lab.route``, not the network ``lab.yaml``).

    Raises:
        InputError: ``name`` is not a file name (:func:`file_name`), named by ``option``.
    """
    from pirate_bt.resources import data_dir

    path = file_name(name, option or kind)
    if _exists(path) or path.is_absolute() or len(path.parts) > 1:
        return path
    folder = data_dir(kind)
    if not path.suffix and _exists(folder / f"{path}{suffix}"):
        return folder / f"{path}{suffix}"
    if _exists(folder / path.name):
        return folder / path.name
    return path


def _exists(path: Path) -> bool:
    """``path.exists()``, false for a name the system refuses (a part too long)."""
    try:
        return path.exists()
    except OSError:
        return False


def network_name(name: str | Path, option: str = "network") -> Path:
    """The network file a name means (a path, or a bundled network), for the simulator.

    Raises:
        InputError: not a name, or no such network; the error lists the bundled ones.
    """
    from pirate_bt.task.networks import resolve_network_path

    given = file_name(name, option)
    try:
        return resolve_network_path(str(given), None)
    except FileNotFoundError as exc:
        raise InputError(f"{option}: {exc}") from None
    except OSError as exc:  # a name the system refuses (a part too long)
        raise InputError(f"{option}: no network {str(given)[:80]!r}: {exc.strerror}") from None
