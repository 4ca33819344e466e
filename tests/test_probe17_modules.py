"""Probe 17 of the lower public modules, called with hostile but plausible arguments.

Each test is one thing a user of ``pirate_bt.pipes``, ``pirate_bt.sim`` and the
layers beside them saw: a traceback from inside the library, or a silent nonsense
answer, where one line naming the argument or the file's place was due.
"""

from __future__ import annotations

import json
import math
import os
import socket
import subprocess
import threading
from pathlib import Path
from typing import Any

import py_trees
import pytest

from pirate_bt.cli import main
from pirate_bt.clock import SimClock
from pirate_bt.errors import (
    ArgumentTypeError,
    ArgumentValueError,
    InputError,
    LinkError,
    LocatedError,
    ValidationFailed,
)
from pirate_bt.link import open_link
from pirate_bt.link.transport import Transport
from pirate_bt.pipes import Network, load_network, network_from_data
from pirate_bt.pipes.arguments import UnknownSegmentError
from pirate_bt.robot import StateBuilder, load_robot, robot_from_data
from pirate_bt.sim import Simulator
from pirate_bt.sim.server import ListenError, SimServer
from pirate_bt.sim.simulator import _REGISTRY
from pirate_bt.trace import TraceRecorder, read_trace
from pirate_bt.units import format_quantity, parse_quantity, units_of


def _line(*extra: dict[str, str]) -> dict[str, object]:
    segments = [{"type": "straight", "length": "1 m"}, *extra]
    return {"name": "x", "diameter": "63 mm", "segments": segments}


@pytest.mark.parametrize(
    "segment",
    [
        {"type": "bend", "direction": "up", "angle": "1e-300 deg"},
        {"type": "straight", "length": "1e-300 m"},
        {"type": "reducer", "diameter": "55 mm", "length": "1e-300 m"},
    ],
)
def test_a_piece_too_short_to_have_a_length_is_refused(segment: dict[str, str]) -> None:
    """A bend of 1e-300 deg after 1 m of pipe ended `pirate-bt validate` (and
    `load_network`) in *internal error: ZeroDivisionError*: 1 m + 1e-302 m is 1 m, and
    the bend's end frame divided by its length 0. A straight or reducer as short passed
    validate as a piece with no length."""
    with pytest.raises(ValidationFailed) as caught:
        network_from_data(_line(segment), "f.yaml")
    message = str(caught.value)
    assert "segment 'main-2' has no length 1 m along its line" in message
    assert len(caught.value.errors) == 1


def test_validate_says_where_a_bend_has_no_length(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "tiny.yaml"
    path.write_text(
        "name: x\ndiameter: 63 mm\nsegments:\n  - {type: straight, length: 1 m}\n"
        "  - {type: bend, direction: up, angle: 1e-300 deg}\n"
    )
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}:5:33: segment 'main-2' has no length" in err
    assert "internal error" not in err


LAB = load_network("lab")
ROBOT = load_robot()


@pytest.mark.parametrize("method", ["slope_at", "diameter_at", "frame_at", "position_at"])
def test_a_path_refuses_nan_for_a_distance(method: str) -> None:
    """`main_path().slope_at(nan)` answered 0.0 (the first piece's slope) and
    `position_at(nan)` a position of nans: a distance computed wrong upstream went on
    as a level pipe."""
    with pytest.raises(ArgumentValueError, match=r"^s_m: nan is no distance"):
        getattr(LAB.main_path(), method)(math.nan)


@pytest.mark.parametrize("value", ["12", None, True, b"1"])
def test_a_path_refuses_a_distance_that_is_no_number(value: object) -> None:
    """`slope_at("12")` raised *'<=' not supported between instances of 'float' and
    'str'* from inside `Path.index_at`; `slope_at(True)` answered as at 1 m."""
    with pytest.raises(ArgumentTypeError, match=r"^s_m: give a distance along the path"):
        LAB.main_path().piece_at(value)  # type: ignore[arg-type]


def test_a_path_refuses_a_whole_number_too_large_for_a_float() -> None:
    with pytest.raises(ArgumentValueError, match="401-digit number is too large"):
        LAB.main_path().diameter_at(10**400)


def test_a_path_holds_distances_beyond_its_ends_as_documented() -> None:
    main_path = LAB.main_path()
    assert main_path.diameter_at(-5) == main_path.diameter_at(0.0)
    assert main_path.diameter_at(math.inf) == main_path.diameter_at(main_path.length_m)


@pytest.mark.parametrize("choice", ["sideways", None, "Branch"])
def test_a_way_through_a_tee_other_than_straight_or_branch_is_refused(choice: object) -> None:
    """`net.path({"tee-1": "sideways"})` gave the main path, as if straight on had been
    asked: a planner's typo drove past the branch it meant."""
    with pytest.raises(ArgumentValueError, match=r"^choices: tee 'tee-1': .* give 'straight'"):
        LAB.path({"tee-1": choice})  # type: ignore[dict-item]


@pytest.mark.parametrize("choices", [["tee-1"], "tee-1"])
def test_choices_that_are_no_mapping_are_refused(choices: object) -> None:
    """A list raised *dictionary update sequence element #0 has length 5; 2 is required*."""
    with pytest.raises(ArgumentTypeError, match=r"^choices: give a mapping of tee ids"):
        LAB.path(choices)  # type: ignore[arg-type]


def test_an_unknown_tee_or_segment_is_an_input_error_and_still_a_key_error() -> None:
    """`net.segment("nosuch")` was a bare `KeyError: 'nosuch'` naming no segment it has."""
    with pytest.raises(UnknownSegmentError) as caught:
        LAB.segment("nosuch")
    assert isinstance(caught.value, InputError) and isinstance(caught.value, KeyError)
    assert str(caught.value).startswith("unknown segment 'nosuch'; segments: entry, bend-a,")
    with pytest.raises(KeyError, match="unknown tee 'tee-9'; tees: tee-1, tee-2"):
        LAB.path({"tee-9": "branch"})
    assert LAB.path({"tee-1": "branch"}).choices["tee-1"] == "branch"


@pytest.mark.parametrize(
    ("argument", "value", "error", "said"),
    [
        ("robot", "hardware/pirate.yaml", ArgumentTypeError, "robot: give a RobotDescription"),
        ("clock", "wall", ArgumentTypeError, "clock: give a SimClock or None, not a str"),
        ("noise", "typical", ArgumentTypeError, "noise: give a SensorNoise or None, not a str"),
        ("seed", -1, ArgumentValueError, "seed: -1 is not a whole number from 0 to 2**63 - 1"),
        ("seed", 1.5, ArgumentTypeError, "seed: give a whole number, not a float"),
        ("seed", None, ArgumentTypeError, "seed: give a whole number, not None"),
        ("faults", None, ArgumentTypeError, "faults: give a fault's text or a list of them"),
        ("faults", [5], ArgumentTypeError, "faults: a fault is text such as"),
        ("name", "", ArgumentValueError, "name: '' cannot be the NAME of a sim://NAME URL"),
        ("name", "a?b", ArgumentValueError, "name: 'a?b' cannot be the NAME of a sim://NAME"),
        ("start_m", 10**400, ArgumentValueError, "start_m: the front tip's distance is a"),
    ],
)
def test_a_simulator_refuses_a_wrong_argument_by_name(
    argument: str, value: object, error: type[Exception], said: str
) -> None:
    """`Simulator("straight", "hardware/pirate.yaml")` raised *AttributeError: 'str'
    object has no attribute 'clamp'*, `clock="wall"` *'str' object has no attribute
    'now'*; seeds -1, 1.5 and None were taken (the API refuses them); `name="a?b"`
    registered a simulator its own `url` (`sim://a?b`) could not reach, and `name=""`
    was quietly replaced; `start_m=10**400` raised an `OverflowError`."""
    with pytest.raises(error) as caught:
        Simulator("straight", **{argument: value})  # type: ignore[arg-type]
    assert str(caught.value).startswith(said)
    assert not [name for name in _REGISTRY if name in ("", "a?b")]


def test_one_fault_as_text_is_one_fault_not_its_characters() -> None:
    """`Simulator(..., faults="board_reset:22@1s")` (the API's `faults=` takes text)
    said *faults: bad fault 'b'*: the text was taken one character at a time."""
    with Simulator("straight", faults="board_reset:22@1s") as sim:
        sim.schedule("link_loss@2s+1s")
        sim.advance_to(2.5)
        kinds = [event.kind for event in sim.events()]
    assert "fault" in kinds


@pytest.mark.parametrize(
    ("value", "error"),
    [(math.inf, ArgumentValueError), (math.nan, ArgumentValueError), ("1", ArgumentTypeError)],
)
def test_advance_to_refuses_a_time_that_is_not_finite(value: object, error: type) -> None:
    """`sim.advance_to(math.inf)` stepped the world 10 ms at a time for ever (the
    process hung); `nan` did nothing, silently; `"1"` raised *can only concatenate
    str (not "float") to str*."""
    with Simulator("straight") as sim:
        with pytest.raises(error, match=r"^now_s: "):
            sim.advance_to(value)  # type: ignore[arg-type]
        sim.advance_to(0.05)
        assert sim.counters().state_frames_sent > 0


@pytest.mark.parametrize("data", ["abc", None])
def test_write_takes_bytes_only(data: object) -> None:
    """`sim.write("abc")` said *must be str or None, not bytes* (the reverse of the
    mistake) and `sim.write(None)` was taken silently."""
    with Simulator("straight") as sim, pytest.raises(ArgumentTypeError, match=r"^data: give bytes"):
        sim.write(data)  # type: ignore[arg-type]


@pytest.mark.parametrize("loader", [robot_from_data, network_from_data])
@pytest.mark.parametrize("data", [None, ["name"], "lab"])
def test_data_that_is_no_mapping_is_refused_by_name(loader: Any, data: object) -> None:
    """`network_from_data(None)` and `robot_from_data(None)` raised *'NoneType' object
    is not iterable*; a list *cannot convert dictionary update sequence element #0*."""
    with pytest.raises(ArgumentTypeError, match=r"^data: give a mapping of the file's keys"):
        loader(data)


def test_a_state_builder_needs_a_robot_description() -> None:
    """`StateBuilder("pirate")` raised *'str' object has no attribute 'state_channels'*."""
    with pytest.raises(ArgumentTypeError, match=r"^robot: give a RobotDescription"):
        StateBuilder("pirate")  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("value", "error", "said"),
    [
        (math.nan, ArgumentValueError, "values: bend_1_angle: nan is not a finite number"),
        (math.inf, ArgumentValueError, "values: bend_1_angle: inf is not a finite number"),
        ("1", ArgumentTypeError, "values: bend_1_angle: give a number in SI units, not a str"),
    ],
)
def test_encode_names_the_channel_it_cannot_encode(
    value: object, error: type[Exception], said: str
) -> None:
    """`StateBuilder.encode({"bend_1_angle": nan})` raised *cannot convert float NaN to
    integer* (inf an `OverflowError`), naming no channel; a value beyond the raw range
    still saturates."""
    builder = StateBuilder(ROBOT)
    with pytest.raises(error) as caught:
        builder.encode({"bend_1_angle": value})  # type: ignore[dict-item]
    assert str(caught.value) == said
    raw = builder.encode({"bend_1_angle": 1e300})
    assert max(r for r in raw if r is not None) == 4095


@pytest.mark.parametrize(
    ("argument", "value", "said"),
    [
        ("url", None, "url: give a port or pyserial URL as text, not None"),
        ("url", b"sim://x", "url: give a port or pyserial URL as text, not a bytes"),
        ("robot", None, "robot: give a RobotDescription"),
        ("clock", None, "clock: give a Clock (SimClock, WallClock), not None"),
        ("faults", 5, "faults: give a link fault spec"),
        ("config", "fast", "config: give a SessionConfig or None, not a str"),
        ("threaded", "no", "threaded: give True, False or None, not 'no'"),
        ("reset_wait_s", math.nan, "reset_wait_s: nan is not a number of seconds from 0"),
        ("write_timeout_s", math.nan, "write_timeout_s: nan is not a number of seconds"),
    ],
)
def test_open_link_refuses_a_wrong_argument_by_name(
    argument: str, value: object, said: str
) -> None:
    """`open_link(None, ...)` raised *'NoneType' object has no attribute 'partition'*,
    a robot or clock of None an `AttributeError`, `faults=5` *'int' object has no
    attribute 'active'*; `threaded="no"` was taken as true and `reset_wait_s=nan`
    and `write_timeout_s=nan` as given."""
    clock = SimClock()
    with Simulator("straight", ROBOT, clock=clock) as sim:
        arguments: dict[str, Any] = {"url": sim.url, "robot": ROBOT, "clock": clock}
        arguments[argument] = value
        with pytest.raises(InputError) as caught:
            open_link(**arguments)
        assert str(caught.value).startswith(said)
        assert sim.counters().frames_received == 0  # refused before anything was sent


def test_a_bad_fault_spec_leaves_no_port_open(monkeypatch: pytest.MonkeyPatch) -> None:
    """`open_link(url, ..., faults="drop=2")` opened the port, then refused the spec and
    left the port open (on a serial device, held until garbage collection; on the TCP
    simulator, taken for the one host it serves). The spec is read before the port
    opens now, and any failure after it closes the port."""
    opened: list[Transport] = []
    real_open = Transport.open

    def recording_open(*args: Any, **kwargs: Any) -> Transport:
        opened.append(real_open(*args, **kwargs))
        return opened[-1]

    monkeypatch.setattr(Transport, "open", recording_open)
    clock = SimClock()
    with Simulator("straight", ROBOT, clock=clock) as sim:
        with pytest.raises(InputError, match="drop='2': a probability must lie in"):
            open_link(sim.url, ROBOT, clock, faults="drop=2")
        with pytest.raises(InputError, match="drop='nan'"):
            open_link(sim.url + "?faults=drop=nan", ROBOT, clock)
    assert all(not transport.port.is_open for transport in opened)  # type: ignore[attr-defined]


def _trace_with(tmp_path: Path, tick: str) -> Path:
    """A trace of one recorded tick and then ``tick``, with the header of a real run."""
    header = json.dumps(
        {"type": "header", "format": "pirate-bt-trace", "version": 1, "tree": _TREE}
    )
    path = tmp_path / "run.jsonl"
    path.write_text(
        f'{header}\n{{"type":"tick","n":1,"t_s":0.0,"state":{{"rotation_rad":0.0}}}}\n{tick}\n'
    )
    return path


_TREE = {
    "name": "t",
    "nodes": [
        {
            "id": "0",
            "name": "t",
            "type": "Sequence",
            "kind": "composite",
            "parent": None,
            "children": [],
            "params": {},
        }
    ],
}


@pytest.mark.parametrize(
    ("tick", "said"),
    [
        (
            '{"type":"tick","n":2,"t_s":0.1,"state":{"rotation_rad":"x"}}',
            'state: rotation_rad: "x" is no number',
        ),
        (
            '{"type":"tick","n":2,"t_s":0.1,"state":{"rotation_rad":[1]}}',
            "state: rotation_rad: [1] is no number",
        ),
        ('{"type":"tick","n":2,"t_s":0.1,"feedback":{"0":5}}', "feedback: node 0: 5 is no text"),
        ('{"type":"tick","n":2,"t_s":0.1,"full":"yes"}', 'full is true or false, not "yes"'),
    ],
)
def test_a_tick_value_of_the_wrong_kind_is_refused_at_its_line(
    tmp_path: Path, tick: str, said: str
) -> None:
    """A state value `"x"` in a tick was read, and `trace.robot_state_at(2)` then raised
    *ValueError: could not convert string to float: 'x'*; `[1]` became a silent `nan`,
    a feedback of `5` was handed on as a number, and `"full": "yes"` read as true."""
    path = _trace_with(tmp_path, tick)
    with pytest.raises(LocatedError) as caught:
        read_trace(path)
    assert str(caught.value) == f"{path}:3:1: bad tick record: {said}"


def test_the_spellings_of_nan_and_inf_still_read_as_numbers(tmp_path: Path) -> None:
    path = _trace_with(tmp_path, '{"type":"tick","n":2,"t_s":0.1,"state":{"rotation_rad":"-inf"}}')
    state = read_trace(path).robot_state_at(2)
    assert state is not None and state.rotation_rad == -math.inf


@pytest.mark.parametrize(
    ("options", "said"),
    [
        ({"speed": math.inf}, "speed: inf is not a number above 0 and at most 100"),
        ({"speed": math.nan}, "speed: nan is not a number above 0 and at most 100"),
        ({"speed": "2"}, "speed: give a number, not a str"),
        ({"tick_s": 0}, "tick_s: 0 is not a number above 0 and at most 1"),
    ],
)
def test_a_sim_server_refuses_a_speed_or_tick_it_cannot_serve(
    options: dict[str, Any], said: str
) -> None:
    """`SimServer(sim, speed=math.inf)` was taken, and its serving loop then stepped
    the world for ever in one pass (the server hung, the host heard nothing); `nan`
    froze the world, `"2"` raised *'<=' not supported*, and `tick_s=0` spun a core."""
    with Simulator("straight") as sim, pytest.raises(InputError) as caught:
        SimServer(sim, **options)
    assert str(caught.value) == said


def test_a_port_in_use_is_one_error_naming_the_address() -> None:
    """`SimServer(sim).open_tcp(PORT)` on a port in use raised a bare *OSError: [Errno
    98] Address already in use* (`pirate-bt sim --tcp PORT` printed only that), and
    left its socket open."""
    taken = socket.socket()
    taken.bind(("127.0.0.1", 0))
    taken.listen()
    port = taken.getsockname()[1]
    try:
        with Simulator("straight") as sim:
            server = SimServer(sim)
            with pytest.raises(ListenError) as caught:
                server.open_tcp(port)
            assert str(caught.value).startswith(f"cannot listen on 127.0.0.1:{port}: ")
            assert isinstance(caught.value, InputError) and isinstance(caught.value, OSError)
            with pytest.raises(ArgumentValueError, match="port: 70000 is not a port"):
                server.open_tcp(70000)
            server.close()
    finally:
        taken.close()


def test_one_server_serves_one_endpoint_from_one_loop() -> None:
    """A second `open_tcp` left the first listener open and unserved; a second
    `start()` ran two loops stepping one simulator and reading each other's bytes."""
    with Simulator("straight") as sim:
        server = SimServer(sim)
        server.open_tcp(0)
        try:
            with pytest.raises(InputError, match="already serves"):
                server.open_tcp(0)
            server.start()
            with pytest.raises(InputError, match="serving already"):
                server.start()
            assert [t for t in threading.enumerate() if t.name == "pirate-sim"] != []
        finally:
            server.stop()
    assert [t for t in threading.enumerate() if t.name == "pirate-sim"] == []


@pytest.mark.parametrize(
    "call",
    [
        lambda: parse_quantity("1 m", "lenght"),
        lambda: format_quantity(1.0, "lenght"),
        lambda: units_of("lenght"),
    ],
)
def test_an_unknown_dimension_names_the_known_ones(call: Any) -> None:
    """`format_quantity(1.0, "lenght")` and `units_of("lenght")` raised a bare
    *KeyError: 'lenght'*; `parse_quantity` a `ValueError` naming no dimension it knows."""
    with pytest.raises(ArgumentValueError) as caught:
        call()
    assert str(caught.value).startswith("dimension: unknown dimension 'lenght'; known: ")
    assert "length, time, angle" in str(caught.value)


def test_format_quantity_refuses_a_value_or_digits_it_cannot_format() -> None:
    """`format_quantity("1", "length")` raised *can't multiply sequence by non-int of
    type 'float'*, `digits=-1` *Format specifier missing precision*."""
    with pytest.raises(ArgumentTypeError, match=r"^value_si: give a number in SI units"):
        format_quantity("1", "length")  # type: ignore[arg-type]
    with pytest.raises(ArgumentValueError, match=r"^digits: give a whole number from 0 to 17"):
        format_quantity(1.0, "length", -1)
    assert format_quantity(math.pi / 2, "angle") == "90 deg"


def test_a_tee_shorter_than_its_opening_is_refused() -> None:
    """A tee of `length: 30 mm` in 63 mm pipe validated, though its branch opening (one
    diameter wide, in its middle) reached 16 mm into the straights on either side, where
    the simulator found wall: a half clamped over the hole there."""
    tee = {"type": "tee", "length": "30 mm", "branch": {"direction": "left", "segments": []}}
    with pytest.raises(ValidationFailed) as caught:
        network_from_data(_line(tee), "f.yaml")
    assert str(caught.value) == (
        "f.yaml:1:1: segment 'main-2': a tee 30 mm long in a 63 mm pipe; its branch"
        " opening is one diameter wide, so a tee is at least one diameter long"
    )
    assert network_from_data(_line({**tee, "length": "63 mm"})).tee_ids() == ["main-2"]


@pytest.mark.parametrize(
    ("url", "said"),
    [
        (
            "socket://127.0.0.1:99999",
            "the port '99999' is not from 0 to 65535; give socket://HOST:PORT",
        ),
        ("socket://127.0.0.1", "no port; give socket://HOST:PORT"),
        ("socket://:5760", "no host; give socket://HOST:PORT"),
        (
            "socket://127.0.0.1:5760?logging=verbose",
            "logging='verbose' is none of debug, info, warning, error",
        ),
        ("rfc2217://host:x", "the port 'x' is not from 0 to 65535; give rfc2217://HOST:PORT"),
    ],
)
def test_a_malformed_network_url_says_what_is_wrong(url: str, said: str) -> None:
    """`--port socket://127.0.0.1:99999` said *cannot open ...: Could not open port ...:
    'debug|info|warning|error'* (pyserial's own message, garbled), no port *'<=' not
    supported between instances of 'int' and 'NoneType'*, `?logging=verbose` *'verbose'*."""
    with pytest.raises(LinkError) as caught:
        Transport.open(url, baud=115200)
    assert str(caught.value) == f"cannot open {url}: {said}"


def _writer_processes(path: Path) -> list[str]:
    """Trace writer processes of this process that write ``path``."""
    out = subprocess.run(
        ["ps", "--ppid", str(os.getpid()), "-o", "args="], capture_output=True, text=True
    ).stdout
    return [line for line in out.splitlines() if "sink.py" in line and str(path) in line]


@pytest.mark.parametrize("tree", [None, "straight"])
def test_a_trace_recorder_for_no_tree_creates_nothing(tmp_path: Path, tree: object) -> None:
    """`TraceRecorder("run.jsonl", None)` raised *'NoneType' object has no attribute
    'name'* after it had created an empty `run.jsonl` (read back: *empty trace (no
    header)*) and started its writer process, which ran on with nothing to write."""
    path = tmp_path / "run.jsonl"
    with pytest.raises(ArgumentTypeError, match=r"^tree: give a py_trees BehaviourTree"):
        TraceRecorder(path, tree)  # type: ignore[arg-type]
    assert not path.exists()
    assert _writer_processes(path) == []


def test_a_trace_recorder_names_a_destination_it_cannot_write(tmp_path: Path) -> None:
    """A folder named `run.jsonl` raised `IsADirectoryError`, `/proc/x.jsonl` a
    `FileNotFoundError`, and `None` *expected str, bytes or os.PathLike object*."""
    tree = py_trees.trees.BehaviourTree(py_trees.behaviours.Success(name="ok"))
    folder = tmp_path / "run.jsonl"
    folder.mkdir()
    with pytest.raises(InputError, match=r"run\.jsonl: cannot write trace: it is a folder"):
        TraceRecorder(folder, tree)
    with pytest.raises(InputError, match=r"^/proc/x.jsonl: cannot write trace: "):
        TraceRecorder("/proc/x.jsonl", tree)
    with pytest.raises(ArgumentTypeError, match=r"^destination: give a trace file name"):
        TraceRecorder(None, tree)  # type: ignore[arg-type]


@pytest.mark.parametrize("spec", ["lab", None, {"name": "x"}])
def test_a_network_built_from_no_spec_says_how_to_load_one(spec: object) -> None:
    """`Network("lab")` (the simulator and `load_network` take a name) raised *'str'
    object has no attribute 'segments'*."""
    with pytest.raises(ArgumentTypeError, match=r"^spec: give a NetworkSpec; .* load_network"):
        Network(spec)  # type: ignore[arg-type]
    assert Network(LAB.spec, "lab.yaml").main_path().length_m == LAB.main_path().length_m
