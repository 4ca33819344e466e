"""The route language: plain words an operator writes to send the robot through a network.

A route file (``scenarios/*.route``) is a list of commands, one per line, read
top to bottom. It is meant for people who do not program: no brackets, no
quotes, no indentation, and every quantity carries its unit::

    # Inspect the first run of the lab main and come back.
    network lab
    forward 2.5 m
    at the bend turn right
    inspect 3 m slowly
    at the T-joint go straight
    forward to the end

The words (case does not matter; ``the``, ``next`` and ``then`` may be written
or left out, so ``then at the next bend turn right`` reads as well):

=====================================  =============================================
``network NAME``                       the pipe network the route is written for
``forward DISTANCE [slowly]``          drive forward along the straight pipe
``forward to the end [slowly]``        drive to the end of the pipe line
``inspect DISTANCE [slowly]``          drive forward at inspection speed, cameras on
``inspect to the end [slowly]``        inspect up to the end of the pipe line
``back DISTANCE``                      drive backwards along the straight pipe
``at the bend turn [DIRECTION]``       pass the next bend (up, down, left, right)
``at the T-joint go WAY``              pass the next T-joint: left, right, up, down
                                       (into the branch) or straight (through it)
``go to SEGMENT``                      go to a named segment of the network, taking
                                       the shortest way through the junctions
``pause DURATION``                     stand still (clamped) for a while, at most an hour
``return to start``                    drive back to where the robot was put in
=====================================  =============================================

``#`` starts a comment. Parsing is one step (words, units, spelling); whether a
route fits its network (is there a bend where it says "turn"?) is the
planner's job (:mod:`pirate_bt.task.planner`, which also checks route files for
``pirate-bt validate``). Every problem is reported as ``file:line:column``
with the nearest valid words, so "forwrad 2 m" says "did you mean 'forward'?".
"""

from __future__ import annotations

import difflib
import enum
import re
import unicodedata
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pirate_bt.errors import (
    ArgumentTypeError,
    LocatedError,
    SourceLocation,
    UnitError,
    ValidationFailed,
    bytes_escaped,
    shown,
)
from pirate_bt.task.route_schema import route_schema
from pirate_bt.units import parse_quantity, units_of


def _printable(name: str) -> str:
    """A file name as a route's (and its mission tree's) name: bytes that are no UTF-8
    (``$'\\xfc.route'``, read as a lone surrogate) and control characters escaped, as
    ``\\xfc``; a mission of such a file was refused with *<dict>:1:1: name: must not
    contain control characters*, a place nobody wrote."""
    return "".join(c if c.isprintable() or c == " " else repr(c)[1:-1] for c in bytes_escaped(name))


__all__ = [
    "BEND_DIRECTIONS",
    "COMMAND_WORDS",
    "MAX_WAIT_S",
    "TEE_WAYS",
    "Route",
    "RouteStep",
    "StepKind",
    "load_route",
    "parse_route",
    "route_schema",
]


class StepKind(enum.StrEnum):
    """What one line of a route asks for."""

    FORWARD = "forward"
    INSPECT = "inspect"
    BACK = "back"
    BEND = "bend"
    TEE = "tee"
    GOTO = "goto"
    PAUSE = "pause"
    RETURN = "return"


COMMAND_WORDS: tuple[str, ...] = (
    "network",
    "forward",
    "inspect",
    "back",
    "at",
    "go",
    "pause",
    "wait",
    "return",
)
"""Words that may start a line."""

BEND_DIRECTIONS: tuple[str, ...] = ("up", "down", "left", "right")
"""Directions a bend may turn, in the pipe's cross-section looking along the travel."""

TEE_WAYS: tuple[str, ...] = ("left", "right", "up", "down", "straight")
"""Ways through a T-joint: into a branch pointing that way, or straight through."""

_FILLERS = frozenset({"the", "next", "then", "a"})
_FEATURES = {
    "bend": "bend",
    "elbow": "bend",
    "t-joint": "t-joint",
    "tjoint": "t-joint",
    "tee": "t-joint",
    "junction": "t-joint",
}
_NUMBER_RE = re.compile(r"^[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?", re.ASCII)
_NAME_RE = re.compile(r"^[A-Za-z][A-Za-z0-9_-]*$")
_NETWORK_FILE_RE = re.compile(r"^[^\x00-\x1f]+\.ya?ml$")
"""A network file on a route's ``network`` line: a path ending in .yaml or .yml,
relative to the route's directory or absolute (whitespace splits words already)."""
_SUFFIX = ".route"
MAX_WAIT_S = 3600.0
"""The longest pause of a route, and wait step of a navigator (an hour)."""
_LONGEST_PAUSE = (MAX_WAIT_S, f"{MAX_WAIT_S:.0f} s (an hour)")
"""A pause, as the navigator's ``wait`` step: at most an hour (a longer one ran the
mission for ever, its time limit planned from the pause)."""


@dataclass(frozen=True, slots=True)
class RouteStep:
    """One command of a route, in SI units.

    Attributes:
        kind: What the line asks for.
        location: Where the command starts in the route file.
        text: The line as written (without its comment), for messages and reports.
        distance_m: Forward, inspect, back: how far; ``None`` for "to the end".
        slowly: Drive at the slow (inspection) speed.
        direction: Bend: ``up``/``down``/``left``/``right`` or ``None`` (as on the map).
            T-joint: one of :data:`TEE_WAYS`.
        duration_s: Pause: how long.
        segment: Go to: the segment id.
    """

    kind: StepKind
    location: SourceLocation
    text: str
    distance_m: float | None = None
    slowly: bool = False
    direction: str | None = None
    duration_s: float | None = None
    segment: str | None = None

    @property
    def line(self) -> int:
        """The route line this step comes from."""
        return self.location.line

    def describe(self) -> str:
        """``line 4: at the bend turn right`` for messages."""
        return f"line {self.location.line}: {self.text}"


@dataclass(frozen=True)
class Route:
    """A parsed route.

    Attributes:
        name: The file name without ``.route`` (or the name given).
        source: Where it was read from.
        steps: The commands, in order.
        network: The network named by a ``network`` line, if any.
        network_location: Where the name on that line is written.
    """

    name: str
    source: str
    steps: tuple[RouteStep, ...]
    network: str | None = None
    network_location: SourceLocation | None = None

    def to_json(self) -> dict[str, Any]:
        """The route as plain data (for reports and traces)."""
        return {
            "name": self.name,
            "source": self.source,
            "network": self.network,
            "steps": [
                {
                    k: v
                    for k, v in {
                        "kind": s.kind.value,
                        "line": s.line,
                        "text": s.text,
                        "distance_m": s.distance_m,
                        "slowly": s.slowly or None,
                        "direction": s.direction,
                        "duration_s": s.duration_s,
                        "segment": s.segment,
                    }.items()
                    if v is not None
                }
                for s in self.steps
            ],
        }


@dataclass(frozen=True, slots=True)
class _Word:
    text: str
    """Lower-case (except names) text of the word."""
    raw: str
    column: int


def _suggest(word: str, options: tuple[str, ...] | list[str]) -> str:
    close = difflib.get_close_matches(word.lower(), list(options), n=2, cutoff=0.6)
    if close:
        return "; did you mean " + " or ".join(f"'{c}'" for c in close) + "?"
    return "; expected " + ", ".join(f"'{o}'" for o in options)


class _Line:
    """The words of one line, consumed left to right."""

    def __init__(self, source: str, line_no: int, text: str) -> None:
        self.source = source
        self.line_no = line_no
        self.end_column = len(text.rstrip()) + 1
        words = [
            _Word(m.group().lower(), m.group(), m.start() + 1) for m in re.finditer(r"\S+", text)
        ]
        # "T joint" written as two words is one feature word.
        merged: list[_Word] = []
        for w in words:
            if merged and w.text == "joint" and merged[-1].text == "t":
                merged[-1] = _Word("t-joint", merged[-1].raw + " " + w.raw, merged[-1].column)
            else:
                merged.append(w)
        self.words = [w for w in merged if w.text not in _FILLERS]
        self.pos = 0

    def at(self, column: int) -> SourceLocation:
        return SourceLocation(self.source, self.line_no, column)

    def peek(self) -> _Word | None:
        return self.words[self.pos] if self.pos < len(self.words) else None

    def take(self) -> _Word | None:
        word = self.peek()
        if word is not None:
            self.pos += 1
        return word

    def here(self) -> SourceLocation:
        word = self.peek()
        return self.at(word.column if word is not None else self.end_column)

    def error(self, message: str, word: _Word | None = None) -> LocatedError:
        return LocatedError(message, self.at(word.column) if word else self.here())

    def expect(self, options: tuple[str, ...], what: str) -> _Word:
        word = self.take()
        if word is None:
            raise self.error(f"{what}: expected {' or '.join(repr(o) for o in options)}")
        if word.text not in options:
            raise self.error(f"{what}: unexpected '{word.raw}'{_suggest(word.text, options)}", word)
        return word

    def done(self, allowed: tuple[str, ...] = ()) -> None:
        word = self.peek()
        if word is None:
            return
        hint = _suggest(word.text, allowed) if allowed else "; the line should end here"
        raise self.error(f"unexpected '{word.raw}'{hint}", word)


def _quantity(
    line: _Line, dimension: str, what: str, example: str, most: tuple[float, str] | None = None
) -> float:
    """The quantity at the line's next word(s): positive, and at most ``most`` (its
    value in SI units and as written in the message) when given."""
    word = line.take()
    if word is None:
        raise line.error(f"{what} needs {dimension_article(dimension)}, e.g. '{example}'")
    match = _NUMBER_RE.match(word.text)
    if match is None:
        raise line.error(
            f"{what}: '{word.raw}' is not a number; write e.g. '{example}'",
            word,
        )
    text = word.raw
    unit_word: _Word | None = None
    if match.end() == len(word.text):
        unit_word = line.peek()
        if unit_word is None or _NUMBER_RE.match(unit_word.text) or unit_word.text in _KEYWORDS:
            raise line.error(
                f"{what}: '{word.raw}' needs a unit; write e.g. '{example}'",
                unit_word if unit_word is not None else None,
            )
        line.take()
        text = f"{word.raw} {_UNIT_WORDS.get(unit_word.text, unit_word.raw)}"
    try:
        value = parse_quantity(text, dimension)
    except UnitError as exc:
        unit_text = unit_word.raw if unit_word is not None else word.raw[match.end() :]
        known = units_of(dimension)
        words = [*known, *(w for w, u in _UNIT_WORDS.items() if u in known)]
        close = difflib.get_close_matches(unit_text.lower(), words, n=2, cutoff=0.6)
        if "unknown unit" in str(exc):
            hint = (
                "did you mean " + " or ".join(f"'{c}'" for c in close) + "?"
                if close
                else f"{dimension} units: {', '.join(known)}"
            )
            message = f"{what}: unknown unit '{unit_text}'; {hint}"
        else:
            message = f"{what}: {exc}"
        raise line.error(message, unit_word or word) from None
    if len(text) > _MAX_SHOWN:  # a number of 300 digits is a finite float
        text = text[: _MAX_SHOWN - 3] + "..."
    if value <= 0:
        raise line.error(f"{what}: '{text}' must be more than zero", word)
    if most is not None and value > most[0]:
        raise line.error(f"{what}: '{text}' must be at most {most[1]}", word)
    return value


_MAX_SHOWN = 40
"""The longest quantity a message repeats as written."""


_KEYWORDS = frozenset({"slowly", "to", "end", "start"})
_UNIT_WORDS = {
    **dict.fromkeys(("metre", "metres", "meter", "meters"), "m"),
    **dict.fromkeys(("centimetre", "centimetres", "centimeter", "centimeters"), "cm"),
    **dict.fromkeys(("millimetre", "millimetres", "millimeter", "millimeters"), "mm"),
    **dict.fromkeys(("second", "seconds", "sec", "secs"), "s"),
    **dict.fromkeys(("minute", "minutes", "mins"), "min"),
}
"""Unit words people write, as unit symbols (``2 metres`` is ``2 m``)."""


def dimension_article(dimension: str) -> str:
    """``"a length"``, ``"a time"``: for messages."""
    return ("an " if dimension[:1] in "aeiou" else "a ") + dimension


def _distance_or_end(line: _Line, verb: str) -> float | None:
    word = line.peek()
    if word is not None and word.text == "to":
        line.take()
        line.expect(("end",), f"{verb} to")
        return None
    return _quantity(line, "length", verb, f"{verb} 2.5 m")


def _slowly(line: _Line) -> bool:
    word = line.peek()
    if word is not None and word.text == "slowly":
        line.take()
        return True
    line.done(("slowly",))
    return False


def _parse_line(
    line: _Line, text: str
) -> RouteStep | tuple[str, SourceLocation, SourceLocation] | None:
    """A command, or for a ``network`` line the name, the line's place and the name's."""
    first = line.take()
    if first is None:
        return None
    loc = line.at(first.column)
    verb = first.text
    if verb == "network":
        name = line.take()
        if name is None or not (_NAME_RE.match(name.raw) or _NETWORK_FILE_RE.match(name.raw)):
            raise line.error(
                "network: give the network's name or its file, e.g. 'network lab' or"
                " 'network ../networks/site.yaml'",
                name,
            )
        line.done()
        return (name.raw, loc, line.at(name.column))
    if verb in ("forward", "inspect"):
        distance = _distance_or_end(line, verb)
        slowly = _slowly(line)
        kind = StepKind.FORWARD if verb == "forward" else StepKind.INSPECT
        return RouteStep(kind, loc, text, distance_m=distance, slowly=slowly)
    if verb == "back":
        distance = _quantity(line, "length", "back", "back 1 m")
        slowly = _slowly(line)
        return RouteStep(StepKind.BACK, loc, text, distance_m=distance, slowly=slowly)
    if verb == "at":
        feature_word = line.take()
        if feature_word is None:
            raise line.error("at: expected 'bend' or 'T-joint', e.g. 'at the bend turn up'")
        feature = _FEATURES.get(feature_word.text)
        if feature is None:
            raise line.error(
                f"at: unknown feature '{feature_word.raw}'"
                f"{_suggest(feature_word.text, ('bend', 't-joint', 'tee'))}",
                feature_word,
            )
        if feature == "bend":
            line.expect(("turn", "go"), "at the bend")
            word = line.peek()
            direction: str | None = None
            if word is not None:
                direction = line.expect(BEND_DIRECTIONS, "at the bend turn").text
            line.done()
            return RouteStep(StepKind.BEND, loc, text, direction=direction)
        line.expect(("go", "turn"), "at the T-joint")
        direction = line.expect(TEE_WAYS, "at the T-joint go").text
        line.done()
        return RouteStep(StepKind.TEE, loc, text, direction=direction)
    if verb == "go":
        line.expect(("to",), "go")
        word = line.peek()
        if word is not None and word.text == "segment":
            line.take()
        name = line.take()
        if name is None or not _NAME_RE.match(name.raw):
            raise line.error("go to: give a segment's id, e.g. 'go to service-1'", name)
        line.done()
        return RouteStep(StepKind.GOTO, loc, text, segment=name.raw)
    if verb in ("pause", "wait"):
        duration = _quantity(line, "time", verb, f"{verb} 5 s", _LONGEST_PAUSE)
        line.done()
        return RouteStep(StepKind.PAUSE, loc, text, duration_s=duration)
    if verb == "return":
        line.expect(("to",), "return")
        line.expect(("start",), "return to")
        line.done()
        return RouteStep(StepKind.RETURN, loc, text)
    raise line.error(f"unknown command '{first.raw}'{_suggest(verb, COMMAND_WORDS)}", first)


def _hidden_character(line: str, commands: int) -> tuple[int, str] | None:
    """The first character of ``line`` a terminal or an editor would not show as it is,
    and why, if any: a control character but a tab anywhere (an ESC echoed in *unknown
    unit 'm<ESC>[31m'* recoloured or cleared the operator's terminal), or a format
    character (a zero-width space, a text-direction override) among the first
    ``commands`` characters, the line before its comment."""
    if line.isprintable():
        return None
    for index, c in enumerate(line):
        category = unicodedata.category(c)
        if (category == "Cc" and c != "\t") or (category == "Cf" and index < commands):
            what = "a control character" if category == "Cc" else "an invisible character"
            label = unicodedata.name(c, "") or repr(c)[1:-1]
            return index, f"U+{ord(c):04X} {label} ({what}) is not allowed in a route"
    return None


def parse_route(text: str, source: str = "<route>", name: str | None = None) -> Route:
    """Parse route text.

    Args:
        text: The route, one command per line.
        source: File name for messages.
        name: The route's name (default: the file name without its suffix).

    Returns:
        The parsed route.

    Raises:
        ValidationFailed: every malformed line, each at ``file:line:column``.
        ArgumentTypeError: ``text`` or ``source`` not text, ``name`` neither text nor
            ``None`` (a file is for :func:`load_route`).
    """
    for arg, value, may_be_none in (
        ("text", text, False),
        ("source", source, False),
        ("name", name, True),
    ):
        if not isinstance(value, str) and not (may_be_none and value is None):
            raise ArgumentTypeError(
                f"parse_route: {arg}: give text{' or None' if may_be_none else ''},"
                f" not {shown(value)}"
                + ("; pirate_bt.load_route reads a file" if arg == "text" else "")
            )
    errors: list[LocatedError] = []
    steps: list[RouteStep] = []
    network: str | None = None
    network_loc: SourceLocation | None = None
    from pirate_bt.yamlfile import refuse_hidden_break

    # a form feed or U+2028 would start a line str.splitlines sees and an editor does not
    # ('# skip:<FF>forward 5 m' would run the forward): refused, a file's or text's
    refuse_hidden_break(text, source, "route")
    text = text.removeprefix("\ufeff")  # a byte-order mark, as editors on Windows write
    for line_no, raw_line in enumerate(text.splitlines(), start=1):
        body = raw_line.split("#", 1)[0]
        odd = _hidden_character(raw_line, len(body))
        if odd is not None:
            errors.append(LocatedError(odd[1], SourceLocation(source, line_no, odd[0] + 1)))
            continue
        line = _Line(source, line_no, body)
        try:
            result = _parse_line(line, " ".join(body.split()))
        except LocatedError as exc:
            errors.append(exc)
            continue
        if result is None:
            continue
        if isinstance(result, tuple):
            if network is not None:
                errors.append(LocatedError("the network is already named above", result[1]))
            elif steps:
                errors.append(LocatedError("name the network before the first command", result[1]))
            network, _, network_loc = result
            continue
        steps.append(result)
    if not errors and not steps:
        errors.append(
            LocatedError(
                "the route has no commands; write e.g. 'forward 2.5 m'",
                SourceLocation(source, 1, 1),
            )
        )
    if errors:
        raise ValidationFailed(errors)
    route_name = name or _printable(Path(source).name.removesuffix(_SUFFIX))
    return Route(route_name, source, tuple(steps), network, network_loc)


def load_route(path: str | Path) -> Route:
    """Read and parse a route file.

    ``path`` is a file path only; :func:`pirate_bt.plan_route` and
    :func:`pirate_bt.simulate_mission` also find a bundled route (``"lab.route"``).

    Raises:
        ValidationFailed: the file cannot be read or a line is malformed.

    Example::

        route = pirate_bt.load_route("scenarios/lab.route")
        print(route.network, [step.text for step in route.steps][:2])
        # lab ['inspect 3 m', 'at the bend turn right']
    """
    from pirate_bt.yamlfile import MAX_BYTES, decode_text, read_at_most, special_file

    p = Path(path)
    where = SourceLocation(str(path))
    kind = special_file(p)
    if kind is not None:
        raise ValidationFailed([LocatedError(f"is {kind}, not a route file", where)])
    try:
        with p.open("rb") as stream:  # at most MAX_BYTES: /dev/zero never ends
            raw = read_at_most(stream, MAX_BYTES)
    except OSError as exc:  # worded as the YAML files' (no errno, no name twice)
        why = {FileNotFoundError: "no such file", IsADirectoryError: "is a directory, not a file"}
        text = why.get(type(exc)) or f"cannot read the route: {exc.strerror or exc}"
        raise ValidationFailed([LocatedError(text, where)]) from None
    if len(raw) > MAX_BYTES:
        raise ValidationFailed(
            [LocatedError(f"larger than the {MAX_BYTES} bytes a route may be", where)]
        )
    text = decode_text(raw, str(path), "route")
    try:
        return parse_route(text, str(path))
    except ValidationFailed:
        if p.suffix.lower() not in (".yaml", ".yml"):
            raise
        # a network (or another YAML file) given where a route goes: one line saying
        # so, not a line per YAML key read as an unknown command
        raise ValidationFailed(
            [
                LocatedError(
                    "a YAML file, not a route: a route is lines of steps ('network lab',"
                    " then 'forward 1 m', ...; docs/routes.md); a network file goes to"
                    " --network or --sim (navigate: --map)",
                    SourceLocation(str(path), 1, 1),
                )
            ]
        ) from None
