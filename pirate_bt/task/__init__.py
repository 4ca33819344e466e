"""The task level: routes an operator writes, the map, localisation and missions.

- :mod:`pirate_bt.task.route`: the route language (``scenarios/*.route``).
- :mod:`pirate_bt.task.planner`: a route, or a goal segment, planned on the pipe
  network into one chain of PABs, run as one tree.
- :mod:`pirate_bt.task.localise`: the robot's belief of where it is, from drive
  odometry corrected at recognised bends and T-joints.
- :mod:`pirate_bt.task.mission`: run a planned mission behind a supervisor you hold
  (:func:`~pirate_bt.task.mission.run_mission`), with its trace and result; planner
  code usually calls :func:`pirate_bt.simulate_mission` / :func:`pirate_bt.run_mission`,
  which connect first.
- :mod:`pirate_bt.task.outcome`: why a run ended, one outcome per PAB.

The task level reaches the robot only through the safety supervisor (it never
imports ``pirate_bt.link``). See ``docs/routes.md`` and ``docs/missions.md``.
"""

from __future__ import annotations

from pirate_bt.task.mission import Leg, MissionResult, TimelineEntry, run_mission
from pirate_bt.task.outcome import PabOutcome, explain_run
from pirate_bt.task.planner import (
    MissionPlan,
    PabContract,
    PlannedPab,
    mission_tree_spec,
    plan_goal,
    plan_route,
)
from pirate_bt.task.route import Route, RouteStep, StepKind, load_route, parse_route

__all__ = [
    "Leg",
    "MissionPlan",
    "MissionResult",
    "PabContract",
    "PabOutcome",
    "PlannedPab",
    "Route",
    "RouteStep",
    "StepKind",
    "TimelineEntry",
    "explain_run",
    "load_route",
    "mission_tree_spec",
    "parse_route",
    "plan_goal",
    "plan_route",
    "run_mission",
]
