"""A tree file's own declarations: the file read, its top level, its parameters.

Part of step 1 of loading (see :mod:`pirate_bt.treefile.loader`), under the node walk
of :mod:`pirate_bt.treefile.reader`: each file the tree uses is read once, its top
level checked (its keys, ``name``, ``description``, ``subtrees``) and its blackboard
recorded; a tree's declared ``params`` are read and the caller's values bound to
them. Every problem is collected at its place, and a refused declaration stops only
what depends on it: a parameter whose ``default`` is refused is unknown to the nodes
that use it (``_Env.unknown``), a blackboard key whose declaration is refused is not
checked against the nodes (``board_unsure``).
"""

from __future__ import annotations

import unicodedata
from collections.abc import Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from pirate_bt.errors import LocatedError, SourceLocation, ValidationFailed, shown
from pirate_bt.robot.description import RobotDescription
from pirate_bt.treefile.names import (
    alike_among,
    name_problem,
    odd_character,
    printable,
    skeleton,
    unknown_key,
)
from pirate_bt.treefile.names import shown_name as _shown
from pirate_bt.treefile.params import (
    PARAM_RE,
    ParamDecl,
    coerce_param,
    listed,
    written_value,
)
from pirate_bt.treefile.refused import holds_blank, read_tree_yaml
from pirate_bt.treefile.registry import Registry
from pirate_bt.treefile.spec import _TOP_KEYS, BlackboardDecl, PathKey
from pirate_bt.yamlfile import YamlDocument
from pirate_bt.yamlvalidate import close_matches, validation_problems

__all__ = []

# -- reading -------------------------------------------------------------------------


SUGGESTION_BUDGET = 20_000
"""The most names one load compares for its *did you mean* hints. Each comparison of
similar names costs about 0.1 ms: 3,000 refs to no subtree, each compared with a file's
3,000 subtrees, took five minutes to validate."""


def _not_ascii(name: str) -> str:
    """Which character of ``name`` is not ASCII, by its code point: a Kelvin sign K
    (U+212A) looks like K, so ``'xK'`` said alone looks like a valid name."""
    odd = next((c for c in name if not c.isascii()), None)
    if odd is None:
        return ""
    return f" ({odd!r} is U+{ord(odd):04X} {unicodedata.name(odd, 'a character')})"


def misspelt(body: Mapping[Any, Any], key: str, allowed: frozenset[str]) -> bool:
    """Whether ``body`` lacks ``key`` and has an unknown key that its message calls a
    misspelling of it (``blackbaord``: did you mean 'blackboard'?)."""
    return key not in body and any(
        isinstance(k, str) and k not in allowed and close_matches(k, sorted(allowed), n=1) == [key]
        for k in body
    )


def _written(key: object) -> str:
    """A key as a message shows it: text cut short, anything else (``1``, ``None``) as is."""
    return _shown(key) if isinstance(key, str) else repr(key)


def _field(path: PathKey) -> bool:
    """Whether a declaration's problem at ``path`` is at one of its fields, which its
    message names (``default: ...``); else it is the declaration's own, or a key that is
    not text (``key 9 must be text``), and the message says whose."""
    return bool(path) and isinstance(path[0], str)


class _Names:
    """Names a later check cannot rely on, because what they stood for was refused
    (and said so): some names, or, when a whole section was refused, every name."""

    def __init__(self, names: Iterable[str] = (), *, every: bool = False) -> None:
        self.names = set(names)
        self.every = every

    def __contains__(self, name: object) -> bool:
        return self.every or name in self.names

    def add(self, name: str) -> None:
        self.names.add(name)


@dataclass
class _Declared:
    """A tree's declared parameters, as far as they could be read.

    ``decls``: the usable declarations (a refused ``default`` or ``example`` taken
    out); ``names``: every name declared, in order; ``refused``: names whose
    declaration was refused (its type unknown, so neither a value given for it nor a
    use of it can be checked); ``no_default`` and ``no_example``: names whose
    ``default`` or ``example`` was refused.
    """

    decls: dict[str, ParamDecl] = field(default_factory=dict)
    names: list[str] = field(default_factory=list)
    refused: _Names = field(default_factory=_Names)
    no_default: set[str] = field(default_factory=set)
    no_example: set[str] = field(default_factory=set)


@dataclass
class _Env:
    """Where we are while reading: the document, the parameters, the include chain.

    ``caller`` maps a parameter whose value was written outside this document (by the
    caller of ``load_tree``, or at the subtree call that gave it, through further calls
    too) to that writer's name for it and the place it was written; ``used`` is where
    the reader's ``subst`` put such a value, so a problem with it is reported where the
    value was written (:meth:`_FileReader.value_error`). ``unknown`` names the
    parameters whose value cannot be known (refused where it was declared or given, or
    not given): a use of one is not checked, as the problem was said where it is.
    """

    doc: YamlDocument
    values: dict[str, Any]
    chain: tuple[str, ...]
    caller: Mapping[str, tuple[str, SourceLocation]] = field(default_factory=dict)
    used: dict[PathKey, tuple[str, SourceLocation]] = field(default_factory=dict)
    unknown: Collection[str] | _Names = frozenset()
    declared: Sequence[str] = ()
    """Every parameter declared, for messages (those of ``values`` first)."""


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
        """Where the reader's ``subst`` met a value it cannot know: an unknown
        ``$parameter`` (reported once, there), a parameter of ``_Env.unknown`` or a value
        YAML refused (:mod:`pirate_bt.treefile.refused`; both reported where they are).
        The checks of a node with such a value are skipped where they concern it, and
        the node is left out of the tree (so later checks, which need the whole tree,
        are skipped)."""
        self.blanked: set[str] = set()
        """Files read with refused values blanked out (:mod:`pirate_bt.treefile.refused`)."""
        self.board_unsure = _Names()
        """Blackboard keys whose declaration was refused: not checked against the nodes."""
        self.expanded: set[str] = set()
        """The subtrees a call used (``file#name``): the others are checked on their own."""
        self.compared = 0
        """Names compared so far for a *did you mean* (at most :data:`SUGGESTION_BUDGET`)."""

    # -- helpers

    def close_names(self, name: str, known: list[str]) -> list[str]:
        """The (at most two) names of ``known`` close to ``name``, for a *did you mean*;
        none once :data:`SUGGESTION_BUDGET` names have been compared in this load."""
        if self.compared + len(known) > SUGGESTION_BUDGET:
            return []
        self.compared += len(known)
        return close_matches(name, known, n=2)

    def error(self, doc: YamlDocument, path: Sequence[str | int], message: str) -> None:
        message += yes_no_note(doc, path)
        self.errors.append(doc.locator.error(path, printable(message)))

    def blank(self, doc: YamlDocument, value: Any) -> bool:
        """Whether ``value`` (of ``doc``) is or holds a value YAML refused, which was said
        where it is: what depends on it is not checked."""
        return doc.file in self.blanked and holds_blank(value)

    def refused(self, doc: YamlDocument, refused: list[LocatedError]) -> None:
        """Say the values YAML refused in ``doc`` (blanked out by
        :func:`~pirate_bt.treefile.refused.read_tree_yaml`)."""
        if refused:
            self.errors.extend(refused)
            self.blanked.add(doc.file)

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
                LocatedError(f"parameter {shown(name)}: {message} (used at {used})", written)
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
            loaded, refused = read_tree_yaml(path)
        except ValidationFailed as exc:
            self.errors.extend(exc.errors)
            return None
        self.refused(loaded, refused)
        self.docs[key] = loaded
        return loaded

    def header(self, doc: YamlDocument) -> bool:
        """Check a file's top level and record its blackboard; False if unusable."""
        data = doc.data
        if not isinstance(data, dict):
            if not self.blank(doc, data):
                self.error(doc, (), "a tree file is a mapping with a 'root' key")
            return False
        if doc.file in self.headers_read:
            return True
        other = _another_kind(data)
        if other is not None:  # a line for each of its keys said nothing more
            self.error(doc, (), other)
            return False
        self.headers_read.add(doc.file)
        for key in data:
            if key not in _TOP_KEYS and not self.blank(doc, key):
                self.error(doc, (key,), unknown_key(key, _TOP_KEYS))
        if misspelt(data, "blackboard", _TOP_KEYS):
            self.board_unsure.every = True  # what it declares is not known
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
        if self.blank(doc, subtrees) and not isinstance(subtrees, dict):
            pass  # said where it is; a ref to it is not looked for
        elif subtrees is not None and not isinstance(subtrees, dict):
            self.error(doc, ("subtrees",), "subtrees: a mapping of name -> tree")
        elif isinstance(subtrees, dict):
            seen: dict[str, str] = {}  # each name's skeleton -> the first name of it
            for key in subtrees:
                if isinstance(key, str) and seen.setdefault(skeleton(key), key) != key:
                    first = seen[skeleton(key)]
                    self.error(
                        doc,
                        ("subtrees", key),
                        f"subtree name {shown(key)} looks like {shown(first)} (at"
                        f" {doc.locator.locate(('subtrees', first))}:"
                        f" {odd_character(first, key)}); a ref could mean either: rename one",
                    )
                if not isinstance(key, str):
                    self.error(doc, ("subtrees", str(key)), f"subtree name {key!r} must be text")
                elif not key or "#" in key or key.lower().endswith((".yaml", ".yml")):
                    # a ref of it would name a file (x.yaml, x.yaml#t) or nothing: never it
                    self.error(
                        doc,
                        ("subtrees", key),
                        f"subtree name {shown(key)}: no ref can name it (a ref with '#' or"
                        " ending .yaml or .yml names a file); rename it",
                    )
        self.board(doc, data.get("blackboard", {}))
        return True

    def board(self, doc: YamlDocument, board: Any) -> None:
        """Record a file's blackboard declarations; a key whose declaration is refused
        is not checked against the nodes (every key, if the whole section is)."""
        if board is None:
            board = {}
        if not isinstance(board, dict):
            if not self.blank(doc, board):
                self.error(doc, ("blackboard",), "blackboard: a mapping of key -> declaration")
            self.board_unsure.every = True
            return
        for key, decl in board.items():
            where: PathKey = ("blackboard", key)
            if self.blank(doc, key):
                self.board_unsure.every = True  # said; which key the nodes meant is unknown
                continue
            if not isinstance(key, str) or not PARAM_RE.fullmatch(f"${key}"):
                # as a node names it: 'café' is a Python identifier, but no node's key: it
                # was declared, and every node reading it refused
                self.error(
                    doc,
                    where,
                    f"blackboard key {_written(key)} must be an identifier of ASCII letters,"
                    " digits and '_', not first a digit"
                    + (_not_ascii(key) if isinstance(key, str) else ""),
                )
                if isinstance(key, str):
                    self.board_unsure.add(key)
                continue
            decl = {} if decl is None else decl
            blanked = self.blank(doc, decl)
            if blanked and isinstance(decl, dict):  # the rest of it is still checked
                decl = {
                    k: v for k, v in decl.items() if not (self.blank(doc, k) or self.blank(doc, v))
                }
            try:
                parsed = BlackboardDecl.model_validate(decl)
            except ValidationError as exc:
                if not blanked or isinstance(decl, dict):
                    for at_key, msg in validation_problems(exc, decl):
                        own = _field(at_key) and at_key[0] != "type"  # a type's: and its key
                        msg = msg if own else f"blackboard key {shown(key)}: {msg}"
                        self.error(doc, (*where, *at_key), msg)
                self.board_unsure.add(key)
                continue
            if blanked:
                self.board_unsure.add(key)
                continue
            loc = doc.locator.locate(where)
            previous = self.blackboard.get(key)
            if previous is not None and previous[0].type != parsed.type:
                self.error(
                    doc,
                    where,
                    f"blackboard key {shown(key)} declared as {parsed.type} here"
                    f" but as {previous[0].type} at {previous[1]}",
                )
                continue
            if previous is None or parsed.default is not None or parsed.external:
                self.blackboard[key] = (parsed, loc)

    def declared_params(
        self, doc: YamlDocument, where: PathKey, raw: Any, misspelt: bool = False
    ) -> _Declared:
        """A tree's declared ``params``: each declaration that can be read; one that is
        refused is said, and its parameter's uses are not checked (``_Declared``).
        ``misspelt``: the tree has no ``params`` but a key said to be a misspelling of
        it (``parms``), whose parameters are not known."""
        out = _Declared()
        if raw is None:
            out.refused.every = misspelt
            return out
        if not isinstance(raw, dict):
            if not self.blank(doc, raw):
                self.error(doc, where, "params: a mapping of name -> {type, default}")
            out.refused.every = True
            return out
        for name, decl in raw.items():
            at = (*where, name)
            if self.blank(doc, name):
                continue  # said where it is; no $name can name it
            if isinstance(name, str):
                out.names.append(name)
            if not isinstance(name, str) or not PARAM_RE.fullmatch(f"${name}"):
                ascii_only = ""  # 'café' is a Python identifier, but no $café names it
                if isinstance(name, str) and name.isidentifier():
                    ascii_only = " of ASCII letters, digits and '_', as $name is written"
                    ascii_only += _not_ascii(name)
                self.error(
                    doc, at, f"parameter name {_written(name)} must be an identifier{ascii_only}"
                )
                if isinstance(name, str):
                    out.refused.add(name)
                continue
            if isinstance(decl, str):
                decl = {"type": decl}
            if self.blank(doc, decl):
                kept = self.unblanked(doc, decl)
                if kept is None:  # its type or choices unknown: nothing to check it by
                    out.refused.add(name)
                    continue
                if "default" in decl and "default" not in kept:
                    out.no_default.add(name)
                if "example" in decl and "example" not in kept:
                    out.no_example.add(name)
                decl = kept
            try:
                parsed = ParamDecl.model_validate(decl)
            except ValidationError as exc:
                for loc, msg in validation_problems(exc, decl):
                    msg = msg if _field(loc) else f"parameter {shown(name)}: {msg}"
                    self.error(doc, (*at, *loc), msg)
                out.refused.add(name)
                continue
            if parsed.choices is not None and parsed.type != "string":
                self.error(doc, (*at, "choices"), "choices: only a string parameter has choices")
                out.refused.add(name)
                continue
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
                    written[key] = None  # the parameter is still declared, without it
                    (out.no_default if key == "default" else out.no_example).add(name)
            out.decls[name] = parsed.model_copy(update=written)
        return out

    def unblanked(self, doc: YamlDocument, decl: Any) -> dict[str, Any] | None:
        """A parameter's declaration without its blanked ``default`` and ``example``
        (:mod:`pirate_bt.treefile.refused`); None when another part of it is blanked."""
        if not isinstance(decl, dict):
            return None
        kept = {k: v for k, v in decl.items() if not self.blank(doc, v)}
        if self.blank(doc, list(kept)) or set(decl) - set(kept) - {"default", "example"}:
            return None
        return kept

    def bind(
        self,
        doc: YamlDocument,
        where: PathKey,
        declared: _Declared,
        given: Mapping[str, Any],
        given_at: Any,
        from_text: bool = False,
        use_examples: bool = False,
        in_file: bool = False,
        lost: _Names | None = None,
    ) -> tuple[dict[str, Any], _Names]:
        """Values for declared parameters from the caller, and the names whose value is
        unknown (refused where it was declared or given, or not given: each said).

        With ``use_examples`` (checking or drawing a tree, never running it) a
        parameter the caller did not give takes its declared ``example``. ``in_file``:
        the values are written in the document (a subtree call's), where a quantity
        needs its unit when the document's do. ``lost``: names given whose value could
        not be read (said where it was written); a parameter then left out is not said
        to be missing.
        """
        decls = declared.decls
        lost = lost or _Names()
        values: dict[str, Any] = {}
        # A parameter whose declaration is refused (said there) has no value to know,
        # given or not: its uses are not checked either (one mistake, one line).
        unknown = _Names(
            [*lost.names, *declared.refused.names],
            every=lost.every or declared.refused.every,
        )
        # a name given close to one that must be given and was not ('distanse' for
        # 'distance') is one problem, said at the name given: it was two lines
        owed = [
            n
            for n, d in decls.items()
            if n not in given
            and d.default is None
            and not (use_examples and d.example is not None)
            and n not in declared.no_default
            and not (use_examples and n in declared.no_example)
            and not (lost.names or lost.every)
        ]
        meant: dict[str, str] = {}
        for name, value in given.items():
            if name in lost:
                continue
            if name in declared.refused:
                unknown.add(name)  # no type to check it by: its declaration is refused
                continue
            if name not in decls:
                known = listed(declared.names) or "none declared"
                close = close_matches(str(name), owed, n=2, cutoff=0.7)
                hint = ""
                if len(close) == 1 and close[0] not in meant.values():
                    meant[str(name)] = close[0]
                    hint = f"; did you mean {shown(close[0])}?"
                hint += alike_among(str(name), [str(n) for n in decls])
                self.errors.append(
                    LocatedError(
                        f"unknown parameter {_shown(str(name))} (parameters: {known}){hint}",
                        given_at(name),
                    )
                )
                continue
            try:
                values[name] = coerce_param(
                    decls[name],
                    value,
                    from_text=from_text,
                    units_required=in_file and self.units_required,
                )
            except ValueError as exc:
                note = yes_no_note(doc, (*where, "params", name)) if in_file else ""
                self.errors.append(
                    LocatedError(f"parameter {shown(name)}: {exc}{note}", given_at(name))
                )
                unknown.add(name)
        for name, decl in decls.items():
            if name in values or name in given or name in lost:  # given but refused: said
                continue
            if name in meant.values():
                unknown.add(name)  # said with the name given for it
                continue
            if decl.default is not None:
                values[name] = coerce_param(decl, decl.default)
            elif use_examples and decl.example is not None:
                values[name] = coerce_param(decl, decl.example)
            elif name in declared.no_default or (use_examples and name in declared.no_example):
                unknown.add(name)  # its default (or example) is refused, where it is written
            elif lost.names or lost.every:
                # A call whose values could not all be read (an unknown $name in one) is
                # not also held to the values it leaves out (as before: one problem).
                unknown.add(name)
            else:
                hint = (
                    " (declare an 'example' to check the tree without it)" if use_examples else ""
                )
                missing = f"parameter {shown(name)} has no default and was not given{hint}"
                self.error(doc, where, missing)
                unknown.add(name)
        return values, unknown


def yes_no_note(doc: YamlDocument, path: Sequence[str | int]) -> str:
    """Where the value refused at ``path`` is a plain ``no``, ``yes``, ``on`` or ``off``,
    which YAML 1.1 reads as a boolean (``message: no``: *must be text, not false*): so."""
    plain = doc.locator.yes_no.get(tuple(path))
    if plain is None:
        return ""
    meaning = "true" if plain.lower() in ("yes", "on") else "false"
    return f" (YAML reads a plain {plain} as {meaning}: quote it for the text)"


def _another_kind(data: Mapping[Any, Any]) -> str | None:
    """One line for a file of another kind given as a tree (a robot description, a pipe
    network, a campaign): none of a tree's keys, and a key that marks that kind. Each of
    its keys was a line of its own (*unknown key 'schema_version'*, *missing required
    key 'root'*, ...), as other kinds already said of a tree given as them."""
    own = _TOP_KEYS - {"name", "description"}
    if any(key in own for key in data):
        return None
    from pirate_bt.filekinds import KINDS

    for kind in KINDS.values():
        marker = next((m for m in kind.marker_keys if m in data and m not in own), None)
        if marker is not None:
            unknown = [str(k) for k in data if k not in _TOP_KEYS]
            return (
                f"not a behaviour tree: it has none of its keys ({', '.join(sorted(own))}) and"
                f" keys it does not take ({', '.join(unknown[:4])}): it looks like a"
                f" {kind.title} (it has {marker!r})"
            )
    return None
