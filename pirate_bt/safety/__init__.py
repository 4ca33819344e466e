"""The protective layer: the only road from the layers above to the robot.

The :class:`Supervisor` holds the robot port and is the only object that sends
commands. It checks every command - from a tree, planner code or an operator -
against static limits from the robot description, state invariants on the
current :class:`~pirate_bt.robot.state.RobotState`, data freshness and link
health, and answers with a :class:`Verdict` (pass, clip or refuse with a
machine-readable :class:`Reason`). It owns the safe state (drives stopped,
clamps held), the latched e-stop and the operator's authority (:class:`Mode`).

Layers above ``safety`` never import ``pirate_bt.link``: they get a supervisor
from :func:`open_supervisor`. See ``docs/safety.md``.
"""

from pirate_bt.robot.description import Half
from pirate_bt.safety.checks import INVARIANTS, Check, CheckContext, ClampState, Intent, Problem
from pirate_bt.safety.commands import (
    Bend,
    Clamp,
    Command,
    Drive,
    MoveFrontClear,
    Raw,
    Rotate,
    Stop,
    Tilt,
    Unclamp,
    describe,
)
from pirate_bt.safety.factory import open_supervisor
from pirate_bt.safety.operator import (
    Confirm,
    Confirmation,
    Deny,
    EStop,
    Mode,
    OperatorAction,
    OperatorCommand,
    OperatorInput,
    ResetEStop,
    Resume,
    SafeStop,
    ScriptedOperator,
    SetMode,
)
from pirate_bt.safety.supervisor import Supervisor
from pirate_bt.safety.tally import Counters, SafeStateEntry, VerdictTally
from pirate_bt.safety.verdict import Outcome, Reason, Source, Verdict, VerdictLog

__all__ = [
    "INVARIANTS",
    "Bend",
    "Check",
    "CheckContext",
    "Clamp",
    "ClampState",
    "Command",
    "Confirm",
    "Confirmation",
    "Counters",
    "Deny",
    "Drive",
    "EStop",
    "Half",
    "Intent",
    "Mode",
    "MoveFrontClear",
    "OperatorAction",
    "OperatorCommand",
    "OperatorInput",
    "Outcome",
    "Problem",
    "Raw",
    "Reason",
    "ResetEStop",
    "Resume",
    "Rotate",
    "SafeStateEntry",
    "SafeStop",
    "ScriptedOperator",
    "SetMode",
    "Source",
    "Stop",
    "Supervisor",
    "Tilt",
    "Unclamp",
    "Verdict",
    "VerdictLog",
    "VerdictTally",
    "describe",
    "open_supervisor",
]
