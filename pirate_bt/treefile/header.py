"""A tree file's own declarations: the file read, its top level, its parameters.

Part of step 1 of loading (see :mod:`pirate_bt.treefile.loader`), under the node walk
of :mod:`pirate_bt.treefile.reader`: each file the tree uses is read once, its top
level checked (its keys, ``name``, ``description``, ``subtrees``) and its blackboard
recorded; a tree's declared ``params`` are read and the caller's values bound to
them. Every problem is collected at its place.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from pirate_bt.errors import LocatedError, SourceLocation, ValidationFailed
from pirate_bt.robot.description import RobotDescription
from pirate_bt.treefile.names import name_problem, unknown_key
from pirate_bt.treefile.names import shown_name as _shown
from pirate_bt.treefile.params import ParamDecl, coerce_param, written_value
from pirate_bt.treefile.registry import Registry
from pirate_bt.treefile.spec import _TOP_KEYS, BlackboardDecl, PathKey
from pirate_bt.yamlfile import YamlDocument, load_yaml
from pirate_bt.yamlvalidate import validation_problems

__all__ = []

# -- reading -------------------------------------------------------------------------


def _written(key: object) -> str:
    """A key as a message shows it: text cut short, anything else (``1``, ``None``) as is."""
    return _shown(key) if isinstance(key, str) else repr(key)


@dataclass
class _Env:
    """Where we are while reading: the document, the parameters, the include chain.

    ``caller`` maps a parameter whose value was written outside this document (by the
    caller of ``load_tree``, or at the subtree call that gave it, through further calls
    too) to that writer's name for it and the place it was written; ``used`` is where
    the reader's ``subst`` put such a value, so a problem with it is reported where the
    value was written (:meth:`_FileReader.value_error`).
    """

    doc: YamlDocument
    values: dict[str, Any]
    chain: tuple[str, ...]
    caller: Mapping[str, tuple[str, SourceLocation]] = field(default_factory=dict)
    used: dict[PathKey, tuple[str, SourceLocation]] = field(default_factory=dict)


class _FileReader:
    """What the reader keeps while it reads (problems, files, blackboard, bounds), and
    the checks of a file's declarations; :class:`~pirate_bt.treefile.reader._Reader`
    adds the node walk."""

    def __init__(
        self,
        registry: Registry,
        robot: RobotDescription | None,
        units_required: bool,
        base_dir: Path,
    ) -> None:
        self.registry = registry
        self.robot = robot
        self.units_required = units_required
        self.base_dir = base_dir
        self.errors: list[LocatedError] = []
        self.warnings: list[LocatedError] = []
        self.docs: dict[str, YamlDocument] = {}
        self.blackboard: dict[str, tuple[BlackboardDecl, SourceLocation]] = {}
        self.headers_read: set[str] = set()
        self.depth = 0
        """How deep the reader's ``node`` is, subtrees included (bounded by MAX_TREE_DEPTH)."""
        self.too_deep = False
        self.count = 0
        """Nodes read so far, subtrees expanded (bounded by MAX_TREE_NODES)."""
        self.unbound: list[PathKey] = []
        """Where the reader's ``subst`` met an unknown ``$parameter`` (reported once, there)."""

    # -- helpers

    def error(self, doc: YamlDocument, path: Sequence[str | int], message: str) -> None:
        self.errors.append(doc.locator.error(path, message))

    def value_error(self, env: _Env, path: PathKey, message: str) -> None:
        """A problem with the value at ``path``: where it was written when it is a
        parameter value given from outside this document (``-1 m`` for a distance that
        must be above 0, by the caller of ``load_tree`` or at a subtree call), naming
        where the tree uses it; else at ``path``."""
        given = next(
            (env.used[path[:n]] for n in range(len(path), 0, -1) if path[:n] in env.used), None
        )
        if given is None:
            self.error(env.doc, path, message)
        else:
            name, written = given
            used = env.doc.locator.locate(path)
            self.errors.append(
                LocatedError(f"parameter {name!r}: {message} (used at {used})", written)
            )

    def read_file(self, path: Path, doc: YamlDocument, at: PathKey) -> YamlDocument | None:
        """The subtree file at ``path`` (``at`` names it in ``doc``), read once; None
        after saying, at ``at``, why it cannot be read."""
        try:
            key = str(path.resolve())
            if key in self.docs:
                return self.docs[key]
            what = None
            if not path.is_file():
                what = "not found"
                if path.is_dir():
                    what = "is a directory, not a file"
                elif path.exists():  # a pipe would be waited on for ever, a device read
                    what = "is not a regular file"
        except ValueError:  # "\0" written in a quoted ref
            what = "cannot be read: a NUL in the file name"
        except RuntimeError:  # Path.resolve (Python 3.11 and 3.12) on links that loop
            what = "cannot be read: a loop of symbolic links"
        except OSError as exc:  # a name the system refuses (a part too long)
            what = f"cannot be read: {exc.strerror or exc}"
        if what is not None:
            self.error(doc, at, f"subtree file {_shown(str(path))} {what}")
            return None
        try:
            loaded = load_yaml(path)
        except ValidationFailed as exc:
            self.errors.extend(exc.errors)
            return None
        self.docs[key] = loaded
        return loaded

    def header(self, doc: YamlDocument) -> bool:
        """Check a file's top level and record its blackboard; False if unusable."""
        data = doc.data
        if not isinstance(data, dict):
            self.error(doc, (), "a tree file is a mapping with a 'root' key")
            return False
        if doc.file in self.headers_read:
            return True
        self.headers_read.add(doc.file)
        for key in data:
            if key not in _TOP_KEYS:
                self.error(doc, (key,), unknown_key(key, _TOP_KEYS))
        if "name" in data and not isinstance(data["name"], str):
            self.error(doc, ("name",), "name: must be text")
        elif data.get("name"):
            problem = name_problem(data["name"])
            root = data.get("root")
            # A '/' only matters where the name becomes the root node's (it has none).
            if problem and not ("'/'" in problem and isinstance(root, dict) and root.get("name")):
                self.error(doc, ("name",), problem)
        if "description" in data and not isinstance(data["description"], str):
            self.error(doc, ("description",), "description: must be text")
        subtrees = data.get("subtrees")
        if subtrees is not None and not isinstance(subtrees, dict):
            self.error(doc, ("subtrees",), "subtrees: a mapping of name -> tree")
        elif isinstance(subtrees, dict):
            for key in subtrees:
                if not isinstance(key, str):
                    self.error(doc, ("subtrees", str(key)), f"subtree name {key!r} must be text")
        board = data.get("blackboard", {})
        if board is None:
            board = {}
        if not isinstance(board, dict):
            self.error(doc, ("blackboard",), "blackboard: a mapping of key -> declaration")
            return True
        for key, decl in board.items():
            where: PathKey = ("blackboard", key)
            if not isinstance(key, str) or not key.isidentifier():
                self.error(doc, where, f"blackboard key {_written(key)} must be an identifier")
                continue
            try:
                decl = {} if decl is None else decl
                parsed = BlackboardDecl.model_validate(decl)
            except ValidationError as exc:
                for at_key, msg in validation_problems(exc, decl):
                    msg = msg if at_key else f"blackboard key {key!r}: {msg}"
                    self.error(doc, (*where, *at_key), msg)
                continue
            loc = doc.locator.locate(where)
            previous = self.blackboard.get(key)
            if previous is not None and previous[0].type != parsed.type:
                self.error(
                    doc,
                    where,
                    f"blackboard key {key!r} declared as {parsed.type} here"
                    f" but as {previous[0].type} at {previous[1]}",
                )
                continue
            if previous is None or parsed.default is not None or parsed.external:
                self.blackboard[key] = (parsed, loc)
        return True

    def declared_params(
        self, doc: YamlDocument, where: PathKey, raw: Any
    ) -> dict[str, ParamDecl] | None:
        if raw is None:
            return {}
        if not isinstance(raw, dict):
            self.error(doc, where, "params: a mapping of name -> {type, default}")
            return None
        out: dict[str, ParamDecl] = {}
        before = len(self.errors)
        for name, decl in raw.items():
            at = (*where, name)
            if not isinstance(name, str) or not name.isidentifier():
                self.error(doc, at, f"parameter name {_written(name)} must be an identifier")
                continue
            if isinstance(decl, str):
                decl = {"type": decl}
            try:
                parsed = ParamDecl.model_validate(decl)
            except ValidationError as exc:
                for loc, msg in validation_problems(exc, decl):
                    self.error(doc, (*at, *loc), msg if loc else f"parameter {name!r}: {msg}")
                continue
            if parsed.choices is not None and parsed.type != "string":
                self.error(doc, (*at, "choices"), "choices: only a string parameter has choices")
                continue
            bad = False
            written: dict[str, Any] = {}
            for key in ("default", "example"):
                value = getattr(parsed, key)
                if value is None:
                    continue
                try:
                    written[key] = written_value(value)  # $$x: the literal $x, once
                    coerce_param(parsed, written[key], units_required=self.units_required)
                except ValueError as exc:
                    self.error(doc, (*at, key), f"{key}: {exc}")
                    bad = True
            if bad:
                continue
            out[name] = parsed.model_copy(update=written)
        return out if len(self.errors) == before else None

    def bind(
        self,
        doc: YamlDocument,
        where: PathKey,
        decls: dict[str, ParamDecl],
        given: Mapping[str, Any],
        given_at: Any,
        from_text: bool = False,
        use_examples: bool = False,
        in_file: bool = False,
    ) -> dict[str, Any] | None:
        """Values for declared parameters from the caller; None on error.

        With ``use_examples`` (checking or drawing a tree, never running it) a
        parameter the caller did not give takes its declared ``example``. ``in_file``:
        the values are written in the document (a subtree call's), where a quantity
        needs its unit when the document's do.
        """
        values: dict[str, Any] = {}
        ok = True
        for name, value in given.items():
            if name not in decls:
                known = ", ".join(decls) or "none declared"
                self.errors.append(
                    LocatedError(
                        f"unknown parameter {_shown(str(name))} (parameters: {known})",
                        given_at(name),
                    )
                )
                ok = False
                continue
            try:
                values[name] = coerce_param(
                    decls[name],
                    value,
                    from_text=from_text,
                    units_required=in_file and self.units_required,
                )
            except ValueError as exc:
                self.errors.append(LocatedError(f"parameter {name!r}: {exc}", given_at(name)))
                ok = False
        for name, decl in decls.items():
            if name in values or name in given:  # given but invalid: reported above
                continue
            if decl.default is not None:
                values[name] = coerce_param(decl, decl.default)
            elif use_examples and decl.example is not None:
                values[name] = coerce_param(decl, decl.example)
            else:
                hint = (
                    " (declare an 'example' to check the tree without it)" if use_examples else ""
                )
                self.error(doc, where, f"parameter {name!r} has no default and was not given{hint}")
                ok = False
        return values if ok else None
