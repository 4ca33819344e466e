"""Motion primitives: the smallest meaningful actions of PIRATE, as py_trees leaves.

The drive lives in :mod:`pirate_bt.behaviours.drive`, the common base in
:mod:`pirate_bt.behaviours.primitive`; both are re-exported here.

A primitive asks the safety supervisor for one effect - clamp a half, release it,
drive, bend a module, rotate the halves, move the front module clear - and then
*watches the sensors* until the effect is confirmed. It never trusts that a command
did what it asked:

- ``clamp`` is done when every bend joint of the half has reached the wall and its
  spring reads the force the torque should give;
- ``unclamp``, ``bend``, ``rotate``, ``align_roll`` and ``move_front_clear`` are
  done when the joint angles are within a tolerance of their targets;
- ``drive`` is done when the wheel odometry has covered a distance, or when a
  feature of the pipe shows itself in the sensors (the robot is blocked at a turn
  it may not take, or a half has crossed a tee's opening).

Position setpoints are rate-limited by the supervisor (it clips a step that is too
big), so a primitive re-sends its command every tick until the supervisor passes
it unclipped. Every primitive has a ``timeout`` on the injected clock and fails -
with the reason in ``feedback_message`` - on a refusal, a timeout or a stall (a
drive motor drawing stall current without turning). When a primitive is
interrupted or fails, ``terminate()`` leaves the robot safe: drives are stopped
and clamps are held as they are.

Two nodes complete the set: ``confirm`` (a decorator: the operator confirms the
step before its child runs, in SUPERVISED mode; granted at once in AUTONOMOUS), and
``safe_state`` (the end of a recovery branch: the supervisor's "stop the drives,
hold the clamps", with the reason of the primitive that failed last).

Primitives reach the robot only through ``context.supervisor`` (layer rule), read
every number about the robot from its description, and acquire the supervisor in
``setup()`` so a tree builds and draws with no robot attached.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Annotated, Any, ClassVar, Literal

import py_trees
from py_trees.common import Status
from pydantic import AfterValidator, Field, ValidationInfo

from pirate_bt.behaviours.base import (
    BuildContext,
    GuardDecorator,
    Leaf,
    NodeParams,
    Outcome,
)
from pirate_bt.behaviours.drive import Drive, DriveParams
from pirate_bt.behaviours.primitive import (
    _SETTLE_TICKS,
    Primitive,
    _commands,
    _deg,
    _exact,
    _exact_deg,
    _read_blackboard,
)
from pirate_bt.behaviours.rotation import AlignRoll, AlignRollParams, Rotate, RotateParams
from pirate_bt.errors import shown
from pirate_bt.robot.description import Half, RobotDescription, Role
from pirate_bt.robot.state import RobotState
from pirate_bt.safety.checks import released_force_n
from pirate_bt.units import Angle, Duration, Torque

__all__ = [
    "AlignRoll",
    "AlignRollParams",
    "Bend",
    "Clamp",
    "Confirm",
    "Drive",
    "DriveParams",
    "MoveFrontClear",
    "Primitive",
    "Rotate",
    "RotateParams",
    "SafeState",
    "Unclamp",
    "last_failure",
]


def last_failure(node: py_trees.behaviour.Behaviour) -> str | None:
    """The reason of the primitive that failed last in ``node``'s tree, if any (the
    failure of a selector's first way rather than that of its fallback tried after it:
    :func:`~pirate_bt.behaviours.cause.explaining_stamp`)."""
    from pirate_bt.behaviours.cause import explaining_stamp

    root = node
    while root.parent is not None:
        root = root.parent
    found = explaining_stamp(root)
    return f"{found[1].name}: {found[2]}" if found is not None else None


# -- clamp and release -----------------------------------------------------------


class ClampParams(NodeParams):
    half: Half = Field(description="which half clamps: front or rear")
    torque: Torque = Field(gt=0, description="joint torque pressing the wheels on the wall")
    timeout: Duration = Field(5.0, gt=0, description="fail if not clamped within this time")


def _joint_torque_limit(robot: RobotDescription) -> float | None:
    limits = [
        robot.joint_motor(m.name).limits.torque
        for m in robot.all_bend_modules()
        if robot.joint_motor(m.name).limits.torque is not None
    ]
    return min(lim.max for lim in limits if lim is not None) if limits else None


class Clamp(Primitive):
    """Clamp ``half`` at ``torque``; success when every joint is at the wall and its spring
    reads the force the torque gives (or, without springs, the angle is in the wall range).

    Fails at once when a joint swings past every wall-contact angle (no wall there: the
    half is over a tee's opening) and on refusal or timeout.
    """

    Params = ClampParams
    verb = "clamp"

    @classmethod
    def check_limits(cls, params: Any, robot: RobotDescription) -> list[str]:
        problems: list[str] = []
        if params.torque < robot.clamp.min_torque:
            problems.append(
                f"torque: {_exact(params.torque)} N*m is below the minimum clamp torque"
                f" {robot.clamp.min_torque:g} N*m"
            )
        limit = _joint_torque_limit(robot)
        if limit is not None and params.torque > limit:
            problems.append(
                f"torque: {_exact(params.torque)} N*m is above the bend joints' limit {limit:g} N*m"
            )
        return problems

    def start(self) -> None:
        self._sent = False
        self._held = 0

    def step(self, state: RobotState) -> Status:
        p: ClampParams = self.params  # type: ignore[assignment]
        if not self._sent:
            ok, _ = self.send(_commands().Clamp(p.half, p.torque))
            if not ok:
                return self.refused()
            self._sent = True
        robot = self.robot
        clamp = robot.clamp
        tol = robot.safety.angle_tolerance
        wall_min = min(c.angle for c in clamp.contact_angles) - tol
        wall_max = max(c.angle for c in clamp.contact_angles) + 4 * tol
        need_force = robot.safety.clamp_force_fraction * p.torque / clamp.lever_arm
        ok_all = True
        shown: list[str] = []
        for module in robot.bend_modules(p.half):
            angle = state.joint_angle_rad.get(module.name)
            if angle is None:
                ok_all = False
                continue
            force = state.clamp_force_n.get(module.name)
            shown.append(
                f"{module.name} {_deg(angle)}" + (f" {force:.1f} N" if force is not None else "")
            )
            if abs(angle) > wall_max:
                return self.fail(
                    f"no wall: {module.name} swung to {_deg(angle)}, past every wall-contact"
                    f" angle (the {p.half} half is over an opening, or the pipe is wider"
                    " than its clamp.contact_angles?)"
                )
            if abs(angle) < wall_min or (force is not None and abs(force) < need_force):
                ok_all = False
        self.feedback_message = f"clamping {p.half}: " + ", ".join(shown)
        self._held = self._held + 1 if ok_all else 0
        return Status.SUCCESS if self._held >= _SETTLE_TICKS else Status.RUNNING


class UnclampParams(NodeParams):
    half: Half = Field(description="which half releases: front or rear")
    tolerance: Angle = Field(0.05, gt=0, description="joint angle counted as straight")
    timeout: Duration = Field(5.0, gt=0, description="fail if not released within this time")


class Unclamp(Primitive):
    """Release ``half``: its joints back to straight; success when every joint is within
    ``tolerance`` of 0 (and its springs read no force)."""

    Params = UnclampParams
    verb = "unclamp"

    def start(self) -> None:
        self._done_sending = False
        self._held = 0

    def step(self, state: RobotState) -> Status:
        p: UnclampParams = self.params  # type: ignore[assignment]
        if not self._done_sending:
            ok, done = self.send(_commands().Unclamp(p.half))
            if not ok:
                return self.refused()
            self._done_sending = done
        return self._settle(state, p.half, p.tolerance)

    def _settle(self, state: RobotState, half: Half, tol: float) -> Status:
        robot = self.robot
        release = released_force_n(robot)
        ok_all = self._done_sending
        shown: list[str] = []
        for module in robot.bend_modules(half):
            angle = state.joint_angle_rad.get(module.name)
            force = state.clamp_force_n.get(module.name)
            if angle is None or abs(angle) > tol or (force is not None and abs(force) > release):
                ok_all = False
            if angle is not None:
                # the spring too: a joint back at straight whose spring still reads force
                # (a stuck sensor, something caught) is what keeps a release from ending
                shown.append(
                    f"{module.name} {_deg(angle)}"
                    + (f" {force:.1f} N" if force is not None else "")
                )
        self.feedback_message = f"releasing {half}: " + ", ".join(shown)
        self._held = self._held + 1 if ok_all else 0
        return Status.SUCCESS if self._held >= _SETTLE_TICKS else Status.RUNNING


# -- joints --------------------------------------------------------------------------


class BendParams(NodeParams):
    module: str = Field(
        description="a bend module (bend_1), or a half (front, rear) for all of its bend modules"
    )
    angle: Angle = Field(description="joint angle; positive bends toward the bending direction")
    sign_from: str | None = Field(
        None,
        description="blackboard key holding +1 or -1 (written by align_roll): the angle's sign",
    )
    tolerance: Angle = Field(0.05, gt=0, description="how close counts as reached")
    timeout: Duration = Field(5.0, gt=0, description="fail if not reached within this time")


def _bend_targets(robot: RobotDescription, module: str) -> list[str]:
    if module in (Half.FRONT.value, Half.REAR.value):
        return [m.name for m in robot.bend_modules(Half(module))]
    mod = robot.module(module)
    if mod.role is not Role.BEND:
        raise KeyError(module)
    return [mod.name]


class Bend(Primitive):
    """Set the joint angle of a bend module (or of both of a half's) and wait until reached.

    With ``sign_from`` the angle is multiplied by the sign on the blackboard, so a
    tree can steer a half toward a turn whose side ``align_roll`` chose.
    """

    Params = BendParams
    verb = "bend"

    @classmethod
    def check_limits(cls, params: Any, robot: RobotDescription) -> list[str]:
        try:
            modules = _bend_targets(robot, params.module)
        except KeyError:
            names = [m.name for m in robot.all_bend_modules()]
            return [f"module: {shown(params.module)} is not a bend module or a half ({names})"]
        problems: list[str] = []
        for name in modules:
            lim = robot.joint_motor(name).limits.angle
            if lim is not None and not (lim.min <= params.angle <= lim.max):
                problems.append(
                    f"angle: {_exact_deg(params.angle)} is beyond {name}'s range"
                    f" [{_deg(lim.min)}, {_deg(lim.max)}]"
                )
            if lim is not None and params.sign_from and not lim.min <= -params.angle <= lim.max:
                problems.append(f"angle: -{_exact_deg(params.angle)} is beyond {name}'s range")
        steer = robot.motion.steer_angle
        if params.sign_from and abs(params.angle) < steer:
            # a bend that steers a half toward a turn (the sign align_roll chose): below
            # the robot's steer angle the half does not count as steered, and the drive
            # into the turn would only block at its mouth
            problems.append(
                f"angle: {_exact_deg(params.angle)} steers less than the robot's"
                f" motion.steer_angle ({_exact_deg(steer)}): the half would not enter a turn"
                " (give the tree's steer parameter at least that)"
            )
        return problems

    @classmethod
    def blackboard_reads(cls, params: Any) -> tuple[str, ...]:
        return (params.sign_from,) if params.sign_from else ()

    def start(self) -> None:
        p: BendParams = self.params  # type: ignore[assignment]
        self._modules = _bend_targets(self.robot, p.module)
        self._target = p.angle
        self._sign_error = ""
        if p.sign_from:
            sign = _read_blackboard(p.sign_from)
            if isinstance(sign, bool) or sign not in (1, -1):  # True == 1 is no sign
                self._sign_error = f"blackboard {shown(p.sign_from)} is {shown(sign)}, not +1 or -1"
            else:
                self._target = p.angle * float(sign)
        self._done_sending = False
        self._held = 0

    def step(self, state: RobotState) -> Status:
        p: BendParams = self.params  # type: ignore[assignment]
        if self._sign_error:
            return self.fail(self._sign_error)
        if not self._done_sending:
            done_all = True
            for name in self._modules:
                ok, done = self.send(_commands().Bend(name, self._target))
                if not ok:
                    return self.refused()
                done_all = done_all and done
            self._done_sending = done_all
        ok_all = self._done_sending
        shown: list[str] = []
        for name in self._modules:
            angle = state.joint_angle_rad.get(name)
            if angle is None or abs(angle - self._target) > p.tolerance:
                ok_all = False
            if angle is not None:
                shown.append(f"{name} {_deg(angle)}")
        self.feedback_message = f"bending to {_deg(self._target)}: " + ", ".join(shown)
        self._held = self._held + 1 if ok_all else 0
        return Status.SUCCESS if self._held >= _SETTLE_TICKS else Status.RUNNING


class MoveFrontClearParams(NodeParams):
    side: Literal["positive", "negative"] = Field(
        "positive", description="to which side the front module swings out of the way"
    )
    timeout: Duration = Field(5.0, gt=0, description="fail if not clear within this time")


class MoveFrontClear(Primitive):
    """Tilt the front module out of the way (``clamp.front_clear_angle``): it must be clear
    before the front half clamps, or the bend modules push on it."""

    Params = MoveFrontClearParams
    verb = "move_front_clear"

    def start(self) -> None:
        self._done_sending = False
        self._held = 0

    def step(self, state: RobotState) -> Status:
        p: MoveFrontClearParams = self.params  # type: ignore[assignment]
        sign = 1 if p.side == "positive" else -1
        if not self._done_sending:
            ok, done = self.send(_commands().MoveFrontClear(sign))
            if not ok:
                return self.refused()
            self._done_sending = done
        tilt = state.front_tilt_rad
        need = self.robot.clamp.front_clear_angle - self.robot.safety.angle_tolerance
        clear = tilt is not None and tilt * sign >= need
        self.feedback_message = f"front tilt {_deg(tilt) if tilt is not None else 'unknown'}"
        self._held = self._held + 1 if (clear and self._done_sending) else 0
        return Status.SUCCESS if self._held >= _SETTLE_TICKS else Status.RUNNING


# -- confirmation and safe state -----------------------------------------------------


def _shown_text(text: str, info: ValidationInfo) -> str:
    """Text shown to the operator and logged: no control character (an escape sequence
    in a tree file would clear or rewrite the operator's terminal)."""
    bad = next((c for c in text if c < " " or "\x7f" <= c <= "\x9f"), None)
    if bad is not None:
        raise ValueError(f"{info.field_name}: must not contain control characters ({bad!r})")
    return text


class ConfirmParams(NodeParams):
    step: Annotated[str, AfterValidator(_shown_text)] = Field(
        min_length=1, description="the step's name shown to the operator"
    )


class Confirm(GuardDecorator):
    """A confirmation point: the operator confirms ``step`` before the child runs.

    In SUPERVISED mode the node is RUNNING (the child does not start) until the
    operator confirms the step, and fails if they deny it; in AUTONOMOUS mode it is
    granted at once. The grant lasts while the child runs and ends with it.
    """

    Params = ConfirmParams
    needs_robot: ClassVar[bool] = True
    pab_step: ClassVar[bool] = True
    """Every PAB step sits behind a confirmation point: traces and plots show them as steps."""

    def __init__(
        self,
        name: str,
        child: py_trees.behaviour.Behaviour,
        params: ConfirmParams,
        context: BuildContext,
    ) -> None:
        super().__init__(name, child, params, context)
        self.step = params.step
        self._granted = False
        self.denied_at_s: float | None = None

    @classmethod
    def decorated_outcomes(
        cls, params: Any, child_outcomes: frozenset[Outcome]
    ) -> frozenset[Outcome]:
        return child_outcomes | {"failure", "running"}

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        sup = self.context.supervisor
        if self.status != Status.RUNNING:
            self._granted = False
            self.denied_at_s = None
        if not self._granted and sup is not None:
            answer = sup.request_confirmation(self.step).value
            if answer == "granted":
                self._granted = True
            elif answer == "denied":
                self.feedback_message = f"the operator denied {self.step!r}"
                self.denied_at_s = self.context.clock.now()
                sup.end_step(self.step)
                self.stop(Status.FAILURE)
                yield self
                return
            else:
                if self.status != Status.RUNNING:
                    self.initialise()
                self.status = Status.RUNNING
                self.feedback_message = f"waiting for the operator to confirm {self.step!r}"
                yield self
                return
        yield from super().tick()

    def update(self) -> Status:
        self.feedback_message = self.decorated.feedback_message
        return self.decorated.status

    def terminate(self, new_status: Status) -> None:
        sup = self.context.supervisor
        if new_status != Status.RUNNING and self._granted and sup is not None:
            sup.end_step(self.step)
            self._granted = False


class SafeStateParams(NodeParams):
    reason: Annotated[str, AfterValidator(_shown_text)] = Field(
        "recovery", description="why the tree puts the robot in its safe state"
    )


class SafeState(Leaf):
    """Put the robot in its safe state (drives stopped, clamps held); always succeeds.

    The end of a recovery branch: the reason given to the supervisor includes the
    reason of the primitive that failed last, so it shows in the log and the trace.
    """

    Params = SafeStateParams
    needs_robot: ClassVar[bool] = True

    @classmethod
    def outcomes(cls, params: Any) -> frozenset[Outcome]:
        return frozenset({"success"})

    def update(self) -> Status:
        p: SafeStateParams = self.params  # type: ignore[assignment]
        cause = last_failure(self)
        reason = f"{p.reason}: {cause}" if cause else p.reason
        self.feedback_message = reason
        sup = self.context.supervisor
        if sup is not None:
            sup.safe_state(reason)
        return Status.SUCCESS
