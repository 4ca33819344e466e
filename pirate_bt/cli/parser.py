"""The parser of ``pirate-bt`` and its verbs: argparse, held to the command-line
contract of DESIGN.md.

A usage error is one line and exit 2 (not the usage block first); an option is taken
only as written in full (no abbreviations); a value option given twice is refused, as
is an empty value where empty means nothing; a sub-command's parser names what it does
not know. :func:`pirate_bt.cli.main` makes every parser of :class:`Parser`'s kind.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path, PurePath
from typing import Any, NoReturn

__all__ = ["EXIT_INPUT", "EmptyValue", "Parser"]

EXIT_INPUT = 2

_GIVEN = "_pirate_bt_given"  # the options given so far in one parse (then removed)


class _StoreOnce(argparse._StoreAction):
    """argparse's ``store``, refusing an option given twice in one command line.

    argparse keeps the last value: ``--seed 1 ... --seed 2`` ran seed 2 and ``-o a
    --output b`` wrote only b, with nothing said. An option meant to be repeated says
    so (``action="append"``: ``--param``, ``--log``); a flag given twice is still one
    flag (``store_true``)."""

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        if option_string is not None:  # an option (a positional is called once)
            given: dict[int, tuple[str, Any]] = vars(namespace).setdefault(_GIVEN, {})
            first = given.get(id(self))
            if first is not None:
                from pirate_bt.errors import shown

                spelt = (
                    option_string
                    if first[0] == option_string
                    else f"{first[0]}, then {option_string},"
                )

                def typed(value: Any) -> str:  # a path as typed, not PosixPath('a.svg')
                    return str(value) if isinstance(value, PurePath) else shown(value)

                parser.error(
                    f"{spelt} given twice ({typed(first[1])} and {typed(values)}); give it once"
                )
            given[id(self)] = (option_string, values)
        super().__call__(parser, namespace, values, option_string)


class _SubCommands(argparse._SubParsersAction):  # type: ignore[type-arg]
    """argparse's sub-commands (``trace show``, ``export btcpp``), whose parser names
    what it does not know: ``trace plot t.jsonl -o p.png --start 2`` said *pirate-bt
    trace: unrecognized arguments: --start 2 (see 'pirate-bt trace --help')*, a page
    that lists no option of ``plot``'s."""

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        super().__call__(parser, namespace, values, option_string)
        unknown = vars(namespace).pop(argparse._UNRECOGNIZED_ARGS_ATTR, None)
        if unknown:
            chosen = self._name_parser_map[values[0]]
            chosen.error(f"unrecognized arguments: {' '.join(unknown)}")


# An option's value may be empty only where empty means something: no faults, no keys,
# the root ROS namespace. Anywhere else '--output "$DIR"' with DIR unset ran demo and
# mission into the working folder, and '--sim "$NET"' ran in the default network.
_MAY_BE_EMPTY = frozenset({"faults", "keys", "ros_namespace"})
_EMPTY_HINT = {  # metavar -> what to give
    "DIR": "name a folder",
    "NETWORK": "name a network",
    "MAP": "name a network",
    "SURVEYED": "name a network",
    "TREE": "name a tree",
    "ROUTE": "name a route",
    "URL": "name a port",
    "ADDRESS": "name a scheduler",
    "COMMAND": "name a command",
    "SPEC": "name a file",  # campaign's (--faults '' is no faults)
}


class EmptyValue(Exception):
    """An option given as ``''`` (:data:`_MAY_BE_EMPTY`): one line, exit 2."""


class Parser(argparse.ArgumentParser):
    """argparse, with a usage error in one line (DESIGN.md: one clear line each), not
    the usage block first; ``--help`` shows the usage. Subcommands' parsers are of
    this class too (``add_subparsers`` makes its parent's kind). A value option given
    twice is refused (:class:`_StoreOnce`).

    An option is taken only as written in full: argparse's abbreviations read
    ``mission --map lab`` as ``--map-tolerance lab`` (and then failed on "not a
    fraction"), and a later option sharing a prefix would change what an old
    command line means."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)
        self.register("action", None, _StoreOnce)
        self.register("action", "store", _StoreOnce)
        self.register("action", "parsers", _SubCommands)

    def parse_known_args(  # type: ignore[override]
        self, args: Sequence[str] | None = None, namespace: argparse.Namespace | None = None
    ) -> tuple[argparse.Namespace, list[str]]:
        parsed, extras = super().parse_known_args(args, namespace)
        vars(parsed).pop(_GIVEN, None)  # one parse's bookkeeping, not an option
        return parsed, extras

    def _get_value(self, action: argparse.Action, arg_string: str) -> Any:
        if (
            arg_string == ""
            and action.dest not in _MAY_BE_EMPTY
            # --param '' and validate '' say their own; a verb '' is no choice
            and (action.option_strings or action.nargs in (None, "?"))
            and not isinstance(action, argparse._AppendAction | argparse._SubParsersAction)
        ):
            metavar = action.metavar if isinstance(action.metavar, str) else ""
            metavar = metavar or action.dest.upper()
            named_file = "FILE" in metavar or action.type is Path or action.dest == "output"
            hint = _EMPTY_HINT.get(metavar, "name a file" if named_file else "give a value")
            name = "/".join(action.option_strings) or metavar
            raise EmptyValue(f"{name}: empty; {hint}")
        return super()._get_value(action, arg_string)

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_INPUT, f"{self.prog}: {message} (see '{self.prog} --help')\n")
