"""``pirate-bt trace summary|show|plot|schema|export``: read a run back from its trace."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from pirate_bt.cli import as_option, check_output, said_path, stdout_open
from pirate_bt.errors import file_argument

__all__ = ["EXPORTS", "configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    subs = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    summary = subs.add_parser(
        "summary", help="outcome and why, duration, per-node counts, refusals, faults"
    )
    summary.add_argument("trace", type=Path, help="trace file (.jsonl, .jsonl.gz or .mcap)")
    show = subs.add_parser("show", help="the tree with statuses at one tick")
    show.add_argument("trace", type=Path, help="trace file (.jsonl, .jsonl.gz or .mcap)")
    show.add_argument("--tick", type=int, help="tick number (default: the last; 0 is before)")
    show.add_argument(
        "--state",
        action="store_true",
        help="also print state, link, simulator counters, blackboard, commands and events",
    )
    show.add_argument("--ascii", action="store_true", help="ASCII status marks only")
    plot = subs.add_parser("plot", help="joints, clamps, speed and rotation over time")
    plot.add_argument("trace", type=Path, help="trace file (.jsonl, .jsonl.gz or .mcap)")
    plot.add_argument("-o", "--output", type=Path, required=True, help="picture (.png, .svg)")
    plot.add_argument(
        "--from",
        dest="start",
        metavar="SECONDS",
        type=float,
        help="zoom: start at this many seconds of trace time (adds the PAB steps)",
    )
    plot.add_argument(
        "--to", dest="end", metavar="SECONDS", type=float, help="zoom: end at this time"
    )
    subs.add_parser("schema", help="print the JSON Schema of one trace record")
    export = subs.add_parser(
        "export",
        help="write the trace for other tools: .btlog (Groot2), .mcap (Foxglove),"
        " RUN_bag/ (a rosbag2 directory for ROS 2)",
    )
    export.add_argument("trace", type=Path, help="trace file (.jsonl, .jsonl.gz or .mcap)")
    export.add_argument(
        "-o",
        "--output",
        required=True,
        help="file to write; its suffix picks the format (a name ending in / or _bag:"
        " a rosbag2 directory)",
    )
    export.add_argument(
        "--ros-distro",
        metavar="DISTRO",
        help="for a rosbag2 directory: the ROS 2 distribution that will read it; humble"
        " or iron writes bag format 8, jazzy (the default), kilted or rolling 9",
    )


def _summary(args: argparse.Namespace) -> int:
    from pirate_bt.trace.reader import read_trace
    from pirate_bt.trace.text import format_summary, summarise

    stdout_open("the summary")  # >&-: it went nowhere, exit 0
    trace = read_trace(args.trace)
    print("\n".join(format_summary(summarise(trace), trace.structure)))
    return 0


def _show(args: argparse.Namespace) -> int:
    from pirate_bt.trace.reader import read_trace
    from pirate_bt.trace.text import one_line, tree_text

    stdout_open("the tick")  # >&-: it went nowhere, exit 0
    trace = read_trace(args.trace)
    tick = trace.last_tick if args.tick is None else args.tick
    frame = trace.frame_at(tick)
    name = one_line(trace.structure.name)  # a line break or escape of the file's, escaped
    print(f"{name}: tick {frame.n} of {trace.last_tick}, t = {frame.t_s:.3f} s")
    print(
        "\n".join(tree_text(trace.structure, frame.status, frame.feedback, ascii_only=args.ascii))
    )
    if args.state:
        for title, values in (
            ("state", frame.state),
            ("link", frame.link),
            ("sim", frame.sim),
            ("blackboard", frame.blackboard),
        ):
            if values:
                print(f"{title}:")
                for key in sorted(values):
                    print(one_line(f"  {key} = {_shown(title, key, values[key])}"))
        for command in frame.commands:
            print(one_line(f"command: {json.dumps(command, ensure_ascii=False)}"))
        for event in frame.events:
            print(one_line(f"event: {json.dumps(event, ensure_ascii=False)}"))
    return 0


#: The last part of a name that says its value is a quantity in a unit, not a count.
_UNIT_ENDINGS = ("_m", "_s", "_rad", "_mps", "_a", "_v", "_deg", "_ratio", "_hz")


def _shown(title: str, key: str, value: object) -> str:
    """A value as ``trace show --state`` prints it: JSON, with the simulator's counts
    (recorded as numbers, ``5.0``) printed as the whole numbers they are."""
    if (
        title == "sim"
        and isinstance(value, float)
        and value.is_integer()
        and not key.endswith(_UNIT_ENDINGS)
    ):
        return str(int(value))
    return json.dumps(value, ensure_ascii=False)


def _plot(args: argparse.Namespace) -> int:
    from pirate_bt.render.plot import plot_trace
    from pirate_bt.trace.reader import read_trace

    trace = read_trace(args.trace)
    check_output(args.output)
    out = plot_trace(trace, args.output, start_s=args.start, end_s=args.end)
    print(f"plotted {said_path(out)}")
    return 0


def _schema(args: argparse.Namespace) -> int:
    from pirate_bt.trace.records import trace_schema

    stdout_open("the schema")  # >&-: it went nowhere, exit 0
    print(json.dumps(trace_schema(), indent=2, ensure_ascii=False))
    return 0


# output suffix -> (module, function); the function takes (trace_path, out_path)
# and returns the file written. Imported only when chosen.
EXPORTS: dict[str, tuple[str, str]] = {
    ".btlog": ("pirate_bt.interop.btlog", "export_btlog"),
    ".mcap": ("pirate_bt.interop.mcap_trace", "export_mcap"),
}


def _export(args: argparse.Namespace) -> int:
    import importlib

    from pirate_bt.errors import InputError
    from pirate_bt.interop.rosbag2 import export_rosbag2, is_bag_path

    target = str(args.output)
    distro = getattr(args, "ros_distro", None)
    if is_bag_path(target):
        from pirate_bt.interop.rosbag2 import DEFAULT_ROS_DISTRO, bag_version

        if distro is not None:
            try:
                bag_version(distro)
            except InputError as exc:  # named by its option (the API's is "ros_distro")
                raise InputError(str(exc).replace("ros_distro ", "--ros-distro ", 1)) from None
        bag = target.rstrip("/") or "/"
        if not Path(bag).exists():  # named by its option (the API's is "out_dir")
            check_output(bag)
        written = export_rosbag2(args.trace, Path(target), ros_distro=distro or DEFAULT_ROS_DISTRO)
        print(f"wrote {said_path(written)}")
        return 0
    if distro is not None:  # it would be dropped without a word
        raise InputError(
            "--ros-distro is for a rosbag2 directory (-o NAME/ or NAME_bag),"
            f" not {said_path(target)}"
        )
    check_output(target)
    args.output = Path(target)
    from pirate_bt.api.options import not_an_input

    # export t.mcap -o t.mcap wrote over the trace it was reading, exit 0
    not_an_input(args.output, "-o", {"trace": args.trace})
    suffix = args.output.suffix.lower()
    if suffix not in EXPORTS:
        raise InputError(
            f"{args.output}: unknown export format {suffix or '(no suffix)'!r};"
            f" known: {', '.join(EXPORTS)}, or a rosbag2 folder (a name ending in / or _bag)"
        )
    module_name, function = EXPORTS[suffix]
    export = getattr(importlib.import_module(module_name), function)
    try:
        written = export(args.trace, args.output)
    except InputError as exc:  # a full disk said "out_path: cannot write t.mcap: ..."
        as_option(exc, "out_path", "-o")
        raise
    print(f"wrote {said_path(written)}")
    return 0


def run(args: argparse.Namespace) -> int:
    actions = {
        "summary": _summary,
        "show": _show,
        "plot": _plot,
        "schema": _schema,
        "export": _export,
    }
    if getattr(args, "trace", None) is not None:
        # named as the user typed it ('trace: ...'), not the library's parameter
        file_argument(args.trace, "trace")
    code = actions[args.action](args)
    sys.stdout.flush()
    return code
