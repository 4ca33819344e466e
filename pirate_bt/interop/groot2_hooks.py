"""Groot2's hooks on the tick thread: breakpoints and replaced results.

The hooks Groot2 sets (``HOOK_INSERT``) are installed on their nodes before the
next tick by :meth:`_Hooks.apply_hooks` (a runner's pre-tick hook), never from
the server's thread. A breakpoint holds the tick thread at its node while the
runner's housekeeping goes on (:meth:`_Hooks._hold`); a replaced result is given
without running the node (:func:`_replace`). See
:mod:`pirate_bt.interop.groot2_server` for how they meet the protective layer.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from typing import Any

import py_trees
from py_trees.common import Status

from pirate_bt.interop.groot2_protocol import IDLE_FROM, Hook, RequestType, pack_request
from pirate_bt.interop.groot2_run import (
    _REPLACED,
    BREAKPOINT,
    POST,
    PRE,
    _Run,
    _ServerState,
    logger,
)

__all__: list[str] = []  # parts of Groot2Server (groot2_server.py re-exports what is public)


class _Hooks(_ServerState):
    """The hook half of :class:`~pirate_bt.interop.groot2_server.Groot2Server`."""

    def apply_hooks(self, info: object = None) -> None:
        """Install and remove hook wrappers to match the hooks set (a pre-tick hook)."""
        self.last_info = info
        run = self._run
        if run is None or self._generation == self._applied:
            return  # the common tick: no hook changed since the last (no lock taken)
        with self._cond:
            self._applied = self._generation
            wanted = {run.served.node_of[uid] for (_, uid) in self._hooks}
        current = set(run.installed)
        if wanted == current:
            return
        self._uninstall(run, current - wanted)
        for index in wanted - current:
            node = run.nodes[index]
            run.installed[index] = node.__dict__.get("tick")
            original = type(node).tick.__get__(node)
            node.tick = self._hooked(run, index, node, original)  # type: ignore[method-assign]

    def _uninstall(self, run: _Run, indices: set[int]) -> None:
        for index in indices:
            node = run.nodes[index]
            before = run.installed.pop(index, None)
            if before is None:
                node.__dict__.pop("tick", None)
            else:
                node.tick = before  # type: ignore[method-assign]

    def _hooked(
        self,
        run: _Run,
        index: int,
        node: py_trees.behaviour.Behaviour,
        original: Callable[[], Iterator[py_trees.behaviour.Behaviour]],
    ) -> Callable[[], Iterator[py_trees.behaviour.Behaviour]]:
        uids = run.served.uids_of.get(index, ())

        def tick() -> Iterator[py_trees.behaviour.Behaviour]:
            replaced = self._fire(run, uids, PRE, node)
            if replaced is not None:
                _replace(node, replaced)
                yield node
                return
            done = False
            for n in original():
                if n is node and not done:
                    done = True
                    replaced = self._fire(run, uids, POST, node)
                    if replaced is not None:
                        _replace(node, replaced)
                yield n

        return tick

    def _fire(
        self, run: _Run, uids: Sequence[int], position: int, node: py_trees.behaviour.Behaviour
    ) -> Status | None:
        """Run the hook at ``position`` of a node's UIDs: the result that replaces the
        node's, or ``None`` to let it run."""
        with self._cond:
            hook = next(
                (
                    h
                    for uid in uids
                    if (h := self._hooks.get((position, uid))) is not None and h.enabled
                ),
                None,
            )
            if hook is None:
                return None
            self._notices.append([pack_request(RequestType.BREAKPOINT_REACHED), b"%d" % hook.uid])
            if hook.mode == BREAKPOINT:
                self._held = hook
                self._show_midtick(run, node, hook.uid)
        if hook.mode == BREAKPOINT:
            outcome = self._hold(run, hook, node)
            if outcome is not None:
                return outcome
        with self._cond:
            if not hook.enabled:
                return None
            status = _REPLACED.get(hook.desired_status)
            if hook.once:
                self._remove_locked(hook.position, hook.uid)
            if status is not None and run.robot is not None:
                return None  # refused when set; never against a robot
            return status

    def _show_midtick(self, run: _Run, node: py_trees.behaviour.Behaviour, uid: int) -> None:
        """Show the tree as BT.CPP would while it waits at ``node`` (the hook's ``uid``)
        in the middle of a tick: the node's ancestors RUNNING (BT.CPP's composites and
        decorators turn RUNNING before they tick a child), the nodes already ticked with
        their result. The tick's end shows them as it left them.

        A node whose parent has already reset it in this tick shows "IDLE, was ..."
        (:func:`_resets_children`), one halted in this tick "IDLE, was RUNNING"; and
        a subtree's root shares its py_trees node with the ``<SubTree>`` node(s)
        calling it (lower UIDs): waiting at the root, those are its ancestors in
        BT.CPP, RUNNING. Until 2026-11-30 all three were shown as they were."""
        recorder = run.recorder
        if recorder is None:
            return
        index = recorder.index_of(node)
        if index is None:
            return
        status = self._status
        done: dict[int, int] = {}
        for ticked in recorder.ticked_so_far():
            code = _CODES.get(ticked.status)
            where = recorder.index_of(ticked)
            if code is not None and where is not None:
                done[where] = code
        reset: set[int] = set()
        for up, code in done.items():
            if _resets_children(run.nodes[up], code):
                for child in recorder.children[up]:
                    if done.get(child, recorder.shown[child]) in (2, 3):
                        reset.add(child)  # ticked now, or finished in an earlier tick
        for where in reset - done.keys():
            done[where] = recorder.shown[where]
        shown = recorder.shown
        for where, halted in enumerate(run.nodes):  # halted in this tick: "IDLE, was RUNNING"
            if shown[where] == 1 and where not in done and halted.status == Status.INVALID:
                self._set_codes(run, status, where, IDLE_FROM + 1)
                run.midtick.add(where)
        for where, code in done.items():
            self._set_codes(run, status, where, code + IDLE_FROM if where in reset else code)
            run.midtick.add(where)
        for outer in run.served.uids_of.get(index, ()):
            if outer < uid:  # a <SubTree> node above the subtree root waited at
                status[run.offset[outer]] = 1
                run.midtick.add(index)
        up = run.parents[index] if index < len(run.parents) else -1
        while up >= 0:
            self._set_codes(run, status, up, 1)
            run.midtick.add(up)
            up = run.parents[up]

    def _hold(self, run: _Run, hook: Hook, node: py_trees.behaviour.Behaviour) -> Status | None:
        """Wait at a breakpoint while the runner's housekeeping goes on. Returns FAILURE
        when the client fell silent against a robot (the fail-safe), else ``None``.

        Every period the run's ``keep_alive`` runs (the runner's pre-tick hooks: the
        supervisor's tick, an operator console's keys), and on a simulator simulated
        time moves on. What those raise (an operator quitting, a link error) ends the
        wait and reaches the runner, as from a pre-tick hook.
        """
        supervisor = run.supervisor
        logger.warning("Groot2: breakpoint at %s (%s); the tree waits", node.name, hook.uid)
        if supervisor is not None:
            _stop_drives(supervisor)
        clock = run.clock
        silent = False
        try:
            while True:
                with self._cond:
                    if hook.ready or not hook.enabled or self._silent:
                        hook.ready = False
                        silent = self._silent
                        break
                    self._cond.wait(timeout=run.period_s)
                if run.keep_alive is not None:
                    run.keep_alive()
                if clock is not None and clock.is_simulated:
                    clock.sleep(run.period_s)
        finally:
            with self._cond:
                self._held = None
                self._silent = False
        if silent and run.robot is not None:
            reason = (
                f"Groot2 client silent for {self.heartbeat_s:g} s while the tree waited at"
                f" a breakpoint ({node.name})"
            )
            if supervisor is not None:
                supervisor.safe_state(reason)
            node.feedback_message = reason
            return Status.FAILURE
        logger.warning("Groot2: the tree goes on from %s", node.name)
        return None

    def _remove_locked(self, position: int, uid: int) -> None:
        hook = self._hooks.pop((position, uid), None)
        if hook is not None:
            hook.enabled = False
            self._generation += 1
            self._cond.notify_all()

    def _remove_all_locked(self) -> None:
        for position, uid in list(self._hooks):
            self._remove_locked(position, uid)


_CODES = {Status.RUNNING: 1, Status.SUCCESS: 2, Status.FAILURE: 3}


def _resets_children(parent: py_trees.behaviour.Behaviour, code: int) -> bool:
    """Whether BT.CPP's ``parent``, whose tick ended with ``code`` in the tick in
    progress, has reset its finished children (to IDLE) by now: every parent that
    finished, a decorator as soon as its child finished, a reactive composite every
    finished child at the end of its tick (the rules of
    :class:`~pirate_bt.trace.coverage.CoverageRecorder` at the tick's end)."""
    if code != 1:
        return True
    if isinstance(parent, py_trees.composites.Composite):
        reactive = isinstance(parent, py_trees.composites.Sequence | py_trees.composites.Selector)
        return reactive and not getattr(parent, "memory", True)
    return len(parent.children) == 1  # a decorator


def _stop_drives(supervisor: Any) -> None:
    """Stop the drives as an operator takeover does (clamps and joints hold)."""
    try:
        from pirate_bt.safety import Source, Stop

        supervisor.command(Stop(), source=Source.SUPERVISOR)
    except Exception:
        logger.exception("Groot2: stopping the drives at a breakpoint failed")


def _replace(node: py_trees.behaviour.Behaviour, status: Status) -> None:
    """Give ``node`` a result without running it (halting it first if it runs)."""
    if node.status == Status.RUNNING:
        node.stop(Status.INVALID)
    node.status = status
    node.feedback_message = f"result replaced by Groot2: {status.name}"
