"""Probe 19: other implementations of the live protocols, and the servers a planner opens.

Found by acting as a peer of each protocol (a Groot2 client, a Foxglove client, a
ROS 2 node, MCAP and rosbag2 readers) and as planner code that opens the live views'
servers itself (``Ros2Node``, ``Groot2Server``, ``FoxgloveServer``), with values read
from a configuration file or the environment.
"""

from __future__ import annotations

import math
import subprocess
from typing import Any

import pytest

from pirate_bt.errors import ArgumentTypeError, ArgumentValueError, InputError


def _no_process(monkeypatch: pytest.MonkeyPatch, module: Any) -> None:
    """Make starting a process fail the test: a refusal must come before one starts."""

    def refuse(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError(f"a process was started: {args[0]!r}")

    monkeypatch.setattr(module.subprocess, "Popen", refuse)
    assert module.subprocess is subprocess


@pytest.mark.parametrize(
    ("kwargs", "kind", "says"),
    [
        ({"rate_hz": math.nan}, ArgumentValueError, "rate_hz: give a positive, finite number"),
        ({"rate_hz": math.inf}, ArgumentValueError, "rate_hz: give a positive, finite number"),
        ({"rate_hz": "20"}, ArgumentTypeError, "rate_hz: give a number, not a str"),
        ({"domain_id": 3.7}, ArgumentTypeError, "domain_id: give a whole number from 0 to 232"),
        ({"domain_id": True}, ArgumentTypeError, "domain_id: give a whole number from 0 to 232"),
        ({"domain_id": "3"}, ArgumentTypeError, "domain_id: give a whole number from 0 to 232"),
        ({"namespace": 5}, ArgumentTypeError, "namespace: give text, not an int"),
        ({"endpoint": 7447}, ArgumentTypeError, "endpoint: give text, not an int"),
        ({"name": None}, ArgumentTypeError, "name: give text, not None"),
    ],
)
def test_a_ros2_node_refuses_an_argument_it_cannot_use_before_its_process_starts(
    monkeypatch: pytest.MonkeyPatch, kwargs: dict[str, Any], kind: type, says: str
) -> None:
    """``Ros2Node(rate_hz=nan)`` started the node's process, which died at its first wait
    with a traceback on the run's terminal (the run went on unseen, its e-stop topic
    unheard); ``rate_hz=inf`` made it poll without rest (a third of a core);
    ``domain_id=3.7`` joined domain 3 and ``True`` domain 1; text for a number, or a
    number for text, was a ``TypeError`` or ``AttributeError`` traceback."""
    pytest.importorskip("zenoh")
    from pirate_bt.interop import ros2_node

    _no_process(monkeypatch, ros2_node)
    with pytest.raises(kind) as caught:
        ros2_node.Ros2Node(**kwargs)
    message = str(caught.value)
    assert isinstance(caught.value, InputError)
    assert message.startswith("ROS 2 node: ") and says in message, message
    assert "\n" not in message


@pytest.mark.parametrize(
    ("args", "kwargs", "kind", "says"),
    [
        (("127.0.0.1", "1667"), {}, ArgumentTypeError, "port: give a whole number from 0 to 65534"),
        (("127.0.0.1", 1.5), {}, ArgumentTypeError, "port: give a whole number from 0 to 65534"),
        (("127.0.0.1", True), {}, ArgumentTypeError, "port: give a whole number from 0 to 65534"),
        ((None, 0), {}, ArgumentTypeError, "host: give text, not None"),
        (("127.0.0.1", 0), {"heartbeat_s": math.nan}, ArgumentValueError, "heartbeat_s: give a"),
        (("127.0.0.1", 0), {"heartbeat_s": 0}, ArgumentValueError, "heartbeat_s: give a"),
        (("127.0.0.1", 0), {"heartbeat_s": math.inf}, ArgumentValueError, "heartbeat_s: give a"),
        (("127.0.0.1", 0), {"heartbeat_s": "5"}, ArgumentTypeError, "heartbeat_s: give a number"),
    ],
)
def test_a_groot2_server_refuses_an_argument_it_cannot_use_before_it_binds(
    args: tuple[Any, ...], kwargs: dict[str, Any], kind: type, says: str
) -> None:
    """A port read from the environment as text was a ``TypeError`` traceback;
    ``port=1.5`` bound ports 1 and 2 (ZeroMQ reads the digits it can); a heartbeat of
    ``nan`` or 0 removed every hook as soon as it was set (against a robot, a held
    breakpoint then put it in its safe state) and ``inf`` turned the fail-safe off."""
    pytest.importorskip("zmq")
    from pirate_bt.interop import groot2_server

    made: list[Any] = []
    real = groot2_server.Groot2Server._bind

    def bind(self: Any, host: str, port: int) -> int:
        made.append(port)
        return real(self, host, port)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(groot2_server.Groot2Server, "_bind", bind)
        with pytest.raises(kind) as caught:
            groot2_server.Groot2Server(*args, **kwargs).close()
    message = str(caught.value)
    assert isinstance(caught.value, InputError)
    assert message.startswith("Groot2Server: ") and says in message, message
    assert "\n" not in message
    assert made == []  # refused before anything was bound


@pytest.mark.parametrize(
    ("args", "kind", "says"),
    [
        (("127.0.0.1", 70000), ArgumentValueError, "port: give a whole number from 0 to 65535"),
        (("127.0.0.1", -1), ArgumentValueError, "port: give a whole number from 0 to 65535"),
        (("127.0.0.1", True), ArgumentTypeError, "port: give a whole number from 0 to 65535"),
        (("127.0.0.1", "8765"), ArgumentTypeError, "port: give a whole number from 0 to 65535"),
        ((None, 0), ArgumentTypeError, "host: give text, not None"),
    ],
)
def test_a_foxglove_server_refuses_a_port_it_cannot_use_before_its_process_starts(
    monkeypatch: pytest.MonkeyPatch, args: tuple[Any, ...], kind: type, says: str
) -> None:
    """``FoxgloveServer(host, 70000)`` started the server's process and returned a
    server that never listened, with no error (its ``failure`` said ``OverflowError:
    number too large to fit in target type``); ``-1`` and ``True`` were called an
    unknown host; ``None`` for the host was a ``TypeError`` traceback."""
    pytest.importorskip("foxglove")
    from pirate_bt.interop import foxglove_live, foxglove_server

    _no_process(monkeypatch, foxglove_server)
    with pytest.raises(kind) as caught:
        foxglove_live.FoxgloveServer(*args)
    message = str(caught.value)
    assert isinstance(caught.value, InputError)
    assert message.startswith("FoxgloveServer: ") and says in message, message
    assert "unknown host" not in message and "\n" not in message


@pytest.mark.parametrize(
    ("bag", "kind", "says"),
    [
        (None, ArgumentTypeError, "bag: give a file name (text or a Path), not None"),
        (5, ArgumentTypeError, "bag: give a file name (text or a Path), not an int"),
        (b"run_bag", ArgumentTypeError, "bag: give a file name (text or a Path), not a bytes"),
        ("run\0_bag", ArgumentValueError, "bag: a file name may not hold a NUL character"),
        ("", ArgumentValueError, "bag: the file name is empty"),
    ],
)
def test_reading_a_bag_by_no_file_name_is_refused_as_the_export_refuses_one(
    bag: object, kind: type, says: str
) -> None:
    """``read_rosbag2_records(None)`` said ``None: not a readable rosbag2 bag: TypeError:
    expected str, bytes or os.PathLike object, not NoneType``, a NUL was written into the
    line as it was, and ``""`` was 'Expected metadata file '.' does not exist'; the
    export names its argument and says what it takes."""
    pytest.importorskip("rosbags")
    from pirate_bt.interop.rosbag2 import read_rosbag2_records

    with pytest.raises(kind) as caught:
        read_rosbag2_records(bag)  # type: ignore[arg-type]
    assert str(caught.value) == says


@pytest.mark.parametrize("record", [None, ["tick"], "tick"])
def test_a_record_that_is_no_mapping_is_left_out_not_raised(record: Any) -> None:
    """``FoxgloveServer.publish_record`` says it never raises; ``None``, a list or text
    raised ``TypeError``/``ValueError`` out of ``dict(record)`` into the run's hook."""
    pytest.importorskip("foxglove")
    from pirate_bt.interop.foxglove_live import FoxgloveServer

    class Handed:
        def __init__(self) -> None:
            self.given: list[Any] = []

        def _hand_over(self, *args: Any) -> None:
            self.given.append(args)

    server = Handed()
    FoxgloveServer.publish_record(server, record)  # type: ignore[arg-type]
    assert server.given == []
    FoxgloveServer.publish_record(server, {"type": "tick", "n": 1})  # type: ignore[arg-type]
    assert len(server.given) == 1
