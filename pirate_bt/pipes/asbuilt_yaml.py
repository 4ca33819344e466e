"""Writing a network as a network file: units written out, so that it loads and validates.

:func:`network_yaml` writes any network (a drawing, an as-built variant of
:mod:`pirate_bt.pipes.asbuilt`, an edited one) as the YAML ``pirate-bt validate``
reads. Split from :mod:`pirate_bt.pipes.asbuilt`, which re-exports it.
"""

from __future__ import annotations

import math
from typing import Any

from pirate_bt.errors import ArgumentTypeError, kind_of
from pirate_bt.pipes.model import (
    BendSpec,
    NetworkSpec,
    ReducerSpec,
    SegmentSpec,
    StraightSpec,
    TeeBranchSpec,
)
from pirate_bt.pipes.network import Network

__all__ = ["network_yaml"]


def _len(value: float) -> str:
    return f"{value * 1000:.1f} mm" if value < 1.0 else f"{value:.4f} m"


def _deg(value: float) -> str:
    return f"{math.degrees(value):.3f} deg"


def _segment_data(seg: SegmentSpec) -> dict[str, Any]:
    out: dict[str, Any] = {"id": seg.id} if seg.id is not None else {}
    out["type"] = seg.type
    if isinstance(seg, StraightSpec):
        out["length"] = _len(seg.length)
        if seg.diameter is not None:
            out["diameter"] = _len(seg.diameter)
        if seg.slope is not None:
            out["slope"] = _deg(seg.slope)
    elif isinstance(seg, ReducerSpec):
        out["diameter"] = _len(seg.diameter)
        out["length"] = _len(seg.length)
    elif isinstance(seg, BendSpec):
        out.update(_turn_data(seg))
        out["radius"] = _len(seg.radius)
        if abs(seg.angle - math.pi / 2) > 1e-9:
            out["angle"] = _deg(seg.angle)
    else:
        if seg.length is not None:
            out["length"] = _len(seg.length)
        branch: dict[str, Any] = _turn_data(seg.branch)
        if seg.branch.radius is not None:
            branch["radius"] = _len(seg.branch.radius)
        branch["segments"] = [_segment_data(s) for s in seg.branch.segments]
        out["branch"] = branch
    return out


def _turn_data(turn: BendSpec | TeeBranchSpec) -> dict[str, Any]:
    if turn.direction is not None:
        return {"direction": turn.direction.value}
    assert turn.roll is not None
    return {"roll": _deg(turn.roll)}


def network_yaml(spec: NetworkSpec, header: str = "") -> str:
    """A network as a network file (units written out, so it loads and validates).

    Args:
        spec: The network.
        header: Comment lines to put on top (``#`` is added).

    Raises:
        ArgumentTypeError: ``spec`` is no ``NetworkSpec`` (a ``Network``'s is its
            ``.spec``), or ``header`` no text (each was an ``AttributeError``).
    """
    from pirate_bt.yamlfile.scalars import dump_yaml

    if not isinstance(spec, NetworkSpec):
        hint = " (a Network's is its .spec)" if isinstance(spec, Network) else ""
        raise ArgumentTypeError(f"spec: give a NetworkSpec{hint}, not {kind_of(spec)}")
    if not isinstance(header, str):
        raise ArgumentTypeError(f"header: give text, not {kind_of(header)}")

    data: dict[str, Any] = {
        "schema_version": spec.schema_version,
        "name": spec.name,
        "description": spec.description,
        "diameter": _len(spec.diameter),
    }
    if spec.slope:
        data["slope"] = _deg(spec.slope)
    data["tether_drag_per_metre"] = f"{spec.tether_drag_per_metre:g} N"
    start: dict[str, Any] = {"roll": _deg(spec.start.roll)}
    if spec.start.position is not None:
        start["position"] = _len(spec.start.position)
    data["start"] = start
    data["segments"] = [_segment_data(s) for s in spec.segments]
    if spec.faults:
        data["faults"] = [
            {
                k: v
                for k, v in {
                    "kind": f.kind,
                    "at": f"{f.at:g} s",
                    "duration": f"{f.duration:g} s" if f.duration is not None else None,
                    "target": f.target,
                }.items()
                if v is not None
            }
            for f in spec.faults
        ]
    comment = "".join(f"# {line}\n" for line in header.splitlines())
    return comment + dump_yaml(data, sort_keys=False, allow_unicode=True, width=100)
