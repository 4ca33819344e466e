"""One mapping from trace records to Foxglove topics, and back.

Foxglove (and its open fork Lichtblick) shows data as *topics*: named streams of
messages, each message a JSON object described by a JSON Schema. A pirate_bt
trace is a stream of *records* (``header``, ``tick``, ``end``; see
``docs/formats/trace.md``) in which each tick holds only what changed. This
module turns records into topic messages, and messages back into records, so
that the MCAP file writer (:mod:`pirate_bt.interop.mcap_trace`) and the live
WebSocket server (:mod:`pirate_bt.interop.foxglove_live`) publish exactly the
same topics from the same records, and an MCAP file can be read back into the
trace it came from.

The topics (all under ``/pirate``):

============================  =====================  =========================================
topic                         schema                 one message per ...
============================  =====================  =========================================
``/pirate/run``               ``pirate.Run``         run: the trace's header record as it is
``/pirate/state``             ``pirate.RobotState``  tick in which the state changed: every
                                                     value as it is now (not only the changes),
                                                     nested by view (``joint_angle_rad.bend_1``)
                                                     and ``speed_mps``, the mean wheel speed
``/pirate/tree``              ``pirate.TreeStatus``  tick in which a status or feedback message
                                                     changed: the changes, and ``active``, the
                                                     name path of the deepest running node
``/pirate/blackboard``        ``pirate.Blackboard``  tick in which the blackboard changed
``/pirate/commands``          ``pirate.Verdict``     command: what was asked, the supervisor's
                                                     verdict (pass, clip, refuse) and why
``/pirate/link``              ``pirate.LinkHealth``  tick in which link health changed (all of it)
``/pirate/sim``               ``pirate.SimTruth``    tick in which a simulator counter changed
``/pirate/localisation``      ``pirate.Localisation`` tick in which the belief changed: belief,
                                                     simulator truth, error, fixes (``task.*``)
``/pirate/log``               ``foxglove.Log``       event (fault, e-stop, operator, exception,
                                                     note), refusal, and the end of the run
``/pirate/end``               ``pirate.RunEnd``      run: the end record as it is
``/pirate/tick``              ``pirate.Tick``        tick record that nothing above carries (a
                                                     tick where nothing changed, keys of a newer
                                                     trace version)
============================  =====================  =========================================

Every message but ``/pirate/run`` and ``/pirate/log`` carries the tick ``n`` and
``t_s`` (seconds since the header). Log times are the run's clock: the header's
``created_utc`` plus ``t_s``, in nanoseconds (a simulated run of ten minutes
spans ten minutes, however fast it ran).

Records back from messages (:func:`records_from_messages`): state, link health
and counters are sent as whole values and turned back into changes by comparing
each message with the one before on its topic, which gives back exactly what the
recorder wrote (it writes a value only when it differs from the one it last
wrote). Derived members (``speed_mps``, ``active``, names and paths, the log
lines of refusals and of the end) are dropped.

The topic names and schemas live in :mod:`pirate_bt.interop.foxglove_schemas`,
the way back in :mod:`pirate_bt.interop.foxglove_records`; this module keeps
every name it had.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from datetime import datetime
from typing import Any

from pirate_bt.interop.foxglove_records import records_from_messages
from pirate_bt.interop.foxglove_schemas import (
    _END_LEVEL,
    _ERROR,
    _EVENT_LEVEL,
    _INFO,
    _STATUS_NAME,
    _TASK,
    _TICK_KEYS,
    _WARNING,
    BLACKBOARD,
    COMMANDS,
    END,
    LINK,
    LOCALISATION,
    LOG,
    RUN,
    SIM,
    STATE,
    TICK,
    TOPICS,
    TREE,
    encode_message,
    missing_extra,
    schema_of,
)

__all__ = [
    "TOPICS",
    "TopicMapper",
    "TopicMessage",
    "encode_message",
    "missing_extra",
    "records_from_messages",
    "schema_of",
]


# --- records -> messages -----------------------------------------------------------


@dataclass(frozen=True, slots=True)
class TopicMessage:
    """One message on one topic.

    Attributes:
        topic: The topic (one of :data:`TOPICS`).
        log_time_ns: When, on the run's clock, in nanoseconds since the Unix epoch.
        message: The message (JSON data).
    """

    topic: str
    log_time_ns: int
    message: dict[str, Any]


def _start_ns(header: Mapping[str, Any]) -> int:
    text = header.get("created_utc")
    if isinstance(text, str):
        try:
            return int(datetime.fromisoformat(text).timestamp()) * 1_000_000_000
        except ValueError:
            pass
    return 0


def _nest(flat: Mapping[str, Any]) -> dict[str, Any]:
    """``{"joint_angle_rad.bend_1": v}`` → ``{"joint_angle_rad": {"bend_1": v}}``."""
    out: dict[str, Any] = {}
    for name, value in flat.items():
        group, dot, key = name.partition(".")
        if dot:
            inner = out.get(group)
            if not isinstance(inner, dict):
                inner = out[group] = {}
            inner[key] = value
        else:
            out[name] = value
    return out


def _mean(values: Iterable[Any]) -> float:
    numbers = [v for v in values if isinstance(v, int | float) and not isinstance(v, bool)]
    return sum(numbers) / len(numbers) if numbers else 0.0


class TopicMapper:
    """Turns trace records (header, ticks, end) into topic messages.

    Keeps what it needs between records: the tree's node names, the statuses, and
    the whole state, link health, counters and blackboard, since each tick record
    holds only what changed and each message holds everything. Feed it records in
    order, header first; a new header (a new run) starts afresh.
    """

    def __init__(self) -> None:
        self._reset({})

    def _reset(self, header: Mapping[str, Any]) -> None:
        self.header: dict[str, Any] = dict(header)
        self._start_ns = _start_ns(header)
        nodes = (header.get("tree") or {}).get("nodes") or []
        self._names: dict[str, str] = {}
        self._paths: dict[str, str] = {}
        self._children: dict[str, list[str]] = {}
        for node in nodes:
            node_id, name, parent = str(node.get("id")), str(node.get("name")), node.get("parent")
            self._names[node_id] = name
            above = self._paths.get(str(parent)) if parent is not None else None
            self._paths[node_id] = f"{above}/{name}" if above else name
            self._children[node_id] = [str(c) for c in node.get("children") or []]
        self._root = str(nodes[0].get("id")) if nodes else None
        self.statuses: dict[str, str] = {}
        self._active: str | None = None
        self.feedback: dict[str, Any] = {}
        self.state: dict[str, Any] = {}
        self.link: dict[str, Any] = {}
        self.sim: dict[str, Any] = {}
        self.localisation: dict[str, Any] = {}
        self.blackboard: dict[str, Any] = {}
        self.last: dict[str, TopicMessage] = {}
        """The last message on each topic (what a late live subscriber is sent)."""

    def log_time_ns(self, t_s: Any) -> int:
        """The log time of a moment ``t_s`` seconds into the run."""
        seconds = t_s if isinstance(t_s, int | float) else 0.0
        return self._start_ns + round(seconds * 1e9)

    def messages(self, record: Mapping[str, Any]) -> list[TopicMessage]:
        """The messages of one record (a tick in which nothing changed gives one on /tick).

        Raises:
            ValueError: a record of an unknown type.
        """
        kind = record.get("type")
        out: list[TopicMessage] = []
        if kind == "tick":
            self._tick(record, out)
        elif kind == "header":
            self._reset(record)
            out.append(TopicMessage(RUN, self._start_ns, dict(record)))
        elif kind == "end":
            when = self.log_time_ns(record.get("t_s"))
            out.append(TopicMessage(END, when, dict(record)))
            outcome = str(record.get("outcome"))
            reason = record.get("reason")
            text = f"run ended: {outcome}" + (f" - {reason}" if reason else "")
            if record.get("dropped"):
                text += f" ({record['dropped']} ticks not shown: the live view lagged)"
            level = _END_LEVEL.get(outcome, _ERROR)
            out.append(self._log(when, record, level, text, "end", "end"))
        else:
            raise ValueError(f"not a trace record type: {kind!r}")
        for message in out:
            self.last[message.topic] = message
        return out

    def _log(
        self,
        when: int,
        record: Mapping[str, Any],
        level: int,
        text: str,
        name: str,
        origin: str,
    ) -> TopicMessage:
        message: dict[str, Any] = {
            "timestamp": {"sec": when // 1_000_000_000, "nsec": when % 1_000_000_000},
            "level": level,
            "message": text,
            "name": name,
            "file": "",
            "line": 0,
            "n": record.get("n"),
            "t_s": record.get("t_s"),
            "record": origin,
        }
        return TopicMessage(LOG, when, message)

    def _tick(self, record: Mapping[str, Any], out: list[TopicMessage]) -> None:
        n, t_s = record.get("n"), record.get("t_s")
        when = self.log_time_ns(t_s)
        stamp = {"n": n, "t_s": t_s}
        status = record.get("status")
        feedback = record.get("feedback")
        if status or feedback:
            tree: dict[str, Any] = dict(stamp)
            if status:
                self.statuses.update(status)
                tree["status"] = [
                    {
                        "id": node_id,
                        "name": self._names.get(node_id, ""),
                        "path": self._paths.get(node_id, ""),
                        "status": _STATUS_NAME.get(code, code),
                    }
                    for node_id, code in status.items()
                ]
            if feedback:
                self.feedback.update(feedback)
                tree["feedback"] = [
                    {"id": node_id, "name": self._names.get(node_id, ""), "feedback": text}
                    for node_id, text in feedback.items()
                ]
            if status or self._active is None:  # only a status change moves it
                self._active = self.active()
            tree["active"] = self._active
            out.append(TopicMessage(TREE, when, tree))
        bb, unset = record.get("bb"), record.get("bb_unset")
        if bb or unset:
            board: dict[str, Any] = dict(stamp)
            if bb:
                self.blackboard.update(bb)
                board["set"] = bb
            if unset:
                for key in unset:
                    self.blackboard.pop(key, None)
                board["unset"] = unset
            board["values"] = dict(self.blackboard)
            out.append(TopicMessage(BLACKBOARD, when, board))
        state = record.get("state")
        if state is not None:
            if record.get("full"):
                self.state = dict(state)
            else:
                self.state.update(state)
            nested = _nest(self.state)
            drives = nested.get("drive_velocity_mps")
            message = {**stamp, **nested}
            message["speed_mps"] = _mean(drives.values()) if isinstance(drives, dict) else 0.0
            if record.get("full"):
                message["full"] = True
            out.append(TopicMessage(STATE, when, message))
        for command in record.get("commands") or ():
            verdict: dict[str, Any] = {**stamp, **command}
            sent = command.get("sent")
            if sent is not None:
                verdict["sent"] = [
                    {"motor": m, "mode": mode, "value": value} for m, mode, value in sent
                ]
            node = command.get("node")
            if node is not None:
                verdict["node_path"] = self._paths.get(str(node), "")
            out.append(TopicMessage(COMMANDS, when, verdict))
            if command.get("verdict") == "refuse":
                who = verdict.get("node_path") or command.get("source") or "-"
                why = command.get("detail") or command.get("reason") or ""
                text = f"{who}: {command.get('command')} refused ({why})"
                out.append(self._log(when, record, _WARNING, text, "supervisor", "commands"))
        link = record.get("link")
        if link is not None:
            self.link.update(link)
            out.append(TopicMessage(LINK, when, {**stamp, **self.link}))
        sim = record.get("sim")
        if sim is not None:
            counters = {k: v for k, v in sim.items() if not k.startswith(_TASK)}
            task = {k[len(_TASK) :]: v for k, v in sim.items() if k.startswith(_TASK)}
            if counters:
                self.sim.update(counters)
                out.append(TopicMessage(SIM, when, {**stamp, **self.sim}))
            if task:
                self.localisation.update(task)
                out.append(TopicMessage(LOCALISATION, when, {**stamp, **self.localisation}))
        for event in record.get("events") or ():
            kind = str(event.get("kind", "note"))
            node = event.get("node")
            where = self._paths.get(str(node), str(node)) if node is not None else ""
            text = f"{kind}: {event.get('message', '')}" + (f" (at {where})" if where else "")
            line = self._log(when, record, _EVENT_LEVEL.get(kind, _INFO), text, kind, "events")
            line.message["event"] = event
            out.append(line)
        extra = {k: v for k, v in record.items() if k not in _TICK_KEYS}
        if extra or not out:
            tick: dict[str, Any] = dict(stamp)
            if extra:
                tick["extra"] = extra
            out.append(TopicMessage(TICK, when, tick))

    def active(self) -> str:
        """The name path of the deepest RUNNING node (``""`` when the root is not running)."""
        node = self._root
        if node is None or self.statuses.get(node) != "R":
            return ""
        while True:
            child = next(
                (c for c in self._children.get(node, ()) if self.statuses.get(c) == "R"), None
            )
            if child is None:
                return self._paths.get(node, "")
            node = child

    def snapshot(self, topic: str) -> TopicMessage | None:
        """What a client that subscribes now should be sent on ``topic`` first, if anything.

        The whole-value topics repeat their last message; the tree topic gets every
        node's status and feedback message as it is now (``snapshot: true``).
        """
        if topic == TREE:
            last = self.last.get(TREE)
            if last is None:
                return None
            message = {
                "n": last.message.get("n"),
                "t_s": last.message.get("t_s"),
                "status": [
                    {
                        "id": node_id,
                        "name": self._names.get(node_id, ""),
                        "path": self._paths.get(node_id, ""),
                        "status": _STATUS_NAME.get(code, code),
                    }
                    for node_id, code in self.statuses.items()
                ],
                "feedback": [
                    {"id": node_id, "name": self._names.get(node_id, ""), "feedback": text}
                    for node_id, text in self.feedback.items()
                ],
                "active": self.active(),
                "snapshot": True,
            }
            return TopicMessage(TREE, last.log_time_ns, message)
        if topic in (RUN, STATE, LINK, SIM, LOCALISATION, BLACKBOARD, END):
            return self.last.get(topic)
        return None
