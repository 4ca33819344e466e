"""What a Groot2 server holds between requests and ticks: the served run.

A :class:`~pirate_bt.interop.groot2_server.Groot2Server` serves one tree at a
time: :class:`_Pending` until a client first asks for it, then the :class:`_Run`
made from it (the XML and UIDs Groot2 sees, the status buffer's offsets, the
nodes' parents). :class:`_ServerState` is the state the server's parts share
(declared for the type checker) and the building of the run; the hooks
(:mod:`pirate_bt.interop.groot2_hooks`) and the requests
(:mod:`pirate_bt.interop.groot2_requests`) stand on it.
"""

from __future__ import annotations

import collections
import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import py_trees
from py_trees.common import Status

from pirate_bt.errors import ConfigurationError, InputError
from pirate_bt.interop.groot2_protocol import IDLE_FROM, Hook, new_tree_uuid
from pirate_bt.interop.groot2_tree import ServedTree, served_tree
from pirate_bt.trace.coverage import CoverageRecorder
from pirate_bt.trace.structure import iter_with_ids

__all__ = [
    "INSTALL_HINT",
    "MAX_REQUEST_BYTES",
    "MAX_SUBSCRIPTION_BYTES",
    "REPLIES_QUEUED",
    "REQUESTS_QUEUED",
    "REST_MAX_S",
    "REST_PER_CPU",
    "TRANSITIONS_KEPT",
    "Unservable",
]

# The server's parts log as the server always did.
logger = logging.getLogger("pirate_bt.interop.groot2_server")

INSTALL_HINT = "pip install 'pirate-bt[groot2]'"
MAX_REQUEST_BYTES = 1 << 20
MAX_SUBSCRIPTION_BYTES = 1 << 10
"""The largest subscription the PUB socket takes (Groot2 subscribes to every notice: one
byte; ZeroMQ 3.1's SUBSCRIBE command adds ten); a peer sending a larger one is
disconnected by ZeroMQ."""
REPLIES_QUEUED = 4
"""Replies ZeroMQ holds for one client that does not read them (more are dropped).
Groot2 (a REQ socket) waits for each reply before it asks again; a client that
asked for the tree thousands of times and never read made ZeroMQ's default (1,000
a client) hold 1,000 copies of the tree's XML per connection in the run's process."""
REQUESTS_QUEUED = 4
"""Requests ZeroMQ reads ahead for one client before the server takes them (more wait in
the client's TCP connection). Groot2 sends one and waits for its reply."""
REST_PER_CPU = 4
"""After each request the server's thread rests this many times the CPU time the request
took: at most a fifth of the interpreter, whatever a client sends."""
REST_MAX_S = 0.1
"""The longest rest after one request (a large tree's XML, made at the first request)."""
TRANSITIONS_KEPT = 1000
PRE, POST = 0, 1
BREAKPOINT, REPLACE = 0, 1
_REPLACED = {"SUCCESS": Status.SUCCESS, "FAILURE": Status.FAILURE}


def _load() -> tuple[Any, Any]:
    try:
        import msgpack
        import zmq
    except ImportError as exc:
        raise ConfigurationError(
            f"--groot2 needs {exc.name or 'pyzmq and msgpack'}: {INSTALL_HINT}"
        ) from None
    return zmq, msgpack


@dataclass
class _Pending:
    """A tree to serve, until a client first asks for it."""

    tree: py_trees.trees.BehaviourTree
    source: Any
    name: str | None
    checked: Any
    recorder: CoverageRecorder | None
    period_s: float
    clock: Any
    supervisor: Any
    robot: str | None
    keep_alive: Callable[[], None] | None
    failure: str | None = None
    """Why it cannot be served, once that is known (said again, not found again)."""


class Unservable(InputError):
    """The served tree cannot be shown to Groot2 (the error reply's text)."""


@dataclass
class _Run:
    """The tree being served and what its hooks need."""

    served: ServedTree
    uuid: bytes
    offset: dict[int, int]
    """UID -> index of its status byte."""
    nodes: list[py_trees.behaviour.Behaviour]
    period_s: float
    clock: Any
    supervisor: Any = None
    robot: str | None = None
    """Where the run is, when that is a robot (replacing results is refused there)."""
    recorder: CoverageRecorder | None = None
    keep_alive: Callable[[], None] | None = None
    """What runs every period while a breakpoint holds the tree."""
    installed: dict[int, Any] = field(default_factory=dict)
    """py_trees node index -> what its instance ``tick`` was before the hook (or None)."""
    parents: list[int] = field(default_factory=list)
    """py_trees node index -> its parent's (-1 for the root)."""
    midtick: set[int] = field(default_factory=set)
    """Nodes shown as they were in the middle of a tick (at a breakpoint)."""
    inner_idle: dict[int, bool] = field(default_factory=dict)
    """Subtree roots' UIDs -> whether BT.CPP has them IDLE (for the transitions)."""


class _ServerState:
    """What the server's parts share (set in ``Groot2Server.__init__``), and the run."""

    heartbeat_s: float
    requests: int
    last_info: object
    enabled: bool
    _msgpack: Any
    _cond: threading.Condition
    _run: _Run | None
    _pending: _Pending | None
    _status: bytearray
    _hooks: dict[tuple[int, int], Hook]
    _generation: int
    _applied: int
    _held: Hook | None
    _silent: bool
    _recording: bool
    _record_t0_ns: int
    _transitions: collections.deque[tuple[int, int, int]]
    _notices: collections.deque[list[bytes]]
    _last_request: float
    _heard: bool

    def _build(self) -> _Run | None:
        """The served tree's run, made on the first request (outside the lock: the
        tick thread never waits for it)."""
        with self._cond:
            if self._run is not None or self._pending is None:
                return self._run
            pending = self._pending
        if pending.failure is not None:
            raise Unservable(pending.failure)
        try:
            served = served_tree(pending.tree, pending.source, pending.name, pending.checked)
        except Exception as exc:  # a tree that cannot be shown must not stop the server
            # Once per tree: every request (Groot2 polls ten times a second) made it
            # again, 0.4 s of the server's thread and a traceback in the log each time.
            logger.exception("Groot2: cannot serve this tree")
            pending.failure = f"cannot serve this tree: {exc}"
            raise Unservable(pending.failure) from None
        nodes = [node for _, node in iter_with_ids(pending.tree)]
        run = _Run(
            served=served,
            uuid=new_tree_uuid(),
            offset={uid: 3 * i + 2 for i, uid in enumerate(served.order)},
            nodes=nodes,
            period_s=pending.period_s,
            clock=pending.clock,
            supervisor=pending.supervisor,
            robot=pending.robot,
            recorder=pending.recorder,
            keep_alive=pending.keep_alive,
        )
        index_of = {id(node): i for i, node in enumerate(nodes)}
        run.parents = [-1] * len(nodes)
        for i, node in enumerate(nodes):
            for child in node.children:
                run.parents[index_of[id(child)]] = i
        status = bytearray(3 * len(served.order))
        for i, uid in enumerate(served.order):
            status[3 * i : 3 * i + 2] = uid.to_bytes(2, "little")
        with self._cond:
            if self._pending is not pending:  # another tree since: serve that one
                return self._run
            if run.recorder is not None:  # under the lock: the listener waits for us
                for index, code in enumerate(list(run.recorder.shown)):
                    if code:
                        self._set_codes(run, status, index, code)
            self._run, self._pending, self._status = run, None, status
        return run

    def _set_codes(self, run: _Run, status: bytearray, index: int, code: int) -> None:
        inner = run.served.inner
        for uid in run.served.uids_of.get(index, ()):
            shown = code
            if uid in inner and code in (2, 3):
                shown = IDLE_FROM + code  # the SubTree node resets its child when it finishes
            status[run.offset[uid]] = shown
