"""Guards read the state value they name, say why they stopped a child, and name themselves.

Written with the mutation run (docs/testing.md): every state value of the guards'
vocabulary is read once through a guard, every feedback message a user sees in a
trace or the console is checked word for word, and the nodes planner code builds get
the names and the robot they show in diagrams.
"""

from __future__ import annotations

import math

import py_trees
import pytest
from py_trees.common import Status

from pirate_bt.behaviours.guards import (
    Comparison,
    FailureIf,
    IsClamped,
    LinkHealthy,
    ModeIs,
    SkipIf,
    StateFresh,
    While,
    failure_if,
    is_clamped,
    link_healthy,
    mode_is,
    skip_if,
    state_fresh,
    while_,
)
from pirate_bt.clock import SimClock
from pirate_bt.robot import Half, load_robot
from pirate_bt.safety import Mode, Supervisor
from pirate_bt.safety.testing import FakePort
from pirate_bt.treefile.loader import load_tree

ROBOT = load_robot()


@pytest.fixture(autouse=True)
def clean_blackboard() -> None:
    py_trees.blackboard.Blackboard.clear()


@pytest.fixture
def clock() -> SimClock:
    return SimClock(5.0)


@pytest.fixture
def port(clock: SimClock) -> FakePort:
    return FakePort(ROBOT, clock)


@pytest.fixture
def sup(port: FakePort, clock: SimClock) -> Supervisor:
    return Supervisor(port, clock)


class Once(py_trees.behaviour.Behaviour):
    """Succeeds at once; counts its ticks."""

    def __init__(self) -> None:
        super().__init__("once")
        self.count = 0

    def update(self) -> Status:
        self.count += 1
        return Status.SUCCESS


def tick(node: py_trees.behaviour.Behaviour) -> Status:
    node.tick_once()
    status: Status = node.status
    return status


# -- every state value of the vocabulary, read through a guard ----------------------------

# (state value, channels to set on the fake robot, the SI value the guard must read)
READINGS = [
    ("imu.roll", {"imu__roll": 0.25}, 0.25),
    ("imu.pitch", {"imu__pitch": -0.5}, -0.5),
    ("imu.yaw", {"imu__yaw": 1.25}, 1.25),
    ("joint_angle.bend_2", {"bend_2_angle": 0.75}, 0.75),
    ("clamp_force.bend_3", {"bend_3_spring": 6.5}, 6.5),
    ("rotation", {"rotation_angle": -1.5}, -1.5),
    ("front_tilt", {"front_tilt_angle": 0.5}, 0.5),
    ("drive_velocity.bend_4_drive", {"bend_4_drive__velocity": 0.0625}, 0.0625),
    ("motor_current.bend_1_drive", {"bend_1_drive__current": 0.375}, 0.375),
]


def _set(port: FakePort, values: dict[str, float]) -> None:
    for key, value in values.items():
        port.set(**{key.replace("__", "."): value})


@pytest.mark.parametrize(("path", "channels", "expected"), READINGS)
def test_a_guard_reads_the_state_value_it_names(
    sup: Supervisor, port: FakePort, path: str, channels: dict[str, float], expected: float
) -> None:
    _set(port, channels)
    child = Once()
    guard = failure_if(child, {"state": path, "op": "==", "value": expected}, sup)
    assert tick(guard) == Status.FAILURE and child.count == 0
    assert guard.feedback_message == f"{path} == {expected}"
    other = failure_if(child, {"state": path, "op": "==", "value": expected + 1.0}, sup)
    assert tick(other) == Status.SUCCESS and child.count == 1
    assert other.feedback_message == f"not ({path} == {expected + 1.0}): it is {expected!r}"


def test_drive_velocity_alone_is_the_mean_of_the_wheels(sup: Supervisor, port: FakePort) -> None:
    motors = [m.name for m in ROBOT.drive_motors()]
    for i, name in enumerate(motors):
        port.set(**{f"{name}.velocity": 0.01 * (i + 1)})
    mean = sum(0.01 * (i + 1) for i in range(len(motors))) / len(motors)
    child = Once()
    guard = skip_if(child, {"state": "drive_velocity", "op": "==", "value": mean}, sup)
    assert tick(guard) == Status.SUCCESS and child.count == 0  # skipped: it holds
    assert guard.feedback_message == f"drive_velocity == {mean}"


@pytest.mark.parametrize(
    "path", ["joint_angle.no_such_module", "motor_current.no_such_motor", "rotation", "front_tilt"]
)
def test_a_value_with_no_reading_fails_the_guard(
    sup: Supervisor, port: FakePort, path: str
) -> None:
    """A missing reading is not a value: the guard fails, whichever way the comparison goes."""
    for channel in ("rotation_angle", "front_tilt_angle"):
        del port.values[channel]
    child = Once()
    for guard in (
        failure_if(child, {"state": path, "op": "==", "value": 0.0}, sup),
        skip_if(child, {"state": path, "op": "!=", "value": 0.0}, sup),
    ):
        assert tick(guard) == Status.FAILURE
        assert guard.feedback_message == f"{path} has no reading"
    assert child.count == 0


def test_a_guard_with_no_state_yet_fails(clock: SimClock) -> None:
    class Silent(FakePort):
        def state(self) -> None:  # type: ignore[override]
            return None

    sup = Supervisor(Silent(ROBOT, clock), clock)
    guard = failure_if(Once(), {"state": "imu.pitch", "op": ">", "value": 0.0}, sup)
    assert tick(guard) == Status.FAILURE
    assert guard.feedback_message == "imu.pitch has no reading"


def test_half_mode_and_link_values(sup: Supervisor, port: FakePort) -> None:
    port.clamp_half(Half.FRONT)
    condition = [
        {"state": "half.front", "value": "clamped"},
        {"state": "half.rear", "value": "unclamped"},
        {"state": "mode", "value": "autonomous"},
        {"state": "link.healthy", "value": True},
    ]
    guard = failure_if(Once(), condition, sup)
    assert tick(guard) == Status.FAILURE
    assert guard.feedback_message == (
        "half.front == clamped and half.rear == unclamped and mode == autonomous"
        " and link.healthy == True"
    )
    port.connected = False
    assert tick(failure_if(Once(), condition, sup)) == Status.SUCCESS


def test_a_guard_without_a_robot_fails_and_says_so() -> None:
    guard = skip_if(Once(), {"state": "imu.pitch", "op": ">", "value": 0.0})
    assert tick(guard) == Status.FAILURE
    assert guard.feedback_message == "no robot attached"


def test_a_comparison_that_cannot_be_made_fails_the_guard() -> None:
    py_trees.blackboard.Blackboard.set("/word", "seven")
    guard = failure_if(Once(), {"blackboard": "word", "op": "<", "value": 7})
    assert tick(guard) == Status.FAILURE
    assert guard.feedback_message == "cannot compare 'seven' < 7"


def test_a_blackboard_guard_names_the_key_in_its_messages() -> None:
    child = Once()
    guard = while_(child, {"blackboard": "/go", "value": True})
    assert tick(guard) == Status.FAILURE
    assert guard.feedback_message == "blackboard go is not set"
    py_trees.blackboard.Blackboard.set("/go", False)
    assert tick(guard) == Status.SUCCESS and child.count == 0
    assert guard.feedback_message == "not (blackboard /go == True): it is False"


# -- the vocabulary, checked as a file is loaded --------------------------------------------


def test_per_module_and_per_motor_values_are_accepted() -> None:
    for path in ("joint_angle.bend_1", "clamp_force.bend_4", "motor_current.rotate"):
        Comparison.model_validate({"state": path, "op": ">", "value": 1.0})


@pytest.mark.parametrize("path", ["joint_angle.", "joint_angle", "imu.", "half.", "imu.pitch.x"])
def test_an_incomplete_state_value_is_refused_with_the_vocabulary(path: str) -> None:
    with pytest.raises(ValueError) as caught:
        Comparison.model_validate({"state": path, "value": 1.0})
    text = str(caught.value)
    assert (
        f"unknown state value {path!r}; use one of: clamp_force.<bend module>, drive_velocity,"
        in (text)
    )


def test_a_unit_error_in_a_comparison_says_what_is_wrong() -> None:
    with pytest.raises(ValueError, match=r"'10 mm' is a length, but an angle is expected"):
        Comparison.model_validate({"state": "imu.pitch", "value": "10 mm"})
    with pytest.raises(ValueError, match=r"'10' needs a unit"):
        Comparison.model_validate({"state": "imu.pitch", "value": "10"})


def test_comparisons_read_as_written() -> None:
    state = Comparison.model_validate({"state": "imu.pitch", "op": ">", "value": "10 deg"})
    board = Comparison.model_validate({"blackboard": "/roll", "op": "<=", "value": 1})
    assert str(state) == "imu.pitch > 10 deg"
    assert str(board) == "blackboard /roll <= 1"
    assert state.si_value == pytest.approx(math.radians(10))


# -- the conditions' messages ----------------------------------------------------------------


def test_conditions_without_a_robot_fail_and_say_so() -> None:
    for node in (
        is_clamped(None, Half.REAR),
        link_healthy(None),
        state_fresh(None),
        mode_is(None, Mode.AUTONOMOUS),
    ):
        assert tick(node) == Status.FAILURE
        assert node.feedback_message == "no robot attached"


def test_condition_messages(sup: Supervisor, port: FakePort, clock: SimClock) -> None:
    clamped = is_clamped(sup, Half.REAR)
    assert tick(clamped) == Status.FAILURE and clamped.feedback_message == "rear half unclamped"
    link = link_healthy(sup)
    assert tick(link) == Status.SUCCESS and link.feedback_message == "link healthy"
    port.connected = False
    assert tick(link) == Status.FAILURE
    assert link.feedback_message == sup.link_problem().detail  # type: ignore[union-attr]
    mode = mode_is(sup, Mode.MANUAL)
    assert tick(mode) == Status.FAILURE and mode.feedback_message == "mode autonomous"
    fresh = state_fresh(sup)
    assert tick(fresh) == Status.SUCCESS and fresh.feedback_message == "fresh"
    port.freeze("bend_1_spring", "bend_2_angle")
    clock.advance(1.0)
    assert tick(fresh) == Status.FAILURE
    assert fresh.feedback_message == "stale: bend_1_spring, bend_2_angle"


def test_state_fresh_on_named_channels(sup: Supervisor, port: FakePort, clock: SimClock) -> None:
    node = state_fresh(sup, ["rotation_angle", "bend_3_angle"])
    port.freeze("rotation_angle")
    clock.advance(1.0)
    assert tick(node) == Status.FAILURE
    assert node.feedback_message == "stale: rotation_angle"


def test_state_fresh_on_named_channels_with_no_state_yet(clock: SimClock) -> None:
    class Silent(FakePort):
        def state(self) -> None:  # type: ignore[override]
            return None

    sup = Supervisor(Silent(ROBOT, clock), clock)
    node = state_fresh(sup, ["rotation_angle"])
    assert tick(node) == Status.FAILURE
    assert node.feedback_message == "no state yet"


def test_conditions_succeed_or_fail_and_never_run() -> None:
    """A condition can fail (a selector's next child runs) and succeed (a sequence's does)."""
    tree = {
        "name": "either way",
        "root": {
            "type": "sequence",
            "children": [
                {
                    "type": "selector",
                    "children": [{"type": "is_clamped", "half": "rear"}, {"type": "success"}],
                },
                {"type": "is_clamped", "half": "front"},
                {"type": "success", "name": "after"},
            ],
        },
    }
    assert load_tree(tree, robot=ROBOT).warnings == []
    for cls in (IsClamped, LinkHealthy, StateFresh, ModeIs):
        assert cls.outcomes(None) == frozenset({"success", "failure"})


# -- what planner code builds ------------------------------------------------------------------


def test_planner_built_conditions_are_named_and_bound(sup: Supervisor) -> None:
    nodes = {
        "is_clamped(rear)": is_clamped(sup, Half.REAR),
        "link healthy": link_healthy(sup),
        "state fresh": state_fresh(sup),
        "mode_is(manual)": mode_is(sup, Mode.MANUAL),
    }
    for name, node in nodes.items():
        assert node.name == name
        assert node.context.robot is ROBOT and node.context.clock is sup.clock
        assert node.context.supervisor is sup
    assert is_clamped(sup, Half.FRONT, "front?").name == "front?"
    assert mode_is(sup, Mode.MANUAL, "who").name == "who"
    assert link_healthy(sup).params is not None


def test_planner_built_guards_are_named_and_bound(sup: Supervisor) -> None:
    condition = {"state": "mode", "value": "manual"}
    child = Once()
    for builder, cls in ((skip_if, SkipIf), (failure_if, FailureIf), (while_, While)):
        node = builder(child, condition, sup)
        assert type(node) is cls and node.name == f"{cls.__name__}(once)"
        assert node.context.robot is ROBOT and node.context.clock is sup.clock
        assert node.params.comparisons == [Comparison.model_validate(condition)]
        named = builder(Once(), condition, sup, "named")
        assert named.name == "named"
    built = Comparison.model_validate(condition)
    assert failure_if(Once(), built, sup).params.comparisons[0] is built
    offline = skip_if(Once(), condition).context
    assert offline.robot is None and offline.supervisor is None


def test_a_guard_that_stops_its_child_ends_it_with_its_own_status(
    sup: Supervisor, port: FakePort
) -> None:
    """The child is told how its guard ended (a halted child sees INVALID, as py_trees does)."""

    class Recorder(py_trees.behaviour.Behaviour):
        def __init__(self) -> None:
            super().__init__("recorder")
            self.ends: list[Status] = []
            self.starts = 0

        def initialise(self) -> None:
            self.starts += 1

        def update(self) -> Status:
            return Status.RUNNING

        def terminate(self, new_status: Status) -> None:
            self.ends.append(new_status)

    port.clamp_half(Half.REAR)
    child = Recorder()
    guard = while_(child, {"state": "half.rear", "value": "clamped"}, sup)
    ends: list[Status] = []
    guard.terminate = ends.append  # type: ignore[method-assign]
    assert tick(guard) == Status.RUNNING
    assert tick(guard) == Status.RUNNING and child.starts == 1
    port.free_half(Half.REAR)
    assert tick(guard) == Status.FAILURE
    assert ends == [Status.FAILURE] and child.ends == [Status.INVALID]
    assert guard.feedback_message == "not (half.rear == clamped): it is 'unclamped'"


def test_a_guard_whose_child_finishes_ends_with_the_child_status(sup: Supervisor) -> None:
    child = Once()
    guard = failure_if(child, {"state": "mode", "value": "manual"}, sup)
    ends: list[Status] = []
    guard.terminate = ends.append  # type: ignore[method-assign]
    assert tick(guard) == Status.SUCCESS and child.count == 1
    assert ends == [Status.SUCCESS]


def test_a_guard_reads_the_blackboard_as_itself() -> None:
    guard = skip_if(Once(), {"blackboard": "/go", "value": True}, name="go?")
    assert "go?" in py_trees.blackboard.Blackboard.clients.values()
    assert guard.evaluator.client.name == "go?"


def test_a_context_whose_supervisor_is_something_else_is_no_robot() -> None:
    from pirate_bt.behaviours.base import BuildContext
    from pirate_bt.behaviours.guards import IsClampedParams, PreconditionParams

    context = BuildContext(supervisor=object())  # e.g. a port handed over by mistake
    node = IsClamped("clamped?", IsClampedParams(half=Half.REAR), context)
    assert tick(node) == Status.FAILURE and node.feedback_message == "no robot attached"
    params = PreconditionParams(condition={"state": "mode", "value": "manual"})
    guard = SkipIf("skip?", Once(), params, context)
    assert tick(guard) == Status.FAILURE and guard.feedback_message == "no robot attached"


def test_a_guard_starts_once_per_run_of_its_child(sup: Supervisor, port: FakePort) -> None:
    """``initialise()`` runs when the guard starts, not on the ticks while the child runs."""

    class Counted(While):
        starts = 0

        def initialise(self) -> None:
            type(self).starts += 1

    class Twice(py_trees.behaviour.Behaviour):
        def __init__(self) -> None:
            super().__init__("twice")
            self.n = 0

        def update(self) -> Status:
            self.n += 1
            return Status.SUCCESS if self.n % 2 == 0 else Status.RUNNING

    from pirate_bt.behaviours.guards import PreconditionParams

    params = PreconditionParams(condition={"state": "mode", "value": "autonomous"})
    from pirate_bt.behaviours.base import BuildContext

    context = BuildContext(robot=ROBOT, clock=sup.clock, supervisor=sup)
    guard = Counted("counted", Twice(), params, context)
    starts = []
    for expected in (Status.RUNNING, Status.SUCCESS) * 2:
        assert tick(guard) == expected
        starts.append(Counted.starts)
    assert starts == [1, 1, 2, 2]  # as each run of the child starts, not while it runs


def test_a_misspelt_state_value_gets_the_nearest_name() -> None:
    # 'imu.pich' listed the vocabulary but not the name meant (probe 10)
    with pytest.raises(ValueError) as caught:
        Comparison.model_validate({"state": "imu.pich", "op": ">", "value": "5 deg"})
    text = str(caught.value)
    assert "unknown state value 'imu.pich'; use one of: " in text
    assert "motor_current.<motor>, rotation; did you mean 'imu.pitch'?" in text
