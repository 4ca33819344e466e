"""The API's options that name files, folders and connection targets.

User-named files that fall back to the bundled ones (``"bend"`` → ``trees/bend.yaml``),
files and folders to write, robot descriptions, and :func:`connect` targets
(``"sim:lab"``, a network file, a serial port or pyserial URL). Split out of
:mod:`pirate_bt.api.options`, which re-exports every name here; the same rules: each
refusal an :class:`~pirate_bt.errors.InputError` of one line naming the argument.
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pirate_bt.errors import MAX_PATH, InputError, file_argument, kind_of

if TYPE_CHECKING:
    from pirate_bt.robot.description import RobotDescription

__all__ = [
    "DEFAULT_NETWORK",
    "file_name",
    "find",
    "load_robot_like",
    "network_name",
    "not_an_input",
    "output_folder",
    "output_path",
    "parse_target",
    "port_url",
    "writable_folder",
]

_PORT = re.compile(r"^([a-z][a-z0-9+.-]*://|/dev/|COM\d+$|\\\\\.\\)", re.IGNORECASE)

DEFAULT_NETWORK = "straight"
"""The simulator's network when none is named."""


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
    if isinstance(target, os.PathLike) and isinstance(name := os.fspath(target), str):
        # a device named as a path (Path("/dev/ttyACM0")) is that port, as its text is;
        # it was read as a network file: "no network '/dev/ttyACM0'"
        if _PORT.match(name) and not name.endswith((".yaml", ".yml")):
            return "port", name
        return "sim", Path(name)
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
    """A real robot's serial port or pyserial URL (not a simulator target), as text: a
    device given as a path (``Path("/dev/ttyACM0")``) is its name (it was refused as
    *not a serial port*, beside the example of that very name).

    Raises:
        InputError: anything else, named by ``option``; a URL opening it would refuse
            (``bogus://x``), as that says it (``PortURLError``: *cannot open bogus://x*).
    """
    kind = None
    if isinstance(port, os.PathLike) and isinstance(name := os.fspath(port), str):
        port = name  # a device's path; a network file is no port (refused below)
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
    return str(port)


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
