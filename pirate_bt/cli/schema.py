"""``pirate-bt schema KIND``: print a file kind's JSON Schema."""

from __future__ import annotations

import argparse
import json

from pirate_bt.filekinds import KINDS, json_schema

__all__ = ["configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("kind", choices=sorted(KINDS), help="file kind")


def run(args: argparse.Namespace) -> int:
    from pirate_bt.cli import stdout_open

    stdout_open("the schema")  # >&-: it went nowhere, exit 0
    print(json.dumps(json_schema(args.kind), indent=2, sort_keys=True))
    return 0
