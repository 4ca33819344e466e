"""Probe 16: the interop files (rosbag2, MCAP) read back by a hostile but realistic user.

Pure tests, no live server (those are in ``tests/test_probe16_interop_live.py``).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.errors import InputError
from tests.trace_support import run_and_record


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    pytest.importorskip("rosbags")
    from pirate_bt.interop.rosbag2 import export_rosbag2

    folder = tmp_path_factory.mktemp("bag")
    trace = folder / "run.jsonl"
    run_and_record(trace, ticks=3)
    return export_rosbag2(trace, folder / "run_bag")


def _copy(bag: Path, where: Path) -> Path:
    copy = where / bag.name
    shutil.copytree(bag, copy)
    return copy


def test_a_file_compressed_bag_cut_short_is_bad_input_not_an_eof_traceback(
    bag: Path, tmp_path: Path
) -> None:
    # `ros2 bag record --compression-mode file --compression-format zstd` writes
    # NAME.mcap.zstd; one copied in part (or whose recorder was killed while it
    # compressed) raised EOFError from the decompressor, not the documented InputError
    zstd = pytest.importorskip("zstandard")
    from pirate_bt.interop.rosbag2 import read_rosbag2_records

    copy = _copy(bag, tmp_path)
    mcap = copy / f"{bag.name}.mcap"
    packed = zstd.ZstdCompressor().compress(mcap.read_bytes())
    mcap.unlink()
    (copy / f"{mcap.name}.zstd").write_bytes(packed)
    meta = copy / "metadata.yaml"
    meta.write_text(
        meta.read_text()
        .replace("compression_format: ''", "compression_format: zstd")
        .replace("compression_mode: ''", "compression_mode: file")
        .replace(f"{bag.name}.mcap", f"{bag.name}.mcap.zstd")
    )
    whole = read_rosbag2_records(copy)  # the compressed bag is read
    assert whole == read_rosbag2_records(bag)
    (copy / f"{mcap.name}.zstd").write_bytes(packed[: len(packed) // 2])
    with pytest.raises(InputError, match=r"not a readable rosbag2 bag: EOFError") as caught:
        read_rosbag2_records(copy)
    assert str(caught.value).startswith(f"{copy}: ")
    assert "\n" not in str(caught.value)


def test_a_bag_whose_metadata_is_not_utf8_is_bad_input_not_a_unicode_traceback(
    bag: Path, tmp_path: Path
) -> None:
    from pirate_bt.interop.rosbag2 import read_rosbag2_records

    copy = _copy(bag, tmp_path)
    (copy / "metadata.yaml").write_bytes(b"\xff\xfe\x00 not yaml")
    with pytest.raises(InputError, match=r"not a readable rosbag2 bag: UnicodeDecodeError"):
        read_rosbag2_records(copy)


def test_a_bag_whose_trace_topic_yields_nothing_is_bad_input_not_an_empty_trace(
    bag: Path, tmp_path: Path
) -> None:
    # a metadata.yaml whose QoS was edited (for playback) no longer matches the MCAP
    # file's channels: rosbags then reads no message at all, and the bag's trace came
    # back as [] (no header, no end: not a run), with no word of it
    from pirate_bt.interop.rosbag2 import read_rosbag2_records

    copy = _copy(bag, tmp_path)
    meta = copy / "metadata.yaml"
    meta.write_text(meta.read_text().replace("reliability: reliable", "reliability: best_effort"))
    with pytest.raises(
        InputError, match=r"no message on /pirate/trace \(its metadata counts \d+\)"
    ):
        read_rosbag2_records(copy)


def _surrogate_tree() -> Any:
    """A tree built in Python whose names and feedback hold lone surrogates (and a NUL):
    tree files refuse them, Python does not."""
    import py_trees
    from py_trees.behaviours import StatusQueue
    from py_trees.common import Status

    py_trees.blackboard.Blackboard.clear()
    running, success = Status.RUNNING, Status.SUCCESS
    leaf = StatusQueue("dr\ud800ive\x00", [running, running, success], success)
    leaf.feedback_message = "fb \udcff"
    root = py_trees.composites.Sequence("ro\udfffot", memory=True, children=[leaf])
    return py_trees.trees.BehaviourTree(root)


def test_a_tree_with_a_lone_surrogate_is_traced_to_mcap_and_exported_as_to_jsonl(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # `.jsonl` kept such a name (JSON escapes it); `--trace RUN.mcap` failed the run with
    # SinkError (the writer's UnicodeEncodeError: surrogates not allowed), and exporting
    # the `.jsonl` to MCAP or to a bag was refused ("cannot convert this record") or, for
    # the bag's trace topic, turned the character into '?'
    pytest.importorskip("mcap")
    pytest.importorskip("rosbags")
    from pirate_bt.interop.mcap_trace import export_mcap, read_mcap_records
    from pirate_bt.interop.rosbag2 import export_rosbag2, read_rosbag2_records
    from pirate_bt.trace import read_trace
    from tests import trace_support

    monkeypatch.setattr(trace_support, "make_tree", _surrogate_tree)
    jsonl, mcap = tmp_path / "run.jsonl", tmp_path / "run.mcap"
    trace_support.run_and_record(jsonl, ticks=4)
    trace_support.run_and_record(mcap, ticks=4)
    records = [json.loads(line) for line in jsonl.read_text().splitlines()]
    names = [node["name"] for node in records[0]["tree"]["nodes"]]
    assert names == ["ro\udfffot", "dr\ud800ive\x00"]
    assert read_trace(mcap).end is not None
    recorded = read_mcap_records(mcap)  # another run: its header has its own time
    assert recorded[0]["tree"] == records[0]["tree"]
    assert recorded[1:] == records[1:]
    assert read_mcap_records(export_mcap(jsonl, tmp_path / "export.mcap")) == records
    assert read_rosbag2_records(export_rosbag2(jsonl, tmp_path / "run_bag")) == records


def test_every_message_with_a_lone_surrogate_is_utf8_json_read_back_the_same() -> None:
    # the live server sends encode_message's bytes: the same UnicodeEncodeError turned
    # the Foxglove view off for the rest of such a run
    from pirate_bt.interop.foxglove_schemas import encode_message

    message = {"name": "a\ud800b", "\udcffkey": [1.5, float("nan"), "ü\U0001f600"], "n": 3}
    data = encode_message(message)
    assert json.loads(data.decode("utf-8")) == {**message, "\udcffkey": [1.5, "nan", "ü\U0001f600"]}
    assert "ü\U0001f600".encode() in data  # what has UTF-8 stays as it is


@pytest.mark.parametrize(("namespace", "said"), [("/", "'/'"), ("pirate2", "'/pirate2'")])
def test_a_bag_exported_in_another_namespace_is_named_as_such_not_as_a_foreign_bag(
    tmp_path: Path, namespace: str, said: str
) -> None:
    # read with the default namespace, a bag exported with namespace= said "no
    # /pirate/trace topic (not exported by pirate-bt?)": it was, in another namespace
    pytest.importorskip("rosbags")
    from pirate_bt.interop.rosbag2 import export_rosbag2, read_rosbag2_records

    trace = tmp_path / "run.jsonl"
    run_and_record(trace, ticks=3)
    bag = export_rosbag2(trace, tmp_path / "run_bag", namespace=namespace)
    with pytest.raises(InputError, match=rf"no /pirate/trace topic; .* namespace={said}") as caught:
        read_rosbag2_records(bag)
    assert "not exported by pirate-bt" not in str(caught.value)
    assert read_rosbag2_records(bag, namespace=said.strip("'")) == [
        json.loads(line) for line in trace.read_text().splitlines()
    ]


def test_a_bag_exported_into_the_current_empty_folder_fills_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # `pirate-bt trace export RUN.jsonl -o .` (or `./`) in an empty folder, which the docs
    # take as a bag, was "internal error: WriterError: ..XXXXXXXX exists already" (exit 1):
    # the bag was named after Path('.').name, which is ''
    pytest.importorskip("rosbags")
    from pirate_bt.interop.rosbag2 import export_rosbag2, read_rosbag2_records

    trace = tmp_path / "run.jsonl"
    run_and_record(trace, ticks=3)
    here = tmp_path / "here_bag"
    here.mkdir()
    inode = here.stat().st_ino
    monkeypatch.chdir(here)
    for target in (Path("."), Path("./")):
        for made in here.iterdir():
            made.unlink()
        bag = export_rosbag2(trace, target)
        assert bag == here
        assert sorted(p.name for p in here.iterdir()) == ["here_bag.mcap", "metadata.yaml"]
        assert here.stat().st_ino == inode  # filled, not replaced: a shell in it stays
        assert read_rosbag2_records(Path(".")) == [
            json.loads(line) for line in trace.read_text().splitlines()
        ]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["here_bag", "run.jsonl"]


@pytest.mark.parametrize("text", ["::1", "fe80::1", "tcp/::1", "[::1", "[::1]:", "[]:7447"])
def test_an_ipv6_router_without_its_brackets_is_refused_not_read_as_port_1(text: str) -> None:
    # `--ros2 ::1` was the endpoint tcp/::1 (host ':', port 1): Zenoh opened the session
    # and the run went on, its node waiting for a router there for ever; an unclosed '['
    # was closed quietly
    from pirate_bt.interop.ros2_option import parse_endpoint

    with pytest.raises(InputError, match=r"write an IPv6 address in brackets.*tcp/\[") as caught:
        parse_endpoint(text)
    assert str(caught.value).startswith(f"--ros2 {text}: ")
    assert parse_endpoint("[::1]") == "tcp/[::1]:7447"
    assert parse_endpoint("tcp/[fe80::1]:7448") == "tcp/[fe80::1]:7448"


def test_a_bag_is_exported_into_folders_not_made_yet_and_they_go_if_it_fails(
    tmp_path: Path,
) -> None:
    # every other export made the folders on the way; this one said 'out_dir: cannot
    # write ...: No such file or directory' (the CLI probe)
    pytest.importorskip("rosbags")
    from pirate_bt.interop.rosbag2 import export_rosbag2

    trace = tmp_path / "run.jsonl"
    run_and_record(trace, ticks=3)
    out = export_rosbag2(trace, tmp_path / "new" / "deeper" / "run_bag")
    assert (out / "metadata.yaml").is_file()
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"type": "tick", "t_s": 0}\n', encoding="utf-8")
    with pytest.raises(InputError, match=r"bad\.jsonl:1:1: "):
        export_rosbag2(bad, tmp_path / "other" / "x_bag")
    assert not (tmp_path / "other").exists()  # nothing half-made left behind


def test_a_tee_id_no_network_takes_is_one_line_not_a_validation_traceback() -> None:
    # 'network add-tee lab run-c "1 m" --id é' was a four-line pydantic internal error
    from pirate_bt.errors import ConfigurationError
    from pirate_bt.pipes import load_network
    from pirate_bt.pipes.asbuilt import insert_tee

    spec = load_network("lab").spec
    for bad in ("é", "2tee", "", "x" * 41):
        with pytest.raises(ConfigurationError, match="is not a segment id"):
            insert_tee(spec, "run-c", 1.0, tee_id=bad)
    insert_tee(spec, "run-c", 1.0, tee_id="extra_2")


def test_an_xml_file_named_in_bytes_that_are_no_utf8_is_imported(tmp_path: Path) -> None:
    # 'import btcpp $'\xfe.xml' -o out.yaml' was 'internal error: UnicodeEncodeError'
    import os

    from pirate_bt.cli import main

    xml = tmp_path / "s.xml"
    assert main(["export", "btcpp", "straight", "-o", str(xml)]) == 0
    odd = Path(os.fsdecode(bytes(tmp_path) + b"/\xfe.xml"))
    xml.rename(odd)
    out = tmp_path / "out.yaml"
    assert main(["import", "btcpp", str(odd), "-o", str(out)]) == 0
    assert out.read_text(encoding="utf-8").startswith("# Converted from \\xfe.xml ")
