"""Validate YAML data with pydantic and say what is wrong in the file's own words.

:func:`validate_document` checks a :class:`~pirate_bt.yamlfile.YamlDocument` against a
pydantic model; :func:`validation_problems` and :func:`pydantic_errors` turn pydantic's
error locations (with its union-member tags) back into paths in the data and, through
the document's :class:`~pirate_bt.yamlfile.Locator`, into ``file:line:column``;
:func:`describe_error` words each error as the file would (``unknown key 'x'``,
``kind: 'gyro' is not one of angle, spring, imu``), never in the validator's words.
Split from :mod:`pirate_bt.yamlfile`, which reads the text.
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Iterable, Mapping, Sequence
from types import UnionType
from typing import Annotated, Any, TypeVar, Union, get_args, get_origin

from pydantic import BaseModel, ValidationError

from pirate_bt.errors import LocatedError, ValidationFailed, shown
from pirate_bt.yamlfile import VALUE_WORDS, Locator, PathKey, YamlDocument
from pirate_bt.yamlfile.alike import alike_note

__all__ = [
    "close_matches",
    "describe_error",
    "key_not_text",
    "pydantic_errors",
    "unique_errors",
    "validate_document",
    "validation_problems",
]

ModelT = TypeVar("ModelT", bound=BaseModel)


# What a value of each shape is called, for "should be ..." when no union branch fits.
_SHAPES = {
    "model_type": "a mapping of keys",
    "model_attributes_type": "a mapping of keys",
    "dict_type": "a mapping of keys",
    "list_type": "a list",
    "tuple_type": "a list",
    "set_type": "a list",
    "string_type": "text",
    "int_type": "a whole number",
    "int_parsing": "a whole number",
    "float_type": "a number",
    "float_parsing": "a number",
    "bool_type": "true or false",
    "bool_parsing": "true or false",
    "none_required": "empty",
}


def describe_error(error: Any) -> str:
    """One pydantic error as a short sentence, e.g. ``unknown key 'x'``."""
    msg = str(error["msg"])
    kind = error.get("type", "")
    loc = error.get("loc", ())
    if kind == "extra_forbidden" and loc:  # a key of any length (? KEY): cut short
        return f"unknown key {shown(loc[-1])}"
    if kind == "missing" and loc:
        return f"missing required key {shown(loc[-1])}"
    if kind == "invalid_key":  # "Keys should be strings": a mapping given from Python
        return key_not_text(error.get("input", loc[-1] if loc else None))
    if kind == "union_tag_not_found":  # a tagged union (``kind: angle``) without its tag
        return f"missing required key {_tag_key(error)!r}"
    if kind == "union_tag_invalid":  # the tags as text, not reprs (<SensorKind.IMU: 'imu'>)
        ctx = error.get("ctx") or {}
        tags = re.findall(r"'((?:[^'\\]|\\.)*)'", str(ctx.get("expected_tags", "")))
        return f"{_tag_key(error)}: {shown(ctx.get('tag'))} is not one of {', '.join(tags)}"
    if kind in ("literal_error", "enum") and "input" in error:
        # "Input should be 'front' or 'rear'": the choices as text, and what was written
        expected = str((error.get("ctx") or {}).get("expected", ""))
        choices = re.findall(r"'((?:[^'\\]|\\.)*)'", expected) or [
            c for c in re.split(r",\s*|\s+or\s+", expected) if c
        ]
        if choices:
            msg = f"{_as_written(error['input'])} is not one of {', '.join(choices)}"
    elif kind == "finite_number" and "input" in error:
        msg = f"must be a finite number, not {_as_written(error['input'])}"
    for prefix in ("Value error, ", "Assertion failed, "):
        if msg.startswith(prefix):
            msg = msg[len(prefix) :]
    if kind in ("model_type", "model_attributes_type", "dict_type"):
        # pydantic's own wording names classes ("instance of Motor"): say the shape.
        msg = f"should be {_SHAPES[kind]}"
    elif kind in ("too_short", "too_long") and error.get("ctx"):
        # "List should have at least 1 item after validation, not 0", named by its key
        ctx = error["ctx"]
        bound = f"at least {ctx.get('min_length')}" if kind == "too_short" else ""
        bound = bound or f"at most {ctx.get('max_length')}"
        msg = f"must have {bound} item{'' if bound.endswith(' 1') else 's'}"
        if ctx.get("actual_length") is not None:
            msg += f", not {ctx['actual_length']}"
        keys = [p for p in loc if isinstance(p, str)]
        return f"{keys[-1]}: {msg}" if keys else msg
    elif kind in _TEXT_SHAPE and "input" in error:
        # "String should match pattern '^[a-z]...'": the key, what was written, in words
        keys = [p for p in loc if isinstance(p, str)]
        return f"{keys[-1] + ': ' if keys else ''}{_text_shape(kind, error)}"
    elif kind in _IN_WORDS and "input" in error:
        # "Input should be a valid integer": what to write, and what was written
        msg = f"must be {_IN_WORDS[kind]}, not {_as_written(error['input'])}"
    if (
        kind in ("literal_error", "enum", "finite_number")
        or kind.endswith("_type")
        or kind.endswith("_parsing")
    ):
        where = ".".join(str(p) for p in loc if not isinstance(p, int))
        if where:
            return f"{where.split('.')[-1]}: {msg}"
    return msg


_IN_WORDS = {
    "int_parsing": VALUE_WORDS["int"],
    "int_type": VALUE_WORDS["int"],
    "int_from_float": VALUE_WORDS["int"],
    "float_parsing": VALUE_WORDS["float"],
    "float_type": VALUE_WORDS["float"],
    "bool_parsing": VALUE_WORDS["bool"],
    "bool_type": VALUE_WORDS["bool"],
    "string_type": "text",
    "list_type": "a list",
}
"""pydantic's error types whose words (``Input should be a valid integer``) are said in
the library's: what the value must be, and the value as written."""


_TEXT_SHAPE = ("string_pattern_mismatch", "string_too_short", "string_too_long")

_PATTERN_WORDS = {
    r"^[A-Za-z_][A-Za-z0-9_]*$": ("an identifier (ASCII letters, digits and _, not first a digit)"),
    r"^/?[A-Za-z_][A-Za-z0-9_./]*$": (
        "a blackboard key (ASCII letters, digits, _, . and /, not first a digit)"
    ),
    r"^(/?[A-Za-z_][A-Za-z0-9_/]*)?$": (
        "a blackboard key (ASCII letters, digits, _ and /, not first a digit) or empty"
    ),
    r"^[a-z][a-z0-9_]*$": "lower_snake_case (the pattern [a-z][a-z0-9_]*)",
    r"^[A-Za-z][A-Za-z0-9_-]*$": "a letter, then letters, digits, _ and -",
}
"""The text patterns of the models, in words (``key: 'a b' must be an identifier``);
a pattern not here is shown as it is."""


def _text_shape(kind: str, error: Any) -> str:
    """A text of the wrong form or length, in the file's words: what was written and
    what it must be (pydantic says *String should match pattern '^[a-z]...'*)."""
    ctx = error.get("ctx") or {}
    written = _as_written(error["input"])
    if kind == "string_pattern_mismatch":
        pattern = str(ctx.get("pattern", ""))
        return f"{written} must be {_PATTERN_WORDS.get(pattern, f'text of the pattern {pattern}')}"
    if kind == "string_too_short" and ctx.get("min_length") == 1:
        return "must not be empty"
    bound = "at least" if kind == "string_too_short" else "at most"
    length = ctx.get("min_length" if kind == "string_too_short" else "max_length")
    actual = len(error["input"]) if isinstance(error["input"], str) else None
    return (
        f"must be {bound} {length} characters long, not {actual if actual is not None else written}"
    )


def key_not_text(key: object) -> str:
    """What a key that is not text is told (``key 5 must be text``): only a mapping given
    from Python has one (YAML reads every key of a file as text), so it is shown as
    Python writes it. The one wording of the tree reader and every pydantic model."""
    return f"key {shown(key)} must be text"


def _as_written(value: Any) -> str:
    """A value as a YAML file writes it (``true``, ``null``), else :func:`shown`."""
    if isinstance(value, bool):
        return "true" if value else "false"
    return "null" if value is None else shown(value)


def _tag_key(error: Any) -> str:
    """The key that tags the branches of a union (``kind``), from a tag error."""
    return str((error.get("ctx") or {}).get("discriminator", "kind")).strip("'\"")


_NO_DATA = object()


def _real_path(data: Any, loc: Sequence[str | int], kind: str) -> tuple[PathKey, bool, bool]:
    """``loc`` without pydantic's union-member tags; whether it had any; whether it ends on one.

    pydantic names the branch of a union it tried inside the location
    (``list[function-after[_check(), Comparison]]``). Walking the input data
    tells which elements are real keys and indices; the others are tags, except
    the last element of a missing or unknown key, which names the key.
    """
    if data is _NO_DATA:
        return tuple(loc), False, False
    path: list[str | int] = []
    tagged = ends_on_tag = False
    current = data
    for i, element in enumerate(loc):
        last = i == len(loc) - 1
        if (isinstance(current, Mapping) and element in current) or (
            isinstance(current, list)
            and isinstance(element, int)
            and not isinstance(element, bool)
            and 0 <= element < len(current)
        ):
            path.append(element)
            current = current[element]  # type: ignore[index]
        elif last and kind in ("missing", "extra_forbidden"):
            path.append(element)
        else:
            tagged = True
            ends_on_tag = last
    return tuple(path), tagged, ends_on_tag


def _value_at(data: Any, path: PathKey) -> Any:
    """The value at ``path`` in ``data``, or ``_NO_DATA``."""
    for element in path:
        try:
            data = data[element]
        except (KeyError, IndexError, TypeError):
            return _NO_DATA
    return data


def validation_problems(
    exc: ValidationError, data: Any = _NO_DATA, model: Any = None
) -> list[tuple[PathKey, str]]:
    """pydantic's errors as ``(path into data, message)``: one clear message per problem.

    Union branches that failed only because the value has another shape (the
    list branch of "a comparison or a list of comparisons" given a mapping) are
    dropped when another branch says what is wrong; when every branch failed on
    shape, one message says which shapes are allowed. Locations and messages
    never carry pydantic's internal names.

    Args:
        exc: The validation error.
        data: The input that was validated (to tell real keys from union tags);
            without it every location element is taken as a key.
        model: The model validated, to name a known key close to an unknown one
            (``seed:`` for ``seeds:``); without it only a missing required key is.
    """
    entries = []
    keys: list[tuple[PathKey, str]] = []
    for e in exc.errors():
        kind = str(e.get("type", ""))
        if kind == "string_type" and e["loc"][-1:] == ("[key]",):  # a key that is not text
            path, _, _ = _real_path(data, e["loc"][:-2], kind)
            name = next((f"{p}: " for p in reversed(path) if isinstance(p, str)), "")
            keys.append((path, f"{name}{key_not_text(e.get('input'))}"))
            continue
        path, tagged, ends_on_tag = _real_path(data, e["loc"], kind)
        if kind == "invalid_key" and path and isinstance(_value_at(data, path[:-1]), Mapping):
            path = path[:-1]  # at the mapping that holds it: the message names the key
        entries.append((path, tagged and ends_on_tag and kind in _SHAPES, tagged, e))
    # Paths where some union branch failed on something other than shape, or further in
    # (the value had that branch's shape: a mapping for a comparison, a problem in its
    # 'value' is the one to say, not that it might have been a list).
    substantive = [path for path, shape, tagged, _ in entries if tagged and not shape]
    inner = [path for path, _, tagged, _ in entries if tagged]
    shapes: dict[PathKey, list[str]] = {}
    for path, shape, _, e in entries:
        if shape:
            shapes.setdefault(path, []).append(_SHAPES[str(e["type"])])
    out: list[tuple[PathKey, str]] = []
    for path, shape, _, e in entries:
        if shape:
            if any(p[: len(path)] == path for p in substantive) or any(
                len(p) > len(path) and p[: len(path)] == path for p in inner
            ):
                continue  # another branch of the same union says what is wrong
            name = next((str(p) for p in reversed(path) if isinstance(p, str)), "value")
            out.append((path, f"{name}: should be {' or '.join(dict.fromkeys(shapes[path]))}"))
            continue
        if e["type"] == "union_tag_invalid":  # located at the tag's value, shown as written
            path = (*path, _tag_key(e))
            value = _value_at(data, path)
            if value is not _NO_DATA:
                e = {**e, "ctx": {**e["ctx"], "tag": value}}
        bound = _bound_as_written(e, _value_at(data, path), path)
        out.append((path, bound or describe_error({**e, "loc": path})))
    return list(dict.fromkeys([*keys, *_misspelt(out, entries, model, data)]))


def _misspelt(
    out: list[tuple[PathKey, str]],
    entries: list[tuple[PathKey, bool, bool, Any]],
    model: Any = None,
    data: Any = _NO_DATA,
) -> list[tuple[PathKey, str]]:
    """A key written close to a required key that is missing beside it (``torq:`` for
    ``torque:``) as one problem, ``unknown key 'torq' (did you mean 'torque'?)``, where
    it was two: the unknown key and the missing one. With ``model``, an unknown key
    close to one known key of the model at its place (an optional one: ``distanse:``
    for ``distance:``, ``seed:`` for ``seeds:``) says so too."""
    unknown = {path for path, _, _, e in entries if e.get("type") == "extra_forbidden"}
    missing = {path for path, _, _, e in entries if e.get("type") == "missing"}
    if unknown and not missing and model is not None:
        return _close_to_known(out, unknown, model, data)
    if not unknown or not missing:
        return out
    meant: dict[PathKey, PathKey] = {}
    for path in unknown:
        near = [
            m
            for m in missing
            if m[:-1] == path[:-1] and isinstance(m[-1], str) and isinstance(path[-1], str)
        ]
        names = [str(m[-1]) for m in near]
        close = close_matches(str(path[-1]), names, n=2, cutoff=0.7)
        if len(close) == 1 and close[0] not in {str(m[-1]) for m in meant.values()}:
            meant[path] = next(m for m in near if m[-1] == close[0])
    taken = set(meant.values())
    said: list[tuple[PathKey, str]] = []
    for path, message in out:
        if path in taken and message.startswith("missing required key"):
            continue
        if path in meant and message.startswith("unknown key"):
            message = _did_you_mean(message, str(path[-1]), str(meant[path][-1]))
        said.append((path, message))
    return said if model is None else _close_to_known(said, unknown - set(meant), model, data)


def _did_you_mean(message: str, written: str, meant: str) -> str:
    """``message`` with its *did you mean*, and which character differs where the two
    names look alike (``'durаtion'``, a Cyrillic а, for ``duration``)."""
    note = alike_note(written, meant)[2:-1]  # its own parentheses dropped
    return f"{message} (did you mean {shown(meant)}?{' ' + note if note else ''})"


def _close_to_known(
    out: list[tuple[PathKey, str]], unknown: set[PathKey], model: Any, data: Any
) -> list[tuple[PathKey, str]]:
    """Each unknown key's message with the one known key of ``model`` at its place it
    is close to, if one stands out (and it is not written beside it already)."""
    meant: dict[PathKey, str] = {}
    for path in unknown:
        if not path or not isinstance(path[-1], str):
            continue
        beside = _value_at(data, path[:-1])
        written = set(beside) if isinstance(beside, Mapping) else set()
        best = _nearest(path[-1], field_names_at(model, path[:-1]) - written)
        if best is not None:
            meant[path] = best
    if not meant:
        return out
    return [
        (path, _did_you_mean(message, str(path[-1]), meant[path]))
        if path in meant and message.startswith("unknown key") and "did you mean" not in message
        else (path, message)
        for path, message in out
    ]


def close_matches(
    word: str, possibilities: Iterable[str], n: int = 3, cutoff: float = 0.6
) -> list[str]:
    """:func:`difflib.get_close_matches`, asked only of the possibilities whose length
    alone does not keep them under ``cutoff`` (a ratio is at most twice the shorter
    length over both): the same answer, but a hostile file's name of 13 MB is no longer
    indexed character by character (600 MB) to be compared with names of ten."""
    size = len(word)
    fit = [p for p in possibilities if _may_reach(size, len(p), cutoff)]
    return difflib.get_close_matches(word, fit, n, cutoff) if fit else []


def _may_reach(one: int, other: int, cutoff: float) -> bool:
    """Whether texts of these lengths can be ``cutoff`` alike (difflib's ratio)."""
    total = one + other
    return total == 0 or 2.0 * min(one, other) / total >= cutoff


def _nearest(written: str, known: set[str]) -> str | None:
    """The known key ``written`` is closest to, when one stands out: at least 0.7 alike
    and clearly nearer than the next (``distanse``: ``distance``, not ``distance_key``)."""
    scored = sorted(
        (
            (difflib.SequenceMatcher(None, written, k).ratio(), k)
            for k in known
            # one under 0.6 is neither the one (0.7) nor 0.1 behind it
            if _may_reach(len(written), len(k), 0.6)
        ),
        reverse=True,
    )
    if not scored or scored[0][0] < 0.7:
        return None
    if len(scored) > 1 and scored[0][0] - scored[1][0] < 0.1:
        return None
    return scored[0][1]


def field_names_at(model: Any, path: PathKey) -> set[str]:
    """The keys the pydantic model ``model`` takes at ``path`` into its data: its own
    fields' names and aliases at ``()``, a field's model's further in (through
    optional values, unions, lists and mappings of text keys); empty where no model
    is known."""
    kinds = [model]
    for part in path:
        inner: list[Any] = []
        for kind in kinds:
            for ann in _branches(kind):
                fields = getattr(ann, "model_fields", None) if isinstance(ann, type) else None
                if isinstance(part, str) and fields is not None:
                    field = fields.get(part) or next(
                        (f for f in fields.values() if f.alias == part), None
                    )
                    if field is not None:
                        inner.append(field.annotation)
                    continue
                args = get_args(ann)
                origin = get_origin(ann)
                if isinstance(part, int) and origin in (list, tuple, Sequence) and args:
                    inner.append(args[0])
                elif isinstance(part, str) and origin in (dict, Mapping) and len(args) == 2:
                    inner.append(args[1])
        kinds = inner
    names: set[str] = set()
    for kind in kinds:
        for ann in _branches(kind):
            fields = getattr(ann, "model_fields", None) if isinstance(ann, type) else None
            for name, field in (fields or {}).items():
                names.add(field.alias or name)
    return names


def _branches(ann: Any) -> list[Any]:
    """``ann`` without ``Annotated`` and ``Optional``, a union as its members."""
    while get_origin(ann) is Annotated:
        ann = get_args(ann)[0]
    if get_origin(ann) in (Union, UnionType):
        return [b for a in get_args(ann) for b in _branches(a)]
    return [ann]


_BOUNDS = {"lt": "less than", "le": "at most", "gt": "more than", "ge": "at least"}


def _bound_as_written(error: Any, value: Any, path: PathKey) -> str | None:
    """A number's bound in the unit the file wrote it in (``angle: must be at most 90
    deg, not 180 deg``), not pydantic's SI (``less than or equal to 1.5707963...``);
    a plain number's as it is (``attempts: must be at least 1, not 0``)."""
    from pirate_bt.units import in_unit_of

    ctx = error.get("ctx") or {}
    plain = isinstance(value, int | float) and not isinstance(value, bool)
    for key, words in _BOUNDS.items():
        bound = ctx.get(key)
        limit = in_unit_of(ctx[key], value) if key in ctx else None
        if limit is None and plain and isinstance(bound, int | float):
            # a count or a fraction: ``attempts: must be at least 1``
            limit = str(bound) if isinstance(bound, int) else f"{bound:.10g}"
        if limit is not None:
            name = next((str(p) for p in reversed(path) if isinstance(p, str)), "value")
            return f"{name}: must be {words} {limit}, not {shown(value) if plain else value}"
    return None


def pydantic_errors(
    exc: ValidationError, locator: Locator, data: Any = _NO_DATA, model: Any = None
) -> list[LocatedError]:
    """Translate pydantic's errors into located ones, in file order.

    Args:
        exc: The validation error.
        locator: Where each path of the file was written.
        data: The validated input, to tell keys from pydantic's union tags.
        model: The model validated (a key close to one of its known keys says so).
    """
    errors = [locator.error(path, msg) for path, msg in validation_problems(exc, data, model)]
    errors.sort(key=lambda e: (e.location.line, e.location.column))
    return unique_errors(errors)


def unique_errors(errors: Iterable[LocatedError]) -> list[LocatedError]:
    """``errors`` without repeats (the same message at the same place), order kept."""
    seen: set[str] = set()
    out: list[LocatedError] = []
    for e in errors:
        if str(e) not in seen:
            seen.add(str(e))
            out.append(e)
    return out


def validate_document(
    doc: YamlDocument, model: type[ModelT], what: str, context: dict[str, Any]
) -> ModelT:
    """Validate a loaded YAML document as ``model``, every problem at its place.

    The shape and each field come from pydantic; then, when the model has a
    ``cross_check()`` returning ``(path, message)`` pairs (rules that span the
    file), those are located too; a triple ``(path, message, first_path)`` (a
    duplicate) adds ``(first at FILE:LINE:COLUMN)``. The model should defer its
    own cross-check raising when ``context`` says ``defer_cross_checks``.

    Args:
        doc: The loaded document.
        model: The pydantic model of the file kind.
        what: What people call the file kind ("a pipe network").
        context: The pydantic validation context (``units_required`` for files).

    Raises:
        ValidationFailed: every problem, in file order.
    """
    if not isinstance(doc.data, dict):
        raise ValidationFailed([doc.locator.error((), f"{what} must be a mapping of keys")])
    _refuse_another_kind(doc, model, what)
    try:
        value = model.model_validate(doc.data, context=context)
    except ValidationError as exc:
        raise ValidationFailed(pydantic_errors(exc, doc.locator, doc.data, model)) from None
    cross_check = getattr(value, "cross_check", None)
    problems: list[tuple[Any, ...]] = cross_check() if callable(cross_check) else []
    if problems:
        raise ValidationFailed(
            sorted(
                (_cross_error(doc.locator, *problem) for problem in problems),
                key=lambda e: (e.location.line, e.location.column),
            )
        )
    return value


_COMMON_KEYS = frozenset({"schema_version", "name", "description"})


def _refuse_another_kind(doc: YamlDocument, model: type[BaseModel], what: str) -> None:
    """One line for a file of another kind (a tree given as a robot description): it
    has none of the model's keys but those every kind has, and keys the model does not
    take; every missing and unknown key was a line of its own."""
    fields = model.model_fields
    required = [name for name, field in fields.items() if field.is_required()]
    own = set(fields) - _COMMON_KEYS
    keys = [str(k) for k in doc.data]
    unknown = [k for k in keys if k not in fields]
    if not required or not unknown or any(k in own for k in keys):
        return
    from pirate_bt.filekinds import KINDS

    looks = next(
        (
            f"it looks like a {kind.title} (it has {marker!r})"
            for kind in KINDS.values()
            for marker in kind.marker_keys
            if marker in doc.data
        ),
        "a file of another kind?",
    )
    raise ValidationFailed(
        [
            doc.locator.error(
                (),
                f"not {what}: it has none of its keys ({', '.join(sorted(own)[:6])}, ...) and"
                f" keys it does not take ({', '.join(unknown[:4])}): {looks}",
            )
        ]
    )


def _cross_error(
    locator: Locator, path: PathKey, message: str, first: PathKey | None = None
) -> LocatedError:
    """A cross-check's problem at ``path``; a duplicate names its ``first`` place too."""
    if first is not None:
        message = f"{message} (first at {locator.locate(first)})"
    return locator.error(path, message)
