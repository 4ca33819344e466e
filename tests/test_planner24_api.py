"""Planner scripts written from the docs alone (the twenty-fourth session's probe).

What a planner met: ``print(campaign_result)`` printed every row with its coverage
(megabytes for a large campaign); the map a navigator is handed, ``obs.map``, had a
type no name of ``pirate_bt`` gave (a typed ``check_map`` needed ``pirate_bt.pipes``);
and ``obs.map.path(obs.choices)``, the way taken so far, failed ``mypy --strict``
(``Mapping[str, str]`` is not ``Mapping[str, Literal['straight', 'branch']]``).
"""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.campaign.case import OUTCOMES
from pirate_bt.campaign.stats import Counts


def _row(index: int) -> dict[str, object]:
    """A campaign row as big as a real one: its coverage lists every node."""
    names = [f"node {n}" for n in range(60)]
    return {
        "id": f"{index:06d}-00000000",
        "index": index,
        "run": "s",
        "outcome": "success" if index % 3 else "failed-safe",
        "reason": "tree succeeded after 132 ticks",
        "coverage": {"names": names, "counts": [[n, 132, 2, 1, 0, 0, 0] for n in range(60)]},
    }


def test_printing_a_campaign_result_is_one_short_line_not_every_row() -> None:
    rows = tuple(_row(i) for i in range(300))
    counts = dict.fromkeys(OUTCOMES, 0)
    for row in rows:
        counts[str(row["outcome"])] += 1
    result = pirate_bt.CampaignResult(
        name="mine",
        rows=rows,
        groups=(),
        counts=Counts(counts),
        violations=0,
        damage=0,
        output=Path("campaign-mine"),
        report_path=Path("campaign-mine/report.md"),
        files=(),
        executor="2 local workers",
        wall_s=12.5,
    )
    shown = repr(result)
    assert "\n" not in shown and len(shown) < 400, shown[:500]  # was some 700,000 characters
    assert shown.startswith("CampaignResult(name='mine', cases=300 (200 success, 100 failed-safe)")
    assert "succeeded=False" in shown and "output='campaign-mine'" in shown
    assert str(result) == shown


def test_the_map_a_navigator_is_given_is_a_pirate_bt_network() -> None:
    network = pirate_bt.load_network("t-joint")
    assert isinstance(network, pirate_bt.Network)
    assert "Network" in pirate_bt.__all__ and "Network" in dir(pirate_bt)

    # a check_map typed with it refuses a map as the docs say
    class NeedsBranch:
        def check_map(self, map: pirate_bt.Network | None) -> None:
            if map is None or all("branch" not in p.segments for p in map.paths()):
                raise ValueError("the map has no segment 'branch'")

        def next_step(self, obs: pirate_bt.Observation) -> pirate_bt.Step | None:
            return None

    with pytest.raises(pirate_bt.InputError, match="NeedsBranch': the map has no segment"):
        pirate_bt.navigate(NeedsBranch(), map="straight")


def test_the_way_taken_so_far_is_a_path_of_the_map_for_a_type_checker_too() -> None:
    # Observation.choices is a Mapping[str, str]; Network.path must take it as it is
    # (as written: the package's annotations are strings, some of TYPE_CHECKING names)
    assert pirate_bt.Observation.__annotations__["choices"] == "Mapping[str, str]"
    assert pirate_bt.Network.path.__annotations__["choices"] == "Mapping[str, str] | None"
    network = pirate_bt.load_network("t-joint")
    assert "branch" in network.path({"tee": "branch"}).segments
    # the value is still checked where the annotation no longer says it
    with pytest.raises(pirate_bt.InputError, match="'left' is no way through a tee"):
        network.path({"tee": "left"})


def test_printing_a_trace_read_back_says_what_run_it_holds(tmp_path: Path) -> None:
    path = tmp_path / "run.jsonl"
    pirate_bt.simulate_tree("straight", params={"distance": "0.2 m"}, trace=path)
    shown = repr(pirate_bt.read_trace(path))  # was <pirate_bt.trace.reader.Trace object at 0x...>
    assert shown == (
        f"Trace({str(path)!r}, tree='straight', outcome='success',"
        " why='tree succeeded after 107 ticks', last_tick=111, duration_s=5.50, records=111)"
    )


def test_a_network_counts_its_segments_and_tees_in_good_english() -> None:
    # a survey's result showed Network('surveyed', 4 segments, 1 tees)
    assert repr(pirate_bt.load_network("t-joint")) == "Network('t-joint', 4 segments, 1 tee)"
    assert repr(pirate_bt.load_network("straight")) == "Network('straight', 1 segment, 0 tees)"
