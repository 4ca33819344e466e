"""A rosbag2 export that ROS 2 Humble reads: ``export_rosbag2(..., ros_distro="humble")``
(``pirate-bt trace export T -o RUN_bag/ --ros-distro humble``) writes bag format 8.

The export wrote version 9 only. Humble's (and Iron's) rosbag2 reads a topic's
``offered_qos_profiles`` as text (rosbag2_storage ``metadata_io.cpp`` on the humble
branch: ``node["offered_qos_profiles"].as<std::string>()`` for version 4 and later),
which version 9 writes as a YAML list: ``ros2 bag info`` and ``play`` stopped at it,
``yaml-cpp: ... bad conversion`` (ros2/rosbag2 issues 1895 and 2013). Its player then
reads each policy as a number (rosbag2_transport ``qos.cpp``), which version 9 writes
by name. The metadata here is read as each distribution's rosbag2 reads it: the
fields it asks for, by version, with yaml-cpp's conversions, and the QoS of every
MCAP channel as its player (Humble) or storage (Jazzy) parses it.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import yaml

from tests.trace_support import run_and_record

pytest.importorskip("rosbags")


class BadConversion(Exception):
    """What yaml-cpp throws: ``yaml-cpp: error at ...: bad conversion``."""


def _node(parent: Any, key: str, where: str) -> Any:
    if not isinstance(parent, dict) or key not in parent:
        raise BadConversion(f"{where}.{key}: missing")  # an invalid node: as<> throws
    return parent[key]


def _as_str(value: Any, where: str) -> str:
    # a scalar only: a sequence, a map or null does not convert to std::string
    if value is None or isinstance(value, dict | list):
        raise BadConversion(f"{where}: {type(value).__name__} as std::string")
    return str(value)


def _as_int(value: Any, where: str, least: int = -(2**31)) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < least:
        raise BadConversion(f"{where}: {value!r} as an integer")
    return value


def _as_bool(value: Any, where: str) -> bool:
    if not isinstance(value, bool):
        raise BadConversion(f"{where}: {value!r} as bool")
    return value


def _time(node: Any, where: str) -> None:
    for key in ("sec", "nsec"):
        _as_int(_node(node, key, where), f"{where}.{key}", 0)


_NAMES = {
    "history": {"system_default", "keep_last", "keep_all", "unknown"},
    "reliability": {"system_default", "reliable", "best_effort", "unknown", "best_available"},
    "durability": {"system_default", "transient_local", "volatile", "unknown", "best_available"},
    "liveliness": {"system_default", "automatic", "manual_by_topic", "unknown", "best_available"},
}


def _qos_list(profiles: Any, where: str, by_name: bool) -> list[dict[str, Any]]:
    """QoS profiles as rosbag2 decodes them: the policies as numbers (Humble's
    ``Rosbag2QoS``, Jazzy's for a bag before version 9) or by name (Jazzy's, 9)."""
    if not isinstance(profiles, list):
        raise BadConversion(f"{where}: {type(profiles).__name__} as a sequence of QoS")
    for i, qos in enumerate(profiles):
        at = f"{where}[{i}]"
        for policy, names in _NAMES.items():
            value = _node(qos, policy, at)
            if by_name and not isinstance(value, int):
                if value not in names:
                    raise BadConversion(f"{at}.{policy}: {value!r} is no policy")
            else:
                _as_int(value, f"{at}.{policy}", 0)
        _as_int(_node(qos, "depth", at), f"{at}.depth", 0)
        for key in ("deadline", "lifespan", "liveliness_lease_duration"):
            _time(_node(qos, key, at), f"{at}.{key}")
        _as_bool(_node(qos, "avoid_ros_namespace_conventions", at), at)
    return profiles


def _qos_text(text: Any, where: str, by_name: bool = False) -> list[dict[str, Any]]:
    """``offered_qos_profiles`` given as text: YAML::Load, then the profiles."""
    return _qos_list(yaml.safe_load(_as_str(text, where)) or [], where, by_name)


def read_metadata(bag: Path, distro: str) -> tuple[int, dict[str, list[dict[str, Any]]]]:
    """``bag/metadata.yaml`` read as ``distro``'s rosbag2 reads it: its version and each
    topic's QoS profiles; :class:`BadConversion` where that rosbag2 stops."""
    doc = yaml.safe_load((bag / "metadata.yaml").read_text(encoding="utf-8"))
    info = _node(doc, "rosbag2_bagfile_information", "")
    version = _as_int(_node(info, "version", "info"), "version")
    _as_str(_node(info, "storage_identifier", "info"), "storage_identifier")
    _as_int(_node(_node(info, "duration", "info"), "nanoseconds", "duration"), "duration", 0)
    start = _node(info, "starting_time", "info")
    _as_int(_node(start, "nanoseconds_since_epoch", "starting_time"), "starting_time", 0)
    _as_int(_node(info, "message_count", "info"), "message_count", 0)
    topics = {}
    for i, entry in enumerate(_node(info, "topics_with_message_count", "info")):
        where = f"topics_with_message_count[{i}].topic_metadata"
        topic = _node(entry, "topic_metadata", where)
        name = _as_str(_node(topic, "name", where), f"{where}.name")
        for key in ("type", "serialization_format"):
            _as_str(_node(topic, key, where), f"{where}.{key}")
        profiles = _node(topic, "offered_qos_profiles", where)
        at = f"{where}.offered_qos_profiles"
        if distro == "humble" or version < 9:  # text, the policies as numbers
            topics[name] = _qos_text(profiles, at)
        else:  # jazzy, version 9: a sequence, the policies by name
            topics[name] = _qos_list(profiles, at, by_name=True)
        if distro == "jazzy" and version >= 7:
            _as_str(_node(topic, "type_description_hash", where), f"{where}.type_description_hash")
        _as_int(_node(entry, "message_count", where), "message_count", 0)
    for j, path in enumerate(_node(info, "relative_file_paths", "info")):
        _as_str(path, f"relative_file_paths[{j}]")
    for key in ("compression_format", "compression_mode"):
        _as_str(_node(info, key, "info"), key)
    for j, file in enumerate(_node(info, "files", "info")):
        _as_str(_node(file, "path", "files"), f"files[{j}].path")
        _node(_node(file, "starting_time", "files"), "nanoseconds_since_epoch", "files")
        _node(_node(file, "duration", "files"), "nanoseconds", "files")
        _as_int(_node(file, "message_count", "files"), "files.message_count", 0)
    if distro == "jazzy":
        custom = info.get("custom_data") if version >= 6 else None
        if version >= 6 and not (custom is None or isinstance(custom, dict)):
            raise BadConversion("custom_data")  # iterated as a map (null: empty)
        if version >= 8:
            _as_str(_node(info, "ros_distro", "info"), "ros_distro")
    return version, topics


def channel_qos(bag: Path, distro: str, version: int) -> dict[str, list[dict[str, Any]]]:
    """Each MCAP channel's ``offered_qos_profiles`` as ``distro``'s player gets it from
    the storage (the MCAP plugin hands the text on; Humble's player reads numbers)."""
    from mcap.reader import make_reader

    (mcap_file,) = bag.glob("*.mcap")
    with mcap_file.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    by_name = distro == "jazzy" and version >= 9
    return {
        channel.topic: _qos_text(
            channel.metadata.get("offered_qos_profiles"), channel.topic, by_name=by_name
        )
        for channel in summary.channels.values()
    }


@pytest.fixture(scope="module")
def trace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("bag22") / "run.jsonl"
    run_and_record(path, ticks=6)
    return path


def test_a_bag_for_humble_is_version_8_and_read_by_humble_and_jazzy(
    trace: Path, tmp_path: Path
) -> None:
    from pirate_bt.interop.rosbag2 import export_rosbag2, read_rosbag2_records

    bag = export_rosbag2(trace, tmp_path / "run_bag", ros_distro="humble")
    version, topics = read_metadata(bag, "humble")
    assert version == 8
    assert read_metadata(bag, "jazzy") == (8, topics)  # Jazzy reads it too
    channels = channel_qos(bag, "humble", version)
    assert channels == topics
    tree, trace_topic = topics["/pirate/tree/snapshots"], topics["/pirate/trace"]
    # what the live node offers, as numbers: reliable (1), keep last (1); the tree
    # latched, transient local (1) with depth 1; the others volatile (2), depth 10
    assert [(q["reliability"], q["history"], q["durability"], q["depth"]) for q in tree] == [
        (1, 1, 1, 1)
    ]
    assert [(q["durability"], q["depth"]) for q in trace_topic] == [(2, 10)]
    assert read_rosbag2_records(bag) == [
        json.loads(line) for line in trace.read_text(encoding="utf-8").splitlines()
    ]


def test_the_default_bag_is_version_9_which_humble_cannot_read(trace: Path, tmp_path: Path) -> None:
    from pirate_bt.interop.rosbag2 import export_rosbag2

    bag = export_rosbag2(trace, tmp_path / "run_bag")
    version, topics = read_metadata(bag, "jazzy")
    assert version == 9
    assert channel_qos(bag, "jazzy", version) == topics
    with pytest.raises(BadConversion, match="offered_qos_profiles: list as std::string"):
        read_metadata(bag, "humble")  # ros2/rosbag2 issue 2013's 'bad conversion'
    for distro, want in (("iron", 8), ("jazzy", 9), ("rolling", 9), ("Humble", 8)):
        other = export_rosbag2(trace, tmp_path / f"{distro}_bag", ros_distro=distro)
        assert read_metadata(other, "humble" if want == 8 else "jazzy")[0] == want


def test_the_command_writes_for_humble_and_refuses_what_it_cannot(
    trace: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from pirate_bt.cli import main

    bag = tmp_path / "run_bag"
    assert main(["trace", "export", str(trace), "-o", str(bag), "--ros-distro", "humble"]) == 0
    assert read_metadata(bag, "humble")[0] == 8
    capsys.readouterr()
    assert (
        main(["trace", "export", str(trace), "-o", f"{tmp_path}/x_bag", "--ros-distro", "noetic"])
        == 2
    )
    said = capsys.readouterr().err.strip()
    assert said == (
        "pirate-bt: --ros-distro 'noetic': not a ROS 2 distribution the rosbag2 export writes"
        " for; give one of humble, iron, jazzy, kilted, rolling"
    )
    assert not (tmp_path / "x_bag").exists()
    out = tmp_path / "run.mcap"
    assert main(["trace", "export", str(trace), "-o", str(out), "--ros-distro", "humble"]) == 2
    assert "--ros-distro is for a rosbag2 directory" in capsys.readouterr().err
    assert not out.exists()
