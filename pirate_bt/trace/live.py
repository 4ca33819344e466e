"""A compact live view of a running tree, for the terminal.

:func:`live_view_hook` returns a post-tick handler that shows the tree with
statuses and progress while it runs:

- on a terminal, the tree is redrawn in place at most every ``interval_s``
  seconds of wall time, with the branches that are not running folded away,
  under a line giving the tick, the run time and the active step (``step 2/5:
  clamp front``);
- on anything else (a pipe, a log file), one line is written whenever the
  running path changes, so the output stays short and greppable.

``pirate-bt run --quiet`` simply does not attach it. Log output per subsystem
is separate and goes through ``logging`` (``--log link=debug``).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import TextIO

import py_trees

from pirate_bt.clock import Clock
from pirate_bt.trace.records import STATUS_CODE
from pirate_bt.trace.structure import TreeStructure, iter_with_ids, tree_structure
from pirate_bt.trace.text import STATUS_WORD, tree_text

__all__ = ["LiveView", "live_view_hook"]

TreeLike = py_trees.trees.BehaviourTree | py_trees.behaviour.Behaviour


class LiveView:
    """Draws a running tree to a text stream; call it after every tick.

    Args:
        tree: The tree being run (its shape must not change).
        stream: Where to draw (default: standard error).
        clock: The run's clock, for the time shown (default: ticks only).
        interval_s: Least wall time between two redraws on a terminal.
        redraw: Redraw in place (default: when ``stream`` is a terminal).
        colour: ANSI colours (default: when redrawing).
        ascii_only: Plain ASCII marks instead of Unicode.
    """

    def __init__(
        self,
        tree: TreeLike,
        stream: TextIO | None = None,
        *,
        clock: Clock | None = None,
        interval_s: float = 0.2,
        redraw: bool | None = None,
        colour: bool | None = None,
        ascii_only: bool = False,
    ) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.structure: TreeStructure = tree_structure(tree)
        self._nodes = list(iter_with_ids(tree))
        self.clock = clock
        self._start_s = clock.now() if clock is not None else 0.0
        self.interval_s = interval_s
        is_tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.redraw = is_tty if redraw is None else redraw
        self.colour = self.redraw if colour is None else colour
        self.ascii_only = ascii_only
        self._ticks = 0
        self._drawn_lines = 0
        self._last_draw = -float("inf")
        self._last_line = ""
        self._steps = self.structure.steps()
        self._off = False  # the stream refused a write: the view is gone, not the run
        step_ids = {step.id for step in self._steps}
        self._step_nodes = [(i, n) for i, n in self._nodes if i in step_ids]

    def __call__(self, tree: object = None) -> None:
        """Note one tick (the signature of a py_trees post-tick handler)."""
        self._ticks += 1
        if self._off:
            return
        if self.redraw:
            now = time.monotonic()
            if now - self._last_draw < self.interval_s and not self._finished():
                return
            self._last_draw = now
            self._draw()
        else:
            self._line()

    def _snapshot(self) -> tuple[dict[str, str], dict[str, str]]:
        status = {node_id: STATUS_CODE[node.status] for node_id, node in self._nodes}
        feedback = {node_id: node.feedback_message for node_id, node in self._nodes}
        return status, feedback

    def _finished(self) -> bool:
        return self._nodes[0][1].status in (
            py_trees.common.Status.SUCCESS,
            py_trees.common.Status.FAILURE,
        )

    def _progress(self, status: dict[str, str]) -> str:
        t = ""
        if self.clock is not None:
            t = f"  t={self.clock.now() - self._start_s:.2f} s"
        head = f"tick {self._ticks}{t}"
        for index, step in enumerate(self._steps, start=1):
            if status.get(step.id) == "R":
                return f"{head}  step {index}/{len(self._steps)}: {step.name}"
        return f"{head}  {STATUS_WORD[status[self.structure.root.id]]}"

    def _draw(self) -> None:
        status, feedback = self._snapshot()
        lines = [self._progress(status)]
        lines += tree_text(
            self.structure,
            status,
            feedback,
            ascii_only=self.ascii_only,
            colour=self.colour,
            collapse=True,
        )
        out = []
        if self._drawn_lines:
            out.append(f"\x1b[{self._drawn_lines}F\x1b[J")
        out.append("\n".join(lines) + "\n")
        self._write("".join(out))
        self._drawn_lines = len(lines)

    def _line(self) -> None:
        # Runs every tick: follow the running path down from the root (the first
        # RUNNING child at each level) instead of reading every node.
        node = self._nodes[0][1]
        running = py_trees.common.Status.RUNNING
        if node.status is running:
            chain = [node.name]
            while True:
                child = next((c for c in node.children if c.status is running), None)
                if child is None:
                    break
                node = child
                chain.append(node.name)
            message = node.feedback_message
            key = " > ".join(chain)
            text = key + (f" -- {message}" if message else "")
        else:
            text = key = f"{node.name}: {STATUS_WORD[STATUS_CODE[node.status]]}"
        if key != self._last_line:
            self._last_line = key
            status = {node_id: STATUS_CODE[n.status] for node_id, n in self._step_nodes}
            status[self.structure.root.id] = STATUS_CODE[self._nodes[0][1].status]
            self._write(f"[{self._progress(status)}] {text}\n")

    def _write(self, text: str) -> None:
        """Write and flush; a stream that refuses (a full log disk, a closed terminal)
        switches the view off, as Python's logging drops a record it cannot write: a
        run that would succeed is not ended by its view (before 2026-11-30 it was)."""
        try:
            self.stream.write(text)
            self.stream.flush()
        except (OSError, ValueError):  # ValueError: a file closed under the view
            self._off = True


def _nothing(_tree: object = None) -> None:
    return None


def live_view_hook(
    tree: TreeLike,
    stream: TextIO | None = None,
    *,
    quiet: bool = False,
    clock: Clock | None = None,
    interval_s: float = 0.2,
    redraw: bool | None = None,
    ascii_only: bool = False,
) -> Callable[[object], None]:
    """A post-tick handler that shows ``tree`` live (a no-op when ``quiet``).

    Works as ``BehaviourTree.add_post_tick_handler(hook)`` and as a runner
    post-tick hook; the argument it is called with is ignored.

    Args:
        tree: The tree being run.
        stream: Where to draw (default: standard error).
        quiet: Return a handler that does nothing (``--quiet``).
        clock: The run's clock, for the time shown.
        interval_s: Least wall time between redraws on a terminal.
        redraw: Force in-place redraw on or off (default: if a terminal).
        ascii_only: Plain ASCII marks.
    """
    if quiet:
        return _nothing
    return LiveView(
        tree,
        stream,
        clock=clock,
        interval_s=interval_s,
        redraw=redraw,
        ascii_only=ascii_only,
    )
