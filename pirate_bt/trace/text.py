"""Trees as text with statuses, and trace summaries, for terminals and logs.

The same drawing serves ``pirate-bt trace show`` (a tick read back from a
trace) and the live view (the tree while it runs): one line per node, indented
by depth, a status mark, the node's name and class, and its feedback message.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from pirate_bt.trace.coverage import GUARDS, Coverage
from pirate_bt.trace.reader import Trace
from pirate_bt.trace.structure import TreeStructure

__all__ = [
    "NodeSummary",
    "TraceSummary",
    "coverage_lines",
    "format_summary",
    "node_names",
    "one_line",
    "summarise",
    "tree_text",
]

STATUS_WORD = {"S": "SUCCESS", "F": "FAILURE", "R": "RUNNING", "I": "-"}
_MARK_UNICODE = {"S": "✔", "F": "✘", "R": "▶", "I": "·"}
_MARK_ASCII = {"S": "+", "F": "x", "R": "*", "I": "."}
_KIND_TAG = {"composite": "", "decorator": "^", "guard": "!", "leaf": ""}
_ANSI = {"S": "\x1b[32m", "F": "\x1b[31m", "R": "\x1b[33m", "I": "\x1b[2m"}
_RESET = "\x1b[0m"


def tree_text(
    structure: TreeStructure,
    status: Mapping[str, str],
    feedback: Mapping[str, str] | None = None,
    *,
    ascii_only: bool = False,
    colour: bool = False,
    collapse: bool = False,
) -> list[str]:
    """The tree as lines of text, one node per line.

    Args:
        structure: The tree's structure.
        status: Status code (``S``/``F``/``R``/``I``) by node id; missing is ``I``.
        feedback: Feedback message by node id.
        ascii_only: Use ``+ x * .`` instead of Unicode marks.
        colour: Colour lines with ANSI escapes by status.
        collapse: Hide the children of nodes that are not RUNNING (compact live view).
    """
    marks = _MARK_ASCII if ascii_only else _MARK_UNICODE
    feedback = feedback or {}
    lines: list[str] = []
    hidden: set[str] = set()
    for node in structure:
        if node.parent is not None and node.parent in hidden:
            hidden.add(node.id)
            continue
        code = status.get(node.id, "I")
        if collapse and code != "R" and node.children:
            hidden.add(node.id)
        tag = _KIND_TAG.get(node.kind, "")
        kind = f"{tag}{node.type}" if node.type != node.name else tag
        # a name or message with a line break, an escape sequence or a NUL (a tree
        # built in Python, a hand-made trace) broke its line or recoloured the terminal
        name = one_line(node.name)
        label = f"{name} [{one_line(kind)}]" if kind else name
        line = f"{'    ' * node.depth}{marks.get(code, '?')} {label}"
        if code != "I":
            line += f"  {STATUS_WORD[code]}"
        message = feedback.get(node.id, "")
        if message:
            line += f"  -- {one_line(message)}"
        if colour:
            line = f"{_ANSI.get(code, '')}{line}{_RESET}"
        lines.append(line)
    return lines


@dataclass
class NodeSummary:
    """What one node did over a run.

    Attributes:
        runs: Times the node started (turned RUNNING, or finished within the tick
            it started in).
        successes: Times it turned SUCCESS.
        failures: Times it turned FAILURE.
        running_s: Total seconds spent RUNNING.
    """

    runs: int = 0
    successes: int = 0
    failures: int = 0
    running_s: float = 0.0


@dataclass
class TraceSummary:
    """A run at a glance (``pirate-bt trace summary``)."""

    path: str
    tree: str
    outcome: str
    ticks: int
    duration_s: float
    truncated: bool
    nodes: dict[str, NodeSummary]
    commands: int = 0
    clips: int = 0
    refusals: list[dict[str, Any]] = field(default_factory=list)
    faults: list[dict[str, Any]] = field(default_factory=list)
    header: Mapping[str, Any] = field(default_factory=dict)
    coverage: Coverage | None = None
    """What each node did, as BT.CPP's ``TreeObserver`` counts it (from the end record)."""
    final_commands: list[dict[str, Any]] = field(default_factory=list)
    """Verdicts given after the last tick (the stops of the run's end; the end record)."""
    why: str | None = None
    """Why the run ended: the end record's reason, the first cause the run's own line
    gave (``None`` without an end record)."""


def summarise(trace: Trace) -> TraceSummary:
    """Count what every node did, and collect refusals and faults.

    Counts are of status *changes*: a condition that succeeds tick after tick
    counts once, since a trace stores only what changed (a tick record that gives a
    node the status it already had changes nothing). A run starts whenever a
    node turns RUNNING, SUCCESS or FAILURE from anything but RUNNING, so a node
    that finishes within the tick it started in (a refused command, a condition)
    counts as a run too: ``runs`` is never below ``ok + fail``.
    """
    nodes = {n.id: NodeSummary() for n in trace.structure}
    running_since: dict[str, float] = {}
    last_code: dict[str, str] = {}
    summary = TraceSummary(
        path=str(trace.path),
        tree=trace.structure.name,
        outcome=trace.outcome,
        ticks=trace.last_tick,
        duration_s=trace.duration_s,
        truncated=trace.truncated,
        nodes=nodes,
        header=trace.header,
        coverage=trace.coverage,
        why=trace.why,
    )
    for tick in trace.ticks:
        for node_id, code in tick.status.items():
            entry = nodes.get(node_id)
            before = last_code.get(node_id, "I")
            if entry is None or code == before:
                # the same status again is no change (a trace written by another tool,
                # or by hand, may repeat it): counted once, as trace.statuses() lists it
                continue
            started = running_since.pop(node_id, None)
            if started is not None:
                entry.running_s += tick.t_s - started
            if code in ("R", "S", "F") and before != "R":
                entry.runs += 1
            last_code[node_id] = code
            if code == "R":
                running_since[node_id] = tick.t_s
            elif code == "S":
                entry.successes += 1
            elif code == "F":
                entry.failures += 1
        for command in tick.commands:
            summary.commands += 1
            verdict = command.get("verdict")
            if verdict == "clip":
                summary.clips += 1
            elif verdict == "refuse":
                summary.refusals.append({"tick": tick.n, **command})
        for event in tick.events:
            if event.get("kind") in ("fault", "estop", "exception"):
                summary.faults.append({"tick": tick.n, **event})
    for node_id, started in running_since.items():
        nodes[node_id].running_s += trace.duration_s - started
    final = trace.end.get("commands") if trace.end is not None else None
    if isinstance(final, list):
        summary.final_commands = [c for c in final if isinstance(c, dict)]
    already = any(f.get("kind") == "exception" for f in summary.faults)
    if trace.end is not None and trace.end.get("error") and not already:
        error = trace.end["error"]
        summary.faults.append({"tick": trace.last_tick, "kind": "exception", **error})
    return summary


def node_names(structure: TreeStructure, node_id: str) -> str:
    """A node as its path of names from the root, e.g. ``bend/steer front/unclamp front``."""
    names: list[str] = []
    current: str | None = node_id
    while current is not None:
        node = structure.node(current)
        names.append(node.name)
        current = node.parent
    return "/".join(reversed(names))


def coverage_lines(coverage: Coverage, limit: int = 12) -> list[str]:
    """What a run's (or a campaign's) coverage says, in a few lines: how many nodes ran,
    which never did, and which guards never failed (their failure branch never ran)."""
    lines = [f"coverage  {coverage.summary()}"]
    for title, found in (
        ("never ran", coverage.never_ran()),
        ("guards and conditions that never failed", coverage.never_failed(GUARDS)),
    ):
        if not found:
            continue
        shown = ", ".join(n.path for n in found[:limit])
        more = f" and {len(found) - limit} more" if len(found) > limit else ""
        lines.append(f"  {title} ({len(found)}): {shown}{more}")
    return lines


def one_line(text: str) -> str:
    """``text`` on one line, as a result's ``why`` is: line breaks and control
    characters escaped (a feedback message or a node's name may hold them; the trace
    keeps them). Text without them is returned as it is, so a second pass changes
    nothing."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def _why_line(why: str) -> str:
    """``why`` as the run's own line said it (``RunResult.why``): escaped, and the middle
    of a long one left out; a 20,000-character exception was printed whole."""
    from pirate_bt.behaviours.foreign import one_line as result_why

    return result_why(why)


def format_summary(summary: TraceSummary, structure: TreeStructure) -> list[str]:
    """A summary as lines of text."""
    header = summary.header
    robot = header.get("robot")
    if not isinstance(robot, dict):  # a hand-edited header: "robot": "abc" ended in a traceback
        robot = {}
    outcome = summary.outcome
    if outcome == "incomplete":
        outcome += " (no end record: the run was cut off)"
    elif summary.truncated:  # the end record is there, what came after it is not
        outcome += " (the file is cut off after the run's end record)"
    lines = [
        f"trace     {summary.path}",
        f"tree      {summary.tree} ({len(structure)} nodes)",
        f"outcome   {outcome}",
        *([f"why       {_why_line(summary.why)}"] if summary.why is not None else []),
        f"ticks     {summary.ticks}",
        f"duration  {summary.duration_s:.3f} s",
    ]
    if robot.get("name") or robot.get("digest"):
        digest = str(robot.get("digest") or "")[:12]
        lines.append(f"robot     {robot.get('name') or '?'} (digest {digest or '?'})")
    if header.get("scenario") or header.get("seed") is not None:
        lines.append(f"scenario  {header.get('scenario') or '-'}, seed {header.get('seed')}")
    lines.append(
        f"commands  {summary.commands} ({summary.clips} clipped, {len(summary.refusals)} refused)"
    )
    width = max((len(one_line(n.name)) + 4 * n.depth for n in structure), default=4)
    coverage = summary.coverage.by_id() if summary.coverage is not None else {}
    extra = f" {'ticks':>7} {'trans':>6} {'halts':>5} {'skips':>5}" if coverage else ""
    lines.append("")
    lines.append(f"{'node':<{width}}  {'runs':>5} {'ok':>5} {'fail':>5} {'running':>10}{extra}")
    for node in structure:
        entry = summary.nodes[node.id]
        name = f"{'    ' * node.depth}{one_line(node.name)}"
        counts = ""
        seen = coverage.get(node.id)
        if seen is not None:
            counts = f" {seen.ticks:>7} {seen.transitions:>6} {seen.halts:>5} {seen.skips:>5}"
        lines.append(
            f"{name:<{width}}  {entry.runs:>5} {entry.successes:>5} {entry.failures:>5}"
            f" {entry.running_s:>9.3f}s{counts}"
        )
    if summary.coverage is not None:
        lines += ["", *coverage_lines(summary.coverage)]
    if summary.refusals:
        lines.append("")
        lines.append("refusals:")
        for refusal in summary.refusals:
            node_id = refusal.get("node")
            known = isinstance(node_id, str) and node_id in structure
            who = node_names(structure, str(node_id)) if known else "-"
            lines.append(
                f"  tick {refusal['tick']}: {who}: {refusal.get('command')}"
                f" refused ({refusal.get('reason', '?')}) {refusal.get('detail', '')}".rstrip()
            )
    if summary.final_commands:
        lines.append("")
        lines.append("after the last tick:")
        for command in summary.final_commands:
            detail = command.get("detail") or command.get("reason") or ""
            who = command.get("source") or "-"
            lines.append(
                f"  {command.get('command')} [{who}] {command.get('verdict')}: {detail}".rstrip()
            )
    if summary.faults:
        lines.append("")
        lines.append("faults:")
        for fault in summary.faults:
            text = fault.get("message") or fault.get("exception") or ""
            node_id = fault.get("node")
            where = ""
            if isinstance(node_id, str) and node_id in structure:
                where = f" at {structure.node(node_id).name}"
            lines.append(f"  tick {fault['tick']}: {fault.get('kind')}{where}: {text}")
    # every line on one line: names, reasons, commands and messages come from the file
    return [one_line(line) for line in lines]
