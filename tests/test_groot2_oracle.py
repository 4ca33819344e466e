"""The oracle is BehaviorTree.CPP: our Groot2 server against BT.CPP's own, asked by BT.CPP's code.

``tests/groot2_oracle`` builds (once, cached) a client on BT.CPP's own protocol
header and cppzmq, and a reference server: BT.CPP's ``Groot2Publisher`` and
``TreeObserver`` on the tree loaded from pirate_bt's exported XML. A
pure-logic tree (``tests/data/btcpp/groot2.yaml``: memory and reactive
sequences and fallbacks, an inverter, force success and failure, a parallel,
one subtree called twice) runs tick by tick under pirate_bt; BT.CPP's tree
runs the same ticks, its leaves returning what ours returned. Then the client
asks both servers the same questions, and the answers must be the same:

- the full tree: subtree instances with their ``_fullpath``, every node's tag,
  ``name``, ``_uid`` and ports, the node models;
- the status reply after every tick, byte for byte in BT.CPP's order (statuses
  as BT.CPP keeps them: reset to IDLE, with the status they had, when a parent
  finishes or a reactive parent moves on);
- the transitions recorded in each tick (as sets: within one tick the order
  may differ), and BT.CPP's ``TreeObserver`` counts against our coverage;
- the subtrees' blackboards;
- the error replies to malformed requests;
- hooks: the dump after inserts and removes, a breakpoint's notice, the
  statuses while the tree waits at it, and after it is unlocked.

The reference is BT.CPP 4.8.2 (the ``behaviortreepy`` wheel's); where 4.10 differs
(malformed JSON in a hook request is an error reply in 4.10 and ends 4.8.2's
process; 4.10 also has post-tick hooks), that is not asked of it.
"""

from __future__ import annotations

import importlib.util
import json
import queue
import socket
import subprocess
import threading
import xml.etree.ElementTree as ET
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import py_trees
import pytest

pytest.importorskip("zmq")
pytest.importorskip("msgpack")

import pirate_bt
from pirate_bt.interop.btcpp import tree_to_xml
from pirate_bt.interop.groot2_server import Groot2Server
from pirate_bt.runner import tick_tree
from pirate_bt.trace.coverage import CoverageRecorder

ROOT = Path(__file__).resolve().parent.parent
TREE = ROOT / "tests" / "data" / "btcpp" / "groot2.yaml"
CODE = {py_trees.common.Status.RUNNING: 1, py_trees.common.Status.SUCCESS: 2}
CODE[py_trees.common.Status.FAILURE] = 3

# the real-time group (tests/conftest.py): a live Groot2 client against the wall clock
pytestmark = pytest.mark.xdist_group("real-time")


@pytest.fixture(scope="module")
def programs() -> tuple[Path, Path]:
    # Loaded under its own name: tests/btcpp_checker's build.py is imported as `build`.
    spec = importlib.util.spec_from_file_location(
        "groot2_oracle_build", ROOT / "tests" / "groot2_oracle" / "build.py"
    )
    assert spec is not None and spec.loader is not None
    oracle_build = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(oracle_build)
    try:
        client, reference = oracle_build.build_oracle()
    except oracle_build.Unavailable as exc:
        pytest.skip(f"the Groot2 oracle cannot be built here: {exc}")
    return client, reference


class Program:
    """A line-oriented child process (the client or the reference)."""

    def __init__(self, *argv: str) -> None:
        self.process = subprocess.Popen(
            argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1
        )
        self.lines: queue.Queue[str] = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            self.lines.put(line.rstrip("\n"))
        self.lines.put("<eof>")

    def say(self, line: str) -> None:
        assert self.process.stdin is not None
        self.process.stdin.write(line + "\n")
        self.process.stdin.flush()

    def hear(self, timeout_s: float = 30.0) -> str:
        return self.lines.get(timeout=timeout_s)

    def talk(self, line: str, timeout_s: float = 30.0) -> str:
        self.say(line)
        return self.hear(timeout_s)

    def close(self) -> None:
        if self.process.poll() is None:
            try:
                self.say("quit")
                self.process.wait(timeout=5)
            except (OSError, subprocess.TimeoutExpired):
                self.process.kill()
                self.process.wait()


class Client(Program):
    def ask(self, name: str, kind: str, text: str | None = None) -> dict[str, Any]:
        line = f"ask {name} {kind}" + (f" {text}" if text is not None else "")
        answer: dict[str, Any] = json.loads(self.talk(line))
        assert "exception" not in answer and "timeout" not in answer, (line, answer)
        return answer

    def raw(self, name: str, *parts: bytes) -> dict[str, Any]:
        answer: dict[str, Any] = json.loads(
            self.talk(f"raw {name} " + " ".join(p.hex() or "-" for p in parts))
        )
        return answer

    def body(self, name: str, kind: str, text: str | None = None) -> Any:
        answer = self.ask(name, kind, text)
        assert answer.get("matches") is True and answer["protocol"] == 2, answer
        return answer["body"]


def _free_pair() -> int:
    """A port P with P and P + 1 free (the reference binds both)."""
    for _ in range(100):
        with socket.socket() as probe:
            probe.bind(("127.0.0.1", 0))
            port = probe.getsockname()[1]
        if port >= 65534:
            continue
        with socket.socket() as a, socket.socket() as b:
            try:
                a.bind(("127.0.0.1", port))
                b.bind(("127.0.0.1", port + 1))
            except OSError:
                continue
        return int(port)
    raise RuntimeError("no two free neighbouring ports")


class _Results(py_trees.visitors.VisitorBase):
    """Each leaf's result, as it ends its tick."""

    def __init__(self) -> None:
        super().__init__(full=False)
        self.seen: list[tuple[py_trees.behaviour.Behaviour, Any]] = []

    def run(self, behaviour: py_trees.behaviour.Behaviour) -> None:
        if not behaviour.children:
            self.seen.append((behaviour, behaviour.status))


class Session:
    """The same tree under pirate_bt (our server) and under BT.CPP (the reference)."""

    def __init__(self, programs: tuple[Path, Path], tmp: Path) -> None:
        client_path, reference_path = programs
        self.loaded = pirate_bt.load_tree(TREE)
        self.loaded.write_blackboard_defaults()
        self.tree = self.loaded.behaviour_tree()
        self.recorder = CoverageRecorder(self.tree, self.loaded.name)
        self.results = _Results()
        self.tree.visitors.append(self.results)
        self.ours = Groot2Server(port=0)
        self.ours.serve(
            self.tree,
            source=self.loaded.source,
            name=self.loaded.name,
            checked=self.loaded,
            recorder=self.recorder,
        )
        served = self.ours.served()
        assert served is not None
        self.served = served
        assert self.served.expanded
        xml = tmp / "oracle.xml"
        xml.write_text(tree_to_xml(TREE), encoding="utf-8")
        port = _free_pair()
        self.reference = Program(str(reference_path), str(xml), str(port))
        assert self.reference.hear() == "ready"
        self.client = Client(str(client_path))
        for name, where in (("ours", self.ours.port), ("bt", port)):
            assert json.loads(self.client.talk(f"connect {name} 127.0.0.1 {where}"))["ok"]
        self.nodes = [node for _, node in self.recorder_pairs()]
        self.index_of = {id(node): i for i, node in enumerate(self.nodes)}
        self.ticks = 0

    def recorder_pairs(self) -> list[tuple[str, Any]]:
        return list(zip(self.recorder.ids, self.recorder.nodes, strict=True))

    def tick(self, ours_in_thread: bool = False) -> threading.Thread | None:
        """One tick on both sides (ours first: BT.CPP's leaves return what ours did)."""
        self.ticks += 1
        self.ours.apply_hooks()
        if ours_in_thread:
            thread = threading.Thread(target=self._tick_ours, daemon=True)
            thread.start()
            return thread
        self._tick_ours()
        self.tick_reference()
        return None

    def _tick_ours(self) -> None:
        self.results.seen.clear()
        tick_tree(self.tree)
        self.recorder.record_tick()

    def tick_reference(self, wait: bool = True) -> None:
        for node, status in self.results.seen:
            uid = self.served.uids_of[self.index_of[id(node)]][0]
            if status in CODE:
                assert self.reference.talk(f"status {uid} {CODE[status]}") == "ok"
        assert self.reference.talk("tick") == "ok"
        if wait:
            self.wait_reference()

    def wait_reference(self) -> str:
        done = self.reference.talk("wait").split()
        assert done[0] == "done" and done[2:] == [], f"BT.CPP ticked other leaves: {done}"
        return done[1]

    @property
    def finished(self) -> bool:
        return self.ticks > 0 and self.tree.root.status != py_trees.common.Status.RUNNING

    def close(self) -> None:
        self.client.close()
        self.reference.close()
        self.ours.close()


@pytest.fixture
def session(programs: tuple[Path, Path], tmp_path: Path) -> Iterator[Session]:
    made = Session(programs, tmp_path)
    try:
        yield made
    finally:
        made.close()


def _nodes(element: ET.Element) -> list[tuple[str, dict[str, str]]]:
    return [(e.tag, dict(e.attrib)) for e in element.iter()]


def test_the_full_tree_is_bt_cpp_s(session: Session) -> None:
    ours = ET.fromstring(session.client.body("ours", "T")[0])
    theirs = ET.fromstring(session.client.body("bt", "T")[0])
    assert ours.get("BTCPP_format") == theirs.get("BTCPP_format") == "4"
    our_trees, their_trees = ours.findall("BehaviorTree"), theirs.findall("BehaviorTree")
    assert [(t.get("ID"), t.get("_fullpath")) for t in our_trees] == [
        (t.get("ID"), t.get("_fullpath")) for t in their_trees
    ]
    assert [t.get("_fullpath") for t in our_trees] == ["", "first pass", "second pass"]
    for mine, bt in zip(our_trees, their_trees, strict=True):
        assert _nodes(mine) == _nodes(bt)
    their_models = {m.get("ID"): m for m in theirs.find("TreeNodesModel") or []}
    for model in ours.find("TreeNodesModel") or []:
        assert model.get("ID") in their_models, model.get("ID")
        match = their_models[model.get("ID")]
        assert model.tag == match.tag
        assert sorted(p.get("name", "") for p in model) == sorted(p.get("name", "") for p in match)


def _statuses(session: Session, name: str) -> list[tuple[int, int]]:
    return [tuple(pair) for pair in session.client.body(name, "S")[0]]


def _transitions(session: Session, name: str) -> Counter[tuple[int, int]]:
    return Counter((uid, status) for _, uid, status in session.client.body(name, "t")[0])


def test_statuses_transitions_and_observer_counts_are_bt_cpp_s(session: Session) -> None:
    assert _statuses(session, "ours") == _statuses(session, "bt")  # all IDLE, in BT.CPP's order
    for name in ("ours", "bt"):
        assert session.client.body(name, "r", "start")[0].isdigit()
    while not session.finished:
        session.tick()
        assert session.ticks < 50
        assert _statuses(session, "ours") == _statuses(session, "bt"), f"tick {session.ticks}"
        assert _transitions(session, "ours") == _transitions(session, "bt"), session.ticks
    assert session.ticks >= 8
    # BT.CPP's TreeObserver: transitions, successes and failures per node
    stats = session.reference.talk("stats").split()[1:]
    theirs = {int(u): tuple(map(int, rest)) for u, *rest in (s.split(":") for s in stats)}
    coverage = session.recorder.coverage()
    for uid, (transitions, successes, failures, skips) in theirs.items():
        node = coverage.nodes[session.served.node_of[uid]]
        assert (node.transitions, node.successes, node.failures) == (
            transitions,
            successes,
            failures,
        ), (uid, node.path)
        assert skips == 0


def test_the_subtrees_blackboards_are_bt_cpp_s(session: Session) -> None:
    names = "first pass;second pass"
    ours = session.client.body("ours", "B", names)[0]
    theirs = session.client.body("bt", "B", names)[0]
    assert (
        ours
        == theirs
        == {
            "first pass": {"label": "first", "limit": "3"},
            "second pass": {"label": "step", "limit": "5"},
        }
    )
    assert session.client.body("ours", "B", "nothing") == session.client.body("bt", "B", "x")


def test_the_main_tree_s_blackboard_is_keyed_as_bt_cpp_keys_it(session: Session) -> None:
    # BT.CPP's publisher keys the main tree's blackboard by its tree ID; pirate_bt
    # served it under "" only, and a client asking as BT.CPP answers got nothing
    main = session.served.main_id
    assert main
    ours = session.client.body("ours", "B", main)[0]
    theirs = session.client.body("bt", "B", main)[0]
    assert isinstance(ours, dict) and isinstance(theirs, dict)
    assert set(ours) == set(theirs) == {main}
    assert set(session.client.body("ours", "B", "")[0]) == {""}  # pirate_bt's own name


def test_malformed_requests_get_bt_cpp_s_error_replies(session: Session) -> None:
    cases = [
        (b"\x02S\x01",),  # a header that is not 6 bytes
        (b"\x02S\x00\x00\x00\x00\x00",),
        (b"\x02Q\x01\x00\x00\x00",),  # no such request
        (b"\x02\x00\x01\x00\x00\x00",),
        *((bytes([2, ord(kind), 1, 0, 0, 0]),) for kind in "BIRUr"),  # one part of two
        (b"\x02R\x01\x00\x00\x00", b'{"uid":999,"position":0}'),  # no such node
        (b"\x02R\x01\x00\x00\x00", b'{"uid":2,"position":0}'),  # no such hook
        (b"\x02U\x01\x00\x00\x00", b'{"uid":2,"position":0,"desired_status":"SUCCESS",'
         b'"remove_when_done":true}'),
    ]  # fmt: skip
    for parts in cases:
        ours, theirs = session.client.raw("ours", *parts), session.client.raw("bt", *parts)
        assert "error" in ours and ours == theirs, (parts, ours, theirs)
    # and both still answer
    assert _statuses(session, "ours") == _statuses(session, "bt")


def _hook(uid: int, mode: int = 0, status: str = "SKIPPED") -> str:
    return json.dumps(
        {"uid": uid, "position": 0, "mode": mode, "enabled": True, "once": False,
         "desired_status": status}
    )  # fmt: skip


def _dump(session: Session, name: str) -> list[dict[str, Any]]:
    return sorted(json.loads(session.client.body(name, "D")[0]), key=lambda h: h["uid"])


def test_hooks_are_kept_and_dumped_as_bt_cpp_keeps_them(session: Session) -> None:
    for name in ("ours", "bt"):
        assert session.client.body(name, "I", _hook(5)) == []
        assert session.client.body(name, "I", f"[{_hook(7)}, {_hook(999)}]") == []
        assert session.client.body(name, "I", _hook(7, status="FAILURE")) == []  # an update
    assert _dump(session, "ours") == _dump(session, "bt")
    assert [h["uid"] for h in _dump(session, "ours")] == [5, 7]
    for name in ("ours", "bt"):
        assert session.client.body(name, "R", '{"uid":5,"position":0}') == []
        assert session.client.body(name, "X") == []
    assert _dump(session, "ours") == _dump(session, "bt")
    assert [h["enabled"] for h in _dump(session, "ours")] == [False]
    for name in ("ours", "bt"):
        assert session.client.body(name, "A") == []
    assert _dump(session, "ours") == _dump(session, "bt") == []


def _uid(session: Session, path: str) -> int:
    return next(uid for uid, where in session.served.paths.items() if where == path)


def test_a_breakpoint_holds_both_trees_alike(session: Session) -> None:
    work = _uid(session, "first pass/work")
    for name in ("ours", "bt"):
        assert session.client.body(name, "I", _hook(work)) == []
    thread = session.tick(ours_in_thread=True)
    assert thread is not None
    notice = json.loads(session.client.talk("notice ours 10000"))
    assert notice == {"type": "N", "protocol": 2, "uid": str(work)}
    # BT.CPP's leaves return what ours did: they are known once ours has gone on, so
    # BT.CPP is ticked with the script of its first tick, taken after ours unlocks.
    held = _statuses(session, "ours")
    assert dict(held)[work] == 0  # waiting before its tick
    assert dict(held)[1] == 1  # the root is RUNNING, as BT.CPP shows it mid-tick
    assert session.client.body("ours", "U", json.dumps(
        {"uid": work, "position": 0, "desired_status": "SKIPPED", "remove_when_done": True}
    )) == []  # fmt: skip
    thread.join(10)
    assert not thread.is_alive()
    session.tick_reference(wait=False)
    notice = json.loads(session.client.talk("notice bt 10000"))
    assert notice == {"type": "N", "protocol": 2, "uid": str(work)}
    assert _statuses(session, "bt") == held  # the same picture while both wait
    assert session.client.body("bt", "U", json.dumps(
        {"uid": work, "position": 0, "desired_status": "SKIPPED", "remove_when_done": True}
    )) == []  # fmt: skip
    session.wait_reference()
    assert _statuses(session, "ours") == _statuses(session, "bt")
    assert _dump(session, "ours") == _dump(session, "bt") == []


def test_a_replaced_result_is_bt_cpp_s(session: Session) -> None:
    work = _uid(session, "first pass/work")
    for name in ("ours", "bt"):
        assert session.client.body(name, "I", _hook(work, mode=1, status="SUCCESS")) == []
    session.tick()
    assert _statuses(session, "ours") == _statuses(session, "bt")
    assert dict(_statuses(session, "ours"))[work] == 12  # succeeded, reset by its parent


def test_a_mission_with_groot2_answers_bt_cpp_s_client_as_bt_cpp_would(
    programs: tuple[Path, Path], tmp_path: Path
) -> None:
    """``simulate_mission(..., groot2=...)``: BT.CPP's client reads the mission's tree,
    statuses and blackboards while it runs; the tree and the status layout are what
    BT.CPP's publisher serves for the same (exported) tree."""
    client_path, reference_path = programs
    client = Client(str(client_path))
    polled: list[list[tuple[int, int]]] = []
    sources: list[Any] = []
    stop = threading.Event()
    try:
        with Groot2Server(port=0) as server:
            assert json.loads(client.talk(f"connect ours 127.0.0.1 {server.port}"))["ok"]

            def poll() -> None:
                while not stop.is_set():
                    answer = client.ask("ours", "S")
                    if "error" not in answer:
                        polled.append([tuple(p) for p in answer["body"][0]])
                    # Groot2 polls at 10 Hz; five times that, so that a run that is
                    # over in half a second on a quiet machine is still seen often
                    stop.wait(0.02)

            pollers: list[threading.Thread] = []

            def observe(runner: Any, _values: Any) -> None:
                sources.append(runner._loaded.source)
                pollers.append(threading.Thread(target=poll, daemon=True))
                pollers[-1].start()

            result = pirate_bt.simulate_mission("straight.route", groot2=server, observe=observe)
            stop.set()
            for poller in pollers:  # one connection: its last answer is read before ours
                poller.join(10)
            assert result.succeeded, result.why
            ours_tree = ET.fromstring(client.body("ours", "T")[0])
            board = client.body("ours", "B", ";01 straight 1 m (line 4)")[0]
            final = [tuple(p) for p in client.body("ours", "S")[0]]
        assert len(polled) >= 5 and any(code == 1 for tick in polled for _, code in tick)
        assert board["01 straight 1 m (line 4)"]["distance"] == "1.0 m"
        assert board[""]["map_ok"] is True  # the live blackboard of the main tree
        xml = tmp_path / "mission.xml"
        xml.write_text(tree_to_xml(sources[0]), encoding="utf-8")
        port = _free_pair()
        reference = Program(str(reference_path), str(xml), str(port))
        try:
            assert reference.hear() == "ready"
            assert json.loads(client.talk(f"connect bt 127.0.0.1 {port}"))["ok"]
            theirs = ET.fromstring(client.body("bt", "T")[0])
            for mine, bt in zip(
                ours_tree.findall("BehaviorTree"), theirs.findall("BehaviorTree"), strict=True
            ):
                assert (mine.get("ID"), mine.get("_fullpath")) == (
                    bt.get("ID"),
                    bt.get("_fullpath"),
                )
                assert _nodes(mine) == _nodes(bt)
            their_status = [tuple(p) for p in client.body("bt", "S")[0]]
            assert [uid for uid, _ in final] == [uid for uid, _ in their_status]
            their_board = client.body("bt", "B", "01 straight 1 m (line 4)")[0]
            assert their_board["01 straight 1 m (line 4)"] == board["01 straight 1 m (line 4)"]
        finally:
            reference.close()
    finally:
        client.close()
