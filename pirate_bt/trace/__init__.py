"""Traces: every tick of a run, written as it happens and read back afterwards.

A trace answers "what did the tree do, and what did the robot do" for a run
nobody watched. :class:`TraceRecorder` writes one (a header with the tree's
shape, then what changed in each tick, then the outcome); :func:`read_trace`
reads it back and rebuilds the whole tree status and robot state at any tick;
:func:`summarise` and :func:`tree_text` turn it into text; :func:`live_view_hook`
shows a tree live while it runs. The file format is in ``docs/formats/trace.md``.

Typical use with plain py_trees::

    tree = py_trees.trees.BehaviourTree(root)
    with TraceRecorder("run.jsonl", tree, clock=clock) as recorder:
        tree.add_post_tick_handler(recorder.post_tick_handler(extras))
        for _ in range(100):
            tree.tick()
    trace = read_trace("run.jsonl")
    trace.statuses_at(42)
    trace.first_tick("*/clamp rear", "SUCCESS")   # queries: see pirate_bt.trace.query
"""

from pirate_bt.trace.attach import (
    attach_live_view,
    attach_trace,
    counter_values,
    supervised_extras,
)
from pirate_bt.trace.formats import ENTRY_POINT_GROUP, load_format_entry_points
from pirate_bt.trace.live import LiveView, live_view_hook
from pirate_bt.trace.query import Failure, FeedbackChange, NodeLookupError, StatusChange
from pirate_bt.trace.reader import (
    READERS,
    TickFrame,
    TickRecord,
    Trace,
    TraceFormatReader,
    open_reader,
    read_trace,
    register_reader,
)
from pirate_bt.trace.records import (
    TRACE_VERSION,
    CommandRecord,
    TickExtras,
    TraceEvent,
    trace_schema,
)
from pirate_bt.trace.sink import SinkError
from pirate_bt.trace.structure import NodeInfo, TreeStructure, tree_structure
from pirate_bt.trace.text import format_summary, summarise, tree_text
from pirate_bt.trace.writer import (
    WRITERS,
    TraceFormatWriter,
    TraceRecorder,
    open_writer,
    register_writer,
)

__all__ = [
    "ENTRY_POINT_GROUP",
    "READERS",
    "TRACE_VERSION",
    "WRITERS",
    "CommandRecord",
    "Failure",
    "FeedbackChange",
    "LiveView",
    "NodeInfo",
    "NodeLookupError",
    "SinkError",
    "StatusChange",
    "TickExtras",
    "TickFrame",
    "TickRecord",
    "Trace",
    "TraceEvent",
    "TraceFormatReader",
    "TraceFormatWriter",
    "TraceRecorder",
    "TreeStructure",
    "attach_live_view",
    "attach_trace",
    "counter_values",
    "format_summary",
    "live_view_hook",
    "load_format_entry_points",
    "open_reader",
    "open_writer",
    "read_trace",
    "register_reader",
    "register_writer",
    "summarise",
    "supervised_extras",
    "trace_schema",
    "tree_structure",
    "tree_text",
]
