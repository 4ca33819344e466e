"""``pirate-bt export TARGET ...``: write a tree in another tool's format.

Targets are rows of :data:`TARGETS` (name -> module, function, help), imported
only when chosen, so adding a format is one module and one row. Today:

- ``btcpp``: BehaviorTree.CPP v4 XML, which Groot2 opens
  (:func:`pirate_bt.interop.btcpp.export_xml`).

Traces are exported with ``pirate-bt trace export`` (``.btlog``, ``.mcap``).
"""

from __future__ import annotations

import argparse
import importlib
from pathlib import Path

from pirate_bt.cli import STDOUT, check_output, said_path, write_to_stdout

__all__ = ["TARGETS", "configure", "run"]

# target -> (module, function, one-line help); the function takes
# (tree_path, out_path, params) and returns the file written.
TARGETS: dict[str, tuple[str, str, str]] = {
    "btcpp": (
        "pirate_bt.interop.btcpp",
        "export_xml",
        "BehaviorTree.CPP v4 XML (Groot2 opens it)",
    ),
}


def configure(parser: argparse.ArgumentParser) -> None:
    subs = parser.add_subparsers(dest="target", required=True, metavar="TARGET")
    for name, (_module, _function, text) in TARGETS.items():
        sub = subs.add_parser(name, help=text, description=text)
        sub.add_argument("tree", type=Path, help="tree file (.yaml)")
        sub.add_argument(
            "-o", "--output", required=True, help="file to write ('-': standard output)"
        )
        sub.add_argument(
            "--param",
            action="append",
            default=[],
            metavar="KEY=VALUE",
            help="a tree parameter (repeatable); written as the main tree's port default."
            " A parameter not given takes its default, else its declared example",
        )


def run(args: argparse.Namespace) -> int:
    from pirate_bt.api.running import find_tree
    from pirate_bt.cli.run import parse_params

    module_name, function, _text = TARGETS[args.target]
    export = getattr(importlib.import_module(module_name), function)
    params = parse_params(args.param)
    if args.output == STDOUT:  # the text only, no "wrote" line
        tree = find_tree(args.tree)
        write_to_stdout(lambda out: export(tree, out, params), f"{tree.stem}.xml")
        return 0
    check_output(args.output)
    # a name that is no file: a bundled tree's, else the API's error listing them
    written = export(find_tree(args.tree), args.output, params)
    print(f"wrote {said_path(written)}")
    return 0
