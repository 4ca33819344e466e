"""A second insertion: extend a surveyed network into a branch the first one left as a stub.

A branch the robot cannot back out of (docs/pabs.md) is entered only as a survey's
last act, so one insertion leaves the others as *stubs*: tees whose branch has no
segments, named in :attr:`~pirate_bt.ExploreNavigator.unexplored`. The robot is
pulled out by its tether and put in again; :class:`~pirate_bt.ExploreNavigator`
given ``extend=`` then drives the way to the first stub (depth-first, main line
first), choosing at each tee it meets by the surveyed network's order, turns into
the stub's branch and surveys it as a first insertion would. The network written
is the surveyed one with that branch filled in; everything else is kept as it was
surveyed.

This module reads the surveyed network: where the stubs are and the way to the
first one. The driving is the navigator's.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pirate_bt.errors import InputError, shown
from pirate_bt.task.explore_frame import SIDE_TOLERANCE_DEG, imu_side
from pirate_bt.units import parse_quantity

__all__ = ["NOT_SURVEYED", "Extension", "earlier", "earlier_ends", "load_extension"]

_ID = re.compile(r"^(run|bend|tee|reducer)-(\d+)$")
_KINDS = {"run": "straight", "bend": "bend", "tee": "tee", "reducer": "reducer"}


@dataclass
class Extension:
    """The surveyed network and the way to its first stub.

    Attributes:
        data: The network file's data (segments as the file writes them); the
            stub's branch is filled in place.
        way: On each line from the main line down, the ordinal (from 0) of the tee
            the robot turns into; the last is the stub's.
        sides: The side each of those tees' branch leaves on, as surveyed.
        stub: The stub tee's segment (in ``data``).
        others: The other stubs, named (a further insertion surveys them).
        counts: The highest number in the surveyed ids per kind (``run-3``: 3
            straights), so that new ids follow on.
        diameter_m: The network's diameter.
        notes: What the surveyed network's description names as not surveyed,
            other than its stubs (a line an earlier insertion did not survey to its
            end): still not surveyed after this one.
        stopped: Why an earlier insertion stopped, as its description says, when
            ``notes`` is not empty.
    """

    data: dict[str, Any]
    way: list[int]
    sides: list[str]
    stub: dict[str, Any]
    others: list[str] = field(default_factory=list)
    counts: dict[str, int] = field(default_factory=dict)
    diameter_m: float = 0.063
    notes: list[str] = field(default_factory=list)
    stopped: str | None = None

    @property
    def stub_name(self) -> str:
        return str(self.stub.get("id") or "the stub")


def _stubs(
    segments: list[dict[str, Any]],
    way: list[int],
    sides: list[str],
    root: list[dict[str, Any]] | None = None,
    diameter_m: float | None = None,
    tees: tuple[dict[str, Any], ...] = (),
) -> list[Any]:
    """Every stub, depth-first: ``(way, sides, segment, tees)``; each side as the IMU
    reads it (a branch written with its ``roll`` in a twisted frame: explore_frame),
    ``tees`` the tee segments turned into on the way, the stub's last."""
    out: list[Any] = []
    ordinal = 0
    root = segments if root is None else root
    for seg in segments:
        if seg.get("type") != "tee":
            continue
        branch = seg.get("branch") or {}
        here = [*way, ordinal]
        side = [*sides, imu_side(root, diameter_m, seg)]
        if not branch.get("segments"):
            out.append((here, side, seg, (*tees, seg)))
        else:
            out.extend(_stubs(branch["segments"], here, side, root, diameter_m, (*tees, seg)))
        ordinal += 1
    return out


def _no_side(source: Any, spec: Any, sides: list[str], tees: tuple[dict[str, Any], ...]) -> None:
    """Refuse a way to the stub through a tee whose branch leaves on none of the four
    sides the survey takes (a hand-edited ``roll: -45 deg`` was read as ``up``)."""
    for side, tee in zip(sides, tees, strict=True):
        if side == "None":
            roll = str((tee.get("branch") or {}).get("roll"))
            try:
                roll = f"{math.degrees(parse_quantity(roll, 'angle')):.1f} deg"
            except (ValueError, InputError):
                roll = shown(roll)
            raise InputError(
                f"extend: {_named(source, spec)}: {tee.get('id') or 'a tee'}'s branch"
                f" leaves at roll {roll}, none of up, down, left or right (within"
                f" {SIDE_TOLERANCE_DEG:g} deg as the robot's IMU reads it there): a survey"
                f" turns only into a branch on one of those sides"[:400]
            )


NOT_SURVEYED = "Not surveyed: "
"""Begins the list of what a survey did not survey, in its description (and header)."""

_STOPPED = re.compile(r"stopped: (.*?)\.(?: Each line's end: | Not surveyed: |$)", re.DOTALL)
_ENDS = re.compile(r"Each line's end: [^:]*: (.*?) \(the survey tries only", re.DOTALL)


def earlier_ends(description: str) -> list[str]:
    """The lines' ends a surveyed network's description names (each a cap, or a bend at
    a roll the survey does not try)."""
    found = _ENDS.search(description)
    return found.group(1).split("; ") if found else []


def earlier(description: str, stubs: list[str]) -> tuple[list[str], str | None]:
    """What a surveyed network's description names as not surveyed, other than the tee
    branches in ``stubs`` (their ids; a second insertion names those itself), and why
    the survey that left them stopped (``None``: none left, or no stop named)."""
    _, marker, listed = description.rpartition(NOT_SURVEYED)
    if not marker:
        return [], None
    items = [i.strip() for i in listed.strip().removesuffix(".").split("; ") if i.strip()]
    notes = [i for i in items if not any(i.startswith(f"{stub}'s branch") for stub in stubs)]
    found = _STOPPED.search(description)
    return notes, (found.group(1) if found and notes else None)


def _counts(segments: list[dict[str, Any]], counts: dict[str, int]) -> None:
    for seg in segments:
        found = _ID.match(str(seg.get("id", "")))
        if found:
            kind = _KINDS[found.group(1)]
            counts[kind] = max(counts.get(kind, 0), int(found.group(2)))
        if seg.get("type") == "tee":
            _counts((seg.get("branch") or {}).get("segments") or [], counts)


def _named(source: Any, spec: Any) -> str:
    """The surveyed network as the caller gave it: the file (and its network's name),
    else the network's name (it said only ``'surveyed'``, for every file)."""
    if isinstance(source, str | Path):
        return f"{shown(str(source))} (network {shown(spec.name)})"
    return f"the network {shown(spec.name)}"


def load_extension(source: Any) -> Extension:
    """Read a surveyed network (a path or a ``NetworkSpec``/``Network``) to extend.

    Raises:
        InputError: it cannot be read, or it has no stub to extend; the message starts
            ``extend:``, the argument's name (``pirate_bt.survey(extend=...)``,
            ``ExploreNavigator(extend=...)``, the navigator's ``extend`` parameter);
            ``pirate-bt survey`` says ``--extend:``.
    """
    import yaml

    from pirate_bt.pipes import load_network
    from pirate_bt.pipes.asbuilt import network_yaml
    from pirate_bt.pipes.model import NetworkSpec

    spec = getattr(source, "spec", source)
    if isinstance(source, str | Path):
        try:
            os.stat(source)
        except FileNotFoundError:
            pass  # a bundled name, or the loader's "no such file"
        except OSError as exc:  # a name the system refuses (a part too long)
            raise InputError(f"extend: cannot read {str(source)[:80]!r}: {exc.strerror}") from None
        spec = load_network(Path(source)).spec
    elif not isinstance(spec, NetworkSpec):
        raise InputError(  # it said "not a int"
            f"extend: give a surveyed network file, a Network or a NetworkSpec, not {shown(source)}"
        )
    data = yaml.safe_load(network_yaml(spec))
    stubs = _stubs(data["segments"], [], [], diameter_m=float(spec.diameter))
    notes, stopped = earlier(spec.description, [str(seg.get("id")) for _, _, seg, _ in stubs])
    if not stubs:
        cut = f" (a line not surveyed to its end is not extended: {notes[0]})" if notes else ""
        raise InputError(
            f"extend: {_named(source, spec)} has no tee branch left as a"
            f" stub: there is nothing to extend{cut}"[:400]
        )
    way, sides, stub, tees = stubs[0]
    _no_side(source, spec, sides, tees)
    counts: dict[str, int] = {}
    _counts(data["segments"], counts)
    return Extension(
        data=data,
        way=list(way),
        sides=list(sides),
        stub=stub,
        others=[f"{seg.get('id') or 'a tee'}'s branch" for _, _, seg, _ in stubs[1:]],
        counts=counts,
        diameter_m=float(spec.diameter),
        notes=notes,
        stopped=stopped,
    )
