"""A run live in Groot2: BehaviorTree.CPP's ``Groot2Publisher``, in Python, for any tree.

``pirate-bt run|mission|teleop --tree ... --groot2 [HOST:]PORT`` (the API's
``groot2=`` option, or :func:`attach_groot2` for a runner of your own) starts a
:class:`Groot2Server`: ZeroMQ ROUTER, answering as REP does, on PORT (1667 by
default, on 127.0.0.1) and PUB on PORT + 1, speaking protocol 2 of BT.CPP 4.10
(:mod:`pirate_bt.interop.groot2_protocol`). In Groot2, "Connect" to the host
with those two ports: it loads the tree (with its subtrees, see
:mod:`pirate_bt.interop.groot2_tree`), polls the statuses, reads the
blackboards, records transitions, and sets breakpoints. The two TCP ports are a
relay process's (:mod:`pirate_bt.interop.groot2_relay`), which passes requests,
replies and notices to this process's sockets over Unix sockets: a client's
connections cost the run's process nothing.

**Off the tick path.** The server has its own thread. The tick thread only
copies the nodes whose status changed into a 3-byte-per-node buffer, from the
same per-tick reading that counts coverage
(:class:`~pirate_bt.trace.coverage.CoverageRecorder`: statuses as BT.CPP would
show them), and, while Groot2 records, appends the tick's transitions to a
bounded buffer (1,000, as BT.CPP). Requests are answered from those buffers
under a short lock; a reply that fails is logged and never reaches the tick. After
each request the thread rests four times the CPU time it took, so that no client takes
more than a fifth of the interpreter the tick runs in.
Requests larger than 1 MiB are dropped before they are read (a part over 1 MiB by
ZeroMQ, many parts adding up to more by the relay).

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

**Its parts.** The served run and the state the parts share:
:mod:`pirate_bt.interop.groot2_run`; the hooks on the tick thread:
:mod:`pirate_bt.interop.groot2_hooks`; the requests:
:mod:`pirate_bt.interop.groot2_requests`; the relay process as the server holds it:
:mod:`pirate_bt.interop.groot2_ports`. Here: the sockets, the statuses after
each tick, the server thread, and :func:`attach_groot2`.
"""

from __future__ import annotations

import collections
import contextlib
import logging
import os
import shutil
import subprocess
import tempfile
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import py_trees

from pirate_bt.errors import ConfigurationError as ConfigurationError
from pirate_bt.errors import InputError
from pirate_bt.interop.groot2_hooks import _replace as _replace
from pirate_bt.interop.groot2_hooks import _stop_drives as _stop_drives
from pirate_bt.interop.groot2_option import DEFAULT_HOST, check_server_args, parse_groot2_address
from pirate_bt.interop.groot2_ports import end_relay, relay_ended, relay_to_null, start_relay
from pirate_bt.interop.groot2_protocol import DEFAULT_PORT, Hook, routing_envelope
from pirate_bt.interop.groot2_protocol import ERROR as ERROR
from pirate_bt.interop.groot2_protocol import IDLE_FROM as IDLE_FROM
from pirate_bt.interop.groot2_protocol import NOT_FOUND as NOT_FOUND
from pirate_bt.interop.groot2_protocol import NOT_RECOGNIZED as NOT_RECOGNIZED
from pirate_bt.interop.groot2_protocol import TWO_PARTS as TWO_PARTS
from pirate_bt.interop.groot2_protocol import WRONG_HEADER as WRONG_HEADER
from pirate_bt.interop.groot2_protocol import HookError as HookError
from pirate_bt.interop.groot2_protocol import RequestType as RequestType
from pirate_bt.interop.groot2_protocol import hooks_json as hooks_json
from pirate_bt.interop.groot2_protocol import new_tree_uuid as new_tree_uuid
from pirate_bt.interop.groot2_protocol import pack_request as pack_request
from pirate_bt.interop.groot2_protocol import pack_transitions as pack_transitions
from pirate_bt.interop.groot2_protocol import parse_hooks as parse_hooks
from pirate_bt.interop.groot2_protocol import parse_remove as parse_remove
from pirate_bt.interop.groot2_protocol import parse_unlock as parse_unlock
from pirate_bt.interop.groot2_protocol import reply_header as reply_header
from pirate_bt.interop.groot2_protocol import unpack_request as unpack_request
from pirate_bt.interop.groot2_requests import _TWO_PART as _TWO_PART
from pirate_bt.interop.groot2_requests import _error as _error
from pirate_bt.interop.groot2_requests import _live_blackboard as _live_blackboard
from pirate_bt.interop.groot2_requests import _refusal as _refusal
from pirate_bt.interop.groot2_requests import _Requests
from pirate_bt.interop.groot2_run import _REPLACED as _REPLACED
from pirate_bt.interop.groot2_run import BREAKPOINT as BREAKPOINT
from pirate_bt.interop.groot2_run import INSTALL_HINT as INSTALL_HINT
from pirate_bt.interop.groot2_run import (
    MAX_REQUEST_BYTES,
    MAX_SUBSCRIPTION_BYTES,
    REPLIES_QUEUED,
    REQUESTS_QUEUED,
    REST_MAX_S,
    REST_PER_CPU,
    TRANSITIONS_KEPT,
    _load,
    _Pending,
)
from pirate_bt.interop.groot2_run import POST as POST
from pirate_bt.interop.groot2_run import PRE as PRE
from pirate_bt.interop.groot2_run import REPLACE as REPLACE
from pirate_bt.interop.groot2_run import _Run as _Run
from pirate_bt.interop.groot2_tree import ServedTree
from pirate_bt.interop.groot2_tree import served_tree as served_tree
from pirate_bt.trace.coverage import CoverageRecorder, attach_coverage
from pirate_bt.trace.sink_formats import forget_in_forks, let_go_in_forks
from pirate_bt.trace.structure import iter_with_ids as iter_with_ids
from pirate_bt.trace.structure import jsonable as jsonable

__all__ = [
    "DEFAULT_HOST",
    "DEFAULT_PORT",
    "Groot2Server",
    "attach_groot2",
    "parse_groot2_address",
]

logger = logging.getLogger(__name__)

RELAYED_REPLIES = 64
"""Replies this process holds for the relay (every client's; it reads them at once)."""
RELAY_LOOK_S = 1.0
"""How often the server's thread looks whether the relay process still runs."""
RELAY_RESTARTS = 3
"""How many times a relay that ended is started again before the server gives up."""


class Groot2Server(_Requests):
    """Groot2's live view of a running tree (see the module docstring).

    Args:
        host: Interface to listen on (``0.0.0.0`` for every one: see the docs on what
            that exposes).
        port: The server (request) port; PUB is ``port + 1``. 0 picks two free neighbouring ports.
        heartbeat_s: Silence after which every hook is removed (BT.CPP: 5 s).

    Raises:
        ConfigurationError: ``pyzmq`` or ``msgpack`` is missing (the ``groot2`` extra).
        InputError: a port is taken or the host cannot be listened on; an argument of
            the wrong kind (``ArgumentTypeError``) or a heartbeat that is not a positive,
            finite number of seconds (``ArgumentValueError``).
    """

    def __init__(
        self, host: str = DEFAULT_HOST, port: int = DEFAULT_PORT, *, heartbeat_s: float = 5.0
    ) -> None:
        zmq, self._msgpack = _load()
        check_server_args(host, port, heartbeat_s)
        self._zmq = zmq
        self.host = host
        self.heartbeat_s = heartbeat_s
        self._context = zmq.Context()
        # ROUTER, with REP's envelope handled here (routing_envelope): libzmq's REP (4.3.5) lost
        # the reply to the next request for good after a message with no envelope from a
        # peer that had gone by the time it was read (its ROUTER's rollback left the
        # reply's routing half-done); Groot2's REQ then waited for ever.
        # Both are bound to Unix sockets in a folder of the user's; the TCP ports Groot2
        # connects to are the relay process's (groot2_relay): a client's connections
        # cost this process no file descriptor and no buffer.
        self._rep = self._context.socket(zmq.ROUTER)
        self._pub = self._context.socket(zmq.PUB)
        for sock in (self._rep, self._pub):
            sock.setsockopt(zmq.LINGER, 0)
            sock.setsockopt(zmq.SNDTIMEO, 1000)
        self._rep.setsockopt(zmq.MAXMSGSIZE, MAX_REQUEST_BYTES)
        # every client's replies go through the relay: one pipe, which it reads at once
        self._rep.setsockopt(zmq.SNDHWM, RELAYED_REPLIES)
        # requests read ahead (ZeroMQ's default, 1,000 of up to 1 MiB each, let a client
        # that sent faster than they were answered make the run's process hold 1 GB); the
        # relay holds the rest in the clients' own pipes, as TCP makes them wait
        self._rep.setsockopt(zmq.RCVHWM, REQUESTS_QUEUED)
        self._relay: subprocess.Popen[bytes] | None = None
        self._copy = False  # a forked process's copy of a server (see _forked)
        self._folder = tempfile.mkdtemp(prefix="pirate-groot2-")  # 0700: the user's
        self._endpoints: tuple[str, ...] = ()
        self._relay_lock = threading.Lock()  # a restart (server thread) against close()
        self._relay_restarts = 0
        self._relay_looked = time.monotonic()
        try:
            self.port = self._bind(host, port)
        except BaseException:
            self._end_relay()
            raise
        let_go_in_forks(self)
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
        """Bind the sockets to the folder's Unix sockets, start the relay on ``host``
        and ``port`` and return the port it listens on."""
        zmq = self._zmq
        rep, pub = (f"ipc://{os.path.join(self._folder, name)}" for name in ("rep", "pub"))
        try:
            self._rep.bind(rep)
            self._pub.bind(pub)
            self._endpoints = (rep, pub)
        except zmq.ZMQError as exc:  # a temporary folder's name too long for a Unix socket
            raise ConfigurationError(
                f"--groot2: cannot make the server's sockets in {self._folder}: {exc}"
            ) from None
        sockets = {
            "rep": rep,
            "pub": pub,
            "folder": self._folder,
            "max_request_bytes": MAX_REQUEST_BYTES,
            "max_subscription_bytes": MAX_SUBSCRIPTION_BYTES,
            "replies_queued": REPLIES_QUEUED,
            "requests_queued": REQUESTS_QUEUED,
        }
        self._relay, listening = start_relay(host, port, sockets)
        return listening

    def _end_relay(self) -> None:
        """Close the sockets, end the relay process and remove the folder."""
        self._context.destroy(linger=0)
        relay, self._relay = self._relay, None
        end_relay(relay)
        shutil.rmtree(self._folder, ignore_errors=True)

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
                if time.monotonic() - self._relay_looked >= RELAY_LOOK_S:
                    self._relay_looked = time.monotonic()
                    self._look_at_relay()
                if self._rep not in ready:
                    continue
                try:
                    parts = self._rep.recv_multipart(zmq.NOBLOCK)
                except zmq.Again:
                    continue
                envelope = routing_envelope(parts)
                if envelope is None:
                    continue  # not a request (REP drops it too): nobody to answer
                reply = self._answer(parts[len(envelope) :])
                try:
                    self._rep.send_multipart(envelope + reply)
                except zmq.ZMQError as exc:
                    logger.warning("Groot2: could not send a reply: %s", exc)
                self._rest(time.thread_time() - self.cpu_s)
            except Exception:
                if self._stop.is_set():
                    return
                logger.exception("Groot2: the server loop failed; it goes on")
                time.sleep(0.05)

    def _look_at_relay(self) -> None:
        """Start the relay again where it ended while the server serves (killed, or its
        pipe closed by another's mistake): until 2026-12-01 the server went on without
        a word, and Groot2 (and every client after it) waited for replies that never
        came. It is started on the same ports, at most :data:`RELAY_RESTARTS` times;
        Groot2 reconnects by itself (a request it had sent is lost with the relay)."""
        relay = self._relay
        if relay is None or self._stop.is_set() or (how := relay_ended(relay)) is None:
            return
        with self._relay_lock:
            if self._stop.is_set() or self._relay is not relay:
                return  # closing: the relay's end is close()'s
            if self._relay_restarts >= RELAY_RESTARTS:
                self._lose_relay(how, f"it ended {RELAY_RESTARTS + 1} times")
                return
            self._relay_restarts += 1
            end_relay(relay)  # its pipes (it has ended: no wait)
            old = self._folder
            try:
                for sock, endpoint in zip((self._rep, self._pub), self._endpoints, strict=True):
                    sock.unbind(endpoint)
                self._folder = tempfile.mkdtemp(prefix="pirate-groot2-")
                self.port = self._bind(self.host, self.port)
            except (self._zmq.ZMQError, OSError, ConfigurationError, InputError) as exc:
                self._lose_relay(how, f"it could not be started again: {exc}")
                return
            finally:
                shutil.rmtree(old, ignore_errors=True)
        logger.warning(
            "Groot2: the relay process listening on %s ended (%s); started again on the"
            " same ports (Groot2 reconnects by itself)",
            self.address,
            how,
        )

    def _lose_relay(self, how: str, why: str) -> None:
        """The relay is gone for good: say so once; the run goes on without Groot2."""
        end_relay(self._relay)  # its pipes (it has ended: no wait)
        self._relay = None
        self.enabled = False
        logger.error(
            "Groot2: the relay process listening on %s ended (%s) and %s: Groot2 can no"
            " longer connect; the run goes on without it",
            self.address,
            how,
            why,
        )

    def _rest(self, spent_s: float) -> None:
        """After a request, rest :data:`REST_PER_CPU` times the CPU time it took (at most
        :data:`REST_MAX_S`): the server's thread shares the interpreter's lock with the
        tick and the link's threads, and a client asking as fast as it can (requests
        of 1 MiB, back to back) must not take more than a fifth of it. Groot2's polls
        take a tenth of a millisecond: it never notices."""
        if spent_s > 0:
            self._stop.wait(min(REST_MAX_S, spent_s * REST_PER_CPU))

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

    # -- the end

    def close(self) -> None:
        """Stop the server (idempotent); a held breakpoint goes on."""
        if self._copy or self._stop.is_set():
            return
        with self._cond:
            self._remove_all_locked()
        self._stop.set()
        self._thread.join(timeout=2.0)
        with self._relay_lock:  # a restart under way finishes first, then ends here
            if self._thread.is_alive():  # it was restarting the relay: it stops now
                self._thread.join(timeout=2.0)
            self._end_relay()
        forget_in_forks(self)

    def _forked(self) -> None:
        """In a forked process: let go of the relay (its pipe points at ``/dev/null``,
        ``close`` does nothing). The child's copy of the pipe kept the relay listening
        after the server closed, for as long as the child lived (a pool's worker)."""
        self._copy = True
        relay_to_null(self._relay)

    def __enter__(self) -> Groot2Server:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


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
