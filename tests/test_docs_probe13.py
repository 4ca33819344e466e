"""Probe 13: a researcher with only the manual (docs/api.md, navigators.md,
missions.md, campaigns.md, observability.md, routes.md, networks.md) writes planner
scripts; each discrepancy found is fixed and tested here, on short networks."""

from __future__ import annotations

import json
from pathlib import Path

import pirate_bt
from pirate_bt import Observation, Step


class _Done:
    """A navigator that is done at once: the navigation connects, and runs no step."""

    def next_step(self, obs: Observation) -> Step | None:
        return None


def _scenario(trace: Path) -> str:
    first = json.loads((trace / "navigation.jsonl").read_text().splitlines()[0])
    return str(first["scenario"])


def test_navigate_with_a_map_and_no_sim_runs_in_the_map(tmp_path: Path) -> None:
    """docs/navigators.md, *The loop*: with neither ``sim=`` nor ``port=`` the simulator
    runs the map, as a mission's truth defaults to its map and a campaign's navigator
    runs in its ``network``. It ran the bundled ``straight`` whatever the map was, so
    ``navigate("goal", map="lab", ...)`` drove 5 m of straight pipe against the lab's
    drawing and failed on a disagreement at its first bend."""
    pirate_bt.navigate(_Done(), map="bend-right", trace=tmp_path / "a")
    assert _scenario(tmp_path / "a") == "bend-right"
    pirate_bt.navigate(_Done(), trace=tmp_path / "b")  # no map: straight, as before
    assert _scenario(tmp_path / "b") == "straight"
    pirate_bt.navigate(_Done(), sim="t-joint", map="bend-right", trace=tmp_path / "c")
    assert _scenario(tmp_path / "c") == "t-joint"  # sim= still says what the pipe is


def test_a_route_navigator_run_again_follows_its_route_again() -> None:
    """docs/navigators.md, *Built-in navigators*: one ``RouteNavigator`` given to two
    navigations drives its route in each. The second was ``done after 0 steps``, a
    success with the robot not moved, as the first had used up the route."""
    from pirate_bt.task import parse_route

    route = parse_route("network straight\nforward 0.2 m\n", "short.route")
    navigator = pirate_bt.RouteNavigator(route)
    for _ in range(2):
        result = pirate_bt.navigate(navigator, sim="straight", map="straight")
        assert result.status == "success" and result.steps == 1, result.why
        assert result.distance_m > 0.15


def test_an_explore_navigator_run_again_surveys_afresh(tmp_path: Path) -> None:
    """docs/navigators.md, *Built-in navigators*: one ``ExploreNavigator`` given to two
    navigations surveys the pipe each time. The second went on from the first survey and
    wrote both as one network: ``bend-right`` surveyed twice had two bends."""
    out = tmp_path / "s.yaml"
    navigator = pirate_bt.ExploreNavigator(output=out, search="2 m")
    for _ in range(2):
        result = pirate_bt.navigate(navigator, sim="straight")
        assert result.status == "success", result.why
        assert navigator.network is not None
        assert [s.type for s in navigator.network.segments] == ["straight"]
    assert [s.type for s in pirate_bt.load_network(out).spec.segments] == ["straight"]


def test_a_campaign_axis_of_truths_with_a_tree_run_is_placed_at_its_key(tmp_path: Path) -> None:
    """docs/campaigns.md: every mistake in a campaign file is one line at its
    ``file:line:column``. ``as_built`` (or ``maps``) beside a tree run was placed at
    the file's ``1:1`` and named no run; it is placed at the axis, naming the tree."""
    import pytest

    from pirate_bt.campaign import run_campaign
    from pirate_bt.errors import InputError

    spec = tmp_path / "c.campaign.yaml"
    spec.write_text(
        "name: c\nruns:\n  - {name: a, tree: straight}\n  - {route: bend-right}\n"
        "as_built: {count: 2}\n"
    )
    with pytest.raises(InputError) as caught:
        run_campaign(spec, workers=1)
    assert str(caught.value).startswith(f"{spec}:5:1: 'as_built' (variants of the network)")
    assert "run 'a' is a tree" in str(caught.value)
    spec.write_text("name: c\nruns: [{tree: straight}]\nmaps: [null, lab]\n")
    with pytest.raises(InputError, match=r":3:1: 'maps' .* run 'straight' is a tree"):
        run_campaign(spec, workers=1)


def test_reading_a_navigations_record_as_a_trace_names_the_step_traces(tmp_path: Path) -> None:
    """docs/navigators.md, *Traces*: ``DIR/navigation.jsonl`` is the navigation's record
    and ``DIR/step-NNN.jsonl`` its tick traces, which ``read_trace`` reads. Given the
    record, ``read_trace`` said only *the first record is no header*; it now says what
    the file is and where the traces are."""
    import pytest

    from pirate_bt.errors import InputError

    pirate_bt.navigate(_Done(), trace=tmp_path)
    with pytest.raises(InputError, match=r"navigation.jsonl:1:1: .*no header \(a navigation's"):
        pirate_bt.read_trace(tmp_path / "navigation.jsonl")


def test_read_trace_given_a_folder_names_the_traces_in_it(tmp_path: Path) -> None:
    """docs/campaigns.md, the rows' ``trace``: a route or navigator case keeps a folder
    (a mission's outputs; a navigation's ``step-NNN.jsonl``). ``read_trace`` given the
    row's ``trace`` said *unknown trace format; name it with one of: .jsonl, ...*; it
    says it is a folder and names the traces in it."""
    import pytest

    from pirate_bt.errors import InputError

    class Short:
        def next_step(self, obs: Observation) -> Step | None:
            return Step("straight", distance="0.1 m") if obs.step == 0 else None

    pirate_bt.navigate(Short(), trace=tmp_path)
    in_it = r"cannot read trace: it is a folder, not a file; the traces in it: step-0"
    with pytest.raises(InputError, match=in_it):
        pirate_bt.read_trace(tmp_path)
    assert pirate_bt.read_trace(tmp_path / "step-001.jsonl").outcome == "success"


def test_a_navigation_that_ran_no_step_has_its_truth_on_the_simulator() -> None:
    """docs/navigators.md: the result has ``belief_m`` and, on the simulator,
    ``truth_m``. A navigation that ran no step (done at once, or its navigator raised
    or was late at its first decision) had ``truth_m`` ``None`` on the simulator."""

    class Raises:
        def next_step(self, obs: Observation) -> Step | None:
            raise RuntimeError("no plan")

    for navigator in (_Done(), Raises()):
        result = pirate_bt.navigate(navigator, sim="straight")
        assert result.steps == 0
        assert result.truth_m == 0.0 and result.belief_m == 0.0


def test_a_decision_records_what_the_navigator_was_told(tmp_path: Path) -> None:
    """docs/navigators.md: ``decisions`` are every answer *with its observation*. A
    navigator that wrote into ``obs.choices`` (a plain dict it is handed) changed the
    recorded observation: the result and ``navigation.jsonl`` showed its scribble as
    the way the robot had taken."""

    class Scribbles:
        def next_step(self, obs: Observation) -> Step | None:
            obs.choices["tee"] = "branch"
            return None

    result = pirate_bt.navigate(Scribbles(), sim="t-joint", map="t-joint", trace=tmp_path)
    assert result.decisions[0].observation.choices == {}
    record = json.loads((tmp_path / "navigation.jsonl").read_text().splitlines()[1])
    assert record["observation"]["choices"] == {}
