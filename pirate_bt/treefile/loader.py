"""Load a YAML behaviour tree, check it, and build the py_trees tree.

Loading runs in three steps, so that every problem in a file is reported at
once, each at ``file:line:column``:

1. **Read** every file the tree uses (the tree file and the files its subtrees
   name), substitute parameters, and turn each node into a :class:`NodeSpec`:
   its class from the registry, its parameters validated by the class's pydantic
   model and checked against the robot's limits.
2. **Check** the whole spec tree: duplicate sibling names, blackboard keys read
   but never written (or not declared), and children that can never run (a
   warning). The blackboard checks run whenever every node could be read, even
   when step 1 found problems elsewhere (a bad tree name, a duplicate name, a
   refused blackboard declaration, whose key is then not checked); the warnings only
   for a tree without problems. Within step 1 too, a problem stops only what depends
   on it (a refused parameter ``default``: the nodes that use it; a number YAML
   refused, :mod:`pirate_bt.treefile.refused`: what it is in), and the problems are
   reported in file order, without repeats.
3. **Build** the behaviours with each class's ``from_params``; nothing touches
   hardware here (behaviours acquire it in ``setup()``). ``from_params`` checks
   its parameters again (it does so for nodes built in Python); after step 1
   that finds nothing, so a file's messages are only those of step 1.

The format is described in ``docs/trees.md``.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import py_trees

from pirate_bt.behaviours.base import BuildContext
from pirate_bt.behaviours.composites import Selector, Sequence
from pirate_bt.clock import Clock, WallClock
from pirate_bt.errors import (
    LocatedError,
    SourceLocation,
    ValidationFailed,
    caller_location,
    file_argument,
)
from pirate_bt.robot.description import RobotDescription
from pirate_bt.treefile.checks import _check_blackboard, _check_conditions, _outcomes
from pirate_bt.treefile.header import misspelt
from pirate_bt.treefile.params import COMMAND_LINE, given_location
from pirate_bt.treefile.reader import _Env, _Reader
from pirate_bt.treefile.refused import read_tree_yaml, shows_blank
from pirate_bt.treefile.registry import Registry, default_registry
from pirate_bt.treefile.spec import (
    _TOP_KEYS,
    COMPOSITES,
    BlackboardDecl,
    LoadedTree,
    NodeSpec,
    PathKey,
)
from pirate_bt.yamlfile import Locator, YamlDocument, check_depth
from pirate_bt.yamlvalidate import unique_errors

__all__ = [
    "COMPOSITES",
    "BlackboardDecl",
    "LoadedTree",
    "NodeSpec",
    "PathKey",
    "build",
    "load_tree",
    "validate_tree_file",
]

_log = logging.getLogger("pirate_bt.treefile")


# -- building -----------------------------------------------------------------------------


def build(spec: NodeSpec, context: BuildContext) -> py_trees.behaviour.Behaviour:
    """Build the behaviour of a validated spec tree (no hardware is touched).

    Raises:
        ValueError: a node's ``from_params`` refused its parameters.
    """
    if spec.cls is not None:
        child = build(spec.children[0], context) if spec.children else None
        return spec.cls.from_params(spec.name, spec.params, context, child)
    children = [build(c, context) for c in spec.children]
    if spec.node_type == "sequence":
        return Sequence(spec.name, spec.params["memory"], children)
    if spec.node_type == "selector":
        return Selector(spec.name, spec.params["memory"], children)
    if spec.node_type == "eternal_guard":
        conditions = [build(c, context) for c in spec.conditions]
        return Sequence(spec.name, False, [*conditions, *children])
    policy: py_trees.common.ParallelPolicy.Base
    if spec.params["policy"] == "one":
        policy = py_trees.common.ParallelPolicy.SuccessOnOne()
    elif spec.params["policy"] == "all":
        policy = py_trees.common.ParallelPolicy.SuccessOnAll(spec.params["synchronise"])
    else:
        chosen = [c for c in children if c.name in spec.params["selected"]]
        policy = py_trees.common.ParallelPolicy.SuccessOnSelected(
            chosen, spec.params["synchronise"]
        )
    return py_trees.composites.Parallel(spec.name, policy, children)


# -- public API ------------------------------------------------------------------------------


TRACE_SUFFIXES = (".jsonl", ".ndjson", ".jsonl.gz", ".mcap", ".btlog")
"""Names of trace files (:mod:`pirate_bt.trace`'s formats, BehaviorTree.CPP's log): a
file of such a name that is no YAML is named as a trace, not as YAML that does not
parse (a YAML tree of such a name still loads)."""


def load_tree(
    source: str | Path | Mapping[str, Any],
    *,
    robot: RobotDescription | None = None,
    params: Mapping[str, Any] | None = None,
    params_from_text: bool = False,
    clock: Clock | None = None,
    supervisor: Any = None,
    registry: Registry | None = None,
    units_required: bool | None = None,
    use_examples: bool = False,
    params_origin: str | SourceLocation | None = None,
) -> LoadedTree:
    """Load, check and build a behaviour tree.

    Args:
        source: A tree file, or the same structure as a mapping (planner code).
        robot: The robot description; parameters are checked against its limits.
            ``None`` skips the limit checks.
        params: Values for the tree's declared parameters (numbers are SI unless
            ``params_from_text``).
        params_from_text: ``params`` are command-line texts (``{"roll": "90 deg"}``).
        clock: The clock behaviours read (default: the wall clock).
        supervisor: The safety supervisor, handed to nodes that command the robot.
        registry: Node types allowed (default: :func:`default_registry`).
        units_required: Refuse bare numbers for quantities; default true for files
            and false for mappings (where numbers are SI).
        use_examples: A parameter given no value and with no default takes its
            declared ``example`` (for checking and drawing a tree, never running it).
        params_origin: Where ``params`` came from, for their errors' locations: a
            pseudo-file name (``"--param"``, the command line's, places each value's
            problem at the option as typed: ``--param roll=9mm: ...``) or a
            :class:`~pirate_bt.errors.SourceLocation`.
            Default: the caller's file and line when ``load_tree`` is called, directly
            or through :mod:`pirate_bt.api`, from code outside ``pirate_bt``
            (``planner.py:12:1: parameter 'roll': ...``); else ``--param`` (the
            library's own commands).

    Returns:
        The built tree with its warnings (also logged).

    Raises:
        InputError: ``source`` is a name but no file name (empty, a NUL, bytes, more
            than 4096 characters: :func:`~pirate_bt.errors.file_argument`).
        ValidationFailed: every problem found, each at ``file:line:column``; a ``.xml``
            file (a BehaviorTree.CPP tree: :func:`pirate_bt.load_xml_tree` reads it), at 1:1.
    """
    reg = registry or default_registry()
    refused: list[LocatedError] = []
    if isinstance(source, Mapping):
        check_depth(source, "<dict>")
        doc = YamlDocument(dict(source), Locator("<dict>"))
        base_dir = Path.cwd()
        strict = False if units_required is None else units_required
    elif isinstance(source, str | os.PathLike):
        path = file_argument(source, "source")
        if path.suffix.lower() == ".xml":  # read as YAML, it fails with a syntax error
            raise ValidationFailed(
                [
                    LocatedError(
                        "a BehaviorTree.CPP XML tree, not a YAML tree file: read it with"
                        " pirate_bt.load_xml_tree (pirate-bt run, validate and render read it"
                        " as it is)",
                        SourceLocation(str(path)),
                    )
                ]
            )
        try:
            doc, refused = read_tree_yaml(path)  # a number YAML refused: the rest is read
        except OSError as exc:  # a name the system refuses (a part longer than 255 bytes)
            where = SourceLocation(str(path))
            raise ValidationFailed([LocatedError(f"cannot read: {exc.strerror}", where)]) from None
        except ValidationFailed:
            # a trace read as YAML: a syntax error at its second line, or "binary file"
            if path.name.lower().endswith(TRACE_SUFFIXES):
                said = (
                    "a trace, not a behaviour tree file: read it with pirate-bt trace"
                    " summary (or show, plot) and pirate_bt.read_trace"
                )
                raise ValidationFailed([LocatedError(said, SourceLocation(str(path)))]) from None
            raise
        base_dir = path.parent
        strict = True if units_required is None else units_required
    else:
        raise ValidationFailed(
            [
                LocatedError(
                    f"a tree is a mapping with a 'root' key or a file's path,"
                    f" not {type(source).__name__}",
                    caller_location(skip=Path(__file__).parent.parent) or SourceLocation("<dict>"),
                )
            ]
        )
    reader = _Reader(reg, robot, strict, base_dir)
    reader.refused(doc, refused)
    # Each check that does not depend on an earlier one runs even when that one found
    # problems (a parameter's refused default, a bad tree name, a duplicate node name),
    # so that every problem of the file is said at once; a check that depends on what
    # was refused is skipped (never the same mistake twice).
    if not reader.header(doc):
        raise ValidationFailed(reader.errors)
    if doc.file != "<dict>":
        reader.docs[str(Path(doc.file).resolve())] = doc
    data: dict[str, Any] = doc.data
    params_misspelt = misspelt(data, "params", _TOP_KEYS)
    declared = reader.declared_params(doc, ("params",), data.get("params"), params_misspelt)
    given = dict(params or {})
    given_loc = _params_location(params_origin) if given else COMMAND_LINE

    def given_at(name: str) -> SourceLocation:
        return given_location(given_loc, name, given[name])  # --param d=1e999s, as typed

    values, unknown = reader.bind(
        doc, ("params",), declared, given, given_at, params_from_text, use_examples
    )
    caller = {name: (name, given_at(name)) for name in given}
    env = _Env(doc, values, (doc.file,), caller, unknown=unknown, declared=declared.names)
    # None when a node could not be read: the checks of the whole tree need every node
    spec = reader.tree(env, (), data)
    reader.check_unused(doc)  # the subtrees no call used: checked all the same
    if spec is not None:
        _check_blackboard(spec, reader.blackboard, reader.errors, reader.board_unsure)
        _check_conditions(spec, reader.errors)
    if spec is not None and not reader.errors:
        if not spec.explicit_name:
            name = data.get("name")
            spec.name = name if isinstance(name, str) and name else spec.name
        _outcomes(spec, reader.warnings)
    if reader.errors or spec is None:
        errors = reader.errors or [LocatedError("tree could not be read", SourceLocation(doc.file))]
        if reader.blanked:  # a check that met a value YAML refused (said) is no problem
            errors = [e for e in errors if not shows_blank(e.message)] or errors
        # what the caller gave first (a misspelt --param or a spec's params: the cause
        # of a parameter then left out), then the tree's file, then the others
        first = (given_loc.file, doc.file) if given else (doc.file,)
        raise ValidationFailed(_in_file_order(errors, *first))
    context = BuildContext(robot=robot, clock=clock or WallClock(), supervisor=supervisor)
    try:
        root = build(spec, context)
    except (ValueError, TypeError) as exc:
        raise ValidationFailed([LocatedError(f"cannot build: {exc}", spec.location)]) from None
    for warning in reader.warnings:
        _log.warning("%s", warning)
    name = data.get("name") if isinstance(data.get("name"), str) else None
    return LoadedTree(
        name=name or (Path(doc.file).stem if doc.file != "<dict>" else spec.name),
        root=root,
        spec=spec,
        params=values,
        blackboard={k: d for k, (d, _) in reader.blackboard.items()},
        warnings=reader.warnings,
        files=[doc.file, *(d.file for d in reader.docs.values() if d.file != doc.file)],
        needs_robot=any(s.cls is not None and s.cls.needs_robot for s in spec.walk()),
        source=source if isinstance(source, Mapping) else Path(source),
    )


def _in_file_order(errors: list[LocatedError], *first: str) -> list[LocatedError]:
    """``errors`` without repeats, each file's in the order of its lines and columns:
    the files ``first`` in that order (the caller's values, the tree's), then the
    others in the order their first problem was found (subtree files)."""
    unique = unique_errors(errors)
    rank: dict[str, int] = {name: i for i, name in enumerate(dict.fromkeys(first))}
    for error in unique:
        rank.setdefault(error.location.file, len(rank))
    return sorted(unique, key=lambda e: (rank[e.location.file], e.location.line, e.location.column))


def _params_location(origin: str | SourceLocation | None) -> SourceLocation:
    """Where the caller's ``params`` were written (see ``load_tree``'s ``params_origin``)."""
    if isinstance(origin, SourceLocation):
        return origin
    if origin is not None:
        return SourceLocation(origin)
    # Past the loader and the Python API (pirate_bt.api): a planner's own call, or
    # None when pirate_bt's own code (a command) called.
    package = Path(__file__).parent.parent
    return caller_location(skip=(package / "treefile", package / "api")) or SourceLocation(
        "--param"
    )


def validate_tree_file(path: str | Path, params: Mapping[str, str] | None = None) -> LoadedTree:
    """Validate a tree file against the default robot description (``pirate-bt validate``).

    Parameters without a default take ``params`` (command-line texts), else their
    declared ``example``.
    """
    from pirate_bt.robot.loader import load_robot

    return load_tree(
        path, robot=load_robot(), params=params, params_from_text=True, use_examples=True
    )
