"""``pirate-bt validate FILE...``: check files, one located line per problem."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pirate_bt.errors import LocatedError, PirateError, ValidationFailed
from pirate_bt.filekinds import KINDS, validate_file

__all__ = ["configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("files", nargs="+", metavar="FILE", help="files to check")
    parser.add_argument(
        "--kind",
        choices=sorted(KINDS),
        help="the kind of every file (default: detect from suffix and keys; a .xml file is"
        " a BehaviorTree.CPP v4 tree)",
    )
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a tree parameter, e.g. --param roll=90deg (repeatable; trees only; a parameter"
        " not given takes the tree's declared example)",
    )
    parser.add_argument("-q", "--quiet", action="store_true", help="print problems only")


def _tree_name(path: str, kind: str | None) -> str:
    """The file a tree's name means, as ``pirate-bt run`` reads it: with ``--kind tree``,
    or for a name with no suffix that is no file (``validate bend``), a bundled tree's
    when no file is there, else the API's error listing the bundled trees. Any other
    name is the path as given (``net.yaml`` may be any kind); ``""`` is no name (it was
    read as the working folder)."""
    from pirate_bt.api.running import find_tree
    from pirate_bt.resources import missing

    given = Path(path)
    if not path or kind == "tree" or (kind is None and not given.suffix and missing(given)):
        return str(find_tree(path, "FILE"))
    return path


def run(args: argparse.Namespace) -> int:
    from pirate_bt.cli.run import parse_params

    params = parse_params(args.param)
    worst = 0
    for path in args.files:
        try:
            path = _tree_name(path, args.kind)
            if args.kind in (None, "tree") and path.lower().endswith(".xml"):
                # BehaviorTree.CPP v4 XML (Groot2's): checked as `run` loads it
                from pirate_bt.api.running import load_tree_source

                load_tree_source(
                    path, robot=None, params=params, params_from_text=True, use_examples=True
                )
            else:
                validate_file(path, args.kind, params)
        except ValidationFailed as exc:
            for error in exc.errors:
                print(str(error), file=sys.stderr)
            worst = max(worst, exc.exit_code)
        except LocatedError as exc:
            print(str(exc), file=sys.stderr)
            worst = max(worst, exc.exit_code)
        except KeyError as exc:
            print(f"{path}: {exc.args[0]}", file=sys.stderr)
            worst = max(worst, 2)
        except PirateError as exc:
            text = str(exc)
            # name the file once: most messages already start with it
            named = not path or text.startswith(f"{path}:")
            print(text if named else f"{path}: {text}", file=sys.stderr)
            worst = max(worst, exc.exit_code)
        else:
            if not args.quiet:
                print(f"{path}: ok")
    return worst
