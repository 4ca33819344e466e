"""Bridges to the tools robotics engineers already use.

- :mod:`pirate_bt.interop.btcpp`: BehaviorTree.CPP v4 XML, both ways (Groot2 opens it).
- :mod:`pirate_bt.interop.btlog`: traces as BT.CPP ``FileLogger2`` logs (Groot2 replays them).
- :mod:`pirate_bt.interop.mcap_trace`: traces as MCAP files (Foxglove, Lichtblick).
- :mod:`pirate_bt.interop.foxglove_live`: the same topics live over the Foxglove WebSocket.
- :mod:`pirate_bt.interop.ros2_live`: a run on a ROS 2 graph over Zenoh (rmw_zenoh's
  conventions, :mod:`pirate_bt.interop.rmw_zenoh`); :mod:`pirate_bt.interop.rosbag2`:
  traces as rosbag2 directories.

Each module imports its optional dependency only when used and says which extra
to install when it is missing.

The file converters are also here (and in ``pirate_bt``), imported on first use:
``export_xml``, ``import_xml``, ``load_xml_tree``, ``export_btlog``, ``read_btlog``,
``export_mcap``, ``export_rosbag2``.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

_EXPORTS: dict[str, str] = {
    "export_xml": "pirate_bt.interop.btcpp_export",
    "import_xml": "pirate_bt.interop.btcpp_import_file",
    "load_xml_tree": "pirate_bt.interop.btcpp_import_file",
    "export_btlog": "pirate_bt.interop.btlog",
    "read_btlog": "pirate_bt.interop.btlog",
    "export_mcap": "pirate_bt.interop.mcap_trace",
    "export_rosbag2": "pirate_bt.interop.rosbag2",
}

__all__ = [
    "export_btlog",
    "export_mcap",
    "export_rosbag2",
    "export_xml",
    "import_xml",
    "load_xml_tree",
    "read_btlog",
]


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'pirate_bt.interop' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


if TYPE_CHECKING:
    from pirate_bt.interop.btcpp_export import export_xml
    from pirate_bt.interop.btcpp_import_file import import_xml, load_xml_tree
    from pirate_bt.interop.btlog import export_btlog, read_btlog
    from pirate_bt.interop.mcap_trace import export_mcap
    from pirate_bt.interop.rosbag2 import export_rosbag2
