"""``pirate-bt network perturb|remove|add-tee``: as-built variants of a drawn network.

``perturb MAP --seed N`` writes a network with the same features whose straight
lengths, slopes and diameters differ within stated bounds (``docs/networks.md``);
``remove MAP FEATURE`` one without a tee or bend that was never built;
``add-tee MAP SEGMENT AT`` one with a tee nobody drew. Each writes the network
file to ``-o OUT`` or to standard output, once the text it writes has loaded back
as ``pirate-bt validate`` loads a network; nothing is written when the input is bad,
when the network it would write does not validate, or when ``OUT`` is the input
network's own file. Give the result to ``pirate-bt mission ROUTE --sim OUT --network
MAP``.
"""

from __future__ import annotations

import argparse
import math
import shlex
import sys
from pathlib import Path
from typing import Any

from pirate_bt.atomic import write_atomically
from pirate_bt.cli import STDOUT, said_path, stdout_open, utf8_text
from pirate_bt.errors import (
    ConfigurationError,
    InputError,
    PirateError,
    ValidationFailed,
    bytes_escaped,
    shown,
)
from pirate_bt.units import parse_quantity

__all__ = ["configure", "run"]


_BOUND_OPTIONS: dict[str, tuple[str, str | float | None]] = {
    "length": ("--length", "10%"),
    "length_max": ("--length-max", "0.5 m"),
    "slope": ("--slope", "3 deg"),
    "diameter": ("--diameter", "5%"),
    "scale": ("--scale", 1.0),
    "robot": ("--robot", None),
}
"""The perturb options that change the variant: option and default, by attribute."""


def _default(attr: str) -> str | float | None:
    return _BOUND_OPTIONS[attr][1]


def configure(parser: argparse.ArgumentParser) -> None:
    subs = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    perturb = subs.add_parser(
        "perturb", help="an as-built variant: lengths, slopes, diameters within bounds"
    )
    perturb.add_argument("map", metavar="MAP", help="the drawn network (file or bundled name)")
    perturb.add_argument("--seed", type=int, required=True, help="which variant")
    perturb.add_argument(
        "--length",
        default=_default("length"),
        metavar="FRACTION",
        help="straight length change (default %(default)s)",
    )
    perturb.add_argument(
        "--length-max",
        default=_default("length_max"),
        metavar="LENGTH",
        help="... at most (default %(default)s)",
    )
    perturb.add_argument(
        "--slope",
        default=_default("slope"),
        metavar="ANGLE",
        help="slope change (default %(default)s)",
    )
    perturb.add_argument(
        "--diameter",
        default=_default("diameter"),
        metavar="FRACTION",
        help="diameter change (default %(default)s)",
    )
    perturb.add_argument(
        "--scale",
        type=float,
        default=_default("scale"),
        help="multiply every bound (e.g. 2 for twice)",
    )
    perturb.add_argument("--robot", metavar="FILE", help="robot whose clamp range bounds diameters")
    remove = subs.add_parser("remove", help="without a tee or bend (never built)")
    remove.add_argument("map", metavar="MAP")
    remove.add_argument("feature", metavar="FEATURE", help="the tee's or bend's segment id")
    add = subs.add_parser("add-tee", help="with a tee nobody drew")
    add.add_argument("map", metavar="MAP")
    add.add_argument("segment", metavar="SEGMENT", help="the straight the tee sits in")
    add.add_argument("at", metavar="AT", help="how far into the straight, e.g. 1.5m")
    add.add_argument(
        "--direction",
        default="left",
        choices=("up", "down", "left", "right"),
        help="where the new tee's branch leaves (default left)",
    )
    add.add_argument(
        "--id", default="extra-tee", type=utf8_text, help="the new tee's id (default extra-tee)"
    )
    for sub in (perturb, remove, add):
        sub.add_argument(
            "-o",
            "--output",
            type=Path,
            metavar="OUT",
            help="network file to write (default, or '-': standard output)",
        )


def _fraction(text: str, option: str) -> float:
    body = text.strip()
    try:
        value = float(body[:-1]) / 100.0 if body.endswith("%") else float(body)
    except ValueError:
        raise InputError(f"{option}: {text!r} is not a fraction (write e.g. 10% or 0.1)") from None
    if not 0.0 <= value < 1.0:
        raise InputError(f"{option}: {text!r} must be at least 0 and below 100%")
    return value


def _quantity(text: str, dimension: str, option: str) -> float:
    try:
        value = parse_quantity(text, dimension)
    except InputError as exc:
        raise InputError(f"{option}: {exc}") from None
    if value < 0:
        raise InputError(f"{option}: {text!r} must not be negative")
    return value


_MAX_SCALE = 10.0
"""As a campaign's ``as_built.scale``: ten times the stated bounds."""


def _bounds(args: argparse.Namespace) -> Any:
    from pirate_bt.pipes.asbuilt import AsBuiltBounds
    from pirate_bt.robot.loader import load_robot

    robot = load_robot(args.robot)
    points = robot.clamp.contact_angles
    if not 0 < args.scale <= _MAX_SCALE:
        raise InputError(f"--scale must be a positive number, at most {_MAX_SCALE:g}")
    slope = _quantity(args.slope, "angle", "--slope")
    if slope * args.scale > math.pi / 2 + 1e-9:  # was taken, and each slope clamped to 90
        raise InputError(
            f"--slope: {args.slope!r}"
            + (f" x --scale {args.scale:g}" if args.scale != 1 else "")
            + " is more than 90 deg, past plumb: a slope changes by at most 90 deg"
        )
    return AsBuiltBounds(
        length_fraction=_fraction(args.length, "--length"),
        length_max_m=_quantity(args.length_max, "length", "--length-max"),
        slope_rad=slope,
        diameter_fraction=_fraction(args.diameter, "--diameter"),
        diameter_min_m=points[0].diameter,
        diameter_max_m=points[-1].diameter,
        put_in_m=sum(module.length for module in robot.modules),  # put in on straight pipe
    ).scaled(args.scale)


def _loads_back(text: str, output: Path | None, what: str) -> None:
    """Refuse a network text that does not load back as ``validate`` loads the file
    (``remove`` of a network's only segment wrote ``segments: []``; ``add-tee`` at
    ``1e-300m`` wrote ``length: 0.0 mm``; both exit 0)."""
    from pirate_bt.pipes.loader import network_from_document
    from pirate_bt.yamlfile import load_yaml_text

    try:
        network_from_document(load_yaml_text(text, str(output or "<stdout>")))
    except ValidationFailed as exc:
        first = exc.errors[0]
        lines = text.splitlines()
        line = first.location.line
        at = f" at {lines[line - 1].strip()!r}" if line and 0 < line <= len(lines) else ""
        more = f" (and {len(exc.errors) - 1} more)" if len(exc.errors) > 1 else ""
        where = f"-o {output}" if output is not None else "standard output"
        raise InputError(
            f"{where}: nothing written: {what} does not validate{at}: {first.message}{more}"
        ) from None


def _write(text: str, output: Path | None) -> None:
    if output is None:
        stdout_open("the network file")
        sys.stdout.write(text)
        return
    if output.is_dir():
        raise InputError(f"-o {output}: a folder, not a file; give the network file to write")
    if output.exists() and not output.is_file():  # a pipe nobody reads hung the command
        raise InputError(
            f"-o {output}: a pipe or a device, not a file (without -o the network goes to"
            " standard output)"
        )
    data = text.encode("utf-8")
    try:  # no half-written network file
        write_atomically(output, lambda stream: stream.write(data))
    except OSError as exc:
        raise InputError(f"-o {output}: cannot write there: {exc.strerror or exc}") from None
    print(f"wrote {said_path(output)}")  # the path written, on stdout as every command says it


def _load_map(source: Path, given: str) -> Any:
    """The network MAP names; a file of another kind said to be one (a route was
    *lab.route:6:1: YAML syntax error: did not find expected <document start>*, or
    *a pipe network must be a mapping of keys*), with what to give instead."""
    from pirate_bt.filekinds import KINDS
    from pirate_bt.pipes import load_network

    other = next(
        (
            kind
            for kind in KINDS.values()
            if kind.name != "network" and any(source.name.endswith(s) for s in kind.suffixes)
        ),
        None,
    )
    if other is None or other.name == "route":
        try:
            return load_network(source)
        except ValidationFailed:
            route = _as_route(source)
            if route is None and other is None:
                raise
    else:
        route = None
    title = "route" if other is None else other.title
    named = getattr(route, "network", None)
    if named:
        instead = (
            f"give the network it is written for, {shown(named)} (its 'network' line), or"
            " another network file (.yaml) or bundled name"
        )
    else:
        instead = "give a network file (.yaml) or a bundled network's name"
    raise InputError(f"{given}: a {title}, not a pipe network: {instead}")


def _as_route(source: Path) -> Any:
    """``source`` read as a route, or ``None`` when it is none."""
    from pirate_bt.task.route import load_route

    try:
        route = load_route(source)
    except PirateError:
        return None
    return route if route.steps or route.network else None


def _bound_options(args: argparse.Namespace) -> str:
    """The options given that change the variant, as they would be typed again, so that
    the header's command writes the same file."""
    out = ""
    for attr, (option, default) in _BOUND_OPTIONS.items():
        value = getattr(args, attr)
        if value != default:
            shown = f"{value:g}" if isinstance(value, float) else str(value)
            out += f" {option} {shlex.quote(shown)}"
    return out


def run(args: argparse.Namespace) -> int:
    from pirate_bt.api.options import not_an_input
    from pirate_bt.pipes.asbuilt import insert_tee, network_yaml, perturb_network, remove_feature
    from pirate_bt.resources import find_file, missing

    if args.action == "perturb":
        from pirate_bt.api.options import seed_value

        # a campaign's as_built variants are 0 to 2**63 - 1: '--seed -1' wrote variant 1
        # (Python's random seeds by the number's size) under another name
        seed_value(args.seed, "--seed")
    if args.output is not None and str(args.output) == STDOUT:  # was a file named "-"
        args.output = None
    if args.output is not None:  # before any work; a name too long was an OSError's line
        from pirate_bt.cli import check_output

        check_output(args.output)
    source = find_file("scenarios", args.map)
    if missing(source):  # named as --sim names it, not as the bundled path never typed
        from pirate_bt.task.networks import resolve_network_path

        try:
            source = resolve_network_path(str(args.map))
        except FileNotFoundError as exc:
            raise InputError(str(exc)) from None
    network = _load_map(source, str(args.map))
    if args.output is not None:  # perturb br2.yaml -o br2.yaml replaced its input
        not_an_input(args.output, "-o", {"input network": source})
    try:
        if args.action == "perturb":
            bounds = _bounds(args)
            spec = perturb_network(network.spec, args.seed, bounds)
            header = (
                f"As-built variant {args.seed} of {network.source}: {bounds.describe()}.\n"
                f"Written by: pirate-bt network perturb {shlex.quote(args.map)} --seed {args.seed}"
                f"{_bound_options(args)}"
            )
            what = f"as-built variant {args.seed}"
        elif args.action == "remove":
            spec = remove_feature(network.spec, args.feature)
            header = f"{network.source} without {args.feature} (never built)."
            what = f"the network without {args.feature}"
        else:
            at_m = _quantity(args.at, "length", "AT")
            spec = insert_tee(network.spec, args.segment, at_m, args.direction, tee_id=args.id)
            header = f"{network.source} with a tee nobody drew ({args.id} in {args.segment})."
            what = f"the network with {args.id} {args.at} into {args.segment}"
    except ConfigurationError as exc:
        raise InputError(str(exc)) from None
    # a file name of bytes that are no UTF-8 ($'\xff.yaml', read as '\udcff') shown as
    # \xff: it was "internal error: UnicodeEncodeError ... surrogates not allowed", exit 1
    header = bytes_escaped(header)
    text = network_yaml(spec, header)
    _loads_back(text, args.output, what)
    _write(text, args.output)
    return 0
