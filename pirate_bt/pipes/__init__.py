"""Pipe networks: the simulator's world and the task layer's map.

Load a network with :func:`load_network` (``scenarios/*.yaml``, or a bundled
name such as ``"lab"``), then ask it for paths: :meth:`Network.main_path`,
:meth:`Network.path` with a choice per tee, or every :meth:`Network.paths`. A
:class:`Path` answers what is at a distance along it, and the slope and
diameter there. The file format is described in ``docs/networks.md``.
"""

from __future__ import annotations

from pirate_bt.pipes.loader import (
    load_network,
    network_from_data,
    network_from_document,
    network_schema,
)
from pirate_bt.pipes.model import DIRECTION_ROLL_RAD, Direction, FaultSpec, NetworkSpec
from pirate_bt.pipes.network import Network, Path, Piece, PieceKind, TeeChoice

__all__ = [
    "DIRECTION_ROLL_RAD",
    "Direction",
    "FaultSpec",
    "Network",
    "NetworkSpec",
    "Path",
    "Piece",
    "PieceKind",
    "TeeChoice",
    "load_network",
    "network_from_data",
    "network_from_document",
    "network_schema",
]
