"""A tee in a riser (or on a steep slope) whose branch leaves on the other side.

Turning into the branch, the rear half holds while the steered front half looks for
the turn; with the branch on the other side nothing turns, and the rear half drives
onto the opening. On the level the drive names the slip and the mission a map
disagreement (*... a branch on another side than drawn?*); in a steep pipe the
protective hold acts first, and the mission's why was the hold's alone
(*steep_pipe_unclamped: no half holds the robot ...*), the map never named. It is
named now, the hold's words kept after it.
"""

from __future__ import annotations

from typing import Any

import pytest

import pirate_bt
from pirate_bt.pipes import Network, network_from_data
from pirate_bt.robot import Half
from pirate_bt.sim import model as sim_model
from pirate_bt.task.route import parse_route


@pytest.fixture
def models(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """Every simulator model made, to read the truth at the end of a run."""
    made: list[Any] = []
    init = sim_model.PipeRobotModel.__init__

    def keep(self: Any, *args: Any, **kwargs: Any) -> None:
        init(self, *args, **kwargs)
        made.append(self)

    monkeypatch.setattr(sim_model.PipeRobotModel, "__init__", keep)
    return made


def _tee_in(side: str, *, slope: str | None) -> Network:
    branch = [{"id": "x", "type": "straight", "length": "1 m"}]
    tee = {"id": "t", "type": "tee", "branch": {"direction": side, "segments": branch}}
    first: list[dict[str, Any]] = (
        [{"id": "a", "type": "straight", "length": "1.5 m", "slope": slope}]
        if slope is not None
        else [
            {"id": "a", "type": "straight", "length": "1 m"},
            {"id": "b", "type": "bend", "direction": "up"},
            {"id": "c", "type": "straight", "length": "1 m"},
        ]
    )
    segments = [*first, tee, {"id": "d", "type": "straight", "length": "1 m"}]
    return network_from_data({"name": "tee", "diameter": "63 mm", "segments": segments})


@pytest.mark.parametrize(
    ("slope", "route"),
    [
        (None, "at the bend turn up\nat the T-joint turn right\n"),  # a riser
        ("30 deg", "at the T-joint turn right\n"),
    ],
)
def test_a_branch_on_the_other_side_in_a_steep_pipe_is_named_a_map_disagreement(
    models: list[Any], slope: str | None, route: str
) -> None:
    result = pirate_bt.simulate_mission(
        parse_route(route, "tee.route"),
        network=_tee_in("right", slope=slope),
        truth=_tee_in("left", slope=slope),
        seed=1,
    )
    assert result.status == "failure" and result.safe_state
    # was: 'steep_pipe_unclamped: no half holds the robot in a steep pipe ...' alone
    assert result.why.startswith("map disagreement at "), result.why
    assert "not as drawn at T-joint 't' (right): the PAB's search met no turn" in result.why
    assert "(a branch on another side than drawn?)" in result.why
    assert "steep_pipe_unclamped: no half holds the robot in a steep pipe" in result.why
    truth = models[-1].truth()
    assert truth.velocity_mps == 0 and not truth.sliding
    assert truth.halves[Half.FRONT].clamped and truth.halves[Half.REAR].clamped
    assert models[-1].counters().damage_count == 0
