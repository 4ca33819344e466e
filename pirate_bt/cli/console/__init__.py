"""The operator console behind ``pirate-bt teleop``: a view, not a layer.

- :mod:`~pirate_bt.cli.console.view` builds the text the operator reads from the
  supervisor's read-outs (no terminal library; scripts and tests use it too);
- :mod:`~pirate_bt.cli.console.engine` owns the supervisor in one thread and
  applies keys at tick boundaries;
- :mod:`~pirate_bt.cli.console.app` is the full-screen Textual screen.

Textual is imported only by :class:`OperatorConsole`, so ``teleop --keys`` and
the rest of the command line start without it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from pirate_bt.cli.console.engine import ConsoleEngine
from pirate_bt.cli.console.view import Snapshot, VerdictFeed, verdict_text

if TYPE_CHECKING:
    from pirate_bt.cli.console.app import OperatorConsole

__all__ = ["ConsoleEngine", "OperatorConsole", "Snapshot", "VerdictFeed", "verdict_text"]


def __getattr__(name: str) -> Any:
    if name == "OperatorConsole":
        from pirate_bt.cli.console.app import OperatorConsole

        return OperatorConsole
    raise AttributeError(name)
