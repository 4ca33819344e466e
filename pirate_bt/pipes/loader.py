"""Load and validate pipe network files with located errors."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pirate_bt.errors import (
    ConfigurationError,
    LocatedError,
    PirateError,
    SourceLocation,
    ValidationFailed,
    file_argument,
)
from pirate_bt.pipes.model import NetworkSpec
from pirate_bt.pipes.network import Network, NetworkGeometryError
from pirate_bt.resources import bundled, bundled_names, missing
from pirate_bt.yamlfile import YamlDocument, data_document, load_yaml
from pirate_bt.yamlvalidate import validate_document

__all__ = [
    "load_network",
    "network_from_data",
    "network_from_document",
    "network_place",
    "network_schema",
]

_FILE_CONTEXT = {"units_required": True}


def network_from_document(doc: YamlDocument) -> Network:
    """Validate a loaded YAML document as a pipe network.

    Raises:
        ValidationFailed: every problem, each at ``file:line:column``.
    """
    spec = validate_document(doc, NetworkSpec, "a pipe network", _FILE_CONTEXT)
    try:
        return Network(spec, doc.file)
    except ConfigurationError as exc:
        path = exc.path if isinstance(exc, NetworkGeometryError) else ("segments",)
        raise ValidationFailed([doc.locator.error(path, str(exc))]) from None


def network_from_data(data: Mapping[str, Any], name: str = "<data>") -> Network:
    """Validate plain data (as from a YAML file, units required) as a pipe network.

    Raises:
        ArgumentTypeError: ``data`` is no mapping or ``name`` no text.
        ValidationFailed: every problem, each at ``name:1:1``.
    """
    return network_from_document(data_document(data, name))


def load_network(path: str | Path) -> Network:
    """Load a pipe network file; a bare name such as ``lab`` loads a bundled scenario.

    Raises:
        InputError: ``path`` is no file name (empty, a NUL, bytes, a number, more than
            4096 characters: :func:`~pirate_bt.errors.file_argument`).
        ValidationFailed: the file cannot be read (a name the system refuses, such as
            a part longer than 255 bytes, too) or does not validate; a bare name that is
            neither a file nor a bundled network: ``nosuch:1:1: no such network file;
            bundled networks: bend-down, ...``.
    """
    p = file_argument(path, "path")
    if missing(p) and p.parent == Path(".") and not p.suffix:
        candidate = bundled("scenarios", str(p))
        if missing(candidate):  # named as typed, not as the bundled path never typed
            names = ", ".join(bundled_names("scenarios"))
            message = f"no such network file; bundled networks: {names}"
            raise ValidationFailed([LocatedError(message, SourceLocation(str(p)))])
        p = candidate
    return network_from_document(load_yaml(p))


def network_place(network: Network, path: tuple[str | int, ...]) -> str | None:
    """``file:line:column`` of ``path`` (keys from the file's top) in the file ``network``
    was loaded from; ``None`` when it was not loaded from a file that still reads."""
    try:
        if not Path(network.source).is_file():
            return None
        document = load_yaml(network.source)
    except (OSError, PirateError):
        return None
    return str(document.locator.locate(path))


def network_schema() -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of ``scenarios/*.yaml`` pipe networks."""
    schema = NetworkSpec.model_json_schema(mode="validation")
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "pirate_bt pipe network"
    return schema
