"""Load a tree for a run: a tree file (YAML or BehaviorTree.CPP XML), a bundled name, a
mapping, or a tree already built, each checked against the robot before anything connects.

Split from :mod:`pirate_bt.api.running` (which re-exports what it had), which runs what
is loaded here.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import py_trees

from pirate_bt.api.options import find, flag, kind_of, params_mapping
from pirate_bt.errors import (
    InputError,
    LocatedError,
    SourceLocation,
    ValidationFailed,
    caller_location,
)

if TYPE_CHECKING:
    from pirate_bt.robot.description import RobotDescription
    from pirate_bt.treefile import LoadedTree

__all__ = ["LOAD_OPTIONS", "as_loaded", "find_tree", "load_tree", "load_tree_source"]


def as_loaded(
    tree: Any, robot: RobotDescription | None, params: Mapping[str, Any] | None = None
) -> Any:
    """A tree as the runner takes it: a checked ``LoadedTree``, or the behaviour itself.

    Args:
        tree: A path or bundled name, a mapping, a ``LoadedTree``, a behaviour or a
            ``BehaviourTree``.
        robot: The robot description the tree is checked against.
        params: The tree's parameters (YAML trees only): strings are read as on the
            command line (``"90 deg"``), numbers are SI.

    Raises:
        ValidationFailed: the tree or a parameter does not validate.
        InputError: parameters for a tree that is not YAML, or an unknown kind of tree.
    """
    from pirate_bt.treefile import LoadedTree

    params_mapping(params)
    if isinstance(tree, LoadedTree | py_trees.behaviour.Behaviour | py_trees.trees.BehaviourTree):
        if params:
            raise InputError(
                f"params: given for an already built tree ({type(tree).__name__});"
                " give them to load_tree, or pass the tree's file"
            )
        return tree
    if isinstance(tree, Mapping):
        source: Any = tree
    elif isinstance(tree, str | Path):
        source = find_tree(tree)
    else:
        raise InputError(
            f"tree: cannot run {kind_of(tree)}: give a tree file, a mapping, a"
            " LoadedTree or a py_trees behaviour"
        )
    given = params_mapping(params)
    # text is read as on the command line, numbers and booleans as they are, each by itself
    from_text = any(isinstance(v, str) for v in given.values())
    return _at_callers_line(
        source,
        lambda: load_tree_source(source, robot=robot, params=given, params_from_text=from_text),
    )


def find_tree(tree: str | Path, option: str = "tree") -> Path:
    """The tree file ``tree`` names: the path if something is there, else the bundled
    tree of that name (``"bend"`` → ``trees/bend.yaml``). What ``simulate_tree``,
    ``load_tree`` and ``pirate-bt run`` look a tree up with.

    Raises:
        InputError: ``tree`` is not a file name (named by ``option``).
        ValidationFailed: neither a file nor a bundled tree: one line,
            ``nosuch:1:1: no such tree file; bundled trees: bend, bend-back, ...``.
    """
    from pirate_bt.resources import bundled_names, missing

    path = find("trees", tree, ".yaml", option)
    if not missing(path):  # a file, or what the loader says it is (a folder, a device)
        return path
    names = ", ".join(bundled_names("trees"))
    message = f"no such tree file; bundled trees: {names}"
    raise ValidationFailed([LocatedError(message, SourceLocation(str(path)))])


def load_tree_source(
    source: str | Path | Mapping[str, Any],
    *,
    robot: RobotDescription | None,
    params: Mapping[str, Any] | None = None,
    params_from_text: bool = False,
    **options: Any,
) -> LoadedTree:
    """Load and check a tree file or mapping for a run: a ``.xml`` file as a
    BehaviorTree.CPP v4 tree (Groot2's; :func:`pirate_bt.interop.load_xml_tree`, each
    problem at its XML element), anything else as a YAML tree
    (:func:`pirate_bt.treefile.load_tree`). ``options`` go to either (``params_origin``,
    ``use_examples``). What ``simulate_tree``, ``pirate-bt run`` and ``pirate-bt
    validate`` load a tree with.
    """
    if isinstance(source, str | Path) and Path(source).suffix.lower() == ".xml":
        from pirate_bt.interop.btcpp_import_file import load_xml_tree

        return load_xml_tree(
            source, robot=robot, params=params, params_from_text=params_from_text, **options
        )
    from pirate_bt.treefile import load_tree

    return load_tree(
        source, robot=robot, params=params, params_from_text=params_from_text, **options
    )


def _at_callers_line(source: Any, load: Callable[[], LoadedTree]) -> LoadedTree:
    """``load()``; for a tree given as a mapping, its problems at the planner's line.

    The loader places them at ``<dict>:1:1`` (a mapping has no lines); the planner's
    own call is where the mapping was written (``planner.py:17:1: clamp: torque: ...``),
    as for parameters and nodes built in Python.
    """
    try:
        return load()
    except ValidationFailed as exc:
        if not isinstance(source, Mapping):
            raise
        package = Path(__file__).parent.parent
        where = caller_location(skip=(package / "treefile", package / "api"))
        if where is None:  # pirate_bt's own code gave it
            raise
        moved = [
            LocatedError(e.message, where) if e.location.file == "<dict>" else e for e in exc.errors
        ]
        raise ValidationFailed(moved) from None


LOAD_OPTIONS = ("registry", "use_examples", "clock", "supervisor")
"""The options :func:`load_tree` passes on to :func:`pirate_bt.treefile.load_tree`."""


def _load_options(options: Mapping[str, Any]) -> dict[str, Any]:
    """:func:`load_tree`'s ``**options``, each checked: one it does not pass on, or a
    value of another type, was taken on to a traceback from inside the loader (a
    ``registry`` of text), read as true (``use_examples="no"``) or kept unused.

    Raises:
        ArgumentTypeError: the first that is wrong, named.
    """
    from pirate_bt.errors import ArgumentTypeError, shown
    from pirate_bt.safety import Supervisor
    from pirate_bt.treefile import Registry

    for name, value in options.items():
        if name not in LOAD_OPTIONS:
            raise ArgumentTypeError(
                f"load_tree: no option {name!r}"[:100]
                + f"; it takes params, robot, check_robot, {', '.join(LOAD_OPTIONS)}"
            )
        if name == "use_examples":
            flag(value, name)
        elif value is None:
            continue
        elif name == "registry" and not isinstance(value, Registry):
            raise ArgumentTypeError(
                "registry: give a Registry (pirate_bt.treefile.default_registry(), with"
                f" your node types added) or None, not {shown(value)}"
            )
        elif name == "clock" and not callable(getattr(value, "now", None)):
            raise ArgumentTypeError(
                f"clock: give a clock (pirate_bt.clock.SimClock(), WallClock()) or None, not"
                f" {shown(value)}"
            )
        elif name == "supervisor" and not isinstance(value, Supervisor):
            raise ArgumentTypeError(
                "supervisor: give a Supervisor (a connection's robot.supervisor) or None,"
                f" not {shown(value)}"
            )
    return dict(options)


def load_tree(
    tree: Any,
    *,
    robot: Any = None,
    params: Mapping[str, Any] | None = None,
    check_robot: bool = True,
    **options: Any,
) -> LoadedTree:
    """Load and check a tree: a YAML tree (a file, a bundled name such as ``"bend"``, or
    a mapping) or a BehaviorTree.CPP v4 XML file (``.xml``, as
    :func:`pirate_bt.load_xml_tree` reads it, each problem at its XML element).

    Unlike :func:`pirate_bt.treefile.load_tree`, the tree is checked against the
    bundled robot when no ``robot`` is given (``check_robot=False`` skips the limit
    checks, for a tree of generic leaves drawn offline). Parameters are read as on
    the command line when they are strings (``{"roll": "90 deg"}``); numbers are SI.
    Build it on a robot with :meth:`Connection.run` or :func:`simulate_tree`.

    Args:
        tree: The tree.
        robot: The robot description (a loaded one, a file; default: bundled).
        params: The tree's parameters.
        check_robot: Check against the robot's limits.
        **options: Passed to :func:`pirate_bt.treefile.load_tree`: ``registry`` (a
            ``Registry``), ``use_examples`` (``True``/``False``), ``clock`` (a clock),
            ``supervisor`` (a ``Supervisor``), each or ``None``; no other.

    Returns:
        pirate_bt.treefile.LoadedTree: The checked tree (``root``, ``params``,
            ``needs_robot``, ``warnings``...).

    Raises:
        ValidationFailed: every problem, each at ``file:line:column``.
        ArgumentTypeError: an option it does not take, or one of another type.

    Example::

        tree = pirate_bt.load_tree("bend", params={"roll": "90 deg"})
        print(tree.name, tree.needs_robot)
    """
    from pirate_bt.api.options import load_robot_like

    description = load_robot_like(robot) if flag(check_robot, "check_robot") else None
    options = _load_options(options)
    if isinstance(tree, Mapping):
        source: Any = tree
    elif isinstance(tree, str | Path):
        source = find_tree(tree)
    else:
        raise InputError(
            f"tree: give a tree file, a bundled name or a mapping, not {kind_of(tree)}"
        )
    given = params_mapping(params)
    # text is read as on the command line, numbers and booleans as they are, each by itself
    from_text = any(isinstance(v, str) for v in given.values())
    return _at_callers_line(
        source,
        lambda: load_tree_source(
            source, robot=description, params=given, params_from_text=from_text, **options
        ),
    )
