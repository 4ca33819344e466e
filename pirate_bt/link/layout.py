"""The robot-dependent wire layout: sizes of the STATE, BULK_SETPOINTS and COUNTERS payloads.

Both ends derive it from the robot description (``docs/protocol.md``, Layout).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path

from pirate_bt.errors import ConfigurationError, LocatedError, ValidationFailed
from pirate_bt.link.framing import HEADER_BYTES, MAX_PAYLOAD_BYTES
from pirate_bt.robot.description import ControlMode, Motor, MotorFunction, RobotDescription
from pirate_bt.robot.header import uncovered_boards

__all__ = [
    "LayoutError",
    "LayoutTooLarge",
    "LayoutUncovered",
    "StopRole",
    "WireLayout",
    "layout_text",
    "stop_role",
    "validate_robot_file",
]

COUNTERS_FIXED_BYTES = 20
"""The COUNTERS payload's bridge figures; each board adds :data:`COUNTERS_BOARD_BYTES`."""
COUNTERS_BOARD_BYTES = 13


class LayoutError(ConfigurationError, ValueError):
    """A robot description the PIRATEbay protocol cannot carry (exit 2, an unusable
    description; a ``ValueError`` as before)."""


class LayoutTooLarge(LayoutError):
    """A robot description whose frames do not fit the protocol's largest frame."""


class LayoutUncovered(LayoutError):
    """A robot description with a board that has no motor and no sensor: it takes a
    board status nibble and a ``COUNTERS`` entry, but the layout digest, which names
    only channels and motors, cannot see it."""


class StopRole(StrEnum):
    """What a stop does to a motor (docs/protocol.md, Stop category)."""

    DRIVE = "drive"
    """Velocity 0 at once."""
    ROTATE = "rotate"
    """PWM 0 (brake) at once."""
    BEND = "bend"
    """Unchanged: the clamps keep holding."""
    OTHER = "other"
    """PWM 0 (brake)."""


def stop_role(motor: Motor) -> StopRole:
    """The stop role of ``motor``, from its function in the robot description."""
    function = motor.function
    if function is MotorFunction.DRIVE:
        return StopRole.DRIVE
    if function is MotorFunction.ROTATE:
        return StopRole.ROTATE
    if function is MotorFunction.BEND:
        return StopRole.BEND
    return StopRole.OTHER


def layout_text(robot: RobotDescription) -> str:
    """The text whose SHA-256 gives the layout digest (docs/protocol.md, Layout).

    Args:
        robot: A validated robot description.

    Returns:
        ``C|M``: channels as ``board:name``, motors as ``board:slot:role:modes``.
    """
    channels = ";".join(f"{c.board}:{c.name}" for c in robot.state_channels())
    motors = []
    for s in robot.setpoint_slots():
        modes = ",".join(
            f"{mode.value}={conv.raw[0]}..{conv.raw[1]}"
            for mode in ControlMode
            if (conv := s.motor.modes.get(mode)) is not None
        )
        motors.append(f"{s.board}:{s.slot}:{stop_role(s.motor).value}:{modes}")
    return channels + "|" + ";".join(motors)


def digest_of(text: str) -> int:
    """The first 4 bytes (big-endian) of SHA-256 over ``text``."""
    return int.from_bytes(hashlib.sha256(text.encode()).digest()[:4], "big")


@dataclass(frozen=True, slots=True)
class WireLayout:
    """The robot-dependent sizes of the STATE and BULK_SETPOINTS payloads.

    Attributes:
        n_channels: int16 channels in the state frame.
        n_motors: Motors in the bulk setpoint frame.
        n_boards: Boards (one status nibble each).
        digest: 32-bit layout digest both ends compare at hello time.
    """

    n_channels: int
    n_motors: int
    n_boards: int
    digest: int

    @classmethod
    def from_robot(cls, robot: RobotDescription) -> WireLayout:
        """The layout of ``robot``'s wire frames.

        Args:
            robot: A validated robot description.

        Returns:
            Its wire layout.

        Raises:
            LayoutTooLarge: the STATE, BULK_SETPOINTS or COUNTERS frame would exceed the
                largest frame (a ``ConfigurationError``, exit 2, and a ``ValueError``).
            LayoutUncovered: a board with no motor and no sensor (the same kinds).
        """
        if (uncovered := uncovered_boards(robot)) is not None:
            raise LayoutUncovered(uncovered)
        try:
            return cls(
                n_channels=len(robot.state_channels()),
                n_motors=len(robot.setpoint_slots()),
                n_boards=len(robot.board_ids()),
                digest=robot.layout_digest(),
            )
        except LayoutTooLarge as exc:
            raise LayoutTooLarge(f"robot {robot.name!r}: {exc}") from None

    def __post_init__(self) -> None:
        why = "the robot description does not fit the PIRATEbay protocol's frames: "
        most = MAX_PAYLOAD_BYTES
        if self.state_payload_bytes > most:
            raise LayoutTooLarge(
                f"{why}{self.n_channels} channels and {self.n_boards} boards need a"
                f" {self.state_payload_bytes}-byte STATE payload (max {most})"
            )
        if self.bulk_payload_bytes > most:
            raise LayoutTooLarge(
                f"{why}{self.n_motors} motors need a {self.bulk_payload_bytes}-byte"
                f" BULK_SETPOINTS payload (max {most}: {most // 3} motors)"
            )
        if self.counters_payload_bytes > most:
            boards = (most - COUNTERS_FIXED_BYTES) // COUNTERS_BOARD_BYTES
            raise LayoutTooLarge(
                f"{why}{self.n_boards} boards need a {self.counters_payload_bytes}-byte"
                f" COUNTERS payload (max {most}: {boards} boards)"
            )

    @property
    def mask_bytes(self) -> int:
        """Bytes of the fresh bitmask: ceil(n_channels / 8)."""
        return (self.n_channels + 7) // 8

    @property
    def status_bytes(self) -> int:
        """Bytes of board status: ceil(n_boards / 2), two nibbles per byte."""
        return (self.n_boards + 1) // 2

    @property
    def state_payload_bytes(self) -> int:
        """STATE payload: ack_seq, fresh mask, board status, channels."""
        return 2 + self.mask_bytes + self.status_bytes + 2 * self.n_channels

    @property
    def counters_payload_bytes(self) -> int:
        """COUNTERS payload: the bridge's figures, then one entry per board."""
        return COUNTERS_FIXED_BYTES + COUNTERS_BOARD_BYTES * self.n_boards

    @property
    def bulk_payload_bytes(self) -> int:
        """BULK_SETPOINTS payload: one mode byte and one int16 per motor."""
        return 3 * self.n_motors

    def wire_bytes(self, payload_bytes: int) -> int:
        """Worst-case wire size of a frame with ``payload_bytes`` of payload.

        Args:
            payload_bytes: Payload size.

        Returns:
            Header + payload + CRC + COBS overhead + delimiter.
        """
        body = HEADER_BYTES + payload_bytes + 2
        return body + (body + 253) // 254 + 1


def validate_robot_file(path: str | Path) -> RobotDescription:
    """A robot description file checked as ``pirate-bt validate`` checks it: its schema
    and cross-checks (:func:`~pirate_bt.robot.loader.load_robot`), then that its frames
    fit the PIRATEbay protocol's largest frame, as every run needs (:class:`WireLayout`).

    Raises:
        ValidationFailed: the file does not validate, its STATE, BULK_SETPOINTS or
            COUNTERS frame would not fit, or a board has no motor and no sensor (placed
            at its ``boards`` key).
    """
    from pirate_bt.robot.loader import load_robot
    from pirate_bt.yamlfile import load_yaml

    robot = load_robot(path)
    try:
        WireLayout.from_robot(robot)
    except LayoutError as exc:
        where = load_yaml(path).locator.locate(("boards",))
        raise ValidationFailed([LocatedError(str(exc), where)]) from None
    return robot
