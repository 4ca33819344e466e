"""Coverage: which nodes ran, counted as BehaviorTree.CPP's TreeObserver counts it.

The counts themselves are checked against BT.CPP's own ``TreeObserver`` in
``tests/test_groot2_oracle.py``; here: the BT.CPP view of statuses on small
trees worked out by hand, that the bulk counting of repeated ticks changes
nothing, and that coverage reaches results, traces, summaries, diagrams,
mission reports and campaign reports.
"""

from __future__ import annotations

import json
import random
from pathlib import Path

import py_trees
import pytest
from py_trees.common import Status

import pirate_bt
from pirate_bt.clock import SimClock
from pirate_bt.runner import Runner
from pirate_bt.trace.coverage import (
    Coverage,
    CoverageRecorder,
    attach_coverage,
    coverage_of,
    merge_coverage,
)

ROOT = Path(__file__).resolve().parent.parent
S, F, R = Status.SUCCESS, Status.FAILURE, Status.RUNNING


def queue(name: str, *statuses: Status) -> py_trees.behaviour.Behaviour:
    return py_trees.behaviours.StatusQueue(name, queue=list(statuses), eventually=statuses[-1])


def run(root: py_trees.behaviour.Behaviour, max_ticks: int = 50) -> CoverageRecorder:
    runner = Runner(root, clock=SimClock(), period_s=0.1, max_time_s=max_ticks * 0.1)
    recorder = attach_coverage(runner)
    runner.run()
    assert coverage_of(runner) is recorder
    return recorder


def counts(recorder: CoverageRecorder) -> dict[str, list[int]]:
    return {n.path.rsplit("/", 1)[-1]: n.counts() for n in recorder.coverage()}


def test_a_reactive_sequence_counts_its_condition_every_tick() -> None:
    # BT.CPP: the ReactiveSequence resets the condition to IDLE while the action
    # runs, so each tick the condition goes IDLE -> SUCCESS again: one transition
    # and one success a tick. The action goes RUNNING once, SUCCESS once.
    guarded = py_trees.composites.Sequence(
        "guarded", memory=False, children=[queue("cond", S), queue("act", R, R, R, S)]
    )
    recorder = run(py_trees.composites.Sequence("root", memory=True, children=[guarded]))
    got = counts(recorder)
    assert got["cond"] == [4, 4, 4, 0, 0, 0]
    assert got["act"] == [4, 2, 1, 0, 0, 0]
    # composites turn RUNNING first, then SUCCESS: two transitions each
    assert got["guarded"] == [4, 2, 1, 0, 0, 0]
    assert got["root"] == [4, 2, 1, 0, 0, 0]
    # as BT.CPP leaves it: everything reset to IDLE, each from what it was
    assert recorder.shown == [12, 12, 12, 12]


def test_a_fallback_counts_failures_and_halts() -> None:
    # A reactive fallback: the first child fails twice, then succeeds and halts the
    # second, which was running: one halt; the root resets its children at the end.
    fallback = py_trees.composites.Selector(
        "fallback", memory=False, children=[queue("first", F, F, S), queue("second", R)]
    )
    recorder = run(fallback)
    got = counts(recorder)
    assert got["first"] == [3, 3, 1, 2, 0, 0]
    assert got["second"] == [2, 1, 0, 0, 1, 0]
    assert got["fallback"] == [3, 2, 1, 0, 0, 0]
    assert recorder.coverage().never_ran() == []


def test_a_skip_is_counted_on_the_child_the_guard_passed_over() -> None:
    tree = pirate_bt.load_tree(
        {
            "name": "skipping",
            "blackboard": {"done": {"type": "boolean", "default": True}},
            "root": {
                "type": "sequence",
                "children": [
                    {
                        "type": "skip_if",
                        "name": "unless done",
                        "condition": {"blackboard": "done", "op": "==", "value": True},
                        "child": {"type": "success", "name": "work"},
                    },
                    {"type": "success", "name": "after"},
                ],
            },
        },
        check_robot=False,
    )
    result = pirate_bt.simulate_tree(tree)
    assert result.coverage is not None
    work = result.coverage.node("skipping/unless done/work")
    assert (work.ticks, work.skips, work.ran) == (0, 1, False)
    assert [n.path for n in result.coverage.never_ran()] == ["skipping/unless done/work"]
    guard = result.coverage.node("skipping/unless done")
    assert guard.kind == "guard"
    assert guard in result.coverage.never_failed(("guard",))


def _random_tree(rng: random.Random, depth: int = 0) -> py_trees.behaviour.Behaviour:
    name = f"n{rng.randrange(10**6)}"
    if depth >= 3 or rng.random() < 0.35:
        statuses = [rng.choice((S, F, R, R)) for _ in range(rng.randint(1, 6))]
        return py_trees.behaviours.StatusQueue(name, queue=statuses, eventually=statuses[-1])
    pick = rng.random()
    if pick < 0.15:
        return py_trees.decorators.Inverter(name, _random_tree(rng, depth + 1))
    kids = [_random_tree(rng, depth + 1) for _ in range(rng.randint(1, 4))]
    memory = rng.random() < 0.5
    if pick < 0.55:
        return py_trees.composites.Sequence(name, memory=memory, children=kids)
    if pick < 0.9:
        return py_trees.composites.Selector(name, memory=memory, children=kids)
    return py_trees.composites.Parallel(
        name, policy=py_trees.common.ParallelPolicy.SuccessOnAll(synchronise=True), children=kids
    )


class _TickByTick(CoverageRecorder):
    """The recorder without the bulk counting of repeated ticks."""

    def record_tick(self, _info: object = None) -> None:
        self._steady = False
        super().record_tick(_info)


@pytest.mark.parametrize("seed", range(40))
def test_bulk_counting_of_repeated_ticks_changes_nothing(seed: int) -> None:
    rng = random.Random(seed)
    root = py_trees.composites.Sequence("root", memory=True, children=[_random_tree(rng)])
    tree = py_trees.trees.BehaviourTree(root)
    fast, slow = CoverageRecorder(tree), _TickByTick(tree)
    seen: list[tuple[dict[int, int], list[tuple[int, int]]]] = []
    slow_seen: list[tuple[dict[int, int], list[tuple[int, int]]]] = []
    fast.add_listener(lambda codes, events: seen.append((dict(codes), list(events))))
    slow.add_listener(lambda codes, events: slow_seen.append((dict(codes), list(events))))
    for _ in range(30):
        tree.tick()
        fast.record_tick()
        slow.record_tick()
        assert fast.shown == slow.shown
    fast.finish()
    slow.finish()
    assert fast.coverage() == slow.coverage()
    assert seen == slow_seen


def test_the_result_the_trace_and_the_summary_carry_coverage(tmp_path: Path) -> None:
    trace = tmp_path / "patrol.jsonl"
    result = pirate_bt.simulate_tree(ROOT / "trees" / "examples" / "patrol.yaml", trace=trace)
    assert result.coverage is not None
    assert result.as_dict()["coverage"]["tree"] == "patrol"
    read = pirate_bt.read_trace(trace)
    assert read.coverage is not None
    assert [n.counts() for n in read.coverage] == [n.counts() for n in result.coverage]
    assert [n.kind for n in read.coverage] == [n.kind for n in result.coverage]
    end = json.loads(trace.read_text().splitlines()[-1])
    assert end["coverage"]["counts"]["0"][0] == result.ticks
    from pirate_bt.trace import format_summary, summarise

    lines = format_summary(summarise(read), read.structure)
    assert any(line.startswith("coverage  9 of 9 nodes ran") for line in lines)
    assert "ticks" in next(line for line in lines if line.startswith("node"))


def test_compact_form_round_trips_and_merges() -> None:
    result = pirate_bt.simulate_tree(ROOT / "trees" / "examples" / "patrol.yaml")
    cov = result.coverage
    assert cov is not None
    data = json.loads(json.dumps(cov.as_dict()))
    back = Coverage.from_dict(data)
    assert [(n.path, n.id, n.kind, n.counts()) for n in back] == [
        (n.path, n.id, n.kind, n.counts()) for n in cov
    ]
    merged = merge_coverage([data, cov])
    assert merged is not None and merged.runs == 2
    assert merged.node("patrol").ticks == 2 * cov.node("patrol").ticks
    assert merge_coverage([]) is None


def test_the_diagram_colours_nodes_by_count_band(tmp_path: Path) -> None:
    from pirate_bt.render.tree import COVERAGE_BANDS, tree_graph

    tree = pirate_bt.load_tree(ROOT / "trees" / "examples" / "guarded_wait.yaml")
    result = pirate_bt.simulate_tree(tree)
    assert result.coverage is not None
    source = tree_graph(tree, coverage=result.coverage)
    assert "coverage:" in source
    for node in result.coverage:
        band = [b for b in COVERAGE_BANDS if node.ticks >= b[0]][-1]
        line = next(x for x in source.splitlines() if x.startswith(f'  "{node.id}" ['))
        assert f'fillcolor="{band[1]}"' in line, (node.path, line)
    with pytest.raises(ValueError):
        tree_graph(tree, {"0": "S"}, coverage=result.coverage)


def test_mission_result_and_report_have_coverage(tmp_path: Path) -> None:
    result = pirate_bt.simulate_mission("straight.route", output=tmp_path / "out")
    assert result.coverage is not None and result.coverage.tree
    never = {n.path for n in result.coverage.never_ran()}
    assert any(path.endswith("/recover") for path in never)  # nothing failed: no recovery
    report = (tmp_path / "out" / "report.md").read_text()
    assert "## Coverage" in report
    assert "never failed" in report


def test_campaign_report_names_what_no_run_exercised(tmp_path: Path) -> None:
    from pirate_bt.campaign.report import write_report

    rows = []
    for index in range(3):
        result = pirate_bt.simulate_tree(ROOT / "trees" / "examples" / "patrol.yaml", seed=index)
        assert result.coverage is not None
        rows.append(
            {
                "id": f"c{index}",
                "index": index,
                "run": "patrol",
                "tree": "patrol",
                "outcome": "success",
                "coverage": result.coverage.as_dict(),
            }
        )
    write_report(rows, tmp_path)
    report = (tmp_path / "report.md").read_text()
    assert "## Coverage over all runs" in report
    assert "over 3 runs" in report
    assert "guards and conditions that never failed in any run" in report
    assert "patrol/started?" in report
    assert "Coverage over all runs" in (tmp_path / "report.html").read_text()
