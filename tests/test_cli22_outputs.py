"""The command line's outputs: a named pipe where a file is to be written is refused
before any work, in one line naming the option; never waited on for ever."""

from __future__ import annotations

import contextlib
import errno
import os
import threading
from pathlib import Path

import pytest

from pirate_bt.atomic import write_atomically
from pirate_bt.cli import main
from tests.hostile_support import no_hang

pytestmark = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")

# (argv with {out} for the output, the option named, the file the pipe is made at)
CASES = {
    "render": (["render", "straight", "-o", "{out}"], "-o", "t.dot"),
    "robot draw": (["robot", "--draw", "{out}"], "--draw", "r.svg"),
    "robot header": (["robot", "header", "-o", "{out}"], "-o", "layout.h"),
    "export": (["export", "btcpp", "straight", "-o", "{out}"], "-o", "t.xml"),
    "run trace": (
        ["run", "straight", "--param", "distance=0.05m", "--trace", "{out}"],
        "--trace",
        "t.jsonl",
    ),
    "mission output": (["mission", "lab", "--output", "{dir}"], "--output", "plot.png"),
    "mission trace": (["mission", "lab", "--output", "{dir}"], "--output", "trace.jsonl"),
    "demo output": (["demo", "--output", "{dir}"], "--output", "robot.svg"),
    "survey trace": (
        ["survey", "-q", "-o", "{dir}.yaml", "--trace", "{dir}"],
        "--trace",
        "navigation.jsonl",
    ),
    "survey step": (
        ["survey", "-q", "-o", "{dir}.yaml", "--trace", "{dir}"],
        "--trace",
        "step-001.jsonl",
    ),
}


@pytest.mark.parametrize("case", CASES)
def test_a_named_pipe_as_an_output_is_refused_before_any_work(
    case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before: render, robot --draw, robot header (and trace plot, trace export .mcap)
    opened the pipe and waited for a reader for ever; run --trace said the API's
    'trace: ... is not a regular file', an option nobody typed; mission --output waited
    at the end for plot.png or said 'trace: DIR/trace.jsonl ...'; demo waited on its
    robot.svg; survey and navigate --trace DIR waited on DIR/navigation.jsonl (or a
    step's trace)."""
    argv, option, name = CASES[case]
    folder = tmp_path / "out"
    folder.mkdir()
    fifo = folder / name
    os.mkfifo(fifo)
    args = [a.format(out=fifo, dir=folder) for a in argv]
    with contextlib.contextmanager(no_hang)(30):
        assert main(args) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.splitlines() == [
        f"pirate-bt: {option}: '{fifo}' is a named pipe, not a file to write"
    ]
    assert sorted(p.name for p in folder.iterdir()) == [name]  # nothing written


def test_a_named_pipe_nobody_reads_is_not_waited_on(tmp_path: Path) -> None:
    """Before: write_atomically opened a named pipe to write it in place, and waited
    for a reader for ever (a pipe made after the command's checks: render_tree, a
    mission's pictures)."""
    fifo = tmp_path / "t.dot"
    os.mkfifo(fifo)
    link = tmp_path / "link.dot"
    link.symlink_to(fifo)
    with contextlib.contextmanager(no_hang)(30), pytest.raises(OSError) as caught:
        write_atomically(link, lambda stream: stream.write(b"digraph {}\n"))
    assert caught.value.errno == errno.ENXIO
    assert caught.value.filename == str(link)  # as given
    assert caught.value.strerror == "a named pipe nobody reads"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.dot", "t.dot"]


def test_a_named_pipe_that_is_read_is_written_in_place(tmp_path: Path) -> None:
    fifo = tmp_path / "t.dot"
    os.mkfifo(fifo)
    read: list[bytes] = []
    # opened for reading here (it does not wait: O_NONBLOCK), then read in a thread
    fd = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
    try:
        os.set_blocking(fd, True)
        with contextlib.contextmanager(no_hang)(30):
            written = write_atomically(fifo, lambda stream: stream.write(b"digraph {}\n"))
            reader = threading.Thread(target=lambda: read.append(os.read(fd, 100)))
            reader.start()
            reader.join(30)
    finally:
        os.close(fd)
    assert written == fifo and read == [b"digraph {}\n"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.dot"]
