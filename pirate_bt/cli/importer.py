"""``pirate-bt import SOURCE FILE -o TREE.yaml``: read a tree from another tool's format.

Sources are rows of :data:`SOURCES` (name -> module, function, help), imported
only when chosen. Today:

- ``btcpp``: BehaviorTree.CPP v4 XML, as Groot2 saves it
  (:func:`pirate_bt.interop.btcpp.import_xml`).

The tree file is checked with the tree loader, against the robot (``--robot
FILE``, default the bundled one: its limits, units and node types), before it is
written; anything that cannot be converted or that the loader refuses is
reported at its ``file:line:column`` in the source file and nothing is written.
"""

from __future__ import annotations

import argparse
import importlib
from pathlib import Path

from pirate_bt.cli import STDOUT, check_output, said_path, write_to_stdout
from pirate_bt.errors import file_argument

__all__ = ["SOURCES", "configure", "run"]

# source -> (module, function, one-line help); the function takes
# (source_path, out_path, robot=FILE_OR_NONE) and returns the file written.
SOURCES: dict[str, tuple[str, str, str]] = {
    "btcpp": (
        "pirate_bt.interop.btcpp",
        "import_xml",
        "BehaviorTree.CPP v4 XML (as Groot2 saves it)",
    ),
}


def configure(parser: argparse.ArgumentParser) -> None:
    subs = parser.add_subparsers(dest="source", required=True, metavar="SOURCE")
    for name, (_module, _function, text) in SOURCES.items():
        sub = subs.add_parser(name, help=text, description=text)
        sub.add_argument("file", type=Path, help="file to read")
        sub.add_argument(
            "-o", "--output", required=True, help="tree file (.yaml; '-': standard output)"
        )
        sub.add_argument(
            "--robot",
            metavar="FILE",
            help="robot description the tree must fit (default: bundled)",
        )


def run(args: argparse.Namespace) -> int:
    # named as this command names it ("file"), not as the Python function does
    file_argument(args.file, "file")
    module_name, function, _text = SOURCES[args.source]
    convert = getattr(importlib.import_module(module_name), function)
    if args.output == STDOUT:  # the tree only, checked as for a file; no "wrote" line
        name = f"{Path(args.file).stem or 'tree'}.yaml"
        write_to_stdout(lambda out: convert(args.file, out, robot=args.robot), name)
        return 0
    check_output(args.output)
    written = convert(args.file, args.output, robot=args.robot)
    print(f"wrote {said_path(written)}")
    return 0
