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
"""

__all__ = []
