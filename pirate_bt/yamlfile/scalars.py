"""YAML scalars as YAML 1.2 and an editor read them, where PyYAML reads YAML 1.1.

Split from :mod:`pirate_bt.yamlfile` (which applies these while it walks a composed
document): the tags of plain values, what a value of an explicit ``!!int``,
``!!bool`` or ``!!float`` tag must be (:func:`unfit`), the YAML 1.1 readings that
differ from YAML 1.2 (:func:`yaml11_number`: a base-60 number, an octal one) and
the tags of values that are no JSON value (:func:`not_json`).
"""

from __future__ import annotations

import re

import yaml

from pirate_bt.errors import LocatedError, SourceLocation, shown

__all__ = [
    "BOOL_TAG",
    "FLOAT_TAG",
    "INT_TAG",
    "NOT_JSON",
    "NULL_TAG",
    "STR_TAG",
    "TEXT_KEYS",
    "TIMESTAMP_TAG",
    "VALUE_WORDS",
    "TextDumper",
    "dump_yaml",
    "node_mark",
    "not_json",
    "plain_reads_as_number",
    "unfit",
    "yaml11_number",
]

INT_TAG = "tag:yaml.org,2002:int"
BOOL_TAG = "tag:yaml.org,2002:bool"
STR_TAG = "tag:yaml.org,2002:str"
TIMESTAMP_TAG = "tag:yaml.org,2002:timestamp"
FLOAT_TAG = "tag:yaml.org,2002:float"
NULL_TAG = "tag:yaml.org,2002:null"
TEXT_KEYS = (BOOL_TAG, INT_TAG, FLOAT_TAG, NULL_TAG, TIMESTAMP_TAG)
"""What YAML 1.1 reads a plain key as (``on``, ``1``, ``1.5``, ``~``, a date): a key is
its text, in every file kind (``1:`` is the key ``'1'``, as ``"1":`` is)."""
VALUE_WORDS = {"bool": "true or false", "int": "a whole number", "float": "a number"}
"""What a value of each YAML type must be, in the words of every file kind's messages."""
_TAGGED = {f"tag:yaml.org,2002:{kind}": words for kind, words in VALUE_WORDS.items()}
"""What a value tagged ``!!bool``, ``!!int`` or ``!!float`` must be: PyYAML builds
``!!int abc`` with a bare ValueError (``!!bool 3`` a KeyError), located nowhere."""
_BUILD = yaml.constructor.SafeConstructor()
_SEXAGESIMAL = re.compile(r"[-+]?[0-9][0-9_]*(:[0-5]?[0-9])+(\.[0-9_]*)?")
"""A YAML 1.1 base-60 number (``1:30`` is 90), which YAML 1.2 reads as text."""
_OCTAL = re.compile(r"[-+]?0[0-7_]+")
"""A YAML 1.1 octal number (``010`` is 8), which YAML 1.2 reads as 10."""
_FLOAT_12 = re.compile(r"[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?")
"""A YAML 1.2 (core schema) number; those YAML 1.1 reads as text (``1e3``) are numbers."""
NOT_JSON: dict[str, str] = {
    "tag:yaml.org,2002:binary": "!!binary (bytes)",
    "tag:yaml.org,2002:set": "!!set",
    "tag:yaml.org,2002:omap": "!!omap",
    "tag:yaml.org,2002:pairs": "!!pairs",
}
"""Tags whose values are no JSON value (every file kind is described by a JSON Schema);
a check would see them as something else (bytes pass as text) and a writer fails on them."""


def node_mark(node: yaml.Node) -> tuple[int, int]:
    return node.start_mark.line + 1, node.start_mark.column + 1


def _implicit(tag: str) -> re.Pattern[str]:
    """The pattern YAML 1.1 reads a plain value's text as ``tag`` by."""
    return next(
        pattern
        for resolvers in yaml.resolver.Resolver.yaml_implicit_resolvers.values()
        for resolved, pattern in resolvers
        if resolved == tag
    )


_WRITTEN = {
    NULL_TAG: ("null, ~ or nothing", _implicit(NULL_TAG)),
    TIMESTAMP_TAG: ("a date such as 2001-12-14", yaml.constructor.SafeConstructor.timestamp_regexp),
}
"""What a value tagged ``!!null`` or ``!!timestamp`` must be written as: PyYAML builds
``!!null main`` as null whatever its text (a node's ``name: !!null main`` was no name,
a parameter's ``default: !!null 5 s`` no default, without a word) and takes any text for
``!!timestamp``."""


def unfit(node: yaml.ScalarNode, file: str) -> LocatedError | None:
    """A value whose explicit tag its text does not fit (``!!int abc``, ``!!bool 3``,
    ``!!null main``, ``!!timestamp soon``). A date, tagged or not, becomes the text
    written (YAML 1.2 reads it so, and no file kind has a date)."""
    if node.tag in _WRITTEN:
        words, pattern = _WRITTEN[node.tag]
        if not pattern.match(node.value) or "\n" in node.value:
            return LocatedError(
                f"a YAML {_short(node.tag)} value is {words}, not {shown(node.value)}",
                SourceLocation(file, *node_mark(node)),
            )
        if node.tag == TIMESTAMP_TAG:
            node.tag = STR_TAG
        return None
    if node.tag not in _TAGGED:
        return None
    try:
        _BUILD.yaml_constructors[node.tag](_BUILD, node)
    except (ValueError, KeyError, IndexError):
        tag = node.tag.rsplit(":", 1)[-1]
        return LocatedError(
            f"a YAML !!{tag} value is {_TAGGED[node.tag]}, not {shown(node.value)}",
            SourceLocation(file, *node_mark(node)),
        )
    return None


def _short(tag: str) -> str:
    return "!!" + tag.rsplit(":", 1)[-1]


def yaml11_number(node: yaml.Node, file: str) -> LocatedError | None:
    """A plain number that YAML 1.1 reads other than as written (YAML 1.2 and editors
    read it as written): ``1:30`` (base 60, 90) is retagged as the text written;
    ``010`` (octal, 8) is refused, as is; ``1e3``, ``1E3``, ``1.0e3`` and ``-.5``
    (text in YAML 1.1, which wants a dot and a signed exponent) are retagged as numbers."""
    if not isinstance(node, yaml.ScalarNode) or node.style:
        return None  # quoted or a block: text as written; plain is "" (libyaml) or None
    if node.tag == STR_TAG and plain_reads_as_number(node.value):
        # (``09``, no octal in YAML 1.1, stays the text it was: not a leading-zero int)
        node.tag = FLOAT_TAG
        return None
    if node.tag not in (INT_TAG, FLOAT_TAG):
        return None
    if _SEXAGESIMAL.fullmatch(node.value):
        node.tag = STR_TAG
        return None
    if not _OCTAL.fullmatch(node.value):
        return None
    sign = "-" if node.value.startswith("-") else ""
    digits = sign + (node.value.lstrip("+-").replace("_", "").lstrip("0") or "0")
    octal = int(node.value.replace("_", ""), 8)
    return LocatedError(
        f"{node.value} has a leading zero, which YAML 1.1 reads as an octal number"
        f" ({octal}): write {digits}, or quote it for text",
        SourceLocation(file, *node_mark(node)),
    )


def plain_reads_as_number(text: str) -> bool:
    """Whether ``text``, written plain, is read back as a number here but not by PyYAML's
    writer, which decides by YAML 1.1 (``1e3``): such text must be written quoted."""
    return _FLOAT_12.fullmatch(text) is not None and not text.lstrip("+-").isdigit()


class TextDumper(yaml.SafeDumper):
    """PyYAML's safe writer, with text that this package's files read as a number
    (``1e3``, ``-.5``: YAML 1.2) written quoted, so a written file reads back as
    written; PyYAML's own writer decides by YAML 1.1 and leaves it plain."""


def _represent_str(dumper: yaml.SafeDumper, value: str) -> yaml.Node:
    style = "'" if plain_reads_as_number(value) else None
    return dumper.represent_scalar(STR_TAG, value, style=style)


TextDumper.add_representer(str, _represent_str)


def dump_yaml(data: object, **options: object) -> str:
    """``data`` as YAML text that the package's loader reads back as ``data``
    (:class:`TextDumper`); ``options`` are :func:`yaml.dump`'s."""
    text: str = yaml.dump(data, Dumper=TextDumper, **options)  # type: ignore[call-overload]
    return text


def not_json(node: yaml.Node, file: str) -> LocatedError:
    return LocatedError(
        f"a YAML {NOT_JSON[node.tag]} value is not allowed here: write text, a number,"
        " a list or a mapping",
        SourceLocation(file, *node_mark(node)),
    )
