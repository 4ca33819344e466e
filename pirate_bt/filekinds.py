"""The kinds of file a user touches, and how each is recognised, validated and described.

One table, :data:`KINDS`, maps a kind name to its loader and schema. ``pirate-bt
validate`` and ``pirate-bt schema`` read it, and each later layer (trees, pipe
networks, routes) adds its row here, so the CLI never grows special cases.
Loaders are named as ``module:function`` and imported only when used.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pirate_bt.errors import InputError, LocatedError, SourceLocation, ValidationFailed

__all__ = ["KINDS", "FileKind", "detect_kind", "get_kind", "json_schema", "validate_file"]


@dataclass(frozen=True)
class FileKind:
    """One kind of user file.

    Attributes:
        name: The kind's name on the command line (``pirate-bt schema NAME``).
        title: What people call it.
        marker_keys: Top-level YAML keys that identify the kind.
        suffixes: File suffixes that identify the kind without reading it.
        loader: ``module:function`` taking a path and returning the validated object.
        schema: ``module:function`` returning the JSON Schema as a dict.
    """

    name: str
    title: str
    marker_keys: tuple[str, ...]
    suffixes: tuple[str, ...]
    loader: str
    schema: str

    def load(self, path: str | Path, **options: Any) -> Any:
        return _resolve(self.loader)(path, **options)

    def json_schema(self) -> dict[str, Any]:
        result: dict[str, Any] = _resolve(self.schema)()
        return result


def _resolve(ref: str) -> Callable[..., Any]:
    module, _, attr = ref.partition(":")
    func: Callable[..., Any] = getattr(importlib.import_module(module), attr)
    return func


KINDS: dict[str, FileKind] = {
    "hardware": FileKind(
        name="hardware",
        title="robot description",
        marker_keys=("boards",),
        suffixes=(),
        loader="pirate_bt.link.layout:validate_robot_file",  # the frames must fit
        schema="pirate_bt.robot.schema:robot_schema",
    ),
    "network": FileKind(
        name="network",
        title="pipe network",
        marker_keys=("segments",),
        suffixes=(),
        loader="pirate_bt.pipes.loader:load_network",
        schema="pirate_bt.pipes.loader:network_schema",
    ),
    "tree": FileKind(
        name="tree",
        title="behaviour tree",
        marker_keys=("root",),
        suffixes=(),
        loader="pirate_bt.treefile.loader:validate_tree_file",
        schema="pirate_bt.treefile.schema:tree_schema",
    ),
    "route": FileKind(
        name="route",
        title="route",
        marker_keys=(),
        suffixes=(".route",),
        loader="pirate_bt.task.planner:validate_route_file",
        schema="pirate_bt.task.route:route_schema",
    ),
    "campaign": FileKind(
        name="campaign",
        title="campaign",
        marker_keys=("runs",),
        suffixes=(".campaign.yaml", ".campaign.yml"),
        loader="pirate_bt.campaign.run:validate_campaign_file",
        schema="pirate_bt.campaign.spec:campaign_schema",
    ),
    "trace": FileKind(
        name="trace",
        title="trace",
        marker_keys=(),
        suffixes=(".jsonl", ".ndjson", ".jsonl.gz", ".mcap"),
        loader="pirate_bt.trace.reader:read_trace",
        schema="pirate_bt.trace.records:trace_schema",
    ),
}


def get_kind(name: str) -> FileKind:
    """The :class:`FileKind` called ``name``.

    Raises:
        ValidationFailed: never; raises KeyError with the known names instead.
    """
    if name not in KINDS:
        raise KeyError(f"unknown file kind {name!r}; known kinds: {', '.join(KINDS)}")
    return KINDS[name]


def detect_kind(path: str | Path) -> FileKind:
    """Guess a file's kind from its suffix, else from its top-level keys.

    Raises:
        ValidationFailed: unreadable or unrecognisable file, with its location.
    """
    p = Path(path)
    for kind in KINDS.values():
        if any(p.name.endswith(suffix) for suffix in kind.suffixes):
            return kind
    from pirate_bt.yamlfile import load_yaml

    try:
        doc = load_yaml(p)
    except ValidationFailed:
        # A number YAML refuses (a leading zero) hides nothing else of a tree file
        # (pirate_bt.treefile.refused): its top-level keys still tell the kind, and
        # the kind's loader says every problem. Anything else raises as load_yaml did.
        doc, _refused = _resolve("pirate_bt.treefile.refused:read_tree_yaml")(p)
    if isinstance(doc.data, dict):
        for kind in KINDS.values():
            if any(key in doc.data for key in kind.marker_keys):
                return kind
    expected = "; ".join(
        f"a {k.title} has '{k.marker_keys[0]}'" for k in KINDS.values() if k.marker_keys
    )
    raise ValidationFailed(
        [
            LocatedError(
                f"cannot tell what kind of file this is ({expected}); name it with --kind",
                SourceLocation(str(path)),
            )
        ]
    )


def validate_file(
    path: str | Path, kind: str | None = None, params: Mapping[str, str] | None = None
) -> Any:
    """Validate one file, detecting its kind unless given; return the loaded object.

    Args:
        path: The file.
        kind: Its kind (default: detected from the suffix or the top-level keys).
        params: Tree parameters as command-line texts (``{"roll": "90 deg"}``); only
            behaviour trees take parameters.

    Raises:
        ValidationFailed: the file does not validate (each error located).
        InputError: parameters given for a file that is not a tree.
    """
    file_kind = get_kind(kind) if kind else detect_kind(path)
    if params:
        if file_kind.name != "tree":
            raise InputError(
                f"{path}: --param applies to behaviour trees, not to a {file_kind.title}"
            )
        return file_kind.load(path, params=params)
    return file_kind.load(path)


def json_schema(kind: str) -> dict[str, Any]:
    """The JSON Schema of a file kind."""
    return get_kind(kind).json_schema()
