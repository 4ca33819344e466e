"""The API's options, read the way the command line reads them.

Quantities as text with a unit (``"600 s"``, ``"20 Hz"``) or SI numbers; fault specs
(``"motor_stall:bend_3_drive@5s+20s,drop=0.05"``); connection targets (``"sim:lab"``,
a network file, a serial port or pyserial URL); user-named files that fall back to
the bundled ones (``"bend"`` → ``trees/bend.yaml``); robot descriptions.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pirate_bt.errors import InputError, UnitError
from pirate_bt.units import parse_quantity

if TYPE_CHECKING:
    from pirate_bt.robot.description import RobotDescription

__all__ = [
    "DEFAULT_NETWORK",
    "find",
    "load_robot_like",
    "network_name",
    "parse_target",
    "quantity",
    "split_faults",
]

_PORT = re.compile(r"^([a-z][a-z0-9+.-]*://|/dev/|COM\d+$|\\\\\.\\)", re.IGNORECASE)

DEFAULT_NETWORK = "straight"
"""The simulator's network when none is named."""


def quantity(value: str | float | int, dimension: str, option: str) -> float:
    """A quantity given as text with its unit (``"600 s"``) or as an SI number.

    Raises:
        InputError: a malformed quantity, named by ``option``.
    """
    if isinstance(value, bool):
        raise InputError(f"{option}: {value!r} is not a {dimension}")
    if isinstance(value, int | float):
        return float(value)
    try:
        return parse_quantity(str(value), dimension)
    except UnitError as exc:
        raise InputError(f"{option}: {exc}") from None


def split_faults(faults: str | Iterable[str] | None) -> tuple[list[str], str | None]:
    """Split a fault spec into simulator faults and a link fault spec.

    Items are separated by ``,``, ``;`` or whitespace (or given as a list). An item
    with ``@`` is a simulator fault (``motor_stall:bend_3_drive@5s+2s``); the others
    are link byte faults (``drop=0.05``, ``corrupt=0.01``), joined into one spec.

    Returns:
        ``(simulator faults, link fault spec or None)``.
    """
    items: list[str] = []
    if isinstance(faults, str):
        items = [i for i in re.split(r"[,;\s]+", faults) if i]
    elif faults is not None:
        for part in faults:
            items += [i for i in re.split(r"[,;\s]+", str(part)) if i]
    sim = [i for i in items if "@" in i]
    link = [i for i in items if "@" not in i]
    return sim, (",".join(link) or None)


def parse_target(target: Any) -> tuple[str, Any]:
    """``("sim", network)``, ``("firmware", network)`` or ``("port", url)`` for a
    :func:`connect` target.

    Raises:
        InputError: a target that is neither.
    """
    from pirate_bt.pipes import Network

    if target is None:
        return "sim", DEFAULT_NETWORK
    if isinstance(target, Network):
        return "sim", target
    if isinstance(target, Path):
        return "sim", target
    if not isinstance(target, str):
        raise InputError(
            f"connect: cannot connect to a {type(target).__name__};"
            ' give "sim:NETWORK", a network file or a serial port URL'
        )
    text = target.strip()
    if not text:
        raise InputError('connect: empty target; give "sim:NETWORK" or a serial port URL')
    if text == "sim":
        return "sim", DEFAULT_NETWORK
    if text.startswith("sim:"):
        return "sim", text[4:] or DEFAULT_NETWORK
    if text == "firmware":
        return "firmware", DEFAULT_NETWORK
    if text.startswith("firmware:"):
        return "firmware", text[9:] or DEFAULT_NETWORK
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


def load_robot_like(robot: Any) -> RobotDescription:
    """A robot description from a loaded one, a file path, or ``None`` (bundled)."""
    from pirate_bt.robot.description import RobotDescription
    from pirate_bt.robot.loader import load_robot

    if isinstance(robot, RobotDescription):
        return robot
    return load_robot(None if robot is None else str(robot))


def find(kind: str, name: str | Path, suffix: str) -> Path:
    """A user-named file: the path if it exists, else a bundled file of that name, with
    ``suffix`` added when the name has none (``"bend"`` → the bundled ``trees/bend.yaml``,
    ``"lab"`` as a route → ``scenarios/lab.route``, not the network ``lab.yaml``)."""
    from pirate_bt.resources import data_dir

    path = Path(name)
    if path.exists() or path.is_absolute() or len(path.parts) > 1:
        return path
    folder = data_dir(kind)
    if not path.suffix and (folder / f"{name}{suffix}").exists():
        return folder / f"{name}{suffix}"
    if (folder / path.name).exists():
        return folder / path.name
    return path


def network_name(name: str | Path) -> Path:
    """The network file a name means (a path, or a bundled network), for the simulator.

    Raises:
        InputError: no such network; the error lists the bundled ones.
    """
    from pirate_bt.task.networks import resolve_network_path

    try:
        return resolve_network_path(str(name), None)
    except FileNotFoundError as exc:
        raise InputError(str(exc)) from None
