"""Verdicts as a trace, a log and a listener see them.

Written with the mutation run (docs/testing.md): the record a trace stores for each
verdict, field by field; the log levels (refusals and the supervisor's own acts are
warnings); the verdict log's queries; and node paths for duck-typed nodes.
"""

from __future__ import annotations

import logging

import pytest

from pirate_bt.robot import ControlMode, Half, MotorCommand
from pirate_bt.safety import Clamp, Drive, Outcome, Reason, Source, Stop
from pirate_bt.safety.verdict import Verdict, VerdictLog, node_path

DRIVE = (MotorCommand("bend_1_drive", ControlMode.VELOCITY, 0.04),)


def refusal(seq: int = 3, tick: int = 2) -> Verdict:
    return Verdict(
        Outcome.REFUSE,
        Clamp(Half.FRONT, 0.5),
        Source.TREE,
        reason=Reason.FRONT_NOT_CLEAR,
        detail="move the front module clear",
        stamp_s=1.5,
        tick=tick,
        seq=seq,
        node="0.1",
        node_name="probe/clamp",
    )


def test_a_record_holds_every_field_a_trace_reads() -> None:
    assert refusal().to_record() == {
        "seq": 3,
        "tick": 2,
        "t": 1.5,
        "source": "tree",
        "command": "clamp(front, 0.5 N·m)",
        "outcome": "refuse",
        "reason": "front_not_clear",
        "detail": "move the front module clear",
        "sent": [],
        "node": "0.1",
    }
    clip = Verdict(
        Outcome.CLIP,
        Drive(0.08),
        Source.OPERATOR,
        sent=DRIVE,
        reason=Reason.ACCELERATION_LIMIT,
        seq=4,
    )
    assert clip.to_record()["sent"] == [["bend_1_drive", "velocity", 0.04]]
    plain = Verdict(Outcome.PASS, Stop(), Source.SUPERVISOR)
    assert plain.to_record()["reason"] is None
    assert plain.to_record()["node"] is None


def test_a_verdict_reads_as_one_line() -> None:
    assert str(refusal()) == (
        "REFUSE clamp(front, 0.5 N·m) [tree: probe/clamp] front_not_clear:"
        " move the front module clear"
    )
    assert str(Verdict(Outcome.PASS, Stop(), Source.OPERATOR)) == "PASS stop() [operator]"
    assert refusal().refused and not refusal().ok
    clip = Verdict(Outcome.CLIP, Drive(0.08), Source.TREE, sent=DRIVE)
    assert clip.ok and not clip.refused


def test_refusals_and_the_supervisor_s_own_acts_are_warnings(
    caplog: pytest.LogCaptureFixture,
) -> None:
    log = VerdictLog()
    caplog.set_level(logging.DEBUG, logger="pirate_bt.safety")
    log.append(Verdict(Outcome.PASS, Drive(0.01), Source.TREE, seq=1))
    log.append(refusal(seq=2))
    log.append(Verdict(Outcome.PASS, Stop(), Source.SUPERVISOR, seq=3))
    log.append(Verdict(Outcome.CLIP, Drive(0.08), Source.TREE, sent=DRIVE, seq=4))
    levels = [(r.levelno, r.getMessage()) for r in caplog.records]
    assert levels == [
        (logging.INFO, "PASS drive(10 mm/s) [tree]"),
        (logging.WARNING, str(refusal(seq=2))),
        (logging.WARNING, "PASS stop() [supervisor]"),
        (logging.INFO, "CLIP drive(80 mm/s) [tree]"),
    ]


def test_the_log_keeps_the_last_ones_and_answers_queries() -> None:
    log = VerdictLog(maxlen=3)
    assert log.last() is None and len(log) == 0
    for seq in range(1, 6):
        log.append(refusal(seq=seq, tick=seq // 2))
    assert len(log) == 3
    assert [v.seq for v in log] == [3, 4, 5]
    last = log.last()
    assert last is not None and last.seq == 5
    assert [v.seq for v in log.since(tick=2)] == [4, 5]
    assert [v.seq for v in log.since(seq=3)] == [4, 5]
    assert [v.seq for v in log.since(tick=1, seq=4)] == [5]
    assert [v.seq for v in log.since()] == [3, 4, 5]


def test_listeners_come_and_go() -> None:
    log = VerdictLog()
    heard: list[int] = []

    def listener(verdict: Verdict) -> None:
        heard.append(verdict.seq)

    log.remove_listener(listener)  # never added: nothing happens
    log.add_listener(listener)
    log.append(refusal(seq=1))
    log.remove_listener(listener)
    log.remove_listener(listener)
    log.append(refusal(seq=2))
    assert heard == [1]


def test_a_listener_may_remove_itself_while_called() -> None:
    log = VerdictLog()
    heard: list[str] = []

    def once(verdict: Verdict) -> None:
        heard.append("once")
        log.remove_listener(once)

    def always(verdict: Verdict) -> None:
        heard.append("always")

    log.add_listener(once)
    log.add_listener(always)
    log.append(refusal(seq=1))
    log.append(refusal(seq=2))
    assert heard == ["once", "always", "always"]


class Plain:
    """A node that is only a name, no ``parent`` attribute (duck typing)."""

    def __init__(self, name: str) -> None:
        self.name = name


class Node(Plain):
    def __init__(self, name: str, parent: Node | None = None) -> None:
        super().__init__(name)
        self.parent = parent
        self.children: list[Node] = []
        if parent is not None:
            parent.children.append(self)


def test_node_paths() -> None:
    assert node_path(Plain("alone")) == ("0", "alone")
    root = Node("root")
    first = Node("first", root)
    second = Node("second", root)
    leaf = Node("leaf", second)
    assert node_path(root) == ("0", "root")
    assert node_path(first) == ("0.0", "root/first")
    assert node_path(leaf) == ("0.1.0", "root/second/leaf")


def test_the_log_keeps_a_thousand_verdicts_by_default() -> None:
    log = VerdictLog()
    for seq in range(1, 1002):
        log.append(refusal(seq=seq))
    assert len(log) == 1000 and next(iter(log)).seq == 2


def test_a_log_handler_gets_the_verdict_itself(caplog: pytest.LogCaptureFixture) -> None:
    """Handlers may read the Verdict object from the record's args (structured logging)."""
    caplog.set_level(logging.INFO, logger="pirate_bt.safety")
    verdict = refusal()
    VerdictLog().append(verdict)
    (record,) = caplog.records
    assert record.msg == "%s" and record.args == (verdict,)
