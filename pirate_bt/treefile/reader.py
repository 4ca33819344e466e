"""Reading a tree file: every file it uses, parameters substituted, into node specs.

Step 1 of loading (see :mod:`pirate_bt.treefile.loader`): the reader turns each
node into a :class:`~pirate_bt.treefile.spec.NodeSpec`, its class from the
registry and its parameters validated, and collects every problem at its place.
Each file's top level and a tree's parameters are checked by
:mod:`pirate_bt.treefile.header`, which this walk stands on.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pydantic import ValidationError

from pirate_bt.errors import SourceLocation, shown
from pirate_bt.treefile.header import _Env as _Env  # the loader's, kept importable here
from pirate_bt.treefile.header import _FileReader, _Names, misspelt
from pirate_bt.treefile.names import (
    alike_note,
    dedupe,
    name_problem,
    node_label,
    non_text_keys,
    unknown_key,
)
from pirate_bt.treefile.names import shown_name as _shown
from pirate_bt.treefile.params import PARAM_RE, chain_text, listed
from pirate_bt.treefile.registry import UnknownNode
from pirate_bt.treefile.spec import (
    _COMMON_KEYS,
    _STRUCT_KEYS,
    _SUBTREE_KEYS,
    _TOP_KEYS,
    MAX_TREE_DEPTH,
    MAX_TREE_NODES,
    NodeSpec,
    PathKey,
)
from pirate_bt.yamlvalidate import key_not_text, validation_problems

if TYPE_CHECKING:
    from pirate_bt.yamlfile import YamlDocument

__all__ = []

_log = logging.getLogger("pirate_bt.treefile")


def _in(path: PathKey) -> str:
    """The key under which a value is, for a message (``condition: ``), or nothing."""
    named = [p for p in path if isinstance(p, str)]
    return f"{named[-1]}: " if named else ""


class _Reader(_FileReader):
    """The node walk: each node read into a spec, subtrees expanded in place."""

    # -- parameters

    def subst(self, env: _Env, value: Any, path: PathKey) -> Any:
        """``value`` with each ``$name`` replaced by the parameter's value; where a value
        cannot be known (``unbound``), None."""
        if isinstance(value, str):
            if self.blank(env.doc, value):
                self.unbound.append(path)  # YAML refused it, and said so where it is
                return None
            if value.startswith("$$"):
                return value[1:]
            match = PARAM_RE.match(value)
            if match:
                name = match["name"]
                if name in env.values:
                    if name in env.caller:
                        env.used[path] = env.caller[name]
                    return env.values[name]
                if name in env.unknown:
                    self.unbound.append(path)  # said where it is declared or given
                    return None
                names = [*env.values, *(n for n in env.declared if n not in env.values)]
                # not a refused declaration ('x\u212a', a Kelvin sign): said on its own
                # line, and listed it looked like the '$xK' said to be unknown
                names = [n for n in names if PARAM_RE.fullmatch(f"${n}")]
                known = listed(names, "$") or "none declared"
                self.error(
                    env.doc, path, f"unknown parameter ${_shown(name)[1:-1]} (parameters: {known})"
                )
                self.unbound.append(path)
                return None
            if value.startswith("$"):
                if value[1:] not in env.unknown:  # '$café': its declaration is refused
                    self.error(
                        env.doc, path, f"{_shown(value)}: write $name, or $$ for a literal $"
                    )
                self.unbound.append(path)  # one mistake, one line: not also checked as text
                return None
            return value
        if isinstance(value, dict):
            out = {}
            for k, v in value.items():
                if self.blank(env.doc, k):
                    self.unbound.append((*path, k))
                else:
                    out[k] = self.subst(env, v, (*path, k))
            return out
        if isinstance(value, list):
            return [self.subst(env, v, (*path, i)) for i, v in enumerate(value)]
        return value

    # -- trees

    def tree(self, env: _Env, where: PathKey, body: Mapping[str, Any]) -> NodeSpec | None:
        if "root" not in body:
            self.error(env.doc, where, "missing required key 'root'")
            return None
        return self.node(env, (*where, "root"), body["root"])

    def node(self, env: _Env, path: PathKey, raw: Any) -> NodeSpec | None:
        if self.count > MAX_TREE_NODES:
            return None  # reported once, where the tree grew past the limit
        self.count += 1
        if self.count > MAX_TREE_NODES:
            self.error(
                env.doc,
                path,
                f"the tree expands to more than {MAX_TREE_NODES} nodes (subtrees included)",
            )
            return None
        if self.depth >= MAX_TREE_DEPTH:
            if not self.too_deep:  # once: the first node too deep says it
                self.too_deep = True
                deeper = f"nodes nested deeper than {MAX_TREE_DEPTH} levels (subtrees included)"
                self.error(env.doc, path, deeper)
            return None
        self.depth += 1
        try:
            return self.read_node(env, path, raw)
        finally:
            self.depth -= 1

    def read_node(self, env: _Env, path: PathKey, raw: Any) -> NodeSpec | None:
        doc = env.doc
        if isinstance(raw, str):
            raw = {"type": raw}
        if not isinstance(raw, dict):
            self.error(doc, path, "a node is a mapping with a 'type' key, or a node type name")
            return None
        kind = raw.get("type")
        if kind is None:
            self.error(doc, path, "node without 'type'")
            return None
        if not isinstance(kind, str):
            self.error(doc, (*path, "type"), "type: must be a node type name")
            return None
        if self.blank(doc, kind):
            return None  # YAML refused it (said there): which node it is, is unknown
        loc = doc.locator.locate(path)
        # A refused name or description is said, and the node is read on (its keys and
        # children have their own problems), but it is left out of the tree.
        name = raw.get("name")
        problem = None if name is None else name_problem(name)
        if problem:
            self.error(doc, (*path, "name"), problem)
        if "description" in raw and not isinstance(raw["description"], str):
            self.error(doc, (*path, "description"), "description: must be text")
            problem = problem or "description"
        left_out = bool(problem) or self.blank(doc, name)
        if left_out:
            name = None
        spec = NodeSpec(node_type=kind, name=name or kind, location=loc, explicit_name=bool(name))
        label = node_label(kind, name, path, doc.file == "<dict>")  # for a non-text key
        if kind in _STRUCT_KEYS:
            for key in raw:
                allowed = _STRUCT_KEYS[kind]
                if key not in _COMMON_KEYS and key not in allowed and not self.blank(doc, key):
                    named = "" if isinstance(key, str) else f"{label}: "
                    self.error(doc, (*path, key), named + unknown_key(key, allowed))
            if kind == "subtree":
                read = self.subtree(env, path, raw, spec)
            elif kind == "eternal_guard":
                read = self.guard(env, path, raw, spec)
            else:
                read = self.composite(env, path, raw, spec)
            return None if left_out else read
        try:
            cls = self.registry.get(kind)
        except UnknownNode as exc:
            self.error(doc, (*path, "type"), f"{exc}{_NOT_SUBSTITUTED if _dollar(kind) else ''}")
            return None
        except ImportError as exc:
            self.error(doc, (*path, "type"), f"node type {kind!r} cannot be loaded: {exc}")
            return None
        spec.cls = cls
        raw_params = {k: v for k, v in raw.items() if k not in _COMMON_KEYS and k not in ("child",)}
        unbound = len(self.unbound)
        raw_params = self.subst(env, raw_params, path)
        unknown = self.unbound[unbound:]  # not checked: the problem is said where it is
        raw_params, bad_keys = non_text_keys(raw_params)  # said here, in the library's words
        for at_key, key in bad_keys:
            self.error(doc, (*path, *at_key), f"{label}: {_in(at_key)}{key_not_text(key)}")
        try:
            spec.params = cls.Params.model_validate(
                raw_params,
                context={"units_required": self.units_required, "magnitude_limits": True},
            )
        except ValidationError as exc:
            for at_key, msg in validation_problems(exc, raw_params, cls.Params):
                at = (*path, *at_key)
                if not any(at[: len(u)] == u or u[: len(at)] == at for u in unknown):
                    self.value_error(env, at, f"{kind}: {msg}")
            spec.params = None
        if unknown or bad_keys:
            spec.params = None  # its limits are checked with every value known
        if spec.params is not None and self.robot is not None:
            for problem in cls.check_limits(spec.params, self.robot):
                field_name, sep, _ = problem.partition(":")
                at = (*path, field_name) if sep and field_name in raw else path
                self.value_error(env, at, f"{kind}: {problem}")
        if cls.kind == "decorator":
            if "child" not in raw:
                self.error(doc, path, f"decorator {kind!r} needs a 'child'")
                return None
            child = self.node(env, (*path, "child"), raw["child"])
            if child is None:
                return None
            spec.children = [child]
        elif "child" in raw:
            self.error(doc, (*path, "child"), f"{kind!r} is a leaf and takes no child")
            return None  # what the child was for is unknown (it is not read)
        return spec if spec.params is not None and not left_out else None

    def children(self, env: _Env, path: PathKey, raw: Any, key: str) -> list[NodeSpec] | None:
        """The nodes listed under ``key``; None if one of them cannot be read (said)."""
        read = self.read_children(env, path, raw, key)
        if read is None:
            return None
        out, ok, named = read
        dedupe(named, self.errors)  # those read, and the names of those that were not
        return out if ok else None

    def read_children(
        self, env: _Env, path: PathKey, raw: Any, key: str
    ) -> tuple[list[NodeSpec], bool, list[NodeSpec]] | None:
        """The nodes listed under ``key`` that could be read, whether all could, and for
        the siblings' names: those read, with a stand-in for each one that could not be
        but names itself plainly (its duplicate name is said with its other problems)."""
        items = raw.get(key)
        if not isinstance(items, list) or not items:
            if not self.blank(env.doc, items):
                self.error(env.doc, (*path, key) if key in raw else path, f"needs a list of {key}")
            return None
        out: list[NodeSpec] = []
        named: list[NodeSpec] = []
        ok = True
        for i, item in enumerate(items):
            child = self.node(env, (*path, key, i), item)
            if child is not None:
                out.append(child)
                named.append(child)
                continue
            ok = False
            name = item.get("name") if isinstance(item, dict) else None
            if isinstance(name, str) and name_problem(name) is None:
                where = env.doc.locator.locate((*path, key, i))
                named.append(NodeSpec(str(item.get("type")), name, where, explicit_name=True))
        return out, ok, named

    def check_unused(self, doc: YamlDocument) -> None:
        """Check each subtree of ``doc`` that no call used, as far as it can be without
        its parameters' values (a use of one is not checked): its node types, keys,
        values and units, names and calls. A library of subtrees was "ok" with a typo in
        one not yet used. Read by a reader of its own, so that what it finds is added to
        the problems only (not the tree's files, blackboard or bounds)."""
        subtrees = doc.data.get("subtrees") if isinstance(doc.data, dict) else None
        if not isinstance(subtrees, dict) or self.too_deep or self.count > MAX_TREE_NODES:
            return  # past a bound the rest was not read: not said to be unused either
        side = type(self)(self.registry, self.robot, self.units_required, self.base_dir)
        side.docs, side.headers_read = dict(self.docs), set(self.headers_read)
        side.blackboard, side.blanked = dict(self.blackboard), set(self.blanked)
        side.board_unsure = _Names(self.board_unsure.names, every=self.board_unsure.every)
        total = 0
        for name, body in subtrees.items():
            ident = f"{doc.file}#{name}"
            if not isinstance(name, str) or ident in self.expanded | side.expanded:
                continue
            where: PathKey = ("subtrees", name)
            if not isinstance(body, dict):
                if not side.blank(doc, body):
                    side.error(doc, where, "a subtree is a mapping with 'root'")
                continue
            for key in body:
                if key not in _SUBTREE_KEYS and not side.blank(doc, key):
                    side.error(doc, (*where, key), unknown_key(key, _SUBTREE_KEYS))
            declared = side.declared_params(
                doc, (*where, "params"), body.get("params"), misspelt(body, "params", _SUBTREE_KEYS)
            )
            unknown = _Names(declared.names, every=declared.refused.every)
            env = _Env(doc, {}, (doc.file, ident), unknown=unknown, declared=declared.names)
            side.count = side.depth = 0
            side.tree(env, where, body)
            total += side.count
            if side.too_deep or side.count > MAX_TREE_NODES:
                break  # said once, as for the tree
            if total > MAX_TREE_NODES:
                break  # a thousand small subtrees that each call a big one: enough read
        said = {str(e) for e in self.errors}
        self.errors.extend(e for e in side.errors if str(e) not in said)
        self.blanked |= side.blanked

    def composite(
        self, env: _Env, path: PathKey, raw: Mapping[str, Any], spec: NodeSpec
    ) -> NodeSpec | None:
        """A sequence, selector or parallel: its options, then its children (read even
        when an option is refused: they do not depend on it)."""
        unbound = len(self.unbound)
        opts = self.subst(env, {k: v for k, v in raw.items() if k != "children"}, path)
        known = len(self.unbound) == unbound  # else an unknown value, said where it is
        params = self.options(env, path, spec.node_type, opts) if known else None
        kids = self.children(env, path, raw, "children")
        if params is None or kids is None:
            return None
        spec.params = params
        spec.children = kids
        if spec.node_type == "parallel" and params["selected"]:
            names = {c.name for c in kids}
            for s in params["selected"]:
                if s not in names:
                    self.error(
                        env.doc, (*path, "selected"), f"selected: no child named {_shown(s)}"
                    )
                    return None
        return spec

    def options(
        self, env: _Env, path: PathKey, kind: str, opts: Mapping[str, Any]
    ) -> dict[str, Any] | None:
        """A composite's options, checked; None after saying what is wrong."""
        if kind in ("sequence", "selector"):
            memory = opts.get("memory", kind == "sequence")
            if not isinstance(memory, bool):
                self.value_error(env, (*path, "memory"), "memory: must be true or false")
                return None
            return {"memory": memory}
        policy = opts.get("policy", "all")
        if policy not in ("all", "one", "selected"):
            self.value_error(env, (*path, "policy"), "policy: one of all, one, selected")
            return None
        sync = opts.get("synchronise", policy != "one")
        if not isinstance(sync, bool):
            self.value_error(env, (*path, "synchronise"), "synchronise: must be true or false")
            return None
        selected = opts.get("selected")
        if (policy == "selected") != (selected is not None):
            self.error(
                env.doc, path, "policy 'selected' and a 'selected' list of names go together"
            )
            return None
        if selected is not None and not (
            isinstance(selected, list) and selected and all(isinstance(s, str) for s in selected)
        ):
            self.value_error(env, (*path, "selected"), "selected: a list of child names")
            return None
        return {"policy": policy, "synchronise": sync, "selected": selected}

    def guard(
        self, env: _Env, path: PathKey, raw: Mapping[str, Any], spec: NodeSpec
    ) -> NodeSpec | None:
        read = self.read_children(env, path, raw, "conditions")
        conditions, ok, named = read if read is not None else ([], False, [])
        child = None
        if "child" not in raw:
            self.error(env.doc, path, "eternal_guard needs a 'child'")
        else:
            child = self.node(env, (*path, "child"), raw["child"])
        dedupe([*named, *([child] if child is not None else [])], self.errors)
        if not ok or child is None:
            return None
        spec.conditions = conditions
        spec.children = [child]
        return spec

    def subtree(
        self, env: _Env, path: PathKey, raw: Mapping[str, Any], spec: NodeSpec
    ) -> NodeSpec | None:
        doc = env.doc
        ref = raw.get("ref")
        if self.blank(doc, ref):
            return None  # YAML refused it (said there): which tree is meant is unknown
        if not isinstance(ref, str) or not ref:
            self.error(doc, (*path, "ref") if "ref" in raw else path, _ref_problem(raw))
            return None
        file_part, hash_sign, tree_name = ref.partition("#")
        own = doc.data.get("subtrees") if isinstance(doc.data, dict) else None
        if file_part.lower().endswith(".xml") and not (isinstance(own, dict) and ref in own):
            self.error(
                doc,
                (*path, "ref"),
                f"ref {_shown(ref)}: a BehaviorTree.CPP XML file; a subtree is a YAML tree"
                " file: convert it with pirate-bt import btcpp, and give the .yaml",
            )
            return None
        if file_part.lower().endswith((".yaml", ".yml")):  # Grip.YAML too, as `run` reads it
            base = Path(doc.file).parent if doc.file not in ("<dict>",) else self.base_dir
            target_doc = self.read_file(base / file_part, doc, (*path, "ref"))
            if target_doc is None or not self.header(target_doc):
                return None
            name = tree_name if hash_sign else ""
        elif hash_sign:
            self.error(doc, (*path, "ref"), f"ref {_shown(ref)}: write FILE.yaml#NAME or NAME")
            return None
        else:
            target_doc, name = doc, file_part
        target = target_doc.data
        if name:
            subtrees = target.get("subtrees") or {}
            if not isinstance(subtrees, dict) or name not in subtrees:
                if not isinstance(subtrees, dict) or name in map(str, subtrees):
                    return None  # header() said what is wrong with the subtrees
                close = self.close_names(name, [k for k in subtrees if isinstance(k, str)])
                hint = f"; did you mean {' or '.join(map(repr, close))}?" if close else ""
                hint += alike_note(name, close[0]) if len(close) == 1 else ""
                hint += _NOT_SUBSTITUTED if _dollar(name) and not hint else ""
                where = f" in {target_doc.file}" if target_doc is not doc else ""
                self.error(doc, (*path, "ref"), f"no subtree named {_shown(name)}{where}{hint}")
                return None
            body = subtrees[name]
            body_path: PathKey = ("subtrees", name)
            if not isinstance(body, dict):
                if not self.blank(target_doc, body):
                    self.error(target_doc, body_path, "a subtree is a mapping with 'root'")
                return None
            for key in body:
                if key not in _SUBTREE_KEYS and not self.blank(target_doc, key):
                    whose = "" if isinstance(key, str) else f"subtree {_shown(name)}: "
                    problem = whose + unknown_key(key, _SUBTREE_KEYS)
                    self.error(target_doc, (*body_path, key), problem)
        else:
            body, body_path = target, ()
        ident = f"{target_doc.file}#{name}" if name else target_doc.file
        self.expanded.add(ident)
        if ident in env.chain:
            loop = chain_text([*env.chain[env.chain.index(ident) :], ident])
            self.error(doc, (*path, "ref"), f"recursive subtree: {loop}")
            return None
        allowed = _SUBTREE_KEYS if name else _TOP_KEYS
        declared = self.declared_params(
            target_doc,
            (*body_path, "params"),
            body.get("params"),
            misspelt=misspelt(body, "params", allowed),
        )
        given = raw.get("params") or {}
        lost = _Names()  # given, but their values are unknown (said where they are)
        if not isinstance(given, dict):
            if not self.blank(doc, given):
                self.error(doc, (*path, "params"), "params: a mapping of name -> value")
            given, lost.every = {}, True
        for key in [k for k in given if not isinstance(k, str)]:  # a mapping's, from Python
            label = node_label("subtree", raw.get("name"), path, doc.file == "<dict>")
            self.error(doc, (*path, "params"), f"{label}: params: {key_not_text(key)}")
            given, lost.every = {k: v for k, v in given.items() if k != key}, True
        unbound = len(self.unbound)
        given = self.subst(env, given, (*path, "params"))
        for at in self.unbound[unbound:]:
            lost.add(str(at[len(path) + 1]))

        def given_at(name: str) -> SourceLocation:
            return doc.locator.locate((*path, "params", name))

        values, unknown = self.bind(doc, path, declared, given, given_at, in_file=True, lost=lost)
        # A value given here is reported here (params: {torque: 50 N*m}), unless it is a
        # value from further out passed on (params: {torque: $torque}): reported there.
        caller = {
            k: env.used.get((*path, "params", k), (k, given_at(k))) for k in given if k in values
        }
        inner = _Env(
            target_doc,
            values,
            (*env.chain, ident),
            caller,
            unknown=unknown,
            declared=declared.names,
        )
        result = self.tree(inner, body_path, body)
        if result is None:
            return None
        if spec.explicit_name:
            result.name = spec.name
            result.explicit_name = True
        result.called_at = spec.location  # the outermost call's, set last
        return result


_NOT_SUBSTITUTED = " (type, name and ref take no $parameter: they are written as they are)"


def _dollar(text: object) -> bool:
    """Whether ``text`` looks like a ``$parameter`` (not the literal ``$$``)."""
    return isinstance(text, str) and text.startswith("$") and not text.startswith("$$")


def _ref_problem(raw: Mapping[str, Any]) -> str:
    """What is wrong with a subtree call's ``ref`` that is no text or empty: it was
    *subtree needs a 'ref'* beside a ``ref: [a.yaml]`` the file has."""
    if "ref" not in raw:
        return "subtree needs a 'ref'"
    ref = raw["ref"]
    if ref is None or ref == "":
        written = "empty"
    elif isinstance(ref, list | dict):
        written = "a list" if isinstance(ref, list) else "a mapping"
    else:
        written = str(ref).lower() if isinstance(ref, bool) else shown(ref)
        if isinstance(ref, int | float) and not isinstance(ref, bool):
            written += " (a number: quote a name)"
    return f"ref: must be a subtree's name, FILE.yaml or FILE.yaml#NAME, not {written}"
