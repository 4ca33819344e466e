"""Planner scripts written from docs/api.md, given hostile arguments.

Every public function answers a bad argument with one line of
:class:`pirate_bt.InputError` (or the documented type) that names the argument,
before anything connects: never a hang (a tick rate of ``nan`` or ``1e9``, a
``max_time`` of ``inf``), a traceback from deep inside, or nonsense accepted
(``seed="x"``, ``realtime="no"``). Each case here is refused in well under a
second: the options are checked first.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

import pirate_bt
from tests.hostile_support import no_hang, refused

TREE = "straight"
PARAMS = {"distance": "0.05 m"}


@pytest.fixture(autouse=True)
def _no_hang() -> Iterator[None]:
    yield from no_hang()


NOT_FINITE = [float("nan"), float("inf"), float("-inf")]


# -- the tick rate and the time limit: one validator for every door


@pytest.mark.parametrize(
    ("rate", "words"),
    [
        (float("nan"), ("rate", "finite")),
        (float("inf"), ("rate", "finite")),
        (1e9, ("rate", "at most 1000 Hz")),
        (1e-9, ("rate", "within max_time")),
        (0, ("rate", "positive")),
        (-20, ("rate", "positive")),
        (10**400, ("rate", "too large")),
        (True, ("rate", "bool")),
        ({}, ("rate", "dict")),
        ("x" * 10_000, ("rate", "too long")),
        ("5 m", ("rate", "frequency")),
    ],
)
def test_every_door_refuses_a_rate_that_never_ends_a_run(rate: Any, words: tuple[str]) -> None:
    # simulate_tree(rate=nan) hung for ever, and so did 1e9 and 1e-9; inf was a bare
    # ValueError from the runner. The same check guards all four doors.
    refused(lambda: pirate_bt.simulate_tree(TREE, params=PARAMS, rate=rate, max_time=5), *words)
    refused(lambda: pirate_bt.navigate("goal", params={"segment": "x"}, rate=rate), "rate")
    refused(lambda: pirate_bt.simulate_mission("lab", rate=rate), "rate")
    with pirate_bt.connect("sim") as robot:
        refused(lambda: robot.runner(TREE, params=PARAMS, rate=rate, max_time=5), "rate")
        refused(lambda: robot.run(TREE, params=PARAMS, rate=rate, max_time=5), "rate")


@pytest.mark.parametrize("max_time", NOT_FINITE)
def test_a_time_limit_must_be_finite_and_says_what_to_give(max_time: float) -> None:
    text = refused(
        lambda: pirate_bt.simulate_tree(TREE, params=PARAMS, max_time=max_time),
        "max_time",
        "finite",
    )
    assert "'3600 s'" in text  # what to give instead
    refused(lambda: pirate_bt.navigate("goal", params={"segment": "x"}, max_time=max_time), "3600")
    refused(lambda: pirate_bt.survey(max_time=max_time), "max_time")
    refused(lambda: pirate_bt.simulate_mission("lab", max_time=max_time), "None for the plan's")
    with pirate_bt.connect("sim") as robot:  # a runner of your own: None is no limit
        refused(lambda: robot.runner(TREE, params=PARAMS, max_time=max_time), "give None")


@pytest.mark.parametrize("max_time", [0, -1, 1e308, 10**400, None, b"5 s", "", "5 Hz", "x" * 1000])
def test_a_time_limit_out_of_range_is_refused(max_time: Any) -> None:
    refused(lambda: pirate_bt.simulate_tree(TREE, params=PARAMS, max_time=max_time), "max_time")


def test_a_mission_tick_must_come_within_the_plans_own_limit() -> None:
    refused(lambda: pirate_bt.simulate_mission("lab", rate="0.0001 Hz"), "the plan's time limit")


@pytest.mark.parametrize("deadline", [*NOT_FINITE, 0, -5, 1e308, "5 kg"])
def test_a_navigator_deadline_must_be_a_finite_wall_time(deadline: Any) -> None:
    # nan raised a bare ValueError from threading, inf and 1e308 an OverflowError
    refused(
        lambda: pirate_bt.navigate("goal", params={"segment": "x"}, deadline=deadline),
        "deadline",
    )


def test_one_rate_limit_for_the_api_the_cli_and_campaigns() -> None:
    from pirate_bt.api import options
    from pirate_bt.campaign import spec
    from pirate_bt.cli import run

    assert spec.MAX_RATE_HZ is options.MAX_RATE_HZ == 1000.0
    assert run.MAX_RATE_HZ is options.MAX_RATE_HZ
    assert run.check_rate is options.check_rate


# -- seeds, flags, callbacks


@pytest.mark.parametrize("seed", [-1, 2**64, 10**400, 1.5, "x", True, None])
def test_a_seed_is_a_whole_number_from_zero(seed: Any) -> None:
    refused(lambda: pirate_bt.simulate_tree(TREE, params=PARAMS, seed=seed), "seed")
    refused(lambda: pirate_bt.connect("sim", seed=seed), "seed")
    refused(lambda: pirate_bt.simulate_mission("lab", seed=seed), "seed")
    refused(lambda: pirate_bt.navigate("goal", params={"segment": "x"}, seed=seed), "seed")


@pytest.mark.parametrize("name", ["realtime", "live", "firmware"])
def test_a_yes_no_option_is_true_or_false(name: str) -> None:
    # realtime="no" paced the run to wall time; firmware="no" ran the firmware chain
    refused(lambda: pirate_bt.simulate_tree(TREE, params=PARAMS, **{name: "no"}), name)


def test_more_yes_no_options() -> None:
    refused(lambda: pirate_bt.simulate_mission("lab", return_on_stop="no"), "return_on_stop")
    refused(lambda: pirate_bt.load_tree(TREE, params=PARAMS, check_robot="no"), "check_robot")
    refused(lambda: pirate_bt.connect("sim", firmware=1), "firmware")


def test_a_callback_is_callable() -> None:
    refused(lambda: pirate_bt.simulate_tree(TREE, params=PARAMS, observe=42), "observe")
    refused(lambda: pirate_bt.simulate_mission("lab", observe=42), "observe")


# -- names, paths and files


@pytest.mark.parametrize(
    ("tree", "words"),
    [
        ("", ("tree", "empty")),
        ("x" * 100_000, ("tree", "too long")),
        (42, ("tree", "int")),
        (None, ("tree", "None")),
        (b"trees/straight.yaml", ("tree", "bytes")),
    ],
)
def test_a_tree_that_is_no_tree_is_named(tree: Any, words: tuple[str]) -> None:
    refused(lambda: pirate_bt.simulate_tree(tree), *words)
    refused(lambda: pirate_bt.load_tree(tree), *words)


def test_a_device_or_a_folder_as_a_tree_route_or_robot_is_located() -> None:
    from pirate_bt.errors import ValidationFailed

    refused(lambda: pirate_bt.load_tree("/dev/zero"), "/dev/zero", kind=ValidationFailed)
    refused(lambda: pirate_bt.load_route("/dev/zero"), "/dev/zero", kind=ValidationFailed)
    refused(lambda: pirate_bt.plan_route("/tmp"), "/tmp", kind=ValidationFailed)
    refused(lambda: pirate_bt.simulate_tree(TREE, robot="/dev/zero"), kind=ValidationFailed)


@pytest.mark.parametrize("route", [42, None, b"lab", "", "x" * 100_000])
def test_a_route_that_is_no_route_is_named(route: Any) -> None:
    refused(lambda: pirate_bt.load_route(route), "route")
    refused(lambda: pirate_bt.plan_route(route), "route")


@pytest.mark.parametrize("network", [42, None, "", "x" * 100_000, "x" * 300, "nope"])
def test_a_network_that_is_no_network_is_named(network: Any) -> None:
    refused(lambda: pirate_bt.load_network(network), "network")
    if network is not None:  # plan_route's default: the route's own network line
        refused(lambda: pirate_bt.plan_route("lab", network=network), "network")


def test_the_network_arguments_are_named_as_given() -> None:
    refused(lambda: pirate_bt.simulate_tree(TREE, params=PARAMS, network=""), "network", "empty")
    refused(lambda: pirate_bt.simulate_tree(TREE, params=PARAMS, network="nope"), "network:")
    refused(lambda: pirate_bt.simulate_mission("lab", truth=42), "truth")
    refused(lambda: pirate_bt.simulate_mission("lab", truth="nope"), "truth")
    refused(lambda: pirate_bt.navigate("goal", params={"segment": "x"}, sim=""), "sim")
    refused(lambda: pirate_bt.navigate("goal", params={"segment": "x"}, map="nope"), "map")
    refused(lambda: pirate_bt.load_network("lab", base=42), "base")
    refused(lambda: pirate_bt.connect("x" * 5000), "connect")
    refused(lambda: pirate_bt.connect("sim:" + "x" * 300), "network")


@pytest.mark.parametrize("robot", [{}, 42, [], ""])
def test_a_robot_that_is_no_robot_is_named(robot: Any) -> None:
    # a dict read as the file "{}": "{}:1:1: no such file"
    refused(lambda: pirate_bt.simulate_tree(TREE, params=PARAMS, robot=robot), "robot")
    refused(lambda: pirate_bt.connect("sim", robot=robot), "robot")


def test_a_trace_that_can_never_be_written_is_refused_before_the_run(tmp_path: Path) -> None:
    def run(trace: Any) -> Callable[[], Any]:
        return lambda: pirate_bt.simulate_tree(TREE, params=PARAMS, trace=trace)

    refused(run({}), "trace", "dict")
    refused(run(42), "trace", "int")
    refused(run(""), "trace", "empty")
    refused(run(tmp_path), "trace", "directory")
    refused(run(tmp_path / "run.bogus"), "trace", "unknown trace format")
    (tmp_path / "file").write_text("")
    refused(run(tmp_path / "file" / "run.jsonl"), "trace", "not a directory")
    refused(run("/proc/run.jsonl"), "trace", "cannot write")  # was a bare FileNotFoundError
    refused(lambda: pirate_bt.simulate_mission("lab", trace=42), "trace")
    refused(lambda: pirate_bt.navigate("goal", params={"segment": "x"}, trace="/dev/zero"), "trace")


def test_an_output_folder_that_is_a_file_is_refused_before_the_run(tmp_path: Path) -> None:
    # simulate_mission(output="/dev/zero") ran the whole mission, then FileExistsError
    refused(lambda: pirate_bt.simulate_mission("lab", output="/dev/zero"), "output", "folder")
    refused(lambda: pirate_bt.simulate_mission("lab", output=42), "output")
    refused(lambda: pirate_bt.write_mission_outputs(42, tmp_path), "result", "MissionResult")
    refused(lambda: pirate_bt.survey(output=tmp_path), "output", "directory")
    refused(lambda: pirate_bt.survey(output=42), "output")


# -- parameters, faults, maps


@pytest.mark.parametrize(
    ("params", "words"),
    [
        ([1, 2], ("params", "list")),
        ("distance=1 m", ("params", "str")),
        ({1: 2}, ("params", "name")),
        ({"distance": 10**400}, ("params", "distance", "too large")),
        ({"distance": "x" * 1_000_000}, ("params", "distance", "too long")),
    ],
)
def test_parameters_are_a_mapping_of_names(params: Any, words: tuple[str]) -> None:
    refused(lambda: pirate_bt.simulate_tree(TREE, params=params), *words)
    refused(lambda: pirate_bt.load_tree(TREE, params=params), *words)


@pytest.mark.parametrize(
    "faults", [42, b"drop=0.1", {"drop": 0.1}, [42], ["x" * 1000], ["drop=0.1"] * 5000]
)
def test_faults_are_text_or_a_list_of_texts(faults: Any) -> None:
    # 42 was a bare TypeError; bytes were read as "fault spec item '100'"
    refused(lambda: pirate_bt.simulate_tree(TREE, params=PARAMS, faults=faults), "faults")
    refused(lambda: pirate_bt.connect("sim", faults=faults), "faults")


@pytest.mark.parametrize("tolerance", [float("nan"), -0.1, 1.0, 5, "10%", True, None])
def test_a_map_tolerance_is_a_fraction(tolerance: Any) -> None:
    refused(lambda: pirate_bt.simulate_mission("lab", map_tolerance=tolerance), "map_tolerance")
    refused(
        lambda: pirate_bt.navigate("goal", params={"segment": "x"}, map_tolerance=tolerance),
        "map_tolerance",
    )


# -- connections, ports, live views


def test_connect_refuses_an_estop_start_and_a_closed_connection_runs_nothing() -> None:
    refused(lambda: pirate_bt.connect("sim", mode="estop"), "mode", "autonomous")
    refused(lambda: pirate_bt.connect("sim", mode=42), "mode")
    robot = pirate_bt.connect("sim")
    robot.close()
    refused(lambda: robot.run(TREE, params=PARAMS, max_time=1), "closed")
    refused(lambda: robot.runner(TREE, params=PARAMS), "closed")


@pytest.mark.parametrize("setup", [float("nan"), -1, 0, "x"])
def test_a_runner_setup_timeout_is_positive(setup: Any) -> None:
    with pirate_bt.connect("sim") as robot:
        refused(lambda: robot.runner(TREE, params=PARAMS, setup_timeout_s=setup), "setup_timeout")


@pytest.mark.parametrize("port", ["sim", "sim:lab", "", "   ", 42, None, "lab"])
def test_a_port_is_a_serial_port_or_url(port: Any) -> None:
    refused(lambda: pirate_bt.run_tree(TREE, port=port, params=PARAMS), "port")
    refused(lambda: pirate_bt.run_mission("lab", port=port), "port")


def test_a_ports_options_are_checked_before_it_is_opened() -> None:
    # rate=nan on a port nobody listens on was a LinkError: the options came second
    refused(
        lambda: pirate_bt.run_tree(TREE, port="socket://127.0.0.1:9", params=PARAMS, rate="nan"),
        "rate",
    )
    refused(lambda: pirate_bt.navigate("explore", port="sim:lab"), "port")


def test_live_view_options_are_checked() -> None:
    def run(**options: Any) -> Callable[[], Any]:
        return lambda: pirate_bt.simulate_tree(TREE, params=PARAMS, **options)

    refused(run(foxglove=42), "foxglove", "int")  # was taken for an open server
    refused(run(ros2=42), "ros2", "int")  # was an AttributeError
    refused(run(groot2=-1), "groot2", "port")
    refused(run(groot2="host:999999"), "groot2:", "port")  # not "--groot2"
    refused(run(ros_domain_id=-5), "ros_domain_id")
    refused(run(ros_domain_id=5), "ros2=")  # ignored without ros2
    refused(run(ros_namespace=42, ros2=True), "ros_namespace")


# -- navigators, surveys


def test_navigation_counts_and_navigators() -> None:
    def nav(**options: Any) -> Callable[[], Any]:
        return lambda: pirate_bt.navigate("goal", params={"segment": "x"}, **options)

    refused(nav(max_steps=0), "max_steps")
    refused(nav(max_steps=10**9), "max_steps")
    refused(nav(max_steps=True), "max_steps")
    refused(lambda: pirate_bt.navigate("route", params=42), "params")
    refused(lambda: pirate_bt.load_navigator(42), "navigator")
    refused(lambda: pirate_bt.load_navigator(["goal"]), "navigator")
    refused(lambda: pirate_bt.load_navigator("route", 42), "params")
    refused(lambda: pirate_bt.GoalNavigator(42), "segment")  # type: ignore[arg-type]
    refused(lambda: pirate_bt.RouteNavigator(42), "route")  # type: ignore[arg-type]


@pytest.mark.parametrize("value", [float("nan"), 0, -1, 1e308, 10**400, True, "3 kg", None])
def test_survey_lengths(value: Any) -> None:
    refused(lambda: pirate_bt.survey(search=value), "search")
    refused(lambda: pirate_bt.ExploreNavigator(radius=value), "radius")


def test_survey_names_and_extensions() -> None:
    refused(lambda: pirate_bt.survey(name=42), "name")
    refused(lambda: pirate_bt.survey(extend=42), "extend")
    for value in (float("nan"), -1.0, 0, "1 m", None):
        refused(lambda v=value: pirate_bt.branch_leavable(v), "diameter_m")
    refused(lambda: pirate_bt.branch_leavable(0.1, float("inf")), "radius_m")


# -- campaigns


def _campaign() -> dict[str, Any]:
    return {"name": "t", "runs": [{"tree": TREE, "params": PARAMS}], "max_time": "5 s"}


@pytest.mark.parametrize(
    ("options", "words"),
    [
        ({"workers": 10**9}, ("workers", "at most")),  # hung starting the processes
        ({"workers": 1.5}, ("workers", "whole number")),
        ({"workers": True}, ("workers",)),
        ({"max_cases": float("nan")}, ("max_cases",)),
        ({"max_cases": True}, ("max_cases",)),
        ({"case_timeout": 10**400}, ("case_timeout", "too large")),
        ({"case_timeout": float("inf")}, ("case_timeout", "at most")),
        ({"scheduler": "tcp://127.0.0.1:9", "scheduler_timeout": float("inf")}, ("at most",)),
        ({"scheduler": 42}, ("scheduler",)),
        ({"output": 42}, ("output",)),
        ({"base": 42}, ("base",)),
        ({"executor": 42}, ("executor",)),
        ({"on_record": 42}, ("on_record",)),
        ({"resume": "no", "output": "x"}, ("resume",)),
    ],
)
def test_campaign_options_are_refused_before_any_case(
    options: dict[str, Any], words: tuple[str]
) -> None:
    refused(lambda: pirate_bt.run_campaign(_campaign(), **options), *words)


def test_a_campaign_spec_of_the_wrong_kind_is_an_input_error_and_a_type_error() -> None:
    for spec in (42, None, b"x"):
        text = refused(lambda s=spec: pirate_bt.run_campaign(s), "spec")
        assert "CampaignSpec" in text
    with pytest.raises(TypeError):
        pirate_bt.run_campaign(42)  # type: ignore[arg-type]
    refused(lambda: pirate_bt.run_campaign("x" * 100_000), "spec", "characters")


# -- a regression met on the way


def test_a_way_back_from_the_start_is_no_error() -> None:
    # return_on_stop after a stop before the robot moved: an empty way back was built
    # and refused as "<dict>:1:1: needs a list of children"
    result = pirate_bt.simulate_mission("lab", return_on_stop=True, max_time=0.5)
    assert result.returned is None
    assert any("still at the start" in line for line in result.replans)


def test_a_missing_scheduler_file_is_waited_for_only_as_long_as_asked(tmp_path: Path) -> None:
    pytest.importorskip("distributed")
    # Dask's client waits for a scheduler file for ever
    missing = tmp_path / "scheduler.json"
    options = {"scheduler_file": missing, "scheduler_timeout": 0.2}
    refused(lambda: pirate_bt.run_campaign(_campaign(), **options), "scheduler_file", "0.2 s")
    options["scheduler_file"] = tmp_path
    refused(lambda: pirate_bt.run_campaign(_campaign(), **options), "directory")


def test_a_survey_extension_with_a_name_too_long_is_named() -> None:
    refused(lambda: pirate_bt.survey(extend="x" * 300), "extend", "too long")


# -- found by a docs-driven probe (2026-11-29): wrong types at three more doors -------


@pytest.mark.parametrize(
    ("args", "words"),
    [
        ((5, "x.route"), ("parse_route: text: give text, not 5", "load_route")),
        ((None, "x.route"), ("parse_route: text: give text, not None",)),
        ((b"forward 1 m\n", "x.route"), ("parse_route: text:", "b'forward 1 m")),
        (("forward 1 m\n", 5), ("parse_route: source: give text, not 5",)),
        (("forward 1 m\n", "x.route", 3), ("parse_route: name: give text or None, not 3",)),
    ],
)
def test_parse_route_names_an_argument_of_the_wrong_type(
    args: tuple[Any, ...], words: tuple[str]
) -> None:
    from pirate_bt.errors import ArgumentTypeError
    from pirate_bt.task import parse_route

    refused(lambda: parse_route(*args), *words, kind=ArgumentTypeError)


def test_building_a_node_in_python_names_a_wrong_context_robot_or_name() -> None:
    from pirate_bt.behaviours.base import BuildContext
    from pirate_bt.behaviours.primitives import Clamp
    from pirate_bt.errors import ArgumentTypeError

    kw = {"half": "rear", "torque": "0.5 N*m"}
    refused(
        lambda: Clamp.build("c", 5, **kw),
        "Clamp: context: give a BuildContext",
        "not 5",
        kind=ArgumentTypeError,
    )  # type: ignore[arg-type]
    refused(
        lambda: Clamp.checked_params("c", kw, robot="x"),  # type: ignore[arg-type]
        "Clamp.checked_params: robot: give a RobotDescription",
        "not 'x'",
        kind=ArgumentTypeError,
    )
    refused(
        lambda: Clamp.build("c", BuildContext(robot="x"), **kw),  # type: ignore[arg-type]
        "robot: give a RobotDescription",
        kind=ArgumentTypeError,
    )
    refused(
        lambda: Clamp.build(5, BuildContext(), **kw),
        "name: give the node's name as text",
        kind=ArgumentTypeError,
    )  # type: ignore[arg-type]
    assert Clamp.build("c", BuildContext(), **kw).name == "c"


@pytest.mark.parametrize("network", [5, b"straight", None, 1.5])
def test_simulate_tree_names_a_network_of_the_wrong_type(network: Any) -> None:
    refused(
        lambda: pirate_bt.simulate_tree("bend", network=network, params={"roll": "90 deg"}),
        "simulate_tree: network: give a bundled name, a network file or a Network",
    )


def test_a_navigation_refused_before_it_ran_leaves_no_trace_folder(tmp_path: Path) -> None:
    from pirate_bt.sim.faults import FaultTargetError

    refused(lambda: pirate_bt.navigate("gaol", sim="straight", trace=tmp_path / "a"), "gaol")
    refused(
        lambda: pirate_bt.survey(sim="straight", trace=tmp_path / "b", faults="motor_stall:zz@1s"),
        "unknown motor 'zz'",
        kind=FaultTargetError,
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("options", "words"),
    [
        ({"network": "/nonexistent.yaml"}, ("/nonexistent.yaml", "no such file")),
        ({"faults": "bogus:x@1s"}, ("unknown fault kind 'bogus'",)),
        ({"faults": "motor_stall:zz@1s"}, ("unknown motor 'zz'",)),
    ],
)
def test_a_tree_that_needs_no_robot_still_checks_the_world_it_was_given(
    options: dict[str, Any], words: tuple[str]
) -> None:
    # a tree of waits runs with no simulator, and took any network and faults, exit 0
    tree = {"name": "t", "root": {"type": "wait", "name": "w", "duration": "1 s"}}
    refused(lambda: pirate_bt.simulate_tree(tree, **options), *words)
    assert pirate_bt.simulate_tree(tree, network="lab", faults="drop=0.1").succeeded


def test_a_fault_in_a_network_file_naming_no_motor_names_the_network_file(tmp_path: Path) -> None:
    from pirate_bt.sim.faults import FaultTargetError

    network = tmp_path / "nf.yaml"
    network.write_text(
        (Path(__file__).parent.parent / "scenarios" / "straight.yaml").read_text()
        + "faults:\n  - {kind: motor_stall, target: nope, at: 1 s}\n"
    )
    text = refused(
        lambda: pirate_bt.simulate_tree("straight", network=network, params=PARAMS),
        f"{network}:11:25: faults: fault motor_stall: unknown motor 'nope'",
        kind=FaultTargetError,
    )
    assert text.startswith(str(network))
