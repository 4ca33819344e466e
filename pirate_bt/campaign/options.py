"""The arguments of :func:`~pirate_bt.campaign.run.run_campaign`, checked before a
spec is read: their types and ranges, the case function each case process imports,
and a case's wall-time limit.

A mistake here would otherwise surface late (every case an error row of the same
cause) or never (an option silently dropped); each is refused in one line that
names the argument.
"""

from __future__ import annotations

import importlib
import importlib.machinery
import importlib.util
import os
import re
from pathlib import Path
from typing import Any

from pirate_bt.api.options import plain_number
from pirate_bt.campaign.spec import MAX_CASE_TIMEOUT_S
from pirate_bt.errors import ArgumentTypeError, InputError, digit_count, said_of, shown

__all__ = [
    "MAX_WORKERS",
    "case_timeout_s",
    "check_callback",
    "check_options",
    "check_target",
    "given_path",
]


MAX_WORKERS = 1024
"""The most local worker processes (never more than the campaign has cases)."""


def given_path(value: Any, name: str) -> Path:
    """A file or folder name given to :func:`run_campaign`: text or a path, not empty."""
    if not isinstance(value, (str, os.PathLike)) or not str(os.fspath(value)).strip():
        raise InputError(f"{name}: give a file or folder name, not {value!r}"[:200])
    text = str(os.fspath(value))
    if len(text) > 4096 or "\0" in text:
        raise InputError(f"{name}: a name of {len(text)} characters (or with a NUL) is no file")
    return Path(text)


def check_callback(value: Any, name: str, argument: str) -> None:
    """``value`` is ``None`` or a plain function the campaign can call as
    ``name(argument)``: one positional argument, not an ``async def`` (called, never
    awaited) nor a generator function (a ``yield`` in it: called, never iterated), whose
    body would never run (a generator ``on_record`` passed zero rows with no word).
    Checked before anything is read, as the API checks ``observe=``
    (:func:`pirate_bt.api.observing.check_callback`, in its words): a callback of
    the wrong arity raised a bare ``TypeError`` from deep inside once a case had run.

    Raises:
        ArgumentTypeError: one line naming ``name``, what it takes and how it is called.
    """
    from pirate_bt.api.observing import check_callback as check_api_callback

    if value is None:
        return
    if not callable(value):
        raise ArgumentTypeError(f"{name}: give a function (or None), not {shown(value)}")
    check_api_callback(value, name, f"{name}({argument})", 1)  # the API's words


_TARGET = re.compile(r"[A-Za-z_]\w*(\.[A-Za-z_]\w*)*:[A-Za-z_]\w*")


def check_options(options: dict[str, Any]) -> dict[str, Any]:
    """Types and ranges of :func:`run_campaign`'s options, before anything is read.

    A NumPy number or truth value is the Python one, as the rest of the API reads it
    (:func:`~pirate_bt.api.options.plain_number`): ``workers=numpy.int64(2)`` was
    refused as no whole number.

    Returns:
        ``options``, its numbers and flags as plain Python values (run with these).

    Raises:
        InputError: the first that is wrong, named.
    """
    for name in ("workers", "max_cases", "resume", "progress"):
        options[name] = plain_number(options[name])
    for name in ("workers", "max_cases"):
        value = options[name]
        if value is None and name == "workers":
            continue
        if isinstance(value, bool) or not isinstance(value, int):
            raise InputError(f"{name}: give a whole number, not {value!r}"[:200])
    workers = options["workers"]
    if workers is not None and workers > MAX_WORKERS:
        raise InputError(f"workers: at most {MAX_WORKERS} local processes, not {workers}")
    for name in ("resume", "progress"):
        if not isinstance(options[name], bool):
            raise InputError(f"{name}: give True or False, not {options[name]!r}"[:200])
    check_callback(options["on_record"], "on_record", "row")
    check_callback(options["echo"], "echo", "line")
    for name in ("scheduler", "command", "target"):
        if options[name] is not None and not isinstance(options[name], str):
            raise InputError(f"{name}: give text, not {options[name]!r}"[:200])
    if not isinstance(options["target"], str) or not _TARGET.fullmatch(options["target"]):
        # else every case died of it, one error row each
        raise InputError(
            f"target: give 'module:function' (pirate_bt.campaign.case:run_case),"
            f" not {options['target']!r}"[:200]
        )
    for name in ("scheduler_file", "output", "base"):
        if options[name] is not None:
            given_path(options[name], name)
    if options["base"] is not None and not Path(options["base"]).is_dir():
        # else every relative name silently resolved against the working folder instead
        raise InputError(f"base: {str(options['base'])[:200]!r} is not a folder")
    executor = options["executor"]
    if executor is not None and not callable(getattr(executor, "submit", None)):
        raise InputError(f"executor: give a concurrent.futures executor, not {executor!r}"[:200])
    return options


def check_target(target: str, cluster: bool) -> None:
    """The case function can be imported, as each case process will import it: a
    module or function that is not there was one error row per case.

    A module this process cannot find may still be the case processes': on a
    ``PYTHONPATH`` given to them, or in a cluster's own environment; only a module
    found nowhere is refused.
    """
    module, _, name = target.partition(":")
    try:
        spec = importlib.util.find_spec(module)
    except Exception:  # a parent package that is missing, or raises as it is imported
        spec = None
    if spec is None:
        top = module.partition(".")[0]
        paths = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
        if cluster or importlib.machinery.PathFinder.find_spec(top, paths) is not None:
            return
        raise InputError(f"target: no module named {module!r} (each case process imports it)")
    try:
        found = importlib.import_module(module)
    except Exception as exc:  # it fails every case the same way
        raise InputError(f"target: importing {module} raised {said_of(exc)}"[:300]) from None
    if not callable(getattr(found, name, None)):
        raise InputError(f"target: {module} has no function {name!r}"[:300])


def case_timeout_s(value: str | float | None, name: str = "case_timeout") -> float | None:
    """A case's wall-time limit in seconds (``"90 s"`` or seconds; ``None`` stays None).

    Raises:
        InputError: not a positive duration, or above a week; the message starts
            with ``name`` (the command passes ``--case-timeout``).
    """
    if value is None:
        return None
    seconds = _seconds(value, name)
    if seconds > MAX_CASE_TIMEOUT_S:
        raise InputError(f"{name} is at most {MAX_CASE_TIMEOUT_S:g} s, not {value!r}")
    return seconds


def _seconds(value: str | float, name: str) -> float:
    """A positive, finite duration given as seconds or a quantity (``"30 s"``)."""
    value = plain_number(value)  # a NumPy number is seconds too
    if isinstance(value, bool) or not isinstance(value, (str, int, float)):
        raise InputError(f"{name}: give a duration such as '30 s', not {value!r}"[:200])
    if isinstance(value, (int, float)):
        try:
            seconds = float(value)
        except OverflowError:
            raise InputError(
                f"{name}: a {digit_count(int(value))}-digit number is too large"
            ) from None
    else:
        from pirate_bt.units import parse_quantity

        try:
            seconds = parse_quantity(value, "time")
        except Exception as exc:
            raise InputError(f"{name}: {exc}") from None
    if not seconds > 0:
        raise InputError(f"{name} must be positive, not {value!r}")
    return seconds
