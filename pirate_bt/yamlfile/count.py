"""A file of more values than any file kind holds, refused before it is composed.

:func:`pirate_bt.yamlfile.load_yaml_text` refuses a document of more than
:data:`MAX_VALUES` values once PyYAML has composed its node graph, which costs about
1 kB a value: a 7 MB flow mapping of 600,000 keys took 1.2 GB of memory and 30 s
before it was said to hold too many. :func:`refuse_too_many_values` counts a large
text's values on PyYAML's event stream, which holds one event at a time, and refuses
it there with the same words at the same place: the first mapping or list to end
with more than :data:`MAX_VALUES` values in it (itself counted; an alias counted once,
as what it expands to is checked on the composed graph).
"""

from __future__ import annotations

from typing import Any

import yaml

from pirate_bt.errors import LocatedError, SourceLocation, ValidationFailed

__all__ = ["MAX_VALUES", "refuse_too_many_values"]

MAX_VALUES = 100_000
"""As :data:`pirate_bt.yamlfile.MAX_NODES`."""

_VALUE_EVENTS = (
    yaml.ScalarEvent,
    yaml.AliasEvent,
    yaml.MappingStartEvent,
    yaml.SequenceStartEvent,
)
_END_EVENTS = (yaml.MappingEndEvent, yaml.SequenceEndEvent)


def refuse_too_many_values(text: str, loader: type[yaml.SafeLoader], file: str) -> None:
    """Raise the ``ValidationFailed`` of a text holding more than :data:`MAX_VALUES`
    values, at the first mapping or list to end with more; a text too short to hold
    that many (each value takes at least one character) is not read. A text YAML
    cannot read is left to the composer, which says where."""
    if len(text) <= MAX_VALUES:
        return
    count = 0
    opened: list[tuple[int, Any]] = []  # (values before it, where it starts: its mark)
    try:
        for event in yaml.parse(text, Loader=loader):
            if isinstance(event, _VALUE_EVENTS):
                count += 1
                if isinstance(event, yaml.MappingStartEvent | yaml.SequenceStartEvent):
                    opened.append((count - 1, event.start_mark))
            elif isinstance(event, _END_EVENTS) and opened:
                before, mark = opened.pop()
                if count - before > MAX_VALUES:
                    raise ValidationFailed(
                        [
                            LocatedError(
                                f"this holds more than {MAX_VALUES} values; a file this large"
                                " is not one a person writes",
                                SourceLocation(file, mark.line + 1, mark.column + 1),
                            )
                        ]
                    )
    except yaml.YAMLError:
        return
