"""BehaviorTree.CPP's tick beside bare py_trees and pirate_bt, on the same trees.

Run: ``.venv/bin/python benchmarks/bench_btcpp.py [--runs N]``. Prints and publishes
the table ``btcpp`` of docs/performance.md ("Trees and runner").

Three trees, each ticked by three engines in the same run of this script:

- **the 51-node tree** of the tree-engine figure (``bench_trees.py``: an eternal
  guard over a parallel of 8 one-hour timeouts over sequences of three stub
  successes and a leaf that stays running);
- **the sparse 50-node tree** of ``bench_trace.py`` (a root sequence of 7 PAB-like
  steps, each a timeout over a sequence of a selector of two leaves, a success and a
  leaf that runs for N ticks; only the first step active, its leaf never finishing);
- **the 3,101-node tree** of ``bench_scale.py`` (a root sequence of 100 copies of a
  31-node PAB-shaped subtree, only the first copy active).

The engines:

BehaviorTree.CPP (C++)
    ``btcpp_tick/tick.cpp``, built once against the BT.CPP 4.8 of the
    ``behaviortreepy`` wheel (``btcpp_tick/build.py``), loads the tree's XML and
    times ``Tree::tickExactlyOnce()``. Without a C++ compiler or BT.CPP's headers
    the script prints ``skipped: <why>`` and exits 0, publishing nothing.
bare py_trees
    The tree built in py_trees, ticked in a bare loop by the benchmark that owns the
    tree: ``bench_trees._time_plain``, ``bench_trace.time_ticks``,
    ``bench_scale.plain_us_per_tick`` (imported, not copied).
pirate_bt
    The :class:`~pirate_bt.runner.Runner` on a simulated clock, as those benchmarks
    run it: the YAML tree (``bench_trees._time_runner``), the sparse tree's py_trees
    nodes (``bench_trace.time_runner_ticks``), the scale tree's
    (``bench_scale.runner_us_per_tick``).

How each tree reaches BT.CPP:

- the 51-node tree is pirate_bt's own export of the YAML
  (:func:`pirate_bt.interop.btcpp_export.tree_to_xml`): ``eternal_guard`` is
  ``ReactiveSequence``, ``sequence`` with ``memory: false`` is ``ReactiveSequence``,
  ``parallel`` (policy all) is ``Parallel success_count=-1 failure_count=1``,
  ``success`` is ``AlwaysSuccess``; two changes (:func:`export_xml_for_btcpp`): the
  exporter's ``timeout`` decorator becomes BT.CPP's ``Timeout`` (``msec`` =
  the duration), and the ``<TreeNodesModel>`` (for Groot2) is left out; pirate_bt's
  ``running`` leaf is a C++ ``StatefulActionNode`` registered under that ID;
- the sparse and scale trees exist only as py_trees objects: :func:`py_trees_xml`
  writes the XML from the very tree py_trees ticks, node for node (Sequence with
  memory -> ``Sequence``, without -> ``ReactiveSequence``; Selector with memory ->
  ``Fallback``, without -> ``ReactiveFallback``; ``Timeout`` -> ``Timeout`` in ms,
  capped at BT.CPP's 32-bit ``msec`` (49 days); ``Success``/``Failure`` ->
  ``AlwaysSuccess``/``AlwaysFailure``; ``bench_trace.Step`` -> a C++
  ``StatefulActionNode`` ``Step`` with a ``ticks`` port).

The C++ ticker reports the node count BT.CPP built and the root's status after the
last tick; both are checked against py_trees' (same count, RUNNING), so a mapping
that drifts fails loudly here. Figures: µs per tick, median and range over the runs;
runs interleave the engines (C++, py_trees, pirate_bt, then the next tree).
"""

from __future__ import annotations

import argparse
import importlib.util
import statistics
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import py_trees

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from bench_trace import Step  # noqa: E402 - this directory is not a package
from report import positive, publish  # noqa: E402

RUNS = 5
CPP_TICKS = 20_000
"""Timed ticks a C++ run (about 0.1 s: the C++ tick is tens of times the Python's speed)."""
SPARSE_TICKS = 5000
"""``bench_trace.py``'s ticks a run."""
SCALE_COPIES = 100
SCALE_TICKS = 2000
SCALE_WARM_UP = 100
"""``bench_scale.py``'s untimed first ticks of a runner run; the C++ run skips as many."""
MSEC_MAX = 2**32 - 1
"""BT.CPP's ``Timeout`` reads ``msec`` as a 32-bit unsigned (49.7 days)."""
NEVER = 10**12
"""Ticks of a leaf that must not finish inside a run."""


# --- the trees as BT.CPP XML ----------------------------------------------------------


def export_xml_for_btcpp(spec: Mapping[str, Any]) -> str:
    """pirate_bt's BT.CPP export of a tree, with ``timeout`` as BT.CPP's own ``Timeout``.

    The exporter writes pirate_bt's ``timeout`` decorator under its own ID (its
    ``duration`` port takes units, BT.CPP's ``Timeout`` takes ``msec``); here it
    becomes ``Timeout msec=...``. The ``<TreeNodesModel>`` (pirate_bt's node models,
    for Groot2) is dropped: BT.CPP does not need it to build the tree.
    """
    from pirate_bt.interop.btcpp_export import tree_to_xml
    from pirate_bt.units import parse_quantity

    root = ET.fromstring(tree_to_xml(spec))
    for models in root.findall("TreeNodesModel"):
        root.remove(models)
    for element in root.iter("timeout"):
        seconds = parse_quantity(element.attrib.pop("duration"), "time")
        element.tag = "Timeout"
        element.set("msec", str(min(round(seconds * 1000), MSEC_MAX)))
    return ET.tostring(root, "unicode")


def py_trees_xml(root: py_trees.behaviour.Behaviour, tree_id: str = "bench") -> str:
    """BT.CPP XML for a py_trees tree of the benchmarks' node types, node for node.

    Raises:
        TypeError: a node type with no BT.CPP counterpart here.
    """

    def element(node: py_trees.behaviour.Behaviour) -> ET.Element:
        attrs = {"name": node.name}
        if isinstance(node, py_trees.composites.Sequence):
            tag = "Sequence" if node.memory else "ReactiveSequence"
        elif isinstance(node, py_trees.composites.Selector):
            tag = "Fallback" if node.memory else "ReactiveFallback"
        elif isinstance(node, py_trees.composites.Parallel):
            policy = node.policy
            if isinstance(policy, py_trees.common.ParallelPolicy.SuccessOnAll) and (
                policy.synchronise
            ):
                tag = "Parallel"
                attrs |= {"success_count": "-1", "failure_count": "1"}
            else:
                raise TypeError(f"{node.name}: parallel policy {policy!r} not mapped")
        elif isinstance(node, py_trees.decorators.Timeout):
            tag = "Timeout"
            attrs["msec"] = str(min(round(node.duration * 1000), MSEC_MAX))
        elif isinstance(node, Step):
            tag = "Step"
            attrs["ticks"] = str(node.ticks)
        elif isinstance(node, py_trees.behaviours.Success):
            tag = "AlwaysSuccess"
        elif isinstance(node, py_trees.behaviours.Failure):
            tag = "AlwaysFailure"
        elif isinstance(node, py_trees.behaviours.Running):
            tag = "running"
        else:
            raise TypeError(f"{node.name}: {type(node).__name__} has no BT.CPP counterpart here")
        out = ET.Element(tag, attrs)
        for child in node.children:
            out.append(element(child))
        return out

    doc = ET.Element("root", {"BTCPP_format": "4", "main_tree_to_execute": tree_id})
    ET.SubElement(doc, "BehaviorTree", {"ID": tree_id}).append(element(root))
    return ET.tostring(doc, "unicode")


def count_nodes(root: py_trees.behaviour.Behaviour) -> int:
    return sum(1 for _ in root.iterate())


# --- the three trees and their engines ----------------------------------------------


@dataclass
class Case:
    """One tree: its row label, node count, XML, and a run of each engine (s/tick)."""

    label: str
    nodes: int
    xml: str
    warm_up: int
    py_trees: Callable[[], float]
    pirate_bt: Callable[[], float]
    python_ticks: int


def cases() -> list[Case]:
    import bench_scale
    import bench_trace
    import bench_trees

    from pirate_bt.clock import SimClock
    from pirate_bt.treefile import load_tree

    def trees_runner() -> float:
        clock = SimClock()
        return bench_trees._time_runner(clock, load_tree(bench_trees._yaml_tree(), clock=clock))

    sparse_root = bench_trace.fifty_node_tree(step_ticks=NEVER).root
    scale_root = bench_scale.mission_tree(SCALE_COPIES)
    return [
        Case(
            "the 51-node tree (`bench_trees.py`: eternal guard, parallel, 8 timeouts"
            " over sequences of stub leaves)",
            count_nodes(bench_trees._plain_tree()),
            export_xml_for_btcpp(bench_trees._yaml_tree()),
            0,
            lambda: bench_trees._time_plain(bench_trees._plain_tree()),
            trees_runner,
            bench_trees.TICKS,
        ),
        Case(
            "the sparse 50-node tree (`bench_trace.py`: 7 PAB-like steps, one active)",
            count_nodes(sparse_root),
            py_trees_xml(sparse_root, "sparse"),
            0,
            # the step never finishes inside the run, as in bench_trace's runner rows
            lambda: bench_trace.time_ticks(
                bench_trace.fifty_node_tree(step_ticks=10 * SPARSE_TICKS),
                SPARSE_TICKS,
                None,
                snapshots=False,
            ),
            lambda: bench_trace.time_runner_ticks(SPARSE_TICKS, None, "sparse", snapshots=False),
            SPARSE_TICKS,
        ),
        Case(
            f"the {count_nodes(scale_root):,}-node tree (`bench_scale.py`: {SCALE_COPIES}"
            " PAB-shaped subtrees, the first active)",
            count_nodes(scale_root),
            py_trees_xml(scale_root, "scale"),
            SCALE_WARM_UP,
            lambda: bench_scale.plain_us_per_tick(SCALE_COPIES, SCALE_TICKS) / 1e6,
            lambda: bench_scale.runner_us_per_tick(SCALE_COPIES, SCALE_TICKS, None) / 1e6,
            SCALE_TICKS,
        ),
    ]


def cpp_run(ticker: Path, xml_path: Path, case: Case, ticks: int = CPP_TICKS) -> float:
    """Seconds per tick of one C++ run; checks BT.CPP built the tree py_trees ticks.

    Raises:
        RuntimeError: the ticker failed, or BT.CPP's tree is not py_trees' (node
            count, or a root that is not RUNNING at the end).
    """
    done = subprocess.run(
        [str(ticker), str(xml_path), str(ticks), str(case.warm_up)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    if done.returncode != 0:
        raise RuntimeError(f"{ticker.name} {xml_path.name}: {done.stderr.strip()}")
    out = dict(line.split(" ", 1) for line in done.stdout.splitlines() if " " in line)
    if int(out["nodes"]) != case.nodes or out["status"] != "RUNNING":
        raise RuntimeError(
            f"{xml_path.name}: BT.CPP built {out['nodes']} nodes ending {out['status']};"
            f" py_trees has {case.nodes} nodes, RUNNING"
        )
    return float(out["seconds_per_tick"])


def ticker_build() -> ModuleType:
    """``btcpp_tick/build.py``, loaded under its own name (not the generic ``build``)."""
    spec = importlib.util.spec_from_file_location(
        "btcpp_tick_build", HERE / "btcpp_tick" / "build.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def micro(seconds: float) -> str:
    """Seconds as µs: two decimals under 10 µs, one above."""
    us = seconds * 1e6
    return f"{us:.2f}" if us < 10 else f"{us:.1f}"


def cell(values: list[float], against: list[float] | None = None, bold: bool = False) -> str:
    """``median µs (min–max)``, then the ratio of the medians to ``against``'s."""
    median = statistics.median(values)
    text = f"{micro(median)} µs"
    text = f"**{text}**" if bold else text
    text += f" ({micro(min(values))}–{micro(max(values))})"
    if against:
        text += f", {median / statistics.median(against):.0f}x"
    return text


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--runs", type=positive, default=RUNS, help=f"runs per engine (default {RUNS})"
    )
    args = parser.parse_args(argv)
    build = ticker_build()
    try:
        ticker = build.build_ticker()
    except build.Unavailable as exc:
        print(f"skipped: {exc}")
        return 0
    every = cases()
    times: dict[str, dict[str, list[float]]] = {c.label: {} for c in every}
    with tempfile.TemporaryDirectory() as tmp:
        paths = {}
        for n, case in enumerate(every):
            paths[case.label] = Path(tmp) / f"tree{n}.xml"
            paths[case.label].write_text(case.xml, encoding="utf-8")
        for _ in range(args.runs):
            for case in every:
                got = times[case.label]
                got.setdefault("cpp", []).append(cpp_run(ticker, paths[case.label], case))
                got.setdefault("py_trees", []).append(case.py_trees())
                got.setdefault("pirate_bt", []).append(case.pirate_bt())
    rows = []
    for case in every:
        got = times[case.label]
        cpp = got["cpp"]
        print(
            f"{case.nodes:>5} nodes: BT.CPP {statistics.median(cpp) * 1e6:8.2f} us,"
            f" py_trees {statistics.median(got['py_trees']) * 1e6:8.1f} us,"
            f" pirate_bt {statistics.median(got['pirate_bt']) * 1e6:8.1f} us per tick"
        )
        rows.append(
            [
                case.label,
                cell(cpp, bold=True),
                cell(got["py_trees"], cpp),
                cell(got["pirate_bt"], cpp),
            ]
        )
    publish(
        "btcpp",
        ["tree", "BehaviorTree.CPP (C++)", "bare py_trees", "pirate_bt"],
        rows,
        note=f"µs per tick, median (range) of {args.runs} runs that interleave the engines;"
        " after the Python figures, how many times BT.CPP's tick they take. BT.CPP 4.8 as"
        " built in the `behaviortreepy` wheel (release), the tree loaded from XML and"
        f" ticked with `tickExactlyOnce()`, {CPP_TICKS:,} ticks a run"
        f" ({SCALE_WARM_UP} untimed first on the large tree); py_trees and pirate_bt as"
        " the benchmark owning each tree runs them,"
        f" {', '.join(f'{c.python_ticks:,}' for c in every)} ticks a run: bare py_trees"
        " is `BehaviourTree.tick()` in a loop on the first two trees (it walks every node"
        " after each tick) and `root.tick()` alone on the large one; pirate_bt is the"
        " `Runner` on a simulated clock (no walk of the whole tree). The 51-node"
        " tree reaches BT.CPP through pirate_bt's XML export, its timeouts as BT.CPP's"
        " `Timeout`; the other two are written node for node from the py_trees trees; the"
        " leaves BT.CPP has no built-in for (`running`, the N-tick step) are small C++"
        " `StatefulActionNode`s.",
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
