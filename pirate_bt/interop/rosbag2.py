"""Traces as rosbag2 directories: ``ros2 bag play``, ``ros2 bag info`` and Foxglove open them.

``pirate-bt trace export RUN.jsonl -o RUN_bag/`` (a name ending in ``/`` or
``_bag``, or an existing empty directory) writes a rosbag2 bag: a directory
with ``metadata.yaml`` and one MCAP file, every message in CDR. It holds the
topics the live ROS 2 output shows (:mod:`pirate_bt.interop.ros2_topics`, under
the namespace, ``/pirate`` by default), each written when its content changed,
stamped with the run's clock (the trace's ``created_utc`` plus ``t_s``), and one
more topic, ``<namespace>/trace`` (``std_msgs/msg/String``): every record of the
trace as its JSON text, so the bag holds the whole run and
:func:`read_rosbag2_records` gives the trace back record for record. There is no
``/clock`` in a bag; ``ros2 bag play --clock`` publishes one.

The bag is written beside the target under a temporary name and renamed into
place when complete: an error leaves nothing half-written. Bags are written with
`rosbags <https://gitlab.com/ternaris/rosbags>`_ (storage ``mcap``, the RIHS01
type hashes in the metadata); the messages are the live output's own CDR
(:mod:`pirate_bt.interop.ros2_cdr`), which the tests read back with rosbags.

The bag format's version is the one the ROS 2 distribution that reads the bag
understands (:data:`ROS_DISTROS`): 9 for Jazzy and later (the default), 8 for
Humble and Iron. Version 9 writes each topic's ``offered_qos_profiles`` as a YAML
list with the policies by name; Humble's and Iron's rosbag2 read that field as text
(``as<std::string>()``, rosbag2_storage's ``yaml.hpp``/``metadata_io.cpp``) and
stop at it, ``yaml-cpp: ... bad conversion``, and their player reads the policies
as numbers. Version 8 writes the list as text, the policies as numbers, in the
metadata and in the MCAP channels alike, and Jazzy reads it too.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pirate_bt.atomic import cut_name, new_folders_undone
from pirate_bt.errors import (
    MAX_PATH,
    ArgumentTypeError,
    ConfigurationError,
    InputError,
    file_argument,
    shown,
)
from pirate_bt.interop.foxglove_schemas import escape_surrogates
from pirate_bt.interop.ros2_cdr import string_message
from pirate_bt.interop.ros2_option import DEFAULT_NAMESPACE
from pirate_bt.interop.ros2_topics import CLOCK, TREE, Frame, Ros2Mapper, _number
from pirate_bt.interop.ros2_types import missing, type_hash, typestore
from pirate_bt.trace.records import BAD_RECORD

if TYPE_CHECKING:
    from pirate_bt.trace.reader import TraceFormatReader

__all__ = [
    "BAD_RECORD",
    "DEFAULT_ROS_DISTRO",
    "ROS_DISTROS",
    "TRACE_TOPIC",
    "bag_version",
    "export_rosbag2",
    "frames_from_records",
    "is_bag_path",
    "read_rosbag2_records",
    "start_ns_of",
]


TRACE_TOPIC = "trace"
"""The topic (relative to the namespace) that holds every trace record as JSON text."""

ROS_DISTROS: dict[str, int] = {"humble": 8, "iron": 8, "jazzy": 9, "kilted": 9, "rolling": 9}
"""The rosbag2 format version written for the distribution that will read the bag:
Humble and Iron read version 8 and not 9; Jazzy and later read both."""

DEFAULT_ROS_DISTRO = "jazzy"


def bag_version(ros_distro: object) -> int:
    """The bag format version for ``ros_distro`` (a name of :data:`ROS_DISTROS`, in
    any case).

    Raises:
        ArgumentTypeError: ``ros_distro`` is not text.
        InputError: a distribution the export does not know.
    """
    if not isinstance(ros_distro, str):
        raise ArgumentTypeError(f"ros_distro: give a distribution's name, not {shown(ros_distro)}")
    version = ROS_DISTROS.get(ros_distro.lower())
    if version is None:
        raise InputError(
            f"ros_distro {shown(ros_distro)}: not a ROS 2 distribution the rosbag2 export"
            f" writes for; give one of {', '.join(ROS_DISTROS)}"
        )
    return version


_TASK = "task."


def start_ns_of(header: Mapping[str, Any]) -> int:
    """The run's start in ns since the Unix epoch, from a trace header's ``created_utc``."""
    text = header.get("created_utc")
    if isinstance(text, str):
        try:
            return int(datetime.fromisoformat(text).timestamp()) * 1_000_000_000
        except ValueError:
            pass
    return 0


def frames_from_records(records: Iterable[Mapping[str, Any]]) -> Iterator[tuple[Any, Frame | None]]:
    """One frame per tick record of a trace, values accumulated as the trace says.

    Yields ``(record, frame)`` pairs; a header yields ``(header, None)`` first. The
    supervisor's part is read from the verdicts (``commands``): the last one, the
    reason of the last safe state (cleared by an operator's resume), and ``estop``
    as the mode once an e-stop latched.
    """
    state: dict[str, Any] = {}
    link: dict[str, Any] = {}
    sim: dict[str, Any] = {}
    task: dict[str, Any] = {}
    statuses: dict[str, str] = {}
    feedback: dict[str, str] = {}
    blackboard: dict[str, Any] = {}
    supervisor: dict[str, Any] = {}
    for record in records:
        kind = record.get("type")
        if kind == "header":
            state, link, sim, task = {}, {}, {}, {}
            statuses, feedback, blackboard, supervisor = {}, {}, {}, {}
            yield record, None
            continue
        if kind != "tick":
            yield record, None
            continue
        if record.get("status"):
            statuses.update(record["status"])
        if record.get("feedback"):
            feedback.update(record["feedback"])
        if record.get("bb"):
            blackboard.update(record["bb"])
        for key in record.get("bb_unset") or ():
            blackboard.pop(key, None)
        if record.get("state") is not None:
            if record.get("full"):
                state = dict(record["state"])
            else:
                state.update(record["state"])
        if record.get("link") is not None:
            link.update(record["link"])
        for key, value in (record.get("sim") or {}).items():
            if key.startswith(_TASK):
                task[key[len(_TASK) :]] = value
            else:
                sim[key] = value
        for command in record.get("commands") or ():
            supervisor["last_command"] = command.get("command")
            supervisor["last_verdict"] = command.get("verdict")
            supervisor["last_reason"] = command.get("reason")
            supervisor["last_detail"] = command.get("detail")
            supervisor["last_source"] = command.get("source")
            reason = command.get("reason")
            if command.get("source") == "supervisor" and reason == "safe_state":
                supervisor["safe_state"] = command.get("detail") or "safe state"
            if reason == "estop_latched" and command.get("source") == "supervisor":
                supervisor["mode"] = "estop"
        yield (
            record,
            Frame(
                n=int(record.get("n", 0)),
                t_s=_number(record.get("t_s", 0.0)),
                state=dict(state),
                link=dict(link),
                sim=dict(sim),
                task=dict(task),
                statuses=dict(statuses),
                feedback=dict(feedback),
                blackboard=dict(blackboard),
                supervisor=dict(supervisor),
            ),
        )


def is_bag_path(text: str | Path) -> bool:
    """Whether an export target names a rosbag2 directory (see the module docstring)."""
    raw = str(text)
    if raw.endswith(("/", os.sep)) or raw.rstrip("/").endswith("_bag"):
        return True
    path = Path(raw)
    return path.is_dir() and not any(path.iterdir())


def _trace_topic(namespace: object) -> str:
    """The trace topic in ``namespace``.

    Raises:
        ArgumentTypeError: ``namespace`` is not text.
        InputError: a namespace ROS 2 refuses (it was a ``ValueError`` from deep inside,
            after the trace had been read).
    """
    from pirate_bt.interop.rmw_zenoh import qualified_name
    from pirate_bt.interop.ros2_option import check_names

    if not isinstance(namespace, str):
        raise ArgumentTypeError(f"namespace: give text, not {shown(namespace)}")
    try:
        # the live node's rules (rmw_validate_namespace), so that a bag and a live run
        # refuse the same namespaces: '/pirate/' and '//pirate' were written as '/pirate'
        check_names(namespace, "pirate_bt", TRACE_TOPIC)
    except InputError as exc:
        rule = str(exc).split(": ", 1)[-1]
        raise InputError(f"namespace {shown(namespace)}: {rule}") from None
    try:
        return qualified_name(namespace, TRACE_TOPIC)
    except ValueError as exc:
        raise InputError(f"namespace {shown(namespace)}: {exc}") from None


def _rosbags() -> Any:
    try:
        from rosbags import rosbag2
    except ImportError:
        raise ConfigurationError(missing("a rosbag2 export", "rosbags")) from None
    return rosbag2


def _offered_qos(topic: str) -> Any:
    """The QoS the live node offers on ``topic`` (:mod:`pirate_bt.interop.ros2_process`), as
    the bag's ``offered_qos_profiles``: ``ros2 bag play`` offers it again. Without it the
    player offers volatile, and a subscriber asking for the latched tree (transient
    local, as py_trees_ros's tree watcher does) is incompatible and gets nothing."""
    from rosbags.interfaces import (
        Qos,
        QosDurability,
        QosHistory,
        QosLiveliness,
        QosReliability,
        QosTime,
    )

    infinite = QosTime(9223372036, 854775807)  # RMW_DURATION_INFINITE, as rosbag2 writes it
    latched = topic == TREE
    return Qos(
        history=QosHistory.KEEP_LAST,
        depth=1 if latched else 10,
        reliability=QosReliability.RELIABLE,
        durability=QosDurability.TRANSIENT_LOCAL if latched else QosDurability.VOLATILE,
        deadline=infinite,
        lifespan=infinite,
        liveliness=QosLiveliness.AUTOMATIC,
        liveliness_lease_duration=infinite,
        avoid_ros_namespace_conventions=False,
    )


def export_rosbag2(
    trace_path: Path,
    out_dir: Path,
    *,
    namespace: str = DEFAULT_NAMESPACE,
    ros_distro: str = DEFAULT_ROS_DISTRO,
) -> Path:
    """Convert a trace file to a rosbag2 directory (MCAP storage, CDR).

    Args:
        trace_path: The trace (any suffix :func:`pirate_bt.trace.read_trace` reads).
        out_dir: The bag directory to write; it must not exist, or be empty.
        namespace: The namespace of the topics.
        ros_distro: The ROS 2 distribution that will read the bag (:data:`ROS_DISTROS`):
            ``"humble"`` or ``"iron"`` writes bag format version 8, which they read;
            ``"jazzy"`` (the default) and later, version 9.

    Returns:
        ``out_dir``.

    Raises:
        InputError: a path that is no file name, the trace cannot be read or is not a
            trace; ``out_dir`` is not empty or cannot be made; a namespace ROS 2 refuses;
            a ``ros_distro`` it does not know.
        ArgumentTypeError: ``namespace`` or ``ros_distro`` is not text.
        ConfigurationError: ``rosbags`` is missing.
    """
    from pirate_bt.trace.reader import open_reader

    trace_path = file_argument(trace_path, "trace_path")
    if not isinstance(namespace, str):
        raise ArgumentTypeError(f"namespace: give text, not {shown(namespace)}")
    _trace_topic(namespace)  # a namespace ROS refuses: said before anything is read
    version = bag_version(ros_distro)
    rosbag2 = _rosbags()
    out = Path(str(file_argument(out_dir, "out_dir")).rstrip("/") or "/")
    if out.name in ("", ".."):  # '.', '..', '/': the folder's own name (the bag's is made
        # of it); '.' was an 'internal error: WriterError: ..XXXXXXXX exists already'
        out = Path(os.path.abspath(out))
    try:
        taken = out.exists() and (not out.is_dir() or any(out.iterdir()))
    except OSError as exc:  # a name the system refuses (a part too long)
        raise InputError(
            f"out_dir: cannot write {shown(str(out), MAX_PATH)}: {exc.strerror}"
        ) from None
    if taken:
        raise InputError(f"{out}: exists and is not an empty directory; rosbag2 writes a new one")
    store = typestore()
    records = open_reader(Path(trace_path))
    folder = out.parent if str(out.parent) else Path(".")
    # the folders on the way are made, as for every other export, and taken away again
    # when the export fails (before 2026-11-30: 'No such file or directory')
    with new_folders_undone(folder):
        try:
            folder.mkdir(parents=True, exist_ok=True)
            # named after the target cut to 64 bytes (as write_atomically names its
            # files): the whole name with a dot before and 9 characters after went over
            # 255 bytes
            temp = Path(tempfile.mkdtemp(prefix=f".{cut_name(out.name)}.", dir=folder))
        except OSError as exc:  # a file on the way, no permission
            raise InputError(
                f"out_dir: cannot write {shown(str(out), MAX_PATH)}: {exc.strerror}"
            ) from None
        return _write_bag(rosbag2, store, records, trace_path, out, temp, namespace, version)


def _write_bag(
    rosbag2: Any,
    store: Any,
    records: TraceFormatReader,
    trace_path: Path,
    out: Path,
    temp: Path,
    namespace: str,
    version: int,
) -> Path:
    """Write the bag in ``temp`` and move it to ``out`` (:func:`export_rosbag2`), in bag
    format ``version``."""
    from pirate_bt.interop.rmw_zenoh import qualified_name
    from pirate_bt.trace.reader import no_header
    from pirate_bt.trace.structure import TreeStructure

    bag = temp / out.name
    try:
        plugin = rosbag2.StoragePlugin.MCAP
        with rosbag2.Writer(bag, version=version, storage_plugin=plugin) as writer:
            connections: dict[str, Any] = {}

            def connection(topic: str, type_name: str) -> Any:
                if topic not in connections:
                    connections[topic] = writer.add_connection(
                        qualified_name(namespace, topic),
                        type_name,
                        typestore=store,
                        rihs01=type_hash(type_name),
                        offered_qos_profiles=[_offered_qos(topic)],
                    )
                return connections[topic]

            mapper: Ros2Mapper | None = None
            start_ns = 0
            first = True
            string_type = "std_msgs/msg/String"
            current = [0]

            def numbered() -> Iterator[Any]:
                for line, record in records:
                    current[0] = line  # frames_from_records yields once per record, in order
                    yield record

            try:
                for record, frame in frames_from_records(numbered()):
                    line = current[0]
                    if first and record.get("type") != "header":
                        raise InputError(
                            f"{trace_path}:{line}: not a trace: the first record is no header"
                        )
                    if record.get("type") == "header":
                        structure = TreeStructure.from_json(
                            record.get("tree") or {"name": "", "nodes": []}
                        )
                        start_ns = start_ns_of(record)
                        mapper = Ros2Mapper(
                            structure,
                            start_ns,
                            hardware_id=str((record.get("robot") or {}).get("name") or "pirate"),
                            period_s=float(record.get("tick_period_s") or 0.0),
                        )
                    first = False
                    when = start_ns + round(float(record.get("t_s") or 0.0) * 1e9)
                    text = json.dumps(record, ensure_ascii=False, separators=(",", ":"))
                    # a lone surrogate (a tree built in Python) escaped, not made '?'
                    text = escape_surrogates(text)
                    writer.write(connection(TRACE_TOPIC, string_type), when, string_message(text))
                    if frame is None or mapper is None:
                        continue
                    for out_message in mapper.messages(frame, changed=True):
                        if out_message.topic == CLOCK:
                            continue
                        writer.write(
                            connection(out_message.topic, out_message.type_name),
                            out_message.stamp_ns,
                            out_message.data,
                        )
            except BAD_RECORD as exc:  # a value of the wrong kind, or out of range
                raise InputError(
                    f"{trace_path}:{current[0]}: cannot convert this record:"
                    f" {type(exc).__name__}: {exc}"
                ) from None
            if first:
                raise no_header(trace_path, records.truncated)
        if out.is_dir():  # an empty folder given: filled, not replaced (the current
            # folder, say: replaced, the user's shell would be left in a deleted one)
            for part in sorted(bag.iterdir(), key=lambda made: made.name == "metadata.yaml"):
                part.rename(out / part.name)  # the metadata last: then it is a bag
        else:
            bag.rename(out)
    except OSError as exc:  # a full disk: was the bare 'File too large', no file named
        raise InputError(
            f"out_dir: cannot write {shown(str(out), MAX_PATH)}: {exc.strerror or exc}"
        ) from None
    finally:
        shutil.rmtree(temp, ignore_errors=True)
    return out


def read_rosbag2_records(bag: Path, *, namespace: str = DEFAULT_NAMESPACE) -> list[dict[str, Any]]:
    """The trace records a bag written by :func:`export_rosbag2` holds, in order.

    Raises:
        InputError: not a bag, no trace topic in it, or a message on it that is no
            trace record (named by its number on the topic, from 1); a namespace ROS 2
            refuses.
        ArgumentTypeError: ``namespace`` is not text, ``bag`` no file name (``None``, a
            number, bytes), as :func:`export_rosbag2` refuses one.
        ArgumentValueError: ``bag`` is empty or holds a NUL.
        ConfigurationError: ``rosbags`` is missing.
    """
    # until 2026-11-30 such a name went to rosbags: 'None: not a readable rosbag2 bag:
    # TypeError: expected str, bytes or os.PathLike object', a NUL written into the line
    bag = file_argument(bag, "bag")
    topic = _trace_topic(namespace)
    rosbag2 = _rosbags()
    store = typestore()
    string_type = "std_msgs/msg/String"
    records: list[tuple[int, dict[str, Any]]] = []
    try:
        with rosbag2.Reader(Path(bag)) as reader:
            chosen = [c for c in reader.connections if c.topic == topic]
            if not chosen:
                # a bag exported with another namespace is pirate-bt's too: name it
                others = sorted(
                    c.topic
                    for c in reader.connections
                    if c.topic.rsplit("/", 1)[-1] == TRACE_TOPIC and c.msgtype == string_type
                )
                if others:
                    where = others[0].rsplit("/", 1)[0] or "/"
                    raise InputError(
                        f"{bag}: no {topic} topic; its trace is {others[0]}: give"
                        f" namespace={where!r} (the namespace it was exported in)"
                    )
                raise InputError(f"{bag}: no {topic} topic (not exported by pirate-bt?)")
            for connection in chosen:
                if connection.msgtype != string_type:
                    raise InputError(
                        f"{bag}: {topic} holds {connection.msgtype}, not {string_type}"
                        " (not exported by pirate-bt?)"
                    )
            for number, (_, stamp, raw) in enumerate(reader.messages(connections=chosen), start=1):
                # a message rosbags cannot decode, or whose text is no JSON object, is
                # named here (it raised the decoder's own error, or gave a list back)
                try:
                    record = json.loads(store.deserialize_cdr(raw, string_type).data)
                except Exception as exc:  # rosbags' SerdeError, JSON's ValueError
                    raise InputError(
                        f"{bag}: message {number} on {topic} is no trace record: {exc}"
                    ) from None
                if not isinstance(record, dict):
                    raise InputError(
                        f"{bag}: message {number} on {topic} is no trace record"
                        f" (JSON {type(record).__name__}, not an object)"
                    )
                records.append((stamp, record))
            if not records:  # a trace has a header at least: [] would be read as a run
                counted = sum(c.msgcount for c in chosen)
                raise InputError(
                    f"{bag}: no message on {topic} (its metadata counts {counted}); no trace"
                )
    except InputError:
        raise
    except (rosbag2.ReaderError, FileNotFoundError) as exc:
        raise InputError(f"{bag}: not a readable rosbag2 bag: {exc}") from None
    except Exception as exc:  # a decompressor's (a zstd file cut short), or the metadata's
        # text (not UTF-8): until 2026-11-30 these came out as EOFError, ZstdError or
        # UnicodeDecodeError with a traceback
        raise InputError(
            f"{bag}: not a readable rosbag2 bag: {type(exc).__name__}: {exc}"
        ) from None
    return list(_in_record_order(records))


_RANK = {"header": 0, "end": 2}
"""Where a record goes among those of one timestamp: the header first, the end last."""


def _in_record_order(stamped: list[tuple[int, dict[str, Any]]]) -> Iterator[dict[str, Any]]:
    """The trace topic's records (in timestamp order, as rosbags reads them) in the order
    of the trace, whatever the order of those that share a timestamp.

    A run's end shares its timestamp with its last tick, and rosbag2 leaves the order of
    messages of one timestamp to the writer: a bag written again by another tool (rosbags'
    ``Writer``, a conversion, a merge) that put the end first was read with the end before
    the last tick. Each run of records of one timestamp is put in order by what they are:
    the header, then the ticks by number (in bag order within one number), then the end.
    Records of different timestamps keep their order (ticks out of order stay so, and are
    refused where a trace is read).
    """
    group: list[tuple[int, int, int, dict[str, Any]]] = []
    time = None
    for stamp, record in stamped:
        if stamp != time and group:
            group.sort(key=lambda item: item[:3])
            yield from (item[3] for item in group)
            group = []
        time = stamp
        kind = record.get("type")
        rank = _RANK.get(kind, 1) if isinstance(kind, str) else 1
        n = record.get("n")
        tick = n if rank == 1 and isinstance(n, int) and not isinstance(n, bool) else 0
        group.append((rank, tick, len(group), record))
    group.sort(key=lambda item: item[:3])
    yield from (item[3] for item in group)
