"""As-built variants of a drawn network: the pipe as it was really laid.

Drawings of buried pipe are rarely exact. :func:`perturb_network` draws one
*as-built* variant of a network: the same features in the same order, with the
same ids, whose straight lengths, slopes and diameters differ from the drawing
within :class:`AsBuiltBounds`, from a seed (the same seed gives the same
variant). A mission can then run the simulator on the variant (the truth) while
it plans on the drawing (the map).

The defaults (``docs/networks.md``):

- a straight's length by at most ±10 % and at most ±0.5 m (tees and reducers keep
  their length: they are fittings);
- a straight's slope by at most ±3° (vertical runs, risers and drops, are laid
  plumb: they stay vertical whatever the tilt of the run before them);
- every diameter given (the network's, a straight's, a reducer's) by at most ±5 %,
  and never outside what the robot can clamp (51-120 mm for the bundled robot).

Three edits make drawings that are wrong in kind, for the disagreement tests:
:func:`remove_feature` (a tee or a bend that was never built) and
:func:`insert_tee` (a tee nobody drew). :func:`network_yaml` writes any of them
as a network file.
"""

from __future__ import annotations

import math
import numbers
import random
import re
import sys
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

from pydantic import ValidationError

from pirate_bt.errors import (
    ArgumentTypeError,
    ArgumentValueError,
    ConfigurationError,
    kind_of,
    seed_argument,
    shown,
)
from pirate_bt.pipes.asbuilt_yaml import network_yaml
from pirate_bt.pipes.model import (
    DIRECTION_ROLL_RAD,
    BendSpec,
    NetworkSpec,
    ReducerSpec,
    SegmentSpec,
    StraightSpec,
    TeeBranchSpec,
    TeeSpec,
)
from pirate_bt.pipes.network import Network, PieceKind

__all__ = [
    "AsBuiltBounds",
    "insert_tee",
    "network_yaml",
    "perturb_network",
    "remove_feature",
]

_PLUMB_TOL = 1e-6
"""A run this close to (in radians) or steeper than plumb is a riser or drop: laid
plumb in every variant. Every other run's slope is perturbed, a steep one too (a run
at 70 deg was laid plumb, 20 deg off its drawing, as was one leaning back past plumb,
120 deg after a bend up from a 30 deg slope, which set_slope writes as 60 deg)."""

_STEEPEST = math.radians(89.999)
"""The steepest a run that is not plumb is laid: a file's slope is written to 0.001
deg. A run at 88 deg tilted past plumb was laid at 90 deg, so the run after it, which
kept its own slope, was a slope set on a vertical run: ``pirate-bt network perturb``
refused one seed in eight (*segment 'e': cannot set a slope on a vertical run*)."""


_FIELDS = (
    "length_fraction",
    "length_max_m",
    "slope_rad",
    "diameter_fraction",
    "diameter_min_m",
    "diameter_max_m",
    "put_in_m",
)


@dataclass(frozen=True)
class AsBuiltBounds:
    """How far an as-built network may differ from its drawing.

    Attributes:
        length_fraction: A straight's length changes by at most this fraction.
        length_max_m: ... and by at most this many metres.
        slope_rad: A non-vertical straight's slope changes by at most this much.
        diameter_fraction: A diameter changes by at most this fraction ...
        diameter_min_m: ... and stays at least this (the smallest pipe the robot clamps)
        diameter_max_m: ... and at most this (the largest).
        put_in_m: The pipe before the first bend or T-joint stays at least this long
            where the drawing's is (give the robot's length: it is put in on straight
            pipe, and the simulator refuses a truth that puts it in across one; 0,
            the default: not kept). Only the straight just before that bend or
            T-joint is lengthened, and only in a variant that needs it.
    """

    length_fraction: float = 0.10
    length_max_m: float = 0.5
    slope_rad: float = math.radians(3.0)
    diameter_fraction: float = 0.05
    diameter_min_m: float = 0.051
    diameter_max_m: float = 0.120
    put_in_m: float = 0.0

    def __post_init__(self) -> None:
        for name in _FIELDS:  # each a finite number (a NumPy one as its float)
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, numbers.Real):
                # text or None was a bare TypeError ('<' not supported ...)
                raise ArgumentTypeError(
                    f"as-built bounds: {name}: give a number, not {kind_of(value)}"
                )
            if not math.isfinite(value):  # nan was taken: every variant's lengths nan
                raise ConfigurationError(f"as-built bounds: {name} {value!r} is not finite")
            object.__setattr__(self, name, float(value))
        for name in (
            "length_fraction",
            "length_max_m",
            "slope_rad",
            "diameter_fraction",
            "put_in_m",
        ):
            if getattr(self, name) < 0:
                raise ConfigurationError(f"as-built bounds: {name} must not be negative")
        if not self.diameter_min_m > 0:
            raise ConfigurationError("as-built bounds: diameter_min_m must be above 0")
        if self.length_fraction >= 1.0:
            raise ConfigurationError("as-built bounds: length_fraction must be below 1")
        if self.slope_rad > math.pi / 2 + 1e-9:  # past plumb: no slope a run can have
            raise ConfigurationError(
                f"as-built bounds: slope_rad {math.degrees(self.slope_rad):g} deg is more"
                " than 90 deg, past plumb (a run's slope is laid within ±90 deg)"
            )
        if self.diameter_min_m > self.diameter_max_m:
            raise ConfigurationError("as-built bounds: diameter_min_m is above diameter_max_m")

    def scaled(self, factor: float) -> AsBuiltBounds:
        """The same bounds ``factor`` times as wide (the clampable range stays).

        Raises:
            ArgumentTypeError: ``factor`` is no number.
            ConfigurationError: ``factor`` is not finite, or the bounds it makes are
                out of range (a negative factor, a slope past plumb).
        """
        if isinstance(factor, bool) or not isinstance(factor, numbers.Real):
            raise ArgumentTypeError(f"factor: give a number, not {kind_of(factor)}")
        if not math.isfinite(factor):  # nan made every bound nan
            raise ConfigurationError(f"as-built bounds: a scale of {factor!r} is not finite")
        return replace(
            self,
            length_fraction=min(self.length_fraction * factor, 0.9),
            length_max_m=self.length_max_m * factor,
            slope_rad=self.slope_rad * factor,
            diameter_fraction=self.diameter_fraction * factor,
        )

    def describe(self) -> str:
        """One line for people and reports."""
        return (
            f"straights ±{self.length_fraction * 100:g} % (at most ±{self.length_max_m:g} m),"
            f" slopes ±{math.degrees(self.slope_rad):g} deg, diameters"
            f" ±{self.diameter_fraction * 100:g} % within"
            f" {self.diameter_min_m * 1000:g}-{self.diameter_max_m * 1000:g} mm"
            + (
                f", the first bend or T-joint at least {self.put_in_m:g} m in"
                if self.put_in_m > 0
                else ""
            )
        )


def _names(segments: Sequence[SegmentSpec], prefix: str) -> list[str]:
    return [seg.id or f"{prefix}-{i + 1}" for i, seg in enumerate(segments)]


def _slopes(network: Network) -> dict[str, float]:
    """The drawn slope of every straight (by segment name), over every way through."""
    out: dict[str, float] = {}
    for path in network.paths():
        for piece in path.pieces:
            if piece.segment not in out and piece.length_m > 0:
                tangent = path.tangent_at((piece.start_m + piece.end_m) / 2)
                out[piece.segment] = math.asin(max(-1.0, min(1.0, tangent[2])))
    return out


def _variant_seed(seed: object) -> int:
    """A variant's seed as every seed is taken (:func:`pirate_bt.errors.seed_argument`):
    ``random.Random`` seeds by a number's size, so -1 gave variant 1 under another
    name, and it took a float or text too.

    Raises:
        InputError: anything but a whole number from 0 to 2**63 - 1.
    """
    return seed_argument(seed)


def _variant_name(name: object) -> str | None:
    """A variant's ``name=``: text, or ``None`` for the default (``name=5`` was the
    network's name unchecked, and ``''`` the default unsaid).

    Raises:
        InputError: anything else (``ArgumentTypeError``, ``ArgumentValueError``).
    """
    if name is None:
        return None
    if not isinstance(name, str):
        raise ArgumentTypeError(f"name: give the variant's name as text, not {kind_of(name)}")
    if not name.strip():
        raise ArgumentValueError("name: empty; give the variant's name, or None for the default")
    return str(name)  # a NumPy text (numpy.str_) was the name YAML could not write


def _segment_id(segment_id: object) -> str:
    """A segment's id as text (``remove_feature(spec, None)`` said *the network 'lab'
    has no None*, a ``ConfigurationError`` as if the id were only unknown).

    Raises:
        ArgumentTypeError: anything but text.
    """
    if not isinstance(segment_id, str):
        raise ArgumentTypeError(
            f"segment_id: give a segment's id as text, not {kind_of(segment_id)}"
        )
    return str(segment_id)


def _distance_in(at_m: object) -> float:
    """``insert_tee``'s ``at_m``: metres, a number (a NumPy one too) or text with a unit
    (``"1.5 m"``, as ``network add-tee`` takes it); ``"1.5 m"`` and ``None`` were
    Python's bare *'<' not supported between instances of 'float' and 'str'*.

    Raises:
        ArgumentTypeError: no number and no text.
        ArgumentValueError: text that is no length, or a number that is not finite.
    """
    from pirate_bt.errors import UnitError
    from pirate_bt.units import parse_quantity

    if isinstance(at_m, bool) or not isinstance(at_m, numbers.Real | str):
        raise ArgumentTypeError(
            f"at_m: give a distance into the straight (metres, or text such as '1.5 m'),"
            f" not {kind_of(at_m)}"
        )
    try:
        value = at_m if isinstance(at_m, str) else float(at_m)
        return parse_quantity(value, "length", require_unit=isinstance(at_m, str))
    except (UnitError, OverflowError) as exc:
        raise ArgumentValueError(f"at_m: {exc}") from None


def _flag(value: object, option: str) -> bool:
    """``True`` or ``False`` (NumPy's too): ``keep_length="no"`` was true."""
    numpy = sys.modules.get("numpy")  # not imported for this
    if numpy is not None and isinstance(value, numpy.bool_):
        return bool(value)
    if isinstance(value, bool):
        return value
    raise ArgumentTypeError(f"{option}: give True or False, not {shown(value)}")


def perturb_network(
    spec: NetworkSpec,
    seed: int,
    bounds: AsBuiltBounds | None = None,
    *,
    name: str | None = None,
) -> NetworkSpec:
    """One as-built variant of a drawn network.

    Args:
        spec: The drawing.
        seed: Which variant (the same seed gives the same variant).
        bounds: How far it may differ (default :class:`AsBuiltBounds`).
        name: The variant's name (default ``NAME-asbuilt-SEED``).

    Returns:
        A network with the same features and ids, lengths, slopes and diameters drawn
        uniformly within the bounds.

    Raises:
        InputError: a seed that is not a whole number from 0 to 2**63 - 1 (as every
            seed, a campaign's ``as_built`` variants' and ``network perturb --seed``),
            bounds that are no ``AsBuiltBounds``, a name that is no text or empty.
        ConfigurationError: the drawing's geometry cannot be built.
    """
    seed = _variant_seed(seed)
    name = _variant_name(name)
    if bounds is not None and not isinstance(bounds, AsBuiltBounds):  # was an AttributeError
        raise ArgumentTypeError(
            f"bounds: give an AsBuiltBounds (None: the defaults), not {kind_of(bounds)}"
        )
    bounds = bounds or AsBuiltBounds()
    rng = random.Random(seed)
    slopes = _slopes(Network(spec))

    def diameter(value: float) -> float:
        d = value * (1.0 + rng.uniform(-1.0, 1.0) * bounds.diameter_fraction)
        return min(max(d, bounds.diameter_min_m), bounds.diameter_max_m)

    def line(segments: Sequence[SegmentSpec], prefix: str) -> list[SegmentSpec]:
        out: list[SegmentSpec] = []
        for seg, seg_name in zip(segments, _names(segments, prefix), strict=True):
            if isinstance(seg, StraightSpec):
                change = min(seg.length * bounds.length_fraction, bounds.length_max_m)
                length = seg.length + rng.uniform(-1.0, 1.0) * change
                drawn = slopes.get(seg_name, seg.slope or 0.0)
                tilt = rng.uniform(-1.0, 1.0) * bounds.slope_rad
                if abs(drawn) < math.pi / 2 - _PLUMB_TOL:
                    slope = max(-_STEEPEST, min(_STEEPEST, drawn + tilt))
                else:  # risers and drops are set plumb, whatever the run before them
                    slope = math.copysign(math.pi / 2, drawn)
                out.append(
                    seg.model_copy(
                        update={
                            "length": length,
                            "slope": slope,
                            "diameter": (
                                diameter(seg.diameter) if seg.diameter is not None else None
                            ),
                        }
                    )
                )
            elif isinstance(seg, ReducerSpec):
                out.append(seg.model_copy(update={"diameter": diameter(seg.diameter)}))
            elif isinstance(seg, TeeSpec):
                branch = seg.branch.model_copy(
                    update={"segments": line(seg.branch.segments, f"{seg_name}-b")}
                )
                out.append(seg.model_copy(update={"branch": branch}))
            else:
                out.append(seg)
        return out

    variant = spec.model_copy(
        update={
            "name": name or f"{spec.name}-asbuilt-{seed}",
            "description": f"as-built variant {seed} of {spec.name} ({bounds.describe()})",
            "diameter": diameter(spec.diameter),
            "segments": line(spec.segments, "main"),
        }
    )
    variant = _put_in_kept(spec, variant, bounds.put_in_m)
    Network(variant)  # fail here, not in the simulator, on impossible geometry
    return variant


_FEATURES = (PieceKind.BEND, PieceKind.TEE, PieceKind.TEE_TURN)


def _first_feature_m(spec: NetworkSpec) -> float | None:
    """How far along the main line its first bend or T-joint starts (None: it has none)."""
    pieces = Network(spec).path({}).pieces
    return next((piece.start_m for piece in pieces if piece.kind in _FEATURES), None)


def _put_in_kept(drawing: NetworkSpec, variant: NetworkSpec, need_m: float) -> NetworkSpec:
    """``variant`` with the straight just before its first bend or T-joint lengthened so
    that the robot (``need_m`` long) is put in on straight pipe, as in the drawing: at
    scale 10 one riser variant in four put it in across the foot bend, a truth the
    simulator refuses. Unchanged when it need not be (and so byte-identical)."""
    if need_m <= 0 or variant.start.position is not None:
        return variant
    first_m = _first_feature_m(variant)
    drawn_m = _first_feature_m(drawing)
    if first_m is None or first_m >= need_m or drawn_m is None or drawn_m < need_m:
        return variant
    segments = list(variant.segments)
    before = next((i for i, seg in enumerate(segments) if isinstance(seg, BendSpec | TeeSpec)), 0)
    last = next(
        (i for i in range(before - 1, -1, -1) if isinstance(segments[i], StraightSpec)), None
    )
    if last is None:
        return variant
    seg = segments[last]
    assert isinstance(seg, StraightSpec)
    # a millimetre more: the file writes lengths to 0.1 mm, and reads back as long
    segments[last] = seg.model_copy(update={"length": seg.length + need_m - first_m + 1e-3})
    return variant.model_copy(update={"segments": segments})


def _edit(
    spec: NetworkSpec, segment_id: str, edit: Any, what: str, name: str | None
) -> NetworkSpec:
    if not isinstance(spec, NetworkSpec):
        Network(spec)  # says what to give instead (load_network, network_from_data)
    name = _variant_name(name)  # name=5 was the variant's name, '' the default unsaid
    found = [False]

    def line(segments: Sequence[SegmentSpec], prefix: str) -> list[SegmentSpec]:
        out: list[SegmentSpec] = []
        for seg, seg_name in zip(segments, _names(segments, prefix), strict=True):
            if seg_name == segment_id:
                found[0] = True
                out.extend(edit(seg))
                continue
            if isinstance(seg, TeeSpec):
                branch = seg.branch.model_copy(
                    update={"segments": line(seg.branch.segments, f"{seg_name}-b")}
                )
                seg = seg.model_copy(update={"branch": branch})
            out.append(seg)
        return out

    segments = line(spec.segments, "main")
    if not found[0]:
        raise ConfigurationError(f"{what}: the network {spec.name!r} has no {segment_id!r}")
    variant = spec.model_copy(
        update={"name": name or f"{spec.name}-{what.replace(' ', '-')}", "segments": segments}
    )
    problems = variant.cross_check()  # a new id may be one the network has
    if problems:
        raise ConfigurationError(f"{what}: {problems[0][1]}")
    try:  # said as the edit asked for: the top bend of a riser taken out said only
        Network(variant)  # *segment 'f': cannot set a slope on a vertical run*
    except ConfigurationError as exc:
        raise ConfigurationError(f"the network {what} cannot be built: {exc}") from None
    return variant


def remove_feature(spec: NetworkSpec, segment_id: str, *, name: str | None = None) -> NetworkSpec:
    """The network without a tee or a bend: one that was drawn but never built.

    A tee becomes straight pipe of its length (its branch goes); a bend is taken out,
    so the line goes on in the direction it had before the bend.

    Raises:
        ConfigurationError: no such segment, or it is not a tee or a bend.
        InputError: ``spec`` is no ``NetworkSpec``, ``segment_id`` no text, ``name``
            no text or empty (as :func:`perturb_network`'s).
    """
    segment_id = _segment_id(segment_id)

    # a tee's default length is three times the pipe's diameter where it is (after a
    # reducer to 55 mm, 165 mm): its run straight through, as the drawing has it
    runs: dict[str, float] = {}
    for path in Network(spec).paths():  # into its branch, a path holds half the run
        for p in path.pieces:
            if p.kind is PieceKind.TEE:
                runs[p.segment] = max(runs.get(p.segment, 0.0), p.end_m - p.start_m)

    def edit(seg: SegmentSpec) -> list[SegmentSpec]:
        if isinstance(seg, TeeSpec):
            length = seg.length if seg.length is not None else runs[segment_id]
            return [StraightSpec(type="straight", id=seg.id, length=length)]
        if isinstance(seg, BendSpec):
            return []
        raise ConfigurationError(f"remove {segment_id!r}: it is a {seg.type}, not a tee or a bend")

    return _edit(spec, segment_id, edit, f"without {segment_id}", name)


def insert_tee(
    spec: NetworkSpec,
    segment_id: str,
    at_m: float,
    direction: str = "left",
    *,
    tee_id: str = "extra-tee",
    name: str | None = None,
    keep_length: bool = False,
) -> NetworkSpec:
    """The network with a tee nobody drew, ``at_m`` into the straight ``segment_id``.

    The straight is split around the tee (so the line's length grows by the tee's,
    unless ``keep_length``: then the tee takes its length from the straight after
    it, as when a map is corrected where a robot found a tee); the branch is a
    capped stub pointing ``direction``.

    ``at_m`` is metres (a NumPy number too) or text with a unit (``"1.5 m"``).

    Raises:
        ConfigurationError: no such straight, ``at_m`` leaves no pipe on a side, or an
            id the network has already (the tee's, or ``SEGMENT-after``).
        InputError: ``spec`` is no ``NetworkSpec``, ``segment_id`` no text, ``at_m`` no
            length, ``keep_length`` not ``True`` or ``False``, ``name`` no text or empty.
    """
    if not isinstance(spec, NetworkSpec):
        Network(spec)  # says what to give instead (load_network, network_from_data)
    segment_id = _segment_id(segment_id)
    at_m = _distance_in(at_m)
    keep_length = _flag(keep_length, "keep_length")
    if not isinstance(tee_id, str) or not re.fullmatch(r"[A-Za-z][A-Za-z0-9_-]{0,39}", tee_id):
        # a four-line pydantic "internal error" for 'network add-tee ... --id é'
        raise ConfigurationError(
            f"insert a tee: id {shown(tee_id)} is not a segment id: a letter, then letters,"
            " digits, '_' or '-' (at most 40 characters)"
        )
    network = Network(spec)
    ids = network.segment_ids()
    for new_id in (tee_id, f"{segment_id}-after"):
        if segment_id in ids and (new_id in ids or tee_id == f"{segment_id}-after"):
            raise ConfigurationError(
                f"insert a tee: duplicate segment id {new_id!r}: the network {spec.name!r}"
                f" has a segment {new_id!r} already (or the straight's rest,"
                f" {segment_id}-after, takes it); give the tee another id"
            )
    # the pipe's diameter there (a reducer before it changes it): the tee's is the same
    local = next(
        (
            p.diameter_start_m
            for path in network.paths()
            for p in path.pieces
            if p.segment == segment_id
        ),
        spec.diameter,
    )

    def edit(seg: SegmentSpec) -> list[SegmentSpec]:
        if not isinstance(seg, StraightSpec):
            raise ConfigurationError(f"insert a tee: {segment_id!r} is a {seg.type}")
        if not 0.0 < at_m < seg.length:
            raise ConfigurationError(
                f"insert a tee: {at_m:g} m is not within {segment_id!r} ({seg.length:g} m)"
            )
        tee_m = 3.0 * (seg.diameter or local)
        rest_m = seg.length - at_m - (tee_m if keep_length else 0.0)
        if rest_m <= 0.0:
            raise ConfigurationError(
                f"insert a tee: no pipe left in {segment_id!r} after a tee at {at_m:g} m"
            )
        first = seg.model_copy(update={"length": at_m})
        rest = StraightSpec(type="straight", id=f"{segment_id}-after", length=rest_m)
        try:
            branch = TeeBranchSpec.model_validate({"direction": direction})
        except ValidationError:
            raise ConfigurationError(
                f"insert a tee: direction {shown(direction)} is not one of"
                f" {', '.join(DIRECTION_ROLL_RAD)}"
            ) from None
        tee = TeeSpec(type="tee", id=tee_id, length=tee_m, branch=branch)
        return [first, tee, rest]

    return _edit(spec, segment_id, edit, f"with {tee_id}", name)
