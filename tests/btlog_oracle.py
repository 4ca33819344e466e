"""BT.CPP's own FileLogger2 log of a traced run, its leaves replaying the trace.

``python tests/btlog_oracle.py TRACE XML OUT``: builds the tree of ``XML`` (a
``.btlog``'s tree, as pirate_bt exports it) in BehaviorTree.CPP (the
``behaviortreepy`` bindings), makes each leaf return, tick by tick, the status the
trace recorded for it, and lets BT.CPP's ``FileLogger`` write ``OUT``. Run in a
process of its own by ``tests/test_btlog.py``; it waits for BT.CPP's writer thread
to write what it queued before the logger is destroyed (:func:`_drained`).
"""

from __future__ import annotations

import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import behaviortreepy as bt

from pirate_bt.interop.btcpp import node_models
from pirate_bt.interop.btlog import read_btlog
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
    _drained(out)
    del logger, tree


def _drained(out: Path, timeout_s: float = 20.0) -> None:
    """Wait until BT.CPP's writer thread has written the transitions queued.

    FileLogger2's destructor stops its writer thread without emptying the queue: when
    the ticks are over before the thread first ran (a fast replay, a busy machine),
    the log would keep its header only. The thread writes and flushes what is queued
    every 10 ms, so the file holding transitions and no longer growing (five reads
    20 ms apart) says it is done.
    """
    deadline = time.monotonic() + timeout_s
    size, still = -1, 0
    while time.monotonic() < deadline:
        now = out.stat().st_size if out.exists() else 0
        still = still + 1 if now == size else 0
        size = now
        if still >= 5 and _has_transitions(out):
            return
        time.sleep(0.02)
    raise SystemExit(f"{out}: BT.CPP's logger wrote no transitions in {timeout_s:g} s")


def _has_transitions(path: Path) -> bool:
    try:
        return bool(read_btlog(path).transitions)
    except Exception:  # cut mid-record: the writer thread is not done
        return False


if __name__ == "__main__":
    replay(Path(sys.argv[1]), Path(sys.argv[2]).read_text(encoding="utf-8"), Path(sys.argv[3]))
