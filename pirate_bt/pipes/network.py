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
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

from pirate_bt.errors import ConfigurationError
from pirate_bt.pipes.arguments import (
    check_spec,
    checked_choices,
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
from pirate_bt.pipes.path import (
    Path,
    Piece,
    PieceKind,
    TeeChoice,
    Vec3,
    _add,
    _comb,
    _cross,
    _dot,
    _scale,
    _unit,
)

__all__ = ["Network", "NetworkGeometryError", "Path", "Piece", "PieceKind", "TeeChoice", "Vec3"]


_EPS = 1e-9


class NetworkGeometryError(ConfigurationError):
    """A network whose parts do not fit together; ``path`` is the key to blame."""

    def __init__(self, message: str, path: tuple[str | int, ...] = ("segments",)) -> None:
        super().__init__(message)
        self.path = path


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

    Two networks are equal when their specs are: the same pipe, wherever it was
    loaded from (``source`` is not compared), so two loads of one file, a network
    pickled and read back, and the plans and results that hold them compare equal. A
    network is not hashable (its spec holds lists: it is not a value that cannot
    change); key a dict by its ``name`` instead.
    """

    __hash__ = None  # type: ignore[assignment]

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self) or not isinstance(other, Network):
            return NotImplemented
        return self is other or self.spec == other.spec

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

    def path(self, choices: Mapping[str, str] | None = None) -> Path:
        """The path taking ``choices`` at tees (``straight`` where not given).

        ``choices`` maps a tee's id to ``"straight"`` or ``"branch"``, checked here:
        a navigator's ``obs.choices`` (and a ``dict[str, str]`` of its own) is taken
        as it is, also by a type checker.

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
        segments, tees = len(self._segments), len(self._tees)
        return (
            f"Network({self.name!r}, {segments} segment{'' if segments == 1 else 's'},"
            f" {tees} tee{'' if tees == 1 else 's'})"
        )
