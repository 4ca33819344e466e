"""Every verdict names the node that asked, and trace summaries count runs honestly."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.safety.verdict import issuing, node_path
from pirate_bt.trace import read_trace
from pirate_bt.trace.text import summarise

# The front module is not moved clear first: the supervisor refuses the clamp.
TREE = """\
name: probe
root:
  type: sequence
  name: probe
  children:
    - {type: wait, name: settle, duration: 50 ms}
    - type: selector
      name: try
      children:
        - {type: clamp, name: clamp front half, half: front, torque: 0.7 N*m}
        - {type: failure, name: give up}
"""


@pytest.fixture(scope="module")
def refused_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    tmp = tmp_path_factory.mktemp("refused")
    tree = tmp / "probe.yaml"
    tree.write_text(TREE)
    trace = tmp / "run.jsonl"
    assert main(["run", str(tree), "--quiet", "--trace", str(trace)]) == 1
    return trace


def test_every_tree_verdict_in_the_trace_names_its_node(refused_run: Path) -> None:
    trace = read_trace(refused_run)
    commands = [c for f in trace.frames() for c in (f.commands or ())]
    refused = [c for c in commands if c["verdict"] == "refuse"]
    assert refused, "the tree should have had a command refused"
    clamp_id = next(n.id for n in trace.structure if n.name == "clamp front half")
    for command in commands:
        if command.get("source") == "tree":
            assert command.get("node") == clamp_id, command
    # Written as a plain field of the record, readable without pirate_bt.
    lines = [json.loads(line) for line in refused_run.read_text().splitlines()]
    raw = [c for r in lines for c in r.get("commands", ()) if c["verdict"] == "refuse"]
    assert raw and all(c["node"] == clamp_id for c in raw)


def test_summary_names_the_refusing_node_by_its_path(
    refused_run: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["trace", "summary", str(refused_run)]) == 0
    out = capsys.readouterr().out
    refusals = out.split("refusals:")[1].splitlines()
    assert any("probe/try/clamp front half: clamp(front" in line for line in refusals), out
    assert not any(": ?:" in line for line in refusals)


def test_a_node_that_finished_ran(refused_run: Path) -> None:
    summary = summarise(read_trace(refused_run))
    trace = read_trace(refused_run)
    by_name = {n.name: summary.nodes[n.id] for n in trace.structure}
    # The clamp and the fallback both finish in the tick they start in.
    assert by_name["clamp front half"].runs == 1
    assert by_name["clamp front half"].failures == 1
    assert by_name["give up"].runs == 1
    for name, entry in by_name.items():
        assert entry.runs >= entry.successes + entry.failures, name


def test_issuing_nests_and_restores() -> None:
    import py_trees

    root = py_trees.composites.Sequence("root", memory=True)
    a, b = py_trees.behaviours.Success("a"), py_trees.behaviours.Success("b")
    root.add_children([a, b])
    assert node_path(b) == ("0.1", "root/b")
    assert node_path(root) == ("0", "root")
    from pirate_bt.safety.verdict import current_issuer

    with issuing(root):
        with issuing(a):
            assert current_issuer() is a
        assert current_issuer() is root
    assert current_issuer() is None


def test_a_node_that_raises_leaves_no_issuer_behind() -> None:
    """A node's code that raises mid-tick does not leave later verdicts naming it."""
    import py_trees

    from pirate_bt.behaviours.base import Leaf
    from pirate_bt.safety.verdict import current_issuer

    class Boom(Leaf):
        def __init__(self) -> None:
            py_trees.behaviour.Behaviour.__init__(self, "boom")

        def update(self) -> py_trees.common.Status:
            assert current_issuer() is self  # its own code runs under its name
            raise RuntimeError("boom")

    node = Boom()
    with pytest.raises(RuntimeError, match="boom"):
        for _ in node.tick():
            pass
    assert current_issuer() is None
    with issuing(node), pytest.raises(KeyError):
        raise KeyError("x")
    assert current_issuer() is None


def test_old_traces_without_nodes_still_summarise(capsys: pytest.CaptureFixture[str]) -> None:
    reference = sorted(Path(__file__).parent.joinpath("data", "traces").glob("*.jsonl"))
    assert reference
    for path in reference:
        assert main(["trace", "summary", str(path)]) == 0
    out = capsys.readouterr().out
    assert ": ?:" not in out


def test_a_safe_state_a_node_asks_for_names_the_node(tmp_path: Path) -> None:
    tree = tmp_path / "stop.yaml"
    tree.write_text(
        "name: stop\nroot:\n  type: sequence\n  name: stop\n  children:\n"
        "    - {type: wait, name: settle, duration: 50 ms}\n"
        "    - {type: safe_state, name: give up here, reason: test}\n"
    )
    trace_path = tmp_path / "run.jsonl"
    main(["run", str(tree), "--quiet", "--trace", str(trace_path)])
    trace = read_trace(trace_path)
    stop_id = next(n.id for n in trace.structure if n.name == "give up here")
    commands = [c for f in trace.frames() for c in (f.commands or ())]
    from_supervisor = [c for c in commands if c.get("source") == "supervisor"]
    assert from_supervisor, commands
    assert all(c.get("node") == stop_id for c in from_supervisor)
