"""Draw a behaviour tree with Graphviz, optionally coloured by status at one tick.

Building the graph (:func:`tree_graph`, returns ``dot`` source) and writing it
(:func:`render_tree`, which uses :func:`write_diagram`) are two functions, as in
``py_trees.display``. Node kinds are told apart by shape, as in py_trees' own
drawings, so a diagram printed in black and white still reads:

========== ==================== ======================================
kind       shape                examples
========== ==================== ======================================
composite  box (sequence),      Sequence, Selector, Parallel
           octagon (selector),
           parallelogram
decorator  ellipse              Retry, Inverter
guard      house, bold border   Timeout, link-healthy and clamped guards
leaf       rounded box          clamp, drive, bend, rotate, conditions
========== ==================== ======================================

Without statuses, kinds are also filled in soft colours; with statuses (from a
trace), the fill is the status: green SUCCESS, red FAILURE, amber RUNNING,
white not ticked. Each node's parameters are listed under its name, and the
Graphviz node id is the trace's path id (``0.1.2``), which SVG output keeps as
the ``id`` of the node's group.

Both functions take a tree as users have it: a tree file (loaded offline and
checked against the bundled robot, parameters not given taking their declared
examples as in ``pirate-bt render``), a
:class:`~pirate_bt.treefile.LoadedTree`, a py_trees ``BehaviourTree`` or root
behaviour, a :class:`~pirate_bt.trace.TreeStructure`, or a trace (a file or a
:class:`~pirate_bt.trace.Trace`, whose header holds the tree). ``trace=`` and
``tick=`` colour it by status at a tick::

    render_tree("trees/straight.yaml", "straight.svg")
    render_tree("trees/straight.yaml", "tick50.svg", trace="run.jsonl", tick=50)
    render_tree(load_tree("trees/bend.yaml", use_examples=True), "bend.png")  # treefile
"""

from __future__ import annotations

import operator
import os
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import py_trees

from pirate_bt.errors import (
    MAX_PATH,
    ArgumentTypeError,
    ArgumentValueError,
    ConfigurationError,
    InputError,
    file_argument,
    output_argument,
    shown,
)
from pirate_bt.render.files import DIAGRAM_SUFFIXES, write_diagram
from pirate_bt.render.labels import (
    COVERAGE_BANDS,
    MAX_NAME_CHARS,
    STATUS_FILL,
    STATUS_WORD,
    attrs_text,
    band,
    cut,
    label,
    quoted,
)
from pirate_bt.trace.coverage import Coverage, NodeCoverage
from pirate_bt.trace.formats import suffix_of
from pirate_bt.trace.reader import READERS, Trace, read_trace
from pirate_bt.trace.structure import TreeStructure, tree_structure

if TYPE_CHECKING:
    from typing import TypeAlias

    from pirate_bt.robot.description import RobotDescription
    from pirate_bt.treefile.spec import LoadedTree

    TreeSource: TypeAlias = (
        str
        | Path
        | LoadedTree
        | py_trees.trees.BehaviourTree
        | py_trees.behaviour.Behaviour
        | TreeStructure
        | Trace
    )
    """What :func:`render_tree` and :func:`tree_graph` draw (see the module docstring)."""

__all__ = [
    "COVERAGE_BANDS",
    "KIND_STYLE",
    "STATUS_FILL",
    "render_tree",
    "tree_graph",
    "write_diagram",
]


#: kind -> Graphviz node attributes.
KIND_STYLE: Mapping[str, Mapping[str, str]] = {
    "composite": {"shape": "box", "fillcolor": "#fed7aa"},
    "decorator": {"shape": "ellipse", "fillcolor": "#e9d5ff"},
    "guard": {"shape": "house", "fillcolor": "#fecaca", "penwidth": "2"},
    "leaf": {"shape": "box", "style": "rounded,filled", "fillcolor": "#e5e7eb"},
}
_COMPOSITE_SHAPE = {"Selector": "octagon", "Parallel": "parallelogram"}


def _is_trace_file(path: str | Path) -> bool:
    if Path(path).name.lower().endswith((".yaml", ".yml")):
        return False
    try:
        suffix_of(path, READERS)
    except (InputError, ConfigurationError):
        return False
    return True


def _load_tree_file(
    path: str | Path,
    params: Mapping[str, Any] | None,
    robot: RobotDescription | str | Path | None,
) -> LoadedTree:
    """A tree file loaded offline, as ``pirate-bt render`` does (parameters not given
    take the tree's declared examples), checked against ``robot`` (default: bundled)."""
    from pirate_bt.resources import find_file
    from pirate_bt.robot.description import RobotDescription
    from pirate_bt.robot.loader import load_robot
    from pirate_bt.treefile import load_tree

    try:
        found = find_file("trees", path)
        if not found.exists() and not found.suffix:
            with_suffix = find_file("trees", f"{path}.yaml")
            found = with_suffix if with_suffix.exists() else found
    except OSError:  # a name the system refuses (a part too long): load_tree says so
        found = Path(path)
    description = robot if isinstance(robot, RobotDescription) else load_robot(robot)
    given = dict(params or {})
    return load_tree(
        found,
        robot=description,
        params=given,
        params_from_text=bool(given) and all(isinstance(v, str) for v in given.values()),
        use_examples=True,
    )


def _mapping(value: object, option: str, what: str) -> None:
    if value is not None and not isinstance(value, Mapping):
        raise ArgumentTypeError(f"{option}: give {what} or None, not {shown(value)}")


def _check_arguments(
    title: object,
    trace: object,
    tick: object,
    params: object,
    robot: object,
    coverage: object,
    status: object,
    feedback: object,
) -> None:
    """Refuse an argument of :func:`tree_graph` of the wrong type, before anything loads.

    Raises:
        ArgumentTypeError: an argument of the wrong type, named.
        ArgumentValueError: a title too long, a name that is no file name.
    """
    from pirate_bt.robot.description import RobotDescription

    if title is not None:
        if not isinstance(title, str):
            raise ArgumentTypeError(f"title: give text or None, not {shown(title)}")
        if len(title) > MAX_PATH:
            raise ArgumentValueError(
                f"title: {len(title)} characters is too long a caption (at most {MAX_PATH})"
            )
    if trace is not None and not isinstance(trace, Trace):
        file_argument(trace, "trace")
    if tick is not None:
        # a whole number as Trace.frame_at takes one (Trace.tick_number): anything with
        # __index__ but a bool, so numpy.int64(3) too (it was refused here, taken there)
        try:
            whole = not isinstance(tick, bool) and isinstance(operator.index(tick), int)  # type: ignore[arg-type]
        except Exception:  # no __index__, or its own raises
            whole = False
        if not whole:
            raise ArgumentTypeError(
                f"tick: give a tick's number (a whole number), not {shown(tick)}"
            )
    _mapping(params, "params", "a mapping of parameter names to values")
    for key in params or {}:  # type: ignore[attr-defined]
        if not isinstance(key, str):
            raise ArgumentTypeError(f"params: a parameter's name is text, not {shown(key)}")
    if robot is not None and not isinstance(robot, RobotDescription):
        if not isinstance(robot, str | Path):
            raise ArgumentTypeError(
                "robot: give a robot description file, a RobotDescription or None (the"
                f" bundled robot), not {shown(robot)}"
            )
        file_argument(robot, "robot")
    if coverage is not None and not isinstance(coverage, Coverage):
        raise ArgumentTypeError(
            f"coverage: give a Coverage (result.coverage) or None, not {shown(coverage)}"
        )
    _mapping(status, "status", "a mapping of node ids to status codes")
    _mapping(feedback, "feedback", "a mapping of node ids to messages")


def _output(out: object) -> Path:
    """``out`` checked: a file name with a suffix that can be drawn, not a folder.

    Raises:
        ArgumentTypeError: not a file name.
        ArgumentValueError: an unknown suffix, a folder, or a file on the way.
    """
    path = output_argument(out, "out")  # a folder first: its name is no suffix to blame
    if path.suffix.lower() not in DIAGRAM_SUFFIXES:
        raise ArgumentValueError(f"out: cannot draw to {shown(path.name)}: use .dot, .svg or .png")
    return path


def _structure_and_trace(
    tree: TreeSource,
    params: Mapping[str, Any] | None,
    robot: RobotDescription | str | Path | None,
) -> tuple[TreeStructure, Trace | None]:
    """The structure to draw, and the trace ``tree`` itself is (if it is one)."""
    from pirate_bt.treefile.spec import LoadedTree

    if isinstance(tree, str | Path):
        tree = _read_source(tree, params, robot)
    if isinstance(tree, Trace):
        return tree.structure, tree
    if isinstance(tree, TreeStructure):
        return tree, None
    if isinstance(tree, LoadedTree):
        return tree_structure(tree.root, name=tree.name), None
    if isinstance(tree, py_trees.trees.BehaviourTree | py_trees.behaviour.Behaviour):
        return tree_structure(tree), None
    raise ArgumentTypeError(
        "tree: render_tree draws a tree file path, a LoadedTree, a py_trees BehaviourTree"
        f" or Behaviour, a TreeStructure or a Trace, not {type(tree).__name__}"
    )


def _read_source(
    tree: str | Path,
    params: Mapping[str, Any] | None,
    robot: RobotDescription | str | Path | None,
) -> Trace | LoadedTree:
    """The trace or the tree file named ``tree``, read."""
    path = file_argument(tree, "tree")
    return read_trace(path) if _is_trace_file(path) else _load_tree_file(path, params, robot)


def _refuse_overwriting(target: Path, tree: object, trace: object) -> None:
    """Refuse to draw over a file being drawn: a tree file named ``tree.dot`` drawn to
    ``tree.svg`` (the ``.dot`` is written beside it), or an output that is a link to it.

    Raises:
        ArgumentValueError: a file written would replace a file read.
    """
    from pirate_bt.treefile.spec import LoadedTree

    read: list[Path] = []
    if isinstance(tree, LoadedTree):
        read += [Path(f) for f in tree.files]
    if isinstance(tree, Trace):
        read.append(Path(tree.path))
    if isinstance(trace, Trace):
        read.append(Path(trace.path))
    elif isinstance(trace, str | Path):
        read.append(Path(trace))
    written = [target] if target.suffix.lower() == ".dot" else [target.with_suffix(".dot"), target]
    for out in written:
        for source in read:
            try:
                same = out.exists() and os.path.samefile(out, source)
            except (OSError, ValueError):  # a name the system refuses: said when written
                same = False
            if same:
                raise ArgumentValueError(
                    f"out: writing {shown(str(out), MAX_PATH)} would replace"
                    f" {shown(str(source), MAX_PATH)}, a file being drawn; nothing written"
                )


def _check_trace_fits(structure: TreeStructure, trace: Trace) -> None:
    for node in structure:
        recorded = trace.structure.node(node.id).name if node.id in trace.structure else None
        if recorded != node.name:  # each name cut (a 10 kB one was said whole); '' is a name
            was = "missing" if recorded is None else shown(recorded, 100)
            raise InputError(
                f"{trace.path} is not a trace of tree {shown(structure.name, 100)}: node"
                f" {shown(node.id, 60)} is {shown(node.name, 100)} in the tree but {was}"
                " in the trace"
            )


def _coverage_by_node(
    structure: TreeStructure, coverage: Coverage | None
) -> dict[str, NodeCoverage]:
    """The coverage of each node of ``structure``, by path id (or by name path).

    Raises:
        InputError: a coverage of another tree.
    """
    if coverage is None:
        return {}
    ids = coverage.by_id()
    if ids and all(n.id in ids for n in structure):
        return ids
    from pirate_bt.trace.coverage import name_paths

    nodes = list(structure)
    index = {n.id: i for i, n in enumerate(nodes)}
    paths = name_paths([n.name for n in nodes], [index.get(n.parent or "", -1) for n in nodes])
    by_path = {n.path: n for n in coverage}
    found = {n.id: by_path[p] for n, p in zip(nodes, paths, strict=True) if p in by_path}
    if not found:
        raise InputError(
            f"the coverage of tree {coverage.tree!r} has no node of {structure.name!r}"
        )
    return found


def tree_graph(
    tree: TreeSource,
    status: Mapping[str, str] | None = None,
    feedback: Mapping[str, str] | None = None,
    title: str | None = None,
    *,
    trace: str | Path | Trace | None = None,
    tick: int | None = None,
    params: Mapping[str, Any] | None = None,
    robot: RobotDescription | str | Path | None = None,
    coverage: Coverage | None = None,
) -> str:
    """Graphviz ``dot`` source of a tree.

    Args:
        tree: What to draw: a tree file path (or a bundled tree's name, such
            as ``"bend"``), loaded offline (no link, no simulator) and drawn as
            ``pirate-bt render`` draws it; a ``LoadedTree``; a ``BehaviourTree``
            or its root behaviour; a ``TreeStructure``; or a trace (a path or a
            ``Trace``), whose header holds the tree.
        status: Status code (``S``/``F``/``R``/``I``) by node id, to colour by
            status; ``None`` colours by kind (or by ``trace``).
        feedback: Feedback message by node id, shown with the status.
        title: A caption; with ``trace`` it defaults to ``tick N at T s``.
        trace: A trace of this tree (a path or a ``Trace``): colour each node by
            its status at ``tick``, and show its feedback message.
        tick: The tick of ``trace`` (or of ``tree``, when it is a trace) to
            colour by; default: the last tick when ``trace`` is given.
        params: The tree file's parameters (strings are read as on the command
            line, ``{"distance": "0.5 m"}``); parameters not given take the
            tree's declared examples. Only for a tree file.
        robot: The robot description (or its file) a tree file is checked
            against; default: the bundled robot.
        coverage: A run's (or a campaign's) :class:`~pirate_bt.trace.coverage.Coverage`
            of this tree (``result.coverage``, ``read_trace(path).coverage``): fill
            each node by its band of tick counts (:data:`COVERAGE_BANDS`, white for
            a node that never ran) and list its ticks, successes and failures.
            Not with statuses.

    Returns:
        The ``dot`` source.

    Raises:
        InputError: ``tick`` without a trace, a tick the trace does not have, or
            a trace of another tree; an argument of the wrong type
            (:class:`~pirate_bt.errors.ArgumentTypeError`, also a ``TypeError``) or
            a name that is no file name, each named.
        ArgumentValueError: ``status`` or ``feedback`` given together with ``trace``
            (an ``InputError`` and a ``ValueError``).
        ValidationFailed: the tree file does not validate.

    Example::

        source = tree_graph("trees/straight.yaml", trace="run.jsonl", tick=50)
    """
    _check_arguments(title, trace, tick, params, robot, coverage, status, feedback)
    if trace is not None and (status is not None or feedback is not None):
        raise ArgumentValueError("give status and feedback, or a trace to take them from, not both")
    if coverage is not None and (status is not None or trace is not None or tick is not None):
        raise ArgumentValueError("colour by coverage or by status, not both")
    structure, own_trace = _structure_and_trace(tree, params, robot)
    run = read_trace(trace) if isinstance(trace, str | Path) else trace
    if run is not None:
        _check_trace_fits(structure, run)
    elif tick is not None:
        if own_trace is None:
            raise InputError("tick needs a trace: pass trace=..., or a trace as the tree")
        run = own_trace
    if run is not None:
        frame = run.frame_at(run.last_tick if tick is None else tick)
        status, feedback = frame.status, frame.feedback
        if title is None:
            title = f"tick {frame.n} at {frame.t_s:.3f} s"
    feedback = feedback or {}
    seen = _coverage_by_node(structure, coverage)
    if coverage is not None and title is None:
        title = f"coverage: {coverage.summary()} (white: never ran; darker: more ticks)"
    named = cut(structure.name, MAX_NAME_CHARS)
    caption = named if title is None else f"{named}: {title}"
    lines = [
        "digraph tree {",
        "  graph [rankdir=TB, ordering=out, nodesep=0.25, ranksep=0.45,"
        f' fontname=Helvetica, labelloc=t, label="{quoted(caption)}"];',
        '  node [fontname=Helvetica, fontsize=10, style=filled, margin="0.12,0.04"];',
        "  edge [arrowsize=0.6];",
    ]
    for node in structure:
        attrs = dict(KIND_STYLE.get(node.kind, KIND_STYLE["leaf"]))
        if node.kind == "composite":
            attrs["shape"] = _COMPOSITE_SHAPE.get(node.type, attrs["shape"])
        code = None if status is None else status.get(node.id, "I")
        counted = seen.get(node.id) if coverage is not None else None
        if code is not None:
            attrs["fillcolor"] = STATUS_FILL.get(code, STATUS_FILL["I"])
            attrs["tooltip"] = f"{node.id} {STATUS_WORD.get(code, code)}"
        elif coverage is not None:
            ticks = counted.ticks if counted is not None else 0
            _, colour, words = band(ticks)
            attrs["fillcolor"] = colour
            attrs["tooltip"] = f"{node.id} {words}"
            if ticks >= 100:
                attrs["fontcolor"] = "white"
            if not ticks:
                attrs["style"] = attrs.get("style", "filled") + ",dashed"
        else:
            attrs["tooltip"] = f"{node.id} {node.kind}"
        attrs["id"] = node.id
        attrs["label"] = label(node, code, feedback.get(node.id, ""), counted)
        lines.append(f'  "{quoted(node.id)}" [{attrs_text(attrs)}];')
    for node in structure:
        for child in node.children:
            lines.append(f'  "{quoted(node.id)}" -> "{quoted(child)}";')
    lines.append("}")
    return "\n".join(lines) + "\n"


def render_tree(
    tree: TreeSource,
    out: str | Path,
    status: Mapping[str, str] | None = None,
    feedback: Mapping[str, str] | None = None,
    title: str | None = None,
    *,
    trace: str | Path | Trace | None = None,
    tick: int | None = None,
    params: Mapping[str, Any] | None = None,
    robot: RobotDescription | str | Path | None = None,
    coverage: Coverage | None = None,
) -> Path:
    """Draw a tree to ``out`` (``.dot``, ``.svg`` or ``.png`` by suffix).

    ``tree`` is a tree file path, a ``LoadedTree``, a ``BehaviourTree`` or root
    behaviour, a ``TreeStructure`` or a trace; ``trace`` and ``tick`` colour it
    by status at that tick; ``coverage`` by how often each node ran. Every argument
    is as in :func:`tree_graph`.

    Example::

        render_tree("trees/straight.yaml", "straight.svg", params={"distance": "1 m"})
        render_tree("bend", "tick120.svg", trace="bend.jsonl", tick=120)  # by status
        mission = pirate_bt.simulate_mission("lab.route")
        render_tree(mission.tree, "coverage.svg", coverage=mission.coverage)  # by count
        # a tree run: RunResult.tree is the tree's name; give the tree itself
        render_tree("trees/straight.yaml", "cov.svg", coverage=result.coverage)

    Returns:
        The path written (the ``.dot`` file if Graphviz was not needed).

    Raises:
        FileNotFoundError: Graphviz ``dot`` is missing; the ``.dot`` file was
            written beside ``out`` all the same (its ``filename`` is ``None``).
        ArgumentValueError: ``out`` has an unsupported suffix, is a folder or has a
            file on its way (an ``InputError`` and a ``ValueError``).
        InputError: ``out`` cannot be written (no permission, a name the system
            refuses); see also :func:`tree_graph`.
    """
    target = _output(out)
    _check_arguments(title, trace, tick, params, robot, coverage, status, feedback)
    if isinstance(tree, str | Path):  # read here, to know which files it reads
        tree = _read_source(tree, params, robot)
    _refuse_overwriting(target, tree, trace)
    source = tree_graph(
        tree,
        status,
        feedback,
        title,
        trace=trace,
        tick=tick,
        params=params,
        robot=robot,
        coverage=coverage,
    )
    try:
        return write_diagram(source, target)
    except OSError as exc:
        if exc.filename is None:  # Graphviz is missing: documented, kept
            raise
        failed = str(target)
        if isinstance(exc.filename, str) and Path(exc.filename) != target:
            # the .dot written beside the picture (a folder of that name, a full disk)
            failed = f"{shown(exc.filename, MAX_PATH)} beside {shown(failed, MAX_PATH)}"
        else:
            failed = shown(failed, MAX_PATH)
        raise InputError(f"out: cannot write {failed}: {exc.strerror or exc}") from None
