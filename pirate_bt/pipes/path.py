"""Paths through a pipe network: :class:`Piece` objects laid end to end by distance
along the pipe axis, and the 3-D vector arithmetic that lays them.

Split from :mod:`pirate_bt.pipes.network` (which builds them and re-exports every name
here); see its docstring for the frames and the roll convention.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Literal

from pirate_bt.pipes.arguments import distance_argument

__all__ = ["Path", "Piece", "PieceKind", "TeeChoice", "Vec3"]

Vec3 = tuple[float, float, float]
TeeChoice = Literal["straight", "branch"]


class PieceKind(StrEnum):
    """What a piece of a path is."""

    STRAIGHT = "straight"
    BEND = "bend"
    TEE = "tee"
    """The straight run through a tee (over its opening)."""
    TEE_TURN = "tee_turn"
    """The turn from the middle of a tee into its branch (works like a bend)."""
    REDUCER = "reducer"


def _add(a: Vec3, b: Vec3, k: float = 1.0) -> Vec3:
    return (a[0] + k * b[0], a[1] + k * b[1], a[2] + k * b[2])


def _scale(a: Vec3, k: float) -> Vec3:
    return (a[0] * k, a[1] * k, a[2] * k)


def _dot(a: Vec3, b: Vec3) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a: Vec3, b: Vec3) -> Vec3:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _unit(a: Vec3) -> Vec3:
    n = math.sqrt(_dot(a, a))
    return _scale(a, 1.0 / n)


def _comb(a: Vec3, ka: float, b: Vec3, kb: float) -> Vec3:
    return (ka * a[0] + kb * b[0], ka * a[1] + kb * b[1], ka * a[2] + kb * b[2])


@dataclass(frozen=True, slots=True)
class Piece:
    """One piece of a path, from ``start_m`` to ``end_m`` along the axis.

    Attributes:
        segment: Id of the segment in the network file (tee pieces: the tee's id).
        kind: What the piece is.
        start_m: Distance of its start from the start of the main line.
        end_m: Distance of its end.
        diameter_start_m: Internal diameter at the start.
        diameter_end_m: Internal diameter at the end (differs for reducers).
        roll_rad: Bends and tee turns: the roll of the turn. Tees: the roll of the
            branch opening. Otherwise 0.
        angle_rad: How far the pipe turns over the piece (0 unless a turn).
        radius_m: Centre-line radius of a turn (0 unless a turn).
        tangent: Unit direction of travel at the start.
        up: Unit cross-section "up" reference at the start.
        origin: 3-D position of the start (metres; the main line starts at 0).
        opening_m: Tees: distance of the middle of the branch opening (the opening is
            one diameter wide); ``None`` for other pieces.
    """

    segment: str
    kind: PieceKind
    start_m: float
    end_m: float
    diameter_start_m: float
    diameter_end_m: float
    roll_rad: float
    angle_rad: float
    radius_m: float
    tangent: Vec3
    up: Vec3
    origin: Vec3
    opening_m: float | None = None

    @property
    def length_m(self) -> float:
        return self.end_m - self.start_m

    def over_opening(self, s_m: float) -> bool:
        """True when ``s_m`` lies over a tee's branch opening (one diameter wide)."""
        if self.opening_m is None:
            return False
        return abs(s_m - self.opening_m) <= self.diameter_start_m / 2

    @property
    def is_turn(self) -> bool:
        """True for the curved part of a bend or of the turn into a tee branch."""
        return self.kind in (PieceKind.BEND, PieceKind.TEE_TURN)

    def _turn_dir(self) -> Vec3:
        right = _cross(self.tangent, self.up)
        return _comb(self.up, math.cos(self.roll_rad), right, math.sin(self.roll_rad))

    def frame_at(self, s_m: float) -> tuple[Vec3, Vec3]:
        """``(tangent, up)`` at distance ``s_m`` (clamped to the piece)."""
        if not self.is_turn:
            return self.tangent, self.up
        theta = self._theta(s_m)
        d = self._turn_dir()
        right = _cross(self.tangent, self.up)
        e = _comb(self.up, -math.sin(self.roll_rad), right, math.cos(self.roll_rad))
        t2 = _comb(self.tangent, math.cos(theta), d, math.sin(theta))
        d2 = _comb(self.tangent, -math.sin(theta), d, math.cos(theta))
        up2 = _comb(d2, math.cos(self.roll_rad), e, -math.sin(self.roll_rad))
        return t2, up2

    @property
    def imu_roll_rad(self) -> float:
        """The turn's roll (``roll_rad``) as the robot's IMU measures roll at its start.

        ``roll_rad`` is in the pipe's own frame, carried along without twisting; the
        IMU measures roll from gravity's up in the cross-section (on a vertical pipe,
        where gravity has no direction there, from the pipe's "up"). The two agree on
        level, sloping and vertical runs reached by bends up and down; after a bend at
        another roll on a slope they differ (a bend at roll 135 deg leaves the pipe
        going down at 45 deg with its "up" 45 deg off gravity's). A half aligned on
        this roll by the IMU lies in the turn's plane.
        """
        t, up = self.tangent, self.up
        zp = (-t[2] * t[0], -t[2] * t[1], 1.0 - t[2] * t[2])  # gravity's up, projected
        n = math.sqrt(_dot(zp, zp))
        if n < 1e-6:
            return self.roll_rad  # vertical: the IMU reads roll from the pipe's "up"
        zp = _scale(zp, 1.0 / n)
        offset = math.atan2(_dot(up, _cross(t, zp)), _dot(up, zp))
        if abs(offset) < 1e-9:
            return self.roll_rad
        return math.remainder(self.roll_rad + offset, 2 * math.pi)

    def _theta(self, s_m: float) -> float:
        frac = min(max((s_m - self.start_m) / self.length_m, 0.0), 1.0)
        return frac * self.angle_rad

    def position_at(self, s_m: float) -> Vec3:
        """3-D position of the axis at distance ``s_m`` (clamped to the piece)."""
        if not self.is_turn:
            u = min(max(s_m - self.start_m, 0.0), self.length_m)
            return _add(self.origin, self.tangent, u)
        theta = self._theta(s_m)
        d = self._turn_dir()
        p = _add(self.origin, self.tangent, self.radius_m * math.sin(theta))
        return _add(p, d, self.radius_m * (1.0 - math.cos(theta)))

    def diameter_at(self, s_m: float) -> float:
        frac = min(max((s_m - self.start_m) / self.length_m, 0.0), 1.0)
        return self.diameter_start_m + frac * (self.diameter_end_m - self.diameter_start_m)

    def end_frame(self) -> tuple[Vec3, Vec3]:
        return self.frame_at(self.end_m)


@dataclass(frozen=True)
class Path:
    """A way through the network, from the main line's start to the end of a line.

    Attributes:
        pieces: The pieces end to end, by increasing distance.
        choices: The way taken at each tee met, by tee id.
    """

    pieces: tuple[Piece, ...]
    choices: Mapping[str, TeeChoice] = field(default_factory=dict)
    _hint: list[int] = field(default_factory=lambda: [0], compare=False, repr=False)

    def __hash__(self) -> int:
        # a value, as frozen says: equal paths hash alike (the generated hash raised
        # "unhashable type: 'dict'" on the choices)
        return hash((self.pieces, tuple(sorted(self.choices.items()))))

    @property
    def length_m(self) -> float:
        return self.pieces[-1].end_m if self.pieces else 0.0

    @property
    def segments(self) -> list[str]:
        """Segment ids along the path, in order, without repeats."""
        out: list[str] = []
        for p in self.pieces:
            if not out or out[-1] != p.segment:
                out.append(p.segment)
        return out

    def index_at(self, s_m: float) -> int:
        """Index of the piece holding distance ``s_m`` (ends belong to the next piece).

        Raises:
            ArgumentTypeError: ``s_m`` is no number; ArgumentValueError: it is ``nan``.
        """
        if type(s_m) is not float or s_m != s_m:  # every distance method asks here
            s_m = distance_argument(s_m)
        pieces = self.pieces
        hint = self._hint[0]
        piece = pieces[hint]
        if piece.start_m <= s_m < piece.end_m:
            return hint  # the common case: the same piece as the last question
        lo, hi = 0, len(pieces) - 1
        if s_m <= pieces[0].start_m:
            return 0
        if s_m >= pieces[-1].end_m:
            return hi
        while lo < hi:
            mid = (lo + hi) // 2
            if pieces[mid].end_m <= s_m:
                lo = mid + 1
            else:
                hi = mid
        self._hint[0] = lo
        return lo

    def piece_at(self, s_m: float) -> Piece:
        """The feature at distance ``s_m`` (held at the path's ends)."""
        return self.pieces[self.index_at(s_m)]

    def diameter_at(self, s_m: float) -> float:
        """Internal diameter at ``s_m`` in metres."""
        return self.piece_at(s_m).diameter_at(s_m)

    def tangent_at(self, s_m: float) -> Vec3:
        return self.piece_at(s_m).frame_at(s_m)[0]

    def frame_at(self, s_m: float) -> tuple[Vec3, Vec3]:
        """``(tangent, up)`` at ``s_m``."""
        return self.piece_at(s_m).frame_at(s_m)

    def slope_at(self, s_m: float) -> float:
        """Inclination of the axis to the horizontal at ``s_m``; positive uphill (rad)."""
        t = self.tangent_at(s_m)
        return math.asin(max(-1.0, min(1.0, t[2])))

    def position_at(self, s_m: float) -> Vec3:
        return self.piece_at(s_m).position_at(s_m)

    def next_turn(self, s_m: float) -> Piece | None:
        """The first turn (bend or tee turn) that ends after ``s_m``, if any."""
        for piece in self.pieces[self.index_at(s_m) :]:
            if piece.is_turn and piece.end_m > s_m:
                return piece
        return None

    def features(self) -> Iterator[Piece]:
        """The pieces that are not plain straights: bends, tees, tee turns, reducers."""
        return (p for p in self.pieces if p.kind is not PieceKind.STRAIGHT)
