"""What a navigator is told before each step: :class:`Observation`, with its parts.

Split out of :mod:`pirate_bt.task.navigation` (steps, their checks and the navigator
protocol), which re-exports every name here. A navigator is handed an
:class:`Observation` before every decision: where the robot believes it is
(:class:`Belief`), what it felt during the last step (:class:`Felt`), how that step
ended, the map if there is one (:meth:`Observation.next_feature` reads the next
feature on it, an :class:`Ahead`), and what the robot's own sensors read of the pipe
where it stands. Nothing in it reaches the robot.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from pirate_bt.pipes import Network
    from pirate_bt.task.outcome import PabOutcome

__all__ = ["Ahead", "Belief", "Felt", "Observation", "OffWall"]


@dataclass(frozen=True)
class Belief:
    """Where the robot believes its front tip is.

    Attributes:
        position_m: Metres along the way taken (the map's path, or the odometry's
            distance from the start when there is no map; backwards counts down).
        segment: The map's segment there (``None`` without a map).
        uncertainty_m: How far off the belief may be (the map's tolerance since the
            last recognised feature; the odometry's own error bound without a map).
        on_map: True when the belief is a position on a map.
    """

    position_m: float
    segment: str | None = None
    uncertainty_m: float = 0.0
    on_map: bool = False


@dataclass(frozen=True)
class Felt:
    """A feature the robot felt (sensed) during a step.

    Attributes:
        kind: ``bend`` (a turn: sensed by the IMU, passed by a PAB, or found by
            ``probe-turn``), ``tee`` (an opening sensed by the joints, or passed),
            ``end`` (``probe-turn`` found no way on: the end of the pipe), ``opening``
            (``probe-tee`` found an opening but no branch it could steer into), or, without
            a map, ``feature`` (a straight step with ``stop_at_feature`` or
            ``stop_at_change`` stopped early).
        at_m: The belief when it was felt.
        segment: The map's segment it was matched to (``None`` without a map).
        direction: ``bend``: the direction of the turn (taken, or found by a probe);
            ``tee``: the way taken (``probe-tee``: the side its branch leaves on).
        how: What sensed it (``imu``, ``joints``, ``pab``, ``back`` (passed
            backwards by ``bend-back`` or ``t-joint-back``), ``probe``; for a
            ``feature``: ``blocked``, every drive at stall current with no progress,
            ``opening``, a front joint swung off the wall, ``slope``, the IMU's pitch
            changed, or ``diameter``, a leading joint at the wall read another diameter).
    """

    kind: str
    at_m: float
    segment: str | None = None
    direction: str | None = None
    how: str = "pab"

    def to_json(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if v is not None}


@dataclass(frozen=True)
class OffWall:
    """A bend joint that swung off the wall during a step with no map: over an opening
    (a tee's branch), as the drive tells one (past every wall-contact angle).

    Attributes:
        joint: The bend module (``bend_1``: the front half's first).
        at_m: The belief (the front tip) when it swung off.
        back_m: The belief when it was back within the wall-contact angles;
            ``None``: still off the wall as the step ended.
        behind_m: How far the joint (its module's middle) is behind the front tip:
            the opening's near edge is about ``at_m - behind_m`` along the way.
    """

    joint: str
    at_m: float
    back_m: float | None
    behind_m: float

    @property
    def where_m(self) -> float:
        """Where along the way the joint swung off: about the opening's near edge."""
        return self.at_m - self.behind_m

    def to_json(self) -> dict[str, Any]:
        return {k: round(v, 4) if isinstance(v, float) else v for k, v in self.__dict__.items()}


@dataclass(frozen=True)
class Ahead:
    """The next feature on the map (:meth:`Observation.next_feature`).

    Attributes:
        kind: ``bend`` or ``tee``.
        segment: Its segment id on the map.
        distance_m: From the front tip to where it starts.
        turn: ``bend``: the direction it turns (``up``, ``down``, ``left``, ``right``).
        branch: ``tee``: the side its branch leaves on (``left``, ``right``...).
    """

    kind: str
    segment: str
    distance_m: float
    turn: str | None = None
    branch: str | None = None


@dataclass(frozen=True)
class Observation:
    """What a navigator is told before it chooses the next step.

    Attributes:
        step: Steps run so far (0 before the first).
        belief: Where the robot believes it is.
        felt: Features felt during the last step, in order.
        last: The last step's outcome (``None`` before the first); ``last.why``
            names the cause of a failure.
        map: The map, when the navigation has one.
        time_s: The run's clock, since the start.
        choices: The way taken at each T-joint of the map so far (segment -> way).
        history: Every step run so far (a :class:`~pirate_bt.task.navigation.Step`)
            with its outcome, oldest first.
        robot_length_m: The robot's length, front tip to rear tip.
        diameter_m: The pipe's diameter where the rear half holds, from its joints'
            wall-contact angles (``None`` without a reading).
        pitch_rad: The pipe's slope at the rotational module, from the IMU (positive
            uphill; ``None`` without a reading).
        front_diameter_m: The same as ``diameter_m`` where the front half is, from its
            joints at the wall (``None`` when none is, e.g. over an opening).
        imu_behind_m: How far the IMU (the rotational module's middle) is behind the
            front tip: where a ``slope`` change was felt.
        joint_behind_m: How far the front half's first bend module (its middle) is
            behind the front tip: where an opening or a ``diameter`` change was felt.
        rear_joint_behind_m: How far the rear half's last bend module (its middle) is
            behind the front tip: the last joint to leave an opening the robot passes
            (0 when not told).
        yaw_rad: The pipe's heading at the rotational module, from the IMU (the
            world's frame: only its change means anything without a map, e.g. across
            a bend left or right; ``None`` without a reading).
        off_wall: Without a map: every time a bend joint swung off the wall during the
            last step (over an opening), oldest first. A step that drives the robot
            across two openings (a second tee close after the one passed) shows the
            second here, where ``felt`` names only the feature the step was for.
    """

    step: int
    belief: Belief
    felt: tuple[Felt, ...] = ()
    last: PabOutcome | None = None
    map: Network | None = None
    time_s: float = 0.0
    choices: Mapping[str, str] = field(default_factory=dict)
    history: tuple[tuple[Any, str], ...] = ()  # Steps: that module imports this one
    robot_length_m: float = 0.0
    diameter_m: float | None = None
    pitch_rad: float | None = None
    front_diameter_m: float | None = None
    imu_behind_m: float = 0.0
    joint_behind_m: float = 0.0
    yaw_rad: float | None = None
    off_wall: tuple[OffWall, ...] = ()
    rear_joint_behind_m: float = 0.0

    def next_feature(self) -> Ahead | None:
        """The next bend or T-joint ahead on the map, along the way taken so far.

        At T-joints not passed yet the way goes straight on. ``None`` without a map or
        when no feature is ahead (then :meth:`to_end_m` says how far the pipe goes).
        """
        if self.map is None:
            return None
        from pirate_bt.pipes import PieceKind
        from pirate_bt.task.plan import direction_name
        from pirate_bt.task.walker import branch_side

        here = self.belief.position_m
        for piece in self.map.path(dict(self.choices)).pieces:
            if piece.kind not in (PieceKind.BEND, PieceKind.TEE) or piece.start_m <= here + 1e-3:
                continue
            side = direction_name(piece.roll_rad)
            if piece.kind is PieceKind.BEND:
                return Ahead("bend", piece.segment, piece.start_m - here, turn=side)
            # the way a t-joint step takes into it, as the IMU reads it (the same but
            # where the pipe's frame is twisted off gravity's: task.walker.branch_side)
            branch = branch_side(piece) or side
            return Ahead("tee", piece.segment, piece.start_m - here, branch=branch)
        return None

    def to_end_m(self) -> float | None:
        """How far the front tip is from the end of the pipe on the map (``None``
        without a map), along the way taken so far."""
        if self.map is None:
            return None
        path = self.map.path(dict(self.choices))
        return float(path.length_m - self.belief.position_m)

    def to_json(self) -> dict[str, Any]:
        """The observation as a trace record's fields."""
        return {
            "step": self.step,
            "time_s": round(self.time_s, 4),
            "belief_m": round(self.belief.position_m, 4),
            "segment": self.belief.segment,
            "uncertainty_m": round(self.belief.uncertainty_m, 4),
            "felt": [f.to_json() for f in self.felt],
            "last": None
            if self.last is None
            else {"label": self.last.label, "outcome": self.last.outcome, "why": self.last.why},
            "choices": dict(self.choices),
            "diameter_m": None if self.diameter_m is None else round(self.diameter_m, 5),
            "pitch_rad": None if self.pitch_rad is None else round(self.pitch_rad, 5),
            **({"off_wall": [o.to_json() for o in self.off_wall]} if self.off_wall else {}),
        }
