"""``pirate-bt run TREE``: run a behaviour tree against the simulator or a robot.

The tree is loaded and checked against the robot description first (exit 2 on
any problem); then the public API runs it (:func:`pirate_bt.simulate_tree`, or
:func:`pirate_bt.run_tree` with ``--port``), which connects only when the tree
needs a robot: a tree of generic leaves runs on a simulated clock with nothing
attached. The command prints the result's summary: the first cause of a failure
and the node it happened at. Exit codes: 0 the tree succeeded; 1 it failed, timed out, raised or
was interrupted, and the robot was left in its safe state; 2 invalid input;
3 link error (cannot connect, link lost).
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from collections.abc import Iterator
from typing import Any

from pirate_bt.api.options import MAX_RATE_HZ, check_rate, seed_value, split_faults
from pirate_bt.cli.faults_option import check_faults_option
from pirate_bt.errors import InputError, UnitError
from pirate_bt.units import parse_quantity

__all__ = [
    "MAX_RATE_HZ",
    "check_rate",
    "check_trace_path",
    "configure",
    "open_foxglove",
    "open_groot2",
    "open_ros2",
    "parse_params",
    "run",
    "split_faults",
]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "tree",
        metavar="TREE",
        help="the tree: a YAML file, a BehaviorTree.CPP / Groot2 XML file, or a bundled"
        " tree's name (bend, straight, ...)",
    )
    parser.add_argument("--robot", metavar="FILE", help="robot description (default: bundled)")
    where = parser.add_mutually_exclusive_group()
    where.add_argument(
        "--sim",
        metavar="NETWORK",
        help="run against the built-in simulator in this pipe network (the default)",
    )
    where.add_argument("--port", metavar="URL", help="a real robot: serial port or pyserial URL")
    parser.add_argument(
        "--firmware-chain",
        action="store_true",
        help="with the simulator: run its physics behind the real firmwares in simavr (the"
        " bridge and a reference PICO per board, virtual time; needs `make firmware`)",
    )
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a tree parameter, e.g. --param roll=90deg (repeatable)",
    )
    parser.add_argument("--seed", type=int, default=0, help="simulator random seed (default 0)")
    parser.add_argument("--faults", metavar="SPEC", help="simulator fault injection")
    parser.add_argument(
        "--max-time", default="600 s", metavar="TIME", help="time limit (default 600 s)"
    )
    parser.add_argument("--rate", default="20 Hz", metavar="FREQ", help="tick rate (default 20 Hz)")
    parser.add_argument("--realtime", action="store_true", help="pace a simulated run to wall time")
    parser.add_argument(
        "--trace", metavar="FILE", help="write a tick-by-tick trace (.jsonl, .jsonl.gz or .mcap)"
    )
    parser.add_argument("-q", "--quiet", action="store_true", help="no live view of the tree")
    from pirate_bt.interop.foxglove_option import add_foxglove_option

    add_foxglove_option(parser)
    from pirate_bt.interop.ros2_option import add_ros2_options

    add_ros2_options(parser)
    from pirate_bt.interop.groot2_option import add_groot2_option

    add_groot2_option(parser)


def _quantity(text: str, dimension: str, option: str) -> float:
    try:
        return parse_quantity(text, dimension)
    except UnitError as exc:
        raise InputError(f"{option}: {exc}") from None


def parse_params(items: list[str]) -> dict[str, str]:
    """``["roll=90 deg"]`` → ``{"roll": "90 deg"}``.

    Raises:
        InputError: an item is not ``key=value``, or a key is given twice with two values.
    """
    out: dict[str, str] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise InputError(f"--param {item!r}: write key=value, e.g. --param roll=90deg")
        key, value = key.strip(), value.strip()
        if out.get(key, value) != value:
            raise InputError(f"--param {key}: given twice ({out[key]!r}, then {value!r})")
        out[key] = value
    return out


def open_foxglove(args: argparse.Namespace) -> Any:
    """The Foxglove server of ``--foxglove [HOST:PORT]``, or ``None`` without the option.

    Raises:
        InputError: a bad address, or the port is taken.
        ConfigurationError: the ``foxglove`` extra is missing.
    """
    if getattr(args, "foxglove", None) is None:
        return None
    from pirate_bt.interop.foxglove_live import FoxgloveServer, parse_address

    host, port = parse_address(args.foxglove)
    server = FoxgloveServer(host, port)
    print(f"pirate-bt: Foxglove live view on {server.url}", file=sys.stderr)
    return server


def open_ros2(args: argparse.Namespace, *, estop: bool = True) -> Any:
    """The ROS 2 node of ``--ros2 [ENDPOINT]``, or ``None`` without the option.
    ``estop=False``: a command with no supervisor to stop (``sim``), whose node must
    not declare an e-stop subscription nothing would hear.

    Raises:
        InputError: a bad endpoint, domain id or namespace.
        ConfigurationError: the ``ros2`` extra is missing.
    """
    if getattr(args, "ros2", None) is None:
        return None
    from pirate_bt.interop.ros2_live import Ros2Node

    node = Ros2Node(
        args.ros2, domain_id=args.ros_domain_id, namespace=args.ros_namespace, estop=estop
    )
    stop = f"e-stop: {node.fq_estop}" if estop else "no e-stop: nothing here to stop"
    print(
        f"pirate-bt: ROS 2 node {node.namespace}/{node.name} on Zenoh {node.endpoint},"
        f" domain {node.domain_id} ({stop})",
        file=sys.stderr,
    )
    return node


def open_groot2(args: argparse.Namespace) -> Any:
    """The Groot2 server of ``--groot2 [HOST:]PORT``, or ``None`` without the option.

    Raises:
        InputError: a bad address, or a port is taken.
        ConfigurationError: the ``groot2`` extra is missing.
    """
    if getattr(args, "groot2", None) is None:
        return None
    from pirate_bt.interop.groot2_server import Groot2Server, parse_groot2_address

    host, port = parse_groot2_address(args.groot2)
    server = Groot2Server(host, port)
    print(
        f"pirate-bt: Groot2 live view on {server.address} (and {server.port + 1});"
        " in Groot2: Monitor, Connect",
        file=sys.stderr,
    )
    return server


@contextlib.contextmanager
def live_outputs(args: argparse.Namespace) -> Iterator[tuple[Any, Any, Any]]:
    """Open what ``--foxglove``, ``--ros2`` and ``--groot2`` ask for; close all of it after.

    Yields ``(foxglove server, ROS 2 node, Groot2 server)``, ``None`` for each not asked
    for. One that fails to open closes those opened before it.
    """
    with contextlib.ExitStack() as stack:
        opened = []
        for opener in (open_foxglove, open_ros2, open_groot2):
            output = opener(args)
            if output is not None:
                stack.callback(output.close)
            opened.append(output)
        yield opened[0], opened[1], opened[2]


def check_trace_path(path: str) -> None:
    """Refuse a ``--trace`` path that can never be written, before anything connects.

    Raises:
        InputError: an unknown suffix (the known ones listed), a directory, or a file
            another run is writing.
    """
    from pirate_bt.cli import check_output
    from pirate_bt.trace.formats import suffix_of
    from pirate_bt.trace.writer import WRITERS

    suffix_of(path, WRITERS)
    check_output(path, "--trace")
    from pirate_bt.api.options import output_path

    output_path(path, "--trace")  # the API's rule (no device), named as typed: "trace: ..."
    from pirate_bt.trace.recorder_args import TraceWriteError, check_free

    try:
        check_free(path)  # another run writing it now
    except TraceWriteError as exc:
        raise InputError(f"--trace: cannot write {path}: {exc.strerror}") from None


def check_firmware_chain(args: argparse.Namespace) -> None:
    """``--firmware-chain`` with ``--port`` is a mistake: say so before opening anything."""
    if args.port is not None and getattr(args, "firmware_chain", False):
        raise InputError(
            "--firmware-chain runs the simulator through the firmwares;"
            " with --port the real bridge runs its own"
        )


def run(args: argparse.Namespace) -> int:
    """Parse, check the tree (exit 2 before connecting), call the API, print."""
    from pirate_bt.api.live import tree_observer
    from pirate_bt.api.running import find_tree, load_tree_source
    from pirate_bt.api.trees import run_tree, simulate_tree
    from pirate_bt.robot.loader import load_robot
    from pirate_bt.runner import StopReason

    max_time_s = _quantity(args.max_time, "time", "--max-time")
    rate_hz = _quantity(args.rate, "frequency", "--rate")
    if max_time_s <= 0:
        raise InputError("--max-time must be positive")
    check_rate(rate_hz, max_time_s, "--rate", "--max-time")  # the API's own limits
    seed_value(args.seed, "--seed")  # the API's check, named as typed (it said "seed:")
    params = parse_params(args.param)
    if args.trace is not None:
        check_trace_path(args.trace)
    robot = load_robot(args.robot)
    check_faults_option(args, robot)  # at its column: it said "faults: ..."
    checked = load_tree_source(  # a YAML tree, or BehaviorTree.CPP XML
        find_tree(args.tree),  # a file, else a bundled tree; else the API's error
        robot=robot,
        params=params,
        params_from_text=True,
        params_origin="--param",
    )
    check_firmware_chain(args)
    with live_outputs(args) as (server, node, groot2):
        options: dict[str, Any] = {
            "faults": args.faults,
            "trace": args.trace,
            "robot": robot,
            "max_time": max_time_s,
            "rate": rate_hz,
            "live": not args.quiet,
            "observe": tree_observer(server, robot) if server is not None else None,
            "ros2": node,
            "groot2": groot2,
        }
        if args.port is not None:
            result = run_tree(checked, port=args.port, **options)
        else:
            try:
                result = simulate_tree(
                    checked,
                    network=args.sim or "straight",
                    seed=args.seed,
                    realtime=args.realtime,
                    firmware=getattr(args, "firmware_chain", False),
                    **options,
                )
            except InputError as exc:  # "network: no network 'x'", the API's parameter
                from pirate_bt.cli import as_option

                as_option(exc, "network", "--sim")
                raise
    if result.succeeded:
        print(result.summary())
        return 0
    if result.after_stop is not None:  # as a mission's notes: before its last line
        print(f"pirate-bt: after the stop, {result.after_stop}", file=sys.stderr)
    print(f"pirate-bt: {result.summary()}", file=sys.stderr)
    if result.stop is StopReason.EXCEPTION and result.traceback and args.debug:
        print(result.traceback, file=sys.stderr)
    return result.exit_code
