"""A trace header whose tree is no tree is refused when the header is read.

A node that was its own ancestor passed ``pirate-bt validate`` and made ``trace
export`` loop for ever (``.btlog``, ``.mcap``) or die of a ``RecursionError``
(a rosbag2 folder); a parent that was no node crashed ``trace summary``, ``plot``
and ``export`` with ``KeyError``. Now every reader of a trace refuses such a
header with one line naming the file and line 1, exit code 2, no output file.
"""

from __future__ import annotations

import contextlib
import copy
import importlib.util
import json
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

import pirate_bt
from pirate_bt.cli import main
from pirate_bt.errors import LocatedError
from pirate_bt.trace.header_check import tree_problem
from pirate_bt.trace.reader import TraceFormatReader, read_trace

ROOT = Path(__file__).resolve().parents[1]

Nodes = list[dict[str, Any]]


@pytest.fixture(scope="module")
def good(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("good") / "good.jsonl"
    pirate_bt.simulate_tree(ROOT / "trees" / "examples" / "patrol.yaml", trace=path)
    return path


def _node(nodes: Nodes, node_id: str) -> dict[str, Any]:
    return next(n for n in nodes if n["id"] == node_id)


def _own_child(nodes: Nodes) -> None:
    nodes[0]["children"] = ["0"]


def _unknown_parent(nodes: Nodes) -> None:
    _node(nodes, "0.2")["parent"] = "zz"


def _parent_disagrees(nodes: Nodes) -> None:
    _node(nodes, "0.0")["parent"] = "0.3"


def _duplicate_id(nodes: Nodes) -> None:
    _node(nodes, "0.1")["id"] = "0.0"


def _unknown_child(nodes: Nodes) -> None:
    nodes[0]["children"].append("0.9")


def _listed_twice(nodes: Nodes) -> None:
    _node(nodes, "0.3")["children"].append("0.0")


def _two_roots(nodes: Nodes) -> None:
    _node(nodes, "0.4")["parent"] = None
    nodes[0]["children"].remove("0.4")


def _no_root(nodes: Nodes) -> None:
    nodes[0]["parent"] = "0.4"


def _parent_cycle(nodes: Nodes) -> None:
    _node(nodes, "0.3.0")["parent"] = "0.3.1"
    _node(nodes, "0.3.1")["parent"] = "0.3.0"


def _root_not_first(nodes: Nodes) -> None:
    nodes[0], nodes[1] = nodes[1], nodes[0]


HOSTILE: dict[str, tuple[Callable[[Nodes], None], str]] = {
    "own_child": (_own_child, "node '0' is its own ancestor"),
    "unknown_parent": (_unknown_parent, "node '0.2' names parent 'zz', which is not a node"),
    "parent_disagrees": (
        _parent_disagrees,
        "node '0' lists child '0.0', whose parent field names parent '0.3'",
    ),
    "duplicate_id": (_duplicate_id, "node id '0.0' is given to two nodes"),
    "unknown_child": (_unknown_child, "node '0' lists child '0.9', which is not a node"),
    "listed_twice": (_listed_twice, "node '0.3' lists child '0.0', which node '0' lists already"),
    "two_roots": (_two_roots, "more than one root: 2 nodes have no parent ('0', '0.4')"),
    "no_root": (_no_root, "no root: every node names a parent"),
    "parent_cycle": (_parent_cycle, "is its own ancestor"),
    "root_not_first": (_root_not_first, "the root '0' is not the first node"),
}


def _lines(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def _write(path: Path, records: list[dict[str, Any]]) -> Path:
    path.write_text("".join(json.dumps(r) + "\n" for r in records))
    return path


def _hostile(good: Path, folder: Path, name: str) -> Path:
    records = _lines(good)
    header = copy.deepcopy(records[0])
    HOSTILE[name][0](header["tree"]["nodes"])
    return _write(folder / f"{name}.jsonl", [header, *records[1:]])


@dataclass
class Ran:
    """One command's exit code and what it wrote to stderr."""

    returncode: int
    stderr: str


@pytest.fixture
def cli(capsys: pytest.CaptureFixture[str]) -> Callable[..., Ran]:
    """The command line in process (``pirate_bt.cli.main``): the same exit code and
    stderr as ``python -m pirate_bt``, without an interpreter's start-up per call."""

    def run(*args: str | Path, cwd: Path) -> Ran:
        capsys.readouterr()
        with contextlib.chdir(cwd):
            code = main([str(a) for a in args])
        return Ran(code, capsys.readouterr().err)

    return run


def _refused(result: Ran, where: str, problem: str) -> None:
    lines = result.stderr.splitlines()
    assert result.returncode == 2, result.stderr
    assert len(lines) == 1, result.stderr
    assert where in lines[0] and problem in lines[0], lines[0]
    assert "Traceback" not in result.stderr and "internal error" not in result.stderr


def test_the_good_trace_reads_and_its_tree_passes(good: Path) -> None:
    trace = read_trace(good)
    assert trace.outcome == "success" and len(trace.structure) == 9
    assert tree_problem(_lines(good)[0]["tree"]) is None
    assert trace.coverage is not None


@pytest.mark.parametrize("name", sorted(HOSTILE))
def test_read_trace_names_file_line_1_and_the_problem(
    good: Path, tmp_path: Path, name: str
) -> None:
    path = _hostile(good, tmp_path, name)
    with pytest.raises(LocatedError) as caught:
        read_trace(path)
    assert caught.value.location.line == 1
    assert str(caught.value).startswith(f"{path}:1:1: bad tree in header: ")
    assert HOSTILE[name][1] in caught.value.message
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize("name", sorted(HOSTILE))
def test_validate_and_export_refuse_with_one_line(
    good: Path, tmp_path: Path, name: str, cli: Callable[..., Ran]
) -> None:
    path = _hostile(good, tmp_path, name)
    problem = HOSTILE[name][1]
    _refused(cli("validate", path, cwd=tmp_path), f"{path}:1:", problem)
    out = tmp_path / "x.btlog"
    _refused(cli("trace", "export", path, "-o", out, cwd=tmp_path), f"{path}:1:", problem)
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]  # nothing written


@pytest.mark.parametrize("name", ["own_child", "unknown_parent"])
def test_the_reported_crashes_and_hangs_are_refusals(
    good: Path, tmp_path: Path, name: str, cli: Callable[..., Ran]
) -> None:
    path = _hostile(good, tmp_path, name)
    problem = HOSTILE[name][1]
    runs: list[tuple[str, ...]] = [("trace", "summary", str(path))]
    runs.append(("trace", "plot", str(path), "-o", str(tmp_path / "o.png")))
    if importlib.util.find_spec("mcap") is not None:
        runs.append(("trace", "export", str(path), "-o", str(tmp_path / "x.mcap")))
    if importlib.util.find_spec("rosbags") is not None:
        runs.append(("trace", "export", str(path), "-o", str(tmp_path / "x_bag/")))
    for args in runs:
        _refused(cli(*args, cwd=tmp_path), f"{path}:1:", problem)
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]


def test_mcap_export_refuses_a_tick_without_n_as_btlog_export_does(
    good: Path, tmp_path: Path, cli: Callable[..., Ran]
) -> None:
    pytest.importorskip("mcap")
    records = _lines(good)
    del records[1]["n"]
    path = _write(tmp_path / "non.jsonl", records)
    for out in ("x.btlog", "x.mcap"):
        result = cli("trace", "export", path, "-o", tmp_path / out, cwd=tmp_path)
        _refused(result, f"{path}:2:", "bad tick record: no n: a tick record holds its number n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["non.jsonl"]


def test_a_format_reader_of_its_own_is_checked_too(good: Path, tmp_path: Path) -> None:
    records = _lines(good)
    _own_child(records[0]["tree"]["nodes"])

    class Listed(TraceFormatReader):  # a plugin format that overrides __iter__
        def __iter__(self) -> Iterator[tuple[int, dict[str, Any]]]:
            yield from enumerate(records, start=1)

    with pytest.raises(LocatedError, match=r"x\.listed:1:1: bad tree in header: node '0' is its"):
        list(Listed(tmp_path / "x.listed"))


def test_a_second_header_is_checked_as_the_first(good: Path, tmp_path: Path) -> None:
    records = _lines(good)
    second = copy.deepcopy(records[0])
    _own_child(second["tree"]["nodes"])
    path = _write(tmp_path / "two.jsonl", [records[0], second, *records[1:]])
    from pirate_bt.trace.reader import open_reader

    with pytest.raises(LocatedError, match=r"two\.jsonl:2:1: bad tree in header"):
        list(open_reader(path))


def test_the_check_is_linear_in_the_nodes() -> None:
    count = 100_000  # a tree file's most nodes (MAX_TREE_NODES)
    nodes: Nodes = [
        {
            "id": str(i),
            "name": "n",
            "parent": None if i == 0 else str(i - 1),
            "children": [str(i + 1)] if i < count - 1 else [],
        }
        for i in range(count)
    ]
    start = time.perf_counter()
    assert tree_problem({"nodes": nodes}) is None
    nodes[-1]["children"] = ["0"]  # the deepest node lists the root: a cycle 100 000 long
    problem = tree_problem({"nodes": nodes})
    assert problem is not None and problem.endswith("is its own ancestor")
    assert time.perf_counter() - start < 10  # quadratic would take hours
