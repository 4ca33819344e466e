"""``pirate-bt teleop``: the operator console, full screen, every key checked.

Every key becomes an operator action on the supervisor, so what you type goes
through exactly the checks a tree's commands do. The session starts in manual
mode (the operator is in control). On a terminal the console fills the screen
and stays put: a status panel updated every tick, the running tree when one is
attached (``--tree``), a condensed verdict log, the steps a supervised tree is
waiting on, and the keys (see :data:`pirate_bt.cli.console.app.KEY_HELP`).

Without ``--port`` the session drives the built-in simulator (``--sim NETWORK``,
default the straight pipe), paced to the terminal. ``--keys`` plays a
string of keys, one per tick, without a terminal (for scripts), and prints one
line per verdict that was not a plain pass.
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
from collections.abc import Callable, Iterator
from typing import Any, TextIO

from pirate_bt.cli.console.view import millimetres_per_s, verdict_text
from pirate_bt.errors import InputError, LinkError
from pirate_bt.robot.description import Half, MotorFunction, RobotDescription
from pirate_bt.safety import (
    Bend,
    Clamp,
    Confirm,
    Deny,
    Drive,
    EStop,
    Mode,
    MoveFrontClear,
    OperatorAction,
    OperatorCommand,
    ResetEStop,
    Resume,
    Rotate,
    SafeStop,
    SetMode,
    Source,
    Stop,
    Supervisor,
    Tilt,
    Unclamp,
    Verdict,
)

__all__ = ["TeleopSession", "configure", "run"]

SPEED_STEP_MPS = 0.02
ANGLE_STEP_RAD = math.radians(5)
SCRIPT_KEYS = "wsfFrRad[]cvmoynpuexq? ."
"""The keys ``--keys`` plays: the console's (:data:`pirate_bt.cli.console.app.KEY_HELP`),
``?`` (print the state) and ``.`` (a tick with no key)."""


def check_keys(keys: str) -> None:
    """Refuse a ``--keys`` script with a character that is no key, before anything is
    sent (before 2026-11-30 an unknown character, a typo or a capital ``W``, was a
    tick with nothing done, and the script went on without a word, exit 0).

    Raises:
        InputError: names the character, its position (from 1) and the keys known.
    """
    for position, key in enumerate(keys, start=1):
        if key not in SCRIPT_KEYS:
            known = " ".join("space" if k == " " else k for k in SCRIPT_KEYS if k != ".")
            raise InputError(
                f"--keys: {key!r} (character {position}) is no key; the keys are {known},"
                " and '.' waits a tick"
            )


class TeleopSession:
    """Turns keys into operator actions and keeps the manual setpoints.

    Args:
        supervisor: The supervisor to act through.
        out: Where ``--keys`` scripts see verdicts and state (``None``: nowhere;
            the full-screen console reads the supervisor's verdicts itself).
    """

    def __init__(self, supervisor: Supervisor, out: TextIO | None = None) -> None:
        self.sup = supervisor
        self.out = out
        self.velocity_mps = 0.0
        self._stopped = (False, False)  # (in the safe state, e-stopped) at the last step
        self.rotation_rad = 0.0
        self.hand_back_mode = (
            Mode.SUPERVISED if supervisor.mode is Mode.SUPERVISED else Mode.AUTONOMOUS
        )
        """What ``o`` hands back to: the mode taken over from (autonomous at first)."""
        self.bend_rad = 0.0
        robot = supervisor.robot
        limit = robot.joint_motor(robot.all_bend_modules()[0].name).limits.torque
        torque = robot.clamp.min_torque * 1.5
        self.clamp_torque_nm = min(torque, limit.max) if limit is not None else torque
        # The drive keys stop at the slowest drive motor's limit, so the setpoint
        # shown is one the supervisor would pass, not one it clips every tick.
        speeds = [
            m.limits.velocity.max
            for _, m in robot.motors()
            if m.function is MotorFunction.DRIVE and m.limits.velocity is not None
        ]
        self.max_velocity_mps = min(speeds) if speeds else math.inf
        self._printed: str | None = None
        self._repeats = 0
        self.after_step: list[Callable[[], None]] = []
        """Called after every :meth:`step`."""
        self.notes: list[Callable[[str], None]] = []
        """Called with a line for a key that had no effect and no verdict says why."""
        if out is not None:
            supervisor.add_listener(self._show)

    def _show(self, verdict: Verdict) -> None:
        if self.out is None or (verdict.reason is None and verdict.source is Source.OPERATOR):
            return
        text = verdict_text(verdict)
        if text == self._printed:
            self._repeats += 1
            return
        self.flush()
        self._printed = text
        print(f"  {text}", file=self.out)

    def flush(self) -> None:
        """Write how often the last verdict line repeated (scripts fold repeats)."""
        if self.out is not None and self._repeats:
            times = "once" if self._repeats == 1 else f"{self._repeats} times"
            print(f"  (the same {times} more)", file=self.out)
        self._repeats = 0
        self._printed = None

    def _speed(self, step: float) -> float:
        limit = self.max_velocity_mps
        self.velocity_mps = max(-limit, min(limit, round(self.velocity_mps + step, 6)))
        return self.velocity_mps

    def actions(self, key: str) -> Iterator[OperatorAction]:
        """The operator actions for one key."""
        robot = self.sup.robot
        front = [m.name for m in robot.bend_modules(Half.FRONT)]
        if key in "ws":
            speed = self._speed(SPEED_STEP_MPS if key == "w" else -SPEED_STEP_MPS)
            # down to 0 is a stop, which always passes: Drive(0) is judged on the
            # readings like any drive, and while a board reboots it was refused as
            # stale and the robot drove on at the speed before
            yield OperatorCommand(Drive(speed) if speed != 0.0 else Stop())
        elif key == " ":
            self.velocity_mps = 0.0
            yield OperatorCommand(Stop())
        elif key in "fFrR":
            half = Half.FRONT if key in "fF" else Half.REAR
            if key.islower():
                yield OperatorCommand(Clamp(half, self.clamp_torque_nm))
            else:
                yield OperatorCommand(Unclamp(half))
        elif key in "ad":
            self.rotation_rad += ANGLE_STEP_RAD if key == "d" else -ANGLE_STEP_RAD
            yield OperatorCommand(Rotate(self.rotation_rad))
        elif key in "[]":
            self.bend_rad += ANGLE_STEP_RAD if key == "]" else -ANGLE_STEP_RAD
            for module in front:
                yield OperatorCommand(Bend(module, self.bend_rad))
        elif key == "c":
            yield OperatorCommand(MoveFrontClear())
        elif key == "v":
            yield OperatorCommand(Tilt(0.0))
        elif key == "m":
            if self.sup.mode in (Mode.SUPERVISED, Mode.AUTONOMOUS):
                self.hand_back_mode = self.sup.mode
            yield SetMode(Mode.MANUAL)
        elif key == "o":
            # back to the mode taken over from: a supervised tree went on autonomous
            # after a takeover and hand-back, its steps no longer asked (before 2026-11-30)
            yield SetMode(self.hand_back_mode)
        elif key == "y":
            yield Confirm()
        elif key == "n":
            yield Deny()
        elif key == "p":
            self.velocity_mps = 0.0  # the stop is what was asked: no drive to keep alive
            yield SafeStop("operator stop (teleop)")
        elif key == "u":
            yield Resume()
        elif key == "e":
            self.velocity_mps = 0.0
            yield EStop("operator e-stop (teleop)")
        elif key == "x":
            yield ResetEStop()

    def press(self, key: str) -> bool:
        """Handle one key; returns False on quit."""
        if key == "q":
            return False
        if key == "?":
            self.show_state()
            return True
        kept = (self.velocity_mps, self.rotation_rad, self.bend_rad)
        waiting = bool(self.sup.pending_confirmations())
        refused = False
        for action in self.actions(key):
            verdict = self.sup.apply(action)
            refused = refused or (verdict is not None and verdict.refused)
        if refused:
            # A refused key changes nothing, the setpoints it stepped included: kept, a
            # refused 'w' (not in control, a half transitioning) was sent again every
            # tick after a takeover, and the robot drove off at a speed the operator
            # had seen refused; two refused 'd' made the next one a 15° turn.
            self.velocity_mps, self.rotation_rad, self.bend_rad = kept
        why = self._ignored(key, waiting)
        if why is not None:
            self._note(f"IGNORED {why}")
        return True

    def _ignored(self, key: str, waiting: bool) -> str | None:
        """Why an operator action had no effect, when it is one a refusal says nothing
        of (before 2026-11-30 the console dropped these in silence: 'm' in an e-stop,
        a reset the bridge refused, 'y' with nothing waiting)."""
        estopped = self.sup.mode is Mode.ESTOP
        if key in "mo" and estopped:
            what = "take over" if key == "m" else "hand back"
            return f"{what}: the e-stop is latched (x resets it)"
        if key == "x" and estopped:
            why = (self.sup.estop_reset_refusal or "the bridge refused it").splitlines()[0]
            return f"e-stop reset: {why}; the e-stop stays latched (try x again)"
        if key in "yn" and not waiting:
            return f"{'confirm' if key == 'y' else 'deny'}: no step is waiting"
        return None

    def _note(self, text: str) -> None:
        for hook in self.notes:
            hook(text)
        if self.out is not None:
            self.flush()
            print(f"  {text}", file=self.out)

    def step(self) -> None:
        """One tick: supervisor housekeeping, keep the drive setpoint alive, then the
        :attr:`after_step` hooks (a live Foxglove view, say)."""
        self.sup.tick()
        stopped = (self.sup.in_safe_state, self.sup.mode is Mode.ESTOP)
        if any(now and not before for now, before in zip(stopped, self._stopped, strict=True)):
            # A stop came (the supervisor's own safe state, an e-stop from the bridge's
            # button or a ROS 2 topic): it took the drive. Kept alive, the drive went on
            # at the next tick (an operator's command in manual passes in the safe
            # state) or after the e-stop's reset; the drive keys start from still.
            self.velocity_mps = 0.0
        self._stopped = stopped
        if self.velocity_mps != 0.0 and self.sup.mode is Mode.MANUAL:
            self.sup.apply(OperatorCommand(Drive(self.velocity_mps)))
        for hook in self.after_step:
            hook()

    def show_state(self) -> None:
        if self.out is None:
            return
        self.flush()
        halves = ", ".join(f"{h} {s}" for h, s in self.sup.half_states().items())
        extra = f" safe state: {self.sup.safe_state_reason}" if self.sup.in_safe_state else ""
        drive = millimetres_per_s(self.velocity_mps)
        print(f"  mode {self.sup.mode}; {halves}; drive {drive}{extra}", file=self.out)


def configure(parser: argparse.ArgumentParser) -> None:
    where = parser.add_mutually_exclusive_group()
    where.add_argument(
        "--sim",
        metavar="NETWORK",
        help="drive the built-in simulator in this pipe network, a file or a bundled name"
        " (the default, in the straight pipe)",
    )
    where.add_argument("--port", metavar="URL", help="a real robot: serial device or URL")
    parser.add_argument(
        "--seed",
        type=int,
        default=None,
        help=argparse.SUPPRESS,  # kept to say why it is refused: nothing to seed
    )
    parser.add_argument("--robot", metavar="FILE", help="robot description (default: bundled)")
    parser.add_argument(
        "--rate",
        default="20",
        metavar="HZ",
        help="ticks per second: 20, or 20 Hz as for 'pirate-bt run' (default 20)",
    )
    parser.add_argument(
        "--tree",
        metavar="TREE",
        help="run this tree under the console, in supervised mode unless --mode says otherwise",
    )
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a parameter of --tree's tree (repeatable), as for 'pirate-bt run'",
    )
    parser.add_argument(
        "--mode",
        choices=[m.value for m in (Mode.MANUAL, Mode.SUPERVISED, Mode.AUTONOMOUS)],
        help="the mode to start in (default: manual; supervised with --tree)",
    )
    parser.add_argument("--keys", help="play these keys, one per tick, then quit (no terminal)")
    from pirate_bt.interop.foxglove_option import add_foxglove_option

    add_foxglove_option(parser)
    from pirate_bt.interop.ros2_option import add_ros2_options

    add_ros2_options(parser)
    from pirate_bt.interop.groot2_option import add_groot2_option

    add_groot2_option(parser)


def _check_link(sup: Supervisor) -> None:
    """Exit 3 when the link was lost during the session (it exited 0: a script of keys
    against a bridge that had died was told all went well, before 2026-11-30).

    Raises:
        LinkError: the link is lost (the safe state's reason when it says so).
    """
    health = sup.health()
    if health.connected:
        return
    reason = sup.safe_state_reason or ""
    if not reason.startswith("link lost"):
        heard = health.last_heard_s
        reason = "link lost during the teleop" + (
            f": nothing heard from the bridge since t = {heard:.2f} s"
            if math.isfinite(heard)
            else ""
        )
    raise LinkError(reason)


def _run_keys(session: TeleopSession, keys: str, period_s: float) -> int:
    sup = session.sup
    for key in keys:
        session.step()
        if not session.press(key):
            break
        sup.clock.sleep(period_s)
    session.show_state()
    session.flush()
    return 0


def _load_tree(args: argparse.Namespace, robot: RobotDescription) -> Any:
    """``--tree`` loaded and checked as ``pirate-bt run`` loads it (a name that is no
    file: a bundled tree's, else the API's error listing them; a ``.xml`` file as
    BehaviorTree.CPP), or None. Before a terminal is asked for or the robot reached, so
    a bad tree is exit 2 whatever else is wrong."""
    if args.tree is None:
        return None
    from pirate_bt.api.running import find_tree, load_tree_source
    from pirate_bt.cli.run import parse_params

    return load_tree_source(
        find_tree(args.tree, "--tree"),
        robot=robot,
        params=parse_params(args.param),
        params_from_text=True,
        params_origin="--param",
    )


def _runner_factory(
    checked: Any,
    connection: Any,
    period_s: float,
    groot2: Any = None,
) -> Callable[[], object] | None:
    """How to build the runner of the checked ``--tree`` (None: no tree), by
    :meth:`pirate_bt.Connection.runner`: supervised as every run is."""
    if checked is None:
        return None

    def factory() -> object:
        # py_trees times setup out with a signal, which only the main thread may set;
        # the console runs the tree in its engine thread. Its "infinite"
        # (sys.float_info.max) is the value that skips the signal.
        runner = connection.runner(checked, rate=1.0 / period_s, setup_timeout_s=sys.float_info.max)
        if groot2 is not None:
            from pirate_bt.api.live import groot2_tree_observer

            groot2_tree_observer(groot2)(runner, connection)
        return runner

    return factory


def _rate(text: str) -> float:
    """``--rate``: a number of ticks per second, or a frequency as ``run --rate`` takes
    it (``20 Hz``; ``--rate 20Hz`` was 'invalid float value' here while ``run`` asks
    for the unit)."""
    from pirate_bt.errors import UnitError
    from pirate_bt.units import parse_quantity

    try:
        return float(text)
    except ValueError:
        pass
    try:
        return parse_quantity(text, "frequency")
    except UnitError as exc:
        raise InputError(f"--rate: {exc}") from None


def run(args: argparse.Namespace) -> int:
    from pirate_bt.api.options import check_rate, seed_value
    from pirate_bt.robot.loader import load_robot

    rate_hz = _rate(args.rate)
    check_rate(rate_hz, None, "--rate")  # the API's limits: above 0 (nan too), 1000 Hz
    if args.seed is not None:
        seed_value(args.seed, "--seed")  # the API's check, named as typed (it said "seed:")
        # it seeded nothing (no noise, no link faults in the teleop; a port has no
        # simulator) and was taken without a word, whatever it was
        raise InputError(
            "--seed: the teleop's simulator has no sensor noise and no faults, nothing"
            " in it is random; leave --seed out"
        )
    if args.port is not None:
        from pirate_bt.api.options import port_url

        # a real robot's: 'sim:lab' drove a simulator, and 'bogus' was told as the
        # API's "connect: 'bogus' is neither a network ... nor a serial port"
        port_url(args.port)  # named --port as typed by the command line
    robot = load_robot(args.robot)
    period_s = 1.0 / rate_hz
    mode = Mode(args.mode) if args.mode else (Mode.SUPERVISED if args.tree else Mode.MANUAL)
    if args.tree is not None and args.keys is not None:
        raise InputError("--keys drives the teleop only; run a tree with 'pirate-bt run'")
    if args.keys is not None:
        check_keys(args.keys)
    if args.param and args.tree is None:  # it was dropped without a word, exit 0
        raise InputError(f"--param {args.param[0]}: a tree's parameter; give the tree with --tree")
    checked = _load_tree(args, robot)
    if args.keys is None and not sys.stdin.isatty():
        if args.tree is not None:
            # --keys drives by hand only: a supervised tree's y/n answers need a person
            raise InputError(
                "the console needs a terminal to confirm a tree's steps; in scripts run"
                " the tree with 'pirate-bt run' (or the teleop by hand with --keys KEYS)"
            )
        raise InputError("the console needs a terminal; use --keys KEYS in scripts")
    if getattr(args, "groot2", None) is not None and args.tree is None:
        raise InputError("--groot2 shows a running tree: give it one with --tree TREE")
    from pirate_bt.cli.run import open_foxglove, open_groot2, open_ros2

    safety_log = logging.getLogger("pirate_bt.safety")
    level = safety_log.level
    if level == logging.NOTSET:
        # The console shows every verdict itself; the log would say each twice. Set back
        # afterwards: main() called in a process of the user's (a test, a script) left
        # the protective layer's warnings silenced for whatever ran next.
        safety_log.setLevel(logging.ERROR)
    foxglove = node = groot2 = None
    try:
        foxglove = open_foxglove(args)
        node = open_ros2(args)
        groot2 = open_groot2(args)
        return _run_session(args, robot, checked, mode, period_s, (foxglove, node, groot2))
    finally:
        for opened in (foxglove, node, groot2):
            if opened is not None:
                opened.close()
        safety_log.setLevel(level)


def _run_session(
    args: argparse.Namespace,
    robot: RobotDescription,
    checked: Any,
    mode: Mode,
    period_s: float,
    views: tuple[Any, Any, Any],
) -> int:
    from pirate_bt.api.connection import connect

    foxglove, ros2, groot2 = views
    target = args.port if args.port is not None else f"sim:{args.sim or 'straight'}"
    try:
        connection = connect(
            target,
            robot=robot,
            seed=0,
            mode=mode.value,
        )
    except InputError as exc:  # "network: no network 'x'", the API's parameter
        if args.port is None:
            from pirate_bt.cli import as_option

            as_option(exc, "network", "--sim")
        raise
    sup = connection.supervisor
    where = connection.description
    try:
        session = TeleopSession(sup, sys.stdout if args.keys is not None else None)
        if foxglove is not None:
            from pirate_bt.interop.foxglove_live import serve_supervisor

            session.after_step.append(serve_supervisor(foxglove, sup, robot=robot))
        if ros2 is not None:
            # The supervisor drains the graph's e-stop topic like the console's e-stop key.
            from pirate_bt.interop.ros2_live import serve_supervisor as serve_ros2

            session.after_step.append(serve_ros2(ros2, sup, robot=robot))
        if args.keys is not None:
            _run_keys(session, args.keys, period_s)
            _check_link(sup)
            return 0
        factory = _runner_factory(checked, connection, period_s, groot2)
        from pirate_bt.cli.console import ConsoleEngine, OperatorConsole

        engine = ConsoleEngine(session, period_s=period_s, runner_factory=factory)
        try:
            OperatorConsole(engine, title=f"pirate-bt teleop - {where}").run()
        finally:
            engine.stop()  # a SIGTERM in the screen's loop left the engine ticking on
        if engine.finished:
            print(engine.finished)
        _check_link(sup)
        return 0
    finally:
        connection.close()
