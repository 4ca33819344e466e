"""Trace formats by suffix: registering one, the entry-point group, clear errors."""

from __future__ import annotations

import bz2
import subprocess
import sys
import textwrap
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

import py_trees
import pytest
from py_trees.behaviours import StatusQueue
from py_trees.common import Status

import pirate_bt.trace.formats as formats
from pirate_bt.clock import SimClock
from pirate_bt.errors import ConfigurationError, InputError
from pirate_bt.trace import (
    ENTRY_POINT_GROUP,
    READERS,
    WRITERS,
    TraceFormatReader,
    TraceFormatWriter,
    TraceRecorder,
    open_reader,
    open_writer,
    read_trace,
    register_reader,
    register_writer,
)

ROOT = Path(__file__).resolve().parent.parent


class Bz2Writer(TraceFormatWriter):
    """JSON Lines, bzip2-compressed: a format of a user's own."""

    def _open(self, fd: int | None) -> IO[bytes]:
        return bz2.open(self.path, "wb")


class Bz2Reader(TraceFormatReader):
    def _open(self) -> IO[bytes]:
        return bz2.open(self.path, "rb")


@pytest.fixture
def bz2_format() -> Any:
    register_writer(".jsonl.bz2", Bz2Writer)
    register_reader(".jsonl.bz2", Bz2Reader)
    yield
    del WRITERS[".jsonl.bz2"], READERS[".jsonl.bz2"]


def _tree() -> py_trees.trees.BehaviourTree:
    py_trees.blackboard.Blackboard.clear()
    s, r = Status.SUCCESS, Status.RUNNING
    root = py_trees.composites.Sequence(
        "pab", memory=True, children=[StatusQueue("a", [r, s], s), StatusQueue("b", [r, s], s)]
    )
    return py_trees.trees.BehaviourTree(root)


def test_a_registered_suffix_is_written_and_read(tmp_path: Path, bz2_format: None) -> None:
    path = tmp_path / "run.jsonl.bz2"
    tree = _tree()
    clock = SimClock()
    with TraceRecorder(path, tree, clock=clock) as recorder:
        assert not recorder.background  # a format of one's own is written in-process
        for _ in range(4):
            clock.advance(0.1)
            tree.tick()
            recorder.record_tick()
    assert bz2.decompress(path.read_bytes()).startswith(b'{"type":"header"')
    assert isinstance(open_writer(tmp_path / "other.JSONL.BZ2"), Bz2Writer)
    assert isinstance(open_reader(path), Bz2Reader)
    trace = read_trace(path)
    assert trace.outcome == "success"
    assert trace.last_tick == 4
    assert trace.statuses_at(1) == {
        "0": Status.RUNNING,
        "0.0": Status.RUNNING,
        "0.1": Status.INVALID,
    }
    assert trace.statuses_at(4)["0"] == Status.SUCCESS


def test_registering_checks_the_suffix_and_keeps_other_rows(bz2_format: None) -> None:
    register_writer(".jsonl.bz2", Bz2Writer)  # the same factory again: nothing changes
    with pytest.raises(ValueError, match="starts with a dot"):
        register_reader("csv", Bz2Reader)
    with pytest.raises(ValueError, match="already registered"):
        register_reader(".jsonl.bz2", lambda path: Bz2Reader(path))
    register_reader(".jsonl.bz2", Bz2Reader, replace=True)
    assert READERS[".jsonl.bz2"] is Bz2Reader


class _EntryPoint:
    def __init__(self, name: str, hook: Callable[[], None]) -> None:
        self.name, self.value, self._hook = name, f"tests:{name}", hook

    def load(self) -> Callable[[], None]:
        return self._hook


def test_entry_points_are_loaded_once_when_a_suffix_is_unknown(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls: list[str] = []

    def register() -> None:
        calls.append("bz2")
        register_writer(".jsonl.bz2", Bz2Writer)
        register_reader(".jsonl.bz2", Bz2Reader)

    def broken() -> None:
        raise ImportError("no module named 'fancy'")

    groups: list[str] = []

    def entry_points(group: str) -> list[_EntryPoint]:
        groups.append(group)
        return [_EntryPoint("bz2", register), _EntryPoint("fancy", broken)]

    monkeypatch.setattr(formats, "entry_points", entry_points)
    monkeypatch.setattr(formats, "_loaded", False)
    monkeypatch.delitem(WRITERS, ".jsonl.bz2", raising=False)
    monkeypatch.delitem(READERS, ".jsonl.bz2", raising=False)
    try:
        open_writer(tmp_path / "a.jsonl").close()  # a known suffix reads no entry point
        assert calls == []
        assert isinstance(open_writer(tmp_path / "b.jsonl.bz2"), Bz2Writer)
        assert calls == ["bz2"] and groups == [ENTRY_POINT_GROUP]
        with pytest.raises(InputError, match=r"unknown trace format.*\.jsonl\.bz2.*'fancy' failed"):
            read_trace(tmp_path / "c.fancy")
        assert calls == ["bz2"]  # once
    finally:
        WRITERS.pop(".jsonl.bz2", None)
        READERS.pop(".jsonl.bz2", None)


def test_mcap_without_entry_points_says_what_to_install(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A source tree that was never installed has no entry points: ``.mcap`` says so."""
    monkeypatch.setattr(formats, "entry_points", lambda group: [])
    monkeypatch.setattr(formats, "_loaded", False)
    monkeypatch.delitem(WRITERS, ".mcap", raising=False)
    monkeypatch.delitem(READERS, ".mcap", raising=False)
    for call in (open_writer, read_trace):
        with pytest.raises(ConfigurationError) as info:
            call(tmp_path / "run.mcap")
        message = str(info.value)
        assert "pip install 'pirate-bt[foxglove]'" in message
        assert message.endswith("known are: .jsonl, .jsonl.gz, .ndjson")


def test_the_trace_package_finds_mcap_without_importing_interop(tmp_path: Path) -> None:
    """``pirate_bt.trace`` never imports ``interop``; the installed entry point brings MCAP."""
    script = textwrap.dedent(
        f"""
        import sys
        from pirate_bt.trace import READERS, WRITERS, open_writer
        from pirate_bt.trace.formats import suffix_of
        assert not [m for m in sys.modules if m.startswith("pirate_bt.interop")]
        assert ".mcap" not in WRITERS and ".mcap" not in READERS
        writer = open_writer({str(tmp_path / "x.mcap")!r})
        writer.close()
        assert type(writer).__name__ == "McapTraceWriter", writer
        assert suffix_of("y.MCAP", READERS) == ".mcap"
        print("ok")
        """
    )
    done = subprocess.run(
        [sys.executable, "-c", script], cwd=tmp_path, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "ok"


def test_pyproject_declares_the_mcap_entry_point() -> None:
    text = (ROOT / "pyproject.toml").read_text()
    assert f'[project.entry-points."{ENTRY_POINT_GROUP}"]' in text
    assert 'mcap = "pirate_bt.interop.mcap_trace:register"' in text
