"""Probe 15: a planner author who reads only the docs, writing navigators of their own.

What they wrote in a hurry (an ``async def next_step``, a ``yield`` in it, an object
with no ``next_step``) and what they read back (the result's ``truth_m`` beside its
belief) must make sense without reading the library's code: one line that names
what is wrong, no ``<... object at 0x7f...>``, nothing connected before a refusal.
"""

from __future__ import annotations

import re
from collections.abc import AsyncIterator, Iterator
from pathlib import Path
from typing import Any

import pytest

import pirate_bt
from pirate_bt import Observation, Step
from pirate_bt.errors import InputError, shown


class _Done:
    def next_step(self, obs: Observation) -> Step | None:
        return None


class _Async:
    async def next_step(self, obs: Observation) -> Step | None:
        return None


class _Yields:
    def next_step(self, obs: Observation) -> Iterator[Step]:
        yield Step("wait", time="1 s")


class _AsyncYields:
    async def next_step(self, obs: Observation) -> AsyncIterator[Step]:
        yield Step("wait", time="1 s")


class _NoNextStep:
    def step(self, obs: Observation) -> None:
        return None


class _ReturnsObject:
    def next_step(self, obs: Observation) -> Any:
        return _NoNextStep()


@pytest.mark.parametrize(
    ("navigator", "said"),
    [
        (_Async(), "navigate: _Async.next_step is async def; write it as a plain def"),
        (_AsyncYields(), "navigate: _AsyncYields.next_step is async def"),
        (_Yields(), "navigate: _Yields.next_step yields; write it to return a Step"),
    ],
)
def test_an_async_or_yielding_next_step_is_refused_before_anything_connects(
    navigator: Any, said: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    # before: the navigation connected, ran, and failed with "returned <coroutine
    # object _Async.next_step at 0x7f...>, not a Step" (and a never-awaited warning)
    def no_connect(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("connected before refusing the navigator")

    monkeypatch.setattr("pirate_bt.api.navigation.connect", no_connect)
    with pytest.raises(InputError) as caught:
        pirate_bt.navigate(navigator, sim="straight")
    assert str(caught.value).startswith(said)
    assert "0x" not in str(caught.value) and "\n" not in str(caught.value)


def test_a_navigator_without_next_step_is_named_by_its_class_not_its_address() -> None:
    with pytest.raises(InputError) as caught:
        pirate_bt.navigate(_NoNextStep(), sim="straight")
    assert str(caught.value) == "navigate: a _NoNextStep has no next_step(obs) method"


def test_a_step_that_is_no_step_is_named_by_its_type_not_its_address() -> None:
    result = pirate_bt.navigate(_ReturnsObject(), sim="straight", max_time=5)
    assert result.status == "failure" and result.safe_state
    assert "returned a _NoNextStep, not a Step" in result.why
    assert "0x" not in result.why


def test_shown_names_a_default_repr_by_its_type() -> None:
    async def later() -> None:
        return None

    coroutine = later()
    try:
        assert shown(coroutine).startswith("a coroutine (")
        assert "later" in shown(coroutine) and "0x" not in shown(coroutine)
    finally:
        coroutine.close()
    assert shown(_NoNextStep()) == "a _NoNextStep"
    assert shown("<x at 0x1>") == "'<x at 0x1>'"  # text is still shown as text


@pytest.mark.parametrize("network", ["bend-right", "lab"])
def test_a_navigation_with_a_map_that_ran_no_step_has_its_truth_where_its_belief_is(
    network: str,
) -> None:
    # before: "believed at 0.52 m, truly 0.00 m" for a robot that had not moved:
    # the truth counted from the start, the belief from the map's entry
    result = pirate_bt.navigate(_Done(), map=network)
    assert result.status == "success" and result.steps == 0
    assert result.truth_m is not None and result.belief_m > 0.3
    assert result.truth_m == pytest.approx(result.belief_m, abs=1e-6)
    assert "truly 0.00 m" not in result.summary()


def test_a_network_of_the_wrong_type_is_said_with_its_article() -> None:
    with pytest.raises(InputError) as caught:
        pirate_bt.simulate_mission("bend-right", truth=123)  # type: ignore[arg-type]
    assert str(caught.value).endswith("not an int")


DOCS = Path(__file__).resolve().parent.parent / "docs"


def _block(page: str, holding: str) -> str:
    text = (DOCS / page).read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    return next(block for block in blocks if holding in block)


def test_the_trees_doc_python_built_nodes_block_runs_on_its_own() -> None:
    # before: NameError: name 'clock' is not defined (it leant on the block above)
    code = _block("trees.md", "ctx = BuildContext(")
    space: dict[str, Any] = {}
    exec(compile(code, "docs/trees.md", "exec"), space)
    assert space["clamp"].name == "clamp front"


def test_the_campaign_doc_says_a_misspelt_navigator_parameter_as_the_campaign_does(
    tmp_path: Path,
) -> None:
    from pirate_bt.campaign import run_campaign

    run = "- {name: goal, navigator: goal, network: lab, params: {segmnt: riser}}"
    text = (DOCS / "campaigns.md").read_text(encoding="utf-8")
    assert run in text
    spec = tmp_path / "nav.campaign.yaml"
    spec.write_text(f"name: nav\nruns:\n  {run}\n", encoding="utf-8")
    with pytest.raises(InputError) as caught:
        run_campaign(spec, output=None)
    said = str(caught.value)
    assert said.startswith(f"{spec}:3:")
    quoted = " ".join(text.split())  # the doc wraps its lines
    assert f"nav.campaign.yaml{said[len(str(spec)) :]}" in quoted


def test_a_network_given_as_a_file_without_yaml_or_a_folder_says_what_it_is(
    tmp_path: Path,
) -> None:
    # before: "no network '/.../drawing'", as if nothing were there
    drawing = tmp_path / "drawing"
    drawing.write_text("segments: []\n", encoding="utf-8")
    with pytest.raises(InputError) as caught:
        pirate_bt.load_network(drawing)
    assert ": a network file ends in .yaml;" in str(caught.value)
    with pytest.raises(InputError) as caught:
        pirate_bt.navigate(_Done(), map=tmp_path)
    said = str(caught.value)
    assert said.startswith("map: no network '") and ": it is a folder;" in said


def test_a_survey_refused_for_its_faults_leaves_no_output_folder_behind(tmp_path: Path) -> None:
    # before: the folders of output= were made, then the fault was refused
    output = tmp_path / "new" / "deeper" / "surveyed.yaml"
    with pytest.raises(InputError, match="unknown motor 'nosuch'"):
        pirate_bt.survey(sim="straight", output=output, faults="motor_stall:nosuch@1s")
    assert not (tmp_path / "new").exists()
    kept = tmp_path / "kept"
    kept.mkdir()
    with pytest.raises(InputError):
        pirate_bt.survey(sim="straight", output=kept / "s.yaml", faults="motor_stall:nosuch@1s")
    assert kept.is_dir()  # a folder that was there is left


def test_a_navigation_result_is_plain_json_as_a_mission_result_is() -> None:
    # RunResult and MissionResult have as_dict(); a planner's report of a navigation
    # had to pick NavigationResult's fields by hand
    import json

    result = pirate_bt.navigate("goal", params={"segment": "after"}, map="bend-right", max_time=3)
    assert not result.succeeded  # cut short by its time limit: the first cause kept
    data = json.loads(json.dumps(result.as_dict()))
    assert data["status"] == "failure" and data["why"] == result.why
    assert data["why"].startswith("navigation time limit reached (3 s) in step 1")
    assert [p["label"] for p in data["pabs"]] == [p.label for p in result.pabs]
    assert len(data["missions"]) == len(result.missions) == 1
    assert data["missions"][0]["status"] == "failure"
    assert data["decisions"][0]["step"] == result.decisions[0].step.to_json()  # type: ignore[union-attr]
    assert data["counters"] == result.counters.as_dict()


class _BuggyCheck:
    """A check_map with a bug: Python raises the TypeError, not a raise of its own."""

    def find(self) -> None:
        return None

    def check_map(self, network: Any) -> None:
        if "run-d" in self.find:  # type: ignore[operator]
            return

    def next_step(self, obs: Observation) -> Step | None:
        return None


class _RefusingCheck(_BuggyCheck):
    def check_map(self, network: Any) -> None:
        raise ValueError("this planner needs a map with a tee")


def test_a_bug_in_check_map_is_said_as_a_bug_with_its_place_not_as_a_bad_map() -> None:
    with pytest.raises(InputError) as caught:
        pirate_bt.navigate(_BuggyCheck(), map="straight", max_time=1)
    said = str(caught.value)
    assert said.startswith(
        "navigator '_BuggyCheck': check_map raised TypeError: argument of type 'method'"
    ), said
    assert f"(at {__file__}:" in said
    with pytest.raises(InputError) as refused:  # a refusal of its own stays as it was
        pirate_bt.navigate(_RefusingCheck(), map="straight", max_time=1)
    assert str(refused.value) == "navigator '_RefusingCheck': this planner needs a map with a tee"
