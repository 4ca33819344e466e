"""The public functions outside ``pirate_bt.api``, given hostile arguments.

As in tests/test_api_hostile.py: every function that ``import pirate_bt`` reaches
(``read_trace``, ``render_tree``, ``load_robot``, a trace's queries) and the loaders
and parsers beneath the API answer a bad argument with one line of
:class:`pirate_bt.InputError` (or the documented type) that names the argument:
never a bare ``TypeError``/``ValueError``/``OSError`` from deep inside, a hang on
``/dev/zero``, or an echo of a 100000-character value.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

import pirate_bt
from pirate_bt.errors import (
    ArgumentTypeError,
    ArgumentValueError,
    InputError,
    ValidationFailed,
    file_argument,
    shown,
)
from tests.hostile_support import no_hang, refused

HUGE = "x" * 100_000
LONG_PART = "y" * 300  # one part longer than the 255 bytes a file system takes
NOT_NAMES: list[Any] = [42, 1.5, float("nan"), {}, [], b"run.jsonl", None]


@pytest.fixture(autouse=True)
def _no_hang() -> Iterator[None]:
    yield from no_hang()


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("run") / "run.jsonl"
    pirate_bt.simulate_tree("straight", params={"distance": "0.05 m"}, trace=path, max_time=10)
    return path


@pytest.fixture(scope="module")
def trace(run: Path) -> pirate_bt.Trace:
    return pirate_bt.read_trace(run)


# -- the shared helpers


def test_shown_cuts_a_long_value_and_gives_its_length() -> None:
    assert shown("abc") == "'abc'"
    assert shown(HUGE) == f"{'x' * 40!r}... (100000 characters)"
    assert shown(10**400) == "a 401-digit number"
    assert len(shown(list(range(10_000)))) < 80
    assert shown(None) == "None"


@pytest.mark.parametrize("value", NOT_NAMES)
def test_a_file_name_is_text_or_a_path(value: Any) -> None:
    text = refused(lambda: file_argument(value, "out"), "out: give a file name", kind=TypeError)  # type: ignore[arg-type]
    with pytest.raises(ArgumentTypeError):
        file_argument(value, "out")
    assert "b'" not in text


@pytest.mark.parametrize(
    ("value", "words"),
    [("", "empty"), ("  ", "empty"), ("a\0b", "NUL"), (HUGE, "100000 characters")],
)
def test_a_file_name_is_not_empty_nor_unbounded(value: str, words: str) -> None:
    refused(lambda: file_argument(value, "path"), "path:", words, kind=ArgumentValueError)


# -- read_trace


@pytest.mark.parametrize("value", NOT_NAMES)
def test_read_trace_names_a_path_of_the_wrong_type(value: Any) -> None:
    # read_trace(42) was a bare TypeError from pathlib
    refused(lambda: pirate_bt.read_trace(value), "path: give a file name")


def test_read_trace_does_not_echo_a_huge_name() -> None:
    # the 100000-character name came back whole in the error
    refused(lambda: pirate_bt.read_trace(HUGE + ".jsonl"), "path", "100006 characters")
    refused(lambda: pirate_bt.read_trace(""), "path", "empty")
    refused(lambda: pirate_bt.read_trace(LONG_PART + ".jsonl"), "cannot read trace")


def test_read_trace_of_dev_zero_or_a_folder_is_refused(tmp_path: Path) -> None:
    zero = tmp_path / "zero.jsonl"
    zero.symlink_to("/dev/zero")  # one endless line: read at most 16 MiB of it
    refused(lambda: pirate_bt.read_trace(zero), "longer than", "not a trace")
    gz = tmp_path / "zero.jsonl.gz"
    gz.symlink_to("/dev/zero")
    refused(lambda: pirate_bt.read_trace(gz), "gzip")
    folder = tmp_path / "d.jsonl"
    folder.mkdir()
    refused(lambda: pirate_bt.read_trace(folder), "cannot read trace")
    refused(lambda: pirate_bt.read_trace("/dev/zero"), "unknown trace format")


# -- a trace's queries


@pytest.mark.parametrize("tick", [None, "5", 1.5, float("nan"), True, b"1", {}])
def test_a_tick_is_a_whole_number(trace: pirate_bt.Trace, tick: Any) -> None:
    # frame_at("5") was a TypeError from '<'; frame_at(1.5) a frame numbered 1.5
    refused(lambda: trace.frame_at(tick), "n: give a tick's number", kind=ArgumentTypeError)
    refused(lambda: trace.status_at("drive straight", tick), "tick: give a tick's number")


def test_a_tick_out_of_range_is_not_echoed_whole(trace: pirate_bt.Trace) -> None:
    text = refused(lambda: trace.frame_at(10**400), "no tick", "401-digit")
    assert "0000000000000000000000000000000000000000000000" not in text
    refused(lambda: trace.status_at("drive straight", -1), "no tick -1")
    assert trace.frame_at(0).n == 0


@pytest.mark.parametrize("value", [42, None, b"x", 1.5, {}])
def test_a_node_is_named_by_text(trace: pirate_bt.Trace, value: Any) -> None:
    # node(None) looked for a node named 'None'; nodes(42) was a TypeError
    if value is not None:
        refused(lambda: trace.node(value), "node: give a node's", kind=ArgumentTypeError)
        refused(lambda: trace.nodes(value), "pattern: give text", kind=ArgumentTypeError)
    refused(lambda: trace.statuses(value), "node:")


def test_a_huge_node_name_or_glob_is_refused_or_cut(trace: pirate_bt.Trace) -> None:
    refused(lambda: trace.node(HUGE), "node", "100000 characters")
    refused(lambda: trace.nodes("*" * 5000), "pattern", "5000 characters")
    text = refused(lambda: trace.node("[" * 3000), "no node", "3000 characters")
    assert "[" * 50 not in text


@pytest.mark.parametrize("status", ["DONE", "", HUGE, 42, None, b"S"])
def test_a_status_is_one_of_four_words(trace: pirate_bt.Trace, status: Any) -> None:
    text = refused(
        lambda: trace.first_tick("drive straight", status), "status: not a status", kind=ValueError
    )  # an InputError and, as before, a ValueError
    assert "xxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxx" not in text


# -- render_tree


@pytest.mark.parametrize("tree", [42, None, {}, b"straight", 1.5])
def test_render_tree_names_a_tree_of_the_wrong_type(tree: Any, tmp_path: Path) -> None:
    # render_tree(42, ...) was a bare TypeError; it still is a TypeError too
    refused(lambda: pirate_bt.render_tree(tree, tmp_path / "t.dot"), "tree:", kind=TypeError)


@pytest.mark.parametrize(("tree", "words"), [("", "empty"), (HUGE, "100000 characters")])
def test_render_tree_names_a_tree_that_is_no_file_name(
    tree: str, words: str, tmp_path: Path
) -> None:
    refused(lambda: pirate_bt.render_tree(tree, tmp_path / "t.dot"), "tree", words)


def test_render_tree_with_a_name_the_system_refuses(tmp_path: Path) -> None:
    # both were bare OSErrors (File name too long)
    refused(lambda: pirate_bt.render_tree(LONG_PART, tmp_path / "t.dot"), "cannot read")
    refused(lambda: pirate_bt.render_tree("straight", tmp_path / f"{LONG_PART}.dot"), "out")


@pytest.mark.parametrize("out", [*NOT_NAMES, "", HUGE])
def test_render_tree_names_an_output_that_is_no_file_name(out: Any) -> None:
    # render_tree("straight", 42) was a TypeError from pathlib
    refused(lambda: pirate_bt.render_tree("straight", out), "out:")


def test_render_tree_refuses_a_folder_or_an_unknown_suffix(tmp_path: Path) -> None:
    # both were bare ValueErrors ("cannot draw to 'tmp'"); still ValueErrors too
    for out in (tmp_path / "x.bogus", tmp_path / "noext"):
        refused(lambda o=out: pirate_bt.render_tree("straight", o), "out: cannot draw to")
        with pytest.raises(ValueError):
            pirate_bt.render_tree("straight", out)
    # a folder with no suffix blamed the suffix of its last part ("cannot draw to 'tmp'")
    refused(lambda: pirate_bt.render_tree("straight", "/tmp"), "out: '/tmp' is a folder")
    folder = tmp_path / "d.svg"
    folder.mkdir()
    refused(lambda: pirate_bt.render_tree("straight", folder), "out:", "is a folder")
    blocker = tmp_path / "blocker"
    blocker.write_text("mine", encoding="utf-8")
    refused(lambda: pirate_bt.render_tree("straight", blocker / "t.dot"), "not a folder")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blocker", "d.svg"]


@pytest.mark.parametrize(
    ("options", "words"),
    [
        ({"trace": 42}, "trace: give a file name"),
        ({"trace": "/dev/zero"}, "unknown trace format"),
        ({"tick": "5"}, "tick: give a tick's number"),
        ({"tick": float("nan")}, "tick:"),
        ({"params": 42}, "params: give a mapping"),
        ({"params": {1: "2"}}, "params: a parameter's name is text"),
        ({"robot": 42}, "robot: give a robot description file"),
        ({"robot": HUGE}, "robot: a file name of 100000 characters"),
        ({"title": 42}, "title: give text"),
        ({"title": HUGE}, "title: 100000 characters"),
        ({"status": 42}, "status: give a mapping"),
        ({"feedback": [1]}, "feedback: give a mapping"),
        ({"coverage": 42}, "coverage: give a Coverage"),
    ],
)
def test_render_tree_names_its_other_arguments(
    options: dict[str, Any], words: str, tmp_path: Path
) -> None:
    # params=42 was a TypeError, status=42 and coverage=42 AttributeErrors, title=42
    # and a 100 kB title were drawn, a robot of 100000 characters an OSError
    refused(lambda: pirate_bt.render_tree("straight", tmp_path / "t.dot", **options), words)


def test_render_tree_of_a_trace_refuses_a_tick_it_does_not_have(run: Path, tmp_path: Path) -> None:
    text = refused(lambda: pirate_bt.render_tree(run, tmp_path / "t.dot", tick=10**400), "no tick")
    assert len(text) < 200
    assert pirate_bt.render_tree(run, tmp_path / "t.dot", tick=3).exists()


# -- load_robot and the loaders below the API


@pytest.mark.parametrize("value", [42, 1.5, {}, b"pirate.yaml"])
def test_load_robot_names_a_path_of_the_wrong_type(value: Any) -> None:
    # load_robot(42) was a bare TypeError
    refused(lambda: pirate_bt.load_robot(value), "path: give a file name")


def test_load_robot_refuses_a_name_too_long_and_dev_zero() -> None:
    # 'x' * 100000 was an OSError (File name too long), a NUL a ValueError
    refused(lambda: pirate_bt.load_robot(HUGE), "path", "100000 characters")
    refused(lambda: pirate_bt.load_robot("a\0b.yaml"), "path", "NUL")
    refused(lambda: pirate_bt.load_robot(LONG_PART), "cannot read", kind=ValidationFailed)
    refused(lambda: pirate_bt.load_robot("/dev/zero"), "larger than", kind=ValidationFailed)
    assert pirate_bt.load_robot(None).name


def test_the_tree_and_network_loaders_name_what_is_no_file_name() -> None:
    from pirate_bt.pipes import load_network
    from pirate_bt.treefile import load_tree

    refused(lambda: load_tree(""), "source", "empty")
    refused(lambda: load_tree(HUGE), "source", "100000 characters")
    refused(lambda: load_tree(LONG_PART), "cannot read", kind=ValidationFailed)
    refused(lambda: load_network(42), "path: give a file name")  # type: ignore[arg-type]
    refused(lambda: load_network(HUGE), "path", "100000 characters")
    # the API's own: a long name is named by the option
    refused(lambda: pirate_bt.load_tree(LONG_PART), "cannot read")
    assert os.path.exists("/dev/zero")
    refused(lambda: load_tree("/dev/zero"), "larger than", kind=ValidationFailed)


# -- fault texts: each message says where it came from


@pytest.mark.parametrize(
    ("faults", "words"),
    [
        ("drop=2", "faults: link fault drop='2': a probability"),
        ("drop=nan", "a probability must lie in [0, 1]"),
        ("foo=1", "faults: unknown link fault 'foo'"),
        ("delay=inf", "faults: link fault delay: not a quantity"),  # was a bare UnitError
        ("seed=1.5", "faults: link fault seed='1.5': not a whole number"),
        ("drop", "faults: link fault 'drop' is not key=value"),
        ("motor_stall:bend_3_drive@-1s", "faults: bad fault"),
        ("bogus:x@5s", "faults: unknown fault kind 'bogus'"),
        ("motor_stall@5s", "faults: fault motor_stall needs a target"),
        ("link_loss@5kg", "faults: bad fault 'link_loss@5kg'"),
    ],
)
def test_a_fault_through_the_api_is_named_faults(faults: str, words: str) -> None:
    # the parsers' messages began 'fault drop=2: ...', 'unknown fault kind ...' or
    # a UnitError's own words, without naming the option
    refused(
        lambda: pirate_bt.simulate_tree("straight", params={"distance": "0.05 m"}, faults=faults),
        words,
    )


def test_the_fault_parsers_refuse_what_is_not_text_and_cut_what_is_long() -> None:
    from pirate_bt.link.faults import parse_fault_spec, split_fault_url
    from pirate_bt.sim.faults import parse_fault

    refused(lambda: parse_fault(42), "faults: a simulator fault is text", kind=TypeError)  # type: ignore[arg-type]
    refused(lambda: parse_fault_spec(None), "faults: a link fault spec is text", kind=TypeError)  # type: ignore[arg-type]
    refused(lambda: parse_fault(HUGE), "faults", "100000 characters")
    refused(lambda: parse_fault_spec(HUGE), "faults", "100000 characters")
    text = refused(lambda: parse_fault_spec("drop=" + "9" * 5000), "drop=", "5000 characters")
    assert "9" * 50 not in text
    refused(lambda: parse_fault("x" * 150 + "@5s"), "unknown fault kind", "150 characters")
    refused(lambda: split_fault_url("loop://?faults=drop=7"), "faults: link fault drop='7'")
    refused(lambda: parse_fault("link_loss", option=""), "bad fault 'link_loss'")
    with pytest.raises(InputError) as caught:
        parse_fault("x", option="")
    assert str(caught.value).startswith("bad fault 'x'")


# -- a campaign's seeds: the API's one limit


def test_a_campaign_takes_the_apis_seed_limit_and_every_seed_it_expands_to() -> None:
    from pirate_bt.api import options
    from pirate_bt.campaign import spec
    from pirate_bt.campaign.spec import campaign_from_data

    # campaign/spec had MAX_SEED = 10**15 and its own MAX_TIME_S beside the API's
    assert spec.MAX_SEED is options.MAX_SEED == 2**63 - 1
    assert spec.MAX_TIME_S is options.MAX_TIME_S
    run = {"runs": [{"tree": "straight", "params": {"distance": "0.05 m"}}]}
    last = campaign_from_data({"name": "s", **run, "seeds": {"start": 2**63 - 2, "count": 2}})
    assert last.seeds.start + last.seeds.count - 1 == options.MAX_SEED
    # a range past the last seed a run takes: each case would have been refused
    with pytest.raises(InputError, match="seeds: the last seed") as caught:
        campaign_from_data({"name": "s", **run, "seeds": {"start": 2**63 - 2, "count": 3}})
    assert "\n" not in str(caught.value)
    with pytest.raises(
        InputError, match="must be at most 9223372036854775807, not 9223372036854775808"
    ):
        campaign_from_data({"name": "s", **run, "seeds": {"start": 2**63}})
    with pytest.raises(InputError, match="sim_faults") as caught:
        campaign_from_data({"name": "s", **run, "sim_faults": [["bogus:x@5s"]]})
    assert "faults: " not in str(caught.value)  # located at its place, not named twice


# -- export and import entry points (pirate-bt export/import)


def test_the_exports_name_a_path_that_is_no_file_name(run: Path, tmp_path: Path) -> None:
    from pirate_bt.interop.btcpp_export import export_xml
    from pirate_bt.interop.btcpp_import_file import import_xml
    from pirate_bt.interop.btlog import export_btlog
    from pirate_bt.interop.mcap_trace import export_mcap
    from pirate_bt.interop.rosbag2 import export_rosbag2

    out = tmp_path / "o"
    # each was a bare TypeError (42, None) or OSError (a 100000-character name);
    # export_rosbag2(trace, 42) wrote a bag named '42' in the working folder
    for bad in (42, None, HUGE):
        refused(lambda b=bad: export_btlog(b, out.with_suffix(".btlog")), "trace_path")
        refused(lambda b=bad: export_btlog(run, b), "out_path")
        refused(lambda b=bad: export_mcap(b, out.with_suffix(".mcap")), "trace_path")
        refused(lambda b=bad: export_mcap(run, b), "out_path")
        refused(lambda b=bad: export_rosbag2(b, out), "trace_path")
        refused(lambda b=bad: export_rosbag2(run, b), "out_dir")
        refused(lambda b=bad: export_xml(b, out.with_suffix(".xml")), "tree_path")
        refused(lambda b=bad: export_xml("trees/straight.yaml", b), "out_path")
        refused(lambda b=bad: import_xml(b, out.with_suffix(".yaml")), "xml_path")
        refused(lambda b=bad: import_xml(out.with_suffix(".xml"), b), "out_path")
    # a folder as the output was an IsADirectoryError
    refused(lambda: export_mcap(run, tmp_path), "out_path", "is a folder")
    refused(lambda: export_btlog(run, tmp_path / f"{LONG_PART}.btlog"), "out_path")
    # the folders on the way to a bag are made (87cab6e), but not through a file
    blocker = tmp_path / "a-file"
    blocker.write_text("x", encoding="utf-8")
    refused(lambda: export_rosbag2(run, blocker / "such" / "bag"), "out_dir")
    blocker.unlink()
    assert not Path("42").exists() and not Path("None").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_read_btlog_reads_dev_zero_at_most_its_limit(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from pirate_bt.interop import btlog

    # read_bytes() on /dev/zero read until the process was killed for its memory
    monkeypatch.setattr(btlog, "MAX_BTLOG_BYTES", 1 << 20)
    refused(lambda: btlog.read_btlog("/dev/zero"), "larger than")
    refused(lambda: btlog.read_btlog(42), "path: give a file name")  # type: ignore[arg-type]
    refused(lambda: btlog.read_btlog(HUGE), "path", "100000 characters")


# -- names the system refuses, at the bottom (yamlfile, resources)


def test_a_name_part_too_long_is_a_located_error_naming_what_was_typed() -> None:
    from pirate_bt.pipes import load_network
    from pirate_bt.yamlfile import load_yaml

    long = "y" * 300  # Path.exists() raised OSError (File name too long) on 3.11
    for call in (lambda: load_yaml(long), lambda: load_network(long)):
        with pytest.raises(ValidationFailed) as caught:
            call()
        text = str(caught.value)
        assert text == f"{long}:1:1: cannot read: File name too long"
        assert "\n" not in text


def test_a_nul_in_a_yaml_file_name_is_a_located_error() -> None:
    from pirate_bt.yamlfile import load_yaml

    with pytest.raises(ValidationFailed, match="cannot read: a NUL in the file name"):
        load_yaml("a\x00b.yaml")


@pytest.mark.parametrize(
    ("faults", "words"),
    [
        (
            "motor_stall:bend_99_drive@1s",
            "faults: fault motor_stall: unknown motor 'bend_99_drive'",
        ),
        ("sensor_stuck:nope@1s", "faults: fault sensor_stuck: unknown state channel 'nope'"),
        ("board_reset:99@1s", "faults: fault board_reset: unknown board '99' (boards: 20, 21,"),
    ],
)
def test_a_fault_on_something_the_robot_lacks_is_bad_input_named_faults(
    faults: str, words: str
) -> None:
    # was a ConfigurationError, which `except InputError` missed, not naming the option
    text = refused(
        lambda: pirate_bt.simulate_tree("straight", params={"distance": "0.05 m"}, faults=faults),
        words,
    )
    assert "(motors: camera_tilt," in text or "(channels: " in text or "(boards: " in text
    from pirate_bt.errors import ConfigurationError

    with pytest.raises(ConfigurationError):  # still one, for callers that caught it
        pirate_bt.connect("sim:straight", faults=faults)


def test_the_task_planners_name_arguments_of_the_wrong_type() -> None:
    from pirate_bt import task

    route = pirate_bt.load_route("lab.route")
    lab = pirate_bt.load_network("lab")
    robot = pirate_bt.load_robot()
    refused(
        lambda: task.plan_route(route, "lab", robot),
        "plan_route: network: give a Network",
        "pirate_bt.plan_route takes a file",
        kind=ArgumentTypeError,
    )  # type: ignore[arg-type]
    refused(
        lambda: task.plan_route("lab.route", lab, robot),
        "plan_route: route: give a parsed",
        kind=ArgumentTypeError,
    )  # type: ignore[arg-type]
    refused(
        lambda: task.plan_route(route, lab, "pirate.yaml"),
        "plan_route: robot: give a",
        kind=ArgumentTypeError,
    )  # type: ignore[arg-type]
    refused(
        lambda: task.plan_goal("lab", "service-2", robot),
        "plan_goal: network: give a",
        kind=ArgumentTypeError,
    )  # type: ignore[arg-type]
    refused(
        lambda: task.plan_goal(lab, 42, robot),
        "plan_goal: segment: give a segment's id",
        kind=ArgumentTypeError,
    )  # type: ignore[arg-type]
    refused(lambda: task.plan_goal(lab, HUGE, robot), "100000 characters", kind=ArgumentTypeError)
    # None is the bundled robot, as everywhere in the API
    assert task.plan_goal(lab, "service-2", None).pabs
    assert task.plan_route(route, lab, None).pabs == task.plan_route(route, lab, robot).pabs
