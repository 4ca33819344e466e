"""Navigators in campaigns: the ``navigator`` run kind and the ``as_built`` axis."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from pirate_bt.campaign import campaign_from_data, expand, run_campaign
from pirate_bt.errors import InputError

SHORT_BRANCH = Path(__file__).parent / "data" / "networks" / "t-joint-short-branch.yaml"
GOAL = {"name": "goal", "navigator": "goal", "network": "t-joint", "params": {"segment": "after"}}
ROUTE = {
    "name": "route",
    "navigator": "route",
    "network": "t-joint",
    "params": {"route": "t-joint-straight.route"},
}

SHORT_BEFORE_BEND = Path(__file__).parent / "data" / "networks" / "short-before-bend.yaml"


def _spec(**changes: Any) -> dict[str, Any]:
    spec: dict[str, Any] = {
        "name": "navigators",
        "runs": [GOAL],
        "max_time": "300 s",
        "case_timeout": "120 s",
    }
    spec.update(changes)
    return spec


def test_navigators_compared_over_the_same_as_built_variants(tmp_path: Path) -> None:
    out = tmp_path / "out"
    result = run_campaign(
        _spec(runs=[GOAL, ROUTE], as_built={"count": 2, "first": 3}), output=out, workers=2
    )
    rows = sorted(result.rows, key=lambda r: r["index"])
    assert [(r["navigator"], r["as_built"]) for r in rows] == [
        ("goal", 3),
        ("goal", 4),
        ("route", 3),
        ("route", 4),
    ]
    assert all(r["outcome"] == "success" for r in rows), [r["reason"] for r in rows]
    for row in rows:
        assert row["steps"] == 2 and row["ticks"] > 0
        assert 1.0 < row["distance_m"] < 5.0
    # the variants are different pipes: the route to the end of the line drives
    # different distances in them
    assert rows[2]["distance_m"] != rows[3]["distance_m"]
    report = (out / "report.md").read_text()
    # one group per navigator; the variants are its runs, as seeds are
    assert "| goal as-built x1 drop=0 corrupt=0 dup=0 | 2 | 100.0 % |" in report
    assert "| route as-built x1 drop=0 corrupt=0 dup=0 | 2 | 100.0 % |" in report
    assert "steps p50" in report and "s per m p50" in report
    header = (out / "results.csv").read_text().splitlines()[0].split(",")
    assert {"navigator", "steps", "distance_m", "as_built"} <= set(header)


def test_a_goal_the_map_does_not_have_stops_the_campaign_before_any_case() -> None:
    seen: list[Any] = []
    run = {**GOAL, "params": {"segment": "nowhere"}}
    with pytest.raises(InputError, match=r"navigator 'goal': the map .* has no segment 'nowhere'"):
        run_campaign(_spec(runs=[run]), on_record=seen.append)
    assert seen == []


def test_a_navigators_own_failure_is_a_failed_safe_row_that_names_it() -> None:
    # the map's branch is 2 m, the world's 0.5 m: too short to hold the robot, so the
    # goal navigator asks again and again for a step that moves nothing
    truth = SHORT_BRANCH
    run = {**GOAL, "params": {"segment": "branch"}}
    result = run_campaign(_spec(runs=[run], maps=[str(truth)]), workers=1)
    (row,) = result.rows
    assert row["outcome"] == "failed-safe", row["reason"]
    assert row["reason"].startswith("navigator 'goal' is stuck"), row["reason"]


def test_an_unknown_navigator_stops_the_campaign_before_any_case() -> None:
    seen: list[Any] = []
    with pytest.raises(InputError, match=r"run 'wall'.*no navigator named 'wall-follower'"):
        run_campaign(
            _spec(runs=[{"name": "wall", "navigator": "wall-follower", "network": "straight"}]),
            on_record=seen.append,
        )
    assert seen == []


def test_a_parameter_the_navigator_does_not_take_is_named() -> None:
    run = {**GOAL, "params": {"segmnet": "after"}}
    with pytest.raises(InputError, match="segmnet"):
        run_campaign(_spec(runs=[run]))


@pytest.mark.parametrize(
    ("changes", "words"),
    [
        ({"runs": [{"navigator": "goal", "tree": "straight"}]}, "exactly one of"),
        ({"runs": [{"tree": "straight", "blind": True}]}, "'blind' applies to navigators"),
        (
            {"runs": [{"tree": "straight"}], "as_built": {"count": 2}},
            "applies to routes and navigators",
        ),
        ({"maps": ["lab"], "as_built": {"count": 2}}, "not both"),
        ({"as_built": {"count": 0}}, "as_built.count"),
        ({"as_built": {"count": 2, "scale": -1}}, "as_built.scale"),
    ],
)
def test_navigator_and_as_built_specs_are_checked(changes: dict[str, Any], words: str) -> None:
    with pytest.raises(InputError, match=words):
        campaign_from_data(_spec(**changes))


def test_cases_without_navigators_or_variants_keep_their_ids() -> None:
    # the keys are added only when used, so an old campaign's results resume as they were
    tree = {"tree": "straight", "params": {"distance": "0.2 m"}}
    (case,) = expand(campaign_from_data({"name": "ids", "runs": [tree]}))
    assert "navigator" not in case and "as_built" not in case
    assert case["id"] == "000000-ec5c404f"  # as before navigators and variants
    (case,) = expand(campaign_from_data({"name": "ids", "runs": [{"route": "lab.route"}]}))
    assert case["id"] == "000000-6449462a"
    built = expand(campaign_from_data(_spec(as_built={"count": 3})))
    assert [c["as_built"] for c in built] == [1, 2, 3]
    assert len({c["id"] for c in built}) == 3


def test_the_as_built_axis_counts_in_the_case_bound() -> None:
    spec = campaign_from_data(_spec(as_built={"count": 50}, seeds={"start": 0, "count": 50}))
    with pytest.raises(InputError, match="2,500 cases"):
        expand(spec, max_cases=1000)


def test_a_survey_campaign_runs_explore_on_as_built_variants_of_the_world(
    tmp_path: Path,
) -> None:
    # blind: the network is only the world, and as_built draws its variants
    explore = {"name": "survey", "navigator": "explore", "network": "t-joint", "blind": True}
    result = run_campaign(
        _spec(runs=[explore], as_built={"count": 2, "first": 3}, max_time="600 s"),
        output=tmp_path / "out",
        workers=2,
    )
    rows = sorted(result.rows, key=lambda r: r["index"])
    assert [(r["navigator"], r["blind"], r["as_built"]) for r in rows] == [
        ("explore", True, 3),
        ("explore", True, 4),
    ]
    assert all(r["outcome"] == "success" for r in rows), [r["reason"] for r in rows]
    # main line, back, and into the branch: eleven steps, a different pipe each time
    # (a joint swinging into the tee's opening is no diameter change: no extra step)
    assert all(r["steps"] == 11 for r in rows), [r["steps"] for r in rows]
    assert rows[0]["distance_m"] != rows[1]["distance_m"]


def test_a_map_that_puts_the_robot_in_across_a_bend_stops_the_campaign_before_any_case() -> None:
    # navigate() refuses it before it connects: each case raised it, one error row each
    net = SHORT_BEFORE_BEND
    seen: list[Any] = []
    run = {**GOAL, "network": str(net), "params": {"segment": "c"}}
    with pytest.raises(InputError, match=r"runs\[0\]\.network.*across the bend 'b'"):
        run_campaign(_spec(runs=[run]), on_record=seen.append)
    assert seen == []
