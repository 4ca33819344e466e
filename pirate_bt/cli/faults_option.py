"""``--faults SPEC`` checked where it is typed: a bad item is ``--faults:1:COLUMN``.

The API names its ``faults=`` argument (``faults: unknown link fault 'bogus'``); on
the command line every other bad input names its place as ``file:line:column``
(``--param d=1e999s: parameter 'd': ...``), so each item of the option is checked here on its own,
before anything is read or connected, and its problem is placed at the item's
column (``--faults:1:11: unknown link fault 'bogus' ...``). The API checks the
same text again and finds nothing more.
"""

from __future__ import annotations

import argparse
from typing import Any

from pirate_bt.errors import InputError, LocatedError, SourceLocation

__all__ = ["check_fault_options", "check_faults_option"]


def check_faults_option(args: argparse.Namespace, robot: Any, option: str = "--faults") -> None:
    """Refuse a bad ``--faults`` value at the column of the item that is wrong.

    Args:
        args: The command's options: ``faults`` (``None``: not given), and ``port``
            and ``firmware_chain`` where the command has them (simulator faults need
            the Python simulator).
        robot: The robot description whose motors, channels and boards a simulator
            fault must name.
        option: The option's name, the pseudo-file of the location.

    Raises:
        LocatedError: too many faults or one too long (at the first one over), a
            simulator fault that does not parse, names something the robot lacks or is
            given with ``--port`` or ``--firmware-chain``, a link fault that does not
            parse or repeats a key.
    """
    text = getattr(args, "faults", None)
    if not text:
        return
    no_simulator = ""  # the API's words, at the item
    if getattr(args, "port", None) is not None:
        no_simulator = "simulator faults (KIND:TARGET@AT) need the simulator, not a port"
    elif getattr(args, "firmware_chain", False):
        no_simulator = (
            "simulator faults (KIND:TARGET@AT) need the Python simulator; through the"
            " firmware only link faults (KEY=VALUE) apply"
        )
    from pirate_bt.api.fault_text import (
        MAX_FAULT_TEXT,
        MAX_FAULTS,
        check_link_faults,
        fault_items,
    )
    from pirate_bt.sim.faults import check_fault_target, parse_fault

    items = fault_items(text)  # as split_faults splits them

    def at(column: int, problem: InputError) -> LocatedError:
        return LocatedError(str(problem), SourceLocation(option, 1, column))

    if len(items) > MAX_FAULTS:
        raise at(
            items[MAX_FAULTS][0],
            InputError(f"more than {MAX_FAULTS} faults ({len(items)} given)"),
        )
    link: list[str] = []
    for column, item in items:
        if len(item) > MAX_FAULT_TEXT:
            raise at(
                column,
                InputError(
                    f"a fault of {len(item)} characters is too long (at most {MAX_FAULT_TEXT})"
                ),
            )
        try:
            if "@" in item:  # a simulator fault, as split_faults tells them apart
                if no_simulator:
                    raise InputError(no_simulator)
                check_fault_target(parse_fault(item, option=""), robot)
            else:  # the spec so far: a key given twice is placed at its second item
                link.append(item)
                check_link_faults(",".join(link), option="")
        except LocatedError:
            raise
        except InputError as exc:
            raise at(column, exc) from None


def check_fault_options(values: list[str], robot: Any, option: str = "--fault") -> None:
    """``pirate-bt sim``'s repeatable ``--fault KIND[:TARGET]@AT``, each a simulator
    fault, refused as ``--fault:1:1: ...`` (it said ``faults: ...``).

    Raises:
        LocatedError: a fault that does not parse or names something the robot lacks.
    """
    from pirate_bt.sim.faults import check_fault_target, parse_fault

    for value in values:
        try:
            check_fault_target(parse_fault(value, option=""), robot)
        except InputError as exc:
            raise LocatedError(str(exc), SourceLocation(option, 1, 1)) from None
