"""What the operator console shows, as plain text: no terminal library here.

The console is a view, not a layer. Everything it shows is built here from the
supervisor's public read-outs into small immutable values (:class:`Snapshot`),
so the same text is what the full-screen console draws, what ``teleop --keys``
prints for scripts, and what the tests read.

Numbers are rounded to the unit shown: speeds in whole mm/s, angles in tenths
of a degree, torques in hundredths of a newton metre, forces in tenths of a
newton. A value below half the last digit shows as ``0``, never as
``6.93889e-17``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode, Half, RobotDescription
from pirate_bt.robot.port import LinkHealth
from pirate_bt.robot.state import RobotState
from pirate_bt.safety import (
    Bend,
    Clamp,
    Command,
    Drive,
    MoveFrontClear,
    Rotate,
    Stop,
    Tilt,
    Unclamp,
    Verdict,
)
from pirate_bt.safety.verdict import Outcome

__all__ = [
    "Snapshot",
    "StatusLine",
    "VerdictFeed",
    "command_text",
    "degrees",
    "millimetres_per_s",
    "newton_metres",
    "newtons",
    "status_lines",
    "verdict_text",
]

_MISSING = "--"


def _rounded(value: float, digits: int) -> str:
    """``value`` with ``digits`` decimals; minus zero and tiny residues print as 0."""
    if not math.isfinite(value):
        return _MISSING
    text = f"{value:.{digits}f}"
    if float(text) == 0.0:
        text = f"{0.0:.{digits}f}"
    return text


def degrees(angle_rad: float | None) -> str:
    """An angle in degrees to a tenth (``12.5°``)."""
    return _MISSING if angle_rad is None else f"{_rounded(math.degrees(angle_rad), 1)}°"


def millimetres_per_s(velocity_mps: float | None) -> str:
    """A speed in whole millimetres per second (``40 mm/s``)."""
    return _MISSING if velocity_mps is None else f"{_rounded(velocity_mps * 1000.0, 0)} mm/s"


def newton_metres(torque_nm: float | None) -> str:
    """A torque to a hundredth of a newton metre (``0.53 N·m``)."""
    return _MISSING if torque_nm is None else f"{_rounded(torque_nm, 2)} N·m"


def newtons(force_n: float | None) -> str:
    """A force to a tenth of a newton (``4.2 N``)."""
    return _MISSING if force_n is None else f"{_rounded(force_n, 1)} N"


def command_text(command: Command) -> str:
    """A command as the operator reads it, numbers rounded to the unit shown."""
    match command:
        case Clamp(half, torque):
            return f"clamp {half} {newton_metres(torque)}"
        case Unclamp(half, angle):
            return f"unclamp {half}" if angle == 0 else f"unclamp {half} to {degrees(angle)}"
        case Drive(velocity):
            return f"drive {millimetres_per_s(velocity)}"
        case Bend(module, angle):
            return f"bend {module} {degrees(angle)}"
        case Rotate(angle):
            return f"rotate {degrees(angle)}"
        case Tilt(angle):
            return f"tilt {degrees(angle)}"
        case MoveFrontClear(sign):
            return f"move front clear ({'+' if sign >= 0 else '-'})"
        case Stop():
            return "stop"
    return type(command).__name__.lower()


def _sent_value(sent: MotorCommand) -> str:
    if sent.mode is ControlMode.VELOCITY:
        return millimetres_per_s(sent.value)
    if sent.mode is ControlMode.TORQUE:
        return newton_metres(sent.value)
    if sent.mode is ControlMode.POSITION:
        return degrees(sent.value)
    return f"{_rounded(sent.value * 100.0, 0)} % duty"


def _sent_summary(sent: Sequence[MotorCommand]) -> str:
    """What went out, in one phrase: one value when every motor got the same."""
    values = [_sent_value(c) for c in sent]
    if not values:
        return ""
    if len(set(values)) == 1:
        return values[0]
    return ", ".join(f"{c.motor} {v}" for c, v in zip(sent, values, strict=True))


def verdict_text(verdict: Verdict) -> str:
    """One line for one verdict: outcome, command, who asked, and why.

    A clip says what was sent instead of listing every motor's limit; a refusal
    gives the supervisor's one-sentence reason.
    """
    who = verdict.source.value
    head = f"{verdict.outcome.upper():<6} {command_text(verdict.command)} [{who}]"
    if verdict.outcome is Outcome.CLIP:
        reason = verdict.reason.value if verdict.reason else "limit"
        sent = _sent_summary(verdict.sent)
        return f"{head} {reason}" + (f": sent {sent}" if sent else "")
    if verdict.outcome is Outcome.REFUSE:
        reason = verdict.reason.value if verdict.reason else "refused"
        detail = verdict.detail.split(";")[0].strip()
        return f"{head} {reason}" + (f": {detail}" if detail else "")
    if verdict.reason is not None:
        # a stop the supervisor made says what made it (it was "PASS stop [supervisor]"
        # for an e-stop, from the console or the bridge's button, and a safe state alike)
        detail = verdict.detail.split(";")[0].strip()
        return f"{head} {verdict.reason.value}" + (f": {detail}" if detail else "")
    return head


@dataclass
class VerdictFeed:
    """A condensed verdict log: one line per command, repeats folded into a count.

    The teleop keeps a drive setpoint alive by sending it every tick, and each
    of those is a verdict; the feed shows such a run once, as ``... (x12)``.

    Args:
        maxlen: How many lines to keep.
    """

    maxlen: int = 200
    lines: list[str] = field(default_factory=list)
    _last: tuple[object, ...] | None = None
    _count: int = 0

    def add(self, verdict: Verdict) -> bool:
        """Add one verdict; returns True when a new line was started.

        Verdicts on the same command with the same outcome and reason fold into
        one line that shows the latest (a ramp clipped by a rate limit is one
        line whose "sent" value moves), with how many there were.
        """
        text = verdict_text(verdict)
        key = (verdict.outcome, verdict.source, command_text(verdict.command), verdict.reason)
        stamp = f"{verdict.stamp_s:8.2f} s  "
        if key == self._last and self.lines:
            self._count += 1
            self.lines[-1] = f"{stamp}{text} (x{self._count})"
            return False
        self._last, self._count = key, 1
        self.lines.append(f"{stamp}{text}")
        del self.lines[: -self.maxlen]
        return True

    def note(self, stamp_s: float, text: str) -> None:
        """Add a line that is no verdict (an operator key that had no effect)."""
        self._last, self._count = None, 0
        self.lines.append(f"{stamp_s:8.2f} s  {text}")
        del self.lines[: -self.maxlen]

    def extend(self, verdicts: Iterable[Verdict]) -> None:
        for verdict in verdicts:
            self.add(verdict)


@dataclass(frozen=True, slots=True)
class StatusLine:
    """One labelled line of the status panel (``level``: ok, warn or alarm)."""

    label: str
    text: str
    level: str = "ok"


def _link_line(health: LinkHealth | None, now_s: float) -> StatusLine:
    if health is None:
        return StatusLine("link", "not connected", "alarm")
    if not health.connected:
        return StatusLine("link", "LOST", "alarm")
    rtt = _MISSING if math.isnan(health.rtt_s) else f"{_rounded(health.rtt_s * 1000.0, 1)} ms"
    silent = health.silent_for(now_s)
    text = (
        f"rtt {rtt}, loss {_rounded(health.loss_ratio * 100.0, 0)} %,"
        f" retries {health.retries}, failed {health.failed}, crc {health.crc_errors}"
    )
    level = "ok" if health.failed == 0 and silent < 0.2 else "warn"
    return StatusLine("link", text, level)


def _half_line(
    robot: RobotDescription, half: Half, clamp: str, state: RobotState | None
) -> StatusLine:
    modules = [m.name for m in robot.bend_modules(half)]
    parts = []
    for name in modules:
        angle = state.joint_angle_rad.get(name) if state is not None else None
        force = state.clamp_force_n.get(name) if state is not None else None
        parts.append(f"{name} {degrees(angle)} {newtons(force)}")
    level = {"clamped": "ok", "unclamped": "ok", "transitioning": "warn"}.get(clamp, "alarm")
    return StatusLine(f"{half} half", f"{clamp.upper():<13} " + "  ".join(parts), level)


def status_lines(
    *,
    robot: RobotDescription,
    mode: str,
    estopped: bool,
    safe_state_reason: str | None,
    half_states: Mapping[Half, str],
    state: RobotState | None,
    health: LinkHealth | None,
    now_s: float,
    manual_velocity_mps: float = 0.0,
) -> list[StatusLine]:
    """The status panel, line by line, from the supervisor's read-outs."""
    lines = [
        StatusLine("mode", mode.upper(), "alarm" if estopped else "ok"),
        StatusLine(
            "e-stop", "LATCHED (x resets)" if estopped else "clear", "alarm" if estopped else "ok"
        ),
    ]
    if safe_state_reason is not None:
        lines.append(StatusLine("safe state", safe_state_reason, "warn"))
    for half in (Half.FRONT, Half.REAR):
        lines.append(_half_line(robot, half, str(half_states.get(half, "unknown")), state))
    if state is None:
        lines.append(StatusLine("state", "no state frame yet", "warn"))
    else:
        speed = state.mean_drive_velocity_mps() if state.drive_velocity_mps else None
        lines.append(
            StatusLine(
                "motion",
                f"speed {millimetres_per_s(speed)} (asked {millimetres_per_s(manual_velocity_mps)})"
                f", rotation {degrees(state.rotation_rad)}"
                f", pitch {degrees(state.imu_rad.get('pitch'))}",
            )
        )
    lines.append(_link_line(health, now_s))
    return lines


@dataclass(frozen=True, slots=True)
class Snapshot:
    """Everything one redraw of the console needs, taken after one tick.

    Attributes:
        time_s: Clock time of the snapshot.
        status: The status panel.
        tree: The running tree as text (empty when no tree is attached).
        verdicts: The condensed verdict log (newest last).
        pending: Steps waiting for the operator's confirmation (supervised mode).
        finished: A line saying how the attached tree's run ended, once it has.
    """

    time_s: float
    status: tuple[StatusLine, ...]
    tree: tuple[str, ...] = ()
    verdicts: tuple[str, ...] = ()
    pending: tuple[str, ...] = ()
    finished: str | None = None

    def text(self) -> str:
        """The whole snapshot as plain text (scripts, logs and tests)."""
        out = [f"t = {self.time_s:.2f} s"]
        out += [f"{line.label:>10}: {line.text}" for line in self.status]
        if self.pending:
            out.append("waiting for confirmation: " + ", ".join(self.pending) + " (y/n)")
        if self.finished:
            out.append(self.finished)
        out += list(self.tree)
        return "\n".join(out)
