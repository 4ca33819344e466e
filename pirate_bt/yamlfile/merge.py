"""Merge keys (``<<``) as YAML's merge key type has them, whatever PyYAML's version.

``<<: [*a, *b]`` merges ``a`` and ``b`` in turn, and "keys in mapping nodes earlier in
the sequence override keys specified in later mapping nodes"; keys written beside the
``<<`` override both. PyYAML 6.0.2 and later keep the first of two merged keys only
when the two key texts are the very same Python object (``id(key)``): a one-letter key
is (CPython shares those), ``duration`` is not, so ``<<: [*slow, *fast]`` took
``fast``'s duration and the first mapping's value won for ``x`` but not for ``xy``.
Every editor and YAML tool reads the first mapping's, and so does
:meth:`pirate_bt.yamlfile.Locator.locate`, which said a problem in the value used at
the first mapping that has the key.
"""

from __future__ import annotations

import yaml
from yaml.constructor import ConstructorError, SafeConstructor
from yaml.nodes import MappingNode, Node, SequenceNode

__all__ = ["MERGE_TAG", "SpecMergeLoader"]

MERGE_TAG = "tag:yaml.org,2002:merge"
_VALUE_TAG = "tag:yaml.org,2002:value"


class _SpecMerge(SafeConstructor):
    def flatten_mapping(self, node: MappingNode) -> None:
        """Put the merged pairs before ``node``'s own, the earliest mapping's last, so
        that building the mapping (a later pair overrides) keeps the earliest's value
        and ``node``'s own over both."""
        merged: list[list[tuple[Node, Node]]] = []
        index = 0
        while index < len(node.value):
            key_node, value_node = node.value[index]
            if key_node.tag == MERGE_TAG:
                del node.value[index]
                if isinstance(value_node, MappingNode):
                    sources: list[Node] = [value_node]
                elif isinstance(value_node, SequenceNode):
                    sources = list(value_node.value)
                else:
                    raise ConstructorError(
                        "while constructing a mapping",
                        node.start_mark,
                        "expected a mapping or list of mappings for merging, but found"
                        f" {value_node.id}",
                        value_node.start_mark,
                    )
                for source in sources:
                    if not isinstance(source, MappingNode):
                        raise ConstructorError(
                            "while constructing a mapping",
                            node.start_mark,
                            "expected a mapping for merging, but found"
                            f" {getattr(source, 'id', 'a node')}",
                            source.start_mark,
                        )
                    self.flatten_mapping(source)
                    merged.append(list(source.value))
            else:
                if key_node.tag == _VALUE_TAG:
                    key_node.tag = "tag:yaml.org,2002:str"
                index += 1
        if merged:
            node.value = [pair for pairs in reversed(merged) for pair in pairs] + node.value


_Base: type[yaml.SafeLoader] = getattr(yaml, "CSafeLoader", yaml.SafeLoader)

SpecMergeLoader: type[yaml.SafeLoader] = type("SpecMergeLoader", (_SpecMerge, _Base), {})
"""PyYAML's safe loader (libyaml's when PyYAML was built with it), merging as YAML does."""
