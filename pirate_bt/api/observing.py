"""Planner code around a run: an ``observe=`` callback attached to its runner.

(A Ctrl-C a node's ``terminate()`` raises as the run ends is the runner's to make safe:
:meth:`pirate_bt.runner.Runner.run` puts the robot in its safe state before it goes on.)
"""

from __future__ import annotations

from pirate_bt.trace.attach import call_observer

__all__ = ["call_observer"]
