"""The front door planner code imports: run trees and missions, and say why they ended.

Everything here is also importable from the package itself (``pirate_bt.simulate_tree``),
lazily, so ``import pirate_bt`` stays light. The command line (``pirate-bt``) and
campaigns stand on these functions; see ``docs/api.md``.

- :func:`simulate_tree`, :func:`run_tree` → :class:`RunResult`
- :func:`plan_route`, :func:`simulate_mission`, :func:`run_mission` →
  :class:`~pirate_bt.task.mission.MissionResult` with :class:`PabOutcome` per step
- :func:`connect` → :class:`Connection` (a supervised robot for trees you build)
- :func:`load_tree`, :func:`load_robot`, :func:`load_network`, :func:`read_trace`,
  :func:`render_tree`
- one :class:`Counters` type in every result
"""

from pirate_bt.api.connection import Connection, connect
from pirate_bt.api.missions import (
    load_network,
    load_route,
    plan_route,
    run_mission,
    simulate_mission,
    write_mission_outputs,
)
from pirate_bt.api.options import split_faults
from pirate_bt.api.results import RunResult
from pirate_bt.api.running import load_tree
from pirate_bt.api.trees import run_tree, simulate_tree
from pirate_bt.safety.tally import Counters
from pirate_bt.task.mission import MissionResult
from pirate_bt.task.outcome import PabOutcome

__all__ = [
    "Connection",
    "Counters",
    "MissionResult",
    "PabOutcome",
    "RunResult",
    "connect",
    "load_network",
    "load_route",
    "load_tree",
    "plan_route",
    "run_mission",
    "run_tree",
    "simulate_mission",
    "simulate_tree",
    "split_faults",
    "write_mission_outputs",
]
