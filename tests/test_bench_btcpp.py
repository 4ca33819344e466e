"""The trees ``benchmarks/bench_btcpp.py`` hands to BehaviorTree.CPP are py_trees' trees.

No timing here: the XML of each benchmark tree loads in BT.CPP (through the
``behaviortreepy`` bindings, the two custom leaves written in Python) and, ticked
tick by tick, does what py_trees does with the same tree; the exporter's XML of the
51-node tree has the shape of the node-for-node mapping of its py_trees twin.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import py_trees
import pytest
from bench_support import load_benchmark

bench = load_benchmark("bench_btcpp")
bench_trees = load_benchmark("bench_trees")
bench_trace = load_benchmark("bench_trace")
bench_scale = load_benchmark("bench_scale")


def _shape(element: ET.Element) -> tuple[Any, ...]:
    """Tag, BT.CPP ports (not names, not ``_`` attributes) and children, recursively."""
    ports = sorted((k, v) for k, v in element.attrib.items() if k != "name" and k[0] != "_")
    return (element.tag, tuple(ports), tuple(_shape(child) for child in element))


def _main_tree(xml: str) -> ET.Element:
    root = ET.fromstring(xml)
    (tree,) = root.findall("BehaviorTree")
    (top,) = list(tree)
    return top


def test_the_export_of_the_51_node_tree_is_the_node_for_node_mapping_of_its_twin() -> None:
    exported = _main_tree(bench.export_xml_for_btcpp(bench_trees._yaml_tree()))
    mapped = _main_tree(bench.py_trees_xml(bench_trees._plain_tree()))
    assert _shape(exported) == _shape(mapped)
    assert sum(1 for _ in exported.iter()) == 51
    assert {e.tag for e in exported.iter()} == {
        "ReactiveSequence",
        "AlwaysSuccess",
        "Parallel",
        "Timeout",
        "running",
    }
    assert {e.get("msec") for e in exported.iter("Timeout")} == {"3600000"}


def test_a_node_type_with_no_counterpart_is_refused() -> None:
    root = py_trees.composites.Sequence("s", memory=True, children=[py_trees.behaviours.Dummy()])
    with pytest.raises(TypeError, match="Dummy"):
        bench.py_trees_xml(root)


def _btcpp_tree(xml: str, counts: dict[str, int]) -> Any:
    """BT.CPP's tree of ``xml``, its ``Step`` and ``running`` leaves in Python.

    The bindings cannot declare ports, so each step's ``ticks`` is read here and
    taken off the XML; ``counts`` gets each step's ticks since it started.
    """
    bt = pytest.importorskip("behaviortreepy")
    root = ET.fromstring(xml)
    ticks: dict[str, int] = {}
    for step in root.iter("Step"):
        ticks[step.get("name", "")] = int(step.attrib.pop("ticks"))

    def running(node: Any) -> Any:
        counts[node.name()] += 1
        done = counts[node.name()] >= ticks[node.name()]
        return bt.NodeStatus.SUCCESS if done else bt.NodeStatus.RUNNING

    def start(node: Any) -> Any:
        counts[node.name()] = 0
        return running(node)

    factory = bt.BehaviorTreeFactory()
    factory.register_simple_stateful_action("Step", start, running)
    factory.register_simple_stateful_action(
        "running", lambda _n: bt.NodeStatus.RUNNING, lambda _n: bt.NodeStatus.RUNNING
    )
    return factory.create_tree_from_text(ET.tostring(root, "unicode"))


def _same_ticks(root: py_trees.behaviour.Behaviour, ticks: int) -> None:
    counts: dict[str, int] = {}
    tree = _btcpp_tree(bench.py_trees_xml(root), counts)
    steps = [n for n in root.iterate() if isinstance(n, bench_trace.Step)]
    statuses = set()
    for n in range(1, ticks + 1):
        for _ in root.tick():
            pass
        theirs = tree.tick_exactly_once()
        assert theirs.name == root.status.name, f"tick {n}"
        assert {s.name: s.count for s in steps if s.name in counts} == counts, f"tick {n}"
        statuses.add(theirs.name)
    assert statuses == {"RUNNING", "SUCCESS"}


def test_the_sparse_tree_ticks_in_bt_cpp_as_in_py_trees() -> None:
    # 3-tick steps: the 7 steps run in turn, the root succeeds at tick 21 and starts again
    _same_ticks(bench_trace.fifty_node_tree(step_ticks=3).root, 50)


def test_the_scale_trees_pab_subtree_ticks_in_bt_cpp_as_in_py_trees() -> None:
    # copy 1 of the scale tree's PAB (the benchmark runs copy 0, whose first action
    # never ends): every step's action and confirmation run and finish
    _same_ticks(bench_scale.pab_subtree(1), 40)


def test_every_benchmark_tree_loads_in_bt_cpp_and_runs() -> None:
    for case in bench.cases():
        tree = _btcpp_tree(case.xml, {})
        for _ in range(3):
            assert tree.tick_exactly_once().name == "RUNNING", case.label


def test_the_cpp_ticker_builds_the_same_trees(tmp_path: Path) -> None:
    # the C++ ticker checks BT.CPP's node count and final status against py_trees'
    build = bench.ticker_build()
    try:
        ticker = build.build_ticker()
    except build.Unavailable as exc:
        pytest.skip(f"BT.CPP ticker unavailable: {exc}")
    for n, case in enumerate(bench.cases()):
        path = tmp_path / f"tree{n}.xml"
        path.write_text(case.xml, encoding="utf-8")
        assert bench.cpp_run(ticker, path, case, ticks=10) > 0
