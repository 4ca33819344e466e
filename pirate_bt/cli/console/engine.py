"""The console's engine: one thread that owns the supervisor, the keys and the tree.

Every call on the supervisor happens in this thread, in tick order: the
supervisor ticks, then the keys the operator typed since the last tick (queued
by the screen) are applied, as ``teleop --keys`` applies them, then the tree
(when one is attached) ticks through the ordinary
:class:`~pirate_bt.runner.Runner`, so its exception safety, safe state and
pause in manual mode are the same as in ``pirate-bt run``. After every tick
the engine hands the screen an immutable :class:`Snapshot`.

Quitting while a tree runs interrupts it as Ctrl-C does in ``pirate-bt run``:
running nodes are stopped and the robot goes to its safe state.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from pirate_bt.cli.console.view import Snapshot, VerdictFeed, status_lines

__all__ = ["ConsoleEngine", "QuitRequested"]

_log = logging.getLogger(__name__)

Publish = Callable[[Snapshot], None]


class QuitRequested(KeyboardInterrupt):
    """Raised inside the runner's pre-tick hook when the operator quits."""


@dataclass
class _TreeView:
    """Reads a running tree's statuses as text (the live view's renderer)."""

    tree: Any

    def __post_init__(self) -> None:
        from pirate_bt.trace.structure import iter_with_ids, tree_structure

        self.structure = tree_structure(self.tree)
        self.nodes = list(iter_with_ids(self.tree))

    def lines(self) -> tuple[str, ...]:
        from pirate_bt.trace.records import STATUS_CODE
        from pirate_bt.trace.text import tree_text

        status = {node_id: STATUS_CODE[node.status] for node_id, node in self.nodes}
        feedback = {node_id: node.feedback_message for node_id, node in self.nodes}
        return tuple(tree_text(self.structure, status, feedback, collapse=True))


class ConsoleEngine:
    """Runs the teleop session (and an attached tree) and publishes snapshots.

    Args:
        session: The :class:`~pirate_bt.cli.teleop.TeleopSession` (keys to actions).
        period_s: Time between ticks on the supervisor's clock.
        runner_factory: Builds the :class:`~pirate_bt.runner.Runner` of an
            attached tree (``None``: teleop only). Called in the engine thread.
        wall_period_s: Wall time between ticks (default ``period_s``: real time).
    """

    def __init__(
        self,
        session: Any,
        *,
        period_s: float,
        runner_factory: Callable[[], Any] | None = None,
        wall_period_s: float | None = None,
    ) -> None:
        self.session = session
        self.sup = session.sup
        self.period_s = period_s
        self.wall_period_s = period_s if wall_period_s is None else wall_period_s
        self.runner_factory = runner_factory
        self.keys: queue.SimpleQueue[str] = queue.SimpleQueue()
        self.feed = VerdictFeed()
        self.sup.add_listener(self.feed.add)
        session.notes.append(lambda text: self.feed.note(self.sup.clock.now(), text))
        self.stop_event = threading.Event()
        self.finished: str | None = None
        self.result: Any = None
        self._tree: _TreeView | None = None
        self._idle = threading.Event()
        self._idle.set()

    # -- called from the screen's thread

    def press(self, key: str) -> None:
        """Queue one key; it takes effect right after the next supervisor tick."""
        self.keys.put(key)

    def quit(self) -> None:
        self.stop_event.set()

    def stop(self, timeout_s: float = 10.0) -> bool:
        """Quit and wait for the engine thread to end (a running tree stopped safe);
        returns False if it did not within ``timeout_s``.

        For a screen that ended without unmounting (SIGTERM or SIGHUP raised in its
        loop): the engine thread ticked on, re-sending the operator's drive, and the
        process never exited (before 2026-11-30).
        """
        self.stop_event.set()
        return self._idle.wait(timeout_s)

    # -- the engine thread

    def _apply_keys(self) -> None:
        while True:
            try:
                key = self.keys.get_nowait()
            except queue.Empty:
                return
            if not self.session.press(key):
                self.stop_event.set()

    def snapshot(self) -> Snapshot:
        """What the screen shows now (engine thread only)."""
        sup = self.sup
        lines = status_lines(
            robot=sup.robot,
            mode=str(sup.mode),
            estopped=sup.estopped,
            safe_state_reason=sup.safe_state_reason if sup.in_safe_state else None,
            half_states={half: str(state) for half, state in sup.half_states().items()},
            state=sup.state(),
            health=sup.health(),
            now_s=sup.clock.now(),
            manual_velocity_mps=self.session.velocity_mps,
        )
        return Snapshot(
            time_s=sup.clock.now(),
            status=tuple(lines),
            tree=self._tree.lines() if self._tree is not None else (),
            verdicts=tuple(self.feed.lines),
            pending=tuple(sup.pending_confirmations()),
            finished=self.finished,
        )

    def _wait(self) -> None:
        if self.sup.clock.is_simulated:
            self.sup.clock.sleep(self.period_s)
        self.stop_event.wait(self.wall_period_s)

    def run(self, publish: Publish) -> None:
        """Tick until the operator quits; call ``publish(snapshot)`` after each tick."""
        self._idle.clear()
        try:
            if self.runner_factory is not None:
                self._run_tree(publish)
            while not self.stop_event.is_set():
                self.session.step()
                self._apply_keys()
                publish(self.snapshot())
                self._wait()
        finally:
            self._idle.set()

    def _run_tree(self, publish: Publish) -> None:
        assert self.runner_factory is not None
        runner = self.runner_factory()
        self._tree = _TreeView(runner.tree)

        def before(_info: object) -> None:
            if self.stop_event.is_set():
                raise QuitRequested("operator quit the console")
            self.session.step()
            self._apply_keys()

        def after(_info: object) -> None:
            publish(self.snapshot())
            if not self.sup.clock.is_simulated:
                return
            # The runner paces the simulated clock; pace the wall to the screen.
            time.sleep(self.wall_period_s)

        runner.add_pre_tick(before)
        runner.add_post_tick(after)
        self.result = runner.run()
        result = self.result
        self.finished = f"tree {result.outcome.upper()}: {result.message}"
        _log.info("%s", self.finished)
        publish(self.snapshot())
