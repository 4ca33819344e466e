"""A trace given where a tree file goes is named as a trace.

``pirate-bt run run.jsonl`` said 'YAML syntax error: did not find expected <document
start>' at line 2, and a ``.mcap`` 'binary file, not YAML text': true, but no help to
someone who passed the wrong file of a run's two.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed

SAID = "a trace, not a behaviour tree file: read it with pirate-bt trace summary"


@pytest.fixture(scope="module")
def trace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("run") / "run.jsonl"
    result = pirate_bt.simulate_tree("straight", params={"distance": "0.05 m"}, trace=path)
    assert result.succeeded and path.is_file()
    return path


def test_running_a_trace_says_it_is_one(trace: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", str(trace), "--sim", "straight"]) == 2
    assert capsys.readouterr().err == f"pirate-bt: {trace}:1:1: {SAID} (or show, plot)" + (
        " and pirate_bt.read_trace\n"
    )


@pytest.mark.parametrize("name", ["run.mcap", "run.btlog", "RUN.JSONL.GZ"])
def test_every_trace_format_is_named(tmp_path: Path, name: str) -> None:
    path = tmp_path / name
    path.write_bytes(b"\x89MCAP0\r\n")  # never read: the name says what it is
    with pytest.raises(ValidationFailed, match=SAID):
        pirate_bt.load_tree(path)


def test_a_yaml_tree_of_a_trace_s_name_still_loads(tmp_path: Path) -> None:
    path = tmp_path / "tree.jsonl"
    path.write_text("root: {type: success}\n")
    assert pirate_bt.load_tree(path).root.name
