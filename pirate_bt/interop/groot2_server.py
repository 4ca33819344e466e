"""A run live in Groot2: BehaviorTree.CPP's ``Groot2Publisher``, in Python, for any tree.

``pirate-bt run|mission|teleop --tree ... --groot2 [HOST:]PORT`` (the API's
``groot2=`` option, or :func:`attach_groot2` for a runner of your own) starts a
:class:`Groot2Server`: ZeroMQ REP on PORT (1667 by default, on 127.0.0.1) and
PUB on PORT + 1, speaking protocol 2 of BT.CPP 4.10
(:mod:`pirate_bt.interop.groot2_protocol`). In Groot2, "Connect" to the host
with those two ports: it loads the tree (with its subtrees, see
:mod:`pirate_bt.interop.groot2_tree`), polls the statuses, reads the
blackboards, records transitions, and sets breakpoints.

**Off the tick path.** The server has its own thread. The tick thread only
copies the nodes whose status changed into a 3-byte-per-node buffer, from the
same per-tick reading that counts coverage
(:class:`~pirate_bt.trace.coverage.CoverageRecorder`: statuses as BT.CPP would
show them), and, while Groot2 records, appends the tick's transitions to a
bounded buffer (1,000, as BT.CPP). Requests are answered from those buffers
under a short lock; a reply that fails is logged and never reaches the tick.
Requests larger than 1 MiB are dropped by ZeroMQ before they are read.

**Hooks meet the protective layer.** A hook is installed on its node before the
next tick (never from the server's thread). A *breakpoint* holds the tick
thread at its node as BT.CPP's does, but never the supervisor: the drives are
stopped at once (clamps and joints hold, as when an operator takes over), and
while the tree waits the runner's pre-tick hooks run every period: the
supervisor's tick (operator input and e-stops applied, link polled, bridge
watchdog fed, freshness checked) and an operator console's keys; on a
simulator simulated time moves on. A hook that *replaces* a node's result (mode 1, or unlocking a
breakpoint with SUCCESS or FAILURE) is allowed on the simulator only; against a
robot it is refused with an error reply that says so. A replaced node that was
RUNNING is halted first (its motion cancelled).

**Heartbeat.** Every request is a heartbeat. When the client falls silent for
5 s, every hook is removed (BT.CPP 4.10 only disables them) and a tree held at
a breakpoint goes on; against a robot it does not go on unattended: the
supervisor puts the robot in its safe state and the held node fails, so the
run ends there.
"""

from __future__ import annotations

import collections
import contextlib
import errno
import logging
import threading
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import py_trees
from py_trees.common import Status

from pirate_bt.errors import ConfigurationError, InputError
from pirate_bt.interop.groot2_option import DEFAULT_HOST, parse_groot2_address
from pirate_bt.interop.groot2_protocol import (
    DEFAULT_PORT,
    ERROR,
    IDLE_FROM,
    NOT_FOUND,
    NOT_RECOGNIZED,
    TWO_PARTS,
    WRONG_HEADER,
    Hook,
    HookError,
    RequestType,
    hooks_json,
    new_tree_uuid,
    pack_request,
    pack_transitions,
    parse_hooks,
    parse_remove,
    parse_unlock,
    reply_header,
    unpack_request,
)
from pirate_bt.interop.groot2_tree import ServedTree, served_tree
from pirate_bt.trace.coverage import CoverageRecorder, attach_coverage
from pirate_bt.trace.structure import iter_with_ids, jsonable

__all__ = [
    "DEFAULT_HOST",
    "DEFAULT_PORT",
    "Groot2Server",
    "attach_groot2",
    "parse_groot2_address",
]

logger = logging.getLogger(__name__)

INSTALL_HINT = "pip install 'pirate-bt[groot2]'"
MAX_REQUEST_BYTES = 1 << 20
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


class Groot2Server:
    """Groot2's live view of a running tree (see the module docstring).

    Args:
        host: Interface to listen on (``0.0.0.0`` for every one: see the docs on what
            that exposes).
        port: The REP port; PUB is ``port + 1``. 0 picks two free neighbouring ports.
        heartbeat_s: Silence after which every hook is removed (BT.CPP: 5 s).

    Raises:
        ConfigurationError: ``pyzmq`` or ``msgpack`` is missing (the ``groot2`` extra).
        InputError: a port is taken or the host cannot be listened on.
    """

    def __init__(
        self, host: str = DEFAULT_HOST, port: int = DEFAULT_PORT, *, heartbeat_s: float = 5.0
    ) -> None:
        zmq, self._msgpack = _load()
        self._zmq = zmq
        self.host = host
        self.heartbeat_s = heartbeat_s
        self._context = zmq.Context()
        self._rep = self._context.socket(zmq.REP)
        self._pub = self._context.socket(zmq.PUB)
        for sock in (self._rep, self._pub):
            sock.setsockopt(zmq.LINGER, 0)
            sock.setsockopt(zmq.SNDTIMEO, 1000)
        self._rep.setsockopt(zmq.MAXMSGSIZE, MAX_REQUEST_BYTES)
        try:
            self.port = self._bind(host, port)
        except BaseException:
            self._context.destroy(linger=0)
            raise
        self._cond = threading.Condition()
        self._run: _Run | None = None
        self._pending: _Pending | None = None
        self._status = bytearray()
        self._hooks: dict[tuple[int, int], Hook] = {}
        self._generation = 0
        self._applied = 0
        self._held: Hook | None = None
        self._silent = False
        self._recording = False
        self._record_t0_ns = 0
        self._transitions: collections.deque[tuple[int, int, int]] = collections.deque(
            maxlen=TRANSITIONS_KEPT
        )
        self._notices: collections.deque[list[bytes]] = collections.deque()
        self._last_request = time.monotonic()
        self._heard = False
        self.requests = 0
        """Requests answered so far."""
        self.cpu_s = 0.0
        """CPU time the server's thread has used so far (seconds)."""
        self.last_info: object = None
        """What the runner last handed :meth:`apply_hooks` (its ``TickInfo``)."""
        self.enabled = True
        """False once the server failed (the run goes on without it)."""
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="pirate-groot2", daemon=True)
        self._thread.start()
        logger.info("Groot2 server on %s, ports %d and %d", host, self.port, self.port + 1)

    # -- sockets

    def _bind(self, host: str, port: int) -> int:
        zmq = self._zmq
        where = f"[{host}]" if ":" in host else host
        if port == 0:
            for _ in range(64):
                try:
                    first = self._rep.bind_to_random_port(f"tcp://{where}", 20000, 60000)
                except zmq.ZMQError as exc:
                    raise InputError(f"--groot2 {host}: cannot listen: {exc}") from None
                try:
                    self._pub.bind(f"tcp://{where}:{first + 1}")
                    return int(first)
                except zmq.ZMQError:
                    self._rep.unbind(f"tcp://{where}:{first}")
            raise InputError(f"--groot2 {host}: found no two free neighbouring ports")
        if not 0 < port < 65535:
            raise InputError(f"--groot2 {host}:{port}: the port must be from 1 to 65534")
        for sock, number in ((self._rep, port), (self._pub, port + 1)):
            try:
                sock.bind(f"tcp://{where}:{number}")
            except zmq.ZMQError as exc:
                if exc.errno == errno.EADDRINUSE:
                    raise InputError(
                        f"--groot2 {host}:{port}: port {number} is taken (another server, or"
                        " another run with --groot2?); pick another with --groot2 HOST:PORT"
                    ) from None
                raise InputError(f"--groot2 {host}:{port}: cannot listen: {exc}") from None
        return port

    @property
    def address(self) -> str:
        """``HOST:PORT`` (the PUB port is the next one)."""
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"{host}:{self.port}"

    # -- the served tree (called from the tick thread)

    def serve(
        self,
        tree: py_trees.trees.BehaviourTree,
        *,
        source: Any = None,
        name: str | None = None,
        checked: Any = None,
        recorder: CoverageRecorder | None = None,
        period_s: float = 0.05,
        clock: Any = None,
        supervisor: Any = None,
        robot: str | None = None,
        keep_alive: Callable[[], None] | None = None,
    ) -> None:
        """Serve ``tree`` from now on (a new tree UUID: Groot2 loads it again).

        Most callers want :func:`attach_groot2`. What Groot2 sees is made when a
        client first asks (in the server's thread: nothing is spent on a run nobody
        watches); the statuses follow ``recorder``; hooks are installed before each
        tick by :meth:`apply_hooks`.

        Args:
            tree: The running tree.
            source: What it was loaded from (a tree file or mapping), to show subtrees.
            name: Its name.
            checked: Its ``LoadedTree``, if there is one (spares loading it again).
            recorder: Its coverage recorder (the statuses as BT.CPP shows them).
            period_s: The tick period (how often a held breakpoint ticks the supervisor).
            clock: The run's clock.
            supervisor: The run's supervisor (``None``: a tree with no robot).
            robot: Where the run is, when that is a robot and not a simulator.
            keep_alive: Called every ``period_s`` while a breakpoint holds the tree
                (the runner's pre-tick hooks: the supervisor's tick).
        """
        pending = _Pending(
            tree, source, name, checked, recorder, period_s, clock, supervisor, robot, keep_alive
        )
        with self._cond:
            self._detach_locked()
            self._run = None
            self._pending = pending
            self._status = bytearray()
            self._transitions.clear()
        if recorder is not None:
            recorder.add_listener(self._on_tick)

    def served(self) -> ServedTree | None:
        """What is served (the XML, the UIDs), made now if no client asked yet;
        ``None`` before :meth:`serve`."""
        run = self._build()
        return run.served if run is not None else None

    def _build(self) -> _Run | None:
        """The served tree's run, made on the first request (outside the lock: the
        tick thread never waits for it)."""
        with self._cond:
            if self._run is not None or self._pending is None:
                return self._run
            pending = self._pending
        served = served_tree(pending.tree, pending.source, pending.name, pending.checked)
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

    def _on_tick(self, codes: Mapping[int, int], events: Sequence[tuple[int, int]]) -> None:
        """The coverage recorder's listener: runs in the tick thread after each tick."""
        run = self._run
        if run is None or not self.enabled or not (codes or run.midtick or self._recording):
            return  # a tick that changed no status, and nobody records transitions
        try:
            with self._cond:
                status = self._status
                if run.midtick and run.recorder is not None:
                    shown = run.recorder.shown
                    for index in run.midtick:
                        self._set_codes(run, status, index, shown[index])
                    run.midtick.clear()
                for index, code in codes.items():
                    self._set_codes(run, status, index, code)
                if self._recording and events:
                    now_us = (time.perf_counter_ns() - self._record_t0_ns) // 1000
                    add = self._transitions.append
                    inner = run.served.inner
                    idle = run.inner_idle
                    for index, value in events:
                        for uid in run.served.uids_of.get(index, ()):
                            if uid not in inner:
                                add((now_us, uid, value))
                            elif value or not idle.get(uid, True):
                                # a subtree's root: reset by its SubTree node when it
                                # finishes, so it is idle already when the call is reset
                                add((now_us, uid, value))
                                idle[uid] = value == 0
                                if value in (2, 3):
                                    add((now_us, uid, 0))
                                    idle[uid] = True
        except Exception:
            self.enabled = False
            logger.exception("Groot2: updating the statuses failed; the live view is off")

    def finish(self) -> None:
        """The run ended: remove every hook (a held breakpoint goes on). The last
        statuses stay served until :meth:`close` or the next :meth:`serve`."""
        with self._cond:
            self._remove_all_locked()
            run, pending = self._run, self._pending
        if run is not None:
            self._uninstall(run, set(run.installed))
        recorder = run.recorder if run is not None else pending.recorder if pending else None
        if recorder is not None:
            recorder.remove_listener(self._on_tick)

    def _detach_locked(self) -> None:
        self._remove_all_locked()
        self._held = None
        self._silent = False

    # -- hooks on the tick thread

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
                self._show_midtick(run, node)
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

    def _show_midtick(self, run: _Run, node: py_trees.behaviour.Behaviour) -> None:
        """Show the tree as BT.CPP would while it waits at ``node`` in the middle of a
        tick: the node's ancestors RUNNING (BT.CPP's composites and decorators turn
        RUNNING before they tick a child), the nodes already ticked with their result.
        The tick's end shows them as it left them."""
        recorder = run.recorder
        if recorder is None:
            return
        index = recorder.index_of(node)
        if index is None:
            return
        status = self._status
        for done in recorder.ticked_so_far():
            code = {Status.RUNNING: 1, Status.SUCCESS: 2, Status.FAILURE: 3}.get(done.status)
            where = recorder.index_of(done)
            if code is not None and where is not None:
                self._set_codes(run, status, where, code)
                run.midtick.add(where)
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

    # -- the server thread

    def _serve(self) -> None:
        zmq = self._zmq
        poller = zmq.Poller()
        poller.register(self._rep, zmq.POLLIN)
        while not self._stop.is_set():
            self.cpu_s = time.thread_time()
            try:
                ready = dict(poller.poll(50))
                self._publish()
                self._heartbeat()
                if self._rep not in ready:
                    continue
                try:
                    parts = self._rep.recv_multipart(zmq.NOBLOCK)
                except zmq.Again:
                    continue
                reply = self._answer(parts)
                try:
                    self._rep.send_multipart(reply)
                except zmq.ZMQError as exc:
                    logger.warning("Groot2: could not send a reply: %s", exc)
            except Exception:
                if self._stop.is_set():
                    return
                logger.exception("Groot2: the server loop failed; it goes on")
                time.sleep(0.05)

    def _publish(self) -> None:
        while self._notices:
            message = self._notices.popleft()
            # nobody subscribed, or too slow: a notice is a courtesy
            with contextlib.suppress(self._zmq.ZMQError):
                self._pub.send_multipart(message, self._zmq.NOBLOCK)

    def _heartbeat(self) -> None:
        if not self._heard or time.monotonic() - self._last_request < self.heartbeat_s:
            return
        with self._cond:
            if not self._hooks and self._held is None:
                return
            logger.warning(
                "Groot2: the client fell silent for %g s; every hook removed", self.heartbeat_s
            )
            self._remove_all_locked()
            if self._held is not None:
                self._silent = True
            self._cond.notify_all()

    def _answer(self, parts: list[bytes]) -> list[bytes]:
        self._last_request = time.monotonic()
        self._heard = True
        self.requests += 1
        header = unpack_request(parts[0]) if parts else None
        if header is None:
            return _error(WRONG_HEADER)
        try:
            run = self._build()
        except Exception as exc:  # a tree that cannot be shown must not stop the server
            logger.exception("Groot2: cannot serve this tree")
            return _error(f"cannot serve this tree: {exc}")
        if run is None:
            return _error("no tree is running yet")
        reply = [reply_header(header, run.uuid)]
        kind = header.type
        try:
            if kind == RequestType.FULLTREE:
                reply.append(run.served.xml.encode("utf-8"))
            elif kind == RequestType.STATUS:
                with self._cond:
                    reply.append(bytes(self._status))
            elif kind in _TWO_PART:
                if len(parts) != 2:
                    return _error(TWO_PARTS)
                more = _TWO_PART[kind](self, run, parts[1])
                if isinstance(more, str):
                    return _error(more)
                reply += more
            elif kind == RequestType.HOOKS_DUMP:
                with self._cond:
                    reply.append(hooks_json(list(self._hooks.values())))
            elif kind == RequestType.REMOVE_ALL_HOOKS:
                with self._cond:
                    self._remove_all_locked()
            elif kind == RequestType.DISABLE_ALL_HOOKS:
                with self._cond:
                    for hook in self._hooks.values():
                        hook.enabled = False
                    self._cond.notify_all()
            elif kind == RequestType.GET_TRANSITIONS:
                with self._cond:
                    taken = list(self._transitions)
                    self._transitions.clear()
                reply.append(pack_transitions(taken))
            else:
                return _error(NOT_RECOGNIZED)
        except HookError as exc:
            return _error(str(exc))
        except Exception as exc:  # never let a request take the server down
            logger.exception("Groot2: answering a request failed")
            return _error(f"Unknown error while processing request: {exc}")
        return reply

    def _blackboard(self, run: _Run, names: bytes) -> list[bytes]:
        wanted = names.decode("utf-8", "replace").split(";")
        dump: dict[str, Any] = {}
        for name in wanted:
            if name == "":  # the main tree's instance: the live blackboard
                dump[name] = _live_blackboard()
            elif name in run.served.subtrees:
                dump[name] = dict(run.served.subtrees[name])
        packed: bytes = self._msgpack.packb(jsonable(dump) if dump else None, use_bin_type=True)
        return [packed]

    def _insert(self, run: _Run, text: bytes) -> list[bytes] | str:
        hooks = parse_hooks(text)
        if run.robot is not None and any(h.mode == REPLACE for h in hooks):
            return _refusal(run)
        with self._cond:
            for hook in hooks:
                key = (hook.position, hook.uid)
                current = self._hooks.get(key)
                if current is not None:
                    was_breakpoint = current.mode == BREAKPOINT
                    current.update(hook)
                    if was_breakpoint and current.mode == REPLACE:
                        current.ready = True
                        self._cond.notify_all()
                elif hook.uid in run.served.node_of:  # BT.CPP ignores an unknown node
                    self._hooks[key] = hook
            self._generation += 1
        return []

    def _remove(self, run: _Run, text: bytes) -> list[bytes] | str:
        uid, position = parse_remove(text)
        with self._cond:
            if uid not in run.served.node_of or (position, uid) not in self._hooks:
                return NOT_FOUND
            self._remove_locked(position, uid)
        return []

    def _unlock(self, run: _Run, text: bytes) -> list[bytes] | str:
        uid, position, status, remove = parse_unlock(text)
        with self._cond:
            hook = self._hooks.get((position, uid))
            if uid not in run.served.node_of or hook is None:
                return NOT_FOUND
            if run.robot is not None and status in _REPLACED:
                return _refusal(run)
            hook.desired_status = status
            hook.once = hook.once or remove
            if hook.mode == BREAKPOINT:
                hook.ready = True
                self._cond.notify_all()
        return []

    def _record(self, run: _Run, command: bytes) -> list[bytes]:
        if command == b"start":
            with self._cond:
                self._record_t0_ns = time.perf_counter_ns()
                self._transitions.clear()
                self._recording = True
            return [str(time.time_ns() // 1000).encode()]
        if command == b"stop":
            with self._cond:
                self._recording = False
        return []

    def _remove_locked(self, position: int, uid: int) -> None:
        hook = self._hooks.pop((position, uid), None)
        if hook is not None:
            hook.enabled = False
            self._generation += 1
            self._cond.notify_all()

    def _remove_all_locked(self) -> None:
        for position, uid in list(self._hooks):
            self._remove_locked(position, uid)

    # -- the end

    def close(self) -> None:
        """Stop the server (idempotent); a held breakpoint goes on."""
        if self._stop.is_set():
            return
        with self._cond:
            self._remove_all_locked()
        self._stop.set()
        self._thread.join(timeout=2.0)
        self._context.destroy(linger=0)

    def __enter__(self) -> Groot2Server:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


_TWO_PART: dict[int, Callable[[Groot2Server, _Run, bytes], Any]] = {
    RequestType.BLACKBOARD: Groot2Server._blackboard,
    RequestType.HOOK_INSERT: Groot2Server._insert,
    RequestType.HOOK_REMOVE: Groot2Server._remove,
    RequestType.BREAKPOINT_UNLOCK: Groot2Server._unlock,
    RequestType.TOGGLE_RECORDING: Groot2Server._record,
}


def _error(message: str) -> list[bytes]:
    return [ERROR, message.encode("utf-8")]


def _refusal(run: _Run) -> str:
    return (
        f"refused: replacing a node's result is allowed on the simulator only, and this"
        f" run is on a robot ({run.robot}); unlock with another status to let the node run"
    )


def _live_blackboard() -> dict[str, Any]:
    """The py_trees blackboard, keys without their leading ``/``."""
    storage = dict(py_trees.blackboard.Blackboard.storage)
    return {key.lstrip("/"): value for key, value in storage.items()}


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


def attach_groot2(
    runner: Any,
    server: Groot2Server,
    *,
    supervisor: Any = None,
    robot: str | None = None,
    source: Any = None,
    name: str | None = None,
) -> None:
    """Serve ``runner``'s tree on ``server`` while it runs (any tree, any runner).

    The statuses come from the runner's coverage recorder
    (:func:`~pirate_bt.trace.coverage.attach_coverage`, added if it has none);
    hooks are installed before each tick; at the end every hook is removed and
    the last statuses stay served.

    Args:
        runner: A :class:`pirate_bt.runner.Runner` (not yet run).
        server: The server.
        supervisor: The run's supervisor: the one that stops the drives at a
            breakpoint and, against a robot, takes the robot to its safe state when
            the client falls silent there (``None``: a tree with no robot). While a
            breakpoint holds the tree, the runner's pre-tick hooks keep running every
            period (in every runner pirate_bt wires, they tick the supervisor).
        robot: Where the run is when that is a real robot (``"robot at
            /dev/ttyACM0"``): replacing results is then refused, and a silent
            client at a breakpoint ends the run in the safe state. ``None``: the
            simulator, or no robot.
        source: What the tree was loaded from (default: the runner's
            ``LoadedTree.source``), to show its subtrees.
        name: The tree's name.

    What Groot2 sees is made when a client first asks (``server.served()`` makes
    it at once: the XML, the UIDs).

    Example::

        with Groot2Server(port=1667) as server:
            runner = connection.runner("bend", params={"roll": "90 deg"})
            attach_groot2(runner, server, supervisor=connection.supervisor)
            runner.run()
    """
    loaded = getattr(runner, "_loaded", None)
    if source is None and loaded is not None:
        source = getattr(loaded, "source", None)
    if name is None and loaded is not None:
        name = getattr(loaded, "name", None)
    recorder = attach_coverage(runner, name)

    def keep_alive() -> None:  # the runner's pre-tick hooks, but for ours
        for hook in list(runner.pre_tick):
            if hook != server.apply_hooks:
                hook(server.last_info)

    server.serve(
        runner.tree,
        source=source,
        name=name,
        checked=loaded if source is getattr(loaded, "source", None) else None,
        recorder=recorder,
        period_s=runner.period_s,
        clock=runner.clock,
        supervisor=supervisor,
        robot=robot,
        keep_alive=keep_alive,
    )
    runner.add_pre_tick(server.apply_hooks)
    runner.add_finish(lambda _result: server.finish())
