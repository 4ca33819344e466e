"""The pipe network as a map: lines, junctions, and paths through them.

:class:`Network` is built from a validated :class:`~pirate_bt.pipes.model.NetworkSpec`.
It is the world of the simulator and, later, the map of the task layer. The
network is a tree (gas mains are): the main line, and at each tee a branch line.
A *path* is what a robot drives: from the start of the main line, going
``straight`` or into the ``branch`` at every tee it meets, to the end of a line.

A :class:`Path` is a list of :class:`Piece` objects laid end to end by distance
along the pipe axis (metres from the start of the main line). Each piece knows
its kind, diameter, the roll of its turn and its 3-D frame, so the path answers
"what is at distance s", "what is the slope here", "what is the diameter here".

Frames: ``tangent`` points along the travel; ``up`` is a cross-section
direction carried along without twisting (parallel transport), starting as the
world's up (+z); ``right = tangent x up``. A turn of roll ``r`` points toward
``cos(r) * up + sin(r) * right``: 0 is up, +90° right, 180° down, -90° left.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from enum import StrEnum
from typing import Literal

from pirate_bt.errors import ConfigurationError
from pirate_bt.pipes.arguments import (
    check_spec,
    checked_choices,
    distance_argument,
    unknown_segment,
)
from pirate_bt.pipes.model import (
    BendSpec,
    FaultSpec,
    NetworkSpec,
    ReducerSpec,
    SegmentSpec,
    StraightSpec,
    TeeSpec,
)

__all__ = ["Network", "NetworkGeometryError", "Path", "Piece", "PieceKind", "TeeChoice", "Vec3"]

Vec3 = tuple[float, float, float]
TeeChoice = Literal["straight", "branch"]

_EPS = 1e-9


class NetworkGeometryError(ConfigurationError):
    """A network whose parts do not fit together; ``path`` is the key to blame."""

    def __init__(self, message: str, path: tuple[str | int, ...] = ("segments",)) -> None:
        super().__init__(message)
        self.path = path


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


class _Builder:
    def __init__(self, spec: NetworkSpec) -> None:
        self.spec = spec

    def build(self, choices: Mapping[str, TeeChoice]) -> Path:
        pieces: list[Piece] = []
        taken: dict[str, TeeChoice] = {}
        state = _Cursor(
            s_m=0.0,
            diameter_m=self.spec.diameter,
            tangent=(math.cos(self.spec.slope), 0.0, math.sin(self.spec.slope)),
            up=(-math.sin(self.spec.slope), 0.0, math.cos(self.spec.slope)),
            origin=(0.0, 0.0, 0.0),
        )
        self._line(self.spec.segments, "main", state, pieces, choices, taken, ("segments",))
        return Path(tuple(pieces), taken)

    def _line(
        self,
        segments: Sequence[SegmentSpec],
        prefix: str,
        cur: _Cursor,
        pieces: list[Piece],
        choices: Mapping[str, TeeChoice],
        taken: dict[str, TeeChoice],
        where: tuple[str | int, ...],
    ) -> None:
        for i, seg in enumerate(segments):
            name = seg.id or f"{prefix}-{i + 1}"
            here = (*where, i)
            if isinstance(seg, StraightSpec):
                if seg.diameter is not None:
                    cur.diameter_m = seg.diameter
                if seg.slope is not None:
                    cur.set_slope(seg.slope, name, (*here, "slope"))
                cur.where = (*here, "length")
                pieces.append(cur.straight(name, PieceKind.STRAIGHT, seg.length))
            elif isinstance(seg, BendSpec):
                _check_radius(name, seg.radius, cur.diameter_m, (*here, "radius"))
                cur.where = (*here, "angle")
                pieces.append(cur.turn(name, PieceKind.BEND, seg.roll_rad, seg.angle, seg.radius))
            elif isinstance(seg, ReducerSpec):
                cur.where = (*here, "length")
                pieces.append(cur.straight(name, PieceKind.REDUCER, seg.length, seg.diameter))
            elif isinstance(seg, TeeSpec):
                length = seg.length if seg.length is not None else 3.0 * cur.diameter_m
                if length < cur.diameter_m - _EPS:  # its opening reached into its neighbours
                    raise NetworkGeometryError(
                        f"segment {name!r}: a tee {length * 1000:g} mm long in a"
                        f" {cur.diameter_m * 1000:g} mm pipe; its branch opening is one"
                        " diameter wide, so a tee is at least one diameter long",
                        (*here, "length"),
                    )
                roll = seg.branch.roll_rad
                choice = choices.get(name, "straight")
                taken[name] = choice
                opening = cur.s_m + length / 2
                radius = seg.branch.radius if seg.branch.radius is not None else cur.diameter_m
                _check_radius(name, radius, cur.diameter_m, (*here, "branch", "radius"))
                cur.where = (*here, "length")
                if choice == "straight":
                    pieces.append(cur.straight(name, PieceKind.TEE, length, roll_rad=roll))
                    pieces[-1] = replace(pieces[-1], opening_m=opening)
                    continue
                pieces.append(cur.straight(name, PieceKind.TEE, length / 2, roll_rad=roll))
                pieces[-1] = replace(pieces[-1], opening_m=opening)
                pieces.append(cur.turn(name, PieceKind.TEE_TURN, roll, math.pi / 2, radius))
                branch = (*here, "branch", "segments")
                self._line(seg.branch.segments, f"{name}-b", cur, pieces, choices, taken, branch)
                return


def _check_radius(
    name: str, radius_m: float, diameter_m: float, where: tuple[str | int, ...]
) -> None:
    """A turn's centre line cannot curve tighter than the pipe's own radius."""
    if radius_m < diameter_m / 2 - _EPS:
        raise NetworkGeometryError(
            f"segment {name!r}: a turn of radius {radius_m * 1000:g} mm in a"
            f" {diameter_m * 1000:g} mm pipe; its radius is at least half the diameter",
            where,
        )


@dataclass
class _Cursor:
    s_m: float
    diameter_m: float
    tangent: Vec3
    up: Vec3
    origin: Vec3
    where: tuple[str | int, ...] = ("segments",)  # the key of the piece being laid

    def straight(
        self,
        name: str,
        kind: PieceKind,
        length_m: float,
        diameter_end_m: float | None = None,
        roll_rad: float = 0.0,
    ) -> Piece:
        d_end = self.diameter_m if diameter_end_m is None else diameter_end_m
        piece = Piece(
            name,
            kind,
            self.s_m,
            self.s_m + length_m,
            self.diameter_m,
            d_end,
            roll_rad,
            0.0,
            0.0,
            self.tangent,
            self.up,
            self.origin,
        )
        self._advance(piece, d_end)
        return piece

    def turn(
        self, name: str, kind: PieceKind, roll_rad: float, angle_rad: float, radius_m: float
    ) -> Piece:
        piece = Piece(
            name,
            kind,
            self.s_m,
            self.s_m + radius_m * angle_rad,
            self.diameter_m,
            self.diameter_m,
            roll_rad,
            angle_rad,
            radius_m,
            self.tangent,
            self.up,
            self.origin,
        )
        self._advance(piece, self.diameter_m)
        return piece

    def _advance(self, piece: Piece, diameter_m: float) -> None:
        if piece.end_m <= piece.start_m:  # 1 m + 1e-300 m is 1 m: a turn would divide by 0
            raise NetworkGeometryError(
                f"segment {piece.segment!r} has no length {piece.start_m:g} m along its line"
                " (too short for a distance there to tell its start from its end);"
                " make it longer or leave it out",
                self.where,
            )
        self.s_m = piece.end_m
        self.diameter_m = diameter_m
        self.origin = piece.position_at(piece.end_m)
        self.tangent, self.up = (_unit(v) for v in piece.end_frame())

    def set_slope(self, slope_rad: float, name: str, where: tuple[str | int, ...]) -> None:
        t = self.tangent
        horizontal = math.hypot(t[0], t[1])
        if horizontal < 1e-6:
            current = math.asin(max(-1.0, min(1.0, t[2])))
            if abs(current - slope_rad) < 1e-6:
                return
            raise NetworkGeometryError(
                f"segment {name!r}: cannot set a slope on a vertical run; use a bend", where
            )
        h = (t[0] / horizontal, t[1] / horizontal, 0.0)
        new_t = _comb(h, math.cos(slope_rad), (0.0, 0.0, 1.0), math.sin(slope_rad))
        self.up = _unit(_rotate_minimal(self.up, t, new_t))
        self.tangent = new_t


def _rotate_minimal(v: Vec3, a: Vec3, b: Vec3) -> Vec3:
    """Rotate ``v`` by the smallest rotation taking unit ``a`` to unit ``b`` (Rodrigues)."""
    axis = _cross(a, b)
    sin = math.sqrt(_dot(axis, axis))
    cos = _dot(a, b)
    if sin < _EPS:
        return v
    k = _scale(axis, 1.0 / sin)
    kxv = _cross(k, v)
    kdv = _dot(k, v)
    return _add(_add(_scale(v, cos), kxv, sin), k, kdv * (1.0 - cos))


class Network:
    """A validated pipe network: the world of the simulator and the task layer's map.

    Args:
        spec: The validated file contents.
        source: Where it was loaded from (for messages).
    """

    def __init__(self, spec: NetworkSpec, source: str = "<network>") -> None:
        check_spec(spec, source)
        self.spec = spec
        self.source = source
        self._builder = _Builder(spec)
        self._tees: dict[str, TeeSpec] = {}
        self._segments: dict[str, SegmentSpec] = {}
        self._index(spec.segments, "main")
        self._cache: dict[tuple[tuple[str, TeeChoice], ...], Path] = {}
        length = self.main_path().length_m  # fail early on impossible geometry
        position = spec.start.position
        if position is not None and position > length + _EPS:
            raise NetworkGeometryError(
                f"the start position {position:g} m is beyond the end of the main line"
                f" ({length:.3f} m)",
                ("start", "position"),
            )

    def _index(self, segments: Sequence[SegmentSpec], prefix: str) -> None:
        for i, seg in enumerate(segments):
            name = seg.id or f"{prefix}-{i + 1}"
            self._segments[name] = seg
            if isinstance(seg, TeeSpec):
                self._tees[name] = seg
                self._index(seg.branch.segments, f"{name}-b")

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def tether_drag_per_m(self) -> float:
        """Tether drag in newtons per metre of tether in the pipe."""
        return self.spec.tether_drag_per_metre

    @property
    def faults(self) -> list[FaultSpec]:
        return list(self.spec.faults)

    def tee_ids(self) -> list[str]:
        """Ids of every tee, main line first."""
        return list(self._tees)

    def segment_ids(self) -> list[str]:
        """Ids of every segment (given, or ``main-N`` / ``TEE-bN`` when not given)."""
        return list(self._segments)

    def segment(self, segment_id: str) -> SegmentSpec:
        """The file's spec of a segment (``UnknownSegmentError``, a ``KeyError``, if none)."""
        try:
            return self._segments[segment_id]
        except (KeyError, TypeError):
            raise unknown_segment("segment", segment_id, list(self._segments)) from None

    def path(self, choices: Mapping[str, TeeChoice] | None = None) -> Path:
        """The path taking ``choices`` at tees (``straight`` where not given).

        Raises:
            UnknownSegmentError: a choice names an unknown tee (an ``InputError`` and
                a ``KeyError``).
            ArgumentValueError: a choice is neither ``straight`` nor ``branch``.
            ArgumentTypeError: ``choices`` is no mapping.
            ConfigurationError: the geometry is impossible (a slope on a vertical run).
        """
        checked = checked_choices(choices, list(self._tees))
        path = self._builder.build(checked)  # type: ignore[arg-type]
        key = tuple(sorted(path.choices.items()))
        return self._cache.setdefault(key, path)

    def main_path(self) -> Path:
        """Straight through every tee, to the end of the main line."""
        return self.path({})

    def paths(self) -> list[Path]:
        """Every distinct path from the start to the end of some line."""
        out: list[Path] = []

        def explore(choices: dict[str, TeeChoice]) -> None:
            path = self.path(choices)
            undecided = [t for t in path.choices if t not in choices]
            if not undecided:
                out.append(path)
                return
            tee = undecided[0]
            for option in ("straight", "branch"):
                explore({**choices, tee: option})

        explore({})
        return out

    def total_length_m(self) -> float:
        """Length of pipe in the network (every line once)."""
        seen: dict[tuple[str, PieceKind], float] = {}
        for path in self.paths():
            for p in path.pieces:
                key = (p.segment, p.kind)
                seen[key] = max(seen.get(key, 0.0), p.length_m)
        return sum(seen.values())

    def __repr__(self) -> str:
        return f"Network({self.name!r}, {len(self._segments)} segments, {len(self._tees)} tees)"
