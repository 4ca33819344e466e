"""BT.CPP's own FileLogger2 log of a traced run, its leaves replaying the trace.

``python tests/btlog_oracle.py TRACE XML OUT``: builds the tree of ``XML`` (a
``.btlog``'s tree, as pirate_bt exports it) in BehaviorTree.CPP (the
``behaviortreepy`` bindings), makes each leaf return, tick by tick, the status the
trace recorded for it, and lets BT.CPP's ``FileLogger`` write ``OUT``. Run in a
process of its own by ``tests/test_btlog.py``, so that the logger's writer thread
has emptied its queue into the file when the process has exited.
"""

from __future__ import annotations

import sys
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import behaviortreepy as bt

from pirate_bt.interop.btcpp import node_models
from pirate_bt.trace.reader import read_trace


def replay(trace_path: Path, xml: str, out: Path) -> None:
    trace = read_trace(trace_path)
    order = [n.id for n in trace.structure]
    per_tick = {frame.n: frame.status for frame in trace.frames()}
    tick = [0]
    status = {
        c: getattr(bt.NodeStatus, n)
        for c, n in (("R", "RUNNING"), ("S", "SUCCESS"), ("F", "FAILURE"))
    }

    def recorded(node: Any) -> Any:
        frame = per_tick.get(tick[0]) or per_tick[max(n for n in per_tick if n <= tick[0])]
        return status[frame[order[node.uid() - 1]]]

    factory = bt.BehaviorTreeFactory()
    for model in node_models().values():
        if model.category == "Decorator":
            factory.register_simple_decorator(model.id, lambda s, node=None: s)
        elif model.category in ("Action", "Condition"):
            factory.register_simple_stateful_action(model.id, recorded, recorded)
    root = ET.fromstring(xml)
    for element in root.iter():
        for key in list(element.attrib):
            if element.tag not in ("root", "BehaviorTree") and key != "name":
                del element.attrib[key]
    root.set("main_tree_to_execute", trace.structure.name)
    tree = factory.create_tree_from_text(ET.tostring(root, "unicode"))
    logger = bt.FileLogger(tree, str(out))
    for n in range(1, trace.last_tick + 1):
        tick[0] = n
        if tree.tick_once() != bt.NodeStatus.RUNNING:
            break
    logger.flush()
    del logger, tree


if __name__ == "__main__":
    replay(Path(sys.argv[1]), Path(sys.argv[2]).read_text(encoding="utf-8"), Path(sys.argv[3]))
