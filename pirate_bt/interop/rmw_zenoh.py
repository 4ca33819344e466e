"""rmw_zenoh's conventions: what makes a Zenoh publication a ROS 2 topic.

ROS 2's Zenoh middleware, ``rmw_zenoh_cpp``, maps every ROS 2 entity onto
plain Zenoh, and documents how in its design document (``docs/design.md`` of
https://github.com/ros2/rmw_zenoh; we follow the version of commit
``99a6a2bd10b949052f4f12c5854825dc005e95a5``, the one with the key expression,
attachment and liveliness sections, with the QoS defaults of its ``qos.cpp``).
A program that follows them is a ROS 2 node to every other node on the same
Zenoh router, with no ROS installed:

- **Data** goes to the key expression
  ``<domain_id>/<fully qualified name, no leading slash>/<DDS type name>/<type hash>``
  as the CDR message, with an **attachment** of 8 bytes sequence number
  (little-endian int64), 8 bytes source timestamp (ns since the Unix epoch,
  little-endian int64), 1 byte GID length (16) and the 16-byte GID.
- **Graph discovery** is liveliness tokens under the hermetic prefix
  ``@ros2_lv``: one per node
  ``@ros2_lv/<domain>/<session id>/<node id>/<node id>/NN/<enclave>/<namespace>/<node name>``
  and one per publisher (``MP``) and subscription (``MS``)
  ``.../<node name>/<topic>/<DDS type name>/<type hash>/<QoS>``, where a name's
  ``/`` become ``%`` (an empty enclave or namespace is ``%``).
- **QoS** in a token is rmw_zenoh's compact form (:func:`qos_text`): each
  policy left empty where it equals rmw_zenoh's default (reliable, volatile,
  keep last 42, infinite deadline, lifespan and lease, automatic liveliness).

This module is those rules as pure functions (nothing here imports Zenoh), so
``tests/test_ros2.py`` can hold them against the design document's grammar and
examples, and :mod:`pirate_bt.interop.ros2_live` can use them.
"""

from __future__ import annotations

import hashlib
import re
import struct
from dataclasses import dataclass

__all__ = [
    "ADMIN_SPACE",
    "Qos",
    "attachment",
    "data_key",
    "endpoint_token",
    "entity_gid",
    "mangle",
    "node_token",
    "parse_attachment",
    "qos_text",
    "qualified_name",
]

ADMIN_SPACE = "@ros2_lv"

# rmw's enum values (rmw/types.h), as they appear in a token's QoS.
RELIABLE, BEST_EFFORT = 1, 2
TRANSIENT_LOCAL, VOLATILE = 1, 2
KEEP_LAST, KEEP_ALL = 1, 2
AUTOMATIC = 1

_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
"""One part of a ROS name (matched whole: ``$`` would let a trailing newline through)."""


@dataclass(frozen=True, slots=True)
class Qos:
    """The QoS of one endpoint (deadline, lifespan and lease are always infinite here).

    Attributes:
        reliability: :data:`RELIABLE` or :data:`BEST_EFFORT`.
        durability: :data:`VOLATILE` or :data:`TRANSIENT_LOCAL` (late joiners get the
            last ``depth`` messages).
        history: :data:`KEEP_LAST` or :data:`KEEP_ALL`.
        depth: How many messages ``KEEP_LAST`` keeps.
    """

    reliability: int = RELIABLE
    durability: int = VOLATILE
    history: int = KEEP_LAST
    depth: int = 10


_DEFAULT = Qos(depth=42)
"""rmw_zenoh's default QoS (its ``QoS::default_qos``)."""


def qos_text(qos: Qos) -> str:
    """The compact QoS of a liveliness token: ``<rel>:<dur>:<hist>,<depth>:<deadline s>,<ns>:
    <lifespan s>,<ns>:<liveliness>,<lease s>,<ns>``, each left empty at rmw_zenoh's default.

    A reliable, volatile, keep-last-10 endpoint is ``::,10:,:,:,,``.
    """

    def part(value: int, default: int) -> str:
        return "" if value == default else str(value)

    return (
        f"{part(qos.reliability, _DEFAULT.reliability)}:"
        f"{part(qos.durability, _DEFAULT.durability)}:"
        f"{part(qos.history, _DEFAULT.history)},{part(qos.depth, _DEFAULT.depth)}:"
        ",:,:,,"
    )


def mangle(name: str) -> str:
    """A name as one key-expression chunk: every ``/`` becomes ``%`` (``""`` -> ``%``)."""
    return name.replace("/", "%") if name else "%"


def qualified_name(namespace: str, name: str) -> str:
    """The fully qualified ROS name of ``name`` (relative or absolute) in ``namespace``.

    Raises:
        ValueError: a name or namespace that ROS would refuse.
    """
    ns = "/" + namespace.strip("/") if namespace.strip("/") else ""
    full = name if name.startswith("/") else f"{ns}/{name}"
    for token in full.strip("/").split("/"):
        if not _NAME.fullmatch(token):
            raise ValueError(f"not a valid ROS name: {full!r} (each part: letters, digits, _)")
    return full


def data_key(domain_id: int, fully_qualified: str, dds_type: str, type_hash: str) -> str:
    """The key expression a topic's messages are put on."""
    return f"{domain_id}/{fully_qualified.strip('/')}/{dds_type}/{type_hash}"


def node_token(
    domain_id: int, session_id: str, node_id: int, namespace: str, node_name: str
) -> str:
    """The liveliness token of a node (entity kind ``NN``, no enclave)."""
    ns = "/" + namespace.strip("/") if namespace.strip("/") else ""
    return (
        f"{ADMIN_SPACE}/{domain_id}/{session_id}/{node_id}/{node_id}/NN/%/{mangle(ns)}/"
        f"{mangle(node_name)}"
    )


def endpoint_token(
    domain_id: int,
    session_id: str,
    node_id: int,
    entity_id: int,
    kind: str,
    namespace: str,
    node_name: str,
    fully_qualified: str,
    dds_type: str,
    type_hash: str,
    qos: Qos,
) -> str:
    """The liveliness token of a publisher (``kind="MP"``) or subscription (``"MS"``)."""
    if kind not in ("MP", "MS", "SS", "SC"):
        raise ValueError(f"not an endpoint kind: {kind!r}")
    ns = "/" + namespace.strip("/") if namespace.strip("/") else ""
    return (
        f"{ADMIN_SPACE}/{domain_id}/{session_id}/{node_id}/{entity_id}/{kind}/%/{mangle(ns)}/"
        f"{mangle(node_name)}/{mangle(fully_qualified)}/{dds_type}/{type_hash}/{qos_text(qos)}"
    )


def entity_gid(token: str) -> bytes:
    """A 16-byte GID for the entity whose liveliness token is ``token``.

    rmw_zenoh hashes the token with XXH3-128; a GID only has to be unique and
    stable (subscribers compare them, none recomputes them), so a 16-byte BLAKE2b
    of the same token serves without another dependency.
    """
    return hashlib.blake2b(token.encode("utf-8"), digest_size=16).digest()


_ATTACHMENT = struct.Struct("<qqB")


def attachment(sequence: int, timestamp_ns: int, gid: bytes) -> bytes:
    """The attachment of one published message (see the module docstring)."""
    if len(gid) != 16:
        raise ValueError("a GID has 16 bytes")
    return _ATTACHMENT.pack(sequence, timestamp_ns, len(gid)) + gid


def parse_attachment(data: bytes) -> tuple[int, int, bytes]:
    """``(sequence, timestamp_ns, gid)`` of an attachment.

    Raises:
        ValueError: it is too short for what its GID length says.
    """
    if len(data) < _ATTACHMENT.size:
        raise ValueError(f"an attachment has at least {_ATTACHMENT.size} bytes, not {len(data)}")
    sequence, stamp, length = _ATTACHMENT.unpack_from(data)
    gid = bytes(data[_ATTACHMENT.size : _ATTACHMENT.size + length])
    if len(gid) != length:
        raise ValueError("attachment cut off inside its GID")
    return sequence, stamp, gid
