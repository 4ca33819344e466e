"""The full-screen operator console (Textual).

The screen stays put: a status panel updated every tick, the running tree when
one is attached, a condensed verdict log, the confirmations a supervised tree
is waiting for, and the keys. Keys go to the engine thread
(:class:`~pirate_bt.cli.console.engine.ConsoleEngine`), which applies them at
the start of the next tick; the screen never calls the supervisor itself.
"""

from __future__ import annotations

import contextlib
import logging
from typing import Any, ClassVar

from rich.text import Text
from textual import events, on, work
from textual.app import App, ComposeResult
from textual.containers import Horizontal, Vertical
from textual.message import Message
from textual.widgets import Footer, Header, Static

from pirate_bt.cli.console.engine import ConsoleEngine
from pirate_bt.cli.console.view import Snapshot

__all__ = ["KEY_HELP", "OperatorConsole"]

KEY_HELP: tuple[tuple[str, str], ...] = (
    ("w / s", "faster / slower (20 mm/s steps)"),
    ("space", "stop the drives"),
    ("f / F", "clamp / unclamp the front half"),
    ("r / R", "clamp / unclamp the rear half"),
    ("a / d", "rotate the halves -5° / +5°"),
    ("[ / ]", "bend the front pair -5° / +5°"),
    ("c / v", "front module clear / back to 0°"),
    ("m / o", "take over / hand back"),
    ("y / n", "confirm / deny the waiting step"),
    ("p / u", "safe state / leave it"),
    ("e / x", "e-stop / reset the e-stop"),
    ("q", "quit (a running tree stops safe; Ctrl-C too)"),
)

_LEVEL_STYLE = {"ok": "green", "warn": "yellow", "alarm": "bold red"}
_VERDICT_STYLE = {"PASS": "", "CLIP": "yellow", "REFUSE": "red", "IGNORED": "yellow"}


class _ConsoleLog(logging.Handler):
    """Shows warnings from the library in the verdict panel instead of on the screen's tty."""

    def __init__(self, app: OperatorConsole) -> None:
        super().__init__(logging.WARNING)
        self.app = app

    def emit(self, record: logging.LogRecord) -> None:
        if record.name.startswith("pirate_bt.safety") and (
            record.levelno < logging.ERROR or str(record.msg).startswith("e-stop reset refused")
        ):
            # Verdicts are in the verdict panel already, and a refused reset is a line
            # of its own there; the protective layer's errors are not (a stop that could
            # not be sent, a protective clamp refused: they were dropped before 2026-11-30).
            return
        first = (record.getMessage().splitlines() or [""])[0]
        self.app.log_lines.append(f"{record.levelname.lower()}: {first}")


class _Published(Message):
    """A snapshot from the engine thread."""

    def __init__(self, snapshot: Snapshot | None) -> None:
        super().__init__()
        self.snapshot = snapshot  # None: the engine has ended


class OperatorConsole(App[int]):
    """The console screen over one :class:`ConsoleEngine`.

    Args:
        engine: The engine that owns the supervisor (started by the app).
        title: What the header says (the robot or simulator in use).
    """

    CSS = """
    #left { width: 3fr; }
    #right { width: 2fr; }
    .panel { border: round $accent; padding: 0 1; }
    #status { height: auto; }
    #pending { height: auto; }
    #keys { height: auto; }
    #tree { height: 1fr; }
    #verdicts { height: 1fr; }
    """

    ENABLE_COMMAND_PALETTE = False
    BINDINGS: ClassVar[list[Any]] = []

    def __init__(self, engine: ConsoleEngine, title: str = "pirate-bt teleop") -> None:
        super().__init__()
        self.engine = engine
        self.title = title
        self.last: Snapshot | None = None
        self.log_lines: list[str] = []
        self._handler = _ConsoleLog(self)

    def compose(self) -> ComposeResult:
        yield Header()
        with Horizontal():
            with Vertical(id="left"):
                yield Static(id="status", classes="panel")
                yield Static(id="pending", classes="panel")
                yield Static(id="verdicts", classes="panel")
            with Vertical(id="right"):
                yield Static(id="tree", classes="panel")
                yield Static(self._keys_text(), id="keys", classes="panel")
        yield Footer()

    def on_mount(self) -> None:
        for widget_id, title in (
            ("status", "robot"),
            ("pending", "confirmations"),
            ("verdicts", "verdicts (one line per command)"),
            ("tree", "tree"),
            ("keys", "keys"),
        ):
            self.query_one(f"#{widget_id}").border_title = title
        root = logging.getLogger()
        self._saved_handlers = list(root.handlers)
        for handler in self._saved_handlers:
            root.removeHandler(handler)
        root.addHandler(self._handler)
        self._engine_thread()

    def on_unmount(self) -> None:
        self.engine.quit()
        root = logging.getLogger()
        root.removeHandler(self._handler)
        for handler in self._saved_handlers:
            root.addHandler(handler)

    @work(thread=True, exclusive=True)
    def _engine_thread(self) -> None:
        try:
            self.engine.run(self._publish)
        finally:
            self._post(None)

    def _publish(self, snapshot: Snapshot) -> None:
        self._post(snapshot)

    def _post(self, snapshot: Snapshot | None) -> None:
        # Posted, not called: call_from_thread waits for the screen's loop, and a loop a
        # SIGTERM or SIGHUP had ended never answered, so the engine thread hung there,
        # the process with it (before 2026-11-30).
        with contextlib.suppress(RuntimeError):  # a closed loop: nobody is looking
            self.post_message(_Published(snapshot))

    @on(_Published)
    def _published(self, message: _Published) -> None:
        if message.snapshot is None:
            self.exit(0)
        else:
            self.show(message.snapshot)

    @staticmethod
    def _keys_text() -> Text:
        text = Text()
        for keys, what in KEY_HELP:
            text.append(f"{keys:>6}  ", style="bold")
            text.append(f"{what}\n")
        return text

    def show(self, snapshot: Snapshot) -> None:
        """Redraw every panel from one snapshot."""
        self.last = snapshot
        status = Text(f"t = {snapshot.time_s:.2f} s\n", style="dim")
        for line in snapshot.status:
            status.append(f"{line.label:>10}  ", style="bold")
            status.append(f"{line.text}\n", style=_LEVEL_STYLE.get(line.level, ""))
        self.query_one("#status", Static).update(status)
        if snapshot.pending:
            pending = Text("waiting: " + ", ".join(snapshot.pending), style="bold yellow")
            pending.append("\n y confirms, n denies", style="")
        else:
            pending = Text("nothing waiting", style="dim")
        self.query_one("#pending", Static).update(pending)
        verdicts = Text()
        panel = self.query_one("#verdicts", Static)
        # The newest lines that fit, so the log never runs off the bottom.
        rows = max(panel.content_region.height, 1)
        for entry in (list(snapshot.verdicts) + self.log_lines[-3:])[-rows:]:
            words = entry.split()
            word = words[2] if len(words) > 2 else ""
            verdicts.append(entry + "\n", style=_VERDICT_STYLE.get(word, "dim"))
        panel.update(verdicts)
        tree = "\n".join(snapshot.tree) if snapshot.tree else "no tree attached (--tree TREE)"
        if snapshot.finished:
            tree = f"{snapshot.finished}\n{tree}"
        self.query_one("#tree", Static).update(Text(tree))

    def on_key(self, event: events.Key) -> None:
        # Ctrl-C quits as q does (a running tree interrupted, the robot left safe), as it
        # stops 'pirate-bt run'; it was taken for an unknown key and did nothing.
        key = {"space": " ", "ctrl+c": "q"}.get(event.key, event.character)
        if key is None or len(key) != 1:
            return
        event.stop()
        self.engine.press(key)
