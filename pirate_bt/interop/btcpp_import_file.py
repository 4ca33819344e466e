"""BehaviorTree.CPP v4 XML import, the file: :func:`import_xml` writes the mapping that
:mod:`pirate_bt.interop.btcpp_import` reads from the XML as a tree file, loaded and
checked before it appears, each problem placed at the XML element it comes from.
Re-exported by :mod:`pirate_bt.interop.btcpp`.
"""

from __future__ import annotations

import bisect
import logging
import os
import re
import tempfile
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from pirate_bt.atomic import new_folders_undone
from pirate_bt.errors import (
    InputError,
    LocatedError,
    SourceLocation,
    ValidationFailed,
    bytes_escaped,
    file_argument,
)
from pirate_bt.interop.btcpp_export import _params_mapping
from pirate_bt.interop.btcpp_import import _read
from pirate_bt.interop.btcpp_xml import (
    caller_params_origin,
    cut_name,
    output_file,
    refuse_special,
)
from pirate_bt.treefile.registry import Registry, default_registry
from pirate_bt.yamlfile import HIDDEN_BREAK, plain_reads_as_number

if TYPE_CHECKING:
    from pirate_bt.robot.description import RobotDescription
    from pirate_bt.treefile import LoadedTree

__all__ = ["import_xml", "load_xml_tree"]


def _in_xml(
    errors: tuple[LocatedError, ...],
    yaml_file: Path,
    where: dict[tuple[str | int, ...], SourceLocation],
) -> list[LocatedError]:
    """The loader's errors about the converted YAML, each at the XML element it came
    from (the element of the node, subtree or parameter the YAML place is part of),
    each once: a main tree another tree calls is in the YAML twice, as its root and as
    a subtree, and its problems are found at the same elements twice."""
    place = _placer(yaml_file, where)
    placed = (place(error) for error in errors)
    return list({str(error): error for error in placed}.values())


def _placer(
    yaml_file: Path, where: dict[tuple[str | int, ...], SourceLocation]
) -> Callable[[LocatedError], LocatedError]:
    """What places one of the loader's errors or warnings about the converted YAML at
    its XML element (:func:`_in_xml`); the YAML is read once, here."""
    from pirate_bt.yamlfile import load_yaml

    try:
        marks = load_yaml(yaml_file).locator.marks
    except ValidationFailed:  # every place then falls back to the main tree's element
        marks = {}
    by_place: dict[tuple[int, int], tuple[str | int, ...]] = {}
    for key_path, place in marks.items():
        if len(key_path) >= len(by_place.get(place, ())):
            by_place[place] = key_path
    places = sorted(by_place)

    def in_xml(line: int, column: int) -> SourceLocation | None:
        # the last place at or before (line, column): a bisection, where a scan of every
        # place for each error took 40 s for 12,000 errors
        at = bisect.bisect_right(places, (line, column))
        path = by_place[places[at - 1]] if at else ()
        while path and path not in where:
            path = path[:-1]
        return where.get(path)

    # A message may name another place of the temporary file ("first at ...").
    mentioned = re.compile(re.escape(str(yaml_file)) + r":(\d+):(\d+)")

    def mention(match: re.Match[str]) -> str:
        target = in_xml(int(match[1]), int(match[2]))
        return str(target) if target is not None else match[0]

    converted = yaml_file.resolve()

    def placed(error: LocatedError) -> LocatedError:
        loc = error.location
        message = mentioned.sub(mention, error.message)
        if loc is None or Path(loc.file).resolve() != converted:
            return LocatedError(message, loc) if message != error.message else error
        target = in_xml(loc.line or 1, loc.column or 1)
        if message.startswith("name: ") and marks.get(("name",)) == (loc.line, loc.column):
            # the tree file's name is the main <BehaviorTree>'s ID (or its _name)
            message = f"<BehaviorTree> ID (the tree's name): {message.removeprefix('name: ')}"
        return LocatedError(message, target if target is not None else loc)

    return placed


_UNDECLARED = re.compile(
    r"(?P<head>blackboard key (?P<key>'[A-Za-z_][A-Za-z0-9_]*'|.+?) is (?:read|written)"
    r" but not declared)(?: under 'blackboard:')?$"
)
_TEXT_FOR_NUMBER = re.compile(
    r".*: value: '(?P<text>[^']*)' is text, but blackboard key .* is declared"
    r" .*\(text never equals a number and cannot be ordered with one\)(?P<tail>.*)$"
)
_UNKNOWN_POINTER = re.compile(
    r"unknown parameter \$(?P<name>[A-Za-z_][A-Za-z0-9_]*) \(parameters: (?P<known>.*)\)$"
)
"""The loader's word for a ``$x`` no tree declares: in the XML, a pointer ``{x}``."""
_DOLLARS = re.compile(r"(^|, )\$")
_JSON_NUMBER = re.compile(r"-?(?:0|[1-9][0-9]*)(?:\.[0-9]+)?(?:[eE][+-]?[0-9]+)?")


_VALUE_PORTS = ("check_blackboard: value: ", "set_blackboard: value: ")
"""Nodes whose compared ``value`` is a port of its own (``value="5"``)."""
_YAML_ADVICE = {  # the loader's advice in YAML's terms -> in the XML's
    "(text never equals it; quote it for text)": (
        "(text never equals it; for text, write the value without json:)"
    ),
    "(write true or false)": "(write json:true or json:false)",
}


def _in_xml_words(error: LocatedError, yaml_file: Path) -> LocatedError:
    """A loader's error about the converted YAML as an XML author reads it: ``{x}``
    names a port of the tree's ``<SubTree>`` model, not a ``$x``; a key is
    declared in a ``<BehaviorTree>``'s ``_blackboard`` attribute, not under
    ``blackboard:``; a value's kind is chosen with ``json:`` (``value="5"`` is text,
    ``value="json:5"`` a number), not with YAML's quotes."""
    message, loc = error.message, error.location
    pointer = _UNKNOWN_POINTER.match(message)
    if loc is None or (pointer is None and "blackboard key " not in message):
        return error
    if Path(loc.file).resolve() != yaml_file.resolve():
        return error  # another (YAML) file's: said in its words
    if pointer is not None:  # {x}: BT.CPP's pointer, the tree's parameter $x
        name, ports = pointer["name"], _DOLLARS.sub(r"\1", pointer["known"])
        return LocatedError(
            f"{{{name}}}: the <BehaviorTree> this node is in has no port {name!r}"
            f" (its ports: {ports}); declare it in that tree's <SubTree> model in"
            f' <TreeNodesModel>: <input_port name="{name}"/>',
            loc,
        )
    match = _UNDECLARED.match(message)
    if match is not None:
        key = match["key"][1:-1] if match["key"].startswith("'") else "k"
        said = (
            f"{match['head']} in a <BehaviorTree>'s _blackboard attribute"
            f""" (_blackboard='json:{{"{key}": {{"type": "number"}}}}', with the key's type)"""
        )
        return LocatedError(said, loc)
    if not message.startswith(_VALUE_PORTS):
        return error  # a guard's comparison is JSON in the XML: its value is JSON's
    match = _TEXT_FOR_NUMBER.match(message)
    if match is not None and not match["tail"]:
        written = match["text"] if _JSON_NUMBER.fullmatch(match["text"]) else "5"
        return LocatedError(f'{message[:-1]}; a number is written value="json:{written}")', loc)
    if match is not None:  # a quantity: "give 'unit: length' to compare a quantity"
        return LocatedError(re.sub(r"give 'unit: (\w+)'", r'give unit="\1"', message), loc)
    for yaml_words, xml_words in _YAML_ADVICE.items():
        if message.endswith(yaml_words):
            return LocatedError(message[: -len(yaml_words)] + xml_words, loc)
    return error


class _WarningsInXml(logging.Filter):
    """Places the tree loader's logged warnings about the converted YAML at their XML
    elements (they named the temporary file, gone once the call returns)."""

    def __init__(self, yaml_file: Path, where: dict[tuple[str | int, ...], SourceLocation]):
        super().__init__()
        self.yaml_file = yaml_file
        self.where = where
        self.place: Callable[[LocatedError], LocatedError] | None = None

    def placed(self, warning: LocatedError) -> LocatedError:
        if self.place is None:  # the YAML is read at the first warning, if there is one
            self.place = _placer(self.yaml_file, self.where)
        return self.place(warning)

    def filter(self, record: logging.LogRecord) -> bool:
        args = record.args
        if isinstance(args, tuple) and any(self._ours(a) for a in args):
            record.args = tuple(
                self.placed(a) if isinstance(a, LocatedError) and self._ours(a) else a for a in args
            )
        return True

    def _ours(self, arg: object) -> bool:
        """``arg`` is an error naming the converted file (not another thread's)."""
        return isinstance(arg, LocatedError) and str(self.yaml_file) in str(arg)


def _load_placed(
    yaml_file: Path, where: dict[tuple[str | int, ...], SourceLocation], **kwargs: Any
) -> LoadedTree:
    """:func:`pirate_bt.treefile.load_tree` of the converted ``yaml_file``, each error
    and warning (logged and kept) at its XML element.

    Raises:
        ValidationFailed: the tree does not load, each problem at its XML element.
    """
    from pirate_bt.treefile import load_tree

    logger = logging.getLogger("pirate_bt.treefile")
    placing = _WarningsInXml(yaml_file, where)
    logger.addFilter(placing)
    try:
        loaded = load_tree(yaml_file, **kwargs)
    except ValidationFailed as exc:
        errors = tuple(_in_xml_words(error, yaml_file) for error in exc.errors)
        raise ValidationFailed(_in_xml(errors, yaml_file, where)) from None
    finally:
        logger.removeFilter(placing)
    loaded.warnings = [placing.placed(warning) for warning in loaded.warnings]
    return loaded


class _Dumper(yaml.SafeDumper):
    pass


def _str(dumper: yaml.SafeDumper, value: str) -> yaml.Node:
    # a line break an editor does not show (U+0085, U+2028) is written escaped: PyYAML
    # writes it as it is (the tree loader refuses it) and in a quoted value folds it
    style = '"' if HIDDEN_BREAK.search(value) else "|" if "\n" in value else None
    if style is None and plain_reads_as_number(value):
        style = "'"  # 1e3: text to PyYAML's writer (YAML 1.1), a number to the loader
    return dumper.represent_scalar("tag:yaml.org,2002:str", value, style=style)


_Dumper.add_representer(str, _str)


def _converted(
    source: Path, registry: Registry
) -> tuple[str, dict[tuple[str | int, ...], SourceLocation], dict[str, Any]]:
    """The tree file's text for an XML file, each YAML place's XML element, and the
    tree file's mapping."""
    data, where = _read(source, registry)
    # a file name of bytes that are no UTF-8 ($'\xfe.xml', read as '\udcfe'): shown as
    # \xfe, not an "internal error: UnicodeEncodeError" when the YAML is written
    name = bytes_escaped(source.name)
    text = (
        f"# Converted from {name} (BehaviorTree.CPP v4 XML) by pirate-bt import btcpp.\n"
        + yaml.dump(data, Dumper=_Dumper, sort_keys=False, allow_unicode=True, width=100)
    )
    return text, where, data


def import_xml(
    xml_path: str | Path,
    out_path: str | Path,
    registry: Registry | None = None,
    robot: Any = None,
) -> Path:
    """Convert a BT.CPP v4 XML file to a pirate_bt tree file, checked before it appears.

    The YAML is written beside ``out_path`` under a temporary name, loaded with
    the tree loader against the robot (its limits, units and node types, as
    ``pirate-bt validate`` and ``run`` check a tree), and only then renamed to
    ``out_path``: a file that does not load is never left behind. Every problem
    the loader finds is reported at the XML element it comes from.

    Args:
        xml_path: The XML file.
        out_path: The tree file to write.
        registry: Node types allowed (default: pirate_bt's).
        robot: The robot description the tree must fit (a loaded one or its file;
            default: the bundled robot).

    Returns:
        The file written.

    Raises:
        InputError: a path that is no file name (an output that is a folder too), an
            output not named ``.yaml`` or ``.yml``, or an output that cannot be written.
        LocatedError: the XML cannot be converted (at the XML's line and column).
        ValidationFailed: the converted tree does not load for the robot, each
            problem at ``xml_file:line:column``.
    """
    from pirate_bt.robot.description import RobotDescription
    from pirate_bt.robot.loader import load_robot

    source = file_argument(xml_path, "xml_path")
    out = output_file(out_path, "out_path")
    refuse_special(out)
    if out.exists() and out.resolve() == source.resolve():
        raise InputError(f"{out}: is the XML file being imported; nothing written")
    if out.suffix.lower() not in (".yaml", ".yml"):  # YAML in b.xml: read back as XML, refused
        raise InputError(
            f"{out}: a pirate_bt tree is written to a .yaml file (as pirate-bt run and a"
            f" subtree's ref read it), not {out.suffix or 'a name without a suffix'};"
            " nothing written"
        )
    reg = registry or default_registry()
    description = robot if isinstance(robot, RobotDescription) else load_robot(robot)
    text, where, _data = _converted(source, reg)
    folder = out.parent if str(out.parent) else Path(".")
    # A missing folder is made, as for every other output of the library, and taken
    # away again when the tree does not load: a refused import leaves nothing.
    with new_folders_undone(folder):
        _write_loaded(out, folder, text, where, description, reg)
    return out


def _write_loaded(
    out: Path,
    folder: Path,
    text: str,
    where: dict[tuple[str | int, ...], SourceLocation],
    robot: RobotDescription,
    registry: Registry,
) -> None:
    """Write ``text`` to ``out`` through a temporary file in ``folder`` (made if
    missing), once it loads as a tree for ``robot``; nothing is left when it does not.

    Raises:
        InputError: the file cannot be written.
        ValidationFailed: the tree does not load (each problem at its XML element).
    """
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp_name = tempfile.mkstemp(
            prefix=f".{cut_name(out.stem)}.", suffix=".yaml", dir=folder
        )
    except OSError as exc:
        raise InputError(f"{out}: cannot write: {exc.strerror or exc}") from None
    tmp = Path(tmp_name)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as stream:
            stream.write(text)
        _load_placed(tmp, where, robot=robot, use_examples=True, registry=registry)
        mask = os.umask(0o022)
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)
        os.replace(tmp, out)
    except OSError as exc:
        raise InputError(f"{out}: cannot write: {exc.strerror or exc}") from None
    finally:
        tmp.unlink(missing_ok=True)


def load_xml_tree(
    xml_path: str | Path,
    *,
    robot: Any = None,
    params: Mapping[str, Any] | None = None,
    params_from_text: bool = False,
    params_origin: str | None = None,
    use_examples: bool = False,
    registry: Registry | None = None,
    **options: Any,
) -> LoadedTree:
    """A BT.CPP v4 XML file loaded as a tree to run, checked as :func:`import_xml`
    checks it (each problem at its XML element), nothing written beside it.

    What ``pirate-bt run tree.xml`` and ``simulate_tree("tree.xml")`` run, and
    ``pirate-bt validate tree.xml`` checks: the XML converted in a temporary folder
    (removed again), then loaded with ``params`` as a YAML tree is.

    Args:
        xml_path: The XML file.
        robot: The robot description (a loaded one or its file; default: the bundled).
        params: The tree's parameters (see :func:`pirate_bt.treefile.load_tree`).
        params_from_text: Read string parameters as the command line does.
        params_origin: Where the parameters came from, in messages (``--param``).
        use_examples: A parameter not given takes its declared example (validation).
        registry: Node types allowed (default: pirate_bt's).
        **options: Passed on to :func:`pirate_bt.treefile.load_tree` (``clock``,
            ``supervisor``).

    Raises:
        InputError: a path that is no file.
        LocatedError: the XML cannot be converted (at the XML's line and column).
        ValidationFailed: the converted tree does not load for the robot.
    """
    from pirate_bt.robot.description import RobotDescription
    from pirate_bt.robot.loader import load_robot

    source = file_argument(xml_path, "xml_path")
    given = None if params is None else _params_mapping(params)  # as load_tree refuses it
    reg = registry or default_registry()
    description = robot if isinstance(robot, RobotDescription) else load_robot(robot)
    text, where, data = _converted(source, reg)
    with tempfile.TemporaryDirectory(prefix="pirate-bt-xml-") as folder:
        # named as the XML (a tree without a name takes its file's), cut to a legal name
        converted = Path(folder) / f"{cut_name(source.stem, 250)}.yaml"
        converted.write_text(text, encoding="utf-8")
        loaded = _load_placed(
            converted,
            where,
            robot=description,
            params=given,
            params_from_text=params_from_text,
            params_origin=params_origin or (caller_params_origin() if given else None),
            use_examples=use_examples,
            registry=reg,
            **options,
        )
    # not the temporary file, gone now: the XML is what was read, and the mapping is
    # what a Groot2 server exports again to show the subtrees (it showed none)
    loaded.files = [str(source)]
    loaded.source = data
    return loaded
