"""Which network a mission runs in, and which it plans on: names resolved to files."""

from __future__ import annotations

import stat
from pathlib import Path

from pirate_bt.errors import InputError, LocatedError, SourceLocation, shown
from pirate_bt.pipes import Network, load_network
from pirate_bt.task.route import Route

__all__ = ["load_network_for", "resolve_network_path"]


def resolve_network_path(name: str, base_dir: Path | None = None) -> Path:
    """The network file a route or ``--sim`` names.

    ``lab`` is looked up next to the route (``lab.yaml``), then among the bundled
    scenarios; a name ending in ``.yaml`` is a path (relative to ``base_dir``; without one,
    returned as given, relative to the current folder).

    Raises:
        FileNotFoundError: no such network (or a name no file can have: too long),
            with the bundled names.
    """
    from pirate_bt.resources import data_dir

    candidates: list[Path] = []
    plain = Path(name)
    if plain.suffix in (".yaml", ".yml"):
        # relative to base_dir; without one, as typed (relative to the current folder),
        # so that errors in the file name it as the user did
        candidates.append(plain if plain.is_absolute() or base_dir is None else base_dir / plain)
        candidates.append(plain)
    else:
        if base_dir is not None:
            candidates.append(base_dir / f"{name}.yaml")
        candidates.append(data_dir("scenarios") / f"{name}.yaml")
    for candidate in candidates:
        if _is_file(candidate):
            return candidate
    bundled = sorted(p.stem for p in data_dir("scenarios").glob("*.yaml"))
    # a route or other file given where a network goes: say why it is not one
    kind = ": a network file ends in .yaml" if _is_file(plain) else ""
    for candidate in [*candidates, plain]:
        if kind:
            break
        what = _not_a_file(candidate)  # "no network '/tmp'" read as if nothing were there
        if what:
            kind = f": it is {what}; a network is a .yaml file"
    raise FileNotFoundError(
        f"no network {shown(name)}{kind}; bundled networks: {', '.join(bundled)}"
    )


def _is_file(path: Path) -> bool:
    """``path.is_file()``, False for a name the system refuses (a part longer than 255
    bytes raises ``OSError: File name too long``): the caller says "no network"."""
    try:
        return path.is_file()
    except (OSError, ValueError):  # ValueError: a NUL in the name
        return False


_NOT_FILES = (
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISFIFO, "a named pipe"),
    (stat.S_ISSOCK, "a socket"),
    (stat.S_ISCHR, "a device"),
    (stat.S_ISBLK, "a device"),
)


def _not_a_file(path: Path) -> str | None:
    """What ``path`` is when it exists and is no regular file (``a folder``, ``a named
    pipe``, ...), else None. Only stat()ed, never opened: a named pipe's open blocks."""
    try:
        mode = path.stat().st_mode
    except (OSError, ValueError):  # none there, a name the system refuses, a NUL
        return None
    return next((what for test, what in _NOT_FILES if test(mode)), None)


def load_network_for(route: Route, sim: str | None, *, option: str = "--sim") -> Network:
    """The network a mission runs in: ``--sim`` if given, else the route's ``network`` line.

    Raises:
        LocatedError: neither is given, or the network the route names does not exist.
        InputError: the network ``option`` names does not exist.
        ValidationFailed: the network file does not validate.
    """
    name = sim or route.network
    if name is None:
        give = f"{option} NETWORK" if option.startswith("-") else f"{option}=NAME"  # Python
        raise LocatedError(
            f"the route names no network; add a line 'network NAME' or give {give}",
            SourceLocation(route.source),
        )
    base = Path(route.source).parent if not route.source.startswith("<") else None
    try:
        path = resolve_network_path(name, base)
    except FileNotFoundError as exc:
        where = route.network_location if sim is None and route.network_location else None
        if where is None:  # an option or a parameter, no place in a file: '--sim:1:1:' was
            raise InputError(f"{option}: {exc}") from None
        raise LocatedError(str(exc), where) from None
    return load_network(path)
