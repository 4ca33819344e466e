"""pirate_bt: behaviour-tree autonomy for the PIRATE pipe-inspection robot.

The front door for planner code (see ``docs/api.md``)::

    import pirate_bt

    result = pirate_bt.simulate_tree("bend", network="bend-right", params={"roll": "90 deg"},
                                     faults="motor_stall:bend_3_drive@5s+20s")
    print(result.status, result.why, result.failing_node)

    mission = pirate_bt.simulate_mission("lab.route")
    for pab in mission.pabs:
        print(pab.label, pab.outcome, pab.why)

Names are imported lazily, on first use: ``import pirate_bt`` and the command
line stay light (py_trees, pydantic models and graphviz load only when needed).
The library logs through ``logging`` under ``pirate_bt`` and adds only a
``NullHandler``: configure logging in your program to see its records.
"""

from __future__ import annotations

import importlib
import logging
from typing import TYPE_CHECKING, Any

from pirate_bt._version import __version__

logging.getLogger(__name__).addHandler(logging.NullHandler())

# public name -> the module that defines it
_EXPORTS: dict[str, str] = {
    # running trees and missions
    "simulate_tree": "pirate_bt.api.trees",
    "run_tree": "pirate_bt.api.trees",
    "load_tree": "pirate_bt.api.loading",
    "connect": "pirate_bt.api.connection",
    "Connection": "pirate_bt.api.connection",
    "plan_route": "pirate_bt.api.missions",
    "simulate_mission": "pirate_bt.api.missions",
    "run_mission": "pirate_bt.api.missions",
    "load_network": "pirate_bt.api.missions",
    "Network": "pirate_bt.pipes.network",
    "write_mission_outputs": "pirate_bt.api.mission_outputs",
    "run_campaign": "pirate_bt.campaign",
    # planner code in the loop
    "navigate": "pirate_bt.api.navigation",
    "survey": "pirate_bt.api.survey",
    "SurveyResult": "pirate_bt.api.survey",
    "Step": "pirate_bt.task.navigation",
    "Observation": "pirate_bt.task.navigation",
    "Navigator": "pirate_bt.task.navigation",
    "NavigationResult": "pirate_bt.task.navigate",
    "load_navigator": "pirate_bt.task.navigators",
    "navigator_names": "pirate_bt.task.navigators",
    "Felt": "pirate_bt.task.navigation",
    "OffWall": "pirate_bt.task.navigation",
    "RouteNavigator": "pirate_bt.task.navigators",
    "GoalNavigator": "pirate_bt.task.navigators",
    "ExploreNavigator": "pirate_bt.task.explore",
    "SurveyIncomplete": "pirate_bt.task.explore",
    "branch_leavable": "pirate_bt.task.explore",
    # other tools' files: BehaviorTree.CPP XML and logs, MCAP, rosbag2 (pirate_bt.interop
    # names their modules)
    "export_xml": "pirate_bt.interop",
    "import_xml": "pirate_bt.interop",
    "load_xml_tree": "pirate_bt.interop",
    "export_btlog": "pirate_bt.interop",
    "read_btlog": "pirate_bt.interop",
    "export_mcap": "pirate_bt.interop",
    "export_rosbag2": "pirate_bt.interop",
    # live views of your own runners
    "attach_groot2": "pirate_bt.interop.groot2_server",
    "Groot2Server": "pirate_bt.interop.groot2_server",
    "attach_trace": "pirate_bt.trace.attach",
    "TraceRecorder": "pirate_bt.trace.writer",
    # results
    "RunResult": "pirate_bt.api.results",
    "MissionResult": "pirate_bt.task.mission",
    "PabOutcome": "pirate_bt.task.outcome",
    "Fix": "pirate_bt.task.fixes",
    "Disagreement": "pirate_bt.task.fixes",
    "Counters": "pirate_bt.safety.tally",
    "CampaignResult": "pirate_bt.campaign",
    "MissionPlan": "pirate_bt.task.plan",
    "StopReason": "pirate_bt.runner",
    # files
    "load_robot": "pirate_bt.robot.loader",
    "load_route": "pirate_bt.api.missions",
    "read_trace": "pirate_bt.trace.reader",
    "Trace": "pirate_bt.trace.reader",
    "render_tree": "pirate_bt.render.tree",
    # building trees in Python
    "BuildContext": "pirate_bt.behaviours.base",
    # errors
    "PirateError": "pirate_bt.errors",
    "InputError": "pirate_bt.errors",
    "LocatedError": "pirate_bt.errors",
    "ValidationFailed": "pirate_bt.errors",
    "LinkError": "pirate_bt.errors",
    "SafetyError": "pirate_bt.errors",
    "ConfigurationError": "pirate_bt.errors",
}

__all__ = [
    "BuildContext",
    "CampaignResult",
    "ConfigurationError",
    "Connection",
    "Counters",
    "Disagreement",
    "ExploreNavigator",
    "Felt",
    "Fix",
    "GoalNavigator",
    "Groot2Server",
    "InputError",
    "LinkError",
    "LocatedError",
    "MissionPlan",
    "MissionResult",
    "NavigationResult",
    "Navigator",
    "Network",
    "Observation",
    "OffWall",
    "PabOutcome",
    "PirateError",
    "RouteNavigator",
    "RunResult",
    "SafetyError",
    "Step",
    "StopReason",
    "SurveyIncomplete",
    "SurveyResult",
    "Trace",
    "TraceRecorder",
    "ValidationFailed",
    "__version__",
    "attach_groot2",
    "attach_trace",
    "branch_leavable",
    "connect",
    "export_btlog",
    "export_mcap",
    "export_rosbag2",
    "export_xml",
    "import_xml",
    "load_navigator",
    "load_network",
    "load_robot",
    "load_route",
    "load_tree",
    "load_xml_tree",
    "navigate",
    "navigator_names",
    "plan_route",
    "read_btlog",
    "read_trace",
    "render_tree",
    "run_campaign",
    "run_mission",
    "run_tree",
    "simulate_mission",
    "simulate_tree",
    "survey",
    "write_mission_outputs",
]


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'pirate_bt' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later lookups skip this function
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_EXPORTS})


if TYPE_CHECKING:  # for type checkers and IDEs: the same names, eagerly
    from pirate_bt.api.connection import Connection, connect
    from pirate_bt.api.loading import load_tree
    from pirate_bt.api.missions import (
        load_network,
        load_route,
        plan_route,
        run_mission,
        simulate_mission,
        write_mission_outputs,
    )
    from pirate_bt.api.navigation import navigate
    from pirate_bt.api.results import RunResult
    from pirate_bt.api.survey import SurveyResult, survey
    from pirate_bt.api.trees import run_tree, simulate_tree
    from pirate_bt.behaviours.base import BuildContext
    from pirate_bt.campaign import CampaignResult, run_campaign
    from pirate_bt.errors import (
        ConfigurationError,
        InputError,
        LinkError,
        LocatedError,
        PirateError,
        SafetyError,
        ValidationFailed,
    )
    from pirate_bt.interop.btcpp_export import export_xml
    from pirate_bt.interop.btcpp_import_file import import_xml, load_xml_tree
    from pirate_bt.interop.btlog import export_btlog, read_btlog
    from pirate_bt.interop.groot2_server import Groot2Server, attach_groot2
    from pirate_bt.interop.mcap_trace import export_mcap
    from pirate_bt.interop.rosbag2 import export_rosbag2
    from pirate_bt.pipes.network import Network
    from pirate_bt.render.tree import render_tree
    from pirate_bt.robot.loader import load_robot
    from pirate_bt.runner import StopReason
    from pirate_bt.safety.tally import Counters
    from pirate_bt.task.explore import ExploreNavigator, SurveyIncomplete, branch_leavable
    from pirate_bt.task.fixes import Disagreement, Fix
    from pirate_bt.task.mission import MissionResult
    from pirate_bt.task.navigate import NavigationResult
    from pirate_bt.task.navigation import Felt, Navigator, Observation, OffWall, Step
    from pirate_bt.task.navigators import (
        GoalNavigator,
        RouteNavigator,
        load_navigator,
        navigator_names,
    )
    from pirate_bt.task.outcome import PabOutcome
    from pirate_bt.task.plan import MissionPlan
    from pirate_bt.trace.attach import attach_trace
    from pirate_bt.trace.reader import Trace, read_trace
    from pirate_bt.trace.writer import TraceRecorder
