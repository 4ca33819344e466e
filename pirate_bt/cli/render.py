"""``pirate-bt render TREE -o OUT``: draw a tree, optionally coloured by a trace tick.

``TREE`` is a tree file (YAML), or a trace file, whose header holds the tree's
shape. With ``--trace T --tick N`` each node is filled by its status at tick N;
with ``--coverage`` by how often it ran in the trace's run (a band of tick counts;
white: never ran), the counts under its name.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pirate_bt.cli import as_option, check_output, said_path
from pirate_bt.errors import InputError, shown

__all__ = ["check_diagram", "configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("tree", type=Path, help="tree file (.yaml) or trace file (.jsonl)")
    parser.add_argument(
        "-o", "--output", type=Path, required=True, help="diagram (.dot, .svg or .png)"
    )
    parser.add_argument("--trace", type=Path, help="colour nodes by status from this trace")
    parser.add_argument("--tick", type=int, help="tick of --trace to show (default: the last)")
    parser.add_argument(
        "--coverage",
        action="store_true",
        help="colour nodes by how often they ran in the trace's run (needs a trace)",
    )
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a tree parameter, e.g. --param roll=90deg (repeatable; a parameter not given"
        " takes the tree's declared example)",
    )


def check_diagram(out: Path, option: str) -> None:
    """A diagram's output, named by its option, before any work: a file that can be
    written, a suffix that can be drawn (render_tree said ``out:``), and no folder where
    the ``.dot`` source goes beside a picture (``-o q.svg`` beside a folder ``q.dot``
    said ``out: cannot write 'q.dot'`` after the tree was read; ``robot --draw`` printed
    the board table first).

    Raises:
        InputError: any of them.
    """
    from pirate_bt.render.files import DIAGRAM_SUFFIXES

    check_output(out, option)
    if out.suffix.lower() not in DIAGRAM_SUFFIXES:
        raise InputError(f"{option}: cannot draw to {out.name!r}: use .dot, .svg or .png")
    beside = out.with_suffix(".dot")
    if beside != out and beside.is_dir():
        raise InputError(
            f"{option}: cannot write {beside.name!r} beside {out.name!r}, the diagram's"
            " source: it is a folder"
        )


def _is_trace(path: Path) -> bool:
    """A trace file by its suffix: any format a reader is registered for (``.mcap`` too)."""
    from pirate_bt.trace.formats import suffix_of
    from pirate_bt.trace.reader import READERS

    try:
        suffix_of(path, READERS)
    except InputError:
        return False
    return True


def run(args: argparse.Namespace) -> int:
    from pirate_bt.render.tree import render_tree
    from pirate_bt.trace.reader import Trace, read_trace
    from pirate_bt.trace.structure import TreeStructure, tree_structure
    from pirate_bt.treefile import LoadedTree

    if args.tick is not None and args.trace is None and not _is_trace(args.tree):
        raise InputError("--tick needs --trace (or a trace file as TREE)")
    if args.coverage and args.trace is None and not _is_trace(args.tree):
        raise InputError("--coverage needs --trace (or a trace file as TREE)")
    if args.coverage and args.tick is not None:
        raise InputError("--coverage colours by the whole run: leave out --tick")
    check_diagram(args.output, "-o")  # before the tree or trace is read
    trace: Trace | None = None
    structure: TreeStructure
    drawn: Trace | LoadedTree  # given to render_tree, which never draws over its files
    if _is_trace(args.tree):
        trace = drawn = read_trace(args.tree)
        structure = trace.structure
    else:
        from pirate_bt.api.running import find_tree, load_tree_source
        from pirate_bt.cli.run import parse_params

        # a .xml file as a BehaviorTree.CPP tree, as run and validate read it; a name
        # that is no file, a bundled tree's, else the API's error listing them
        drawn = load_tree_source(
            find_tree(args.tree),
            robot=None,
            params=parse_params(args.param),
            params_from_text=True,
            use_examples=True,
        )
        structure = tree_structure(drawn.root, name=drawn.name)
    if args.trace is not None:
        trace = read_trace(args.trace)
        for node in structure:
            recorded = trace.structure.node(node.id).name if node.id in trace.structure else None
            if recorded != node.name:  # names cut: a 10 kB one was said whole
                raise InputError(
                    f"{args.trace} is not a trace of {args.tree}: node {shown(node.id, 60)} is"
                    f" {shown(node.name, 100)} in the tree but"
                    f" {'missing' if recorded is None else shown(recorded, 100)} in the trace"
                )
    status = feedback = None
    title = None
    coverage = None
    if args.coverage:
        assert trace is not None
        coverage = trace.coverage
        if coverage is None:
            raise InputError(
                f"{args.trace or args.tree}: the trace has no coverage (cut off, or written"
                " before pirate_bt counted it)"
            )
    elif trace is not None and (args.trace is not None or args.tick is not None):
        tick = trace.last_tick if args.tick is None else args.tick
        frame = trace.frame_at(tick)
        status, feedback = frame.status, frame.feedback
        title = f"tick {frame.n} at {frame.t_s:.3f} s"
    try:
        written = render_tree(drawn, args.output, status, feedback, title, coverage=coverage)
    except FileNotFoundError as exc:
        if exc.filename is not None:  # a file that cannot be written, not a missing Graphviz
            raise
        print(f"pirate-bt: {exc}", file=sys.stderr)
        return 0
    except (ValueError, InputError) as exc:
        # a full disk said "out: cannot write 'q.dot': ...", render_tree's parameter
        as_option(exc, "out", "-o")
        raise InputError(str(exc)) from None
    print(f"drew {said_path(written)}")
    return 0
