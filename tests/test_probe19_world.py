"""The nineteenth probe of missions on a pipe as built, not as drawn (docs/missions.md,
docs/navigators.md, docs/networks.md), each test written from what a user saw.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pirate_bt
from pirate_bt.pipes import Network, network_from_data


def _net(name: str, *segments: dict[str, Any], **top: Any) -> Network:
    data = {"name": name, "diameter": "63 mm", "segments": list(segments), **top}
    return network_from_data(data)


def _route(tmp_path: Path, text: str) -> str:
    path = tmp_path / "probe.route"
    path.write_text("network drawn\n" + text, encoding="utf-8")
    return str(path)


def test_a_block_short_of_the_routes_bend_names_the_maps_next_turn(tmp_path: Path) -> None:
    # 'a' built 30 % shorter than drawn: the leg up to the bend is blocked at the real
    # bend, 0.90 m before the map's, beyond the matcher's reach. The why said only
    # "where the map has no turn and no end within 0.86 m", though the route's next
    # command turns at the map's bend 'b', drawn 0.90 m further on.
    drawn = _net(
        "drawn",
        {"id": "a", "type": "straight", "length": "3 m"},
        {"id": "b", "type": "bend", "direction": "right"},
        {"id": "c", "type": "straight", "length": "3 m"},
    )
    built = _net(
        "built",
        {"id": "a", "type": "straight", "length": "2.1 m"},
        {"id": "b", "type": "bend", "direction": "right"},
        {"id": "c", "type": "straight", "length": "2.1 m"},
    )
    route = _route(tmp_path, "at the bend turn right\nforward to the end\n")
    result = pirate_bt.simulate_mission(route, network=drawn, truth=built)
    assert result.status == "failure" and result.safe_state
    assert result.counters.violations == 0
    assert result.why.startswith(
        "belief and map disagree: the pipe blocked the robot at 2.10 m (believed, 2.10 m"
        " into 'a'), where the map has no turn and no end within"
    ), result.why
    assert result.why.endswith(
        "; the map's next turn, 'b', is drawn 0.90 m further on (at 3.00 m): is the pipe"
        " before it shorter than drawn, or does it turn or end where the map does not have it?"
    ), result.why


def test_a_block_with_no_turn_ahead_names_the_maps_end_of_the_line(tmp_path: Path) -> None:
    # a cap 2 m in, where the map draws 4 m of straight: 'forward 3 m' is blocked there
    drawn = _net("drawn", {"id": "a", "type": "straight", "length": "4 m"})
    built = _net("built", {"id": "a", "type": "straight", "length": "2 m"})
    route = _route(tmp_path, "forward 3 m\n")
    result = pirate_bt.simulate_mission(route, network=drawn, truth=built)
    assert result.status == "failure" and result.safe_state
    assert result.why.endswith(
        "; the map's line ends 2.00 m further on (at 4.00 m): does the pipe end nearer than"
        " drawn, or turn where the map does not have it?"
    ), result.why


class _FromFile:
    """A navigator that says its one step comes from a file whose name has a newline."""

    origin = ("two\nlines.route", 2)

    def next_step(self, obs: pirate_bt.Observation) -> pirate_bt.Step | None:
        return pirate_bt.Step("straight", distance="0.3 m") if obs.step == 0 else None


def test_an_origin_with_a_control_character_is_no_origin() -> None:
    # was: ValidationFailed '<dict>:1:1: name: must not contain control characters' out
    # of pirate_bt.navigate() itself, after connecting, with no result
    result = pirate_bt.navigate(_FromFile(), sim="straight", map="straight")
    assert result.status == "success", result.why
    assert [p.label for p in result.pabs] == ["01 straight 0.3 m (line 1)"]


class _LineTrue:
    origin = ("f.route", True)

    def next_step(self, obs: pirate_bt.Observation) -> pirate_bt.Step | None:
        return pirate_bt.Step("bend", direction="left")


def test_an_origin_whose_line_is_a_bool_is_no_origin() -> None:
    # was: placed at 'f.route:1:1', True taken for line 1
    result = pirate_bt.navigate(_LineTrue(), sim="bend-right", map="bend-right")
    assert result.status == "failure" and result.safe_state
    assert "invalid step Step('bend', direction='left'): <navigator _LineTrue>:1:1:" in result.why


class _Answers:
    def __init__(self, step: object) -> None:
        self.step = step

    def next_step(self, obs: pirate_bt.Observation) -> Any:
        return self.step if obs.step == 0 else None


class _OwnRepr(pirate_bt.Step):
    def __repr__(self) -> str:
        raise RuntimeError("no repr")


def test_a_step_whose_direction_is_an_array_is_an_invalid_step() -> None:
    # was: ValueError 'The truth value of an array with more than one element is
    # ambiguous' out of pirate_bt.navigate() itself, after connecting, with no result
    import numpy as np

    step = pirate_bt.Step("t-joint", direction=np.array(["left", "right"]))
    for kwargs in ({"map": "t-joint"}, {}):
        result = pirate_bt.navigate(_Answers(step), sim="t-joint", **kwargs)
        assert result.status == "failure" and result.safe_state
        assert result.why.startswith("navigator '_Answers' asked for an invalid step:")
        assert "a T-joint is left by" in result.why


def test_a_step_of_a_subclass_whose_repr_raises_is_run_as_a_plain_step() -> None:
    # was: RuntimeError 'no repr' out of pirate_bt.navigate(), after connecting
    ran = pirate_bt.navigate(_Answers(_OwnRepr("straight", distance="0.3 m")), sim="straight")
    assert ran.status == "success", ran.why
    assert repr(ran.decisions[0].step) == "Step('straight', distance='0.3 m')"
    refused = pirate_bt.navigate(_Answers(_OwnRepr("bend", direction="aslant")), sim="straight")
    assert refused.status == "failure" and refused.safe_state
    assert "Step('bend', direction='aslant'): a bend turns up, down, left or right" in refused.why


def test_a_numpy_truth_value_is_a_flag_as_a_numpy_number_is_a_distance() -> None:
    # was: "slow must be true or false, not np.True_": a step whose flag came out of a
    # NumPy comparison failed the navigation, where a NumPy distance was taken
    import numpy as np

    step = pirate_bt.Step("straight", distance=np.float64(0.3), slow=np.float64(0.3) > 0.2)
    result = pirate_bt.navigate(_Answers(step), sim="straight")
    assert result.status == "success", result.why
    refused = pirate_bt.navigate(_Answers(pirate_bt.Step("straight", distance="0.3 m", slow=1)))
    assert refused.status == "failure" and "slow must be true or false, not 1" in refused.why
