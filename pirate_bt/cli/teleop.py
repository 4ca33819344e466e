"""``pirate-bt teleop``: drive the robot (or the simulator) with single keys.

Every key becomes an operator action on the supervisor, so what you type goes
through exactly the checks a tree's commands do; each verdict that is not a
plain pass is shown. The session starts in manual mode (the operator is in
control). Keys:

====== ==========================================
key    action
====== ==========================================
w / s  faster forwards / backwards (20 mm/s steps)
space  stop the drives
f / F  clamp / unclamp the front half
r / R  clamp / unclamp the rear half
a / d  rotate the halves -5° / +5°
[ / ]  bend the front pair -5° / +5°
c / v  move the front module clear / back to 0°
m / o  take over (manual) / hand back (autonomous)
p      safe state;  u  leave it
e / x  e-stop / reset the e-stop
?      show state;  q  quit
====== ==========================================

Without ``--port`` the session drives the built-in simulator (``--sim NETWORK``,
default the straight pipe; ``--seed N``), paced to the terminal. ``--keys`` plays a
string of keys, one per tick, without a terminal (for scripts).
"""

from __future__ import annotations

import argparse
import contextlib
import math
import select
import sys
from collections.abc import Iterator
from typing import TextIO

from pirate_bt.robot.description import Half
from pirate_bt.safety import (
    Bend,
    Clamp,
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


class TeleopSession:
    """Turns keys into operator actions and keeps the manual setpoints.

    Args:
        supervisor: The supervisor to act through.
        out: Where verdicts and messages are written.
    """

    def __init__(self, supervisor: Supervisor, out: TextIO) -> None:
        self.sup = supervisor
        self.out = out
        self.velocity_mps = 0.0
        self.rotation_rad = 0.0
        self.bend_rad = 0.0
        robot = supervisor.robot
        limit = robot.joint_motor(robot.all_bend_modules()[0].name).limits.torque
        torque = robot.clamp.min_torque * 1.5
        self.clamp_torque_nm = min(torque, limit.max) if limit is not None else torque
        supervisor.add_listener(self._show)

    def _show(self, verdict: Verdict) -> None:
        if verdict.reason is not None or verdict.source is not Source.OPERATOR:
            print(f"  {verdict}", file=self.out)

    def actions(self, key: str) -> Iterator[OperatorAction]:
        """The operator actions for one key."""
        robot = self.sup.robot
        front = [m.name for m in robot.bend_modules(Half.FRONT)]
        if key in "ws":
            self.velocity_mps += SPEED_STEP_MPS if key == "w" else -SPEED_STEP_MPS
            yield OperatorCommand(Drive(self.velocity_mps))
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
            yield SetMode(Mode.MANUAL)
        elif key == "o":
            yield SetMode(Mode.AUTONOMOUS)
        elif key == "p":
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
        for action in self.actions(key):
            self.sup.apply(action)
        return True

    def step(self) -> None:
        """One tick: supervisor housekeeping, then keep the drive setpoint alive."""
        self.sup.tick()
        if self.velocity_mps != 0.0 and self.sup.mode is Mode.MANUAL:
            self.sup.apply(OperatorCommand(Drive(self.velocity_mps)))

    def show_state(self) -> None:
        halves = ", ".join(f"{h} {s}" for h, s in self.sup.half_states().items())
        extra = f" safe state: {self.sup.safe_state_reason}" if self.sup.in_safe_state else ""
        print(
            f"  mode {self.sup.mode}; {halves}; drive {self.velocity_mps * 1000:g} mm/s{extra}",
            file=self.out,
        )


def configure(parser: argparse.ArgumentParser) -> None:
    where = parser.add_mutually_exclusive_group()
    where.add_argument(
        "--sim",
        metavar="NETWORK",
        help="drive the built-in simulator in this pipe network, a file or a bundled name"
        " (the default, in the straight pipe)",
    )
    where.add_argument("--port", metavar="URL", help="a real robot: serial device or URL")
    parser.add_argument("--seed", type=int, default=0, help="simulator random seed (default 0)")
    parser.add_argument("--robot", metavar="FILE", help="robot description (default: bundled)")
    parser.add_argument("--rate", type=float, default=20.0, help="ticks per second (default 20)")
    parser.add_argument("--keys", help="play these keys, one per tick, then quit (no terminal)")


@contextlib.contextmanager
def _raw_terminal() -> Iterator[None]:
    import termios
    import tty

    fd = sys.stdin.fileno()
    old = termios.tcgetattr(fd)
    try:
        tty.setcbreak(fd)
        yield
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, old)


def run(args: argparse.Namespace) -> int:
    from pirate_bt.robot.loader import load_robot
    from pirate_bt.safety.factory import open_supervisor

    robot = load_robot(args.robot)
    if args.port is not None:
        sup = open_supervisor(robot, url=args.port, mode=Mode.MANUAL)
    else:
        sup = open_supervisor(robot, network=args.sim, seed=args.seed, mode=Mode.MANUAL)
    # The simulator's world moves only with its clock: pace it to the terminal.
    simulated = sup.clock.is_simulated
    session = TeleopSession(sup, sys.stdout)
    period_s = 1.0 / max(args.rate, 1.0)
    try:
        if args.keys is not None:
            for key in args.keys:
                session.step()
                if not session.press(key):
                    break
                sup.clock.sleep(period_s)
            session.show_state()
            return 0
        print(__doc__.split("Keys:")[1].split("``--keys``")[0].rstrip(), file=sys.stdout)
        with _raw_terminal():
            while True:
                session.step()
                ready, _, _ = select.select([sys.stdin], [], [], period_s)
                if ready and not session.press(sys.stdin.read(1)):
                    break
                if simulated:
                    sup.clock.sleep(period_s)
        return 0
    finally:
        sup.close()
