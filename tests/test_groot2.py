"""The Groot2 server: protocol, requests and error replies, hooks meeting the protective layer.

A plain ZeroMQ client (pyzmq) asks what Groot2 asks. Whether the answers are
the ones BehaviorTree.CPP's own ``Groot2Publisher`` gives is
``tests/test_groot2_oracle.py``'s question (BT.CPP's own client code, and BT.CPP
serving the same tree).
"""

from __future__ import annotations

import json
import struct
import sys
import threading
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import py_trees
import pytest

zmq = pytest.importorskip("zmq")
msgpack = pytest.importorskip("msgpack")

import pirate_bt  # noqa: E402
from pirate_bt.clock import SimClock  # noqa: E402
from pirate_bt.errors import InputError  # noqa: E402
from pirate_bt.interop import groot2_protocol as proto  # noqa: E402
from pirate_bt.interop.groot2_option import parse_groot2_address  # noqa: E402
from pirate_bt.interop.groot2_server import Groot2Server, attach_groot2  # noqa: E402
from pirate_bt.runner import Runner  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
REPLAY = ROOT / "tests" / "data" / "btcpp" / "replay.yaml"


class Client:
    """What Groot2 does, over pyzmq: REQ to the server, SUB to its notices."""

    def __init__(self, port: int, timeout_ms: int = 30_000) -> None:
        self.context = zmq.Context()
        self.req = self.context.socket(zmq.REQ)
        self.req.setsockopt(zmq.RCVTIMEO, timeout_ms)
        self.req.setsockopt(zmq.LINGER, 0)
        self.req.connect(f"tcp://127.0.0.1:{port}")
        self.sub = self.context.socket(zmq.SUB)
        self.sub.setsockopt(zmq.SUBSCRIBE, b"")
        self.sub.setsockopt(zmq.LINGER, 0)
        self.sub.connect(f"tcp://127.0.0.1:{port + 1}")

    def raw(self, *parts: bytes) -> list[bytes]:
        self.req.send_multipart(list(parts))
        return list(self.req.recv_multipart())

    def ask(self, kind: str, *more: bytes, unique_id: int = 7) -> list[bytes]:
        return self.raw(proto.pack_request(ord(kind), unique_id), *more)

    def tree(self) -> ET.Element:
        reply = self.ask("T")
        assert len(reply) == 2, reply
        return ET.fromstring(reply[1])

    def statuses(self) -> dict[int, int]:
        body = self.ask("S")[1]
        return {struct.unpack_from("<H", body, i)[0]: body[i + 2] for i in range(0, len(body), 3)}

    def hook(self, uid: int, mode: int = 0, status: str = "SKIPPED", once: bool = False) -> Any:
        hook = {"uid": uid, "position": 0, "mode": mode, "enabled": True, "once": once}
        hook["desired_status"] = status
        return self.ask("I", json.dumps(hook).encode())

    def unlock(self, uid: int, status: str = "SKIPPED", remove: bool = True) -> Any:
        body = {"uid": uid, "position": 0, "desired_status": status, "remove_when_done": remove}
        return self.ask("U", json.dumps(body).encode())

    def notice(self, timeout_s: float) -> list[bytes] | None:
        """A breakpoint notice, polling the statuses meanwhile as Groot2 does (each
        request is a heartbeat: a client that only listened would fall silent)."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.sub.poll(100):
                return list(self.sub.recv_multipart())
            self.ask("S")
        return None

    def close(self) -> None:
        self.context.destroy(linger=0)


def uid_of(tree: ET.Element, name: str) -> int:
    for element in tree.iter():
        if element.get("name") == name and element.get("_uid"):
            return int(element.get("_uid", "0"))
    raise KeyError(name)


@pytest.fixture
def server() -> Iterator[Groot2Server]:
    with Groot2Server(port=0) as made:
        yield made


def client_thread(work: Callable[[], None]) -> tuple[threading.Thread, list[BaseException]]:
    errors: list[BaseException] = []

    def run() -> None:
        try:
            work()
        except BaseException as exc:  # surfaced by the test
            errors.append(exc)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return thread, errors


# -- the protocol, without sockets --------------------------------------------------------


def test_headers_are_6_and_22_bytes_little_endian() -> None:
    header = proto.pack_request(proto.RequestType.STATUS, 0x01020304)
    assert header == b"\x02S\x04\x03\x02\x01"
    request = proto.unpack_request(header)
    assert request == proto.RequestHeader(2, ord("S"), 0x01020304)
    assert proto.unpack_request(b"\x02S\x01") is None
    uuid = proto.new_tree_uuid()
    assert len(uuid) == 16 and uuid[6] >> 4 == 4 and uuid[8] >> 6 == 2
    reply = proto.reply_header(proto.RequestHeader(9, ord("T"), 5), uuid)
    assert len(reply) == 22 and reply[0] == 2  # the protocol is always ours
    assert proto.unpack_reply_header(reply) == (proto.RequestHeader(2, ord("T"), 5), uuid)


def test_transitions_are_9_bytes_each() -> None:
    body = proto.pack_transitions([(1, 2, 1), ((1 << 48) - 1, 65535, 3)])
    assert len(body) == 18
    assert body[:9] == b"\x01\x00\x00\x00\x00\x00\x02\x00\x01"
    assert body[9:15] == b"\xff" * 6 and body[15:] == b"\xff\xff\x03"


def test_hooks_are_read_strictly_and_dumped_as_bt_cpp_dumps_them() -> None:
    hooks = proto.parse_hooks(
        b'[{"uid":3,"position":0,"mode":1,"enabled":true,"once":false,"desired_status":"FAILURE"}]'
    )
    assert hooks[0].uid == 3 and hooks[0].mode == 1 and hooks[0].desired_status == "FAILURE"
    assert proto.hooks_json(hooks) == (
        b'[{"desired_status":"FAILURE","enabled":true,"mode":1,"once":false,"position":0,"uid":3}]'
    )
    for bad in (
        b"not json",
        b'{"uid":3}',
        b'{"uid":70000,"position":0,"mode":0,"enabled":true,"once":false,"desired_status":"IDLE"}',
        b'{"uid":3,"position":0,"mode":0,"enabled":1,"once":false,"desired_status":"IDLE"}',
        b'{"uid":3,"position":0,"mode":0,"enabled":true,"once":false,"desired_status":"MAYBE"}',
        b"[1]",
        # nested deeper than the JSON parser goes: was a RecursionError, answered as an
        # internal error with a traceback in the run's log
        b"[" * 100_000 + b"]" * 100_000,
    ):
        with pytest.raises(proto.HookError):
            proto.parse_hooks(bad)


def test_the_option_reads_host_and_port() -> None:
    assert parse_groot2_address(None) == ("127.0.0.1", 1667)
    assert parse_groot2_address("2000") == ("127.0.0.1", 2000)
    assert parse_groot2_address("0.0.0.0:1700") == ("0.0.0.0", 1700)
    assert parse_groot2_address("[::1]:1700") == ("::1", 1700)
    with pytest.raises(InputError):
        parse_groot2_address("host:65535")


# -- requests and replies -----------------------------------------------------------------


def test_before_a_tree_and_for_malformed_requests_the_server_answers_errors(
    server: Groot2Server,
) -> None:
    client = Client(server.port)
    try:
        assert client.ask("S") == [b"error", b"no tree is running yet"]
        server.serve(py_trees.trees.BehaviourTree(py_trees.behaviours.Success("ok")))
        assert client.raw(b"\x02S") == [b"error", b"wrong request header"]
        assert client.raw(b"\x02S\x00\x00\x00\x00\x00") == [b"error", b"wrong request header"]
        assert client.ask("Q") == [b"error", b"Request not recognized"]
        for kind in "BIRUr":
            assert client.ask(kind) == [b"error", b"must be 2 parts message"], kind
        assert client.ask("I", b"{oops")[0] == b"error"
        assert client.ask("R", b'{"uid":1,"position":0}') == [b"error", b"Node ID not found"]
        assert client.unlock(99) == [b"error", b"Node ID not found"]
        # a hook for a node that does not exist is ignored, as BT.CPP does
        assert len(client.hook(99)) == 1 and client.ask("D")[1] == b"[]"
        # still answering
        reply = client.ask("S", unique_id=0xDEADBEEF)
        header, uuid = proto.unpack_reply_header(reply[0])
        assert header == proto.RequestHeader(2, ord("S"), 0xDEADBEEF) and len(uuid) == 16
        assert reply[1] == b"\x01\x00\x00"
    finally:
        client.close()


def test_a_request_over_1_mib_is_dropped_and_the_server_goes_on(server: Groot2Server) -> None:
    server.serve(py_trees.trees.BehaviourTree(py_trees.behaviours.Success("ok")))
    hostile = Client(server.port, timeout_ms=500)
    try:
        hostile.req.send_multipart([proto.pack_request(ord("I")), b"x" * (2 << 20)])
        with pytest.raises(zmq.Again):
            hostile.req.recv_multipart()
    finally:
        hostile.close()
    client = Client(server.port)
    try:
        assert client.statuses() == {1: 0}
    finally:
        client.close()


def test_a_run_serves_its_tree_statuses_blackboard_and_transitions(server: Groot2Server) -> None:
    seen: dict[str, Any] = {}
    go = threading.Event()

    def work() -> None:
        client = Client(server.port)
        try:
            go.wait(10)
            tree = client.tree()
            seen["tree"] = tree
            seen["uuid"] = client.ask("S")[0][6:]
            assert client.ask("r", b"start")[1].isdigit()
            seen["go"] = True
        finally:
            client.close()

    thread, errors = client_thread(work)

    def observe(runner: Any, connection: Any) -> None:
        go.set()
        thread.join(10)  # the client has the tree and records before the first tick

    result = pirate_bt.simulate_tree(REPLAY, groot2=server, observe=observe)
    assert not errors, errors
    assert result.succeeded
    tree = seen["tree"]
    assert tree.tag == "root" and tree.get("BTCPP_format") == "4"
    trees = tree.findall("BehaviorTree")
    assert [t.get("_fullpath") for t in trees] == [""]
    uids = [int(e.get("_uid", "0")) for e in tree.iter() if e.get("_uid")]
    assert sorted(uids) == list(range(1, len(uids) + 1))
    client = Client(server.port)
    try:
        statuses = client.statuses()
        assert sorted(statuses) == sorted(uids)
        # as BT.CPP leaves a finished tree: every node back to IDLE, from what it was
        assert statuses[1] == proto.IDLE_FROM + 2
        assert set(statuses.values()) <= {0, 12, 13}
        transitions = client.ask("t")[1]
        assert transitions and len(transitions) % 9 == 0
        records = [
            (
                int.from_bytes(transitions[i : i + 6], "little"),
                *struct.unpack_from("<HB", transitions, i + 6),
            )
            for i in range(0, len(transitions), 9)
        ]
        assert {uid for _, uid, _ in records} <= set(uids)
        assert {status for _, _, status in records} <= {0, 1, 2, 3}
        assert [t for t, _, _ in records] == sorted(t for t, _, _ in records)
        assert client.ask("t")[1] == b""  # taken
        assert client.ask("S")[0][6:] == seen["uuid"]  # the same tree, the same UUID
    finally:
        client.close()


def test_subtrees_are_served_as_bt_cpp_instantiates_them(server: Groot2Server) -> None:
    tree = pirate_bt.load_tree("bend", params={"roll": "90 deg"})
    runner = Runner(tree, clock=SimClock())
    attach_groot2(runner, server)
    served = server.served()
    assert served is not None and served.expanded
    client = Client(server.port)
    try:
        xml = client.tree()
        paths = [t.get("_fullpath") for t in xml.findall("BehaviorTree")]
        assert paths[0] == "" and "pass bend" in paths and "recover" in paths
        calls = [e for e in xml.iter("SubTree") if e.get("_fullpath") == "pass bend"]
        assert len(calls) == 1 and calls[0].get("ID") == "turn"
        assert calls[0].get("roll") == "{roll}" and "name" not in calls[0].attrib
        statuses = client.statuses()
        assert len(statuses) == len([e for e in xml.iter() if e.get("_uid")])
        board = msgpack.unpackb(client.ask("B", b"pass bend;recover;nothing")[1])
        assert board == {
            "pass bend": {  # steer is bend.yaml's own parameter, passed on
                "search": "3 m",
                "follow": "550 mm",
                "branch": "false",
            },
            "recover": {"reason": "bend PAB failed"},
        }
        assert client.ask("B", b"nothing")[1] == b"\xc0"  # BT.CPP's null
    finally:
        client.close()


def test_a_tree_built_in_python_is_served_as_it_runs(server: Groot2Server) -> None:
    root = py_trees.composites.Sequence(
        "root", memory=True, children=[py_trees.behaviours.Success("a")]
    )
    attach_groot2(Runner(root, clock=SimClock()), server)
    served = server.served()
    assert served is not None and not served.expanded and served.order == (1, 2)
    client = Client(server.port)
    try:
        xml = client.tree()
        assert [e.get("name") for e in xml.iter() if e.get("_uid")] == ["root", "a"]
    finally:
        client.close()


# -- hooks meet the protective layer ------------------------------------------------------


def _held_run(
    server: Groot2Server, node: str, work: Callable[[Client, int], None], **options: Any
) -> tuple[Any, Any]:
    """A simulated ``straight`` run with a breakpoint at ``node``, set before the first
    tick; ``work(client, uid)`` runs once the tree waits there."""
    ready = threading.Event()
    found: dict[str, Any] = {}

    def client_work() -> None:
        client = Client(server.port)
        try:
            ready.wait(10)
            uid = uid_of(client.tree(), node)
            assert len(client.hook(uid)) == 1
            found["uid"] = uid
            found["hooked"] = True
            notice = client.notice(60)
            assert notice is not None, "no breakpoint reached"
            header = proto.unpack_request(notice[0])
            assert header is not None and header.type == ord("N")
            assert notice[1] == str(uid).encode()
            work(client, uid)
        finally:
            client.close()

    thread, errors = client_thread(client_work)

    def observe(runner: Any, connection: Any) -> None:
        found["connection"] = connection
        ready.set()
        deadline = time.monotonic() + 10
        while "hooked" not in found and time.monotonic() < deadline and not errors:
            time.sleep(0.01)

    result = pirate_bt.simulate_tree(
        "straight", params={"distance": "0.1 m"}, groot2=server, observe=observe, **options
    )
    thread.join(30)
    assert not errors, errors
    return result, found["connection"]


def test_a_breakpoint_pauses_the_tree_but_never_the_protective_layer(
    server: Groot2Server,
) -> None:
    during: dict[str, Any] = {}

    def work(client: Client, uid: int) -> None:
        statuses = client.statuses()
        during["waiting"] = statuses[uid]
        time.sleep(1.5)  # six times the bridge watchdog's 250 ms
        during["again"] = client.statuses()[uid]
        assert client.unlock(uid)[0][:2] == b"\x02U"

    result, connection = _held_run(server, "drive straight", work)
    assert result.succeeded, result.why
    assert during["waiting"] == during["again"] == 0  # the node never ran while held
    sim = connection.simulator.counters()
    assert sim.watchdog_trips == 0  # the supervisor kept feeding the link
    assert result.sim_time_s > 1.5  # and simulated time went on while the tree waited
    assert result.counters.safe_states == 0 and not result.safe_state


def test_a_silent_client_removes_its_hooks_and_the_tree_goes_on() -> None:
    with Groot2Server(port=0, heartbeat_s=0.4) as server:

        def work(client: Client, uid: int) -> None:
            time.sleep(1.0)  # silent: the hooks go, the tree goes on

        result, _ = _held_run(server, "drive straight", work)
        assert result.succeeded, result.why
        client = Client(server.port)
        try:
            assert client.ask("D")[1] == b"[]"
        finally:
            client.close()


def test_replacing_a_result_works_on_the_simulator(server: Groot2Server) -> None:
    def work(client: Client, uid: int) -> None:
        # at the breakpoint: give the node a result instead of running it
        assert client.unlock(uid, "FAILURE")[0][:2] == b"\x02U"

    result, _ = _held_run(server, "drive straight", work)
    assert not result.succeeded
    assert result.coverage is not None
    drive = next(n for n in result.coverage if n.path.endswith("drive straight"))
    assert drive.failures == 1


class _Supervisor:
    """Enough of a supervisor for the fail-safe: ticks and a safe state."""

    def __init__(self) -> None:
        self.ticks = 0
        self.safe: list[str] = []
        self.commands: list[Any] = []

    def tick(self) -> None:
        self.ticks += 1

    def safe_state(self, reason: str) -> None:
        self.safe.append(reason)

    def command(self, command: Any, source: Any = None) -> None:
        self.commands.append((command, source))


def _robot_run(server: Groot2Server, work: Callable[[Client, int], None]) -> tuple[Any, Any]:
    """A pure tree served as if it ran on a robot, with a breakpoint on its action."""
    action = py_trees.behaviours.Running("act")
    root = py_trees.composites.Sequence("root", memory=True, children=[action])
    runner = Runner(root, clock=SimClock(), period_s=0.02, max_time_s=60)
    supervisor = _Supervisor()
    runner.add_pre_tick(lambda _info: supervisor.tick())  # as every run pirate_bt wires
    attach_groot2(runner, server, supervisor=supervisor, robot="robot at /dev/ttyTEST")
    hooked = threading.Event()

    def client_work() -> None:
        client = Client(server.port)
        try:
            assert len(client.hook(2)) == 1
            hooked.set()
            assert client.notice(30) is not None
            work(client, 2)
        finally:
            client.close()

    thread, errors = client_thread(client_work)
    runner.add_pre_tick(lambda _info: hooked.wait(10))
    result = runner.run()
    thread.join(30)
    assert not errors, errors
    return result, supervisor


def test_against_a_robot_replacing_is_refused_and_silence_ends_in_the_safe_state() -> None:
    def work(client: Client, uid: int) -> None:
        refused = client.hook(uid, mode=1, status="SUCCESS")
        assert refused[0] == b"error" and b"simulator only" in refused[1]
        refused = client.unlock(uid, "SUCCESS")
        assert refused[0] == b"error" and b"robot at /dev/ttyTEST" in refused[1]
        time.sleep(1.0)  # then silent

    with Groot2Server(port=0, heartbeat_s=0.4) as server:
        result, supervisor = _robot_run(server, work)
    assert not result.succeeded
    assert supervisor.safe and "Groot2 client silent" in supervisor.safe[0]
    assert supervisor.ticks >= 10  # ticked all along while the tree waited
    assert [type(c).__name__ for c, _ in supervisor.commands] == ["Stop"]  # drives stopped


def test_the_default_heartbeat_is_bt_cpp_s_five_seconds(server: Groot2Server) -> None:
    assert server.heartbeat_s == 5.0


def test_a_taken_port_is_a_clear_error(server: Groot2Server) -> None:
    with pytest.raises(InputError, match="is taken"):
        Groot2Server(port=server.port)


def test_the_command_line_serves_a_run(tmp_path: Path) -> None:
    with Groot2Server(port=0) as probe:
        port = probe.port
    from pirate_bt.cli import main

    assert main(["run", str(REPLAY), "--quiet", "--groot2", f"127.0.0.1:{port}"]) == 0
    assert main(["run", str(REPLAY), "--quiet", "--groot2", "host:99999"]) == 2


def test_an_operator_e_stop_works_while_a_breakpoint_holds_the_tree(server: Groot2Server) -> None:
    """``teleop --tree T --groot2``: the console's keys still reach the supervisor while
    the tree waits at a breakpoint (the runner's pre-tick hooks keep running)."""
    from pirate_bt.cli.console import ConsoleEngine
    from pirate_bt.cli.teleop import TeleopSession

    with pirate_bt.connect("sim:straight", mode="autonomous") as robot:

        def factory() -> Any:
            runner = robot.runner(
                "straight", params={"distance": "0.2 m"}, setup_timeout_s=sys.float_info.max
            )
            attach_groot2(runner, server, supervisor=robot.supervisor)
            return runner

        engine = ConsoleEngine(
            TeleopSession(robot.supervisor),
            period_s=0.05,
            wall_period_s=0.002,
            runner_factory=factory,
        )
        thread = threading.Thread(target=engine.run, args=(lambda _s: None,), daemon=True)
        client = Client(server.port)
        try:
            thread.start()
            deadline = time.monotonic() + 30
            while client.ask("S")[0] == b"error" and time.monotonic() < deadline:
                time.sleep(0.01)
            uid = uid_of(client.tree(), "drive straight")
            assert len(client.hook(uid)) == 1
            assert client.notice(60) is not None
            engine.press("e")
            while not robot.supervisor.estopped and time.monotonic() < deadline:
                time.sleep(0.01)
            assert robot.supervisor.estopped  # applied while the tree waits
            # still waiting at the breakpoint, with the status it had when the breakpoint
            # took it, as BT.CPP shows it: IDLE at its first tick, RUNNING at a later one
            # (a loaded machine ticks the tree before the hook is set)
            assert client.statuses()[uid] in (0, 1)
            assert client.unlock(uid)[0][:2] == b"\x02U"
            while engine.finished is None and time.monotonic() < deadline:
                time.sleep(0.01)
        finally:
            engine.quit()
            thread.join(10)
            client.close()
        assert engine.result is not None and not engine.result.succeeded


def test_without_the_extra_the_error_says_what_to_install(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from pirate_bt.errors import ConfigurationError

    monkeypatch.setitem(sys.modules, "zmq", None)  # as if pyzmq were not installed
    with pytest.raises(ConfigurationError, match=r"pip install 'pirate-bt\[groot2\]'"):
        Groot2Server(port=0)


def test_a_post_hook_replaces_the_result_after_the_node_ran(server: Groot2Server) -> None:
    """BT.CPP 4.10's post-tick hooks: the node runs, then its result is replaced."""
    first = py_trees.behaviours.Success("first")
    root = py_trees.composites.Sequence(
        "root", memory=True, children=[first, py_trees.behaviours.Success("second")]
    )
    runner = Runner(root, clock=SimClock(), max_time_s=5)
    attach_groot2(runner, server)
    client = Client(server.port)
    try:
        hook = {"uid": 2, "position": 1, "mode": 1, "enabled": True, "once": True}
        hook["desired_status"] = "FAILURE"
        assert len(client.ask("I", json.dumps(hook).encode())) == 1
        dumped = json.loads(client.ask("D")[1])
        assert [(h["uid"], h["position"]) for h in dumped] == [(2, 1)]
        result = runner.run()
        assert not result.succeeded
        assert "replaced by Groot2" in first.feedback_message
        assert client.ask("D")[1] == b"[]"  # once: removed after it fired
        statuses = client.statuses()
        assert statuses[2] == proto.IDLE_FROM + 3 and statuses[3] == 0  # second never ran
    finally:
        client.close()


def test_mission_and_teleop_take_the_option() -> None:
    from pirate_bt.cli import main

    with Groot2Server(port=0) as probe:
        port = probe.port
    assert main(["mission", "straight.route", "--quiet", "--groot2", f"127.0.0.1:{port}"]) == 0
    # teleop serves a tree it runs: without --tree there is none to show
    assert main(["teleop", "--keys", "q", "--groot2", str(port)]) == 2
