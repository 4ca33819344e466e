"""The front door: ``import pirate_bt`` runs trees and missions and says why they ended."""

from __future__ import annotations

import re
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import py_trees
import pytest
from py_trees.common import Status

import pirate_bt
from pirate_bt.errors import InputError, ValidationFailed

ROOT = Path(__file__).resolve().parents[1]
STALL = "motor_stall:bend_3_drive@5s+20s"


# -- trees ---------------------------------------------------------------------------


def test_a_stalled_bend_says_why_and_where() -> None:
    result = pirate_bt.simulate_tree(
        "bend", network="bend-right", params={"roll": "90 deg"}, faults=STALL
    )
    assert result.status == "failure" and not result.succeeded
    # the deepest cause, not "tree failed after N ticks" nor the recovery's wrapper text
    assert result.why.startswith("stall: bend_3_drive draws 1.50 A at 0 mm/s"), result.why
    assert result.failing_node == "bend/pass bend/confirm enter/front into turn"
    assert result.safe_state and result.exit_code == 1
    assert result.target == "simulator: bend-right"
    assert result.why in result.summary() and result.failing_node in result.summary()
    assert result.counters.violations == 0 and result.counters.damage == 0
    assert result.counters.safe_states == 1  # entered once, however many stops followed


def test_a_bend_that_passes_reports_success_and_counters() -> None:
    result = pirate_bt.simulate_tree(
        ROOT / "trees" / "bend.yaml", network="bend-right", params={"roll": 1.5707963}
    )
    assert result.succeeded and result.failing_node is None and result.exit_code == 0
    assert result.ticks > 100 and result.sim_time_s > 5
    assert result.counters.refusals == 0 and result.counters.violations == 0
    row = result.as_dict()
    assert row["status"] == "success" and row["counters"]["violations"] == 0


def test_a_time_limit_names_the_node_still_running() -> None:
    result = pirate_bt.simulate_tree("straight", params={"distance": "4 m"}, max_time="4 s")
    assert result.stop is pirate_bt.StopReason.TIME_LIMIT
    assert result.why.startswith("time limit of 4 s reached")
    assert result.failing_node == "straight/pass straight/confirm drive/drive straight"
    assert result.failing_node in result.why


def test_the_supervisor_stopping_first_is_the_cause() -> None:
    # the link falls silent: the supervisor stops on the link's silence (its readings
    # stale, nothing heard since); what the tree did after
    # (commands refused in the safe state) is a consequence, not the cause
    result = pirate_bt.simulate_tree(
        "straight", params={"distance": "2 m"}, faults="link_loss@3s+3s"
    )
    assert not result.succeeded and result.safe_state
    assert result.why.startswith("link_silent: nothing heard from the bridge"), result.why
    assert result.exit_code == 3  # a link error


def test_a_tree_of_generic_leaves_needs_no_robot() -> None:
    tree = {"name": "pause", "root": {"type": "wait", "name": "wait", "duration": "1 s"}}
    result = pirate_bt.simulate_tree(tree)
    assert result.succeeded and result.target == "no robot"
    assert 1.0 <= result.sim_time_s < 1.2


def test_bad_parameters_are_refused_before_anything_connects() -> None:
    with pytest.raises(ValidationFailed) as err:
        pirate_bt.simulate_tree("bend", network="bend-right", params={"roll": "9 mm"})
    # located at this caller, named by the parameter
    assert "test_api.py:" in str(err.value) and "roll" in str(err.value)


def test_params_for_a_tree_already_built_are_refused() -> None:
    tree = pirate_bt.load_tree("bend", params={"roll": "90 deg"})
    with pytest.raises(InputError, match="already built tree"):
        pirate_bt.simulate_tree(tree, params={"roll": "0 deg"})


def test_a_loaded_tree_runs_and_renders(tmp_path: Path) -> None:
    tree = pirate_bt.load_tree("bend", params={"roll": "90 deg"})
    assert tree.needs_robot
    result = pirate_bt.simulate_tree(tree, network="bend-right")
    assert result.succeeded
    out = pirate_bt.render_tree(tree, tmp_path / "bend.dot")
    assert "front into turn" in out.read_text()


# -- connect and trees built in Python --------------------------------------------------


class _HasState(py_trees.behaviour.Behaviour):
    """A plain py_trees condition of our own: the robot's state has arrived."""

    def __init__(self, name: str, supervisor: Any) -> None:
        super().__init__(name)
        self.supervisor = supervisor
        self.seen = False

    def update(self) -> Status:
        self.seen = self.supervisor.state() is not None
        return Status.SUCCESS if self.seen else Status.RUNNING


def test_connect_runs_a_tree_built_in_python() -> None:
    from pirate_bt.behaviours.primitives import Clamp, MoveFrontClear, Unclamp

    with pirate_bt.connect("sim:straight") as robot:
        ctx = robot.context()
        root = py_trees.composites.Sequence("clamp and release", memory=True)
        root.add_children(
            [
                has_state := _HasState("state arrived", robot.supervisor),
                MoveFrontClear.build("front clear", ctx),
                Clamp.build("clamp front", ctx, half="front", torque="0.5 N*m"),
                Clamp.build("clamp rear", ctx, half="rear", torque="0.5 N*m"),
                Unclamp.build("release rear", ctx, half="rear"),
            ]
        )
        result = robot.run(root, max_time="30 s")
        assert result.succeeded, result.why
        assert has_state.seen and robot.counters().refusals == 0
    assert robot.supervisor is not None and "closed" in repr(robot)


def test_a_tree_built_offline_is_bound_to_the_connection() -> None:
    from pirate_bt.behaviours.base import BuildContext
    from pirate_bt.behaviours.primitives import Clamp

    robot_description = pirate_bt.load_robot()
    offline = Clamp.build("clamp rear", BuildContext(robot=robot_description), half="rear",
                          torque="0.5 N*m")  # fmt: skip
    result = pirate_bt.simulate_tree(offline)
    assert result.succeeded, result.why
    assert result.target == "simulator: straight"


def test_an_over_limit_node_built_in_python_is_refused_at_the_caller() -> None:
    from pirate_bt.behaviours.primitives import Clamp

    with pirate_bt.connect("sim:straight") as robot, pytest.raises(ValidationFailed) as err:
        Clamp.build("clamp front", robot.context(), half="front", torque=50)
    assert "test_api.py:" in str(err.value) and "torque" in str(err.value)


def test_planner_code_that_raises_leaves_the_robot_safe() -> None:
    with pytest.raises(RuntimeError), pirate_bt.connect("sim") as robot:
        supervisor = robot.supervisor
        raise RuntimeError("planner bug")
    assert supervisor.in_safe_state
    assert supervisor.safe_state_reason == "planner code raised RuntimeError: planner bug"


@pytest.mark.parametrize(
    ("target", "message"),
    [
        ("nowhere", "neither a network"),
        ("", "empty target"),
        (42, "cannot connect to an int"),
    ],
)
def test_a_bad_target_is_one_clear_error(target: Any, message: str) -> None:
    with pytest.raises(InputError, match=message):
        pirate_bt.connect(target)


def test_run_tree_wants_a_port_and_simulator_faults_want_the_simulator() -> None:
    with pytest.raises(InputError, match="not a serial port"):
        pirate_bt.run_tree("straight", port="lab")
    with pytest.raises(InputError, match="need the simulator"):
        pirate_bt.connect("socket://127.0.0.1:9", faults=STALL)


def test_the_first_safe_state_cause_survives_a_later_stop() -> None:
    with pirate_bt.connect("sim") as robot:
        robot.supervisor.safe_state("bend PAB failed: stall")
        robot.supervisor.safe_state("run failed")  # the README's old pattern
        assert robot.supervisor.safe_state_reason == "bend PAB failed: stall"
        robot.supervisor.resume()
        robot.supervisor.safe_state("second episode")
        assert robot.supervisor.safe_state_reason == "second episode"


# -- missions ----------------------------------------------------------------------------


def test_a_mission_lists_every_pab_with_its_outcome_and_cause(tmp_path: Path) -> None:
    plan = pirate_bt.plan_route("bend-right.route")
    result = pirate_bt.simulate_mission(
        plan, faults="motor_stall:bend_3_drive@3s+60s", output=tmp_path / "out"
    )
    assert result.status == "failure" and result.safe_state
    assert [p.label for p in result.pabs] == [p.label(i) for i, p in enumerate(plan.pabs, 1)]
    first, *rest = result.pabs
    assert first.outcome == "failure" and first.kind == "straight"
    assert first.why.startswith("stall: bend_3_drive draws")
    assert first.start_s == 0.0 and first.end_s is not None and first.end_s > 3
    assert first.failing_node is not None and first.failing_node.endswith("drive straight")
    assert all(p.outcome == "not run" and p.start_s is None for p in rest)
    assert result.why == first.why and result.failing_node == first.failing_node
    report = (tmp_path / "out" / "report.md").read_text()
    assert "## PABs" in report and "stall: bend_3_drive draws" in report
    assert f"**Failing node:** `{first.failing_node}`" in report


def test_a_successful_mission_times_each_pab() -> None:
    result = pirate_bt.simulate_mission("t-joint.route")
    assert result.succeeded and result.failing_node is None
    assert [p.outcome for p in result.pabs] == ["success"] * len(result.pabs)
    ends = [p.end_s for p in result.pabs]
    starts = [p.start_s for p in result.pabs]
    assert starts[1:] == ends[:-1] and ends[-1] == pytest.approx(result.sim_time_s, abs=0.1)
    assert result.counters.violations == 0 and result.wall_s > 0


def _swapped_lab(tmp_path: Path) -> Path:
    """The lab as built with tee-1's main and branch swapped: 'straight' at the tee
    leads into the service pipe, and the bend the map has next is not there."""
    text = (ROOT / "scenarios" / "lab.yaml").read_text()
    main = textwrap.dedent("""\
      - id: tee-1
        type: tee
        branch:
          direction: left
          segments:
            - {id: service-1, type: straight, length: 3 m}
            - {id: service-1-bend, type: bend, direction: up, radius: 90 mm}
            - {id: service-1-up, type: straight, length: 1 m}
      - {id: run-c, type: straight, length: 4 m, slope: 5 deg}
      - {id: level-c, type: straight, length: 1 m, slope: 0 deg}
      - {id: bend-b, type: bend, direction: left, radius: 90 mm}
    """)
    swapped = textwrap.dedent("""\
      - id: tee-1
        type: tee
        branch:
          direction: left
          segments:
            - {id: run-c, type: straight, length: 4 m, slope: 5 deg}
            - {id: level-c, type: straight, length: 1 m, slope: 0 deg}
            - {id: bend-b, type: bend, direction: left, radius: 90 mm}
      - {id: service-1, type: straight, length: 3 m}
      - {id: service-1-bend, type: bend, direction: up, radius: 90 mm}
      - {id: service-1-up, type: straight, length: 1 m}
    """)
    indented = textwrap.indent(main, "  ")
    assert indented in text
    body = text.replace(indented, textwrap.indent(swapped, "  "))
    body = body[: body.index("  - {id: run-d,")].replace("name: lab", "name: lab-swapped")
    path = tmp_path / "lab-swapped.yaml"
    path.write_text(body)
    return path


def test_a_pipe_not_as_drawn_is_named_as_the_cause(tmp_path: Path) -> None:
    result = pirate_bt.simulate_mission("lab.route", truth=_swapped_lab(tmp_path))
    assert not result.succeeded and result.safe_state
    # the leg after tee-1 is blocked 3 m on, where the map has no turn within the
    # matcher's reach: the disagreement is named there, after the tee, and no turn is tried
    assert result.why.startswith("belief and map disagree: the pipe blocked the robot at")
    after = re.search(r"(\d+\.\d+) m after 'tee-1'", result.why)
    assert after is not None and 2.8 <= float(after.group(1)) <= 3.2, result.why
    assert "'tee-1' was passed straight through: are its main and branch swapped" in result.why
    d = result.disagreement
    assert d is not None and d.feature == "bend-b" and d.expected is not None
    assert "blocking" in (d.sensed or "")
    bend_b = next(p for p in result.pabs if "bend-b" in p.label)
    assert bend_b.outcome == "not run"
    assert result.counters.violations == 0 and result.counters.damage == 0


def test_a_plan_is_not_planned_again_and_takes_no_map() -> None:
    plan = pirate_bt.plan_route("straight.route")
    with pytest.raises(InputError, match="already planned"):
        pirate_bt.simulate_mission(plan, network="lab")


# -- library manners ---------------------------------------------------------------------


def _python(code: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def test_the_library_prints_nothing_on_the_callers_stderr() -> None:
    done = _python(f"""
        import pirate_bt
        r = pirate_bt.simulate_tree("bend", network="bend-right", params={{"roll": "90 deg"}},
                                    faults="{STALL}")
        print(r.why)
    """)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("stall: bend_3_drive")
    assert done.stderr == ""  # warnings go to the pirate_bt logger, which has a NullHandler


def test_import_is_light_and_every_public_name_resolves() -> None:
    done = _python("""
        import sys, pirate_bt
        heavy = [m for m in ("py_trees", "pydantic", "graphviz") if m in sys.modules]
        assert not heavy, heavy
        for name in pirate_bt.__all__:
            getattr(pirate_bt, name)
        print(len(pirate_bt.__all__))
    """)
    assert done.returncode == 0, done.stderr
    assert int(done.stdout) >= 30


def test_all_lists_exactly_the_exports() -> None:
    exports = pirate_bt._EXPORTS  # type: ignore[attr-defined]
    assert sorted(pirate_bt.__all__) == sorted(["__version__", *exports])
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        pirate_bt.nope  # type: ignore[attr-defined]  # noqa: B018


def test_the_protective_layer_refuses_a_python_built_tree_and_says_so() -> None:
    from pirate_bt.behaviours.primitives import Unclamp

    with pirate_bt.connect("sim:straight") as robot:
        # releasing the rear half while the front one holds nothing: refused, not sent
        result = robot.run(Unclamp.build("release rear", robot.context(), half="rear"))
    assert not result.succeeded and result.safe_state
    assert result.why.startswith("refused unclamp(rear): other_half_not_clamped")
    assert result.failing_node == "release rear"
    assert result.counters.refusals >= 1


def test_every_module_says_what_it_exports() -> None:
    import ast
    import importlib

    for path in sorted((ROOT / "pirate_bt").rglob("*.py")):
        if path.name == "__main__.py":
            continue
        module = ".".join(path.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")
        tree = ast.parse(path.read_text(encoding="utf-8"))
        declared = any(
            (isinstance(node, ast.Assign) and any(
                isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets))
            or (isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name)
                and node.target.id == "__all__")
            for node in tree.body
        )  # fmt: skip
        assert declared, f"{module} has no __all__"
        if module.startswith("pirate_bt.cli.console") or module == "pirate_bt.trace.sink":
            continue  # imported by their own processes and app, not by planner code
        mod = importlib.import_module(module)
        missing = [n for n in mod.__all__ if not hasattr(mod, n)]
        assert not missing, f"{module}.__all__ names {missing}, which it does not define"


def test_bundled_names_mean_the_right_file() -> None:
    # "lab" as a route is scenarios/lab.route, not the network lab.yaml
    assert pirate_bt.load_route("lab").source.endswith("lab.route")
    assert pirate_bt.plan_route("lab").route.source.endswith("lab.route")
    with pytest.raises(InputError, match="no network 'nowhere'; bundled networks: "):
        pirate_bt.simulate_tree("straight", network="nowhere", params={"distance": "1 m"})


def test_a_trace_keeps_the_first_cause(tmp_path: Path) -> None:
    path = tmp_path / "bend.jsonl"
    result = pirate_bt.simulate_tree(
        "bend", network="bend-right", params={"roll": "90 deg"}, faults=STALL, trace=path
    )
    trace = pirate_bt.read_trace(path)
    assert trace.outcome == "failure" and trace.why == result.why


def test_a_runner_of_your_own_is_supervised_and_manual_mode_pauses_it() -> None:
    tree = {"name": "pause", "root": {"type": "wait", "name": "wait", "duration": "0.5 s"}}
    with pirate_bt.connect("sim", mode="manual") as robot:
        runner = robot.runner(tree, max_time="2 s")
        loop = runner.run()
        # the operator holds the robot: the tree never ticks, the time limit still counts
        assert loop.paused_ticks == loop.ticks and loop.reason is pirate_bt.StopReason.TIME_LIMIT
        assert robot.supervisor.in_safe_state  # a run that did not succeed ends safe
    with pytest.raises(InputError, match="mode: 'sideways' is not one of"):
        pirate_bt.connect("sim", mode="sideways")


def test_an_estop_during_a_run_is_its_first_cause() -> None:
    def observe(runner: Any, connection: Any) -> None:
        def stop_at_tick_40(info: Any) -> None:
            if info.tick == 40:
                connection.supervisor.estop("operator pressed the mushroom")

        runner.add_pre_tick(stop_at_tick_40)

    result = pirate_bt.simulate_tree(
        "straight", params={"distance": "2 m"}, max_time="10 s", observe=observe
    )
    assert not result.succeeded
    assert result.why == "e-stop: operator pressed the mushroom"
    assert result.counters.estops == 1


def test_the_api_reference_documents_every_public_name() -> None:
    page = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    documented = {line.split()[1].rsplit(".", 1)[-1] for line in page.splitlines()
                  if line.startswith("::: ")}  # fmt: skip
    missing = sorted(set(pirate_bt.__all__) - documented)
    assert not missing, f"docs/api.md has no reference for {missing}"


def test_the_file_converters_are_in_pirate_bt_and_pirate_bt_interop() -> None:
    # api.md listed them under pirate_bt.interop, which exported nothing
    done = _python("""
        import sys, pirate_bt, pirate_bt.interop as interop
        names = ["export_xml", "import_xml", "export_btlog", "read_btlog", "export_mcap",
                 "export_rosbag2", "load_xml_tree"]
        assert sorted(interop.__all__) == sorted(names)
        for name in names:
            assert getattr(interop, name) is getattr(pirate_bt, name), name
        from pirate_bt.interop import export_xml  # noqa: F401
        print("ok")
    """)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "ok"
